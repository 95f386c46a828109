// Rasterizer benchmark: a ~100k-triangle textured, displaced sphere in a 640x480 pinhole view.
// OpenCV has no rasterizer, so the peers are (1) a naive single-threaded screen-space z-buffer
// rasterizer (edge functions over each triangle's bounding box) and (2) cv::fillConvexPoly filling
// the same projected triangles without any depth test (a lower bound for a z-less fill).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <numbers>
#include <opencv2/imgproc.hpp>

#include "bench_meshes.h"
#include "pg/core/parallel.h"
#include "pg/render/rasterizer.h"

namespace {

using Clock = std::chrono::steady_clock;

cv::Mat checker_texture(int size) {
  cv::Mat image(size, size, CV_8UC3);
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) {
      const bool dark = ((x / 32) + (y / 32)) % 2 == 0;
      image.at<cv::Vec3b>(y, x) = dark ? cv::Vec3b(40, 60, 90) : cv::Vec3b(220, 200, 160);
    }
  return image;
}

// Wall-clock milliseconds per frame, and process CPU milliseconds per frame (steadier on a busy machine).
struct Timing {
  double wall = 0, cpu = 0;
};

template <typename F>
Timing time_per_frame(int frames, F&& frame) {
  frame();  // warm up (allocations, caches)
  const auto start = Clock::now();
  const std::clock_t cpu_start = std::clock();
  for (int i = 0; i < frames; ++i) frame();
  return {std::chrono::duration<double, std::milli>(Clock::now() - start).count() / frames,
          1000.0 * double(std::clock() - cpu_start) / CLOCKS_PER_SEC / frames};
}

// Peer 1: naive z-buffer rasterizer in screen space (undistorted pinhole, vertices in front only).
void naive_zbuffer(const std::vector<Eigen::Vector3d>& screen, const pg::Mesh& mesh, int width, int height,
                   std::vector<float>& depth, std::vector<std::uint32_t>& ids) {
  depth.assign(std::size_t(width) * height, std::numeric_limits<float>::infinity());
  ids.assign(depth.size(), pg::kNoTriangle);
  for (std::uint32_t t = 0; t < mesh.faces.size(); ++t) {
    const auto& f = mesh.faces[t];
    const Eigen::Vector3d &a = screen[f[0]], &b = screen[f[1]], &c = screen[f[2]];  // (x, y, 1/z)
    const double area = (b.x() - a.x()) * (c.y() - a.y()) - (b.y() - a.y()) * (c.x() - a.x());
    if (area == 0) continue;
    const int x0 = std::max(0, int(std::ceil(std::min({a.x(), b.x(), c.x()}))));
    const int x1 = std::min(width - 1, int(std::floor(std::max({a.x(), b.x(), c.x()}))));
    const int y0 = std::max(0, int(std::ceil(std::min({a.y(), b.y(), c.y()}))));
    const int y1 = std::min(height - 1, int(std::floor(std::max({a.y(), b.y(), c.y()}))));
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) {
        const double w0 = ((b.x() - x) * (c.y() - y) - (b.y() - y) * (c.x() - x)) / area;
        const double w1 = ((c.x() - x) * (a.y() - y) - (c.y() - y) * (a.x() - x)) / area;
        const double w2 = 1 - w0 - w1;
        if (w0 < 0 || w1 < 0 || w2 < 0) continue;
        const float z = float(1 / (w0 * a.z() + w1 * b.z() + w2 * c.z()));
        const std::size_t i = std::size_t(y) * width + x;
        if (z < depth[i]) depth[i] = z, ids[i] = t;
      }
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc > 1) pg::set_thread_count(std::atoi(argv[1]));  // optional: thread count
  const pg::Mesh mesh = pg::bench::displaced_sphere(224, 224);
  pg::Camera camera;
  camera.id = "bench";
  camera.width = 640, camera.height = 480;
  camera.intrinsics = {520, 520, 319.5, 239.5};
  camera.cam_from_world = pg::Rigid3::look_at({0.4, -0.5, -2.6}, {0, 0, 0}, {0, 1, 0});
  const pg::Texture texture(checker_texture(1024));
  std::printf("mesh: %zu triangles, %zu vertices; view %dx%d pinhole; %d threads\n", mesh.face_count(),
              mesh.vertex_count(), camera.width, camera.height, pg::thread_count());

  const auto table_start = Clock::now();
  const pg::RayTable rays(camera);
  std::printf("ray table (once per camera): %.1f ms\n",
              std::chrono::duration<double, std::milli>(Clock::now() - table_start).count());

  pg::Renderer renderer;
  pg::RenderBuffers buffers;
  pg::RenderOptions depth_only;
  const Timing ours = time_per_frame(20, [&] { renderer.render(mesh, camera, rays, depth_only, buffers); });
  pg::RenderOptions textured;
  textured.shading = pg::Shading::texture;
  textured.texture = &texture;
  textured.lambert = true;
  const Timing ours_textured =
      time_per_frame(20, [&] { renderer.render(mesh, camera, rays, textured, buffers); });
  std::size_t covered = 0;
  for (std::uint32_t t : buffers.triangle) covered += t != pg::kNoTriangle;

  // The peers get the projection for free (it is not timed): only their rasterization is measured.
  std::vector<Eigen::Vector3d> screen;
  std::vector<cv::Point> points;
  for (const auto& p : mesh.positions) {
    const Eigen::Vector3d c = camera.cam_from_world * p.cast<double>();
    Eigen::Vector2d px;
    camera.project(c, px);
    screen.emplace_back(px.x(), px.y(), 1 / c.z());
    points.emplace_back(int(std::lround(px.x() * 16)), int(std::lround(px.y() * 16)));  // 4 fractional bits
  }
  std::vector<float> naive_depth;
  std::vector<std::uint32_t> naive_ids;
  const Timing naive = time_per_frame(
      5, [&] { naive_zbuffer(screen, mesh, camera.width, camera.height, naive_depth, naive_ids); });
  std::size_t agree = 0;
  for (std::size_t i = 0; i < naive_ids.size(); ++i) agree += naive_ids[i] == buffers.triangle[i];
  cv::Mat fill(camera.height, camera.width, CV_32S);
  const Timing zless = time_per_frame(5, [&] {
    fill.setTo(-1);
    for (std::uint32_t t = 0; t < mesh.faces.size(); ++t) {
      const auto& f = mesh.faces[t];
      const cv::Point tri[3] = {points[f[0]], points[f[1]], points[f[2]]};
      cv::fillConvexPoly(fill, tri, 3, cv::Scalar(double(t)), cv::LINE_8, 4);
    }
  });

  std::printf("                                     wall ms/frame  cpu ms/frame\n");
  std::printf("pg::Renderer ids+barycentrics+depth  %10.2f  %12.2f   (%zu pixels covered)\n", ours.wall,
              ours.cpu, covered);
  std::printf("  + trilinear texture + Lambert      %10.2f  %12.2f\n", ours_textured.wall, ours_textured.cpu);
  std::printf(
      "naive z-buffer (1 thread)            %10.2f  %12.2f   wall ratio naive/pg = %.2f"
      " (same triangle at %.2f%% of pixels)\n",
      naive.wall, naive.cpu, naive.wall / ours.wall, 100.0 * double(agree) / double(naive_ids.size()));
  std::printf("cv::fillConvexPoly, no depth test    %10.2f  %12.2f   wall ratio fill/pg = %.2f\n", zless.wall,
              zless.cpu, zless.wall / ours.wall);
  return 0;
}

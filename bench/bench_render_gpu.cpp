// Rasterizer on the CPU against the OpenCL kernel (PoCL on a machine without a GPU, the GPU's driver
// where there is one): a ~100k-triangle displaced sphere filling a 1536x1024 pinhole view, depth,
// face ids and barycentrics only (as pg-refine renders). Prints each path's time per frame, the
// ratio, and how many pixels are bit-identical. The OpenCL time includes the host's triangle setup
// and binning (the CPU code, on all threads), the upload of the faces and the read-back; the ray
// table stays on the device between frames, as it does for one view in refinement.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <numbers>

#include "bench_meshes.h"
#include "pg/core/parallel.h"
#include "pg/gpu/device.h"
#include "pg/gpu/rasterizer_opencl.h"

namespace {

using Clock = std::chrono::steady_clock;

// The best of `repeats` frames, in seconds, after one warm-up frame (kernel compilation, first upload).
double best_time(int repeats, const std::function<void()>& frame) {
  frame();
  double best = 1e30;
  for (int i = 0; i < repeats; ++i) {
    const auto start = Clock::now();
    frame();
    best = std::min(best, std::chrono::duration<double>(Clock::now() - start).count());
  }
  return best;
}

}  // namespace

int main() {
  const pg::Mesh mesh = pg::bench::displaced_sphere(224, 224);
  pg::Camera camera;
  camera.id = "bench";
  camera.width = 1536, camera.height = 1024;
  camera.intrinsics = {1250, 1250, 767.5, 511.5};
  camera.cam_from_world = pg::Rigid3::look_at({0.4, -0.5, -2.6}, {0, 0, 0}, {0, 1, 0});
  const pg::RayTable rays(camera);
  std::printf("rasterizer: %zu triangles, %dx%d pinhole, %d CPU threads\n", mesh.faces.size(), camera.width,
              camera.height, pg::thread_count());

  pg::Renderer cpu_renderer;
  pg::RenderBuffers cpu, gpu;
  const double cpu_seconds = best_time(5, [&] { cpu_renderer.render(mesh, camera, rays, {}, cpu); });
  std::printf("cpu     %8.2f ms per frame\n", 1e3 * cpu_seconds);

  const std::string unavailable = pg::gpu::opencl_unavailable_reason();
  if (!unavailable.empty()) {
    std::printf("opencl  skipped: %s\n", unavailable.c_str());
    return 0;
  }
  pg::gpu::set_requested_device(pg::gpu::DeviceKind::opencl);
  std::printf("device  %s\n", pg::gpu::describe_active_device().c_str());
  pg::gpu::OpenClRenderer gpu_renderer(rays);
  const double gpu_seconds = best_time(5, [&] { gpu_renderer.render(mesh, camera, {}, gpu); });
  std::size_t identical = 0, hits = 0;
  for (std::size_t i = 0; i < cpu.triangle.size(); ++i) {
    const float a = cpu.depth.ptr<float>()[i], b = gpu.depth.ptr<float>()[i];
    hits += cpu.triangle[i] != pg::kNoTriangle;
    const bool same_depth = std::memcmp(&a, &b, sizeof a) == 0 || (std::isnan(a) && std::isnan(b));
    identical +=
        cpu.triangle[i] == gpu.triangle[i] && cpu.b1[i] == gpu.b1[i] && cpu.b2[i] == gpu.b2[i] && same_depth;
  }
  std::printf("opencl  %8.2f ms per frame   cpu/opencl %5.2fx   bit-identical pixels %zu of %zu (%zu hits)\n",
              1e3 * gpu_seconds, cpu_seconds / gpu_seconds, identical, cpu.triangle.size(), hits);
  return 0;
}

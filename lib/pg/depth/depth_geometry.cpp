#include "pg/depth/depth_geometry.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cmath>
#include <limits>

namespace pg {

Eigen::Vector3d point_from_depth(const Camera& camera, DepthKind kind, const Eigen::Vector2d& pixel,
                                 double depth) {
  const Eigen::Vector3d ray = camera.unproject(pixel);
  return kind == DepthKind::perspective_z ? Eigen::Vector3d(ray * (depth / ray.z()))
                                          : Eigen::Vector3d(ray * depth);
}

double depth_of_point(DepthKind kind, const Eigen::Vector3d& point_cam) {
  return kind == DepthKind::perspective_z ? point_cam.z() : point_cam.norm();
}

cv::Mat3f normals_from_depth(const cv::Mat1f& depth, const Camera& camera, DepthKind kind) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  cv::Mat3f normals(depth.size(), cv::Vec3f(nan, nan, nan));
  const auto point = [&](int x, int y, Eigen::Vector3d& p) {
    if (x < 0 || y < 0 || x >= depth.cols || y >= depth.rows || !std::isfinite(depth(y, x))) return false;
    p = point_from_depth(camera, kind, Eigen::Vector2d(x, y), depth(y, x));
    return true;
  };
  // The difference along one axis: central where both neighbours exist, else one-sided.
  const auto difference = [&](int x, int y, int dx, int dy, const Eigen::Vector3d& centre,
                              Eigen::Vector3d& d) {
    Eigen::Vector3d before, after;
    const bool has_before = point(x - dx, y - dy, before), has_after = point(x + dx, y + dy, after);
    if (has_before && has_after)
      d = after - before;
    else if (has_after)
      d = after - centre;
    else if (has_before)
      d = centre - before;
    else
      return false;
    return true;
  };
  tbb::parallel_for(tbb::blocked_range<int>(0, depth.rows), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y != rows.end(); ++y)
      for (int x = 0; x < depth.cols; ++x) {
        Eigen::Vector3d centre, along_x, along_y;
        if (!point(x, y, centre) || !difference(x, y, 1, 0, centre, along_x) ||
            !difference(x, y, 0, 1, centre, along_y))
          continue;
        Eigen::Vector3d n = along_x.cross(along_y);
        if (n.norm() == 0) continue;
        n.normalize();
        if (n.dot(centre) > 0) n = -n;  // face the camera
        normals(y, x) =
            cv::Vec3f(static_cast<float>(n.x()), static_cast<float>(n.y()), static_cast<float>(n.z()));
      }
  });
  return normals;
}

namespace {

bool valid_pixel(const DepthMap& map, int x, int y) {
  return std::isfinite(map.depth.at<float>(y, x)) &&
         (map.mask.empty() || map.mask.at<std::uint8_t>(y, x) == 0);
}

Eigen::Vector3f world_point(const DepthMap& map, const Rigid3& world_from_cam, int x, int y) {
  return (world_from_cam *
          point_from_depth(map.camera, map.kind, Eigen::Vector2d(x, y), map.depth.at<float>(y, x)))
      .cast<float>();
}

std::array<std::uint8_t, 3> pixel_colour(const cv::Mat& image, int x, int y) {
  if (image.channels() == 1) {
    const std::uint8_t g = image.at<std::uint8_t>(y, x);
    return {g, g, g};
  }
  const cv::Vec3b bgr = image.at<cv::Vec3b>(y, x);
  return {bgr[2], bgr[1], bgr[0]};
}

bool has_colours(const DepthMap& map, const cv::Mat& image) {
  return !image.empty() && image.depth() == CV_8U && (image.channels() == 1 || image.channels() == 3) &&
         image.size() == map.depth.size();
}

}  // namespace

PointCloud depth_point_cloud(const DepthMap& map, const cv::Mat& image) {
  PointCloud cloud;
  const Rigid3 world_from_cam = map.camera.cam_from_world.inverse();
  const Eigen::Matrix3f rotation = world_from_cam.rotation_matrix().cast<float>();
  const bool colours = has_colours(map, image);
  for (int y = 0; y < map.depth.rows; ++y)
    for (int x = 0; x < map.depth.cols; ++x) {
      if (!valid_pixel(map, x, y)) continue;
      cloud.positions.push_back(world_point(map, world_from_cam, x, y));
      if (!map.normals.empty()) {
        const cv::Vec3f n = map.normals.at<cv::Vec3f>(y, x);
        cloud.normals.push_back(rotation * Eigen::Vector3f(n[0], n[1], n[2]));
      }
      if (colours) cloud.colors.push_back(pixel_colour(image, x, y));
      if (!map.confidence.empty()) cloud.confidence.push_back(map.confidence.at<float>(y, x));
    }
  return cloud;
}

Mesh depth_grid_mesh(const DepthMap& map, const cv::Mat& image) {
  Mesh mesh;
  const Rigid3 world_from_cam = map.camera.cam_from_world.inverse();
  const bool colours = has_colours(map, image);
  const std::uint32_t none = std::numeric_limits<std::uint32_t>::max();
  cv::Mat1i index(map.depth.size(), static_cast<int>(-1));
  std::vector<std::uint32_t> vertex_of(static_cast<std::size_t>(map.depth.total()), none);
  for (int y = 0; y < map.depth.rows; ++y)
    for (int x = 0; x < map.depth.cols; ++x) {
      if (!valid_pixel(map, x, y)) continue;
      vertex_of[static_cast<std::size_t>(y) * map.depth.cols + x] =
          static_cast<std::uint32_t>(mesh.positions.size());
      mesh.positions.push_back(world_point(map, world_from_cam, x, y));
      if (colours) mesh.colors.push_back(pixel_colour(image, x, y));
    }
  const auto vertex = [&](int x, int y) {
    return vertex_of[static_cast<std::size_t>(y) * map.depth.cols + x];
  };
  // Image x right, y down, camera looking along +z: (a, c, b) below is counter-clockwise seen from the
  // camera, so the triangles face it.
  const auto add = [&](std::uint32_t a, std::uint32_t b, std::uint32_t c) {
    if (a != none && b != none && c != none) mesh.faces.push_back({a, c, b});
  };
  for (int y = 0; y + 1 < map.depth.rows; ++y)
    for (int x = 0; x + 1 < map.depth.cols; ++x) {
      add(vertex(x, y), vertex(x + 1, y), vertex(x, y + 1));
      add(vertex(x + 1, y), vertex(x + 1, y + 1), vertex(x, y + 1));
    }
  mesh.compute_vertex_normals();
  return mesh;
}

}  // namespace pg

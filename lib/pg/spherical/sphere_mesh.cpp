#include "pg/spherical/sphere_mesh.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "pg/core/error.h"

namespace pg {

namespace {

std::array<std::uint8_t, 3> vertex_color(const cv::Mat& colors, int x, int y) {
  const auto to_byte = [](double value) {
    return static_cast<std::uint8_t>(std::lround(std::clamp(value, 0.0, 1.0) * 255));
  };
  if (colors.channels() == 1) {
    const cv::Mat grey = colors;
    const double value = grey.depth() == CV_8U
                             ? grey.at<std::uint8_t>(y, x) / 255.0
                             : std::pow(std::clamp<double>(grey.at<float>(y, x), 0, 1), 1 / 2.2);
    return {to_byte(value), to_byte(value), to_byte(value)};
  }
  std::array<double, 3> bgr{};
  for (int c = 0; c < 3; ++c) {
    if (colors.depth() == CV_8U)
      bgr[c] = colors.ptr<std::uint8_t>(y)[x * colors.channels() + c] / 255.0;
    else
      bgr[c] = std::pow(std::clamp<double>(colors.ptr<float>(y)[x * colors.channels() + c], 0, 1), 1 / 2.2);
  }
  return {to_byte(bgr[2]), to_byte(bgr[1]), to_byte(bgr[0])};
}

}  // namespace

Mesh sphere_grid_mesh(const DepthMap& map, const SphereMeshOptions& options, const cv::Mat& colors) {
  if (map.kind != DepthKind::spherical_range || map.camera.model != CameraModel::equirectangular)
    throw UsageError("sphere_grid_mesh: needs a spherical range map of an equirectangular camera");
  const int width = map.depth.cols, height = map.depth.rows;
  if (!colors.empty() &&
      (colors.size() != map.depth.size() || (colors.depth() != CV_8U && colors.depth() != CV_32F)))
    throw UsageError("sphere_grid_mesh: colours must be 8-bit or float at the depth map's size");
  const cv::Mat1f depth = map.depth;
  const cv::Mat1f confidence = map.confidence;
  const Rigid3 world_from_cam = map.camera.cam_from_world.inverse();
  const std::uint32_t none = std::numeric_limits<std::uint32_t>::max();

  Mesh mesh;
  // Column `width` repeats column 0 with u one turn further, so the seam closes with its own UVs.
  std::vector<std::uint32_t> index(static_cast<std::size_t>(width + 1) * height, none);
  for (int y = 0; y < height; ++y) {
    for (int column = 0; column <= width; ++column) {
      const int x = column % width;
      const float range = depth(y, x);
      if (!std::isfinite(range) || range <= 0) continue;
      Eigen::Vector3d point = range * equirect_direction_from_pixel(width, height, Eigen::Vector2d(x, y));
      if (options.world_frame) point = world_from_cam * point;
      index[static_cast<std::size_t>(y) * (width + 1) + column] =
          static_cast<std::uint32_t>(mesh.positions.size());
      mesh.positions.push_back(point.cast<float>());
      // Texture origin bottom-left (formats/meshes.md); pixel centres at (x + 0.5) / width.
      mesh.uvs.emplace_back((column + 0.5f) / width, 1.0f - (y + 0.5f) / height);
      if (!colors.empty()) mesh.colors.push_back(vertex_color(colors, x, y));
      if (!confidence.empty()) mesh.vertex_properties["confidence"].push_back(confidence(y, x));
    }
  }
  const auto vertex = [&](int column, int y) {
    return index[static_cast<std::size_t>(y) * (width + 1) + column];
  };
  const auto range_at = [&](int column, int y) { return depth(y, column % width); };
  const auto add_triangle = [&](std::array<std::pair<int, int>, 3> corners) {
    std::array<std::uint32_t, 3> face{};
    float lo = std::numeric_limits<float>::infinity(), hi = 0;
    for (int i = 0; i < 3; ++i) {
      face[i] = vertex(corners[i].first, corners[i].second);
      if (face[i] == none) return;
      lo = std::min(lo, range_at(corners[i].first, corners[i].second));
      hi = std::max(hi, range_at(corners[i].first, corners[i].second));
    }
    if (hi > lo * (1 + options.max_range_jump)) return;
    mesh.faces.push_back(face);
  };
  // Seen from the centre the grid runs right (x) and down (y), so (x, y), (x, y+1), (x+1, y) is
  // counter-clockwise from the camera's side: the surface faces the panorama's centre.
  for (int y = 0; y + 1 < height; ++y) {
    for (int x = 0; x < width; ++x) {
      add_triangle({{{x, y}, {x, y + 1}, {x + 1, y}}});
      add_triangle({{{x + 1, y}, {x, y + 1}, {x + 1, y + 1}}});
    }
  }
  return mesh;
}

}  // namespace pg

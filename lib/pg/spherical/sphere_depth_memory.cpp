#include "pg/spherical/sphere_depth_memory.h"

#include <algorithm>
#include <cmath>

#include "pg/flow/flow_memory.h"

namespace pg {
namespace {

std::uint64_t area(cv::Size size) {
  return static_cast<std::uint64_t>(size.width) * static_cast<std::uint64_t>(size.height);
}

// Position, UV, colour (3 floats) and confidence per vertex; two triangles of three indices per pixel.
constexpr std::uint64_t mesh_bytes_per_pixel = 3 * 4 + 2 * 4 + 3 * 4 + 4 + 2 * 3 * 4;
constexpr std::uint64_t output_planes = 6;
constexpr std::uint64_t line_field_planes = 4;

}  // namespace

std::uint64_t sphere_depth_memory_bytes(cv::Size input, std::uint64_t image_bytes_per_pixel, int channels,
                                        const SphereDepthOptions& options) {
  const std::uint64_t float_pixel =
      4 * static_cast<std::uint64_t>(std::clamp(channels, 1, max_flow_channels));
  // As compute_sphere_depth sizes its work.
  const cv::Size working(std::max(4, static_cast<int>(std::lround(input.width * options.scale))),
                         std::max(2, static_cast<int>(std::lround(input.height * options.scale))));
  const int padding = static_cast<int>(std::lround(options.seam_padding * working.width));
  const cv::Size padded(working.width + 2 * padding, working.height);

  std::uint64_t held = 2 * area(input) * image_bytes_per_pixel;
  held += 2 * area(input) * float_pixel;  // the matching copies before resizing
  if (working != input) held += 2 * area(working) * float_pixel;
  held += 2 * area(padded) * float_pixel;  // rectified, then padded
  const std::uint64_t flow = bidirectional_flow_memory_bytes(padded, channels, options.flow, true) +
                             2 * line_field_planes * 4 * area(padded);
  const std::uint64_t outputs = area(working) * (output_planes * 4 + mesh_bytes_per_pixel + float_pixel);
  return held + std::max(flow, outputs);
}

}  // namespace pg

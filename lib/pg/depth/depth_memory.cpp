#include "pg/depth/depth_memory.h"

#include "pg/depth/depth_geometry.h"
#include "pg/flow/flow_memory.h"

namespace pg {
namespace {

std::uint64_t pixels(const Camera& camera) {
  return static_cast<std::uint64_t>(camera.width) * static_cast<std::uint64_t>(camera.height);
}

}  // namespace

std::uint64_t depth_pair_memory_bytes(const Camera& reference, const Camera& other,
                                      std::uint64_t image_bytes_per_pixel, int channels,
                                      const DepthPairOptions& options) {
  const std::uint64_t per_pixel = image_bytes_per_pixel + 1;  // the image and its optional mask
  std::uint64_t bytes = (pixels(reference) + pixels(other)) * per_pixel;
  Camera working = reference;
  if (options.scale != 1) {
    working = resized_camera(reference, options.scale);
    bytes += (pixels(working) + pixels(resized_camera(other, options.scale))) * per_pixel;
  }
  return bytes + bidirectional_flow_memory_bytes(cv::Size(working.width, working.height), channels,
                                                 options.flow, options.epipolar);
}

}  // namespace pg

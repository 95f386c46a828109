#include "pg/flow/flow_memory.h"

#include <algorithm>
#include <vector>

#include "pg/image/pyramid.h"

namespace pg {
namespace {

constexpr std::uint64_t float_bytes = sizeof(float);
// The line search's census codes of both images (8 bytes each) and its per-pixel label range (4).
constexpr std::uint64_t line_search_bytes_per_pixel = 2 * 8 + 4;

std::uint64_t pixels(cv::Size size) {
  return static_cast<std::uint64_t>(size.width) * static_cast<std::uint64_t>(size.height);
}

std::vector<cv::Size> level_sizes(cv::Size size, const FlowOptions& options) {
  return pyramid_sizes(size, {options.pyramid_factor, options.min_side, options.max_levels});
}

}  // namespace

std::uint64_t flow_pyramid_pixels(cv::Size size, const FlowOptions& options) {
  std::uint64_t sum = 0;
  for (const cv::Size level : level_sizes(size, options)) sum += pixels(level);
  return sum;
}

std::uint64_t flow_memory_bytes(cv::Size size, int channels, const FlowOptions& options, bool epipolar) {
  const std::uint64_t c = static_cast<std::uint64_t>(std::clamp(channels, 1, max_flow_channels));
  const std::vector<cv::Size> sizes = level_sizes(size, options);
  // The solver's buffers are largest at the finest level it solves; the pyramids and the state
  // around the solver are at full size throughout.
  const int finest = std::min(options.finest_level, static_cast<int>(sizes.size()) - 1);
  const std::uint64_t solved = pixels(sizes[static_cast<std::size_t>(finest)]);
  const std::uint64_t pyramid_planes = 2 * c * flow_pyramid_pixels(size, options);
  const std::uint64_t level_planes =
      (flow_solver_planes + 2 * c * flow_derivative_planes_per_channel + flow_smoothness_planes) * solved;
  std::uint64_t state_planes =
      (epipolar ? epipolar_flow_state_planes : free_flow_state_planes) * pixels(size);
  if (epipolar && finest > 0) state_planes += epipolar_level_field_planes * solved;
  std::uint64_t bytes = float_bytes * (pyramid_planes + level_planes + state_planes);
  if (epipolar && options.search_range > 0)
    bytes += static_cast<std::uint64_t>(line_search_bytes_per_entry * options.search_budget) +
             line_search_bytes_per_pixel * pixels(size);
  return bytes;
}

std::uint64_t bidirectional_flow_memory_bytes(cv::Size size, int channels, const FlowOptions& options,
                                              bool epipolar) {
  return flow_memory_bytes(size, channels, options, epipolar) +
         float_bytes * held_forward_flow_planes * pixels(size);
}

}  // namespace pg

#pragma once
// Peak memory of the variational flow (flow.h), estimated from the image size alone so that a tool
// can refuse a job that exceeds its --max-memory budget (pg::cli::require_memory) before decoding or
// allocating anything. The counts below are the cv::Mat1f planes (one float per pixel) the code in
// flow.cpp and level_solver.cpp holds at once; keep them in step with it.
#include <cstdint>
#include <opencv2/core.hpp>

#include "pg/flow/flow.h"

namespace pg {

// LevelSolver's buffers, allocated once at the finest level solved and reused by every level: 15
// planes (the 12 motion-tensor entries b11..b33 and g11..g33, psi, du, dv) and 11 SplitFields of
// about one plane each (split_du, split_dv, a11_inv, a22_inv, a12, rhs1, rhs2 and the four weights
// l, r, u, d).
inline constexpr int flow_solver_planes = 15 + 11;
// prepare_level: per channel and image the derivatives x, y, xx, xy, yy (the image itself is the
// pyramid's level, not a copy).
inline constexpr int flow_derivative_planes_per_channel = 5;
// prepare_level: the smoothness weight alpha * g(x).
inline constexpr int flow_smoothness_planes = 1;
// The state around the solver. Epipolar: the line field (base and direction, 2 channels each), s and
// its rescaled copy, solve_along's warped u and v, the median filter's output: 4 + 2 + 2 + 1.
// Free: u, v, their rescaled copies and the median filter's output: 2 + 2 + 1.
inline constexpr int epipolar_flow_state_planes = 9;
inline constexpr int free_flow_state_planes = 5;
// Epipolar mode stopping above level 0 (finest_level > 0): the line field resized to that level.
inline constexpr int epipolar_level_field_planes = 4;
// Bidirectional flow: the forward result (2 channels) is held while the backward flow runs.
inline constexpr int held_forward_flow_planes = 2;
// Colour is used jointly but alpha is dropped: at most 3 channels enter the pyramids.
inline constexpr int max_flow_channels = 3;
// The discrete line search (search_range > 0): a uint8 matching cost and a uint16 aggregated cost
// per entry, at most search_budget entries.
inline constexpr int line_search_bytes_per_entry = 3;

// Sum of the pixel counts of the pyramid levels compute_flow builds for `size` (level 0 included):
// about size.area() / (1 - pyramid_factor^2), 5.3x the finest for the default factor 0.9.
std::uint64_t flow_pyramid_pixels(cv::Size size, const FlowOptions& options);

// Peak bytes of one compute_flow (epipolar = false) or compute_epipolar_flow on two images of
// `size` with `channels` channels (3 when unknown; only min(channels, 3) count). Excludes the
// caller's input images.
std::uint64_t flow_memory_bytes(cv::Size size, int channels, const FlowOptions& options, bool epipolar);

// The same for compute_flow_bidirectional / compute_epipolar_flow_bidirectional: the two flows run
// one after the other, the forward result held during the second.
std::uint64_t bidirectional_flow_memory_bytes(cv::Size size, int channels, const FlowOptions& options,
                                              bool epipolar);

}  // namespace pg

#pragma once
// Flow visualisation (formats/flow-visualisation.md): the Middlebury colour wheel (Baker et al. 2011).
// Hue is the direction, saturation the magnitude (white: no motion)
// relative to `max_magnitude`; unknown (NaN) flow is black.
#include <opencv2/core.hpp>

namespace pg {

// 8-bit BGR image. max_magnitude <= 0: the largest finite magnitude in the flow (1 if all zero).
cv::Mat3b flow_to_color(const cv::Mat2f& flow, double max_magnitude = 0);

}  // namespace pg

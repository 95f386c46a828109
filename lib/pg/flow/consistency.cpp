#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cmath>
#include <limits>

#include "pg/core/error.h"
#include "pg/flow/flow.h"

namespace pg {

cv::Mat1f forward_backward_error(const cv::Mat2f& forward, const cv::Mat2f& backward) {
  if (forward.empty() || forward.size() != backward.size())
    throw UsageError("forward_backward_error: flows are empty or of different sizes");
  const int rows = forward.rows, cols = forward.cols;
  const float max_x = static_cast<float>(cols - 1), max_y = static_cast<float>(rows - 1);
  cv::Mat1f error(forward.size(), std::numeric_limits<float>::quiet_NaN());
  tbb::parallel_for(tbb::blocked_range<int>(0, rows), [&](const tbb::blocked_range<int>& range) {
    for (int y = range.begin(); y != range.end(); ++y) {
      for (int x = 0; x < cols; ++x) {
        const cv::Vec2f f = forward(y, x);
        const float px = static_cast<float>(x) + f[0], py = static_cast<float>(y) + f[1];
        if (!(px >= 0 && px <= max_x && py >= 0 && py <= max_y)) continue;  // also NaN
        const int x0 = std::min(static_cast<int>(px), std::max(cols - 2, 0));
        const int y0 = std::min(static_cast<int>(py), std::max(rows - 2, 0));
        const int x1 = std::min(x0 + 1, cols - 1), y1 = std::min(y0 + 1, rows - 1);
        const float ax = px - static_cast<float>(x0), ay = py - static_cast<float>(y0);
        const cv::Vec2f b = (1 - ay) * ((1 - ax) * backward(y0, x0) + ax * backward(y0, x1)) +
                            ay * ((1 - ax) * backward(y1, x0) + ax * backward(y1, x1));
        error(y, x) = std::hypot(f[0] + b[0], f[1] + b[1]);  // NaN when b is NaN
      }
    }
  });
  return error;
}

cv::Mat1b occlusion_mask(const cv::Mat1f& fb_error, const cv::Mat2f& forward, double max_error,
                         double relative) {
  if (fb_error.size() != forward.size()) throw UsageError("occlusion_mask: sizes differ");
  cv::Mat1b mask(fb_error.size());
  for (int y = 0; y < mask.rows; ++y)
    for (int x = 0; x < mask.cols; ++x) {
      const cv::Vec2f f = forward(y, x);
      const double limit = max_error + relative * std::hypot(f[0], f[1]);
      mask(y, x) = fb_error(y, x) <= limit ? 0 : 255;  // NaN counts as occluded
    }
  return mask;
}

}  // namespace pg

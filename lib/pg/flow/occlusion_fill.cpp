#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "pg/core/error.h"
#include "pg/flow/flow.h"

namespace pg {
namespace {

bool finite(const cv::Vec2f& v) {
  return std::isfinite(v[0]) && std::isfinite(v[1]);
}

// s of each pixel (NaN where the flow or the line is unknown).
cv::Mat1f along_lines(const cv::Mat2f& flow, const EpipolarField& field) {
  cv::Mat1f s(flow.size());
  for (int y = 0; y < flow.rows; ++y)
    for (int x = 0; x < flow.cols; ++x) {
      const cv::Vec2f f = flow(y, x), base = field.base(y, x), direction = field.direction(y, x);
      s(y, x) = finite(f) && finite(base) && finite(direction) ? (f - base).dot(direction) : NAN;
    }
  return s;
}

}  // namespace

cv::Mat2f fill_occlusions_along_lines(const cv::Mat2f& flow, const cv::Mat1b& occluded,
                                      const EpipolarField& field, int max_distance) {
  if (flow.empty() || occluded.size() != flow.size() || field.base.size() != flow.size() ||
      field.direction.size() != flow.size())
    throw UsageError("fill_occlusions_along_lines: flow, mask and epipolar field differ in size");
  if (max_distance < 0) throw UsageError("fill_occlusions_along_lines: max_distance must not be negative");
  const int rows = flow.rows, cols = flow.cols;
  const int reach = max_distance > 0 ? max_distance : std::max(64, std::max(rows, cols) / 4);
  const cv::Mat1f s = along_lines(flow, field);
  const auto usable = [&](int y, int x) { return occluded(y, x) == 0 && std::isfinite(s(y, x)); };
  cv::Mat2f filled = flow.clone();
  tbb::parallel_for(tbb::blocked_range<int>(0, rows), [&](const tbb::blocked_range<int>& range) {
    for (int y = range.begin(); y != range.end(); ++y)
      for (int x = 0; x < cols; ++x) {
        const cv::Vec2f direction = field.direction(y, x), base = field.base(y, x);
        if (occluded(y, x) == 0 || !finite(direction) || !finite(base)) continue;
        float background = INFINITY;
        for (const float sign : {-1.f, 1.f}) {
          for (int step = 1; step <= reach; ++step) {
            const int px = static_cast<int>(std::lround(x + sign * step * direction[0]));
            const int py = static_cast<int>(std::lround(y + sign * step * direction[1]));
            if (px < 0 || px >= cols || py < 0 || py >= rows) break;
            if (!usable(py, px)) continue;
            background = std::min(background, s(py, px));
            break;
          }
        }
        if (std::isfinite(background)) filled(y, x) = base + background * direction;
      }
  });
  return filled;
}

}  // namespace pg

#include "pg/eval/depth_eval.h"

#include <algorithm>
#include <cmath>

#include "pg/core/error.h"
#include "pg/core/log.h"

namespace pg {
namespace {

// DepthMap masks: 255 = excluded by the user, 0 = kept.
bool unmasked(const cv::Mat& mask, int row, int col) {
  return mask.empty() || mask.at<std::uint8_t>(row, col) == 0;
}

bool usable(float depth) {
  return std::isfinite(depth) && depth > 0;
}

}  // namespace

DepthEvalResult evaluate_depth(const DepthMap& estimate, const DepthMap& truth,
                               const DepthEvalOptions& options) {
  const cv::Mat& e = estimate.depth;
  const cv::Mat& t = truth.depth;
  if (e.size() != t.size())
    throw InputError("estimate",
                     str("depth map is ", e.cols, "x", e.rows, " but the truth is ", t.cols, "x", t.rows));
  if (estimate.kind != truth.kind)
    throw InputError("estimate", str("depth kind ", to_string(estimate.kind), " differs from the truth's ",
                                     to_string(truth.kind)));
  if (e.type() != CV_32F || t.type() != CV_32F)
    throw InputError("estimate", "depth maps must be 32-bit float");
  for (const cv::Mat* mask : {&estimate.mask, &truth.mask})
    if (!mask->empty() && (mask->size() != t.size() || mask->type() != CV_8U))
      throw InputError("estimate", "mask must be 8-bit with the depth map's size");

  DepthEvalResult r;
  r.width = t.cols;
  r.height = t.rows;
  r.thresholds = options.thresholds;
  std::vector<std::pair<float, float>> pairs;  // (estimate, truth)
  for (int row = 0; row < t.rows; ++row) {
    for (int col = 0; col < t.cols; ++col) {
      float dt = t.at<float>(row, col);
      if (!usable(dt) || !unmasked(truth.mask, row, col) || dt < options.min_depth || dt > options.max_depth)
        continue;
      ++r.truth_pixels;
      float de = e.at<float>(row, col);
      if (usable(de) && unmasked(estimate.mask, row, col)) pairs.emplace_back(de, dt);
    }
  }
  r.compared_pixels = pairs.size();
  if (pairs.empty()) throw FailedError("no pixel has a valid depth in both the estimate and the truth");
  r.coverage = double(r.compared_pixels) / double(r.truth_pixels);

  if (options.align_median_scale) {
    std::vector<double> ratios;
    ratios.reserve(pairs.size());
    for (auto [de, dt] : pairs) ratios.push_back(double(dt) / de);
    std::sort(ratios.begin(), ratios.end());
    r.scale = sorted_quantile(ratios, 0.5);
  }

  std::vector<double> relative;
  relative.reserve(pairs.size());
  double sum_squares = 0, sum_absolute = 0;
  for (auto [de, dt] : pairs) {
    double difference = r.scale * de - dt;
    relative.push_back(std::abs(difference) / dt);
    sum_squares += difference * difference;
    sum_absolute += std::abs(difference);
  }
  r.rmse = std::sqrt(sum_squares / double(pairs.size()));
  r.mean_absolute_error = sum_absolute / double(pairs.size());
  r.relative_error = summarize(relative);  // sorts `relative`
  for (double threshold : options.thresholds) {
    auto below = std::lower_bound(relative.begin(), relative.end(), threshold) - relative.begin();
    r.fraction_below.push_back(double(below) / double(relative.size()));
  }
  return r;
}

nlohmann::json DepthEvalResult::to_json() const {
  nlohmann::json below = nlohmann::json::array();
  for (std::size_t i = 0; i < thresholds.size(); ++i)
    below.push_back({{"threshold", thresholds[i]}, {"fraction", fraction_below[i]}});
  return {{"width", width},
          {"height", height},
          {"truth_pixels", truth_pixels},
          {"compared_pixels", compared_pixels},
          {"coverage", coverage},
          {"scale", scale},
          {"relative_error", relative_error.to_json()},
          {"rmse", rmse},
          {"mean_absolute_error", mean_absolute_error},
          {"fraction_below", std::move(below)}};
}

std::string DepthEvalResult::to_text() const {
  std::string text =
      str(compared_pixels, " of ", truth_pixels, " truth pixels compared (coverage ", coverage, ")");
  if (scale != 1) text += str(", estimate scaled by ", scale);
  text += str(". Relative error mean ", relative_error.mean, ", median ", relative_error.median, ", p90 ",
              relative_error.p90, ", p95 ", relative_error.p95, ", max ", relative_error.max, "; RMSE ", rmse,
              ", mean absolute error ", mean_absolute_error, " (depth units).");
  for (std::size_t i = 0; i < thresholds.size(); ++i)
    text += str(i == 0 ? " Below " : ", ", thresholds[i] * 100, "%: ", fraction_below[i] * 100, "%");
  if (!thresholds.empty()) text += ".";
  return text;
}

}  // namespace pg

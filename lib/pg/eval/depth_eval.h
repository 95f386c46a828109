#pragma once
// A depth map against a ground-truth depth map of the same camera: relative error statistics, the
// fraction of pixels within relative-error thresholds, and coverage.
#include <limits>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "pg/eval/stats.h"
#include "pg/image/depth_exr.h"

namespace pg {

struct DepthEvalOptions {
  // Multiply the estimate by median(truth / estimate) first: for up-to-scale inputs.
  bool align_median_scale = false;
  // Only truth depths in [min_depth, max_depth] take part (coverage included).
  double min_depth = 0;
  double max_depth = std::numeric_limits<double>::infinity();
  // Relative-error thresholds for the "fraction below" figures.
  std::vector<double> thresholds = {0.01, 0.02, 0.05, 0.10};
};

struct DepthEvalResult {
  int width = 0, height = 0;
  std::size_t truth_pixels = 0;     // truth valid, not masked (mask 255), in range
  std::size_t compared_pixels = 0;  // of those, where the estimate is valid and unmasked too
  double coverage = 0;              // compared_pixels / truth_pixels
  double scale = 1;                 // applied to the estimate (1 without median alignment)
  ErrorStats relative_error;        // |d - d*| / d*
  double rmse = 0;                  // sqrt(mean((d - d*)^2)), depth units
  double mean_absolute_error = 0;   // mean |d - d*|, depth units
  std::vector<double> thresholds;
  std::vector<double> fraction_below;  // fraction of compared pixels with relative error < threshold

  nlohmann::json to_json() const;
  std::string to_text() const;
};

// Throws InputError (file "estimate") when the sizes or depth kinds differ, FailedError when no pixel
// is valid in both.
DepthEvalResult evaluate_depth(const DepthMap& estimate, const DepthMap& truth,
                               const DepthEvalOptions& options = {});

}  // namespace pg

#pragma once
// Optical flow against ground truth (Middlebury / MPI-Sintel measures): end-point error over all,
// non-occluded and occluded pixels, bad-pixel rates and the Middlebury angular error.
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <string>

#include "pg/eval/stats.h"

namespace pg {

struct FlowEvalResult {
  int width = 0, height = 0;
  std::size_t truth_pixels = 0;                              // truth known and not marked invalid
  std::size_t compared_pixels = 0;                           // of those, where the estimate is known too
  std::size_t occluded_pixels = 0, non_occluded_pixels = 0;  // split of compared_pixels
  double coverage = 0;                                       // compared_pixels / truth_pixels
  double epe_all = 0;                                        // mean end-point error |f - f*| in pixels
  double epe_non_occluded = 0;  // NaN (JSON null) without occlusion mask or such pixels
  double epe_occluded = 0;
  ErrorStats epe;                          // distribution over compared pixels
  double bad_1 = 0, bad_3 = 0, bad_5 = 0;  // fraction of compared pixels with EPE > 1, 3, 5 px
  double angular_error_deg = 0;            // mean angle between (u, v, 1) and (u*, v*, 1)

  nlohmann::json to_json() const;
  std::string to_text() const;
};

// `occlusion` and `invalid` are optional masks of the truth's size, nonzero = occluded / invalid
// (MPI-Sintel's convention). Pixels whose truth or estimate is NaN or above 1e9 are not compared;
// missing estimates lower the coverage. Throws InputError (file "flow") when sizes differ and
// FailedError when no pixel can be compared.
FlowEvalResult evaluate_flow(const cv::Mat2f& flow, const cv::Mat2f& truth,
                             const cv::Mat1b* occlusion = nullptr, const cv::Mat1b* invalid = nullptr);

}  // namespace pg

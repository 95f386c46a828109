#include "pg/eval/flow_eval.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/eval/flo_io.h"

namespace pg {
namespace {

// Middlebury's angular error: the angle between the space-time directions (u, v, 1).
double angular_error_deg(const cv::Vec2f& f, const cv::Vec2f& t) {
  double dot = 1.0 + double(f[0]) * t[0] + double(f[1]) * t[1];
  double norms = std::sqrt((1.0 + double(f[0]) * f[0] + double(f[1]) * f[1]) *
                           (1.0 + double(t[0]) * t[0] + double(t[1]) * t[1]));
  return std::acos(std::clamp(dot / norms, -1.0, 1.0)) * 180.0 / std::numbers::pi;
}

void check_mask(const cv::Mat1b* mask, const cv::Mat2f& truth, const char* name) {
  if (mask && !mask->empty() && mask->size() != truth.size())
    throw InputError(
        name, str("mask is ", mask->cols, "x", mask->rows, " but the flow is ", truth.cols, "x", truth.rows));
}

bool marked(const cv::Mat1b* mask, int row, int col) {
  return mask && !mask->empty() && (*mask)(row, col) != 0;
}

}  // namespace

FlowEvalResult evaluate_flow(const cv::Mat2f& flow, const cv::Mat2f& truth, const cv::Mat1b* occlusion,
                             const cv::Mat1b* invalid) {
  if (flow.size() != truth.size())
    throw InputError("flow", str("flow is ", flow.cols, "x", flow.rows, " but the truth is ", truth.cols, "x",
                                 truth.rows));
  check_mask(occlusion, truth, "occlusions");
  check_mask(invalid, truth, "invalid");

  FlowEvalResult r;
  r.width = truth.cols;
  r.height = truth.rows;
  std::vector<double> epe;
  double sum_occluded = 0, sum_non_occluded = 0, sum_angular = 0;
  std::size_t over_1 = 0, over_3 = 0, over_5 = 0;
  for (int row = 0; row < truth.rows; ++row) {
    for (int col = 0; col < truth.cols; ++col) {
      const cv::Vec2f& t = truth(row, col);
      if (!flow_is_known(t) || marked(invalid, row, col)) continue;
      ++r.truth_pixels;
      const cv::Vec2f& f = flow(row, col);
      if (!flow_is_known(f)) continue;
      double e = std::hypot(double(f[0]) - t[0], double(f[1]) - t[1]);
      epe.push_back(e);
      sum_angular += angular_error_deg(f, t);
      over_1 += e > 1;
      over_3 += e > 3;
      over_5 += e > 5;
      if (marked(occlusion, row, col)) {
        ++r.occluded_pixels;
        sum_occluded += e;
      } else {
        ++r.non_occluded_pixels;
        sum_non_occluded += e;
      }
    }
  }
  if (epe.empty()) throw FailedError("no pixel has a known flow in both the estimate and the truth");
  const double n = double(epe.size());
  const double nan = std::numeric_limits<double>::quiet_NaN();
  r.compared_pixels = epe.size();
  r.coverage = double(r.compared_pixels) / double(r.truth_pixels);
  r.bad_1 = double(over_1) / n;
  r.bad_3 = double(over_3) / n;
  r.bad_5 = double(over_5) / n;
  r.angular_error_deg = sum_angular / n;
  bool split = occlusion && !occlusion->empty();
  r.epe_occluded = split && r.occluded_pixels ? sum_occluded / double(r.occluded_pixels) : nan;
  r.epe_non_occluded =
      split && r.non_occluded_pixels ? sum_non_occluded / double(r.non_occluded_pixels) : nan;
  r.epe = summarize(epe);
  r.epe_all = r.epe.mean;
  return r;
}

nlohmann::json FlowEvalResult::to_json() const {
  return {{"width", width},
          {"height", height},
          {"truth_pixels", truth_pixels},
          {"compared_pixels", compared_pixels},
          {"occluded_pixels", occluded_pixels},
          {"non_occluded_pixels", non_occluded_pixels},
          {"coverage", coverage},
          {"epe_all", epe_all},
          {"epe_non_occluded", json_number(epe_non_occluded)},
          {"epe_occluded", json_number(epe_occluded)},
          {"epe", epe.to_json()},
          {"bad_1", bad_1},
          {"bad_3", bad_3},
          {"bad_5", bad_5},
          {"angular_error_deg", angular_error_deg}};
}

std::string FlowEvalResult::to_text() const {
  std::string text = str(compared_pixels, " of ", truth_pixels, " truth pixels compared (coverage ", coverage,
                         "). EPE mean ", epe_all, " px (median ", epe.median, ", max ", epe.max, ")");
  if (std::isfinite(epe_non_occluded) || std::isfinite(epe_occluded))
    text += str(", non-occluded ", epe_non_occluded, " px over ", non_occluded_pixels, ", occluded ",
                epe_occluded, " px over ", occluded_pixels);
  text += str(". Bad pixels: ", bad_1 * 100, "% > 1 px, ", bad_3 * 100, "% > 3 px, ", bad_5 * 100,
              "% > 5 px. Angular error mean ", angular_error_deg, " deg.");
  return text;
}

}  // namespace pg

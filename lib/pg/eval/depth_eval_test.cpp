#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "pg/core/error.h"
#include "pg/eval/depth_eval.h"

namespace {

// Truth depth 1 + 0.01 col + 0.02 row on a 40x30 image.
pg::DepthMap ramp_depth() {
  pg::DepthMap d;
  d.depth = cv::Mat1f(30, 40);
  for (int row = 0; row < 30; ++row)
    for (int col = 0; col < 40; ++col) d.depth.at<float>(row, col) = 1.0f + 0.01f * col + 0.02f * row;
  return d;
}

// A DepthMap copy shares its cv::Mat buffers: copy the depth deeply.
pg::DepthMap scaled(const pg::DepthMap& d, double factor) {
  pg::DepthMap s = d;
  s.depth = cv::Mat(d.depth * factor);
  return s;
}

}  // namespace

TEST(EvaluateDepth, KnownMultiplicativeError) {
  pg::DepthMap truth = ramp_depth();
  pg::DepthMap estimate = scaled(truth, 1.03);
  pg::DepthEvalResult r = pg::evaluate_depth(estimate, truth);
  EXPECT_EQ(r.truth_pixels, 1200u);
  EXPECT_EQ(r.compared_pixels, 1200u);
  EXPECT_DOUBLE_EQ(r.coverage, 1.0);
  EXPECT_NEAR(r.relative_error.mean, 0.03, 1e-6);
  EXPECT_NEAR(r.relative_error.median, 0.03, 1e-6);
  EXPECT_NEAR(r.relative_error.p90, 0.03, 1e-6);
  EXPECT_NEAR(r.relative_error.p95, 0.03, 1e-6);
  EXPECT_NEAR(r.relative_error.max, 0.03, 1e-6);
  // Independent formula: RMSE = 0.03 sqrt(mean(d*^2)), MAE = 0.03 mean(d*).
  double sum = 0, sum_squares = 0;
  for (float d : cv::Mat1f(truth.depth)) {
    sum += d;
    sum_squares += double(d) * d;
  }
  EXPECT_NEAR(r.rmse, 0.03 * std::sqrt(sum_squares / 1200), 1e-6);
  EXPECT_NEAR(r.mean_absolute_error, 0.03 * sum / 1200, 1e-6);
  ASSERT_EQ(r.fraction_below.size(), 4u);
  EXPECT_EQ(r.fraction_below[0], 0.0);  // 1%
  EXPECT_EQ(r.fraction_below[1], 0.0);  // 2%
  EXPECT_EQ(r.fraction_below[2], 1.0);  // 5%
  EXPECT_EQ(r.fraction_below[3], 1.0);  // 10%
}

TEST(EvaluateDepth, MedianScaleAlignmentRemovesAGlobalScale) {
  pg::DepthMap truth = ramp_depth();
  pg::DepthMap estimate = scaled(truth, 0.25);
  pg::DepthEvalOptions options;
  options.align_median_scale = true;
  pg::DepthEvalResult r = pg::evaluate_depth(estimate, truth, options);
  EXPECT_NEAR(r.scale, 4.0, 1e-6);
  EXPECT_LT(r.relative_error.max, 1e-6);
  EXPECT_EQ(r.fraction_below[0], 1.0);
}

TEST(EvaluateDepth, CoverageMasksAndRange) {
  pg::DepthMap truth = ramp_depth();
  pg::DepthMap estimate = scaled(truth, 1.0);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int row = 0; row < 30; ++row)
    for (int col = 0; col < 10; ++col) estimate.depth.at<float>(row, col) = nan;  // a quarter missing
  truth.depth.at<float>(0, 39) = nan;                                             // one truth pixel unknown
  pg::DepthEvalResult r = pg::evaluate_depth(estimate, truth);
  EXPECT_EQ(r.truth_pixels, 1199u);
  EXPECT_EQ(r.compared_pixels, 899u);
  EXPECT_NEAR(r.coverage, 899.0 / 1199.0, 1e-12);
  EXPECT_EQ(r.relative_error.max, 0.0);

  // A truth mask (255 = excluded) keeps the top 10 rows only.
  truth.mask = cv::Mat1b(30, 40, std::uint8_t(255));
  truth.mask.rowRange(0, 10).setTo(0);
  r = pg::evaluate_depth(estimate, truth);
  EXPECT_EQ(r.truth_pixels, 399u);
  EXPECT_EQ(r.compared_pixels, 299u);
  truth.mask.release();

  // Truth depths in [1.0, 1.2] only, counted independently.
  pg::DepthEvalOptions options;
  options.min_depth = 1.0;
  options.max_depth = 1.2;
  std::size_t in_range = 0;
  for (int row = 0; row < 30; ++row)
    for (int col = 0; col < 40; ++col) {
      float d = truth.depth.at<float>(row, col);
      in_range += std::isfinite(d) && double(d) >= 1.0 && double(d) <= 1.2;
    }
  r = pg::evaluate_depth(estimate, truth, options);
  EXPECT_EQ(r.truth_pixels, in_range);
}

TEST(EvaluateDepth, RejectsMismatchedSizesAndEmptyOverlap) {
  pg::DepthMap truth = ramp_depth();
  pg::DepthMap small;
  small.depth = cv::Mat1f(15, 20, 1.0f);
  EXPECT_THROW(pg::evaluate_depth(small, truth), pg::InputError);
  pg::DepthMap empty = scaled(truth, 1.0);
  empty.depth.setTo(std::numeric_limits<float>::quiet_NaN());
  EXPECT_THROW(pg::evaluate_depth(empty, truth), pg::FailedError);
}

TEST(EvaluateDepth, JsonAndTextCarryTheNumbers) {
  pg::DepthMap truth = ramp_depth();
  pg::DepthEvalResult r = pg::evaluate_depth(scaled(truth, 1.03), truth);
  nlohmann::json j = r.to_json();
  EXPECT_NEAR(j["relative_error"]["mean"].get<double>(), 0.03, 1e-6);
  EXPECT_EQ(j["fraction_below"][2]["threshold"], 0.05);
  EXPECT_EQ(j["fraction_below"][2]["fraction"], 1.0);
  EXPECT_NE(r.to_text().find("1200 of 1200"), std::string::npos);
}

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <numbers>
#include <opencv2/imgcodecs.hpp>

#include "pg/core/error.h"
#include "pg/eval/flo_io.h"
#include "pg/eval/flow_eval.h"
#include "pg/testing/testing.h"

namespace {

// A smooth rotation-plus-translation flow field.
cv::Mat2f swirl(int width, int height) {
  cv::Mat2f f(height, width);
  for (int row = 0; row < height; ++row)
    for (int col = 0; col < width; ++col)
      f(row, col) = cv::Vec2f(2.0f + 0.05f * (row - height / 2), -1.0f - 0.05f * (col - width / 2));
  return f;
}

void write_bytes(const std::filesystem::path& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
}

// A .flo header followed by `payload_bytes` zero bytes.
std::string flo_header(float magic, std::int32_t width, std::int32_t height, std::size_t payload_bytes = 0) {
  std::string h(12 + payload_bytes, '\0');
  std::memcpy(h.data(), &magic, 4);
  std::memcpy(h.data() + 4, &width, 4);
  std::memcpy(h.data() + 8, &height, 4);
  return h;
}

}  // namespace

TEST(EvaluateFlow, ConstantOffsetGivesExactEndPointError) {
  cv::Mat2f truth = swirl(48, 32);
  cv::Mat2f estimate = truth + cv::Scalar(0.3, 0.4);  // |(0.3, 0.4)| = 0.5
  pg::FlowEvalResult r = pg::evaluate_flow(estimate, truth);
  EXPECT_EQ(r.compared_pixels, 48u * 32u);
  EXPECT_DOUBLE_EQ(r.coverage, 1.0);
  EXPECT_NEAR(r.epe_all, 0.5, 1e-5);
  EXPECT_NEAR(r.epe.max, 0.5, 1e-5);
  EXPECT_NEAR(r.epe.median, 0.5, 1e-5);
  EXPECT_EQ(r.bad_1, 0.0);
  EXPECT_TRUE(std::isnan(r.epe_occluded));
  EXPECT_TRUE(std::isnan(r.epe_non_occluded));
  EXPECT_TRUE(r.to_json()["epe_occluded"].is_null());
}

TEST(EvaluateFlow, AngularErrorAgainstZeroFlow) {
  cv::Mat2f truth(10, 10, cv::Vec2f(0, 0));
  cv::Mat2f estimate(10, 10, cv::Vec2f(0.3f, 0.4f));
  pg::FlowEvalResult r = pg::evaluate_flow(estimate, truth);
  // angle between (0.3, 0.4, 1) and (0, 0, 1) = atan(0.5)
  EXPECT_NEAR(r.angular_error_deg, std::atan(0.5) * 180 / std::numbers::pi, 1e-4);
}

TEST(EvaluateFlow, SplitsOccludedPixelsAndCountsBadPixels) {
  cv::Mat2f truth = swirl(40, 20);
  cv::Mat2f estimate = truth.clone();
  cv::Mat1b occluded(20, 40, std::uint8_t(0));
  for (int row = 0; row < 20; ++row)
    for (int col = 0; col < 40; ++col) {
      bool left = col < 10;  // a quarter occluded, error 4 px there; 0.5 px elsewhere
      occluded(row, col) = left ? 255 : 0;
      estimate(row, col) += left ? cv::Vec2f(0, 4) : cv::Vec2f(0.5f, 0);
    }
  pg::FlowEvalResult r = pg::evaluate_flow(estimate, truth, &occluded);
  EXPECT_EQ(r.occluded_pixels, 200u);
  EXPECT_EQ(r.non_occluded_pixels, 600u);
  EXPECT_NEAR(r.epe_occluded, 4.0, 1e-5);
  EXPECT_NEAR(r.epe_non_occluded, 0.5, 1e-5);
  EXPECT_NEAR(r.epe_all, 0.25 * 4 + 0.75 * 0.5, 1e-5);
  EXPECT_DOUBLE_EQ(r.bad_1, 0.25);
  EXPECT_DOUBLE_EQ(r.bad_3, 0.25);
  EXPECT_DOUBLE_EQ(r.bad_5, 0.0);
}

TEST(EvaluateFlow, UnknownAndInvalidPixelsAreNotCompared) {
  cv::Mat2f truth = swirl(20, 10);
  cv::Mat2f estimate = truth + cv::Scalar(1, 0);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  truth(0, 0) = cv::Vec2f(1e10f, 1e10f);  // Middlebury unknown
  truth(0, 1) = cv::Vec2f(nan, 0);
  estimate(5, 5) = cv::Vec2f(nan, nan);  // missing estimate: lowers coverage
  estimate(5, 6) = cv::Vec2f(2e9f, 0);
  cv::Mat1b invalid(10, 20, std::uint8_t(0));
  invalid.row(9).setTo(1);
  estimate.row(9).setTo(cv::Scalar(1000, 1000));  // huge errors that must not count
  pg::FlowEvalResult r = pg::evaluate_flow(estimate, truth, nullptr, &invalid);
  EXPECT_EQ(r.truth_pixels, 200u - 2 - 20);
  EXPECT_EQ(r.compared_pixels, 200u - 2 - 20 - 2);
  EXPECT_NEAR(r.coverage, 176.0 / 178.0, 1e-12);
  EXPECT_NEAR(r.epe_all, 1.0, 1e-5);
  EXPECT_NEAR(r.epe.max, 1.0, 1e-5);
}

TEST(EvaluateFlow, RejectsMismatchedSizes) {
  cv::Mat2f a = swirl(20, 10), b = swirl(10, 20);
  EXPECT_THROW(pg::evaluate_flow(a, b), pg::InputError);
  cv::Mat1b mask(5, 5, std::uint8_t(0));
  EXPECT_THROW(pg::evaluate_flow(a, a, &mask), pg::InputError);
}

TEST(FloIo, RoundTripsAndMapsUnknownToNaN) {
  pg::testing::TempDir dir;
  cv::Mat2f flow = swirl(17, 9);
  flow(3, 4) = cv::Vec2f(std::numeric_limits<float>::quiet_NaN(), 1);
  pg::write_flo(dir / "a.flo", flow);
  EXPECT_EQ(std::filesystem::file_size(dir / "a.flo"), 12u + 17 * 9 * 8);
  cv::Mat2f back = pg::read_flo(dir / "a.flo");
  ASSERT_EQ(back.size(), flow.size());
  for (int row = 0; row < 9; ++row)
    for (int col = 0; col < 17; ++col) {
      if (row == 3 && col == 4) {
        EXPECT_TRUE(std::isnan(back(row, col)[0]) && std::isnan(back(row, col)[1]));
      } else {
        EXPECT_EQ(back(row, col), flow(row, col));
      }
    }
  // The unknown vector is stored as Middlebury's 1e10 marker.
  std::string bytes = pg::testing::read_text(dir / "a.flo");
  float stored;
  std::memcpy(&stored, bytes.data() + 12 + (3 * 17 + 4) * 8 + 4, 4);
  EXPECT_EQ(stored, 1e10f);
}

TEST(FloIo, RejectsMalformedFiles) {
  pg::testing::TempDir dir;
  auto expect_rejected = [&](const std::string& name, const std::string& bytes, const std::string& problem) {
    write_bytes(dir / name, bytes);
    try {
      pg::read_flo(dir / name);
      ADD_FAILURE() << name << " was accepted";
    } catch (const pg::InputError& e) {
      std::string message = e.what();
      EXPECT_NE(message.find(name), std::string::npos) << message;
      EXPECT_NE(message.find(problem), std::string::npos) << message;
    }
  };
  expect_rejected("short.flo", "PIE", "too short");
  expect_rejected("magic.flo", flo_header(1.0f, 2, 2, 32), "bad magic");
  expect_rejected("truncated.flo", flo_header(202021.25f, 4, 4, 100), "truncated");
  expect_rejected("trailing.flo", flo_header(202021.25f, 1, 1, 9), "trailing");
  expect_rejected("huge.flo", flo_header(202021.25f, 100000, 100000), "outside");
  expect_rejected("negative.flo", flo_header(202021.25f, -5, 3), "outside");
  // Within the dimension bound but claiming 32 GiB: refused from the file length, before allocating.
  expect_rejected("big.flo", flo_header(202021.25f, 65536, 65536), "truncated");
  EXPECT_THROW(pg::read_flo(dir / "missing.flo"), pg::InputError);
}

TEST(FloIo, ReadsRealSintelFlow) {
  PG_REQUIRE_REAL_DATA(dir, "flow/sintel/clean/alley_1/gt");
  cv::Mat2f truth = pg::read_flo(dir / "frame_0002.flo");
  EXPECT_EQ(truth.cols, 1024);
  EXPECT_EQ(truth.rows, 436);
  cv::Mat1b occlusions = cv::imread((dir / "occlusions/frame_0002.png").string(), cv::IMREAD_GRAYSCALE);
  cv::Mat1b invalid = cv::imread((dir / "invalid/frame_0002.png").string(), cv::IMREAD_GRAYSCALE);
  ASSERT_EQ(occlusions.size(), truth.size());
  pg::FlowEvalResult self = pg::evaluate_flow(truth, truth, &occlusions, &invalid);
  EXPECT_EQ(self.epe_all, 0.0);
  EXPECT_EQ(self.bad_1, 0.0);
  EXPECT_GT(self.compared_pixels, 400000u);
  EXPECT_GT(self.occluded_pixels, 0u);
  // Zero flow against the truth: EPE is the mean flow magnitude, computed independently.
  cv::Mat2f zero(truth.size(), cv::Vec2f(0, 0));
  double sum = 0;
  std::size_t n = 0;
  for (int row = 0; row < truth.rows; ++row)
    for (int col = 0; col < truth.cols; ++col)
      if (!invalid(row, col) && pg::flow_is_known(truth(row, col))) {
        sum += cv::norm(truth(row, col));
        ++n;
      }
  pg::FlowEvalResult moving = pg::evaluate_flow(zero, truth, &occlusions, &invalid);
  EXPECT_EQ(moving.compared_pixels, n);
  EXPECT_NEAR(moving.epe_all, sum / double(n), 1e-9);
}

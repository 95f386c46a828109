#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <opencv2/imgproc.hpp>

#include "pg/core/error.h"
#include "pg/eval/flo_io.h"
#include "pg/eval/flow_eval.h"
#include "pg/flow/flow.h"
#include "pg/flow/flow_color.h"
#include "pg/image/image_io.h"
#include "pg/testing/testing.h"

namespace {

// A smooth random colour texture (blurred noise), 8-bit.
cv::Mat3b texture(cv::Size size, int seed) {
  cv::Mat3f noise(size);
  cv::RNG rng(seed);
  rng.fill(noise, cv::RNG::UNIFORM, 0, 1);
  cv::GaussianBlur(noise, noise, {0, 0}, 2.0);
  cv::Mat3b out;
  cv::normalize(noise, noise, 0, 255, cv::NORM_MINMAX);
  noise.convertTo(out, CV_8U);
  return out;
}

// `image` moved by (dx, dy): out(x + d) = image(x).
cv::Mat shifted(const cv::Mat& image, double dx, double dy) {
  cv::Mat out;
  const cv::Mat m = (cv::Mat_<double>(2, 3) << 1, 0, dx, 0, 1, dy);
  cv::warpAffine(image, out, m, image.size(), cv::INTER_CUBIC, cv::BORDER_REFLECT);
  return out;
}

double mean_error(const cv::Mat2f& flow, cv::Vec2f truth, int margin) {
  double sum = 0;
  int n = 0;
  for (int y = margin; y < flow.rows - margin; ++y)
    for (int x = margin; x < flow.cols - margin; ++x, ++n) sum += cv::norm(flow(y, x) - truth);
  return sum / n;
}

TEST(Flow, RecoversATranslationToATenthOfAPixel) {
  const cv::Mat3b a = texture({160, 120}, 1);
  const cv::Mat b = shifted(a, 2.3, -1.4);
  EXPECT_LT(mean_error(pg::compute_flow(a, b), {2.3f, -1.4f}, 12), 0.08);
  // The combined local-global data term and grey input recover it too.
  pg::FlowOptions clg;
  clg.clg_rho = 1.5;
  cv::Mat grey_a, grey_b;
  cv::cvtColor(a, grey_a, cv::COLOR_BGR2GRAY);
  cv::cvtColor(b, grey_b, cv::COLOR_BGR2GRAY);
  EXPECT_LT(mean_error(pg::compute_flow(grey_a, grey_b, clg), {2.3f, -1.4f}, 12), 0.08);
}

TEST(Flow, FloatAndHdrInputsGiveTheSameFlow) {
  const cv::Mat3b a = texture({120, 90}, 2);
  const cv::Mat b = shifted(a, -1.7, 0.6);
  cv::Mat3f fa, fb;
  a.convertTo(fa, CV_32F, 1.0 / 255);
  b.convertTo(fb, CV_32F, 1.0 / 255);
  const cv::Mat2f from_8bit = pg::compute_flow(a, b), from_float = pg::compute_flow(fa, fb);
  EXPECT_LT(cv::norm(from_8bit, from_float, cv::NORM_INF), 1e-3);
  pg::FlowOptions hdr;
  hdr.hdr_log = true;
  EXPECT_LT(mean_error(pg::compute_flow(cv::Mat(fa * 40.0), cv::Mat(fb * 40.0), hdr), {-1.7f, 0.6f}, 10),
            0.08);
}

TEST(Flow, EpipolarModeSolvesAlongRectifiedLines) {
  const cv::Mat3b a = texture({160, 120}, 3);
  const cv::Mat b = shifted(a, -4.6, 0);  // disparity 4.6 to the left
  const pg::EpipolarField field{cv::Mat2f(a.size(), cv::Vec2f(0, 0)), cv::Mat2f(a.size(), cv::Vec2f(-1, 0))};
  const pg::EpipolarFlow result = pg::compute_epipolar_flow(a, b, field);
  double sum = 0;
  for (int y = 12; y < a.rows - 12; ++y)
    for (int x = 12; x < a.cols - 12; ++x) sum += std::abs(result.along(y, x) - 4.6);
  EXPECT_LT(sum / ((a.rows - 24) * (a.cols - 24)), 0.04);
  EXPECT_FLOAT_EQ(result.flow(60, 80)[1], 0.f);
  EXPECT_FLOAT_EQ(result.flow(60, 80)[0], -result.along(60, 80));
}

TEST(Flow, EpipolarFieldPutsEveryDepthOnTheLine) {
  pg::Camera a, b;
  a.id = "a", b.id = "b";
  a.width = b.width = 64, a.height = b.height = 48;
  a.intrinsics = b.intrinsics = {60, 60, 31.5, 23.5};
  b.cam_from_world.rotation =
      Eigen::Quaterniond(Eigen::AngleAxisd(0.1, Eigen::Vector3d(0.2, 1, 0.1).normalized()));
  b.cam_from_world.translation = {-0.5, 0.05, 0.1};
  const pg::EpipolarField field = pg::epipolar_field(a, b);
  for (const auto& [x, y] : {std::pair{10, 10}, std::pair{40, 30}, std::pair{60, 5}})
    for (double depth : {1.0, 3.0, 20.0}) {
      const Eigen::Vector3d ray = a.unproject(Eigen::Vector2d(x, y));
      Eigen::Vector2d q;
      ASSERT_TRUE(b.project(b.cam_from_world * (ray / ray.z() * depth), q));
      const cv::Vec2f flow(static_cast<float>(q.x() - x), static_cast<float>(q.y() - y));
      const cv::Vec2f offset = flow - field.base(y, x), d = field.direction(y, x);
      EXPECT_NEAR(offset[0] * d[1] - offset[1] * d[0], 0, 1e-3);  // on the line
      EXPECT_GT(offset.dot(d), 0);                                // nearer than infinity
    }
  pg::Camera twin = a;
  EXPECT_THROW(pg::epipolar_field(a, twin), pg::UsageError);
  EXPECT_EQ(pg::resize_epipolar_field(field, {32, 24}).base.size(), cv::Size(32, 24));
}

TEST(Flow, ForwardBackwardErrorAndOcclusions) {
  cv::Mat2f forward(20, 30, cv::Vec2f(2, 1)), backward(20, 30, cv::Vec2f(-2, -1));
  backward(11, 12) = cv::Vec2f(3, 3);  // an inconsistent vector, sampled by forward pixel (10, 10)
  const cv::Mat1f error = pg::forward_backward_error(forward, backward);
  EXPECT_FLOAT_EQ(error(0, 0), 0.f);
  EXPECT_NEAR(error(10, 10), std::hypot(5.0, 4.0), 1e-5);
  EXPECT_TRUE(std::isnan(error(19, 29)));  // leaves the image
  const cv::Mat1b occluded = pg::occlusion_mask(error, forward);
  EXPECT_EQ(occluded(0, 0), 0);
  EXPECT_EQ(occluded(10, 10), 255);
  EXPECT_EQ(occluded(19, 29), 255);
}

TEST(Flow, RejectsBadInputsAndOptions) {
  const cv::Mat3b a = texture({40, 30}, 4);
  EXPECT_THROW(pg::compute_flow(a, cv::Mat3b(31, 40)), pg::UsageError);
  EXPECT_THROW(pg::compute_flow(a, cv::Mat()), pg::UsageError);
  pg::FlowOptions bad;
  bad.pyramid_factor = 1.0;
  EXPECT_THROW(pg::compute_flow(a, a, bad), pg::UsageError);
  bad = {};
  bad.sor_omega = 2.0;
  EXPECT_THROW(bad.check(), pg::UsageError);
  EXPECT_THROW(pg::FlowOptions::preset("fastest"), pg::UsageError);
  EXPECT_NO_THROW(pg::FlowOptions::preset("accurate").check());
}

TEST(FlowColor, WhiteForNoMotionBlackForUnknownHueForDirection) {
  cv::Mat2f flow(1, 4);
  flow(0, 0) = {0, 0};
  flow(0, 1) = {NAN, 0};
  flow(0, 2) = {1, 0};   // right: red in the Middlebury wheel
  flow(0, 3) = {-1, 0};  // left: cyan
  const cv::Mat3b c = pg::flow_to_color(flow, 1.0);
  EXPECT_EQ(c(0, 0), cv::Vec3b(255, 255, 255));
  EXPECT_EQ(c(0, 1), cv::Vec3b(0, 0, 0));
  EXPECT_GT(c(0, 2)[2], 200);  // BGR: strong red
  EXPECT_LT(c(0, 2)[0], 60);
  EXPECT_GT(c(0, 3)[0], 150);  // blue and green, little red
  EXPECT_LT(c(0, 3)[2], 60);
}

// A rectified row: background at disparity 2, a foreground block at 10 over x in [20, 30), and the
// background pixels just left of the block hidden in the other view (x in [12, 20)).
TEST(OcclusionFill, HiddenPixelsTakeTheirLinesBackground) {
  const cv::Size size(48, 3);
  const pg::EpipolarField field{cv::Mat2f(size, cv::Vec2f(0, 0)), cv::Mat2f(size, cv::Vec2f(-1, 0))};
  cv::Mat2f flow(size, cv::Vec2f(-2, 0));
  cv::Mat1b occluded(size, std::uint8_t{0});
  for (int y = 0; y < size.height; ++y) {
    for (int x = 20; x < 30; ++x) flow(y, x) = {-10, 0};
    for (int x = 12; x < 20; ++x) flow(y, x) = {-7, 0}, occluded(y, x) = 255;  // smoothed across the edge
  }
  const cv::Mat2f filled = pg::fill_occlusions_along_lines(flow, occluded, field);
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x) {
      const float expected = x >= 20 && x < 30 ? -10.f : -2.f;
      EXPECT_FLOAT_EQ(filled(y, x)[0], expected) << x;
      EXPECT_FLOAT_EQ(filled(y, x)[1], 0.f);
    }
}

// Lines at 45 degrees with a base offset: s is measured from each pixel's base, and the walk follows
// the line's direction; with every pixel occluded nothing is filled.
TEST(OcclusionFill, FollowsSlantedLinesAndFillsNothingWithoutABackground) {
  const cv::Size size(32, 32);
  const float r = std::sqrt(0.5f);
  const pg::EpipolarField field{cv::Mat2f(size, cv::Vec2f(1, 0)), cv::Mat2f(size, cv::Vec2f(r, r))};
  cv::Mat2f flow(size);
  cv::Mat1b occluded(size, std::uint8_t{0});
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x) {
      const float s = x + y < 32 ? 3.f : 6.f;  // the far side of the anti-diagonal is nearer
      flow(y, x) = cv::Vec2f(1, 0) + s * cv::Vec2f(r, r);
      if (x + y >= 28 && x + y < 32)
        flow(y, x) = cv::Vec2f(1, 0) + 5.f * cv::Vec2f(r, r), occluded(y, x) = 255;
    }
  occluded(0, 0) = 255;  // one way leaves the image at once, the other finds (1, 1)
  const cv::Mat2f filled = pg::fill_occlusions_along_lines(flow, occluded, field);
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x) {
      const float s = (filled(y, x) - cv::Vec2f(1, 0)).dot(cv::Vec2f(r, r));
      const bool band = x + y >= 28 && x + y < 32;
      // Band pixels near the top or left edge see no background before their walk leaves the image.
      if (!band || (x >= 4 && y >= 4)) {
        EXPECT_NEAR(s, x + y < 32 ? 3.f : 6.f, 1e-5) << x << "," << y;
      }
    }
  EXPECT_NEAR((filled(0, 0) - cv::Vec2f(1, 0)).dot(cv::Vec2f(r, r)), 3.f, 1e-5);  // its neighbour (1, 1)
  cv::Mat1b all(size, std::uint8_t{255});
  const cv::Mat2f untouched = pg::fill_occlusions_along_lines(flow, all, field);
  EXPECT_EQ(cv::norm(untouched, flow, cv::NORM_INF), 0.0);
  EXPECT_THROW(pg::fill_occlusions_along_lines(flow, cv::Mat1b(4, 4), field), pg::UsageError);
}

TEST(FlowRealData, SintelAlleyCleanEndPointError) {
  PG_REQUIRE_REAL_DATA(dir, "flow/sintel/clean/alley_1");
  const cv::Mat a = pg::read_image(dir / "frame_0002.png"), b = pg::read_image(dir / "frame_0003.png");
  const cv::Mat1b occlusion = pg::read_image(dir / "gt/occlusions/frame_0002.png");
  const cv::Mat1b invalid = pg::read_image(dir / "gt/invalid/frame_0002.png");
  const pg::FlowEvalResult r =
      pg::evaluate_flow(pg::compute_flow(a, b, pg::FlowOptions::preset("fast")),
                        pg::read_flo(dir / "gt/frame_0002.flo"), &occlusion, &invalid);
  RecordProperty("epe_all", std::to_string(r.epe_all));
  // The fast preset (1.6x the time of OpenCV's DIS + VariationalRefinement at 1536x1024 in bench_flow)
  // is more accurate than it: DIS + VariationalRefinement measures 0.295 here, fast 0.234.
  EXPECT_LT(r.epe_all, 0.28);
  EXPECT_LT(r.epe_non_occluded, 0.22);
  EXPECT_EQ(r.coverage, 1.0);
}

TEST(FlowRealData, MiddleburyVenusAsEpipolarStereo) {
  PG_REQUIRE_REAL_DATA(dir, "stereo/middlebury/venus");
  const cv::Mat a = pg::read_image(dir / "im2.png"), b = pg::read_image(dir / "im6.png");
  cv::Mat1f truth;
  pg::read_image(dir / "disp2.pgm").convertTo(truth, CV_32F, 1.0 / 8);
  const pg::EpipolarField field{cv::Mat2f(a.size(), cv::Vec2f(0, 0)), cv::Mat2f(a.size(), cv::Vec2f(-1, 0))};
  const pg::EpipolarFlow result = pg::compute_epipolar_flow(a, b, field, pg::FlowOptions::preset("fast"));
  std::size_t known = 0, bad = 0;
  for (int y = 0; y < truth.rows; ++y)
    for (int x = 0; x < truth.cols; ++x)
      if (truth(y, x) > 0) ++known, bad += std::abs(result.along(y, x) - truth(y, x)) > 2;
  const double bad_2px = static_cast<double>(bad) / known;
  RecordProperty("bad_2px", std::to_string(bad_2px));
  EXPECT_LT(bad_2px, 0.07);  // 5.6% measured with the fast preset
}

// Dense stereo on the four Middlebury pairs: epipolar flow both ways from the discrete search, the
// pixels whose forward and backward flows disagree by more than 0.25 px (occluded ones and the least
// certain others, 12-28% of the pixels) filled with their row's background, every pixel scored
// against the true disparity. Measured: 3.6 / 1.3 / 8.9 / 9.7%. A looser check fills fewer pixels
// and scores worse (1 px: 4.2 / 1.7 / 10.5 / 11.6% with a coarser search). Bounds: the best
// OpenCV figures on tsukuba, venus and teddy (StereoSGBM 4.53% and 1.84% over its 84-98% density,
// teddy 11.52%); aloe, which the issue gives no figure for, below 12% (its best dense OpenCV method,
// DeepFlow, measures 31% in bench_flow). StereoSGBM with its holes filled the same way measures
// 4.7 / 2.7 / 15.6 / 16.2%.
struct StereoPair {
  const char* name;
  const char *left, *right, *truth;
  double truth_scale;       // disparity = stored value / scale
  double max_bad_2px;       // percent, the balanced preset
  double max_bad_2px_fast;  // percent, the fast preset: DIS + VariationalRefinement's figure in bench_flow
};

class MiddleburyDenseStereo : public ::testing::TestWithParam<StereoPair> {
 protected:
  // bad-2px (percent) of the dense stereo recipe with `options` over every pixel with known disparity.
  static double bad_2px(const StereoPair& c, const std::filesystem::path& dir, pg::FlowOptions options) {
    const cv::Mat a = pg::read_image(dir / c.left), b = pg::read_image(dir / c.right);
    cv::Mat1f truth;
    pg::read_image(dir / c.truth).convertTo(truth, CV_32F, 1.0 / c.truth_scale);
    // Rectified: nearer points lie further left in the right image, further right in the left one.
    const pg::EpipolarField forward{cv::Mat2f(a.size(), cv::Vec2f(0, 0)),
                                    cv::Mat2f(a.size(), cv::Vec2f(-1, 0))};
    const pg::EpipolarField backward{forward.base, cv::Mat2f(a.size(), cv::Vec2f(1, 0))};
    options.search_range = 0.25;
    const pg::BidirectionalFlow both =
        pg::compute_epipolar_flow_bidirectional(a, b, forward, backward, options);
    const cv::Mat2f flow = pg::fill_occlusions_along_lines(
        both.forward, pg::occlusion_mask(both.fb_error, both.forward, 0.25, 0.0), forward);
    std::size_t known = 0, bad = 0;
    for (int y = 0; y < truth.rows; ++y)
      for (int x = 0; x < truth.cols; ++x)
        if (truth(y, x) > 0) ++known, bad += !(std::abs(-flow(y, x)[0] - truth(y, x)) <= 2);
    return 100.0 * static_cast<double>(bad) / known;
  }
};

TEST_P(MiddleburyDenseStereo, BeatsOpenCVsBestWithEveryPixelEstimated) {
  const StereoPair& c = GetParam();
  PG_REQUIRE_REAL_DATA(dir, "stereo");
  const double bad = bad_2px(c, dir, pg::FlowOptions::preset("balanced"));
  RecordProperty("bad_2px_percent", std::to_string(bad));
  std::printf("%s: bad-2px %.2f%% over every pixel with known disparity (bound %.2f%%)\n", c.name, bad,
              c.max_bad_2px);
  EXPECT_LT(bad, c.max_bad_2px);
}

// The fast preset, within 2x of DIS + VariationalRefinement's time, is more accurate than it here too
// (measured 4.4 / 1.3 / 9.9 / 10.4%).
TEST_P(MiddleburyDenseStereo, FastPresetBeatsDisVariationalRefinement) {
  const StereoPair& c = GetParam();
  PG_REQUIRE_REAL_DATA(dir, "stereo");
  const double bad = bad_2px(c, dir, pg::FlowOptions::preset("fast"));
  RecordProperty("bad_2px_percent", std::to_string(bad));
  std::printf("%s, fast: bad-2px %.2f%% (bound %.2f%%)\n", c.name, bad, c.max_bad_2px_fast);
  EXPECT_LT(bad, c.max_bad_2px_fast);
}

INSTANTIATE_TEST_SUITE_P(
    FlowRealData, MiddleburyDenseStereo,
    ::testing::Values(StereoPair{"tsukuba", "middlebury/tsukuba/im3.png", "middlebury/tsukuba/im4.png",
                                 "middlebury/tsukuba/disp3.pgm", 16, 4.53, 5.97},
                      StereoPair{"venus", "middlebury/venus/im2.png", "middlebury/venus/im6.png",
                                 "middlebury/venus/disp2.pgm", 8, 1.84, 3.43},
                      StereoPair{"teddy", "middlebury/teddy/im2.png", "middlebury/teddy/im6.png",
                                 "middlebury/teddy/disp2.png", 4, 11.52, 18.01},
                      StereoPair{"aloe", "aloe/aloeL.jpg", "aloe/aloeR.jpg", "aloe/aloeGT.png", 1, 12.0,
                                 38.2}),
    [](const ::testing::TestParamInfo<StereoPair>& info) { return std::string(info.param.name); });

}  // namespace

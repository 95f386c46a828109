// Calibration on corners projected in code through known cameras: recovery of the intrinsics and of
// the distortion field, outlier views and corners, degenerate views, flattening.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>
#include <random>

#include "pg/calib/calibrate.h"
#include "pg/calib/corner_fit.h"
#include "pg/calib/detect.h"
#include "pg/calib/flatten.h"
#include "pg/calib/stereo.h"
#include "pg/core/error.h"

using namespace pg;
using namespace pg::calib;

namespace {

const BoardSpec board{9, 6, 0.03};
const cv::Size size{640, 480};

Camera pinhole_truth() {
  Camera c;
  c.id = "truth";
  c.width = size.width;
  c.height = size.height;
  c.intrinsics = {800, 805, 322.5, 238.0};
  c.distortion = {-0.25, 0.08, 0, 0, -0.02, 0, 0, 0};
  return c;
}

// Tangential terms trade off against the principal point in a narrow field of view (their stddevs
// grow ~7x here), so the recovery tests calibrate a lens without them, as most modern lenses are.
CalibrationOptions radial_only() {
  CalibrationOptions o;
  o.zero_tangential = true;
  return o;
}

Camera fisheye_truth() {
  Camera c = pinhole_truth();
  c.model = CameraModel::fisheye;
  c.intrinsics = {260, 261, 318.0, 242.0};
  c.distortion = {};
  c.distortion.k1 = 0.03;
  c.distortion.k2 = -0.01;
  c.distortion.k3 = 0.004;
  c.distortion.k4 = -0.001;
  return c;
}

// Board poses that cover the frame: the board centre on the ray through a random pixel, tilted up to
// ~45 degrees, at a distance where it spans about 40% of the image width.
std::vector<ViewInput> project_views(const Camera& camera, int count, double noise_px, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(-1, 1);
  std::normal_distribution<double> noise(0, noise_px);
  const Eigen::Vector3d centre(0.5 * (board.cols - 1) * board.square_size,
                               0.5 * (board.rows - 1) * board.square_size, 0);
  const double distance = camera.intrinsics.fx * (board.cols - 1) * board.square_size / (0.4 * camera.width);
  std::vector<ViewInput> views;
  while (int(views.size()) < count) {
    // One draw per statement: the order of evaluation of a call's arguments (or of an operator's
    // operands) is unspecified, and GCC and clang differ, which would make the views compiler-specific.
    const double ax = unit(rng), ay = unit(rng), az = unit(rng), tx = unit(rng), ty = unit(rng);
    Rigid3 pose;
    pose.rotation = Eigen::AngleAxisd(0.8 * ax, Eigen::Vector3d::UnitX()) *
                    Eigen::AngleAxisd(0.8 * ay, Eigen::Vector3d::UnitY()) *
                    Eigen::AngleAxisd(0.3 * az, Eigen::Vector3d::UnitZ());
    const Eigen::Vector2d target((0.5 + 0.5 * tx) * (camera.width - 1),
                                 (0.5 + 0.5 * ty) * (camera.height - 1));
    const Eigen::Vector3d ray = camera.unproject(target);
    pose.translation = distance * (1 + 0.2 * unit(rng)) * ray / ray.z() - pose.rotation * centre;
    ViewInput v{"view" + std::to_string(views.size()), {}};
    bool inside = true;
    for (const cv::Point3f& p : board_points(board)) {
      Eigen::Vector2d pixel;
      inside &= camera.project(pose * Eigen::Vector3d(p.x, p.y, p.z), pixel) && camera.in_image(pixel, 5);
      const double nx = noise(rng), ny = noise(rng);
      v.corners.emplace_back(float(pixel.x() + nx), float(pixel.y() + ny));
    }
    if (inside) views.push_back(v);
  }
  return views;
}

// Largest difference of the two cameras' distortion fields over the image area the boards covered
// (within 20 px of an observed corner): beyond it the polynomial is extrapolated.
double distortion_field_error(const Camera& a, const Camera& b, const std::vector<ViewInput>& views) {
  cv::Mat covered(a.height, a.width, CV_8U, cv::Scalar(0));
  for (const ViewInput& v : views)
    for (const cv::Point2f& p : v.corners) cv::circle(covered, p, 20, cv::Scalar(255), -1);
  double worst = 0;
  for (int y = 0; y < a.height; y += 8)
    for (int x = 0; x < a.width; x += 8)
      if (covered.at<std::uint8_t>(y, x))
        worst =
            std::max(worst, (distortion_displacement(a, {x, y}) - distortion_displacement(b, {x, y})).norm());
  return worst;
}

// The bars (fx, fy within 0.2%, cx, cy within `principal_point_px`, the distortion field within
// 0.1 px), and errors the reported standard deviations explain.
void expect_recovered(const Camera& truth, const CalibrationResult& r, const std::vector<ViewInput>& views,
                      double principal_point_px = 0.5) {
  const Intrinsics& k = r.camera.intrinsics;
  ASSERT_TRUE(r.camera.stddev);
  const auto& sd = *r.camera.stddev;
  ::testing::Test::RecordProperty("cx_error", std::to_string(k.cx - truth.intrinsics.cx));
  ::testing::Test::RecordProperty("cx_stddev", std::to_string(sd[2]));
  ::testing::Test::RecordProperty("cy_error", std::to_string(k.cy - truth.intrinsics.cy));
  EXPECT_NEAR(k.fx, truth.intrinsics.fx, 0.002 * truth.intrinsics.fx);
  EXPECT_NEAR(k.fy, truth.intrinsics.fy, 0.002 * truth.intrinsics.fy);
  EXPECT_NEAR(k.cx, truth.intrinsics.cx, principal_point_px);
  EXPECT_NEAR(k.cy, truth.intrinsics.cy, principal_point_px);
  EXPECT_LT(distortion_field_error(truth, r.camera, views), 0.1);
  EXPECT_LT(std::abs(k.fx - truth.intrinsics.fx), 5 * sd[0] + 1e-9);
  EXPECT_LT(std::abs(k.cx - truth.intrinsics.cx), 5 * sd[2] + 1e-9);
}

TEST(Calibrate, RecoversPinholeK3) {
  const Camera truth = pinhole_truth();
  const auto views = project_views(truth, 30, 0.03, 1);
  const CalibrationResult r = calibrate(views, board, size, radial_only());
  EXPECT_EQ(r.camera.model, CameraModel::pinhole);
  expect_recovered(truth, r, views);
  EXPECT_NEAR(r.rms, 0.03 * std::sqrt(2.0), 0.01);  // per-corner RMS of 2D noise with 0.03 px per axis
  EXPECT_LT(r.corners_dropped, 30 * 54 / 50);
}

TEST(Calibrate, RecoversFisheye) {
  const Camera truth = fisheye_truth();
  CalibrationOptions o;
  o.model = LensModel::fisheye;
  const auto views = project_views(truth, 30, 0.03, 2);
  const CalibrationResult r = calibrate(views, board, size, o);
  EXPECT_EQ(r.camera.model, CameraModel::fisheye);
  expect_recovered(truth, r, views);
}

TEST(Calibrate, RationalModelAndFlags) {
  const Camera truth = pinhole_truth();
  const auto views = project_views(truth, 15, 0.05, 3);
  CalibrationOptions o;
  o.model = LensModel::rational;
  o.zero_tangential = true;
  o.fix_principal_point = true;
  o.fix_aspect_ratio = true;
  const CalibrationResult r = calibrate(views, board, size, o);
  EXPECT_EQ(r.camera.distortion.p1, 0.0);
  EXPECT_EQ(r.camera.distortion.p2, 0.0);
  EXPECT_DOUBLE_EQ(r.camera.intrinsics.cx, 319.5);
  EXPECT_DOUBLE_EQ(r.camera.intrinsics.cy, 239.5);
  EXPECT_DOUBLE_EQ((*r.camera.stddev)[2], 0.0);
  // K's starting ratio is 1, held: fy = fx although the truth has fy / fx = 1.00625.
  EXPECT_NEAR(r.camera.intrinsics.fy / r.camera.intrinsics.fx, 1.0, 1e-12);
}

TEST(Calibrate, DropsOutlierViewWithReason) {
  auto views = project_views(pinhole_truth(), 30, 0.03, 4);
  std::mt19937 rng(7);
  std::normal_distribution<double> big(0, 3);
  for (auto& p : views[5].corners) {
    const double dx = big(rng), dy = big(rng);
    p += cv::Point2f(float(dx), float(dy));
  }
  const CalibrationResult r = calibrate(views, board, size, radial_only());
  EXPECT_FALSE(r.views[5].used);
  EXPECT_NE(r.views[5].dropped_reason.find("outlier view"), std::string::npos);
  EXPECT_EQ(r.views_used, 29);
  // These views pin the principal point down to 0.24 px (one standard deviation; the 0.5 px
  // bar is for the RecoversPinholeK3 and fisheye sets): here it must lie within three of them.
  ASSERT_TRUE(r.camera.stddev);
  expect_recovered(pinhole_truth(), r, views, 3 * std::max((*r.camera.stddev)[2], (*r.camera.stddev)[3]));
}

TEST(Calibrate, RejectsOutlierCorners) {
  auto views = project_views(pinhole_truth(), 12, 0.1, 5);
  const int moved[][2] = {{0, 3}, {2, 20}, {7, 53}, {9, 30}};
  for (const auto& m : moved) views[m[0]].corners[m[1]] += cv::Point2f(1.5f, -1.5f);
  const CalibrationResult r = calibrate(views, board, size, {});
  for (const auto& m : moved) EXPECT_FALSE(r.views[m[0]].inlier[m[1]]);
  EXPECT_LT(r.corners_dropped, 4 + 12 * 54 / 50);
  CalibrationOptions keep_all;
  keep_all.corner_outlier_sigmas = 0;
  EXPECT_GT(calibrate(views, board, size, keep_all).rms, r.rms);
}

// A point-symmetric board (8x6 inner corners: the colours look the same turned by 180 degrees) lets
// a detector list one camera's corners from the other end. Those pairs are reversed before the
// stereo solve, which then recovers the rig; before, they pulled the baseline off.
TEST(Stereo, CornersListedFromTheOtherEndAreReversed) {
  const BoardSpec symmetric{8, 6, 0.03};
  const Camera left = pinhole_truth();
  Camera right = left;
  right.id = "right";
  Rigid3 right_from_left;
  right_from_left.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(0.05, Eigen::Vector3d::UnitY()));
  right_from_left.translation = {-0.12, 0.002, 0.001};
  const Eigen::Vector3d centre(0.5 * 7 * 0.03, 0.5 * 5 * 0.03, 0);
  std::vector<ViewInput> first, second;
  for (int i = 0; i < 8; ++i) {
    Rigid3 board_in_left;
    board_in_left.rotation =
        Eigen::Quaterniond(Eigen::AngleAxisd(0.4 * std::sin(i), Eigen::Vector3d::UnitX()) *
                           Eigen::AngleAxisd(0.4 * std::cos(1.7 * i), Eigen::Vector3d::UnitY()) *
                           Eigen::AngleAxisd(0.2 * i - 0.7, Eigen::Vector3d::UnitZ()));
    board_in_left.translation =
        Eigen::Vector3d(0.05 * std::cos(i), 0.04 * std::sin(2 * i), 0.6) - board_in_left.rotation * centre;
    ViewInput a{"pair" + std::to_string(i), {}}, b = a;
    for (const cv::Point3f& p : board_points(symmetric)) {
      const Eigen::Vector3d in_left = board_in_left * Eigen::Vector3d(p.x, p.y, p.z);
      Eigen::Vector2d pa, pb;
      ASSERT_TRUE(left.project(in_left, pa) && left.in_image(pa));
      ASSERT_TRUE(right.project(right_from_left * in_left, pb) && right.in_image(pb));
      a.corners.emplace_back(float(pa.x()), float(pa.y()));
      b.corners.emplace_back(float(pb.x()), float(pb.y()));
    }
    if (i == 2 || i == 5) std::reverse(b.corners.begin(), b.corners.end());
    first.push_back(a);
    second.push_back(b);
  }
  const StereoResult r = stereo_calibrate(first, second, symmetric, left, right);
  EXPECT_EQ(r.reversed_orders, 2);
  EXPECT_NEAR(r.baseline, right_from_left.translation.norm(), 1e-4);
  EXPECT_LT((r.second_from_first.translation - right_from_left.translation).norm(), 1e-4);
  EXPECT_LT(r.rms, 0.01);
  // In the order found, nothing is reversed.
  for (int i : {2, 5}) std::reverse(second[i].corners.begin(), second[i].corners.end());
  EXPECT_EQ(stereo_calibrate(first, second, symmetric, left, right).reversed_orders, 0);
}

TEST(Calibrate, TooFewViewsFails) {
  const auto views = project_views(pinhole_truth(), 2, 0.1, 6);
  EXPECT_THROW(calibrate(views, board, size, {}), FailedError);
}

TEST(Calibrate, BoardWarpIsRecovered) {
  // Corners of a board bowed by 1 mm along x, seen by the pinhole truth.
  const Camera truth = pinhole_truth();
  auto flat = project_views(truth, 15, 0.0, 8);
  CalibrationOptions o;
  o.board_warp = true;
  o.corner_outlier_sigmas = 0;
  // Re-project with the warp: recover each view's pose from the flat corners, then bend the board.
  const CalibrationResult poses = calibrate(flat, board, size, o);
  std::vector<ViewInput> bent = flat;
  for (std::size_t i = 0; i < bent.size(); ++i)
    for (int j = 0; j < board.corner_count(); ++j) {
      const cv::Point3f p = board_points(board)[j];
      const double xr = 2.0 * (j % board.cols) / (board.cols - 1) - 1;
      const Eigen::Vector3d q(p.x, p.y, 0.001 * (1 - xr * xr));
      Eigen::Vector2d pixel;
      truth.project(poses.views[i].cam_from_board * q, pixel);
      bent[i].corners[j] = cv::Point2f(float(pixel.x()), float(pixel.y()));
    }
  const CalibrationResult r = calibrate(bent, board, size, o);
  EXPECT_NEAR(r.board_warp[0], 0.001, 1e-5);
  EXPECT_NEAR(r.board_warp[1], 0.0, 1e-5);
  EXPECT_LT(r.rms, 1e-3);
}

TEST(Detect, DegenerateViews) {
  const auto views = project_views(pinhole_truth(), 1, 0.0, 9);
  EXPECT_EQ(degeneracy(views[0].corners, board, size), "");
  auto squashed = views[0].corners;
  for (auto& p : squashed) p.y = 240 + 0.02f * (p.y - 240);  // edge-on
  EXPECT_NE(degeneracy(squashed, board, size), "");
  auto folded = views[0].corners;
  std::swap(folded[0], folded[10]);
  EXPECT_NE(degeneracy(folded, board, size), "");
  auto tiny = views[0].corners;
  for (auto& p : tiny) p = 0.05f * p;
  EXPECT_NE(degeneracy(tiny, board, size), "");
}

TEST(Detect, SubpixWindowFitsInsideTheSquares) {
  EXPECT_EQ(subpix_half_window(4), 2);
  for (double s : {10.0, 20.0, 30.0, 40.0}) EXPECT_LT(2 * subpix_half_window(s) + 1, s);
  EXPECT_EQ(subpix_half_window(1000), 12);
}

// A 4x3-corner board under a strong perspective, each pixel the exact mean of the checker over its
// area (16 x 16 samples): the X-junction fit lands on the true corners from half a pixel away.
TEST(Detect, CornerFitFindsIdealCornersUnderPerspective) {
  const BoardSpec small{4, 3, 1.0};
  cv::Matx33d H(28, 9, 40.3, -6, 24, 37.7, 0.06, 0.03, 1);  // board units -> pixels
  const cv::Matx33d inverse = H.inv();
  cv::Mat image(150, 190, CV_32F);
  const int n = 16;
  for (int y = 0; y < image.rows; ++y)
    for (int x = 0; x < image.cols; ++x) {
      double sum = 0;
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
          const cv::Vec3d q = inverse * cv::Vec3d(x + (i + 0.5) / n - 0.5, y + (j + 0.5) / n - 0.5, 1);
          const double u = q[0] / q[2], v = q[1] / q[2];
          sum += (int(std::floor(u)) + int(std::floor(v))) % 2 == 0 ? 0.9 : 0.1;
        }
      image.at<float>(y, x) = float(sum / (n * n));
    }
  std::vector<cv::Point2f> truth, corners;
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> offset(-0.5f, 0.5f);
  for (int r = 0; r < small.rows; ++r)
    for (int c = 0; c < small.cols; ++c) {
      const cv::Vec3d p = H * cv::Vec3d(c + 1, r + 1, 1);
      truth.emplace_back(float(p[0] / p[2]), float(p[1] / p[2]));
      const float dx = offset(rng), dy = offset(rng);
      corners.push_back(truth.back() + cv::Point2f(dx, dy));
    }
  ASSERT_EQ(fit_corners(image, small, corner_fit_radius(smallest_square(truth, small)), corners),
            small.corner_count());
  for (std::size_t i = 0; i < truth.size(); ++i) EXPECT_LT(cv::norm(corners[i] - truth[i]), 0.01) << i;
}

TEST(LineFit, StraightAndBentGrids) {
  std::vector<cv::Point2f> grid;
  for (int r = 0; r < board.rows; ++r)
    for (int c = 0; c < board.cols; ++c) grid.emplace_back(10.f + 20 * c + 3 * r, 15.f + 20 * r - 2 * c);
  EXPECT_NEAR(line_fit_rms(grid, board), 0.0, 1e-4);
  // Alternate rows shifted +-d across their own direction: each column fit leaves d per corner minus
  // the fitted line's share; compare with the direct computation for one column.
  std::vector<cv::Point2f> zig = grid;
  for (int r = 0; r < board.rows; ++r)
    for (int c = 0; c < board.cols; ++c) zig[r * board.cols + c].x += (r % 2 ? 0.5f : -0.5f);
  EXPECT_GT(line_fit_rms(zig, board), 0.2);
}

TEST(Flatten, AlphaBoundsAndMaps) {
  const Camera truth = pinhole_truth();
  const FlattenMaps inner = flatten_maps(truth, 0.0), outer = flatten_maps(truth, 1.0);
  EXPECT_NEAR(inner.valid_fraction, 1.0, 1e-9);
  EXPECT_LT(outer.valid_fraction, 0.99);
  EXPECT_GT(inner.pinhole.intrinsics.fx, outer.pinhole.intrinsics.fx);
  EXPECT_EQ(inner.pinhole.model, CameraModel::pinhole);
  EXPECT_TRUE(inner.pinhole.distortion.is_zero());
  // alpha 1 keeps every source pixel: the source corners land inside the flattened image.
  for (const Eigen::Vector2d& corner :
       {Eigen::Vector2d(0, 0), Eigen::Vector2d(639, 479), Eigen::Vector2d(0, 479)}) {
    Eigen::Vector2d p;
    outer.pinhole.project(truth.unproject(corner), p);
    EXPECT_TRUE(outer.pinhole.in_image(p, -0.5)) << p.transpose();
  }
  // The map sends each flattened pixel to where the source camera images the same ray.
  const Eigen::Vector2d q(100, 50);
  Eigen::Vector2d source;
  truth.project(inner.pinhole.unproject(q), source);
  EXPECT_NEAR(inner.source_x.at<float>(50, 100), source.x(), 1e-3);
  EXPECT_NEAR(inner.source_y.at<float>(50, 100), source.y(), 1e-3);
  EXPECT_THROW(flatten_maps(truth, 1.5), UsageError);
}

TEST(Flatten, KeepsDepthAndChannels) {
  const FlattenMaps maps = flatten_maps(fisheye_truth(), 0.0);
  for (int type : {CV_8UC1, CV_8UC3, CV_16UC1, CV_32FC3, CV_32FC1}) {
    cv::Mat image(size, type, cv::Scalar::all(type == CV_32FC3 || type == CV_32FC1 ? 2.5 : 1000));
    const cv::Mat out = flatten_image(image, maps);
    EXPECT_EQ(out.type(), type);
    EXPECT_EQ(out.size(), size);
    // alpha 0: every pixel valid, so a constant image stays constant.
    cv::Mat diff;
    cv::absdiff(out, image, diff);
    double worst = 0;
    cv::minMaxLoc(diff.reshape(1), nullptr, &worst);
    EXPECT_LT(worst, 1e-3) << type;
  }
}

}  // namespace

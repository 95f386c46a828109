#include "pg/calib/stereo.h"

#include <algorithm>
#include <array>
#include <limits>
#include <numbers>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <optional>

#include "pg/core/error.h"
#include "pg/core/log.h"

namespace pg::calib {
namespace {

cv::Mat camera_matrix(const Camera& c) {
  return (cv::Mat_<double>(3, 3) << c.intrinsics.fx, 0, c.intrinsics.cx, 0, c.intrinsics.fy, c.intrinsics.cy,
          0, 0, 1);
}

cv::Mat distortion_vector(const Camera& c) {
  const Distortion& d = c.distortion;
  if (c.model == CameraModel::fisheye) return (cv::Mat_<double>(4, 1) << d.k1, d.k2, d.k3, d.k4);
  return (cv::Mat_<double>(8, 1) << d.k1, d.k2, d.p1, d.p2, d.k3, d.k4, d.k5, d.k6);
}

// The rotation from the first camera's frame to the second's that one board position gives, from
// each camera's board pose (intrinsics held); nullopt when a pose cannot be solved.
std::optional<Eigen::Matrix3d> relative_rotation(const std::vector<cv::Point3f>& points,
                                                 const std::vector<cv::Point2f>& first,
                                                 const std::vector<cv::Point2f>& second,
                                                 const Camera& first_camera, const Camera& second_camera) {
  const auto board_rotation = [&](const std::vector<cv::Point2f>& corners,
                                  const Camera& camera) -> std::optional<Eigen::Matrix3d> {
    cv::Mat rvec, tvec, R;
    try {
      bool solved = false;
      if (camera.model == CameraModel::fisheye) {
        std::vector<cv::Point2d> distorted(corners.begin(), corners.end()), normalised;
        cv::fisheye::undistortPoints(distorted, normalised, camera_matrix(camera), distortion_vector(camera));
        std::vector<cv::Point2f> rays(normalised.begin(), normalised.end());
        solved = cv::solvePnP(points, rays, cv::Mat::eye(3, 3, CV_64F), cv::Mat(), rvec, tvec);
      } else {
        solved = cv::solvePnP(points, corners, camera_matrix(camera), distortion_vector(camera), rvec, tvec);
      }
      if (!solved) return std::nullopt;
    } catch (const cv::Exception&) {
      return std::nullopt;
    }
    cv::Rodrigues(rvec, R);
    Eigen::Matrix3d rotation;
    cv::cv2eigen(R, rotation);
    return rotation;
  };
  const auto a = board_rotation(first, first_camera), b = board_rotation(second, second_camera);
  if (!a || !b) return std::nullopt;
  return Eigen::Matrix3d(*b * a->transpose());
}

double angle_between(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return Eigen::AngleAxisd(a.transpose() * b).angle();
}

// The detectors may list a board's corners from either end (180 degrees apart: certain for a
// point-symmetric board, whose colours do not say which end is first), and the two cameras need not
// agree. Listing corner k as N-1-k turns the board about its centre, so for each pair the second
// view's order, as found or reversed, is the one whose relative rotation agrees with the most pairs.
// Returns how many second views were reversed.
int reconcile_corner_order(const std::vector<cv::Point3f>& points, const std::vector<ViewInput>& first,
                           std::vector<std::vector<cv::Point2f>>& second, const Camera& first_camera,
                           const Camera& second_camera) {
  const std::size_t n = first.size();
  std::vector<std::array<std::optional<Eigen::Matrix3d>, 2>> candidates(n);
  for (std::size_t i = 0; i < n; ++i) {
    std::vector<cv::Point2f> reversed(second[i].rbegin(), second[i].rend());
    candidates[i][0] = relative_rotation(points, first[i].corners, second[i], first_camera, second_camera);
    candidates[i][1] = relative_rotation(points, first[i].corners, reversed, first_camera, second_camera);
  }
  constexpr double agree = 10 * std::numbers::pi / 180;
  const auto nearest = [&](std::size_t j, const Eigen::Matrix3d& r) {
    double best = std::numeric_limits<double>::infinity();
    int side = 0;
    for (int s = 0; s < 2; ++s)
      if (const double angle = candidates[j][s] ? angle_between(*candidates[j][s], r) : best; angle < best) {
        best = angle;
        side = s;
      }
    return std::pair{best, side};
  };
  // The candidate most pairs agree with (the first found, in order, on a tie: the orders as found).
  std::optional<Eigen::Matrix3d> reference;
  std::size_t most = 0;
  for (int s = 0; s < 2; ++s)
    for (std::size_t i = 0; i < n; ++i) {
      if (!candidates[i][s]) continue;
      std::size_t support = 0;
      for (std::size_t j = 0; j < n; ++j) support += nearest(j, *candidates[i][s]).first < agree;
      if (support > most) {
        most = support;
        reference = candidates[i][s];
      }
    }
  if (!reference) return 0;
  int reversed = 0;
  for (std::size_t i = 0; i < n; ++i)
    if (const auto [distance, side] = nearest(i, *reference); side == 1 && distance < agree) {
      std::reverse(second[i].begin(), second[i].end());
      log::info("stereo: ", first[i].name,
                ": the second camera's corners were listed from the other end; reversed");
      ++reversed;
    }
  return reversed;
}

}  // namespace

StereoResult stereo_calibrate(const std::vector<ViewInput>& first, const std::vector<ViewInput>& second,
                              const BoardSpec& board, const Camera& first_camera,
                              const Camera& second_camera) {
  if (first.size() != second.size()) throw FailedError("stereo views are not paired one to one");
  if (first.size() < 3) throw FailedError(str("only ", first.size(), " stereo pairs; at least 3 are needed"));
  if (first_camera.model != second_camera.model)
    throw FailedError("the two stereo cameras must use the same lens model");
  const std::vector<cv::Point3f> points = board_points(board);
  std::vector<std::vector<cv::Point3f>> object(first.size(), points);
  std::vector<std::vector<cv::Point2f>> a, b;
  for (std::size_t i = 0; i < first.size(); ++i) {
    a.push_back(first[i].corners);
    b.push_back(second[i].corners);
  }
  const int reversed = reconcile_corner_order(points, first, b, first_camera, second_camera);
  cv::Mat K1 = camera_matrix(first_camera), D1 = distortion_vector(first_camera);
  cv::Mat K2 = camera_matrix(second_camera), D2 = distortion_vector(second_camera);
  cv::Mat R, T, E, F;
  const cv::Size size(first_camera.width, first_camera.height);
  const cv::TermCriteria criteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 100, 1e-12);
  StereoResult result;
  try {
    if (first_camera.model == CameraModel::fisheye) {
      std::vector<std::vector<cv::Point3d>> object_d(first.size(), {points.begin(), points.end()});
      std::vector<std::vector<cv::Point2d>> a_d, b_d;
      for (std::size_t i = 0; i < first.size(); ++i) {
        a_d.emplace_back(a[i].begin(), a[i].end());
        b_d.emplace_back(b[i].begin(), b[i].end());
      }
      result.rms = cv::fisheye::stereoCalibrate(object_d, a_d, b_d, K1, D1, K2, D2, size, R, T,
                                                cv::fisheye::CALIB_FIX_INTRINSIC, criteria);
    } else {
      result.rms = cv::stereoCalibrate(object, a, b, K1, D1, K2, D2, size, R, T, E, F,
                                       cv::CALIB_FIX_INTRINSIC, criteria);
    }
  } catch (const cv::Exception& e) {
    throw FailedError("OpenCV could not calibrate the stereo pair: " + e.err);
  }
  Eigen::Matrix3d rotation;
  Eigen::Vector3d translation;
  cv::cv2eigen(R, rotation);
  cv::cv2eigen(T, translation);
  result.second_from_first.rotation = Eigen::Quaterniond(rotation).normalized();
  result.second_from_first.translation = translation;
  result.baseline = translation.norm();
  result.pairs = int(first.size());
  result.reversed_orders = reversed;
  return result;
}

}  // namespace pg::calib

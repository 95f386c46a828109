#include "pg/calib/stereo.h"

#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

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
  return result;
}

}  // namespace pg::calib

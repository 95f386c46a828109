#include "pg/sfm/board_scale.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <opencv2/calib3d.hpp>

#include "pg/calib/detect.h"
#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/image/image_io.h"

namespace pg {
namespace {

double median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

// The board centre in the camera frame, in metres, from PnP on the undistorted corner rays.
std::optional<Eigen::Vector3d> board_centre_in_camera(const Camera& camera, const cv::Mat& image,
                                                      const calib::BoardSpec& board) {
  const calib::Detection detection = calib::detect_board(image, board);
  if (!detection.found) return std::nullopt;
  std::vector<cv::Point2d> normalised;
  for (const cv::Point2f& corner : detection.corners) {
    const Eigen::Vector3d ray = camera.unproject({corner.x, corner.y});
    if (!(ray.z() > 1e-6)) return std::nullopt;
    normalised.emplace_back(ray.x() / ray.z(), ray.y() / ray.z());
  }
  std::vector<cv::Point3d> object;
  for (const cv::Point3f& p : calib::board_points(board)) object.emplace_back(p.x, p.y, p.z);
  cv::Mat rvec, tvec;
  if (!cv::solvePnP(object, normalised, cv::Mat::eye(3, 3, CV_64F), cv::noArray(), rvec, tvec, false,
                    cv::SOLVEPNP_IPPE))
    return std::nullopt;
  cv::solvePnPRefineLM(object, normalised, cv::Mat::eye(3, 3, CV_64F), cv::noArray(), rvec, tvec);
  cv::Mat rotation;
  cv::Rodrigues(rvec, rotation);
  const cv::Point3d centre_on_board((board.cols - 1) * board.square_size / 2,
                                    (board.rows - 1) * board.square_size / 2, 0);
  const cv::Mat centre = rotation * cv::Mat(centre_on_board) + tvec;
  return Eigen::Vector3d(centre.at<double>(0), centre.at<double>(1), centre.at<double>(2));
}

}  // namespace

BoardScale scale_from_board(const std::vector<Camera>& cameras,
                            const std::vector<std::filesystem::path>& images, const calib::BoardSpec& board) {
  board.check();
  if (cameras.size() != images.size()) throw UsageError("scale_from_board: one image per camera");
  std::vector<std::size_t> seen;
  std::vector<Eigen::Vector3d> metric;  // board centre in each camera frame, metres
  for (std::size_t i = 0; i < cameras.size(); ++i) {
    if (auto centre = board_centre_in_camera(cameras[i], read_image(images[i]), board)) {
      seen.push_back(i);
      metric.push_back(*centre);
    }
  }
  if (seen.size() < 2)
    throw FailedError(str("--scale-board: the ", board.cols, "x", board.rows, " board was found in ",
                          seen.size(), " registered image(s); at least 2 are needed"));
  // Least-squares intersection of the rays from each camera centre towards the board centre.
  Eigen::Matrix3d normal = Eigen::Matrix3d::Zero();
  Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3d> centres, directions;
  for (std::size_t k = 0; k < seen.size(); ++k) {
    const Rigid3& pose = cameras[seen[k]].cam_from_world;
    const Eigen::Vector3d c = pose.centre();
    const Eigen::Vector3d d = (pose.rotation.conjugate() * metric[k]).normalized();
    const Eigen::Matrix3d across = Eigen::Matrix3d::Identity() - d * d.transpose();
    normal += across;
    rhs += across * c;
    centres.push_back(c);
    directions.push_back(d);
  }
  // Rays within a degree of parallel leave the centre's depth undetermined.
  double widest = 0;
  for (const auto& a : directions)
    for (const auto& b : directions) widest = std::max(widest, std::acos(std::clamp(a.dot(b), -1.0, 1.0)));
  if (widest < M_PI / 180)
    throw FailedError("--scale-board: the views of the board are too close together to triangulate it");
  const Eigen::Vector3d centre_world = normal.ldlt().solve(rhs);

  BoardScale result;
  std::vector<double> ratios;
  for (std::size_t k = 0; k < seen.size(); ++k) {
    const double units = (centre_world - centres[k]).norm();
    if (units > 0) ratios.push_back(metric[k].norm() / units);
    result.used.push_back(cameras[seen[k]].id);
  }
  result.metres_per_unit = median(ratios);
  std::vector<double> deviation;
  for (double r : ratios) deviation.push_back(std::abs(r - result.metres_per_unit));
  result.relative_spread = median(deviation) / result.metres_per_unit;
  result.views = static_cast<int>(seen.size());
  return result;
}

}  // namespace pg

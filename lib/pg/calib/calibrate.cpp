#include "pg/calib/calibrate.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <opencv2/calib3d.hpp>
#include <optional>

#include "pg/calib/projection.h"
#include "pg/calib/refine.h"
#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/core/run_report.h"

namespace pg::calib {

LensModel lens_model_from_string(const std::string& name) {
  if (name == "pinhole-k3") return LensModel::pinhole_k3;
  if (name == "rational") return LensModel::rational;
  if (name == "fisheye") return LensModel::fisheye;
  throw UsageError("unknown lens model \"" + name + "\" (expected pinhole-k3, rational or fisheye)");
}

std::string to_string(LensModel model) {
  switch (model) {
    case LensModel::pinhole_k3:
      return "pinhole-k3";
    case LensModel::rational:
      return "rational";
    case LensModel::fisheye:
      return "fisheye";
  }
  return "pinhole-k3";
}

int min_views(LensModel model) {
  return model == LensModel::rational ? 4 : 3;
}

namespace {

Camera camera_from_opencv(LensModel model, const cv::Mat& K, const cv::Mat& D, cv::Size size) {
  Camera camera;
  camera.id = "camera";
  camera.width = size.width;
  camera.height = size.height;
  camera.model = model == LensModel::fisheye ? CameraModel::fisheye : CameraModel::pinhole;
  camera.intrinsics = {K.at<double>(0, 0), K.at<double>(1, 1), K.at<double>(0, 2), K.at<double>(1, 2)};
  const auto d = [&](int i) { return i < int(D.total()) ? D.at<double>(i) : 0.0; };
  if (model == LensModel::fisheye)
    camera.distortion = {.k1 = d(0), .k2 = d(1), .k3 = d(2), .k4 = d(3)};
  else
    camera.distortion = {d(0), d(1), d(2), d(3), d(4), d(5), d(6), d(7)};
  return camera;
}

}  // namespace

OpenCvCalibration opencv_calibrate(const std::vector<ViewInput>& views, const BoardSpec& board,
                                   cv::Size image_size, const CalibrationOptions& options) {
  const std::vector<cv::Point3f> points = board_points(board);
  std::vector<std::vector<cv::Point3f>> object(views.size(), points);
  std::vector<std::vector<cv::Point2f>> image;
  for (const ViewInput& v : views) image.push_back(v.corners);
  OpenCvCalibration out;
  cv::Mat K = cv::Mat::eye(3, 3, CV_64F), D;
  const cv::TermCriteria criteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 100, 1e-12);
  try {
    if (options.model == LensModel::fisheye) {
      int flags = cv::fisheye::CALIB_RECOMPUTE_EXTRINSIC | cv::fisheye::CALIB_FIX_SKEW;
      if (options.fix_principal_point) flags |= cv::fisheye::CALIB_FIX_PRINCIPAL_POINT;
      std::vector<std::vector<cv::Point3d>> object_d;
      std::vector<std::vector<cv::Point2d>> image_d;
      for (std::size_t i = 0; i < views.size(); ++i) {
        object_d.emplace_back(points.begin(), points.end());
        image_d.emplace_back(image[i].begin(), image[i].end());
      }
      D = cv::Mat::zeros(4, 1, CV_64F);
      cv::fisheye::calibrate(object_d, image_d, image_size, K, D, out.rvecs, out.tvecs, flags, criteria);
    } else {
      int flags = 0;
      if (options.model == LensModel::rational) flags |= cv::CALIB_RATIONAL_MODEL;
      if (options.fix_aspect_ratio) flags |= cv::CALIB_FIX_ASPECT_RATIO;  // K's fx/fy = 1 is the ratio kept
      if (options.fix_principal_point) flags |= cv::CALIB_FIX_PRINCIPAL_POINT;
      if (options.zero_tangential) flags |= cv::CALIB_ZERO_TANGENT_DIST;
      cv::calibrateCamera(object, image, image_size, K, D, out.rvecs, out.tvecs, flags, criteria);
    }
  } catch (const cv::Exception& e) {
    throw FailedError(str("OpenCV could not calibrate the ", to_string(options.model), " model: ", e.err));
  }
  out.camera = camera_from_opencv(options.model, K, D, image_size);
  // RMS per corner, as cv::calibrateCamera reports it, computed the same way for both model families.
  double sum = 0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < views.size(); ++i) {
    std::vector<cv::Point2f> projected;
    if (options.model == LensModel::fisheye)
      cv::fisheye::projectPoints(points, projected, out.rvecs[i], out.tvecs[i], K, D);
    else
      cv::projectPoints(points, out.rvecs[i], out.tvecs[i], K, D, projected);
    for (std::size_t j = 0; j < projected.size(); ++j, ++n) {
      const cv::Point2f d = projected[j] - image[i][j];
      sum += double(d.x) * d.x + double(d.y) * d.y;
    }
  }
  out.rms = n ? std::sqrt(sum / double(n)) : 0;
  return out;
}

namespace {

// cv::fisheye::calibrate fails on some strongly tilted views (its homography start). Then: OpenCV's
// pinhole estimate of fx, fy, cx, cy, equidistant poses from solvePnP, polished by our refinement.
OpenCvCalibration fisheye_fallback(const std::vector<ViewInput>& views, const BoardSpec& board, cv::Size size,
                                   const CalibrationOptions& options) {
  CalibrationOptions pinhole = options;
  pinhole.model = LensModel::pinhole_k3;
  OpenCvCalibration start = opencv_calibrate(views, board, size, pinhole);
  start.camera.model = CameraModel::fisheye;
  start.camera.distortion = {};
  const Intrinsics& k = start.camera.intrinsics;
  const cv::Mat K = (cv::Mat_<double>(3, 3) << k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1);
  for (std::size_t i = 0; i < views.size(); ++i) {
    std::vector<cv::Point2f> normalised;
    cv::fisheye::undistortPoints(views[i].corners, normalised, K, cv::Mat::zeros(4, 1, CV_64F));
    cv::solvePnP(board_points(board), normalised, cv::Mat::eye(3, 3, CV_64F), cv::noArray(), start.rvecs[i],
                 start.tvecs[i]);
  }
  CalibrationOptions polish = options;
  polish.refine = true;
  polish.corner_outlier_sigmas = 0;
  polish.board_warp = false;
  const RefineOutput refined = refine(views, board, start, polish);
  OpenCvCalibration out;
  out.camera = refined.camera;
  out.camera.stddev.reset();
  out.rms = refined.rms;
  for (const Rigid3& pose : refined.cam_from_board) {
    const Eigen::AngleAxisd aa(pose.rotation);
    const Eigen::Vector3d r = aa.angle() * aa.axis();
    out.rvecs.push_back((cv::Mat_<double>(3, 1) << r.x(), r.y(), r.z()));
    out.tvecs.push_back(
        (cv::Mat_<double>(3, 1) << pose.translation.x(), pose.translation.y(), pose.translation.z()));
  }
  return out;
}

// The view-level loop: calibrate with OpenCV, drop the worst view while its RMS is above the threshold.
struct Initial {
  OpenCvCalibration cv;
  std::vector<int> used;  // indices into the input views
};

std::vector<double> view_rms(const std::vector<ViewInput>& views, const std::vector<int>& used,
                             const BoardSpec& board, const OpenCvCalibration& cal, LensModel model) {
  RefineState state = refine_state_from_opencv(cal, model, board, used.size());
  std::vector<double> rms;
  for (std::size_t i = 0; i < used.size(); ++i) {
    double sum = 0;
    for (const Eigen::Vector2d& r : corner_residuals(state, model, board, views[used[i]].corners, i))
      sum += r.squaredNorm();
    rms.push_back(std::sqrt(sum / board.corner_count()));
  }
  return rms;
}

// Median view RMS above which an initial estimate is taken as failed rather than hurt by outlier views.
constexpr double kFailedFitMedianRms = 1.0;

double median_of(std::vector<double> values) {
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return values[values.size() / 2];
}

Initial initial_calibration(const std::vector<ViewInput>& views, const BoardSpec& board, cv::Size size,
                            const CalibrationOptions& options, std::vector<ViewResult>& results) {
  Initial init;
  for (int i = 0; i < int(views.size()); ++i) init.used.push_back(i);
  const int needed = min_views(options.model);
  for (;;) {
    if (int(init.used.size()) < needed)
      throw FailedError(str("only ", init.used.size(), " usable views; the ", to_string(options.model),
                            " model needs at least ", needed));
    std::vector<ViewInput> subset;
    for (int i : init.used) subset.push_back(views[i]);
    try {
      init.cv = opencv_calibrate(subset, board, size, options);
    } catch (const FailedError& e) {
      if (options.model != LensModel::fisheye) throw;
      log::info(e.what(), "; starting from the pinhole estimate instead");
      init.cv = fisheye_fallback(subset, board, size, options);
    }
    std::vector<double> rms = view_rms(views, init.used, board, init.cv, options.model);
    double median = median_of(rms);
    // A median view off by pixels means OpenCV's fisheye fit itself went astray (its homography start
    // fails on strongly tilted boards), not that one view is bad: start from the pinhole estimate.
    if (options.model == LensModel::fisheye && median > kFailedFitMedianRms) {
      log::info("OpenCV's fisheye estimate is off (median view RMS ", median,
                " px); starting from the pinhole estimate instead");
      init.cv = fisheye_fallback(subset, board, size, options);
      rms = view_rms(views, init.used, board, init.cv, options.model);
      median = median_of(rms);
    }
    const double threshold =
        options.max_view_rms > 0 ? options.max_view_rms : std::max(0.5, options.view_rms_factor * median);
    const auto worst = std::max_element(rms.begin(), rms.end());
    if (*worst <= threshold || int(init.used.size()) <= needed) break;
    const int dropped = init.used[worst - rms.begin()];
    results[dropped].used = false;
    results[dropped].rms = *worst;
    results[dropped].dropped_reason = str("outlier view: RMS ", *worst, " px above the threshold ", threshold,
                                          " px (median view RMS ", median, " px)");
    log::warn(views[dropped].name, ": dropped, ", results[dropped].dropped_reason);
    init.used.erase(init.used.begin() + (worst - rms.begin()));
  }
  return init;
}

}  // namespace

CalibrationResult calibrate(const std::vector<ViewInput>& views, const BoardSpec& board, cv::Size image_size,
                            const CalibrationOptions& options) {
  board.check();
  for (const ViewInput& v : views)
    if (int(v.corners.size()) != board.corner_count())
      throw FailedError(
          str(v.name, ": ", v.corners.size(), " corners, the board has ", board.corner_count()));
  CalibrationResult result;
  for (const ViewInput& v : views) {
    ViewResult view;
    view.name = v.name;
    result.views.push_back(view);
  }

  // Wall-clock phases go to the run report (--report), never into the calibration file, whose
  // contents must be a function of the inputs alone.
  std::optional<ScopedTimer> timer(std::in_place, "calibration_opencv_estimate");
  Initial init = initial_calibration(views, board, image_size, options, result.views);
  timer.reset();
  result.opencv_rms = init.cv.rms;
  log::info("OpenCV estimate on ", init.used.size(), " views: RMS ", init.cv.rms, " px, fx ",
            init.cv.camera.intrinsics.fx);

  std::vector<ViewInput> used_views;
  for (int i : init.used) used_views.push_back(views[i]);
  timer.emplace("calibration_refine");
  RefineOutput refined = refine(used_views, board, init.cv, options);
  timer.reset();

  result.camera = refined.camera;
  result.rms = refined.rms;
  result.board_warp = refined.board_warp;
  result.uncertainty = refined.uncertainty;
  result.views_used = int(init.used.size());
  for (std::size_t i = 0; i < init.used.size(); ++i) {
    ViewResult& v = result.views[init.used[i]];
    v.cam_from_board = refined.cam_from_board[i];
    v.residuals = refined.residuals[i];
    v.inlier = refined.inlier[i];
    double sum = 0;
    int n = 0;
    for (std::size_t j = 0; j < v.residuals.size(); ++j) {
      if (!v.inlier[j]) {
        ++v.corners_dropped;
        continue;
      }
      sum += v.residuals[j].squaredNorm();
      ++n;
    }
    v.rms = n ? std::sqrt(sum / n) : 0;
    result.corners_used += n;
    result.corners_dropped += v.corners_dropped;
  }
  return result;
}

Eigen::Vector2d distortion_displacement(const Camera& camera, const Eigen::Vector2d& pixel) {
  const Eigen::Vector3d ray = camera.unproject(pixel);
  Eigen::Vector2d distorted;
  camera.project(ray, distorted);
  const Intrinsics& k = camera.intrinsics;
  Eigen::Vector2d ideal;
  if (camera.model == CameraModel::fisheye) {
    // The undistorted fisheye is the plain equidistant projection r = f theta.
    const double r = std::hypot(ray.x(), ray.y());
    const double scale = r > 1e-12 ? std::atan2(r, ray.z()) / r : 1.0 / ray.z();
    ideal = {k.fx * ray.x() * scale + k.cx, k.fy * ray.y() * scale + k.cy};
  } else {
    ideal = {k.fx * ray.x() / ray.z() + k.cx, k.fy * ray.y() / ray.z() + k.cy};
  }
  return distorted - ideal;
}

double line_fit_rms(const std::vector<cv::Point2f>& corners, const BoardSpec& board) {
  double sum = 0;
  int n = 0;
  const auto fit = [&](const std::vector<Eigen::Vector2d>& points) {
    Eigen::Vector2d mean = Eigen::Vector2d::Zero();
    for (const auto& p : points) mean += p;
    mean /= double(points.size());
    Eigen::Matrix2d scatter = Eigen::Matrix2d::Zero();
    for (const auto& p : points) scatter += (p - mean) * (p - mean).transpose();
    // Total least squares: the smallest eigenvalue is the sum of squared distances to the line.
    sum += std::max(0.0, Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(scatter).eigenvalues()(0));
    n += int(points.size());
  };
  for (int r = 0; r < board.rows; ++r) {
    std::vector<Eigen::Vector2d> row;
    for (int c = 0; c < board.cols; ++c)
      row.emplace_back(corners[r * board.cols + c].x, corners[r * board.cols + c].y);
    fit(row);
  }
  for (int c = 0; c < board.cols; ++c) {
    std::vector<Eigen::Vector2d> column;
    for (int r = 0; r < board.rows; ++r)
      column.emplace_back(corners[r * board.cols + c].x, corners[r * board.cols + c].y);
    fit(column);
  }
  return std::sqrt(sum / n);
}

}  // namespace pg::calib

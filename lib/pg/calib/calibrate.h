#pragma once
// Single-camera calibration from checkerboard corners: OpenCV's estimate, iterative rejection of
// outlier views, then our own Ceres refinement with per-corner outlier rejection, an optional
// board-flatness (warp) term, parameter standard deviations and projection uncertainty.
#include <Eigen/Core>
#include <array>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "pg/calib/board.h"
#include "pg/camera/camera.h"
#include "pg/geometry/rigid.h"

namespace pg::calib {

enum class LensModel {
  pinhole_k3,  // k1 k2 p1 p2 k3 (OpenCV's 5 coefficients)
  rational,    // k1 k2 p1 p2 k3 k4 k5 k6
  fisheye,     // equidistant k1..k4 (cv::fisheye)
};
LensModel lens_model_from_string(const std::string& name);  // "pinhole-k3", "rational", "fisheye"
std::string to_string(LensModel model);
// The fewest usable views each model is calibrated from.
int min_views(LensModel model);

struct CalibrationOptions {
  LensModel model = LensModel::pinhole_k3;
  bool fix_aspect_ratio = false;     // fy = fx
  bool fix_principal_point = false;  // cx, cy at the image centre ((w - 1) / 2, (h - 1) / 2)
  bool zero_tangential = false;      // p1 = p2 = 0
  // Views whose RMS exceeds this are dropped one at a time, worst first (0: automatic, the larger of
  // 0.5 px and view_rms_factor x the median view RMS).
  double max_view_rms = 0;
  double view_rms_factor = 3;
  bool refine = true;  // our Ceres refinement after OpenCV's estimate
  // Corners whose residual exceeds this many robust standard deviations (and 0.1 px) are dropped
  // (0: keep all).
  double corner_outlier_sigmas = 3;
  bool board_warp = false;  // model the board as a shallow paraboloid in x and y (2 parameters)
};

struct ViewInput {
  std::string name;                  // image file name, for messages and the report
  std::vector<cv::Point2f> corners;  // row-major, board.corner_count() of them
};

struct ViewResult {
  std::string name;
  bool used = true;
  std::string dropped_reason;              // why the view was left out
  double rms = 0;                          // px, over the view's inlier corners
  int corners_dropped = 0;                 // corners rejected as outliers
  Rigid3 cam_from_board;                   // for used views
  std::vector<Eigen::Vector2d> residuals;  // observed - projected, px, every corner (used views)
  std::vector<char> inlier;                // per corner
};

// Standard deviation of the projection of a point at infinity seen at `pixel`, from the intrinsics'
// covariance (largest axis of the 1-sigma ellipse).
struct ProjectionUncertainty {
  std::string where;  // "centre", "top-left", ...
  Eigen::Vector2d pixel;
  double stddev_px = 0;
};

struct CalibrationResult {
  Camera camera;          // id "camera", identity pose, stddev filled when refined
  double rms = 0;         // px per corner over inlier corners of used views
  double opencv_rms = 0;  // OpenCV's estimate on the same views, all corners
  int views_used = 0;
  int corners_used = 0;
  int corners_dropped = 0;
  std::array<double, 2> board_warp{0, 0};  // metres, peak deflection along x and y
  std::vector<ViewResult> views;           // in input order
  std::vector<ProjectionUncertainty> uncertainty;
};

// Throws FailedError when fewer than min_views(model) views remain or OpenCV cannot initialise.
CalibrationResult calibrate(const std::vector<ViewInput>& views, const BoardSpec& board, cv::Size image_size,
                            const CalibrationOptions& options);

// OpenCV's cv::calibrateCamera (or cv::fisheye::calibrate) alone on the same corners: its camera and
// RMS (px per corner), for the benchmark and the report.
struct OpenCvCalibration {
  Camera camera;
  double rms = 0;
  std::vector<cv::Mat> rvecs, tvecs;
};
OpenCvCalibration opencv_calibrate(const std::vector<ViewInput>& views, const BoardSpec& board,
                                   cv::Size image_size, const CalibrationOptions& options);

// Displacement from the ideal pinhole projection (same fx, fy, cx, cy) to the distorted pixel, for the
// ray seen at `pixel`: distorted - undistorted, px. Zero for an undistorted camera.
Eigen::Vector2d distortion_displacement(const Camera& camera, const Eigen::Vector2d& pixel);

// RMS distance (px) of the corners from lines fitted to each board row and column: how straight
// the board's straight lines are in an image.
double line_fit_rms(const std::vector<cv::Point2f>& corners, const BoardSpec& board);

}  // namespace pg::calib

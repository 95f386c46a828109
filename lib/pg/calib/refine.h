#pragma once
// Our refinement of OpenCV's estimate (used by calibrate()): a Ceres bundle over the intrinsics, one
// pose per view and an optional board warp, with per-corner outlier rejection, the intrinsics'
// covariance and the projection uncertainty it implies.
#include <Eigen/Core>
#include <array>
#include <vector>

#include "pg/calib/calibrate.h"

namespace pg::calib {

struct RefineState {
  std::array<double, 12> intrinsics{};       // Camera::stddev order
  double fixed_aspect = 0;                   // fy / fx when the aspect ratio is held, else 0
  std::vector<std::array<double, 6>> poses;  // angle-axis, translation: cam_from_board
  std::array<double, 2> warp{0, 0};
};

RefineState refine_state_from_opencv(const OpenCvCalibration& cal, LensModel model, const BoardSpec& board,
                                     std::size_t views);

// observed - projected, px, for every corner of view `view`.
std::vector<Eigen::Vector2d> corner_residuals(const RefineState& state, LensModel model,
                                              const BoardSpec& board, const std::vector<cv::Point2f>& corners,
                                              std::size_t view);

struct RefineOutput {
  Camera camera;
  double rms = 0;
  std::array<double, 2> board_warp{0, 0};
  std::vector<Rigid3> cam_from_board;
  std::vector<std::vector<Eigen::Vector2d>> residuals;
  std::vector<std::vector<char>> inlier;
  std::vector<ProjectionUncertainty> uncertainty;
};

// Without options.refine the OpenCV estimate is kept; its covariance and uncertainty are still given.
RefineOutput refine(const std::vector<ViewInput>& views, const BoardSpec& board,
                    const OpenCvCalibration& init, const CalibrationOptions& options);

}  // namespace pg::calib

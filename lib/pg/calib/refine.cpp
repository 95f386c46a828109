#include "pg/calib/refine.h"

#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

#include "pg/calib/projection.h"
#include "pg/core/error.h"
#include "pg/core/log.h"

namespace pg::calib {
namespace {

using detail::intrinsic_count;

// Board corner (x, y) in metres with its position (xr, yr) in [-1, 1] across the board, for the warp:
// the board bulges by warp[0] (1 - xr^2) + warp[1] (1 - yr^2) along its normal (as mrcal models it).
struct BoardCorner {
  double x, y, xr, yr;
};

BoardCorner board_corner(const BoardSpec& board, int index) {
  const int c = index % board.cols, r = index / board.cols;
  return {c * board.square_size, r * board.square_size, 2.0 * c / (board.cols - 1) - 1,
          2.0 * r / (board.rows - 1) - 1};
}

template <class T>
void project_corner(LensModel model, const T* intrinsics, double fixed_aspect, const T* pose, const T* warp,
                    const BoardCorner& corner, T* pixel) {
  const T on_board[3] = {T(corner.x), T(corner.y),
                         warp[0] * (1 - corner.xr * corner.xr) + warp[1] * (1 - corner.yr * corner.yr)};
  T in_camera[3];
  ceres::AngleAxisRotatePoint(pose, on_board, in_camera);
  for (int i = 0; i < 3; ++i) in_camera[i] += pose[3 + i];
  detail::project(model, intrinsics, fixed_aspect, in_camera, pixel);
}

struct CornerCost {
  LensModel model;
  double fixed_aspect;
  BoardCorner corner;
  double u, v;

  template <class T>
  bool operator()(const T* intrinsics, const T* pose, const T* warp, T* residual) const {
    T pixel[2];
    project_corner(model, intrinsics, fixed_aspect, pose, warp, corner, pixel);
    residual[0] = T(u) - pixel[0];
    residual[1] = T(v) - pixel[1];
    return true;
  }

  static ceres::CostFunction* create(LensModel model, double fixed_aspect, const BoardCorner& corner,
                                     cv::Point2f observed) {
    return new ceres::AutoDiffCostFunction<CornerCost, 2, intrinsic_count, 6, 2>(
        new CornerCost{model, fixed_aspect, corner, observed.x, observed.y});
  }
};

std::vector<int> held_intrinsics(const CalibrationOptions& options) {
  using namespace detail;
  std::vector<int> held;
  if (options.fix_aspect_ratio) held.push_back(fy);
  if (options.fix_principal_point) held.insert(held.end(), {cx, cy});
  if (options.zero_tangential || options.model == LensModel::fisheye) held.insert(held.end(), {p1, p2});
  if (options.model == LensModel::pinhole_k3) held.insert(held.end(), {k4, k5, k6});
  if (options.model == LensModel::fisheye) held.insert(held.end(), {k5, k6});
  std::sort(held.begin(), held.end());
  return held;
}

Camera camera_from_state(const RefineState& s, LensModel model, int width, int height) {
  using namespace detail;
  const auto& in = s.intrinsics;
  Camera camera;
  camera.id = "camera";
  camera.width = width;
  camera.height = height;
  camera.model = model == LensModel::fisheye ? CameraModel::fisheye : CameraModel::pinhole;
  camera.intrinsics = {in[fx], s.fixed_aspect > 0 ? in[fx] * s.fixed_aspect : in[fy], in[cx], in[cy]};
  camera.distortion = {in[k1], in[k2], in[p1], in[p2], in[k3], in[k4], in[k5], in[k6]};
  return camera;
}

Rigid3 rigid_from_pose(const std::array<double, 6>& pose) {
  const Eigen::Vector3d axis(pose[0], pose[1], pose[2]);
  const double angle = axis.norm();
  Rigid3 r;
  if (angle > 0) r.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(angle, axis / angle));
  r.translation = {pose[3], pose[4], pose[5]};
  return r;
}

// Largest-axis standard deviation of the projection of the point at infinity seen at each probe pixel.
std::vector<ProjectionUncertainty> projection_uncertainty(const RefineState& s, LensModel model,
                                                          const Camera& camera,
                                                          const Eigen::Matrix<double, 12, 12>& covariance) {
  const double w = camera.width - 1, h = camera.height - 1;
  const std::vector<std::pair<std::string, Eigen::Vector2d>> probes = {{"centre", {w / 2, h / 2}},
                                                                       {"top-left", {0, 0}},
                                                                       {"top-right", {w, 0}},
                                                                       {"bottom-left", {0, h}},
                                                                       {"bottom-right", {w, h}}};
  std::vector<ProjectionUncertainty> out;
  for (const auto& [where, pixel] : probes) {
    const Eigen::Vector3d ray = camera.unproject(pixel);
    Eigen::Matrix<double, 2, 12> J = Eigen::Matrix<double, 2, 12>::Zero();
    for (int i = 0; i < intrinsic_count; ++i) {
      const double step = 1e-6 * std::max(1.0, std::abs(s.intrinsics[i]));
      std::array<double, 12> plus = s.intrinsics, minus = s.intrinsics;
      plus[i] += step;
      minus[i] -= step;
      double a[2], b[2];
      detail::project(model, plus.data(), s.fixed_aspect, ray.data(), a);
      detail::project(model, minus.data(), s.fixed_aspect, ray.data(), b);
      J(0, i) = (a[0] - b[0]) / (2 * step);
      J(1, i) = (a[1] - b[1]) / (2 * step);
    }
    const Eigen::Matrix2d C = J * covariance * J.transpose();
    const double largest = Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(C).eigenvalues()(1);
    out.push_back({where, pixel, std::sqrt(std::max(0.0, largest))});
  }
  return out;
}

}  // namespace

RefineState refine_state_from_opencv(const OpenCvCalibration& cal, LensModel model, const BoardSpec& board,
                                     std::size_t views) {
  (void)board;
  using namespace detail;
  RefineState s;
  const Camera& c = cal.camera;
  const Distortion& d = c.distortion;
  s.intrinsics = {c.intrinsics.fx,
                  c.intrinsics.fy,
                  c.intrinsics.cx,
                  c.intrinsics.cy,
                  d.k1,
                  d.k2,
                  d.p1,
                  d.p2,
                  d.k3,
                  d.k4,
                  d.k5,
                  d.k6};
  if (model == LensModel::fisheye)
    s.intrinsics[p1] = s.intrinsics[p2] = s.intrinsics[k5] = s.intrinsics[k6] = 0;
  for (std::size_t i = 0; i < views; ++i) {
    std::array<double, 6> pose;
    for (int k = 0; k < 3; ++k) {
      pose[k] = cal.rvecs[i].at<double>(k);
      pose[3 + k] = cal.tvecs[i].at<double>(k);
    }
    s.poses.push_back(pose);
  }
  return s;
}

std::vector<Eigen::Vector2d> corner_residuals(const RefineState& s, LensModel model, const BoardSpec& board,
                                              const std::vector<cv::Point2f>& corners, std::size_t view) {
  std::vector<Eigen::Vector2d> out;
  for (int j = 0; j < int(corners.size()); ++j) {
    double pixel[2];
    project_corner(model, s.intrinsics.data(), s.fixed_aspect, s.poses[view].data(), s.warp.data(),
                   board_corner(board, j), pixel);
    out.emplace_back(corners[j].x - pixel[0], corners[j].y - pixel[1]);
  }
  return out;
}

RefineOutput refine(const std::vector<ViewInput>& views, const BoardSpec& board,
                    const OpenCvCalibration& init, const CalibrationOptions& options) {
  const LensModel model = options.model;
  const int width = init.camera.width, height = init.camera.height;
  RefineState s = refine_state_from_opencv(init, model, board, views.size());
  if (options.fix_aspect_ratio) {  // square pixels, as OpenCV's CALIB_FIX_ASPECT_RATIO without a guess
    s.fixed_aspect = 1.0;
    s.intrinsics[detail::fy] = s.intrinsics[detail::fx];
  }
  if (options.refine && options.fix_principal_point) {
    s.intrinsics[detail::cx] = 0.5 * (width - 1);
    s.intrinsics[detail::cy] = 0.5 * (height - 1);
  }
  const std::vector<int> held = held_intrinsics(options);
  const bool warp = options.refine && options.board_warp;

  std::vector<std::vector<char>> inlier(views.size(), std::vector<char>(board.corner_count(), 1));
  std::vector<std::vector<Eigen::Vector2d>> residuals(views.size());
  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::SubsetManifold held_manifold(intrinsic_count, held);
  std::unique_ptr<ceres::Problem> problem;

  const auto build = [&] {
    problem = std::make_unique<ceres::Problem>(problem_options);
    problem->AddParameterBlock(s.intrinsics.data(), intrinsic_count);
    if (!held.empty()) problem->SetManifold(s.intrinsics.data(), &held_manifold);
    problem->AddParameterBlock(s.warp.data(), 2);
    if (!warp) problem->SetParameterBlockConstant(s.warp.data());
    for (std::size_t i = 0; i < views.size(); ++i)
      for (int j = 0; j < board.corner_count(); ++j)
        if (inlier[i][j])
          problem->AddResidualBlock(
              CornerCost::create(model, s.fixed_aspect, board_corner(board, j), views[i].corners[j]), nullptr,
              s.intrinsics.data(), s.poses[i].data(), s.warp.data());
  };
  const auto update_residuals = [&] {
    for (std::size_t i = 0; i < views.size(); ++i)
      residuals[i] = corner_residuals(s, model, board, views[i].corners, i);
  };

  for (int round = 0;; ++round) {
    build();
    if (options.refine) {
      ceres::Solver::Options solver;
      solver.linear_solver_type = ceres::DENSE_SCHUR;
      solver.max_num_iterations = 200;
      solver.function_tolerance = 1e-14;
      solver.gradient_tolerance = 1e-14;
      solver.parameter_tolerance = 1e-14;
      solver.num_threads = 1;
      solver.logging_type = ceres::SILENT;
      ceres::Solver::Summary summary;
      ceres::Solve(solver, problem.get(), &summary);
      if (!summary.IsSolutionUsable())
        throw FailedError("the calibration refinement failed: " + summary.message);
    }
    update_residuals();
    if (!options.refine || options.corner_outlier_sigmas <= 0 || round == 9) break;
    // Robust sigma per axis from the median residual length of the current inliers (Rayleigh median).
    std::vector<double> lengths;
    for (std::size_t i = 0; i < views.size(); ++i)
      for (int j = 0; j < board.corner_count(); ++j)
        if (inlier[i][j]) lengths.push_back(residuals[i][j].norm());
    std::nth_element(lengths.begin(), lengths.begin() + lengths.size() / 2, lengths.end());
    const double sigma = lengths[lengths.size() / 2] / std::sqrt(2 * std::log(2.0));
    // Never below a tenth of a pixel: on clean (synthetic) images sigma is a few hundredths and a
    // 3-sigma cut would drop a third of perfectly good corners.
    const double limit = std::max(options.corner_outlier_sigmas * sigma, 0.1);
    bool changed = false;
    for (std::size_t i = 0; i < views.size(); ++i)
      for (int j = 0; j < board.corner_count(); ++j) {
        const char keep = residuals[i][j].norm() <= limit;
        changed |= keep != inlier[i][j];
        inlier[i][j] = keep;
      }
    if (!changed) break;
  }

  RefineOutput out;
  out.camera = camera_from_state(s, model, width, height);
  out.board_warp = s.warp;
  out.residuals = residuals;
  out.inlier = inlier;
  double sum = 0;
  int n = 0;
  for (std::size_t i = 0; i < views.size(); ++i) {
    out.cam_from_board.push_back(rigid_from_pose(s.poses[i]));
    for (int j = 0; j < board.corner_count(); ++j)
      if (inlier[i][j]) {
        sum += residuals[i][j].squaredNorm();
        ++n;
      }
  }
  out.rms = std::sqrt(sum / std::max(n, 1));

  // Covariance of the intrinsics (poses and warp marginalised), scaled by the residual variance.
  ceres::Covariance::Options covariance_options;
  covariance_options.algorithm_type = ceres::DENSE_SVD;
  covariance_options.null_space_rank = -1;
  covariance_options.num_threads = 1;
  ceres::Covariance covariance(covariance_options);
  const std::vector<std::pair<const double*, const double*>> blocks = {
      {s.intrinsics.data(), s.intrinsics.data()}};
  Eigen::Matrix<double, 12, 12, Eigen::RowMajor> cov = Eigen::Matrix<double, 12, 12, Eigen::RowMajor>::Zero();
  if (covariance.Compute(blocks, problem.get()) &&
      covariance.GetCovarianceBlock(s.intrinsics.data(), s.intrinsics.data(), cov.data())) {
    const int free_parameters = intrinsic_count - int(held.size()) + 6 * int(views.size()) + (warp ? 2 : 0);
    const double variance = sum / std::max(1, 2 * n - free_parameters);
    cov *= variance;
    std::array<double, 12> stddev;
    for (int i = 0; i < intrinsic_count; ++i) stddev[i] = std::sqrt(std::max(0.0, cov(i, i)));
    if (s.fixed_aspect > 0) stddev[detail::fy] = s.fixed_aspect * stddev[detail::fx];
    out.camera.stddev = stddev;
    out.uncertainty = projection_uncertainty(s, model, out.camera, cov);
  } else {
    log::warn("the intrinsics' covariance could not be computed (the problem is rank deficient)");
  }
  return out;
}

}  // namespace pg::calib

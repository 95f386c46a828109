#include "pg/sfm/bundle_adjustment.h"

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <cmath>

namespace pg {

namespace {

template <class T>
void project(const T* pose, const T* intrinsics, double aspect, const T* point, T* pixel, T* depth) {
  T p[3];
  ceres::AngleAxisRotatePoint(pose, point, p);
  p[0] += pose[3];
  p[1] += pose[4];
  p[2] += pose[5];
  *depth = p[2];
  const T x = p[0] / p[2], y = p[1] / p[2];
  const T r2 = x * x + y * y;
  const T d = T(1) + intrinsics[3] * r2 + intrinsics[4] * r2 * r2;
  pixel[0] = intrinsics[0] * x * d + intrinsics[1];
  pixel[1] = intrinsics[0] * aspect * y * d + intrinsics[2];
}

struct ReprojectionCost {
  ReprojectionCost(const Eigen::Vector2d& observed, double aspect) : observed(observed), aspect(aspect) {}
  template <class T>
  bool operator()(const T* pose, const T* intrinsics, const T* point, T* residual) const {
    T pixel[2], depth;
    project(pose, intrinsics, aspect, point, pixel, &depth);
    residual[0] = pixel[0] - observed.x();
    residual[1] = pixel[1] - observed.y();
    return true;
  }
  static ceres::CostFunction* create(const Eigen::Vector2d& observed, double aspect) {
    return new ceres::AutoDiffCostFunction<ReprojectionCost, 2, 6, 5, 3>(
        new ReprojectionCost(observed, aspect));
  }
  Eigen::Vector2d observed;
  double aspect;
};

}  // namespace

bool project_with_params(const PoseParams& pose, const IntrinsicParams& intrinsics, double aspect,
                         const Eigen::Vector3d& point, Eigen::Vector2d& pixel) {
  double depth = 0;
  project(pose.data(), intrinsics.data(), aspect, point.data(), pixel.data(), &depth);
  return depth > 0 && std::isfinite(pixel.x()) && std::isfinite(pixel.y());
}

BundleSummary bundle_adjust(BundleProblem& problem, const BundleOptions& options) {
  ceres::Problem::Options problem_options;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem ceres_problem(problem_options);
  ceres::HuberLoss loss(options.huber_px);
  auto& poses = *problem.poses;
  auto& intrinsics = *problem.intrinsics;
  auto& points = *problem.points;
  std::vector<bool> group_used(intrinsics.size(), false);
  std::vector<bool> frame_used(poses.size(), false);
  std::vector<bool> point_used(points.size(), false);
  for (const BundleObservation& o : problem.observations) {
    const int group = problem.frame_group[o.frame];
    ceres_problem.AddResidualBlock(ReprojectionCost::create(o.pixel, problem.aspect[group]), &loss,
                                   poses[o.frame].data(), intrinsics[group].data(), points[o.point].data());
    group_used[group] = frame_used[o.frame] = point_used[o.point] = true;
  }
  if (problem.observations.empty()) return {};
  for (std::size_t f = 0; f < poses.size(); ++f)
    if (frame_used[f] && f < problem.frame_constant.size() && problem.frame_constant[f])
      ceres_problem.SetParameterBlockConstant(poses[f].data());
  const int sf = problem.scale_frame;
  if (sf >= 0 && frame_used[sf] &&
      !(static_cast<std::size_t>(sf) < problem.frame_constant.size() && problem.frame_constant[sf]))
    ceres_problem.SetManifold(poses[sf].data(), new ceres::SubsetManifold(6, {3 + problem.scale_axis}));
  for (std::size_t p = 0; p < points.size(); ++p)
    if (point_used[p] && p < problem.point_constant.size() && problem.point_constant[p])
      ceres_problem.SetParameterBlockConstant(points[p].data());
  std::vector<int> held;
  if (!options.refine_focal) held.push_back(0);
  if (!options.refine_principal_point) held.insert(held.end(), {1, 2});
  if (!options.refine_distortion) held.insert(held.end(), {3, 4});
  for (std::size_t g = 0; g < intrinsics.size(); ++g) {
    if (!group_used[g]) continue;
    if (held.size() == 5)
      ceres_problem.SetParameterBlockConstant(intrinsics[g].data());
    else if (!held.empty())
      ceres_problem.SetManifold(intrinsics[g].data(), new ceres::SubsetManifold(5, held));
  }

  ceres::Solver::Options solver;
  solver.linear_solver_type = ceres::SPARSE_SCHUR;
  solver.sparse_linear_algebra_library_type = ceres::SUITE_SPARSE;
  solver.max_num_iterations = options.max_iterations;
  solver.function_tolerance = options.function_tolerance;
  solver.gradient_tolerance = 1e-10;
  solver.parameter_tolerance = 1e-8;
  solver.num_threads = 1;  // deterministic (see the header)
  solver.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(solver, &ceres_problem, &summary);

  BundleSummary out;
  const double n = static_cast<double>(problem.observations.size());
  // Ceres costs are 1/2 sum rho(r^2); the RMS below is of the raw residuals, recomputed.
  double sum = 0;
  for (const BundleObservation& o : problem.observations) {
    Eigen::Vector2d pixel;
    const int group = problem.frame_group[o.frame];
    project_with_params(poses[o.frame], intrinsics[group], problem.aspect[group], points[o.point], pixel);
    sum += (pixel - o.pixel).squaredNorm();
  }
  out.initial_rms_px = std::sqrt(2 * summary.initial_cost / n);
  out.final_rms_px = std::sqrt(sum / n);
  out.iterations = static_cast<int>(summary.iterations.size());
  out.converged = summary.termination_type == ceres::CONVERGENCE;
  return out;
}

}  // namespace pg

#include "pg/sfm/bundle_adjustment.h"

#include <ceres/ceres.h>

#include <cmath>

#include "pg/sfm/reprojection_cost.h"

namespace pg {

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
    ceres_problem.AddResidualBlock(new ReprojectionCost(o.pixel, problem.aspect[group]), &loss,
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

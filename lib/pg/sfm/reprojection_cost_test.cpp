#include "pg/sfm/reprojection_cost.h"

#include <ceres/autodiff_cost_function.h>
#include <gtest/gtest.h>

#include <array>
#include <random>

namespace pg {
namespace {

// The reference: Ceres' automatic differentiation of the same projection.
struct AutodiffReprojection {
  AutodiffReprojection(const Eigen::Vector2d& observed, double aspect) : observed(observed), aspect(aspect) {}
  template <class T>
  bool operator()(const T* pose, const T* intrinsics, const T* point, T* residual) const {
    T pixel[2], depth;
    project(pose, intrinsics, aspect, point, pixel, &depth);
    residual[0] = pixel[0] - observed.x();
    residual[1] = pixel[1] - observed.y();
    return true;
  }
  Eigen::Vector2d observed;
  double aspect;
};

struct Evaluation {
  std::array<double, 2> residual{};
  std::array<double, 12> pose{};
  std::array<double, 10> intrinsics{};
  std::array<double, 6> point{};
};

Evaluation evaluate(const ceres::CostFunction& cost, const double* pose, const double* intrinsics,
                    const double* point) {
  Evaluation e;
  const double* parameters[] = {pose, intrinsics, point};
  double* jacobians[] = {e.pose.data(), e.intrinsics.data(), e.point.data()};
  EXPECT_TRUE(cost.Evaluate(parameters, e.residual.data(), jacobians));
  return e;
}

template <std::size_t N>
void expect_near(const std::array<double, N>& analytic, const std::array<double, N>& reference,
                 const char* what) {
  for (std::size_t i = 0; i < N; ++i)
    EXPECT_NEAR(analytic[i], reference[i], 1e-9 * (1 + std::abs(reference[i]))) << what << "[" << i << "]";
}

TEST(ReprojectionCost, AnalyticJacobiansMatchAutomaticDifferentiation) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> unit(-1, 1);
  for (int trial = 0; trial < 200; ++trial) {
    // Rotations from large to below Ceres' small-angle branch (trial % 4 == 3: exactly zero).
    const double angle_scale = trial % 4 == 0 ? 2.0 : trial % 4 == 1 ? 0.05 : trial % 4 == 2 ? 1e-9 : 0.0;
    const double pose[6] = {angle_scale * unit(rng),
                            angle_scale * unit(rng),
                            angle_scale * unit(rng),
                            unit(rng),
                            unit(rng),
                            6 + unit(rng)};
    const double intrinsics[5] = {800 + 200 * unit(rng), 320 + 10 * unit(rng), 240 + 10 * unit(rng),
                                  0.1 * unit(rng), 0.05 * unit(rng)};
    const double point[3] = {2 * unit(rng), 2 * unit(rng), 2 * unit(rng)};
    const Eigen::Vector2d observed{300 + 50 * unit(rng), 250 + 50 * unit(rng)};
    const double aspect = 1 + 0.01 * unit(rng);
    const ReprojectionCost analytic(observed, aspect);
    const ceres::AutoDiffCostFunction<AutodiffReprojection, 2, 6, 5, 3> reference(
        new AutodiffReprojection(observed, aspect));
    const Evaluation a = evaluate(analytic, pose, intrinsics, point);
    const Evaluation r = evaluate(reference, pose, intrinsics, point);
    expect_near(a.residual, r.residual, "residual");
    expect_near(a.pose, r.pose, "pose");
    expect_near(a.intrinsics, r.intrinsics, "intrinsics");
    expect_near(a.point, r.point, "point");
  }
}

TEST(ReprojectionCost, JacobiansMayBeRequestedSeparately) {
  const double pose[6] = {0.1, -0.2, 0.3, 0.1, 0.2, 5};
  const double intrinsics[5] = {700, 320, 240, -0.05, 0.01};
  const double point[3] = {0.5, -0.4, 1};
  const ReprojectionCost cost(Eigen::Vector2d(330, 250), 1.0);
  const Evaluation all = evaluate(cost, pose, intrinsics, point);
  const double* parameters[] = {pose, intrinsics, point};
  std::array<double, 6> point_only{};
  double* jacobians[] = {nullptr, nullptr, point_only.data()};
  std::array<double, 2> residual{};
  ASSERT_TRUE(cost.Evaluate(parameters, residual.data(), jacobians));
  EXPECT_EQ(point_only, all.point);
  ASSERT_TRUE(cost.Evaluate(parameters, residual.data(), nullptr));
  EXPECT_EQ(residual, all.residual);
}

}  // namespace
}  // namespace pg

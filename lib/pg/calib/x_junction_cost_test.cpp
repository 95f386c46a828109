#include "pg/calib/x_junction_cost.h"

#include <ceres/autodiff_cost_function.h>
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <random>

namespace pg::calib {
namespace {

// The reference: Ceres' automatic differentiation of the same model.
struct AutodiffXJunction {
  double x, y, value;
  template <class T>
  bool operator()(const T* corner, const T* shape, T* residual) const {
    residual[0] = x_junction_model(x, y, corner, shape) - T(value);
    return true;
  }
};

TEST(XJunctionPixelCost, AnalyticDerivativesMatchAutomaticDifferentiation) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> unit(-1, 1);
  for (int trial = 0; trial < 300; ++trial) {
    const double corner[2] = {10 + unit(rng), 20 + unit(rng)};
    // Sharp to blurred edges, any angles, either contrast sign.
    const double shape[5] = {3 * unit(rng), 3 * unit(rng), 0.5 + 0.2 * unit(rng), 0.4 * unit(rng),
                             0.3 + 2 * std::abs(unit(rng))};
    const double x = std::round(corner[0] + 4 * unit(rng)), y = std::round(corner[1] + 4 * unit(rng));
    const double value = 0.5 + 0.5 * unit(rng);
    const XJunctionPixelCost analytic(x, y, value);
    const ceres::AutoDiffCostFunction<AutodiffXJunction, 1, 2, 5> reference(
        new AutodiffXJunction{x, y, value});
    const double* parameters[] = {corner, shape};
    std::array<double, 2> a_corner{}, r_corner{};
    std::array<double, 5> a_shape{}, r_shape{};
    double a_residual = 0, r_residual = 0;
    double* a_jacobians[] = {a_corner.data(), a_shape.data()};
    double* r_jacobians[] = {r_corner.data(), r_shape.data()};
    ASSERT_TRUE(analytic.Evaluate(parameters, &a_residual, a_jacobians));
    ASSERT_TRUE(reference.Evaluate(parameters, &r_residual, r_jacobians));
    EXPECT_NEAR(a_residual, r_residual, 1e-12);
    for (int i = 0; i < 2; ++i) EXPECT_NEAR(a_corner[i], r_corner[i], 1e-10 * (1 + std::abs(r_corner[i])));
    for (int i = 0; i < 5; ++i) EXPECT_NEAR(a_shape[i], r_shape[i], 1e-10 * (1 + std::abs(r_shape[i])));
  }
}

}  // namespace
}  // namespace pg::calib

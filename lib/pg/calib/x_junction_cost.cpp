#include "pg/calib/x_junction_cost.h"

#include <cmath>

namespace pg::calib {

bool XJunctionPixelCost::Evaluate(double const* const* parameters, double* residuals,
                                  double** jacobians) const {
  const double* corner = parameters[0];
  const double* shape = parameters[1];
  // x_junction_model's sum of t0 t1, t_k = tanh(k (c_k dx + s_k dy)), with its derivatives: one pass
  // over the subsamples for both (the tanh are most of the cost).
  const double c0 = std::cos(shape[0]), s0 = std::sin(shape[0]), c1 = std::cos(shape[1]),
               s1 = std::sin(shape[1]), k = shape[4];
  constexpr int n = x_junction_subsamples;
  double sum = 0, by_cx = 0, by_cy = 0, by_angle0 = 0, by_angle1 = 0, by_k = 0;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const double dx = x_ + (i + 0.5) / n - 0.5 - corner[0];
      const double dy = y_ + (j + 0.5) / n - 0.5 - corner[1];
      const double d0 = c0 * dx + s0 * dy, d1 = c1 * dx + s1 * dy;
      const double t0 = std::tanh(k * d0), t1 = std::tanh(k * d1);
      const double g0 = (1 - t0 * t0) * t1, g1 = t0 * (1 - t1 * t1);  // d(t0 t1) / d(k d_i)
      sum += t0 * t1;
      by_cx -= k * (g0 * c0 + g1 * c1);
      by_cy -= k * (g0 * s0 + g1 * s1);
      by_angle0 += g0 * k * (-s0 * dx + c0 * dy);
      by_angle1 += g1 * k * (-s1 * dx + c1 * dy);
      by_k += g0 * d0 + g1 * d1;
    }
  residuals[0] = shape[2] + shape[3] * sum / (n * n) - value_;
  if (!jacobians) return true;
  const double scale = shape[3] / (n * n);
  if (jacobians[0]) {
    jacobians[0][0] = scale * by_cx;
    jacobians[0][1] = scale * by_cy;
  }
  if (jacobians[1]) {
    jacobians[1][0] = scale * by_angle0;
    jacobians[1][1] = scale * by_angle1;
    jacobians[1][2] = 1;
    jacobians[1][3] = sum / (n * n);
    jacobians[1][4] = scale * by_k;
  }
  return true;
}

}  // namespace pg::calib

#pragma once
// The bundle adjustment's reprojection model and its cost with analytic derivatives: pose as
// angle-axis rotation then translation (cam_from_world), intrinsics f, cx, cy, k1, k2 with
// fy = f * aspect. Autodiff over 14 parameters ran ten times slower (and dominated runs under the
// sanitizers); the test checks these Jacobians against autodiff of `project`.
#include <ceres/rotation.h>
#include <ceres/sized_cost_function.h>

#include <Eigen/Core>

namespace pg {

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

// Residual (projected - observed) pixel; parameter blocks pose (6), intrinsics (5), point (3).
class ReprojectionCost final : public ceres::SizedCostFunction<2, 6, 5, 3> {
 public:
  ReprojectionCost(const Eigen::Vector2d& observed, double aspect) : observed_(observed), aspect_(aspect) {}
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  Eigen::Vector2d observed_;
  double aspect_;
};

}  // namespace pg

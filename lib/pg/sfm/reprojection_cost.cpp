#include "pg/sfm/reprojection_cost.h"

#include <Eigen/Core>
#include <limits>

namespace pg {

namespace {

Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d s;
  s << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return s;
}

// J d(R(w) v)/dw for a 2x3 J = d(pixel)/d(R(w) v + t) and the angle-axis w, R = R(w): by Gallego and
// Yezzi 2015 ("A compact formula for the derivative of a 3-D rotation in exponential coordinates"),
// d(R v)/dw = -R [v]x (w w^T + (R^T - I) [w]x) / |w|^2, multiplied out from the left in 2x3 products.
// Below Ceres' small-angle threshold Ceres rotates by v + w x v, whose derivative is -[v]x.
// JR is J R, the derivative by the point.
Eigen::Matrix<double, 2, 3> pixel_by_angle_axis(const Eigen::Matrix<double, 2, 3>& J,
                                                const Eigen::Matrix<double, 2, 3>& JR,
                                                const Eigen::Matrix3d& R, const Eigen::Vector3d& w,
                                                const Eigen::Vector3d& v) {
  const double theta2 = w.squaredNorm();
  if (theta2 <= std::numeric_limits<double>::epsilon()) return -J * skew(v);
  const Eigen::Matrix<double, 2, 3> B = JR * skew(v);
  return -((B * w) * w.transpose() + (B * R.transpose() - B) * skew(w)) / theta2;
}

}  // namespace

bool ReprojectionCost::Evaluate(double const* const* parameters, double* residuals,
                                double** jacobians) const {
  const double* pose = parameters[0];
  const double* intrinsics = parameters[1];
  const double* point = parameters[2];
  double pixel[2], depth;
  project(pose, intrinsics, aspect_, point, pixel, &depth);
  residuals[0] = pixel[0] - observed_.x();
  residuals[1] = pixel[1] - observed_.y();
  if (!jacobians) return true;

  // The same chain as project(): camera point p, normalised (x, y), distortion factor d.
  Eigen::Matrix3d R;
  ceres::AngleAxisToRotationMatrix(pose, R.data());
  const Eigen::Map<const Eigen::Vector3d> w(pose), v(point);
  const Eigen::Vector3d p = R * v + Eigen::Vector3d(pose[3], pose[4], pose[5]);
  const double x = p.x() / p.z(), y = p.y() / p.z();
  const double r2 = x * x + y * y;
  const double f = intrinsics[0], k1 = intrinsics[3], k2 = intrinsics[4];
  const double d = 1 + k1 * r2 + k2 * r2 * r2;
  const double dd_dr2 = k1 + 2 * k2 * r2;
  Eigen::Matrix2d pixel_by_xy;
  pixel_by_xy << f * (d + 2 * x * x * dd_dr2), f * 2 * x * y * dd_dr2,  //
      f * aspect_ * 2 * x * y * dd_dr2, f * aspect_ * (d + 2 * y * y * dd_dr2);
  Eigen::Matrix<double, 2, 3> xy_by_p;
  xy_by_p << 1 / p.z(), 0, -x / p.z(), 0, 1 / p.z(), -y / p.z();
  const Eigen::Matrix<double, 2, 3> pixel_by_p = pixel_by_xy * xy_by_p;
  const Eigen::Matrix<double, 2, 3> pixel_by_point = pixel_by_p * R;

  using RowMajor2x6 = Eigen::Matrix<double, 2, 6, Eigen::RowMajor>;
  using RowMajor2x5 = Eigen::Matrix<double, 2, 5, Eigen::RowMajor>;
  using RowMajor2x3 = Eigen::Matrix<double, 2, 3, Eigen::RowMajor>;
  if (jacobians[0]) {
    Eigen::Map<RowMajor2x6> j(jacobians[0]);
    j.leftCols<3>() = pixel_by_angle_axis(pixel_by_p, pixel_by_point, R, w, v);
    j.rightCols<3>() = pixel_by_p;
  }
  if (jacobians[1]) {
    Eigen::Map<RowMajor2x5> j(jacobians[1]);
    j << x * d, 1, 0, f * x * r2, f * x * r2 * r2,  //
        aspect_ * y * d, 0, 1, f * aspect_ * y * r2, f * aspect_ * y * r2 * r2;
  }
  if (jacobians[2]) {
    Eigen::Map<RowMajor2x3> j(jacobians[2]);
    j = pixel_by_point;
  }
  return true;
}

}  // namespace pg

#pragma once
// The lens models as one templated projection, shared by the Ceres cost, the residuals and the
// uncertainty propagation. Intrinsics are 12 numbers in Camera::stddev order:
// fx fy cx cy k1 k2 p1 p2 k3 k4 k5 k6 (fisheye uses k1 k2 k3 k4; p1 p2 k5 k6 stay zero).
#include <cmath>

#include "pg/calib/calibrate.h"

namespace pg::calib::detail {

enum Slot { fx, fy, cx, cy, k1, k2, p1, p2, k3, k4, k5, k6, intrinsic_count };

// Camera-frame point -> pixel. fixed_aspect > 0 replaces fy by fx * fixed_aspect.
template <class T>
void project(LensModel model, const T* in, double fixed_aspect, const T* point, T* pixel) {
  using std::atan;
  using std::sqrt;
  const T x = point[0] / point[2], y = point[1] / point[2];
  const T r2 = x * x + y * y;
  T xd, yd;
  if (model == LensModel::fisheye) {
    if (r2 < T(1e-16)) {
      xd = x;
      yd = y;
    } else {
      const T r = sqrt(r2);
      const T theta = atan(r);
      const T t2 = theta * theta;
      const T theta_d = theta * (T(1) + t2 * (in[k1] + t2 * (in[k2] + t2 * (in[k3] + t2 * in[k4]))));
      const T scale = theta_d / r;
      xd = x * scale;
      yd = y * scale;
    }
  } else {
    const T radial = (T(1) + r2 * (in[k1] + r2 * (in[k2] + r2 * in[k3]))) /
                     (T(1) + r2 * (in[k4] + r2 * (in[k5] + r2 * in[k6])));
    xd = x * radial + T(2) * in[p1] * x * y + in[p2] * (r2 + T(2) * x * x);
    yd = y * radial + in[p1] * (r2 + T(2) * y * y) + T(2) * in[p2] * x * y;
  }
  const T focal_y = fixed_aspect > 0 ? in[fx] * fixed_aspect : in[fy];
  pixel[0] = in[fx] * xd + in[cx];
  pixel[1] = focal_y * yd + in[cy];
}

}  // namespace pg::calib::detail

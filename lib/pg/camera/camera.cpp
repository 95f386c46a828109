#include "pg/camera/camera.h"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <numbers>

#include "pg/core/error.h"

namespace pg {

std::string to_string(CameraModel model) {
  switch (model) {
    case CameraModel::pinhole:
      return "pinhole";
    case CameraModel::fisheye:
      return "fisheye";
    case CameraModel::equirectangular:
      return "equirectangular";
  }
  return "unknown";
}

CameraModel camera_model_from_string(const std::string& name) {
  for (CameraModel m : {CameraModel::pinhole, CameraModel::fisheye, CameraModel::equirectangular})
    if (to_string(m) == name) return m;
  throw UsageError("unknown camera model \"" + name + "\" (expected pinhole, fisheye or equirectangular)");
}

namespace {

// Radial factor (1 + k1 r2 + k2 r4 + k3 r6) / (1 + k4 r2 + k5 r4 + k6 r6) and its derivative in r2.
void radial_factor(const Distortion& d, double r2, double& factor, double& d_factor_d_r2) {
  const double numerator = 1 + r2 * (d.k1 + r2 * (d.k2 + r2 * d.k3));
  const double denominator = 1 + r2 * (d.k4 + r2 * (d.k5 + r2 * d.k6));
  const double d_numerator = d.k1 + r2 * (2 * d.k2 + r2 * 3 * d.k3);
  const double d_denominator = d.k4 + r2 * (2 * d.k5 + r2 * 3 * d.k6);
  factor = numerator / denominator;
  d_factor_d_r2 = (d_numerator * denominator - numerator * d_denominator) / (denominator * denominator);
}

Eigen::Vector2d distort_with_jacobian(const Distortion& d, const Eigen::Vector2d& p,
                                      Eigen::Matrix2d& jacobian) {
  const double x = p.x(), y = p.y(), r2 = x * x + y * y;
  double radial, d_radial;
  radial_factor(d, r2, radial, d_radial);
  jacobian(0, 0) = radial + 2 * x * x * d_radial + 2 * d.p1 * y + 6 * d.p2 * x;
  jacobian(0, 1) = 2 * x * y * d_radial + 2 * d.p1 * x + 2 * d.p2 * y;
  jacobian(1, 0) = jacobian(0, 1);
  jacobian(1, 1) = radial + 2 * y * y * d_radial + 6 * d.p1 * y + 2 * d.p2 * x;
  return {x * radial + 2 * d.p1 * x * y + d.p2 * (r2 + 2 * x * x),
          y * radial + d.p1 * (r2 + 2 * y * y) + 2 * d.p2 * x * y};
}

constexpr int max_undistort_iterations = 100;

}  // namespace

Eigen::Vector2d distort_pinhole(const Distortion& d, const Eigen::Vector2d& undistorted) {
  Eigen::Matrix2d unused;
  return distort_with_jacobian(d, undistorted, unused);
}

Eigen::Vector2d undistort_pinhole(const Distortion& d, const Eigen::Vector2d& distorted) {
  if (d.is_zero()) return distorted;
  // Newton on distort(x) = distorted, started from the distorted point; each step must lower the
  // residual. When Newton stalls (singular Jacobian beyond the valid field), fall back to OpenCV's
  // fixed-point iteration x = (distorted - tangential(x)) / radial(x), keeping the best point found.
  Eigen::Vector2d x = distorted;
  Eigen::Matrix2d jacobian;
  double residual = (distort_with_jacobian(d, x, jacobian) - distorted).norm();
  const double tolerance = 1e-15 * (1 + distorted.norm());
  for (int i = 0; i < max_undistort_iterations && residual > tolerance; ++i) {
    const Eigen::Vector2d error = distort_with_jacobian(d, x, jacobian) - distorted;
    const Eigen::Vector2d step = jacobian.partialPivLu().solve(error);
    if (!step.allFinite()) break;
    const Eigen::Vector2d candidate = x - step;
    Eigen::Matrix2d unused;
    const double candidate_residual = (distort_with_jacobian(d, candidate, unused) - distorted).norm();
    if (!(candidate_residual < residual)) break;
    x = candidate;
    residual = candidate_residual;
  }
  if (residual <= tolerance) return x;

  Eigen::Vector2d fixed = distorted;
  for (int i = 0; i < max_undistort_iterations; ++i) {
    const double r2 = fixed.squaredNorm();
    double radial, unused_derivative;
    radial_factor(d, r2, radial, unused_derivative);
    const Eigen::Vector2d tangential(
        2 * d.p1 * fixed.x() * fixed.y() + d.p2 * (r2 + 2 * fixed.x() * fixed.x()),
        d.p1 * (r2 + 2 * fixed.y() * fixed.y()) + 2 * d.p2 * fixed.x() * fixed.y());
    const Eigen::Vector2d next = (distorted - tangential) / radial;
    if (!next.allFinite()) break;
    fixed = next;
    Eigen::Matrix2d unused;
    const double fixed_residual = (distort_with_jacobian(d, fixed, unused) - distorted).norm();
    if (fixed_residual < residual) {
      x = fixed;
      residual = fixed_residual;
      if (residual <= tolerance) break;
    }
  }
  return x;
}

double distort_fisheye_theta(const Distortion& d, double theta) {
  const double t2 = theta * theta;
  return theta * (1 + t2 * (d.k1 + t2 * (d.k2 + t2 * (d.k3 + t2 * d.k4))));
}

double undistort_fisheye_theta(const Distortion& d, double theta_d) {
  if (d.k1 == 0 && d.k2 == 0 && d.k3 == 0 && d.k4 == 0) return theta_d;
  // Newton on theta (1 + k1 t^2 + ... + k4 t^8) = theta_d, keeping only improving steps.
  double theta = theta_d;
  double residual = std::abs(distort_fisheye_theta(d, theta) - theta_d);
  for (int i = 0; i < max_undistort_iterations && residual > 1e-16 * (1 + std::abs(theta_d)); ++i) {
    const double t2 = theta * theta;
    const double derivative = 1 + t2 * (3 * d.k1 + t2 * (5 * d.k2 + t2 * (7 * d.k3 + t2 * 9 * d.k4)));
    const double candidate = theta - (distort_fisheye_theta(d, theta) - theta_d) / derivative;
    const double candidate_residual = std::abs(distort_fisheye_theta(d, candidate) - theta_d);
    if (!(candidate_residual < residual)) break;
    theta = candidate;
    residual = candidate_residual;
  }
  return theta;
}

Eigen::Vector2d equirect_pixel_from_direction(int width, int height, const Eigen::Vector3d& dir) {
  double lon = std::atan2(dir.x(), dir.z());
  if (lon == -std::numbers::pi) lon = std::numbers::pi;  // the range is (-pi, pi]
  // asin(-y) of the unit direction, in a form that stays accurate near the poles and needs no
  // normalisation.
  const double lat = std::atan2(-dir.y(), std::hypot(dir.x(), dir.z()));
  return {(lon + std::numbers::pi) / (2 * std::numbers::pi) * width - 0.5,
          (std::numbers::pi / 2 - lat) / std::numbers::pi * height - 0.5};
}

Eigen::Vector3d equirect_direction_from_pixel(int width, int height, const Eigen::Vector2d& pixel) {
  const double lon = (pixel.x() + 0.5) / width * 2 * std::numbers::pi - std::numbers::pi;
  const double lat = std::numbers::pi / 2 - (pixel.y() + 0.5) / height * std::numbers::pi;
  return {std::cos(lat) * std::sin(lon), -std::sin(lat), std::cos(lat) * std::cos(lon)};
}

bool Camera::project(const Eigen::Vector3d& point_cam, Eigen::Vector2d& pixel) const {
  Eigen::Vector2d out = Eigen::Vector2d::Zero();
  bool ok = false;
  switch (model) {
    case CameraModel::pinhole: {
      const Eigen::Vector2d normalised = point_cam.head<2>() / point_cam.z();
      const Eigen::Vector2d d = distort_pinhole(distortion, normalised);
      out = {intrinsics.fx * d.x() + intrinsics.cx, intrinsics.fy * d.y() + intrinsics.cy};
      ok = point_cam.z() > 0;
      break;
    }
    case CameraModel::fisheye: {
      // As cv::fisheye::projectPoints: theta = atan(r) of the normalised point, scaled by theta_d / r.
      const double r = point_cam.head<2>().norm();
      const double theta = std::atan2(r, point_cam.z());
      const double theta_d = distort_fisheye_theta(distortion, theta);
      const double scale = r > 1e-8 * std::abs(point_cam.z()) ? theta_d / r : 1 / point_cam.z();
      out = {intrinsics.fx * scale * point_cam.x() + intrinsics.cx,
             intrinsics.fy * scale * point_cam.y() + intrinsics.cy};
      ok = point_cam.z() > 0;
      break;
    }
    case CameraModel::equirectangular:
      if (point_cam.squaredNorm() == 0) return false;
      out = equirect_pixel_from_direction(width, height, point_cam);
      ok = true;
      break;
  }
  if (!out.allFinite()) return false;
  pixel = out;
  return ok;
}

Eigen::Vector3d Camera::unproject(const Eigen::Vector2d& pixel) const {
  switch (model) {
    case CameraModel::pinhole: {
      const Eigen::Vector2d distorted((pixel.x() - intrinsics.cx) / intrinsics.fx,
                                      (pixel.y() - intrinsics.cy) / intrinsics.fy);
      return undistort_pinhole(distortion, distorted).homogeneous().normalized();
    }
    case CameraModel::fisheye: {
      const Eigen::Vector2d distorted((pixel.x() - intrinsics.cx) / intrinsics.fx,
                                      (pixel.y() - intrinsics.cy) / intrinsics.fy);
      const double theta_d = distorted.norm();
      if (theta_d == 0) return Eigen::Vector3d::UnitZ();
      const double theta = undistort_fisheye_theta(distortion, theta_d);
      const Eigen::Vector2d lateral = std::sin(theta) / theta_d * distorted;
      return Eigen::Vector3d(lateral.x(), lateral.y(), std::cos(theta)).normalized();
    }
    case CameraModel::equirectangular:
      return equirect_direction_from_pixel(width, height, pixel);
  }
  return Eigen::Vector3d::UnitZ();
}

bool Camera::project_world(const Eigen::Vector3d& point_world, Eigen::Vector2d& pixel) const {
  return project(cam_from_world * point_world, pixel);
}

// The image covers [-0.5, width - 0.5) x [-0.5, height - 0.5): pixel centres are at integers.
bool Camera::in_image(const Eigen::Vector2d& pixel, double margin) const {
  return pixel.x() >= -0.5 + margin && pixel.x() < width - 0.5 - margin && pixel.y() >= -0.5 + margin &&
         pixel.y() < height - 0.5 - margin;
}

Eigen::Matrix3d Camera::K() const {
  Eigen::Matrix3d k;
  k << intrinsics.fx, 0, intrinsics.cx, 0, intrinsics.fy, intrinsics.cy, 0, 0, 1;
  return k;
}

Camera resized_camera(const Camera& camera, double factor) {
  Camera c = camera;
  c.width = std::max(1, static_cast<int>(std::lround(camera.width * factor)));
  c.height = std::max(1, static_cast<int>(std::lround(camera.height * factor)));
  if (camera.model == CameraModel::equirectangular) return c;
  const double sx = static_cast<double>(c.width) / camera.width,
               sy = static_cast<double>(c.height) / camera.height;
  c.intrinsics.fx *= sx;
  c.intrinsics.fy *= sy;
  c.intrinsics.cx = (camera.intrinsics.cx + 0.5) * sx - 0.5;
  c.intrinsics.cy = (camera.intrinsics.cy + 0.5) * sy - 0.5;
  return c;
}

Camera turned_camera(const Camera& camera, int quarter_turns) {
  if (camera.model == CameraModel::equirectangular)
    throw UsageError("an equirectangular camera cannot be turned by quarter turns");
  Camera c = camera;
  for (int turn = 0; turn < ((quarter_turns % 4) + 4) % 4; ++turn) {
    // Pixel (x, y) of a W-wide image goes to (y, W - 1 - x); camera axes x' = y, y' = -x.
    const Camera before = c;
    c.width = before.height;
    c.height = before.width;
    c.intrinsics = {before.intrinsics.fy, before.intrinsics.fx, before.intrinsics.cy,
                    before.width - 1 - before.intrinsics.cx};
    if (c.model == CameraModel::pinhole) {
      c.distortion.p1 = -before.distortion.p2;  // radial terms are symmetric; tangential ones turn
      c.distortion.p2 = before.distortion.p1;
    }
    const Eigen::Quaterniond axes(Eigen::AngleAxisd(-EIGEN_PI / 2, Eigen::Vector3d::UnitZ()));
    c.cam_from_world = Rigid3{axes, Eigen::Vector3d::Zero()} * before.cam_from_world;
    if (before.stddev) {
      auto& s = *c.stddev;
      std::swap(s[0], s[1]);
      std::swap(s[2], s[3]);
      std::swap(s[6], s[7]);
    }
  }
  return c;
}

}  // namespace pg

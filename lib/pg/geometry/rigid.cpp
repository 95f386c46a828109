#include "pg/geometry/rigid.h"

#include <cmath>

namespace pg {

Rigid3 Rigid3::look_at(const Eigen::Vector3d& centre, const Eigen::Vector3d& target,
                       const Eigen::Vector3d& up) {
  Eigen::Vector3d z = target - centre;
  if (z.squaredNorm() == 0) z = Eigen::Vector3d::UnitZ();
  z.normalize();
  // Image y (down) is -up with its component along the view direction removed. When `up` is (nearly)
  // parallel to the view direction, any perpendicular will do: take the least aligned world axis.
  Eigen::Vector3d y = -(up - up.dot(z) * z);
  if (y.norm() < 1e-9 * std::max(1.0, up.norm())) {
    Eigen::Index axis;
    z.cwiseAbs().minCoeff(&axis);
    Eigen::Vector3d other = Eigen::Vector3d::Unit(axis);
    y = -(other - other.dot(z) * z);
  }
  y.normalize();
  const Eigen::Vector3d x = y.cross(z);  // right-handed: x = y x z
  Eigen::Matrix3d cam_from_world_rotation;
  cam_from_world_rotation.row(0) = x;
  cam_from_world_rotation.row(1) = y;
  cam_from_world_rotation.row(2) = z;
  Rigid3 pose;
  pose.rotation = Eigen::Quaterniond(cam_from_world_rotation).normalized();
  pose.translation = -(pose.rotation * centre);
  return pose;
}

Sim3 Sim3::inverse() const {
  Sim3 inv;
  inv.scale = 1.0 / scale;
  inv.rotation = rotation.conjugate();
  inv.translation = -inv.scale * (inv.rotation * translation);
  return inv;
}

// The camera frame is scaled with the world, so depths scale by `scale` while the camera's orientation
// turns with the world: cam_from_target = [R_c R^T | scale * t_c - R_c R^T t]. Its centre is
// this * (old centre).
Rigid3 Sim3::transform_pose(const Rigid3& cam_from_world) const {
  Rigid3 out;
  out.rotation = (cam_from_world.rotation * rotation.conjugate()).normalized();
  out.translation = scale * cam_from_world.translation - out.rotation * translation;
  return out;
}

}  // namespace pg

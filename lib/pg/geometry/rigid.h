#pragma once
// Rigid and similarity transforms, named by what they map: `cam_from_world` maps world points into
// the camera frame (formats/conventions.md).
#include <Eigen/Core>
#include <Eigen/Geometry>

namespace pg {

struct Rigid3 {
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();  // unit quaternion
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();

  Eigen::Vector3d operator*(const Eigen::Vector3d& p) const { return rotation * p + translation; }
  Rigid3 operator*(const Rigid3& other) const {
    return {rotation * other.rotation, rotation * other.translation + translation};
  }
  Rigid3 inverse() const {
    Eigen::Quaterniond r = rotation.conjugate();
    return {r, -(r * translation)};
  }
  Eigen::Matrix3d rotation_matrix() const { return rotation.toRotationMatrix(); }
  Eigen::Matrix<double, 3, 4> matrix() const {
    Eigen::Matrix<double, 3, 4> m;
    m << rotation_matrix(), translation;
    return m;
  }
  // For cam_from_world: the camera centre in world coordinates.
  Eigen::Vector3d centre() const { return -(rotation.conjugate() * translation); }
  // A pose at world position `centre`, looking at `target`, with image-up towards `up` (y down in image).
  static Rigid3 look_at(const Eigen::Vector3d& centre, const Eigen::Vector3d& target,
                        const Eigen::Vector3d& up = Eigen::Vector3d::UnitZ());
};

// y = scale * R x + t.
struct Sim3 {
  double scale = 1.0;
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  Eigen::Vector3d operator*(const Eigen::Vector3d& p) const { return scale * (rotation * p) + translation; }
  Sim3 inverse() const;
  // Maps a cam_from_world pose expressed in this transform's source frame into its target frame.
  Rigid3 transform_pose(const Rigid3& cam_from_world) const;
};

}  // namespace pg

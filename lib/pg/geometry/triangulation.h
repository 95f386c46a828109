#pragma once
// Triangulation of 3D points from rays observed by posed cameras. Rays are camera-frame directions
// (any length; Camera::unproject gives unit rays), so every camera model, equirectangular included,
// uses the same code.
#include <Eigen/Core>
#include <optional>
#include <vector>

#include "pg/geometry/rigid.h"

namespace pg {

struct TriangulationOptions {
  // Gauss-Newton refinement of the summed squared angular error (tangent-plane residuals) after the
  // linear estimate. Only steps that lower the error are kept.
  bool refine = true;
  int max_iterations = 10;
};

// Multi-view triangulation: linear DLT on the constraints ray x (R X + t) = 0, then optional refinement.
// Returns nullopt with fewer than two views, mismatched sizes, a degenerate configuration (a point at
// infinity, parallel rays), or a point that is not in front of every ray (angle >= 90 degrees).
std::optional<Eigen::Vector3d> triangulate(const std::vector<Rigid3>& cam_from_world,
                                           const std::vector<Eigen::Vector3d>& rays_cam,
                                           const TriangulationOptions& options = {});

// Midpoint of the shortest segment between two world-frame rays (origin + s * direction, s > 0).
// Returns nullopt when the rays are parallel or the closest points lie behind either origin.
std::optional<Eigen::Vector3d> triangulate_midpoint(const Eigen::Vector3d& origin_a,
                                                    const Eigen::Vector3d& direction_a,
                                                    const Eigen::Vector3d& origin_b,
                                                    const Eigen::Vector3d& direction_b);

// Angle in radians at `point` between the directions to two camera centres (0 when degenerate).
double triangulation_angle(const Eigen::Vector3d& centre_a, const Eigen::Vector3d& centre_b,
                           const Eigen::Vector3d& point);

// Angle in radians between a camera-frame ray and the direction to a world point seen from that camera.
double angular_error(const Rigid3& cam_from_world, const Eigen::Vector3d& ray_cam,
                     const Eigen::Vector3d& point);

}  // namespace pg

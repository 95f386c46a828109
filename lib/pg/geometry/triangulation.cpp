#include "pg/geometry/triangulation.h"

#include <Eigen/Cholesky>
#include <Eigen/SVD>
#include <cmath>
#include <limits>

namespace pg {
namespace {

// Two unit vectors spanning the plane perpendicular to unit vector d.
void tangent_basis(const Eigen::Vector3d& d, Eigen::Vector3d& b1, Eigen::Vector3d& b2) {
  Eigen::Index axis;
  d.cwiseAbs().minCoeff(&axis);
  b1 = d.cross(Eigen::Vector3d::Unit(axis)).normalized();
  b2 = d.cross(b1);
}

struct View {
  Eigen::Matrix3d rotation;
  Eigen::Vector3d translation;
  Eigen::Vector3d ray;  // unit
  Eigen::Vector3d b1, b2;
};

// Sum of squared tangent-plane residuals (tan of the angular error components); infinite when the point
// is not in front of every ray.
double cost(const std::vector<View>& views, const Eigen::Vector3d& x) {
  double total = 0;
  for (const View& v : views) {
    const Eigen::Vector3d p = v.rotation * x + v.translation;
    const double depth = v.ray.dot(p);
    if (!(depth > 0)) return std::numeric_limits<double>::infinity();
    const double r1 = v.b1.dot(p) / depth, r2 = v.b2.dot(p) / depth;
    total += r1 * r1 + r2 * r2;
  }
  return total;
}

Eigen::Vector3d refine(const std::vector<View>& views, Eigen::Vector3d x, int max_iterations) {
  double current = cost(views, x);
  for (int iteration = 0; iteration < max_iterations && current > 0; ++iteration) {
    Eigen::Matrix3d normal = Eigen::Matrix3d::Zero();
    Eigen::Vector3d gradient = Eigen::Vector3d::Zero();
    for (const View& v : views) {
      const Eigen::Vector3d p = v.rotation * x + v.translation;
      const double depth = v.ray.dot(p);
      const Eigen::RowVector3d d_depth = v.ray.transpose() * v.rotation;
      for (const Eigen::Vector3d* b : {&v.b1, &v.b2}) {
        const double numerator = b->dot(p);
        const double residual = numerator / depth;
        // d(n / depth)/dx = (dn * depth - n * d_depth) / depth^2
        const Eigen::RowVector3d jacobian =
            (b->transpose() * v.rotation * depth - numerator * d_depth) / (depth * depth);
        normal += jacobian.transpose() * jacobian;
        gradient += jacobian.transpose() * residual;
      }
    }
    const Eigen::Vector3d step = normal.ldlt().solve(-gradient);
    if (!step.allFinite()) break;
    const Eigen::Vector3d candidate = x + step;
    const double candidate_cost = cost(views, candidate);
    if (!(candidate_cost < current)) break;
    const bool converged = step.norm() <= 1e-15 * (1 + x.norm());
    x = candidate;
    current = candidate_cost;
    if (converged) break;
  }
  return x;
}

}  // namespace

std::optional<Eigen::Vector3d> triangulate(const std::vector<Rigid3>& cam_from_world,
                                           const std::vector<Eigen::Vector3d>& rays_cam,
                                           const TriangulationOptions& options) {
  if (cam_from_world.size() != rays_cam.size() || rays_cam.size() < 2) return std::nullopt;
  std::vector<View> views(rays_cam.size());
  // Each view contributes the three rows of [ray]_x [R | t] (rank 2); rays are unit so rows are
  // comparably scaled.
  Eigen::MatrixXd a(3 * views.size(), 4);
  for (std::size_t i = 0; i < views.size(); ++i) {
    View& v = views[i];
    const double length = rays_cam[i].norm();
    if (!(length > 0) || !std::isfinite(length)) return std::nullopt;
    v.ray = rays_cam[i] / length;
    v.rotation = cam_from_world[i].rotation_matrix();
    v.translation = cam_from_world[i].translation;
    tangent_basis(v.ray, v.b1, v.b2);
    Eigen::Matrix3d cross;
    cross << 0, -v.ray.z(), v.ray.y(), v.ray.z(), 0, -v.ray.x(), -v.ray.y(), v.ray.x(), 0;
    a.block<3, 3>(3 * i, 0) = cross * v.rotation;
    a.block<3, 1>(3 * i, 3) = cross * v.translation;
  }
  // Condition the homogeneous system: shift the origin to the mean camera centre and scale by the
  // spread of the centres, so that translations of any magnitude give a well-posed SVD.
  Eigen::Vector3d mean_centre = Eigen::Vector3d::Zero();
  for (const Rigid3& pose : cam_from_world) mean_centre += pose.centre();
  mean_centre /= double(views.size());
  double spread = 0;
  for (const Rigid3& pose : cam_from_world) spread = std::max(spread, (pose.centre() - mean_centre).norm());
  if (!(spread > 0)) return std::nullopt;  // a single centre cannot triangulate
  // With X = mean + spread * Y: A [X; 1] = [spread * A_xyz | A_xyz * mean + a_t] [Y; 1].
  Eigen::MatrixXd conditioned(a.rows(), 4);
  conditioned.leftCols<3>() = spread * a.leftCols<3>();
  conditioned.col(3) = a.leftCols<3>() * mean_centre + a.col(3);
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(conditioned, Eigen::ComputeFullV);
  const Eigen::Vector4d y = svd.matrixV().col(3);
  if (!(std::abs(y(3)) > 1e-14 * y.head<3>().norm())) return std::nullopt;
  Eigen::Vector3d x = mean_centre + spread * y.head<3>() / y(3);
  if (!x.allFinite() || !std::isfinite(cost(views, x))) return std::nullopt;
  if (options.refine) x = refine(views, x, options.max_iterations);
  return x;
}

std::optional<Eigen::Vector3d> triangulate_midpoint(const Eigen::Vector3d& origin_a,
                                                    const Eigen::Vector3d& direction_a,
                                                    const Eigen::Vector3d& origin_b,
                                                    const Eigen::Vector3d& direction_b) {
  const Eigen::Vector3d da = direction_a.normalized(), db = direction_b.normalized();
  const Eigen::Vector3d w = origin_a - origin_b;
  const double b = da.dot(db), d = da.dot(w), e = db.dot(w);
  const double denominator = 1 - b * b;
  if (!(denominator > 1e-14)) return std::nullopt;
  const double sa = (b * e - d) / denominator;
  const double sb = (e - b * d) / denominator;
  if (!(sa > 0 && sb > 0)) return std::nullopt;
  return 0.5 * ((origin_a + sa * da) + (origin_b + sb * db));
}

double triangulation_angle(const Eigen::Vector3d& centre_a, const Eigen::Vector3d& centre_b,
                           const Eigen::Vector3d& point) {
  const Eigen::Vector3d a = centre_a - point, b = centre_b - point;
  if (a.squaredNorm() == 0 || b.squaredNorm() == 0) return 0;
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

double angular_error(const Rigid3& cam_from_world, const Eigen::Vector3d& ray_cam,
                     const Eigen::Vector3d& point) {
  const Eigen::Vector3d p = cam_from_world * point;
  return std::atan2(ray_cam.cross(p).norm(), ray_cam.dot(p));
}

}  // namespace pg

#include "pg/eval/orientation_error.h"

#include <Eigen/Geometry>
#include <cmath>
#include <numbers>

namespace pg {

std::vector<double> orientation_aligned_rotation_errors_deg(const CameraSet& estimate,
                                                            const CameraSet& truth) {
  std::vector<std::pair<Eigen::Quaterniond, Eigen::Quaterniond>> matched;  // (estimate, truth)
  for (const Camera& t : truth.cameras)
    if (const Camera* e = estimate.find(t.id))
      matched.push_back({e->cam_from_world.rotation.normalized(), t.cam_from_world.rotation.normalized()});
  std::vector<double> errors;
  if (matched.empty()) return errors;
  // Chordal mean of unit quaternions: sum with consistent signs, normalise (exact for small spreads).
  Eigen::Vector4d sum = Eigen::Vector4d::Zero();
  Eigen::Vector4d reference;
  for (std::size_t i = 0; i < matched.size(); ++i) {
    const Eigen::Quaterniond a = matched[i].first.conjugate() * matched[i].second;
    Eigen::Vector4d v = a.coeffs();
    if (i == 0) reference = v;
    if (v.dot(reference) < 0) v = -v;
    sum += v;
  }
  const Eigen::Quaterniond mean(Eigen::Vector4d(sum.normalized()));
  for (const auto& [e, t] : matched) {
    const Eigen::Quaterniond residual = e * mean * t.conjugate();
    errors.push_back(2.0 * std::atan2(residual.vec().norm(), std::abs(residual.w())) * 180.0 /
                     std::numbers::pi);
  }
  return errors;
}

}  // namespace pg

#include "pg/remesh/reference_surface.h"

namespace pg {
namespace {

Mesh segments_as_degenerate_triangles(const std::vector<Segment>& segments) {
  Mesh mesh;
  mesh.positions.reserve(segments.size() * 2);
  for (const Segment& s : segments) {
    const auto i = std::uint32_t(mesh.positions.size());
    mesh.positions.push_back(s[0]);
    mesh.positions.push_back(s[1]);
    mesh.faces.push_back({i, i + 1, i + 1});
  }
  return mesh;
}

}  // namespace

Eigen::Vector3f barycentric(const Eigen::Vector3f& p, const Eigen::Vector3f& a, const Eigen::Vector3f& b,
                            const Eigen::Vector3f& c) {
  const Eigen::Vector3d v0 = (b - a).cast<double>(), v1 = (c - a).cast<double>(), v2 = (p - a).cast<double>();
  const double d00 = v0.dot(v0), d01 = v0.dot(v1), d11 = v1.dot(v1), d20 = v2.dot(v0), d21 = v2.dot(v1);
  const double denominator = d00 * d11 - d01 * d01;
  if (!(denominator > 0)) return {1, 0, 0};  // degenerate face: take its first vertex
  double v = (d11 * d20 - d01 * d21) / denominator;
  double w = (d00 * d21 - d01 * d20) / denominator;
  double u = 1 - v - w;
  u = std::max(u, 0.0), v = std::max(v, 0.0), w = std::max(w, 0.0);
  const double sum = u + v + w;
  return Eigen::Vector3d(u / sum, v / sum, w / sum).cast<float>();
}

ReferenceSurface::ReferenceSurface(const Mesh& mesh, std::vector<Segment> features)
    : positions_(mesh.positions), faces_(mesh.faces), surface_(mesh) {
  if (!features.empty())
    features_ = std::make_unique<TriangleBvh>(segments_as_degenerate_triangles(features));
}

ReferenceSurface::Location ReferenceSurface::locate(const Eigen::Vector3f& p) const {
  const TriangleBvh::ClosestHit hit = surface_.closest_point(p);
  Location at;
  at.face = hit.face;
  at.point = hit.point;
  const auto& f = faces_[hit.face];
  at.barycentric = barycentric(hit.point, positions_[f[0]], positions_[f[1]], positions_[f[2]]);
  return at;
}

Eigen::Vector3f ReferenceSurface::closest_on_features(const Eigen::Vector3f& p) const {
  if (!features_) return p;
  return features_->closest_point(p).point;
}

float ReferenceSurface::interpolate(const std::vector<float>& values, const Location& at) const {
  const auto& f = faces_[at.face];
  return at.barycentric[0] * values[f[0]] + at.barycentric[1] * values[f[1]] +
         at.barycentric[2] * values[f[2]];
}

}  // namespace pg

#include "pg/remesh/sizing.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>

namespace pg {
namespace {

// One-ring average of `values` over the face graph, each vertex counted with itself.
std::vector<float> ring_average(const Mesh& mesh, const std::vector<float>& values) {
  std::vector<double> sum(values.begin(), values.end());
  std::vector<int> count(values.size(), 1);
  for (const auto& f : mesh.faces)
    for (int k = 0; k < 3; ++k) {
      sum[f[k]] += values[f[(k + 1) % 3]] + values[f[(k + 2) % 3]];
      count[f[k]] += 2;
    }
  std::vector<float> out(values.size());
  for (std::size_t i = 0; i < values.size(); ++i) out[i] = float(sum[i] / count[i]);
  return out;
}

}  // namespace

std::vector<bool> boundary_vertices(const Mesh& mesh) {
  std::vector<std::uint64_t> edges;
  edges.reserve(mesh.faces.size() * 3);
  for (const auto& f : mesh.faces)
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t a = f[k], b = f[(k + 1) % 3];
      edges.push_back((std::uint64_t(std::min(a, b)) << 32) | std::max(a, b));
    }
  std::sort(edges.begin(), edges.end());
  std::vector<bool> boundary(mesh.vertex_count(), false);
  for (std::size_t i = 0; i < edges.size();) {
    std::size_t j = i;
    while (j < edges.size() && edges[j] == edges[i]) ++j;
    if (j - i == 1) boundary[edges[i] >> 32] = boundary[edges[i] & 0xffffffffu] = true;
    i = j;
  }
  return boundary;
}

std::vector<float> max_abs_curvature(const Mesh& mesh, int averaging_rounds) {
  const std::size_t n = mesh.vertex_count();
  std::vector<Eigen::Vector3d> laplace(n, Eigen::Vector3d::Zero());
  std::vector<double> area(n, 0.0), angle_sum(n, 0.0);
  for (const auto& f : mesh.faces) {
    const Eigen::Vector3d p[3] = {mesh.positions[f[0]].cast<double>(), mesh.positions[f[1]].cast<double>(),
                                  mesh.positions[f[2]].cast<double>()};
    const double face_area = 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).norm();
    if (!(face_area > 0)) continue;
    for (int k = 0; k < 3; ++k) {
      const int i = k, j = (k + 1) % 3, l = (k + 2) % 3;
      const Eigen::Vector3d a = p[j] - p[i], b = p[l] - p[i];
      const double cot = a.dot(b) / a.cross(b).norm();  // cotangent of the angle at corner i
      laplace[f[j]] += 0.5 * cot * (p[l] - p[j]);       // edge (j, l) lies opposite corner i
      laplace[f[l]] += 0.5 * cot * (p[j] - p[l]);
      angle_sum[f[i]] += std::atan2(a.cross(b).norm(), a.dot(b));
      area[f[i]] += face_area / 3;
    }
  }
  const std::vector<bool> boundary = boundary_vertices(mesh);
  std::vector<float> curvature(n, 0.0f);
  for (std::size_t i = 0; i < n; ++i) {
    if (!(area[i] > 0) || boundary[i]) continue;
    const double h = 0.5 * laplace[i].norm() / area[i];
    const double k = (2 * std::numbers::pi - angle_sum[i]) / area[i];
    curvature[i] = float(h + std::sqrt(std::max(h * h - k, 0.0)));
  }
  // Neither estimate holds on the boundary (no full ring): take the mean of the interior neighbours.
  std::vector<double> sum(n, 0.0);
  std::vector<int> count(n, 0);
  for (const auto& f : mesh.faces)
    for (int k = 0; k < 3; ++k)
      for (int d = 1; d < 3; ++d)
        if (boundary[f[k]] && !boundary[f[(k + d) % 3]]) {
          sum[f[k]] += curvature[f[(k + d) % 3]];
          ++count[f[k]];
        }
  for (std::size_t i = 0; i < n; ++i)
    if (boundary[i] && count[i] > 0) curvature[i] = float(sum[i] / count[i]);
  for (int round = 0; round < averaging_rounds; ++round) curvature = ring_average(mesh, curvature);
  return curvature;
}

std::vector<float> adaptive_target_lengths(const Mesh& mesh, float approximation_error, float min_length,
                                           float max_length) {
  const std::vector<float> curvature = max_abs_curvature(mesh);
  std::vector<float> target(curvature.size(), max_length);
  const double e = approximation_error;
  for (std::size_t i = 0; i < curvature.size(); ++i) {
    const double k = curvature[i];
    const double squared = k > 0 ? 6 * e / k - 3 * e * e : INFINITY;
    const double h = squared > 0 ? std::sqrt(squared) : 0.0;
    target[i] = float(std::clamp(h, double(min_length), double(max_length)));
  }
  return target;
}

}  // namespace pg

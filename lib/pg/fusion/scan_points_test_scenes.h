#pragma once
// Synthetic scans for the point-cloud scan tests: LIDAR sweeps ray-cast through a BVH from a sensor
// origin (or along parallel rays), written as plain PLY point clouds (no pg header), the way a
// scanner's export looks.
#include <array>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <string>
#include <vector>

#include "pg/fusion/fusion_test_scenes.h"
#include "pg/mesh/bvh.h"
#include "pg/mesh/mesh.h"

namespace pg::fusion::testing {

struct SweepPoint {
  Eigen::Vector3d position, origin;
  Eigen::Vector3f normal;  // the hit triangle's unit normal
  std::array<std::uint8_t, 3> color{};
};

inline Eigen::Vector3f face_normal(const Mesh& mesh, std::uint32_t face) {
  const auto& f = mesh.faces[face];
  const Eigen::Vector3f a = mesh.positions[f[0]], b = mesh.positions[f[1]], c = mesh.positions[f[2]];
  return (b - a).cross(c - a).normalized();
}

// A full spherical sweep from `origin`: `elevations` rings from straight down to straight up,
// `azimuths` rays per ring; the first surface each ray hits.
inline std::vector<SweepPoint> lidar_sweep(const Mesh& scene, const Eigen::Vector3d& origin, int azimuths,
                                           int elevations) {
  const TriangleBvh bvh(scene);
  std::vector<SweepPoint> points;
  for (int e = 0; e < elevations; ++e) {
    const double elevation = std::numbers::pi * ((e + 0.5) / elevations - 0.5);
    for (int a = 0; a < azimuths; ++a) {
      const double azimuth = 2 * std::numbers::pi * a / azimuths;
      const Eigen::Vector3d ray(std::cos(elevation) * std::cos(azimuth),
                                std::cos(elevation) * std::sin(azimuth), std::sin(elevation));
      const auto hit = bvh.intersect(origin.cast<float>(), ray.cast<float>());
      if (hit.hit) points.push_back({origin + ray * double(hit.t), origin, face_normal(scene, hit.face)});
    }
  }
  return points;
}

// Parallel rays along `direction` through a square grid of `spacing` over [-half, half]^2 in the
// plane through the origin perpendicular to z, started `back` before it.
inline std::vector<SweepPoint> parallel_sweep(const Mesh& scene, const Eigen::Vector3d& direction,
                                              double half, double spacing, double back) {
  const TriangleBvh bvh(scene);
  std::vector<SweepPoint> points;
  const int n = int(std::floor(2 * half / spacing));
  for (int i = 0; i <= n; ++i)
    for (int j = 0; j <= n; ++j) {
      const Eigen::Vector3d start =
          Eigen::Vector3d(-half + i * spacing, -half + j * spacing, 0) - direction * back;
      const auto hit = bvh.intersect(start.cast<float>(), direction.cast<float>());
      if (hit.hit) points.push_back({start + direction * double(hit.t), start, face_normal(scene, hit.face)});
    }
  return points;
}

// z = height exp(-(x^2 + y^2) / (2 sigma^2)) over [-half, half]^2, faces up.
inline Mesh bump(double half, int n, double height, double sigma) {
  Mesh m;
  for (int i = 0; i <= n; ++i)
    for (int j = 0; j <= n; ++j) {
      const double x = -half + 2 * half * i / n, y = -half + 2 * half * j / n;
      m.positions.emplace_back(float(x), float(y),
                               float(height * std::exp(-(x * x + y * y) / (2 * sigma * sigma))));
    }
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const std::uint32_t a = i * (n + 1) + j, b = a + n + 1, c = a + 1, d = b + 1;
      m.faces.push_back({a, b, d});
      m.faces.push_back({a, d, c});
    }
  return m;
}

struct PlainPlyColumns {
  bool origins = false, normals = false, colors = false;
  float confidence = -1;  // written as a "confidence" column when >= 0
};

// A binary little-endian PLY with only a vertex element: double x y z, then as asked float
// sensor_x sensor_y sensor_z, nx ny nz, confidence, uchar red green blue. No pg comments.
inline void write_plain_points(const std::filesystem::path& path, const std::vector<SweepPoint>& points,
                               const PlainPlyColumns& columns = {}) {
  std::ofstream out(path, std::ios::binary);
  out << "ply\nformat binary_little_endian 1.0\ncomment exported by a scanner\nelement vertex "
      << points.size() << "\nproperty double x\nproperty double y\nproperty double z\n";
  if (columns.origins) out << "property float sensor_x\nproperty float sensor_y\nproperty float sensor_z\n";
  if (columns.normals) out << "property float nx\nproperty float ny\nproperty float nz\n";
  if (columns.confidence >= 0) out << "property float confidence\n";
  if (columns.colors) out << "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  out << "end_header\n";
  auto put = [&out](auto value) { out.write(reinterpret_cast<const char*>(&value), sizeof(value)); };
  for (const SweepPoint& p : points) {
    for (int a = 0; a < 3; ++a) put(p.position[a]);
    if (columns.origins)
      for (int a = 0; a < 3; ++a) put(float(p.origin[a]));
    if (columns.normals)
      for (int a = 0; a < 3; ++a) put(p.normal[a]);
    if (columns.confidence >= 0) put(columns.confidence);
    if (columns.colors)
      for (int a = 0; a < 3; ++a) put(p.color[a]);
  }
}

}  // namespace pg::fusion::testing

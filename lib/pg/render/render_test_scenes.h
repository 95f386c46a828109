#pragma once
// Cameras and meshes with analytic ground truth, shared by the render tests.
#include <Eigen/Geometry>
#include <cmath>
#include <numbers>
#include <optional>
#include <vector>

#include "pg/camera/camera.h"
#include "pg/mesh/mesh.h"

namespace pg::render_test {

inline Rigid3 some_pose() {
  Rigid3 pose;
  pose.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, 3).normalized()));
  pose.translation = Eigen::Vector3d(0.3, -1.2, 2.5);
  return pose;
}

inline Camera pinhole_distorted() {
  Camera c;
  c.id = "pinhole";
  c.width = 640, c.height = 480;
  c.model = CameraModel::pinhole;
  c.intrinsics = {500, 505, 321.3, 238.7};
  c.distortion.k1 = -0.15, c.distortion.k2 = 0.03, c.distortion.p1 = 5e-4, c.distortion.p2 = -3e-4;
  c.cam_from_world = some_pose();
  return c;
}

// About 218 degrees across the diagonal: the corners see rays behind the camera (z < 0).
inline Camera fisheye_wide() {
  Camera c;
  c.id = "fisheye";
  c.width = 640, c.height = 480;
  c.model = CameraModel::fisheye;
  c.intrinsics = {200, 200, 319.5, 239.5};
  c.distortion.k1 = 0.05, c.distortion.k2 = -0.01, c.distortion.k3 = 0.002;
  c.cam_from_world = some_pose();
  return c;
}

inline Camera equirect() {
  Camera c;
  c.id = "equirect";
  c.width = 512, c.height = 256;
  c.model = CameraModel::equirectangular;
  c.cam_from_world = some_pose();
  return c;
}

inline std::vector<Camera> all_models() {
  return {pinhole_distorted(), fisheye_wide(), equirect()};
}

// A parallelogram centre +- a +- b, in the frame of `camera` (converted to world coordinates).
struct Quad {
  Eigen::Vector3d centre, a, b;
};

inline Eigen::Vector3d world_from_cam(const Camera& camera, const Eigen::Vector3d& p) {
  return camera.cam_from_world.inverse() * p;
}

// Appends two triangles per quad, with uvs spanning [uv0, uv1] across each quad.
inline Mesh quads_mesh(const Camera& camera, const std::vector<Quad>& quads, float uv0 = 0, float uv1 = 1) {
  Mesh mesh;
  for (const Quad& q : quads) {
    auto base = std::uint32_t(mesh.positions.size());
    const double su[4] = {-1, 1, 1, -1}, sv[4] = {-1, -1, 1, 1};
    for (int i = 0; i < 4; ++i) {
      mesh.positions.push_back(world_from_cam(camera, q.centre + su[i] * q.a + sv[i] * q.b).cast<float>());
      mesh.uvs.emplace_back(su[i] < 0 ? uv0 : uv1, sv[i] < 0 ? uv0 : uv1);
    }
    mesh.faces.push_back({base, base + 1, base + 2});
    mesh.faces.push_back({base, base + 2, base + 3});
  }
  return mesh;
}

// Nearest hit of the camera-frame ray d (from the camera centre) with the quads: range, or nullopt.
// `grow` widens each quad by that fraction (positive) or shrinks it (negative).
inline std::optional<double> quads_hit(const std::vector<Quad>& quads, const Eigen::Vector3d& d,
                                       double grow = 0) {
  std::optional<double> best;
  for (const Quad& q : quads) {
    Eigen::Vector3d n = q.a.cross(q.b);
    double denom = d.dot(n);
    if (denom == 0) continue;
    double t = q.centre.dot(n) / denom;
    if (!(t > 0)) continue;
    Eigen::Vector3d local = t * d - q.centre;
    // local = s a + r b: solve the 2x2 normal equations (a and b need not be orthogonal).
    const double aa = q.a.dot(q.a), ab = q.a.dot(q.b), bb = q.b.dot(q.b), la = local.dot(q.a),
                 lb = local.dot(q.b);
    const double det = aa * bb - ab * ab;
    const double s = (la * bb - lb * ab) / det, r = (lb * aa - la * ab) / det;
    if (std::abs(s) > 1 + grow || std::abs(r) > 1 + grow) continue;
    if (!best || t < *best) best = t;
  }
  return best;
}

// A latitude-longitude sphere (poles are vertices) around `centre`, its pole axis `axis`, faces
// counter-clockwise seen from outside. Positions are in world coordinates.
inline Mesh uv_sphere(const Eigen::Vector3d& centre, double radius, int rings, int segments,
                      const Eigen::Vector3d& axis = Eigen::Vector3d::UnitY(), double spin = 0) {
  Eigen::Matrix3d frame =
      Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), axis.normalized()).toRotationMatrix() *
      Eigen::AngleAxisd(spin, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  Mesh mesh;
  auto vertex = [&](double theta, double phi) {
    Eigen::Vector3d p(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
    mesh.positions.push_back((centre + radius * (frame * p)).cast<float>());
    mesh.uvs.emplace_back(float(phi / (2 * std::numbers::pi)), float(1 - theta / std::numbers::pi));
  };
  vertex(0, 0);
  for (int i = 1; i < rings; ++i)
    for (int j = 0; j < segments; ++j)
      vertex(std::numbers::pi * i / rings, 2 * std::numbers::pi * j / segments);
  vertex(std::numbers::pi, 0);
  const auto last = std::uint32_t(mesh.positions.size() - 1);
  auto ring = [&](int i, int j) { return std::uint32_t(1 + (i - 1) * segments + (j % segments)); };
  for (int j = 0; j < segments; ++j) {
    mesh.faces.push_back({0, ring(1, j), ring(1, j + 1)});
    mesh.faces.push_back({last, ring(rings - 1, j + 1), ring(rings - 1, j)});
    for (int i = 1; i + 1 < rings; ++i) {
      mesh.faces.push_back({ring(i, j), ring(i + 1, j), ring(i + 1, j + 1)});
      mesh.faces.push_back({ring(i, j), ring(i + 1, j + 1), ring(i, j + 1)});
    }
  }
  // Orient every face outwards.
  for (auto& f : mesh.faces) {
    Eigen::Vector3d p0 = mesh.positions[f[0]].cast<double>(), p1 = mesh.positions[f[1]].cast<double>(),
                    p2 = mesh.positions[f[2]].cast<double>();
    if ((p1 - p0).cross(p2 - p0).dot(p0 + p1 + p2 - 3 * centre) < 0) std::swap(f[1], f[2]);
  }
  return mesh;
}

}  // namespace pg::render_test

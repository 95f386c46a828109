#pragma once
// Small exact scenes for the fusion tests: meshes built here and depth maps ray-cast through a BVH,
// so the true surface is known to float precision.
#include <cmath>
#include <numbers>

#include "pg/camera/camera.h"
#include "pg/fusion/depth_frame.h"
#include "pg/mesh/bvh.h"
#include "pg/mesh/mesh.h"

namespace pg::fusion::testing {

inline void append(Mesh& into, const Mesh& part) {
  const auto base = std::uint32_t(into.positions.size());
  into.positions.insert(into.positions.end(), part.positions.begin(), part.positions.end());
  for (auto f : part.faces) into.faces.push_back({f[0] + base, f[1] + base, f[2] + base});
}

// A UV sphere, faces counter-clockwise from outside.
inline Mesh sphere(const Eigen::Vector3f& centre, float radius, int rings = 48, int segments = 96) {
  Mesh m;
  for (int r = 0; r <= rings; ++r)
    for (int s = 0; s < segments; ++s) {
      const float theta = std::numbers::pi_v<float> * r / rings,
                  phi = 2 * std::numbers::pi_v<float> * s / segments;
      m.positions.push_back(centre + radius * Eigen::Vector3f(std::sin(theta) * std::cos(phi),
                                                              std::sin(theta) * std::sin(phi),
                                                              std::cos(theta)));
    }
  for (int r = 0; r < rings; ++r)
    for (int s = 0; s < segments; ++s) {
      const std::uint32_t a = r * segments + s, b = r * segments + (s + 1) % segments;
      const std::uint32_t c = a + segments, d = b + segments;
      if (r > 0) m.faces.push_back({a, c, b});
      if (r + 1 < rings) m.faces.push_back({b, c, d});
    }
  return m;
}

// An axis-aligned box subdivided n times per side, faces outward (or inward for a room).
inline Mesh box(const Eigen::Vector3f& lo, const Eigen::Vector3f& hi, int n = 8, bool inward = false) {
  Mesh m;
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side) {
      const int u = (axis + 1) % 3, v = (axis + 2) % 3;
      const auto base = std::uint32_t(m.positions.size());
      for (int i = 0; i <= n; ++i)
        for (int j = 0; j <= n; ++j) {
          Eigen::Vector3f p;
          p[axis] = side ? hi[axis] : lo[axis];
          p[u] = lo[u] + (hi[u] - lo[u]) * i / n;
          p[v] = lo[v] + (hi[v] - lo[v]) * j / n;
          m.positions.push_back(p);
        }
      for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
          const std::uint32_t a = base + i * (n + 1) + j, b = a + n + 1, c = a + 1, d = b + 1;
          // u x v = +axis: counter-clockwise seen from +axis for (a, b, d) ordering.
          const bool outward_positive = (side == 1) != inward;
          if (outward_positive) {
            m.faces.push_back({a, b, d});
            m.faces.push_back({a, d, c});
          } else {
            m.faces.push_back({a, d, b});
            m.faces.push_back({a, c, d});
          }
        }
    }
  return m;
}

// A ground square at z = 0, facing +z.
inline Mesh ground(float half, int n = 16) {
  Mesh m;
  for (int i = 0; i <= n; ++i)
    for (int j = 0; j <= n; ++j)
      m.positions.emplace_back(-half + 2 * half * i / n, -half + 2 * half * j / n, 0.0f);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const std::uint32_t a = i * (n + 1) + j, b = a + n + 1, c = a + 1, d = b + 1;
      m.faces.push_back({a, b, d});
      m.faces.push_back({a, d, c});
    }
  return m;
}

inline Camera pinhole_camera(int width, int height, double focal, const Eigen::Vector3d& centre,
                             const Eigen::Vector3d& target) {
  Camera c;
  c.width = width;
  c.height = height;
  c.intrinsics = {focal, focal, (width - 1) / 2.0, (height - 1) / 2.0};
  c.cam_from_world = Rigid3::look_at(centre, target);
  return c;
}

// Exact depth of the mesh seen by the camera: z for perspective cameras, range for panoramas.
inline DepthMap render_depth(const TriangleBvh& bvh, const Camera& camera) {
  DepthMap map;
  map.camera = camera;
  map.kind = camera.is_perspective() ? DepthKind::perspective_z : DepthKind::spherical_range;
  map.depth = cv::Mat1f(camera.height, camera.width, NAN);
  const Rigid3 world_from_cam = camera.cam_from_world.inverse();
  for (int y = 0; y < camera.height; ++y)
    for (int x = 0; x < camera.width; ++x) {
      const Eigen::Vector3d ray = camera.unproject(Eigen::Vector2d(x, y));
      const auto hit = bvh.intersect(world_from_cam.translation.cast<float>(),
                                     (world_from_cam.rotation * ray).cast<float>());
      if (hit.hit)
        map.depth.at<float>(y, x) = float(map.kind == DepthKind::perspective_z ? hit.t * ray.z() : hit.t);
    }
  return map;
}

// Views on a ring around the origin looking at `target`.
inline std::vector<Camera> orbit(int views, double radius, double height, const Eigen::Vector3d& target,
                                 int width, int height_px, double focal) {
  std::vector<Camera> cameras;
  for (int i = 0; i < views; ++i) {
    const double a = 2 * std::numbers::pi * i / views;
    Camera c =
        pinhole_camera(width, height_px, focal, {radius * std::cos(a), radius * std::sin(a), height}, target);
    c.id = "view_" + std::to_string(i);
    cameras.push_back(c);
  }
  return cameras;
}

}  // namespace pg::fusion::testing

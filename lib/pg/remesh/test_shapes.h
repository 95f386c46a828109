#pragma once
// Shapes for the remesh tests: a latitude-longitude sphere (poor triangles at the poles), a box
// with sharp edges and corners, and a plane with a bump deformed into it.
#include <cmath>
#include <map>
#include <numbers>

#include "pg/mesh/mesh.h"

namespace pg::test {

// A UV sphere of `rings` latitude bands and `segments` longitude steps, counter-clockwise outside.
inline Mesh uv_sphere(int rings, int segments, float radius) {
  Mesh mesh;
  const float pi = std::numbers::pi_v<float>;
  mesh.positions.emplace_back(0.0f, 0.0f, radius);
  for (int r = 1; r < rings; ++r) {
    const float theta = pi * float(r) / float(rings);
    for (int s = 0; s < segments; ++s) {
      const float phi = 2 * pi * float(s) / float(segments);
      mesh.positions.emplace_back(radius * std::sin(theta) * std::cos(phi),
                                  radius * std::sin(theta) * std::sin(phi), radius * std::cos(theta));
    }
  }
  mesh.positions.emplace_back(0.0f, 0.0f, -radius);
  const auto ring = [&](int r, int s) { return std::uint32_t(1 + (r - 1) * segments + (s % segments)); };
  const auto south = std::uint32_t(mesh.positions.size() - 1);
  for (int s = 0; s < segments; ++s) mesh.faces.push_back({0, ring(1, s), ring(1, s + 1)});
  for (int r = 1; r + 1 < rings; ++r)
    for (int s = 0; s < segments; ++s) {
      mesh.faces.push_back({ring(r, s), ring(r + 1, s), ring(r + 1, s + 1)});
      mesh.faces.push_back({ring(r, s), ring(r + 1, s + 1), ring(r, s + 1)});
    }
  for (int s = 0; s < segments; ++s)
    mesh.faces.push_back({ring(rings - 1, s), south, ring(rings - 1, s + 1)});
  return mesh;
}

// The box [0, size.x] x [0, size.y] x [0, size.z], each side an n x n grid of quads split in two,
// vertices shared along the edges, counter-clockwise outside.
inline Mesh box(const Eigen::Vector3f& size, int n) {
  Mesh mesh;
  std::map<std::array<int, 3>, std::uint32_t> index;  // lattice coordinates -> vertex
  const auto vertex = [&](std::array<int, 3> c) {
    const auto [it, added] = index.try_emplace(c, std::uint32_t(mesh.positions.size()));
    if (added)
      mesh.positions.emplace_back(size.x() * float(c[0]) / float(n), size.y() * float(c[1]) / float(n),
                                  size.z() * float(c[2]) / float(n));
    return it->second;
  };
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side) {
      const int u = (axis + 1) % 3, v = (axis + 2) % 3;
      for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
          std::array<std::uint32_t, 4> q;
          const int corners[4][2] = {{i, j}, {i + 1, j}, {i + 1, j + 1}, {i, j + 1}};
          for (int k = 0; k < 4; ++k) {
            std::array<int, 3> c{};
            c[axis] = side * n;
            c[u] = corners[k][0];
            c[v] = corners[k][1];
            q[k] = vertex(c);
          }
          if (side == 1) {
            mesh.faces.push_back({q[0], q[1], q[2]});
            mesh.faces.push_back({q[0], q[2], q[3]});
          } else {
            mesh.faces.push_back({q[0], q[2], q[1]});
            mesh.faces.push_back({q[0], q[3], q[2]});
          }
        }
    }
  return mesh;
}

// A flat n x n grid over [0, 1]^2 at z = 0 (before) ...
inline Mesh flat_plane(int n) {
  Mesh mesh;
  for (int y = 0; y <= n; ++y)
    for (int x = 0; x <= n; ++x) mesh.positions.emplace_back(float(x) / float(n), float(y) / float(n), 0.0f);
  const auto at = [&](int x, int y) { return std::uint32_t(y * (n + 1) + x); };
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      mesh.faces.push_back({at(x, y), at(x + 1, y), at(x + 1, y + 1)});
      mesh.faces.push_back({at(x, y), at(x + 1, y + 1), at(x, y + 1)});
    }
  return mesh;
}

// The height of the bump: a smooth cosine cap of `height` within `radius` of (0.5, 0.5).
inline float bump_height(float x, float y, float radius, float height) {
  const float r = std::hypot(x - 0.5f, y - 0.5f);
  return r < radius ? height * 0.5f * (1 + std::cos(std::numbers::pi_v<float> * r / radius)) : 0.0f;
}

// ... and after: the same grid with the bump pushed up (only vertices within `radius` move).
inline Mesh bumped_plane(int n, float radius, float height) {
  Mesh mesh = flat_plane(n);
  for (auto& p : mesh.positions) p.z() = bump_height(p.x(), p.y(), radius, height);
  return mesh;
}

}  // namespace pg::test

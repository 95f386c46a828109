#pragma once
// Meshes the benchmarks render: procedural, so no data file is needed.
#include <cmath>
#include <cstdint>
#include <numbers>

#include "pg/mesh/mesh.h"

namespace pg::bench {

// A unit sphere with a small bump pattern, `rings` x `segments` quads split into triangles (poles as
// fans), with UVs: about 2 x rings x segments triangles.
inline Mesh displaced_sphere(int rings, int segments) {
  Mesh mesh;
  for (int i = 0; i <= rings; ++i)
    for (int j = 0; j <= segments; ++j) {
      const double theta = std::numbers::pi * i / rings, phi = 2 * std::numbers::pi * j / segments;
      const double r = 1 + 0.04 * std::sin(9 * theta) * std::cos(7 * phi);
      mesh.positions.emplace_back(float(r * std::sin(theta) * std::cos(phi)), float(r * std::cos(theta)),
                                  float(r * std::sin(theta) * std::sin(phi)));
      mesh.uvs.emplace_back(float(j) / segments, 1 - float(i) / rings);
    }
  auto id = [&](int i, int j) { return std::uint32_t(i * (segments + 1) + j); };
  for (int i = 0; i < rings; ++i)
    for (int j = 0; j < segments; ++j) {
      if (i > 0) mesh.faces.push_back({id(i, j), id(i, j + 1), id(i + 1, j + 1)});
      if (i + 1 < rings) mesh.faces.push_back({id(i, j), id(i + 1, j + 1), id(i + 1, j)});
    }
  return mesh;
}

}  // namespace pg::bench

#pragma once
// Meshes for the mesh module's tests.
#include <gtest/gtest.h>

#include <random>
#include <string>

#include "pg/mesh/mesh.h"
#include "pg/mesh/ply_format.h"

namespace pg::test {

// A (cols x rows) grid of quads in the z = 0 plane, each split into two counter-clockwise triangles.
inline Mesh grid_mesh(int cols, int rows, float spacing = 1.0f) {
  Mesh mesh;
  for (int y = 0; y <= rows; ++y)
    for (int x = 0; x <= cols; ++x) mesh.positions.emplace_back(float(x) * spacing, float(y) * spacing, 0.0f);
  const auto at = [&](int x, int y) { return std::uint32_t(y * (cols + 1) + x); };
  for (int y = 0; y < rows; ++y)
    for (int x = 0; x < cols; ++x) {
      mesh.faces.push_back({at(x, y), at(x + 1, y), at(x + 1, y + 1)});
      mesh.faces.push_back({at(x, y), at(x + 1, y + 1), at(x, y + 1)});
    }
  return mesh;
}

// Random triangles of about `size` in the unit cube, a few of them degenerate.
inline Mesh random_soup(int triangles, float size, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f), offset(-size, size);
  Mesh mesh;
  for (int t = 0; t < triangles; ++t) {
    const Eigen::Vector3f centre{unit(rng), unit(rng), unit(rng)};
    const auto base = std::uint32_t(mesh.positions.size());
    for (int k = 0; k < 3; ++k)
      mesh.positions.push_back(centre + Eigen::Vector3f{offset(rng), offset(rng), offset(rng)});
    if (t % 97 == 0) mesh.positions[base + 2] = mesh.positions[base + 1];  // zero-area triangle
    mesh.faces.push_back({base, base + 1, base + 2});
  }
  return mesh;
}

// Every attribute and two named properties, with values that are hard to round-trip as text.
inline Mesh attributed_mesh() {
  Mesh mesh = grid_mesh(3, 2, 0.1f);
  const std::size_t n = mesh.vertex_count();
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> any(-1000.0f, 1000.0f), unit(0.0f, 1.0f);
  for (auto& p : mesh.positions) p += Eigen::Vector3f{any(rng), any(rng), any(rng)} * 1e-3f;
  mesh.positions[0] = {1e-40f, -0.0f, 3.4e38f};  // a denormal, negative zero and a huge value
  for (std::size_t i = 0; i < n; ++i) {
    mesh.normals.push_back(Eigen::Vector3f{any(rng), any(rng), any(rng)}.normalized());
    mesh.colors.push_back({std::uint8_t(i * 37), std::uint8_t(255 - i), std::uint8_t(i * 101)});
    mesh.uvs.push_back(Eigen::Vector2f{unit(rng), unit(rng)});
    mesh.vertex_properties["working_set"].push_back(i % 3 == 0 ? 1.0f : 0.0f);
    mesh.vertex_properties["confidence"].push_back(unit(rng) / 3.0f);
  }
  mesh.provenance.tool = "pg-test";
  mesh.provenance.version = "1.2.3";
  mesh.provenance.command_line = "pg-test --in \"a b.ply\"\nsecond line";
  mesh.provenance.created_utc = "2024-01-02T03:04:05Z";
  mesh.provenance.inputs = {"a b.ply", "c.json"};
  return mesh;
}

// Names for tests parameterised by encoding.
inline std::string encoding_name(const ::testing::TestParamInfo<PlyEncoding>& info) {
  switch (info.param) {
    case PlyEncoding::ascii:
      return "ascii";
    case PlyEncoding::binary_little_endian:
      return "binary_little_endian";
    case PlyEncoding::binary_big_endian:
      return "binary_big_endian";
  }
  return "unknown";
}

}  // namespace pg::test

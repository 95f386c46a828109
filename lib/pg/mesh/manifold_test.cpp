#include "pg/mesh/manifold.h"

#include <gtest/gtest.h>

namespace {
// Two triangle fans (square pyramids without bases) touching at their apex, vertex 0.
pg::Mesh bow_tie() {
  pg::Mesh m;
  m.positions = {{0, 0, 0}, {1, 1, 1}, {-1, 1, 1}, {0, -1, 1}, {1, 1, -1}, {-1, 1, -1}, {0, -1, -1}};
  m.faces = {{0, 1, 2}, {0, 2, 3}, {0, 3, 1}, {0, 5, 4}, {0, 6, 5}, {0, 4, 6}};
  m.vertex_properties["pinned"] = {1, 0, 0, 0, 0, 0, 0};
  m.colors.assign(7, {10, 20, 30});
  return m;
}
}  // namespace

TEST(Manifold, SplitsAVertexSharedByTwoFans) {
  pg::Mesh m = bow_tie();
  EXPECT_EQ(pg::split_nonmanifold_vertices(m), 1u);
  ASSERT_EQ(m.positions.size(), 8u);
  EXPECT_EQ(m.positions[7], m.positions[0]);
  EXPECT_EQ(m.vertex_properties["pinned"][7], 1.0f);
  EXPECT_EQ(m.colors[7], m.colors[0]);
  for (int f = 0; f < 3; ++f) EXPECT_EQ(m.faces[f][0], 0u);  // the first fan keeps the vertex
  for (int f = 3; f < 6; ++f) EXPECT_EQ(m.faces[f][0], 7u);  // the second gets the copy
  EXPECT_EQ(pg::split_nonmanifold_vertices(m), 0u);        // idempotent
}

TEST(Manifold, LeavesManifoldMeshesUntouched) {
  pg::Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  m.faces = {{0, 1, 2}, {0, 2, 3}};
  const auto faces = m.faces;
  EXPECT_EQ(pg::split_nonmanifold_vertices(m), 0u);
  EXPECT_EQ(m.faces, faces);
  EXPECT_EQ(m.positions.size(), 4u);
}

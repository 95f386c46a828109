#include <gtest/gtest.h>

#include "pg/core/error.h"
#include "pg/mesh/mesh.h"
#include "pg/mesh/test_meshes.h"

namespace pg {
namespace {

// FNV-1a 64 written out independently of pg::fnv1a64.
std::string reference_faces_hash(const std::vector<std::array<std::uint32_t, 3>>& faces) {
  std::uint64_t h = 14695981039346656037ull;
  for (const auto& f : faces)
    for (std::uint32_t v : f)
      for (int byte = 0; byte < 4; ++byte) {
        h ^= (v >> (8 * byte)) & 0xff;
        h *= 1099511628211ull;
      }
  char text[17];
  std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(h));
  return text;
}

TEST(Mesh, TopologyIdHashesFacesAsLittleEndianTriples) {
  const Mesh mesh = test::grid_mesh(5, 4);
  const TopologyId id = topology_id(mesh);
  EXPECT_EQ(id.vertex_count, 30u);
  EXPECT_EQ(id.face_count, 40u);
  EXPECT_EQ(id.faces_fnv1a64, reference_faces_hash(mesh.faces));
  // An empty face list hashes to the FNV offset basis.
  EXPECT_EQ(topology_id(Mesh{}).faces_fnv1a64, "cbf29ce484222325");
}

TEST(Mesh, TopologyIdSurvivesMovesButNotFaceChanges) {
  Mesh mesh = test::grid_mesh(4, 4);
  const TopologyId before = topology_id(mesh);
  for (auto& p : mesh.positions) p += Eigen::Vector3f(0.1f, -0.2f, p.x() * 0.3f);
  EXPECT_EQ(topology_id(mesh), before);
  std::swap(mesh.faces[0][1], mesh.faces[0][2]);  // flipped orientation: another face list
  EXPECT_NE(topology_id(mesh).faces_fnv1a64, before.faces_fnv1a64);
}

TEST(Mesh, VertexNormalsAreAreaWeighted) {
  // Vertex 0 is shared by a large triangle in the z = 0 plane and a small one in the x = 0 plane.
  Mesh mesh;
  mesh.positions = {{0, 0, 0}, {2, 0, 0}, {0, 2, 0}, {0, 1, 0}, {0, 0, 1}};
  mesh.faces = {{0, 1, 2}, {0, 3, 4}};
  mesh.compute_vertex_normals();
  // Large: area 2, normal +z. Small: area 0.5, normal +x.
  const Eigen::Vector3f expected = Eigen::Vector3f(0.5f, 0, 2).normalized();
  EXPECT_TRUE(mesh.normals[0].isApprox(expected, 1e-6f));
  EXPECT_TRUE(mesh.normals[1].isApprox(Eigen::Vector3f(0, 0, 1), 1e-6f));
  EXPECT_TRUE(mesh.normals[4].isApprox(Eigen::Vector3f(1, 0, 0), 1e-6f));
}

TEST(Mesh, BoundsAndConsistency) {
  Mesh mesh = test::grid_mesh(3, 2, 0.5f);
  EXPECT_TRUE(mesh.bounds().min().isApprox(Eigen::Vector3f(0, 0, 0)));
  EXPECT_TRUE(mesh.bounds().max().isApprox(Eigen::Vector3f(1.5f, 1.0f, 0)));
  EXPECT_TRUE(Mesh{}.bounds().isEmpty());
  EXPECT_NO_THROW(mesh.check_consistent());
  mesh.normals.resize(2);
  EXPECT_THROW(mesh.check_consistent(), Error);
  mesh.normals.clear();
  mesh.vertex_properties["pinned"] = {1.0f};
  EXPECT_THROW(mesh.check_consistent(), Error);
  mesh.vertex_properties.clear();
  mesh.faces[3][1] = std::uint32_t(mesh.vertex_count());
  try {
    mesh.check_consistent();
    FAIL() << "an out-of-range face index was accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ExitCode::internal);
    EXPECT_NE(std::string(e.what()).find("face 3"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace pg

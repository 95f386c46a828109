#include <gtest/gtest.h>

#include <cstring>

#include "pg/build_info.h"
#include "pg/core/error.h"
#include "pg/mesh/mesh_io.h"
#include "pg/mesh/test_meshes.h"
#include "pg/testing/testing.h"

namespace pg {
namespace {

using pg::testing::TempDir;

std::uint32_t bits(float value) {
  std::uint32_t out = 0;
  std::memcpy(&out, &value, sizeof value);
  return out;
}

Mesh read_obj_text(const TempDir& dir, const std::string& text) {
  const auto path = dir / "in.obj";
  pg::testing::write_text(path, text);
  return read_mesh_obj(path);
}

TEST(Obj, RoundTripKeepsAttributesBitExact) {
  TempDir dir;
  Mesh mesh = test::attributed_mesh();
  mesh.vertex_properties.clear();  // OBJ cannot hold them
  write_mesh_obj(dir / "m.obj", mesh);
  const Mesh back = read_mesh_obj(dir / "m.obj");
  ASSERT_EQ(back.vertex_count(), mesh.vertex_count());
  EXPECT_EQ(back.faces, mesh.faces);
  EXPECT_EQ(back.colors, mesh.colors);
  for (std::size_t i = 0; i < mesh.vertex_count(); ++i)
    for (int k = 0; k < 3; ++k) {
      EXPECT_EQ(bits(back.positions[i][k]), bits(mesh.positions[i][k]));
      EXPECT_EQ(bits(back.normals[i][k]), bits(mesh.normals[i][k]));
      if (k < 2) {
        EXPECT_EQ(bits(back.uvs[i][k]), bits(mesh.uvs[i][k]));
      }
    }
  EXPECT_EQ(back.provenance.command_line, mesh.provenance.command_line);
  EXPECT_EQ(back.provenance.inputs, mesh.provenance.inputs);
  const std::string text = pg::testing::read_text(dir / "m.obj");
  EXPECT_EQ(text.rfind("# pg-format pg-mesh 1\n# pg-provenance {", 0), 0u);
  EXPECT_NE(text.find("\nf 1/1/1 2/2/2 6/6/6\n"), std::string::npos);
}

TEST(Obj, PositionsOnlyRoundTrip) {
  TempDir dir;
  const Mesh mesh = test::grid_mesh(3, 3, 0.25f);
  write_mesh_obj(dir / "g.obj", mesh);
  const Mesh back = read_mesh_obj(dir / "g.obj");
  EXPECT_EQ(back.positions, mesh.positions);
  EXPECT_EQ(back.faces, mesh.faces);
  EXPECT_TRUE(back.normals.empty() && back.uvs.empty() && back.colors.empty());
  EXPECT_NE(pg::testing::read_text(dir / "g.obj").find("\nf 1 2 6\n"), std::string::npos);
}

TEST(Obj, SplitsVerticesUsedWithDifferentTextureCoordinates) {
  // Two triangles share the edge 1-3 but use different vt there (a UV seam).
  TempDir dir;
  const Mesh mesh = read_obj_text(dir,
                                  "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
                                  "vt 0 0\nvt 0.5 0\nvt 0.5 0.5\nvt 0.6 0\nvt 0.6 0.5\nvt 1 1\n"
                                  "f 1/1 2/2 3/3\nf 1/4 3/5 4/6\n");
  // Vertex 1 (index 0) and 3 (index 2) need copies: 4 + 2 vertices.
  ASSERT_EQ(mesh.vertex_count(), 6u);
  ASSERT_EQ(mesh.uvs.size(), 6u);
  EXPECT_TRUE(mesh.normals.empty());
  ASSERT_EQ(mesh.face_count(), 2u);
  const std::vector<std::array<std::uint32_t, 3>> faces = {{0, 1, 2}, {4, 5, 3}};
  EXPECT_EQ(mesh.faces, faces);
  // Each corner has the position of its file vertex and its own texture coordinate.
  const Eigen::Vector3f corner_positions[2][3] = {{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}},
                                                  {{0, 0, 0}, {1, 1, 0}, {0, 1, 0}}};
  const Eigen::Vector2f corner_uvs[2][3] = {{{0, 0}, {0.5f, 0}, {0.5f, 0.5f}},
                                            {{0.6f, 0}, {0.6f, 0.5f}, {1, 1}}};
  for (int f = 0; f < 2; ++f)
    for (int c = 0; c < 3; ++c) {
      EXPECT_EQ(mesh.positions[mesh.faces[f][c]], corner_positions[f][c]) << f << " " << c;
      EXPECT_EQ(mesh.uvs[mesh.faces[f][c]], corner_uvs[f][c]) << f << " " << c;
    }
}

TEST(Obj, NegativeIndicesPolygonsAndNormalOnlyCorners) {
  TempDir dir;
  const Mesh mesh = read_obj_text(dir,
                                  "# a quad with one normal\no quad\ng group\ns off\nusemtl none\n"
                                  "v 0 0 0\r\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvn 0 0 1\n"
                                  "f -4//-1 -3//-1 -2//-1 -1//1\nl 1 2\n");
  ASSERT_EQ(mesh.vertex_count(), 4u);
  EXPECT_EQ(mesh.faces, (std::vector<std::array<std::uint32_t, 3>>{{0, 1, 2}, {0, 2, 3}}));
  ASSERT_EQ(mesh.normals.size(), 4u);
  for (const auto& n : mesh.normals) EXPECT_EQ(n, Eigen::Vector3f(0, 0, 1));
  EXPECT_TRUE(mesh.uvs.empty());
}

TEST(Obj, VertexColoursAndFullCorners) {
  TempDir dir;
  const Mesh mesh = read_obj_text(dir,
                                  "v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0 0 0.5\n"
                                  "vt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 1\nvn 0 0 -1\n"
                                  "f 1/1/1 2/2/1 3/3/1\nf 1/1/2 3/3/2 2/2/2\n");
  // The second face uses every vertex with another normal: three copies.
  ASSERT_EQ(mesh.vertex_count(), 6u);
  EXPECT_EQ(mesh.colors[2], (std::array<std::uint8_t, 3>{0, 0, 128}));
  EXPECT_EQ(mesh.colors[mesh.faces[1][1]], mesh.colors[2]);
  EXPECT_EQ(mesh.normals[mesh.faces[1][0]], Eigen::Vector3f(0, 0, -1));
  EXPECT_EQ(mesh.normals[mesh.faces[0][0]], Eigen::Vector3f(0, 0, 1));
  EXPECT_EQ(mesh.uvs[mesh.faces[1][2]], Eigen::Vector2f(1, 0));
}

TEST(Obj, RejectsMalformedLinesNamingFileAndLine) {
  TempDir dir;
  const auto expect_rejected = [&](const std::string& text, const std::string& expected) {
    try {
      read_obj_text(dir, text);
      ADD_FAILURE() << "accepted: " << text;
    } catch (const InputError& e) {
      const std::string message = e.what();
      EXPECT_EQ(message.rfind((dir / "in.obj").string() + ": ", 0), 0u) << message;
      EXPECT_NE(message.find(expected), std::string::npos) << message;
    }
  };
  expect_rejected("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", "line 4: vertex index 4 out of range");
  expect_rejected("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -4\n", "vertex index -4 out of range");
  expect_rejected("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 0\n", "\"0\" is not a valid vertex index");
  expect_rejected("v 0 0 0\nv 1 0 0\nf 1 2\n", "a face has 2 vertices");
  expect_rejected("v 0 zero 0\n", "line 1: \"zero\" is not a number");
  expect_rejected("v 0 0 0\nv 0 nan 0\n", "line 2: \"nan\" is not a finite number");
  expect_rejected("v 0 0 0\nvn 1e39 0 0\n", "\"1e39\" is not");
  expect_rejected("v 0 0\n", "expects 3 to 6 numbers");
  expect_rejected("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1 2/1 3/1\n", "texture coordinate index 1 out of range");
  expect_rejected("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/ 2/ 3//\n", "empty normal index");
  expect_rejected("# pg-format pg-mesh 3\n", "version 3 is not supported");
  expect_rejected("v 0 0 0 1 1 1\nv 0 0 0\n", "some \"v\" lines have colours");
  EXPECT_THROW(read_mesh_obj(dir / "absent.obj"), InputError);
}

TEST(Obj, ExampleMatchesThePlyExample) {
  const std::filesystem::path examples =
      std::filesystem::path(build_info::source_dir) / "formats" / "examples";
  const Mesh obj = read_mesh(examples / "quad-strip.obj");
  const Mesh ply = read_mesh(examples / "quad-strip.ply");
  EXPECT_EQ(obj.positions, ply.positions);
  EXPECT_EQ(obj.faces, ply.faces);
  EXPECT_EQ(obj.uvs, ply.uvs);
  EXPECT_EQ(obj.normals, ply.normals);
  EXPECT_EQ(topology_id(obj), topology_id(ply));
  EXPECT_EQ(obj.provenance.tool, "pg-example");
}

TEST(MeshIo, DispatchesOnExtensionCaseInsensitively) {
  TempDir dir;
  Mesh mesh = test::grid_mesh(2, 1);
  mesh.vertex_properties["pinned"] = std::vector<float>(mesh.vertex_count(), 1.0f);
  write_mesh(dir / "a.PLY", mesh);
  write_mesh(dir / "b.Obj", mesh);
  EXPECT_EQ(pg::testing::read_text(dir / "a.PLY").rfind("ply\nformat binary_little_endian", 0), 0u);
  EXPECT_EQ(pg::testing::read_text(dir / "b.Obj").rfind("# pg-format pg-mesh 1", 0), 0u);
  EXPECT_EQ(read_mesh(dir / "a.PLY").vertex_properties.at("pinned"), mesh.vertex_properties.at("pinned"));
  const Mesh from_obj = read_mesh(dir / "b.Obj");
  EXPECT_EQ(from_obj.positions, mesh.positions);
  EXPECT_TRUE(from_obj.vertex_properties.empty());
  EXPECT_THROW(write_mesh(dir / "c.stl", mesh), OutputError);
  pg::testing::write_text(dir / "d.stl", "solid x\n");
  EXPECT_THROW(read_mesh(dir / "d.stl"), InputError);
}

}  // namespace
}  // namespace pg

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "pg/build_info.h"
#include "pg/core/error.h"
#include "pg/mesh/ply_io.h"
#include "pg/mesh/test_meshes.h"
#include "pg/mesh/vertex_mask.h"
#include "pg/testing/testing.h"

namespace pg {
namespace {

using pg::testing::TempDir;

VertexMask make_mask(const Mesh& mesh, const std::string& name, float fraction_set) {
  VertexMask mask;
  mask.name = name;
  mask.topology = topology_id(mesh);
  mask.weights.assign(mesh.vertex_count(), 0.0f);
  const auto set = std::size_t(fraction_set * float(mesh.vertex_count()));
  for (std::size_t i = 0; i < set; ++i)
    mask.weights[(i * 7) % mesh.vertex_count()] = float(i % 10 + 1) / 10.0f;
  mask.provenance.tool = "pg-test";
  return mask;
}

std::string encoding_of(const std::filesystem::path& path) {
  return nlohmann::json::parse(pg::testing::read_text(path)).at("encoding").get<std::string>();
}

TEST(VertexMask, RoundTripDenseAndSparse) {
  TempDir dir;
  const Mesh mesh = test::grid_mesh(10, 10);
  for (float fraction : {0.1f, 0.6f}) {
    const VertexMask mask = make_mask(mesh, "brush_weight", fraction);
    for (auto encoding : {MaskEncoding::automatic, MaskEncoding::dense, MaskEncoding::sparse}) {
      const auto path = dir / "m.pgmask.json";
      write_vertex_mask(path, mask, encoding);
      const VertexMask back = read_vertex_mask(path);
      EXPECT_EQ(back.name, mask.name);
      EXPECT_EQ(back.topology, mask.topology);
      EXPECT_EQ(back.weights, mask.weights);  // exact: 0.1, 0.2, ... read back to the same floats
      EXPECT_EQ(back.provenance.tool, "pg-test");
      const std::string expected = encoding == MaskEncoding::dense    ? "dense"
                                   : encoding == MaskEncoding::sparse ? "sparse"
                                   : fraction < 0.25f                 ? "sparse"
                                                                      : "dense";
      EXPECT_EQ(encoding_of(path), expected);
    }
  }
}

TEST(VertexMask, FileStartsWithFormatVersionProvenance) {
  TempDir dir;
  const Mesh mesh = test::grid_mesh(2, 2);
  write_vertex_mask(dir / "m.json", make_mask(mesh, "pinned", 0.5f));
  const std::string text = pg::testing::read_text(dir / "m.json");
  EXPECT_EQ(text.rfind("{\n  \"format\": \"pg-vertex-mask\",\n  \"version\": 1,\n  \"provenance\": {", 0), 0u)
      << text;
  EXPECT_NE(text.find("0.1"), std::string::npos);                  // shortest text for the floats
  EXPECT_EQ(text.find("0.10000000149011612"), std::string::npos);  // not the double expansion
}

TEST(VertexMask, FitsAfterVerticesMoveButNotAfterRemeshing) {
  TempDir dir;
  Mesh mesh = test::grid_mesh(6, 6);
  const VertexMask mask = make_mask(mesh, "working_set", 0.3f);
  const auto file = dir / "ws.pgmask.json";
  write_vertex_mask(file, mask);
  const VertexMask back = read_vertex_mask(file);

  for (auto& p : mesh.positions) p.z() += 0.01f * p.x() * p.y();  // refinement moves vertices
  EXPECT_NO_THROW(check_fits(back, mesh, file));

  const auto expect_refused = [&](const Mesh& other, const std::string& expected) {
    try {
      check_fits(back, other, file);
      ADD_FAILURE() << "mask accepted on a changed mesh";
    } catch (const InputError& e) {
      EXPECT_EQ(std::string(e.what()).rfind(file.string() + ": ", 0), 0u) << e.what();
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
    }
  };
  expect_refused(test::grid_mesh(7, 6), "49 vertices, this mesh has 56");
  Mesh fewer_faces = mesh;
  fewer_faces.faces.pop_back();
  expect_refused(fewer_faces, "72 faces, this mesh has 71");
  // Same counts, other connectivity: flip the diagonal of the first quad.
  Mesh flipped = mesh;
  flipped.faces[0] = {0, 1, 7};
  flipped.faces[1] = {1, 8, 7};
  expect_refused(flipped, "another face list");
  Mesh reordered = mesh;
  std::swap(reordered.faces[0], reordered.faces[5]);
  expect_refused(reordered, "another face list");
}

TEST(VertexMask, PropertyConversions) {
  Mesh mesh = test::grid_mesh(3, 3);
  const VertexMask mask = make_mask(mesh, "pinned", 0.5f);
  set_property_from_mask(mesh, mask);
  EXPECT_EQ(mesh.vertex_properties.at("pinned"), mask.weights);
  const VertexMask again = mask_from_property(mesh, "pinned");
  EXPECT_EQ(again.weights, mask.weights);
  EXPECT_EQ(again.topology, topology_id(mesh));
  EXPECT_EQ(again.name, "pinned");

  EXPECT_THROW(mask_from_property(mesh, "absent"), Error);
  mesh.vertex_properties["quality"] = std::vector<float>(mesh.vertex_count(), 2.0f);
  EXPECT_THROW(mask_from_property(mesh, "quality"), Error);
  mesh.vertex_properties["quality"][0] = NAN;
  EXPECT_THROW(mask_from_property(mesh, "quality"), Error);
  EXPECT_THROW(set_property_from_mask(mesh, make_mask(test::grid_mesh(4, 3), "pinned", 0.5f)), Error);

  // A mask survives a PLY round trip as a vertex property.
  TempDir dir;
  write_mesh_ply(dir / "m.ply", mesh);
  EXPECT_EQ(mask_from_property(read_mesh_ply(dir / "m.ply"), "pinned").weights, mask.weights);
}

TEST(VertexMask, WriterRefusesInvalidMasks) {
  TempDir dir;
  const Mesh mesh = test::grid_mesh(2, 2);
  VertexMask mask = make_mask(mesh, "pinned", 0.5f);
  mask.weights[1] = NAN;
  EXPECT_THROW(write_vertex_mask(dir / "m.json", mask), Error);
  mask.weights[1] = 1.5f;
  EXPECT_THROW(write_vertex_mask(dir / "m.json", mask), Error);
  mask.weights[1] = 1.0f;
  mask.weights.pop_back();
  EXPECT_THROW(write_vertex_mask(dir / "m.json", mask), Error);
  mask = make_mask(mesh, "two words", 0.5f);
  EXPECT_THROW(write_vertex_mask(dir / "m.json", mask), Error);
  EXPECT_FALSE(std::filesystem::exists(dir / "m.json"));
}

TEST(VertexMask, ReaderRejectsInvalidFiles) {
  TempDir dir;
  const std::string topology =
      R"("topology": {"vertex_count": 4, "face_count": 2, "faces_fnv1a64": "0123456789abcdef"})";
  const auto doc = [&](const std::string& body) {
    return R"({"format": "pg-vertex-mask", "version": 1, "provenance": {}, "name": "pinned", )" + topology +
           ", " + body + "}";
  };
  const auto expect_rejected = [&](const std::string& text, const std::string& expected) {
    const auto path = dir / "bad.pgmask.json";
    pg::testing::write_text(path, text);
    try {
      read_vertex_mask(path);
      ADD_FAILURE() << "accepted: " << text;
    } catch (const InputError& e) {
      EXPECT_EQ(std::string(e.what()).rfind(path.string() + ": ", 0), 0u) << e.what();
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
    }
  };
  // Valid ones first, so the rejections below are about the one thing changed.
  pg::testing::write_text(dir / "ok.json", doc(R"("encoding": "dense", "weights": [0, 1, 0.5, 0])"));
  EXPECT_EQ(read_vertex_mask(dir / "ok.json").weights, (std::vector<float>{0, 1, 0.5f, 0}));
  pg::testing::write_text(dir / "ok.json",
                          doc(R"("encoding": "sparse", "indices": [3, 1], "weights": [0.25, 1])"));
  EXPECT_EQ(read_vertex_mask(dir / "ok.json").weights, (std::vector<float>{0, 1, 0, 0.25f}));

  expect_rejected(doc(R"("encoding": "dense", "weights": [0, 1.5, 0, 0])"), "not in [0, 1]");
  expect_rejected(doc(R"("encoding": "dense", "weights": [0, -0.1, 0, 0])"), "not in [0, 1]");
  expect_rejected(doc(R"("encoding": "dense", "weights": [0, NaN, 0, 0])"), "not valid JSON");
  expect_rejected(doc(R"("encoding": "dense", "weights": [0, "1", 0, 0])"), "weights[1] is not a number");
  expect_rejected(doc(R"("encoding": "dense", "weights": [0, 1, 0])"), "3 weights for 4 vertices");
  expect_rejected(doc(R"("encoding": "sparse", "indices": [4], "weights": [1])"), "out of range");
  expect_rejected(doc(R"("encoding": "sparse", "indices": [-1], "weights": [1])"), "out of range");
  expect_rejected(doc(R"("encoding": "sparse", "indices": [2, 2], "weights": [1, 1])"), "appears twice");
  expect_rejected(doc(R"("encoding": "sparse", "indices": [0.5], "weights": [1])"), "not an integer");
  expect_rejected(doc(R"("encoding": "sparse", "indices": [1, 2], "weights": [1])"),
                  "2 indices but 1 weights");
  expect_rejected(doc(R"("encoding": "sparse", "weights": [1])"), "missing \"indices\"");
  expect_rejected(doc(R"("encoding": "rle", "weights": [1])"), "neither");
  expect_rejected(R"({"format": "pg-vertex-mask", "version": 2, "name": "x"})", "version 2 is not supported");
  expect_rejected(R"({"format": "pg-mesh", "version": 1})", "expected \"pg-vertex-mask\"");
  expect_rejected(R"({"format": "pg-vertex-mask", "version": 1, "name": "a b", )" + topology +
                      R"(, "encoding": "dense", "weights": [0, 0, 0, 0]})",
                  "name \"a b\"");
  expect_rejected(
      R"({"format": "pg-vertex-mask", "version": 1, "name": "x", "topology": {"vertex_count": 1000000000000,
                      "face_count": 0, "faces_fnv1a64": "0123456789abcdef"}, "encoding": "sparse", "indices": [],
                      "weights": []})",
      "vertex_count 1000000000000 is out of range");
  expect_rejected(R"({"format": "pg-vertex-mask", "version": 1, "name": "x", "topology": {"vertex_count": 1,
                      "face_count": 0, "faces_fnv1a64": "XYZ"}, "encoding": "dense", "weights": [0]})",
                  "faces_fnv1a64");
}

TEST(VertexMask, ExampleFileFitsExampleMesh) {
  const std::filesystem::path examples =
      std::filesystem::path(build_info::source_dir) / "formats" / "examples";
  const Mesh mesh = read_mesh_ply(examples / "quad-strip.ply");
  const VertexMask mask = read_vertex_mask(examples / "working_set.pgmask.json");
  EXPECT_NO_THROW(check_fits(mask, mesh, examples / "working_set.pgmask.json"));
  EXPECT_EQ(mask.name, "working_set");
  EXPECT_EQ(mask.weights, (std::vector<float>{0, 0, 1, 1, 0, 0.5f}));
  EXPECT_EQ(mesh.vertex_properties.at("working_set"), mask.weights);
  EXPECT_EQ(read_vertex_mask(examples / "pinned-dense.pgmask.json").weights,
            (std::vector<float>{1, 1, 0, 0, 0, 0}));
}

}  // namespace
}  // namespace pg

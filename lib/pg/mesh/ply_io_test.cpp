#include <gtest/gtest.h>

#include <bit>
#include <cstring>

#include "pg/core/error.h"
#include "pg/mesh/ply_io.h"
#include "pg/mesh/test_meshes.h"
#include "pg/testing/testing.h"

namespace pg {
namespace {

using pg::testing::TempDir;

template <class T>
std::uint64_t bits(T value) {
  std::uint64_t out = 0;
  std::memcpy(&out, &value, sizeof(T));
  return out;
}

void expect_bit_exact(const Eigen::Vector3f& a, const Eigen::Vector3f& b) {
  for (int k = 0; k < 3; ++k) EXPECT_EQ(bits(a[k]), bits(b[k])) << a[k] << " vs " << b[k];
}

void expect_same_mesh(const Mesh& a, const Mesh& b) {
  ASSERT_EQ(a.vertex_count(), b.vertex_count());
  EXPECT_EQ(a.faces, b.faces);
  ASSERT_EQ(a.normals.size(), b.normals.size());
  ASSERT_EQ(a.uvs.size(), b.uvs.size());
  EXPECT_EQ(a.colors, b.colors);
  for (std::size_t i = 0; i < a.vertex_count(); ++i) {
    expect_bit_exact(a.positions[i], b.positions[i]);
    if (!a.normals.empty()) expect_bit_exact(a.normals[i], b.normals[i]);
    if (!a.uvs.empty()) {
      EXPECT_EQ(bits(a.uvs[i].x()), bits(b.uvs[i].x()));
      EXPECT_EQ(bits(a.uvs[i].y()), bits(b.uvs[i].y()));
    }
  }
  ASSERT_EQ(a.vertex_properties.size(), b.vertex_properties.size());
  for (const auto& [name, values] : a.vertex_properties) {
    ASSERT_TRUE(b.vertex_properties.count(name)) << name;
    const auto& other = b.vertex_properties.at(name);
    ASSERT_EQ(values.size(), other.size());
    for (std::size_t i = 0; i < values.size(); ++i)
      EXPECT_EQ(bits(values[i]), bits(other[i])) << name << " " << i;
  }
}

// Builds a PLY file byte by byte: a header, then binary values in the chosen byte order.
class PlyBytes {
 public:
  explicit PlyBytes(const std::string& header, bool big_endian = false)
      : bytes_(header), big_endian_(big_endian) {}
  template <class T>
  PlyBytes& put(T value) {
    unsigned char raw[sizeof(T)];
    std::memcpy(raw, &value, sizeof(T));
    if (big_endian_ != (std::endian::native == std::endian::big))
      for (std::size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(raw[i], raw[sizeof(T) - 1 - i]);
    bytes_.append(reinterpret_cast<const char*>(raw), sizeof(T));
    return *this;
  }
  const std::string& bytes() const { return bytes_; }

 private:
  std::string bytes_;
  bool big_endian_;
};

// Reading `text` as a PLY file must fail with an InputError naming the file and containing `expected`.
void expect_rejected(const std::string& text, const std::string& expected) {
  TempDir dir;
  const auto path = dir / "bad.ply";
  pg::testing::write_text(path, text);
  try {
    read_mesh_ply(path);
    ADD_FAILURE() << "accepted a file that should fail with \"" << expected << "\"";
  } catch (const InputError& e) {
    const std::string message = e.what();
    EXPECT_EQ(message.rfind(path.string() + ": ", 0), 0u) << message;
    EXPECT_NE(message.find(expected), std::string::npos) << message;
  }
}

class PlyRoundTrip : public ::testing::TestWithParam<PlyEncoding> {};

TEST_P(PlyRoundTrip, EveryAttributeAndPropertyBitExact) {
  TempDir dir;
  const Mesh mesh = test::attributed_mesh();
  write_mesh_ply(dir / "mesh.ply", mesh, GetParam());
  const Mesh back = read_mesh_ply(dir / "mesh.ply");
  expect_same_mesh(mesh, back);
  EXPECT_EQ(back.provenance.tool, "pg-test");
  EXPECT_EQ(back.provenance.command_line, mesh.provenance.command_line);
  EXPECT_EQ(back.provenance.inputs, mesh.provenance.inputs);
  EXPECT_EQ(back.provenance.created_utc, mesh.provenance.created_utc);
}

TEST_P(PlyRoundTrip, PositionsOnlyAndEmptyMesh) {
  TempDir dir;
  Mesh mesh = test::grid_mesh(2, 2);
  write_mesh_ply(dir / "grid.ply", mesh, GetParam());
  expect_same_mesh(mesh, read_mesh_ply(dir / "grid.ply"));
  write_mesh_ply(dir / "empty.ply", Mesh{}, GetParam());
  const Mesh empty = read_mesh_ply(dir / "empty.ply");
  EXPECT_EQ(empty.vertex_count(), 0u);
  EXPECT_EQ(empty.face_count(), 0u);
}

INSTANTIATE_TEST_SUITE_P(Encodings, PlyRoundTrip,
                         ::testing::Values(PlyEncoding::ascii, PlyEncoding::binary_little_endian,
                                           PlyEncoding::binary_big_endian),
                         test::encoding_name);

TEST(PlyWrite, HeaderCarriesFormatAndProvenanceComments) {
  TempDir dir;
  write_mesh_ply(dir / "m.ply", test::attributed_mesh());
  const std::string text = pg::testing::read_text(dir / "m.ply");
  EXPECT_EQ(text.rfind("ply\nformat binary_little_endian 1.0\ncomment pg-format pg-mesh 1\n"
                       "comment pg-provenance {",
                       0),
            0u);
  const std::string header = text.substr(0, text.find("end_header"));
  for (const char* line :
       {"property float x\n", "property float nx\n", "property uchar red\n", "property float s\n",
        "property float t\n", "property float working_set\n", "property float confidence\n",
        "element face 12\nproperty list uchar int vertex_indices\n"})
    EXPECT_NE(header.find(line), std::string::npos) << line;
  // Written atomically: no temporary left beside it.
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir.path()), {}), 1);
}

TEST(PlyWrite, RefusesPropertyNamesItCannotReadBack) {
  TempDir dir;
  Mesh mesh = test::grid_mesh(1, 1);
  mesh.vertex_properties["u"] = std::vector<float>(mesh.vertex_count(), 0.0f);
  EXPECT_THROW(write_mesh_ply(dir / "m.ply", mesh), OutputError);
  mesh.vertex_properties.clear();
  mesh.vertex_properties["two words"] = std::vector<float>(mesh.vertex_count(), 0.0f);
  EXPECT_THROW(write_mesh_ply(dir / "m.ply", mesh), OutputError);
  EXPECT_FALSE(std::filesystem::exists(dir / "m.ply"));
}

TEST(PlyRead, BigEndianDoublesIntIndicesAndExtraElements) {
  // double positions, a ushort property, an unknown element with a list between vertex and face,
  // faces as uchar-count int lists with one quad, and an unknown element after the faces.
  PlyBytes ply(
      "ply\nformat binary_big_endian 1.0\ncomment made by hand\n"
      "element vertex 4\nproperty double x\nproperty double y\nproperty double z\nproperty ushort quality\n"
      "element material 2\nproperty list uint float values\nproperty char id\n"
      "element face 1\nproperty uchar flags\nproperty list uchar int vertex_indices\n"
      "element edge 1\nproperty int vertex1\nproperty int vertex2\nend_header\n",
      true);
  const double xyz[4][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0.1}, {0, 1, -2.5}};
  for (int v = 0; v < 4; ++v)
    ply.put(xyz[v][0]).put(xyz[v][1]).put(xyz[v][2]).put(std::uint16_t(1000 * v + 7));
  ply.put(std::uint32_t(2)).put(0.5f).put(0.25f).put(std::int8_t(-1));
  ply.put(std::uint32_t(0)).put(std::int8_t(2));
  ply.put(std::uint8_t(9)).put(std::uint8_t(4)).put(0).put(1).put(2).put(3);
  ply.put(0).put(1);
  TempDir dir;
  pg::testing::write_text(dir / "hand.ply", ply.bytes());
  const Mesh mesh = read_mesh_ply(dir / "hand.ply");
  ASSERT_EQ(mesh.vertex_count(), 4u);
  EXPECT_TRUE(mesh.positions[3].isApprox(Eigen::Vector3f(0, 1, -2.5f)));
  EXPECT_FLOAT_EQ(mesh.positions[2].z(), 0.1f);
  const std::vector<std::array<std::uint32_t, 3>> fan = {{0, 1, 2}, {0, 2, 3}};
  EXPECT_EQ(mesh.faces, fan);
  EXPECT_EQ(mesh.vertex_properties.at("quality"), (std::vector<float>{7, 1007, 2007, 3007}));
  EXPECT_TRUE(mesh.normals.empty() && mesh.colors.empty() && mesh.uvs.empty());
}

TEST(PlyRead, LittleEndianEverySmallTypeAndUintLists) {
  PlyBytes ply(
      "ply\nformat binary_little_endian 1.0\nelement vertex 3\n"
      "property float32 x\nproperty float32 y\nproperty float32 z\nproperty int8 a\nproperty uint8 b\n"
      "property int16 c\nproperty uint16 d\nproperty int32 e\nproperty uint32 f\nproperty float64 g\n"
      "element face 1\nproperty list ushort uint vertex_index\nend_header\n");
  for (int v = 0; v < 3; ++v)
    ply.put(float(v))
        .put(float(v * v))
        .put(0.5f)
        .put(std::int8_t(-100 + v))
        .put(std::uint8_t(200 + v))
        .put(std::int16_t(-30000 + v))
        .put(std::uint16_t(60000 + v))
        .put(std::int32_t(-2000000000 + v))
        .put(std::uint32_t(4000000000u + v))
        .put(0.125 * v);
  ply.put(std::uint16_t(3)).put(std::uint32_t(2)).put(std::uint32_t(1)).put(std::uint32_t(0));
  TempDir dir;
  pg::testing::write_text(dir / "types.ply", ply.bytes());
  const Mesh mesh = read_mesh_ply(dir / "types.ply");
  ASSERT_EQ(mesh.vertex_count(), 3u);
  EXPECT_EQ(mesh.faces, (std::vector<std::array<std::uint32_t, 3>>{{2, 1, 0}}));
  const auto& p = mesh.vertex_properties;
  EXPECT_EQ(p.at("a")[2], -98.0f);
  EXPECT_EQ(p.at("b")[1], 201.0f);
  EXPECT_EQ(p.at("c")[0], -30000.0f);
  EXPECT_EQ(p.at("d")[2], 60002.0f);
  EXPECT_EQ(p.at("e")[0], -2e9f);
  EXPECT_EQ(p.at("f")[0], 4e9f);
  EXPECT_EQ(p.at("g")[2], 0.25f);
}

TEST(PlyRead, AsciiQuadsFloatColoursUvNamesAndCrLf) {
  const std::string text =
      "ply\r\nformat ascii 1.0\r\ncomment hello\r\nobj_info scanner\r\nelement vertex 4\r\n"
      "property float x\r\nproperty float y\r\nproperty float z\r\n"
      "property float red\r\nproperty float green\r\nproperty float blue\r\n"
      "property float u\r\nproperty float v\r\n"
      "element face 1\r\nproperty list uchar uint vertex_index\r\nend_header\r\n"
      "0 0 0 1 0 0.5 0 0\r\n1 0 0 0 1 0 1 0\r\n1 1 0 0 0 1 +1 1\r\n0 1 0 0.2 0.2 0.2 0 1e0\r\n"
      "4 0 1 2 3\r\n";
  TempDir dir;
  pg::testing::write_text(dir / "quad.ply", text);
  const Mesh mesh = read_mesh_ply(dir / "quad.ply");
  EXPECT_EQ(mesh.faces, (std::vector<std::array<std::uint32_t, 3>>{{0, 1, 2}, {0, 2, 3}}));
  ASSERT_EQ(mesh.colors.size(), 4u);
  EXPECT_EQ(mesh.colors[0], (std::array<std::uint8_t, 3>{255, 0, 128}));
  EXPECT_EQ(mesh.colors[3], (std::array<std::uint8_t, 3>{51, 51, 51}));
  ASSERT_EQ(mesh.uvs.size(), 4u);
  EXPECT_EQ(mesh.uvs[2], Eigen::Vector2f(1, 1));
  EXPECT_EQ(mesh.uvs[3], Eigen::Vector2f(0, 1));
  EXPECT_TRUE(mesh.vertex_properties.empty());
}

TEST(PlyRead, TextureUvNames) {
  const std::string text =
      "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
      "property float texture_u\nproperty float texture_v\nend_header\n1 2 3 0.25 0.75\n";
  TempDir dir;
  pg::testing::write_text(dir / "uv.ply", text);
  const Mesh mesh = read_mesh_ply(dir / "uv.ply");
  ASSERT_EQ(mesh.uvs.size(), 1u);
  EXPECT_EQ(mesh.uvs[0], Eigen::Vector2f(0.25f, 0.75f));
  EXPECT_TRUE(mesh.faces.empty());
}

const std::string xyz_header = "property float x\nproperty float y\nproperty float z\n";

TEST(PlyRead, RejectsBadHeaders) {
  expect_rejected("", "not a PLY file");
  expect_rejected("PLY\nformat ascii 1.0\nend_header\n", "not a PLY file");
  expect_rejected("ply\nformat ascii 1.0\nelement vertex 1\n" + xyz_header, "no end_header");
  expect_rejected("ply\nformat ascii 2.0\nend_header\n", "unsupported PLY version");
  expect_rejected("ply\nformat binary_middle_endian 1.0\nend_header\n", "unknown encoding");
  expect_rejected("ply\nformat ascii 1.0\nelement vertex -3\nend_header\n", "not a count");
  expect_rejected("ply\nformat ascii 1.0\nelement vertex 1\nproperty float128 x\nend_header\n",
                  "unknown property type");
  expect_rejected("ply\nformat ascii 1.0\nelement vertex 1\nproperty list float int x\nend_header\n",
                  "count type must be an integer");
  expect_rejected("ply\nformat ascii 1.0\nproperty float x\nend_header\n", "property before any element");
  expect_rejected("ply\nformat ascii 1.0\nvertices 3\nend_header\n", "line 3: unknown header keyword");
  expect_rejected("ply\nelement vertex 0\nend_header\n", "no format line");
  expect_rejected("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float x\nend_header\n",
                  "duplicate property");
  expect_rejected("ply\nformat ascii 1.0\nelement vertex 0\n" + xyz_header + "element vertex 0\nend_header\n",
                  "duplicate element");
  expect_rejected("ply\nformat ascii 1.0\ncomment pg-format pg-mesh 2\nend_header\n",
                  "version 2 is not supported");
  expect_rejected("ply\nformat ascii 1.0\ncomment pg-format pg-camera 1\nend_header\n", "pg-camera");
  expect_rejected("ply\nformat ascii 1.0\ncomment pg-provenance {oops\nend_header\n", "not valid JSON");
}

TEST(PlyRead, RejectsImplausibleCountsBeforeAllocating) {
  expect_rejected(
      "ply\nformat ascii 1.0\nelement vertex 1000000000000\n" + xyz_header + "end_header\n0 0 0\n",
      "claims 1000000000000 entries");
  expect_rejected("ply\nformat binary_little_endian 1.0\nelement vertex 1000000000000\n" + xyz_header +
                      "end_header\n" + std::string(12, '\0'),
                  "claims 1000000000000 entries");
  expect_rejected("ply\nformat binary_little_endian 1.0\nelement thing 100000000000000\nend_header\n",
                  "has entries but no properties");
  // A list that claims 4 billion entries.
  PlyBytes huge_list("ply\nformat binary_little_endian 1.0\nelement vertex 3\n" + xyz_header +
                     "element face 1\nproperty list uint int vertex_indices\nend_header\n");
  for (int i = 0; i < 9; ++i) huge_list.put(0.0f);
  huge_list.put(std::uint32_t(4000000000u)).put(0).put(1).put(2);
  expect_rejected(huge_list.bytes(), "truncated list");
}

TEST(PlyRead, RejectsTruncatedAndMalformedData) {
  PlyBytes binary("ply\nformat binary_little_endian 1.0\nelement vertex 2\n" + xyz_header + "end_header\n");
  binary.put(1.0f).put(2.0f).put(3.0f).put(4.0f).put(5.0f);
  expect_rejected(binary.bytes(), "truncated");
  expect_rejected("ply\nformat ascii 1.0\nelement vertex 2\n" + xyz_header +
                      "end_header\n1.000 2.000 3.000\n4.000 5.000\n",
                  "entry 1: file ends early");
  expect_rejected("ply\nformat ascii 1.0\nelement vertex 1\n" + xyz_header + "end_header\n1 two 3\n",
                  "\"two\"");
  expect_rejected("ply\nformat ascii 1.0\nelement vertex 1\nproperty uchar x\nend_header\n300\n", "\"300\"");
  expect_rejected(
      "ply\nformat ascii 1.0\nelement vertex 1\nproperty float y\nproperty float z\nend_header\n1 2\n",
      "lacks x, y or z");
  // Non-finite positions and normals (conventions.md); a double beyond float's range is one too.
  expect_rejected("ply\nformat ascii 1.0\nelement vertex 2\n" + xyz_header + "end_header\n0 0 0\n1 nan 3\n",
                  "vertex 1 has a non-finite y");
  PlyBytes huge(
      "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty double x\n"
      "property double y\nproperty double z\nend_header\n");
  huge.put(1.0).put(2.0).put(1e300);
  expect_rejected(huge.bytes(), "vertex 0 has a non-finite z");
  expect_rejected("ply\nformat ascii 1.0\nelement vertex 1\n" + xyz_header +
                      "property float nx\nproperty float ny\nproperty float nz\nend_header\n0 0 0 inf 0 0\n",
                  "non-finite nx");
}

TEST(PlyRead, RejectsBadFaces) {
  const std::string head = "ply\nformat ascii 1.0\nelement vertex 3\n" + xyz_header + "element face 1\n";
  const std::string vertices = "0 0 0\n1 0 0\n0 1 0\n";
  expect_rejected(head + "property list uchar int vertex_indices\nend_header\n" + vertices + "2 0 1\n",
                  "a face has 2 vertices");
  expect_rejected(head + "property list uchar int vertex_indices\nend_header\n" + vertices + "3 0 1 3\n",
                  "vertex index 3 out of range");
  expect_rejected(head + "property list uchar int vertex_indices\nend_header\n" + vertices + "3 0 -1 2\n",
                  "vertex index -1 out of range");
  expect_rejected(head + "property list uchar int corners\nend_header\n" + vertices + "3 0 1 2\n",
                  "no vertex_indices list");
  expect_rejected(head + "property list uchar float vertex_indices\nend_header\n" + vertices + "3 0 1 2\n",
                  "integer type");
}

TEST(PlyRead, MissingFile) {
  TempDir dir;
  EXPECT_THROW(read_mesh_ply(dir / "absent.ply"), InputError);
}

TEST(PlyRead, StanfordBunny) {
  PG_REQUIRE_REAL_DATA(dir, "meshes/stanford-bunny/reconstruction");
  const Mesh bunny = read_mesh_ply(dir / "bun_zipper.ply");
  EXPECT_EQ(bunny.vertex_count(), 35947u);
  EXPECT_EQ(bunny.face_count(), 69451u);
  EXPECT_NO_THROW(bunny.check_consistent());
  EXPECT_EQ(bunny.vertex_properties.count("confidence"), 1u);
  EXPECT_EQ(bunny.vertex_properties.count("intensity"), 1u);
  // The first vertex line of the file: -0.0378297 0.12794 0.00447467 0.850855 0.5
  EXPECT_EQ(bunny.positions[0], Eigen::Vector3f(-0.0378297f, 0.12794f, 0.00447467f));
  EXPECT_EQ(bunny.vertex_properties.at("confidence")[0], 0.850855f);
  const Eigen::AlignedBox3f box = bunny.bounds();
  EXPECT_NEAR(box.sizes().y(), 0.15, 0.01);  // the bunny is about 15 cm tall
}

}  // namespace
}  // namespace pg

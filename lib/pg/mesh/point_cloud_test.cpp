#include <gtest/gtest.h>

#include <cstring>
#include <random>

#include "pg/build_info.h"
#include "pg/core/error.h"
#include "pg/mesh/ply_io.h"
#include "pg/mesh/point_cloud.h"
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

PointCloud random_cloud(std::size_t n) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> any(-50.0f, 50.0f), unit(0.0f, 1.0f);
  PointCloud cloud;
  for (std::size_t i = 0; i < n; ++i) {
    cloud.positions.push_back(Eigen::Vector3f{any(rng), any(rng), any(rng)});
    cloud.normals.push_back(Eigen::Vector3f{any(rng), any(rng), any(rng)}.normalized());
    cloud.colors.push_back({std::uint8_t(rng()), std::uint8_t(rng()), std::uint8_t(rng())});
    cloud.confidence.push_back(unit(rng));
    cloud.track_length.push_back(std::uint32_t(rng() % 5000));
  }
  cloud.track_length[0] = 2147483647u;  // the largest count a PLY int holds
  cloud.provenance.tool = "pg-sfm";
  cloud.provenance.inputs = {"tracks.json"};
  return cloud;
}

class PointCloudRoundTrip : public ::testing::TestWithParam<PlyEncoding> {};

TEST_P(PointCloudRoundTrip, EveryAttributeBitExact) {
  TempDir dir;
  const PointCloud cloud = random_cloud(500);
  write_point_cloud_ply(dir / "c.ply", cloud, GetParam());
  const PointCloud back = read_point_cloud_ply(dir / "c.ply");
  ASSERT_EQ(back.size(), cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i)
    for (int k = 0; k < 3; ++k) {
      EXPECT_EQ(bits(back.positions[i][k]), bits(cloud.positions[i][k]));
      EXPECT_EQ(bits(back.normals[i][k]), bits(cloud.normals[i][k]));
    }
  EXPECT_EQ(back.colors, cloud.colors);
  EXPECT_EQ(back.confidence, cloud.confidence);
  EXPECT_EQ(back.track_length, cloud.track_length);
  EXPECT_EQ(back.provenance.tool, "pg-sfm");
  EXPECT_EQ(back.provenance.inputs, cloud.provenance.inputs);
  const std::string text = pg::testing::read_text(dir / "c.ply");
  EXPECT_NE(text.find("comment pg-format pg-point-cloud 1\n"), std::string::npos);
  EXPECT_NE(text.find("property int track_length\n"), std::string::npos);
  EXPECT_EQ(text.find("element face"), std::string::npos);
}

INSTANTIATE_TEST_SUITE_P(Encodings, PointCloudRoundTrip,
                         ::testing::Values(PlyEncoding::ascii, PlyEncoding::binary_little_endian,
                                           PlyEncoding::binary_big_endian),
                         test::encoding_name);

TEST(PointCloud, PositionsOnlyAndEmpty) {
  TempDir dir;
  PointCloud cloud;
  cloud.positions = {{1, 2, 3}, {4, 5, 6}};
  write_point_cloud_ply(dir / "p.ply", cloud);
  const PointCloud back = read_point_cloud_ply(dir / "p.ply");
  EXPECT_EQ(back.positions, cloud.positions);
  EXPECT_TRUE(back.normals.empty() && back.colors.empty() && back.confidence.empty() &&
              back.track_length.empty());
  write_point_cloud_ply(dir / "e.ply", PointCloud{});
  EXPECT_EQ(read_point_cloud_ply(dir / "e.ply").size(), 0u);
}

TEST(PointCloud, MeshReadsAsItsVertices) {
  TempDir dir;
  Mesh mesh = test::attributed_mesh();
  write_mesh_ply(dir / "m.ply", mesh);
  const PointCloud cloud = read_point_cloud_ply(dir / "m.ply");
  EXPECT_EQ(cloud.positions, mesh.positions);
  EXPECT_EQ(cloud.colors, mesh.colors);
  EXPECT_EQ(cloud.confidence, mesh.vertex_properties.at("confidence"));
  EXPECT_TRUE(cloud.track_length.empty());
  // And a point cloud reads as a mesh without faces.
  write_point_cloud_ply(dir / "c.ply", random_cloud(10));
  const Mesh points = read_mesh_ply(dir / "c.ply");
  EXPECT_EQ(points.vertex_count(), 10u);
  EXPECT_EQ(points.face_count(), 0u);
}

TEST(PointCloud, ReadsTheExample) {
  const PointCloud cloud = read_point_cloud_ply(std::filesystem::path(build_info::source_dir) / "formats" /
                                                "examples" / "sparse-points.ply");
  ASSERT_EQ(cloud.size(), 3u);
  EXPECT_EQ(cloud.positions[1], Eigen::Vector3f(0.75f, 1.5f, -3.1f));
  EXPECT_EQ(cloud.normals[1], Eigen::Vector3f(0, 0.6f, -0.8f));
  EXPECT_EQ(cloud.colors[2], (std::array<std::uint8_t, 3>{20, 20, 25}));
  EXPECT_EQ(cloud.confidence, (std::vector<float>{0.9f, 0.4f, 0.75f}));
  EXPECT_EQ(cloud.track_length, (std::vector<std::uint32_t>{5, 2, 12}));
  EXPECT_EQ(cloud.provenance.tool, "pg-sfm");
}

TEST(PointCloud, RejectsInvalidTrackLengths) {
  TempDir dir;
  for (const char* value : {"-1", "2.5"}) {
    pg::testing::write_text(dir / "t.ply",
                            std::string("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
                                        "property float y\nproperty float z\nproperty float "
                                        "track_length\nend_header\n0 0 0 ") +
                                value + "\n");
    try {
      read_point_cloud_ply(dir / "t.ply");
      ADD_FAILURE() << "accepted track_length " << value;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("track_length of point 0"), std::string::npos) << e.what();
    }
  }
  PointCloud cloud = random_cloud(3);
  cloud.confidence.pop_back();
  EXPECT_THROW(write_point_cloud_ply(dir / "x.ply", cloud), Error);
  cloud = random_cloud(3);
  cloud.track_length[1] = 3000000000u;
  EXPECT_THROW(write_point_cloud_ply(dir / "x.ply", cloud), Error);
}

}  // namespace
}  // namespace pg

#include "pg/refine/refine_memory.h"

#include <gtest/gtest.h>

namespace {

// The estimate reads only the mesh's array sizes: no geometry is needed.
pg::Mesh mesh_of_size(std::size_t vertices, std::size_t faces) {
  pg::Mesh mesh;
  mesh.positions.resize(vertices);
  mesh.faces.resize(faces);
  return mesh;
}

std::vector<pg::Camera> views(int count, int width, int height) {
  std::vector<pg::Camera> cameras(static_cast<std::size_t>(count));
  for (pg::Camera& camera : cameras) {
    camera.width = width;
    camera.height = height;
    camera.intrinsics = {1000, 1000, (width - 1) / 2.0, (height - 1) / 2.0};
  }
  return cameras;
}

TEST(RefineMemory, MeshBytesCountEveryArray) {
  pg::Mesh mesh = mesh_of_size(10, 16);
  EXPECT_EQ(pg::mesh_bytes(mesh), 10u * 12 + 16u * 12);
  mesh.normals.resize(10);
  mesh.colors.resize(10);
  mesh.vertex_properties["displacement"].resize(10);
  EXPECT_EQ(pg::mesh_bytes(mesh), 10u * (12 + 12 + 3 + 4) + 16u * 12);
}

TEST(RefineMemory, EstimateGrowsLinearlyWithTheMesh) {
  const auto cameras = views(4, 640, 480);
  const pg::RefineOptions options;
  const auto estimate = [&](std::size_t k) {
    return pg::refine_memory_bytes(mesh_of_size(k * 50000, k * 100000), cameras, 3, options);
  };
  EXPECT_EQ(estimate(2) - estimate(1), estimate(3) - estimate(2));
  EXPECT_GT(estimate(2) - estimate(1), 0u);
}

TEST(RefineMemory, HugeMeshOverTenViewsLiesBetweenItsCountedBuffersAndTwiceThem) {
  const std::size_t vertices = 5'000'000, faces = 10'000'000;
  const int view_count = 10;
  // Counted independently: every view's rasterizer keeps each face's edge and depth planes (12 floats)
  // and each vertex in camera coordinates (3 doubles); the displacement sums hold per vertex a 3x3
  // double matrix, a 3-vector and a weight; the input and refined meshes their positions and faces.
  const double counted = view_count * (faces * 12.0 * 4 + vertices * 3.0 * 8) + vertices * (9 + 3 + 1) * 8.0 +
                         2 * (vertices * 12.0 + faces * 12.0);
  const double estimate = static_cast<double>(
      pg::refine_memory_bytes(mesh_of_size(vertices, faces), views(view_count, 1920, 1080), 3, {}));
  EXPECT_GT(estimate, counted);
  EXPECT_LT(estimate, 2 * counted);
}

TEST(RefineMemory, LargePhotographsAreCountedAtTheWorkingScale) {
  const pg::Mesh mesh = mesh_of_size(1000, 2000);
  pg::RefineOptions half, full;
  half.scale = 0.5;
  full.scale = 1;
  const auto cameras = views(2, 6000, 4000);
  const double images = 2.0 * 6000 * 4000 * 3;  // the decoded photographs, at full size either way
  const double at_half = static_cast<double>(pg::refine_memory_bytes(mesh, cameras, 3, half)) - images;
  const double at_full = static_cast<double>(pg::refine_memory_bytes(mesh, cameras, 3, full)) - images;
  EXPECT_NEAR(at_half / at_full, 0.25, 0.01);
  // At full scale the one pair's flow (28 solver planes at least) dominates the per-view state.
  EXPECT_GT(at_full, 6000.0 * 4000 * 28 * 4);
}

}  // namespace

#include <gtest/gtest.h>

#include <random>

#include "pg/eval/mesh_eval.h"
#include "pg/fusion/fusion_test_scenes.h"
#include "pg/fusion/point_surface.h"

namespace pg::fusion {
namespace {

// Points on a sphere of radius 0.5, uniformly spread, with a fixed seed.
std::vector<Eigen::Vector3f> sphere_points(int count) {
  std::mt19937 random(7);
  std::normal_distribution<float> gauss;
  std::vector<Eigen::Vector3f> points;
  for (int i = 0; i < count; ++i)
    points.push_back(0.5f * Eigen::Vector3f{gauss(random), gauss(random), gauss(random)}.normalized());
  return points;
}

TEST(PointNormals, HoppeNormalsAreRadialAndFaceTheCameras) {
  const auto points = sphere_points(3000);
  auto normals = estimate_normals(points, 10);
  CameraSet cameras;
  for (const auto& c : testing::orbit(6, 3.0, 0.5, {0, 0, 0}, 200, 200, 150)) cameras.cameras.push_back(c);
  orient_normals(points, normals, 10, &cameras);
  std::size_t outward = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const float cos = normals[i].dot(points[i].normalized());
    EXPECT_GT(std::abs(cos), 0.97f);
    outward += cos > 0;
  }
  EXPECT_EQ(outward, points.size());  // one piece, oriented by the cameras outside it

  // Without cameras the highest point's normal points up: outward on a sphere too.
  auto plain = estimate_normals(points, 10);
  orient_normals(points, plain, 10, nullptr);
  for (std::size_t i = 0; i < points.size(); ++i) EXPECT_GT(plain[i].dot(points[i]), 0);
}

TEST(PoissonSurface, SpherePointsGiveTheSphere) {
  const double voxel = 0.03;
  PointCloud cloud;
  cloud.positions = sphere_points(6000);
  const Mesh mesh = surface_from_points(cloud, nullptr, nullptr, {.voxel_size = voxel});
  ASSERT_GT(mesh.face_count(), 500u);
  const Mesh truth = testing::sphere({0, 0, 0}, 0.5f, 96, 192);
  const MeshEvalResult eval = evaluate_mesh(mesh, truth, {.samples = 20000, .thresholds = {voxel}});
  std::cout << "poisson sphere: accuracy p90 " << eval.accuracy.p90 << ", completeness within v "
            << eval.recall[0] << "\n";
  EXPECT_LT(eval.accuracy.p90, voxel / 2);
  EXPECT_GT(eval.recall[0], 0.98);
  std::size_t outward = 0;
  for (const auto& f : mesh.faces) {
    const Eigen::Vector3f a = mesh.positions[f[0]], b = mesh.positions[f[1]], c = mesh.positions[f[2]];
    outward += (b - a).cross(c - a).dot(a + b + c) > 0;
  }
  EXPECT_GT(double(outward) / mesh.face_count(), 0.99);
}

TEST(PoissonSurface, TrimmingOpensWherePointsAreMissingAndTheBaseFillsIt) {
  const double voxel = 0.03;
  PointCloud cloud;
  for (const auto& p : sphere_points(6000))
    if (p.z() < 0.3f) cloud.positions.push_back(p);  // a cap without points
  const Mesh open = surface_from_points(cloud, nullptr, nullptr, {.voxel_size = voxel, .trim_density = 0.3});
  float highest = -1;
  for (const auto& p : open.positions) highest = std::max(highest, p.z());
  EXPECT_LT(highest, 0.3f + 2 * voxel);
  const Mesh base = testing::sphere({0, 0, 0}, 0.5f, 24, 48);
  const Mesh filled = surface_from_points(cloud, nullptr, &base, {.voxel_size = voxel, .trim_density = 0.0});
  highest = -1;
  for (const auto& p : filled.positions) highest = std::max(highest, p.z());
  EXPECT_GT(highest, 0.5f - voxel);
}

}  // namespace
}  // namespace pg::fusion

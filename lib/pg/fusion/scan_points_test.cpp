// Point-cloud scans integrated along each point's sensor ray: synthetic LIDAR sweeps with a known
// surface, the sensor models (origin, per-point origins, parallel rays), the documented weights,
// thread independence, the bad inputs, and the Stanford bunny scans read as bare points.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <fstream>

#include "pg/build_info.h"
#include "pg/core/error.h"
#include "pg/eval/mesh_eval.h"
#include "pg/fusion/scan_points_test_scenes.h"
#include "pg/fusion/tsdf_volume.h"
#include "pg/mesh/mesh_io.h"
#include "pg/testing/testing.h"

namespace pg::fusion {
namespace {

using pg::testing::TempDir;

Mesh room() {
  return testing::box({-2.0f, -1.5f, 0.0f}, {2.0f, 1.5f, 2.5f}, 8, true);
}

// Exactly representable in float, so per-point origins stored as float are the same points.
const Eigen::Vector3d first_origin(0.25, -0.5, 1.25), second_origin(-0.75, 0.5, 0.75);

ScanPoints read_placed(const std::filesystem::path& path, std::optional<Eigen::Vector3d> origin,
                       std::optional<Eigen::Vector3d> direction = std::nullopt) {
  return place_scan_points(read_scan_points(path), Rigid3{}, origin, direction);
}

TEST(ScanPoints, LidarSweepOfARoomMergesWithinAVoxel) {
  TempDir dir;
  const double voxel = 0.05;
  const Mesh truth = room();
  testing::write_plain_points(dir / "sweep.ply", testing::lidar_sweep(truth, first_origin, 480, 240));
  EXPECT_EQ(inspect_scan(dir / "sweep.ply").kind, ScanKind::points);
  EXPECT_FALSE(inspect_scan(dir / "sweep.ply").per_point_origins);
  TsdfVolume volume({.voxel_size = voxel});
  volume.integrate(read_placed(dir / "sweep.ply", first_origin));
  const Mesh merged = volume.extract_mesh();
  // One sweep from inside a box sees all of it.
  const MeshEvalResult eval = evaluate_mesh(merged, truth, {.samples = 40000, .thresholds = {voxel}});
  std::cout << "room sweep, " << eval.estimate_points << " points at " << voxel << " voxels: accuracy mean "
            << eval.accuracy.mean << ", p90 " << eval.accuracy.p90 << "; completeness within a voxel "
            << eval.recall[0] * 100 << "%\n";
  EXPECT_LT(eval.accuracy.p90, voxel / 4);
  EXPECT_GT(eval.recall[0], 0.95);
  // In front of the wall x = 2 along the x axis through the sensor, the distance to it.
  const auto in_front = volume.distance_at({2.0 - 0.06, first_origin.y(), first_origin.z()});
  ASSERT_TRUE(in_front.has_value());
  EXPECT_NEAR(*in_front, 0.06, voxel / 10);
}

TEST(ScanPoints, PerPointOriginsEqualSeparateSweepsBitForBit) {
  TempDir dir;
  const double voxel = 0.06;
  const Mesh truth = room();
  auto first = testing::lidar_sweep(truth, first_origin, 240, 120);
  const auto second = testing::lidar_sweep(truth, second_origin, 240, 120);
  testing::write_plain_points(dir / "first.ply", first);
  testing::write_plain_points(dir / "second.ply", second);
  first.insert(first.end(), second.begin(), second.end());
  testing::write_plain_points(dir / "both.ply", first, {.origins = true});
  EXPECT_TRUE(inspect_scan(dir / "both.ply").per_point_origins);

  TsdfVolume separate({.voxel_size = voxel}), together({.voxel_size = voxel});
  separate.integrate(read_placed(dir / "first.ply", first_origin));
  separate.integrate(read_placed(dir / "second.ply", second_origin));
  // Per-point origins win over a sensor option.
  together.integrate(read_placed(dir / "both.ply", Eigen::Vector3d(9, 9, 9)));
  const auto difference = separate.compare(together);
  EXPECT_EQ(difference.distance, 0.0);
  EXPECT_EQ(difference.weight_relative, 0.0);
  const MeshEvalResult eval =
      evaluate_mesh(together.extract_mesh(), truth, {.samples = 20000, .thresholds = {voxel}});
  EXPECT_LT(eval.accuracy.p90, voxel / 4);
  EXPECT_GT(eval.recall[0], 0.95);
}

TEST(ScanPoints, PlacementMovesPointsAndTheSensor) {
  TempDir dir;
  const double voxel = 0.06;
  const Mesh truth = room();
  const auto sweep = testing::lidar_sweep(truth, first_origin, 240, 120);
  // The same sweep stored in a scan frame rotated 90 degrees about z and shifted.
  const Rigid3 world_from_scan{
      Eigen::Quaterniond(Eigen::AngleAxisd(std::numbers::pi / 2, Eigen::Vector3d::UnitZ())),
      Eigen::Vector3d(1, 2, 3)};
  const Rigid3 scan_from_world = world_from_scan.inverse();
  auto in_scan = sweep;
  for (auto& p : in_scan) p.position = scan_from_world * p.position;
  testing::write_plain_points(dir / "scan.ply", in_scan);
  TsdfVolume volume({.voxel_size = voxel});
  volume.integrate(place_scan_points(read_scan_points(dir / "scan.ply"), world_from_scan,
                                     scan_from_world * first_origin, std::nullopt));
  const MeshEvalResult eval =
      evaluate_mesh(volume.extract_mesh(), truth, {.samples = 20000, .thresholds = {voxel}});
  EXPECT_LT(eval.accuracy.p90, voxel / 4);
  EXPECT_GT(eval.recall[0], 0.95);
}

TEST(ScanPoints, ParallelRaysMergeAHeightField) {
  TempDir dir;
  const double voxel = 0.04;
  const Mesh scanned = testing::bump(1.2, 120, 0.3, 0.3);
  const Eigen::Vector3d down(0, 0, -1);
  testing::write_plain_points(dir / "sweep.ply", testing::parallel_sweep(scanned, down, 1.2, 0.02, 5));
  TsdfVolume volume({.voxel_size = voxel});
  volume.integrate(read_placed(dir / "sweep.ply", std::nullopt, down));
  const Mesh merged = volume.extract_mesh();
  const MeshEvalResult accuracy = evaluate_mesh(merged, scanned, {.samples = 20000, .thresholds = {voxel}});
  EXPECT_LT(accuracy.accuracy.p90, voxel / 4);
  // Completeness away from the scan's border, where the band is cut off.
  const MeshEvalResult inner =
      evaluate_mesh(merged, testing::bump(1.0, 100, 0.3, 0.3), {.samples = 20000, .thresholds = {voxel}});
  EXPECT_GT(inner.recall[0], 0.95);
}

// A colour that is linear in position across the room, so every voxel's weighted mean of nearby
// samples should be the colour at its own position.
std::array<std::uint8_t, 3> room_color(const Eigen::Vector3d& p) {
  auto channel = [](double t) { return std::uint8_t(std::lround(std::clamp(t, 0.0, 1.0) * 255)); };
  return {channel((p.x() + 2) / 4), channel((p.y() + 1.5) / 3), channel(p.z() / 2.5)};
}

// The largest per-channel difference between each vertex's colour and room_color at the vertex,
// as the median and the 95th percentile over vertices.
std::pair<int, int> color_errors(const Mesh& mesh) {
  std::vector<int> errors;
  for (std::size_t v = 0; v < mesh.vertex_count(); ++v) {
    const auto truth = room_color(mesh.positions[v].cast<double>());
    int worst = 0;
    for (int k = 0; k < 3; ++k) worst = std::max(worst, std::abs(int(mesh.colors[v][k]) - int(truth[k])));
    errors.push_back(worst);
  }
  std::sort(errors.begin(), errors.end());
  return {errors[errors.size() / 2], errors[errors.size() * 95 / 100]};
}

TEST(ScanPoints, PointColoursReachTheMesh) {
  TempDir dir;
  const double voxel = 0.05;
  auto sweep = testing::lidar_sweep(room(), first_origin, 480, 240);
  for (auto& p : sweep) p.color = room_color(p.position);
  testing::write_plain_points(dir / "sweep.ply", sweep, {.colors = true});
  EXPECT_TRUE(inspect_scan(dir / "sweep.ply").has_color);
  const ScanPoints scan = read_placed(dir / "sweep.ply", first_origin);
  ASSERT_EQ(scan.colors.size(), sweep.size());
  EXPECT_EQ(scan.colors[7], sweep[7].color);
  TsdfVolume volume({.voxel_size = voxel, .color = true});
  volume.integrate(scan);
  const Mesh merged = volume.extract_mesh();
  ASSERT_EQ(merged.colors.size(), merged.vertex_count());
  const auto [median, p95] = color_errors(merged);
  std::cout << "point colours: median error " << median << ", p95 " << p95 << " (of 255)\n";
  // A voxel mixes samples within about a voxel across the ray (0.05 m is 3 to 5 levels of 255 here),
  // evenly on both sides for a linear colour; measured median 0, p95 1.
  EXPECT_LE(median, 1);
  EXPECT_LE(p95, 3);
  // Without a colour grid the colours are ignored, and the surface is the same.
  TsdfVolume plain({.voxel_size = voxel});
  plain.integrate(scan);
  EXPECT_TRUE(plain.extract_mesh().colors.empty());
  EXPECT_EQ(plain.compare(volume).distance, 0.0);
}

TEST(ScanPoints, MeshScanColoursAreInterpolatedAtTheHit) {
  Mesh scanned = room();
  scanned.colors.resize(scanned.vertex_count());
  for (std::size_t v = 0; v < scanned.vertex_count(); ++v)
    scanned.colors[v] = room_color(scanned.positions[v].cast<double>());
  TempDir dir;
  write_mesh_ply(dir / "room.ply", scanned);
  EXPECT_TRUE(inspect_scan(dir / "room.ply").has_color);
  const ScanSurface scan =
      place_scan(read_scan_mesh(dir / "room.ply"), Rigid3{}, first_origin, std::nullopt, "room.ply");
  TsdfVolume volume({.voxel_size = 0.05, .color = true});
  volume.integrate(scan);
  const Mesh merged = volume.extract_mesh();
  ASSERT_EQ(merged.colors.size(), merged.vertex_count());
  const auto [median, p95] = color_errors(merged);
  std::cout << "mesh scan colours: median error " << median << ", p95 " << p95 << " (of 255)\n";
  EXPECT_LE(median, 1);  // measured median 0, p95 1
  EXPECT_LE(p95, 3);
}

TEST(ScanPoints, ResultDoesNotDependOnThreads) {
  TempDir dir;
  testing::write_plain_points(dir / "sweep.ply", testing::lidar_sweep(room(), first_origin, 240, 120));
  const ScanPoints scan = read_placed(dir / "sweep.ply", first_origin);
  TsdfVolume parallel({.voxel_size = 0.05}), serial({.voxel_size = 0.05});
  parallel.integrate(scan);
  {
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    serial.integrate(scan);
  }
  const auto difference = parallel.compare(serial);
  EXPECT_EQ(difference.distance, 0.0);
  EXPECT_EQ(difference.weight_relative, 0.0);
}

TEST(ScanPoints, WeightsFollowTheDocumentedFactors) {
  TempDir dir;
  const Mesh truth = room();
  const auto sweep = testing::lidar_sweep(truth, first_origin, 240, 120);
  testing::write_plain_points(dir / "plain.ply", sweep);
  testing::write_plain_points(dir / "half.ply", sweep, {.confidence = 0.5f});
  const double voxel = 0.05;
  TsdfVolume plain({.voxel_size = voxel}), half({.voxel_size = voxel}), doubled({.voxel_size = voxel}),
      ignored({.voxel_size = voxel});
  plain.integrate(read_placed(dir / "plain.ply", first_origin));
  half.integrate(read_placed(dir / "half.ply", first_origin));
  ScanPoints weighted = read_placed(dir / "half.ply", first_origin);
  weighted.multiplier = 2;
  doubled.integrate(weighted);
  weighted.multiplier = 1;
  weighted.use_confidence = false;
  ignored.integrate(weighted);
  // Confidence x multiplier scales every weight and leaves the distances (factors of 2 are exact).
  EXPECT_EQ(plain.compare(doubled).weight_relative, 0.0);
  EXPECT_EQ(plain.compare(ignored).weight_relative, 0.0);
  EXPECT_EQ(plain.compare(half).distance, 0.0);
  const Eigen::Vector3d near_wall(1.97, -0.5, 1.25);
  ASSERT_GT(plain.weight_at(near_wall), 0.0f);
  EXPECT_EQ(half.weight_at(near_wall), plain.weight_at(near_wall) / 2);
  // Behind the point the weight ramps down to 0 at the band's end: 4 voxels behind the wall x = 2
  // along the ray on the x axis, 2 voxels behind it about half.
  EXPECT_LT(plain.weight_at({2.0 + 3.9 * voxel, -0.5, 1.25}), 0.1f * plain.weight_at({1.9, -0.5, 1.25}));

  // Normals: weights by |cos(normal, ray)|; points more grazing than min_cos (0 by default) are dropped.
  auto grazing = sweep;
  for (auto& p : grazing)
    p.normal = (p.position - p.origin).cross(Eigen::Vector3d::UnitZ()).normalized().cast<float>();
  testing::write_plain_points(dir / "grazing.ply", grazing, {.normals = true});
  TsdfVolume dropped({.voxel_size = voxel}), kept({.voxel_size = voxel});
  ScanPoints with_normals = read_placed(dir / "grazing.ply", first_origin);
  with_normals.min_cos = 0.1;
  dropped.integrate(with_normals);
  EXPECT_LT(dropped.active_voxel_count(), plain.active_voxel_count() / 20);
  // Without the angle weight nothing is dropped; the band behind a grazing point reaches deeper
  // along the ray (its depth behind is measured across the surface, cos clamped at min_band_cos).
  with_normals.use_angle = false;
  kept.integrate(with_normals);
  EXPECT_GT(kept.active_voxel_count(), plain.active_voxel_count());
}

TEST(ScanPoints, BadInputsAreClearErrors) {
  TempDir dir;
  {
    std::ofstream out(dir / "no_z.ply");
    out << "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n1 2\n";
  }
  try {
    read_scan_points(dir / "no_z.ply");
    FAIL() << "a cloud without z was read";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("no_z.ply: PLY vertex element lacks x, y or z"), std::string::npos)
        << e.what();
  }
  {
    std::ofstream out(dir / "empty.ply");
    out << "ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\nproperty float "
           "z\nend_header\n";
  }
  EXPECT_THROW(read_scan_points(dir / "empty.ply"), InputError);
  {
    std::ofstream out(dir / "truncated.ply");
    out << "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float "
           "z\nend_header\n1 2 3\n";
  }
  EXPECT_THROW(read_scan_points(dir / "truncated.ply"), InputError);
  testing::write_plain_points(dir / "sweep.ply", testing::lidar_sweep(room(), first_origin, 24, 12));
  EXPECT_THROW(place_scan_points(read_scan_points(dir / "sweep.ply"), Rigid3{}, std::nullopt, std::nullopt),
               UsageError);
  EXPECT_THROW(place_scan_points(read_scan_points(dir / "sweep.ply"), Rigid3{}, first_origin,
                                 Eigen::Vector3d(0, 0, -1)),
               UsageError);
  // Read as a mesh, bare points are still refused.
  EXPECT_THROW(read_scan_mesh(dir / "sweep.ply"), InputError);
}

TEST(ScanPoints, TheFormatExampleReadsWithItsOrigins) {
  const auto example = std::filesystem::path(build_info::source_dir) / "formats/examples/scan-points.ply";
  EXPECT_TRUE(inspect_scan(example).per_point_origins);
  const ScanPoints scan = read_placed(example, std::nullopt);
  ASSERT_EQ(scan.positions.size(), 2u);
  ASSERT_EQ(scan.origins.size(), 2u);
  // Each point lies on a wall of room(), seen from its origin along an axis.
  EXPECT_EQ(scan.positions[0], Eigen::Vector3d(2, -0.5, 1.25));
  EXPECT_EQ(scan.origins[0], first_origin);
  EXPECT_EQ(scan.origins[1], second_origin);
  TsdfVolume volume({.voxel_size = 0.05});
  volume.integrate(scan);
  EXPECT_GT(volume.active_voxel_count(), 0u);
}

TEST(RealData, StanfordBunnyScansAsBarePointsMergeWithinHalfAMillimetre) {
  PG_REQUIRE_REAL_DATA(bunny, "meshes/stanford-bunny");
  TempDir dir;
  const double voxel = 0.001;
  TsdfVolume volume({.voxel_size = voxel, .truncation = 3 * voxel});
  for (const ScanPlacement& p : read_stanford_conf(bunny / "data/bun.conf")) {
    // The range grid's points without its grid: what a scanner exporting a point cloud writes.
    std::vector<testing::SweepPoint> points;
    for (const auto& v : read_scan_mesh(p.file).positions)
      points.push_back({v.cast<double>(), Eigen::Vector3d::Zero(), Eigen::Vector3f::Zero()});
    const auto cloud = dir / p.file.filename();
    testing::write_plain_points(cloud, points);
    volume.integrate(place_scan_points(read_scan_points(cloud), p.world_from_scan, std::nullopt,
                                       Eigen::Vector3d(0, 0, -1)));
  }
  const Mesh merged = volume.extract_mesh({.min_component_fraction = 0.01});
  const Mesh reference = read_mesh(bunny / "reconstruction/bun_zipper.ply");
  const MeshEvalResult eval =
      evaluate_mesh(merged, reference, {.samples = 50000, .thresholds = {0.0005, 2 * voxel}});
  std::cout << "bunny, 10 scans as points at 1 mm voxels: " << merged.face_count() << " faces; accuracy mean "
            << eval.accuracy.mean * 1000 << " mm, p90 " << eval.accuracy.p90 * 1000
            << " mm; completeness p90 " << eval.completeness.p90 * 1000 << " mm, within 2 mm "
            << eval.recall[1] * 100 << "%\n";
  EXPECT_LT(eval.accuracy.p90, 0.0005);
  EXPECT_GT(eval.recall[1], 0.95);
}

}  // namespace
}  // namespace pg::fusion

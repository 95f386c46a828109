// pg-merge volume with point-cloud scans: a synthetic LIDAR sweep of a room written as a plain PLY
// point cloud, merged along its sensor rays and measured against the room; per-point sensor origins;
// the same volume at any thread count; the sensor options' usage errors.
#include <gtest/gtest.h>

#include "pg/eval/mesh_eval.h"
#include "pg/fusion/scan_points_test_scenes.h"
#include "pg/fusion/tsdf_volume.h"
#include "pg/mesh/mesh_io.h"
#include "pg/testing/testing.h"

namespace fs = std::filesystem;
using namespace pg;
using pg::testing::run_tool;
using pg::testing::TempDir;

namespace {

Mesh room() {
  return fusion::testing::box({-2.0f, -1.5f, 0.0f}, {2.0f, 1.5f, 2.5f}, 8, true);
}

const Eigen::Vector3d sensor(0.25, -0.5, 1.25);

std::vector<std::string> volume_args(const fs::path& scan, const fs::path& out,
                                     std::vector<std::string> more) {
  std::vector<std::string> a{"volume", "--scan", scan.string(), "--voxel-size",
                             "0.05",   "--out",  out.string()};
  a.insert(a.end(), more.begin(), more.end());
  return a;
}

TEST(PgMergePoints, LidarSweepMergesWithinAVoxel) {
  TempDir dir;
  const Mesh truth = room();
  fusion::testing::write_plain_points(dir / "sweep.ply",
                                      fusion::testing::lidar_sweep(truth, sensor, 480, 240));
  const auto r = run_tool("pg-merge", volume_args(dir / "sweep.ply", dir / "m.ply",
                                                  {"--sensor-origin", "0.25,-0.5,1.25", "--vdb",
                                                   (dir / "m.vdb").string(), "--threads", "2"}));
  ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
  const double voxel = 0.05;
  const MeshEvalResult eval =
      evaluate_mesh(read_mesh(dir / "m.ply"), truth, {.samples = 20000, .thresholds = {voxel}});
  EXPECT_LT(eval.accuracy.p90, voxel / 4);
  EXPECT_GT(eval.recall[0], 0.95);

  // One thread gives the same voxels, bit for bit.
  const auto single = run_tool("pg-merge", volume_args(dir / "sweep.ply", dir / "s.ply",
                                                       {"--sensor-origin", "0.25,-0.5,1.25", "--vdb",
                                                        (dir / "s.vdb").string(), "--threads", "1"}));
  ASSERT_EQ(single.exit_code, 0) << single.stderr_text;
  const auto difference =
      fusion::TsdfVolume::read_vdb(dir / "m.vdb").compare(fusion::TsdfVolume::read_vdb(dir / "s.vdb"));
  EXPECT_EQ(difference.distance, 0.0);
  EXPECT_EQ(difference.weight_relative, 0.0);
}

TEST(PgMergePoints, PerPointOriginsNeedNoSensorOption) {
  TempDir dir;
  const Mesh truth = room();
  auto sweep = fusion::testing::lidar_sweep(truth, sensor, 240, 120);
  const auto second = fusion::testing::lidar_sweep(truth, {-0.75, 0.5, 0.75}, 240, 120);
  sweep.insert(sweep.end(), second.begin(), second.end());
  fusion::testing::write_plain_points(dir / "both.ply", sweep, {.origins = true});
  const auto r = run_tool("pg-merge", volume_args(dir / "both.ply", dir / "m.ply", {}));
  ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
  const double voxel = 0.05;
  const MeshEvalResult eval =
      evaluate_mesh(read_mesh(dir / "m.ply"), truth, {.samples = 20000, .thresholds = {voxel}});
  EXPECT_LT(eval.accuracy.p90, voxel / 4);
  EXPECT_GT(eval.recall[0], 0.95);
}

TEST(PgMergePoints, ColouredPointsGiveAColouredMesh) {
  TempDir dir;
  auto sweep = fusion::testing::lidar_sweep(room(), sensor, 240, 120);
  // The wall x = 2 is red, everything else grey.
  for (auto& p : sweep)
    p.color = p.position.x() > 1.99 ? std::array<std::uint8_t, 3>{200, 0, 0}
                                    : std::array<std::uint8_t, 3>{90, 90, 90};
  fusion::testing::write_plain_points(dir / "sweep.ply", sweep, {.colors = true});
  const auto r = run_tool(
      "pg-merge", volume_args(dir / "sweep.ply", dir / "m.ply", {"--sensor-origin", "0.25,-0.5,1.25"}));
  ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
  const Mesh merged = read_mesh(dir / "m.ply");
  ASSERT_EQ(merged.colors.size(), merged.vertex_count());
  std::size_t checked = 0;
  for (std::size_t v = 0; v < merged.vertex_count(); ++v) {
    const Eigen::Vector3f& p = merged.positions[v];
    const bool on_red_wall = p.x() > 1.9 && std::abs(p.y()) < 1.3 && p.z() > 0.2 && p.z() < 2.3;
    const bool far_from_it = p.x() < 1.5;
    if (!on_red_wall && !far_from_it) continue;
    const std::array<std::uint8_t, 3> expected =
        on_red_wall ? std::array<std::uint8_t, 3>{200, 0, 0} : std::array<std::uint8_t, 3>{90, 90, 90};
    EXPECT_EQ(merged.colors[v], expected) << "vertex " << v << " at " << p.transpose();
    ++checked;
  }
  EXPECT_GT(checked, merged.vertex_count() / 2);

  // Split over two farm jobs, one of them without colour: the combined mesh has colour whichever
  // partial comes first.
  fusion::testing::write_plain_points(dir / "grey.ply",
                                      fusion::testing::lidar_sweep(room(), sensor, 120, 60));
  for (const auto& [scan, name] : {std::pair{"sweep.ply", "coloured"}, std::pair{"grey.ply", "plain"}}) {
    const auto job = run_tool("pg-merge", volume_args(dir / scan, dir / (std::string(name) + ".ply"),
                                                      {"--sensor-origin", "0.25,-0.5,1.25", "--vdb",
                                                       (dir / (std::string(name) + ".vdb")).string()}));
    ASSERT_EQ(job.exit_code, 0) << job.stderr_text;
  }
  for (const auto& order : {std::vector<std::string>{"plain.vdb", "coloured.vdb"},
                            std::vector<std::string>{"coloured.vdb", "plain.vdb"}}) {
    const auto combined =
        run_tool("pg-merge", {"combine", "--partials", (dir / order[0]).string(), (dir / order[1]).string(),
                              "--out", (dir / "c.ply").string()});
    ASSERT_EQ(combined.exit_code, 0) << combined.stderr_text;
    const Mesh mesh = read_mesh(dir / "c.ply");
    EXPECT_EQ(mesh.colors.size(), mesh.vertex_count()) << order[0] << " first";
  }
}

TEST(PgMergePoints, SensorOptionsAreUsageErrors) {
  TempDir dir;
  fusion::testing::write_plain_points(dir / "sweep.ply",
                                      fusion::testing::lidar_sweep(room(), sensor, 24, 12));
  // A point cloud without per-point origins and no sensor option.
  auto r = run_tool("pg-merge", volume_args(dir / "sweep.ply", dir / "m.ply", {}));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.stderr_text.find("sweep.ply: scans need --sensor-origin x,y,z or --sensor-direction x,y,z"),
            std::string::npos)
      << r.stderr_text;
  // Both sensor options.
  r = run_tool("pg-merge", volume_args(dir / "sweep.ply", dir / "m.ply",
                                       {"--sensor-origin", "0,0,1", "--sensor-direction", "0,0,-1"}));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.stderr_text.find("not both"), std::string::npos) << r.stderr_text;
  EXPECT_FALSE(fs::exists(dir / "m.ply"));
}

// Every scan's header is read before the first is integrated: a second scan that is not a PLY fails
// with exit 3 and its name, without integrating the first.
TEST(PgMergePoints, AnUnreadableScanFailsBeforeAnyIsIntegrated) {
  TempDir dir;
  fusion::testing::write_plain_points(dir / "sweep.ply",
                                      fusion::testing::lidar_sweep(room(), sensor, 48, 24));
  pg::testing::write_text(dir / "broken.ply", "not a ply file\n");
  const auto r = run_tool("pg-merge", volume_args(dir / "sweep.ply", dir / "m.ply",
                                                  {"--scan", (dir / "broken.ply").string(), "--sensor-origin",
                                                   "0.25,-0.5,1.25", "--log-level", "info"}));
  EXPECT_EQ(r.exit_code, 3);
  EXPECT_NE(r.stderr_text.find("broken.ply"), std::string::npos) << r.stderr_text;
  EXPECT_EQ(r.stderr_text.find("integrated 1/"), std::string::npos) << r.stderr_text;
  EXPECT_FALSE(fs::exists(dir / "m.ply"));
}

// A farm chunk (--range-size 1) reads only its own scan, but still refuses to overwrite another
// chunk's: the second scan is kept as it was.
TEST(PgMergePoints, AChunkDoesNotOverwriteAnotherChunksScan) {
  TempDir dir;
  const auto sweep = fusion::testing::lidar_sweep(room(), sensor, 48, 24);
  fusion::testing::write_plain_points(dir / "sweep.ply", sweep);
  fusion::testing::write_plain_points(dir / "other.ply", sweep);
  const std::string before = pg::testing::read_text(dir / "other.ply");
  const auto r = run_tool("pg-merge", volume_args(dir / "sweep.ply", dir / "other.ply",
                                                  {"--scan", (dir / "other.ply").string(), "--range-size",
                                                   "1", "--sensor-origin", "0.25,-0.5,1.25"}));
  EXPECT_EQ(r.exit_code, 6);
  EXPECT_NE(r.stderr_text.find("refusing to overwrite an input"), std::string::npos) << r.stderr_text;
  EXPECT_EQ(pg::testing::read_text(dir / "other.ply"), before);
}

}  // namespace

// pg-merge with its TSDF integration on the OpenCL device (PoCL where there is no GPU) against the
// CPU reference, on a pg-synth set: the merged meshes agree and the run report names the device.
#include <gtest/gtest.h>

#include <algorithm>

#include "pg/eval/mesh_eval.h"
#include "pg/gpu/device.h"
#include "pg/mesh/mesh_io.h"
#include "pg/testing/testing.h"

namespace fs = std::filesystem;
using pg::testing::run_tool;
using pg::testing::TempDir;

namespace {

struct MergeRun {
  pg::Mesh mesh;
  nlohmann::json metrics;
};

MergeRun merge_on(const fs::path& dir, const std::vector<std::string>& depth, const std::string& device) {
  const fs::path out = dir / (device + ".ply"), report = dir / (device + ".json");
  std::vector<std::string> args{"volume", "--voxel-size", "0.05",     "--device",      device,
                                "--out",  out.string(),   "--report", report.string(), "--depth"};
  args.insert(args.end(), depth.begin(), depth.end());
  const auto result = run_tool("pg-merge", args);
  EXPECT_EQ(result.exit_code, 0) << result.stderr_text;
  MergeRun run;
  if (result.exit_code != 0) return run;
  run.mesh = pg::read_mesh(out);
  run.metrics = nlohmann::json::parse(pg::testing::read_text(report)).at("metrics");
  return run;
}

TEST(PgMergeDevice, OpenClMergeMatchesTheCpuAndTheReportNamesTheDevice) {
  if (!pg::gpu::opencl_unavailable_reason().empty())
    GTEST_SKIP() << "no OpenCL device (" << pg::gpu::opencl_unavailable_reason() << "); CPU path only";
  if (!fs::exists(pg::testing::bin_dir() / "pg-synth")) GTEST_SKIP() << "pg-synth is not built";
  TempDir dir;
  const double voxel = 0.05;
  const auto synth = run_tool("pg-synth", {"set", "--out", (dir / "set").string(), "--views", "8", "--width",
                                           "160", "--height", "120", "--supersample", "1"});
  ASSERT_EQ(synth.exit_code, 0) << synth.stderr_text;
  std::vector<std::string> depth;
  for (const auto& entry : fs::directory_iterator(dir / "set" / "depth"))
    depth.push_back(entry.path().string());
  std::sort(depth.begin(), depth.end());

  const MergeRun cpu = merge_on(dir.path(), depth, "cpu"), opencl = merge_on(dir.path(), depth, "opencl");
  ASSERT_GT(cpu.mesh.face_count(), 1000u);
  EXPECT_EQ(cpu.metrics.value("device", ""), "cpu");
  EXPECT_EQ(opencl.metrics.value("device", "").rfind("opencl (", 0), 0u) << opencl.metrics.dump();
  // Every frame went through the kernel (the synthetic set is undistorted pinhole), none on the CPU run.
  EXPECT_EQ(opencl.metrics.value("tsdf_device_frames", 0), int(depth.size()));
  EXPECT_FALSE(cpu.metrics.contains("tsdf_device_frames"));
  EXPECT_EQ(opencl.metrics.at("active_voxels"), cpu.metrics.at("active_voxels"));

  ASSERT_EQ(opencl.mesh.vertex_count(), cpu.mesh.vertex_count());
  ASSERT_EQ(opencl.mesh.face_count(), cpu.mesh.face_count());
  float worst = 0;
  for (std::size_t i = 0; i < cpu.mesh.vertex_count(); ++i)
    worst = std::max(worst, (opencl.mesh.positions[i] - cpu.mesh.positions[i]).norm());
  EXPECT_LT(worst, 1e-4 * voxel);
  EXPECT_TRUE(opencl.mesh.faces == cpu.mesh.faces);
  // Both are the scene, not merely equal to each other.
  const pg::Mesh truth = pg::read_mesh(dir / "set" / "mesh.ply");
  const pg::MeshEvalResult eval =
      pg::evaluate_mesh(opencl.mesh, truth, {.samples = 20000, .thresholds = {2 * voxel}});
  EXPECT_LT(eval.accuracy.p90, voxel);
}

}  // namespace

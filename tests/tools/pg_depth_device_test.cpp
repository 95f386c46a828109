// pg-depth with its flow solver on the OpenCL device (PoCL where there is no GPU) against the CPU
// reference, on a small analytic scene: the depth maps agree and the run report names the device.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <opencv2/imgcodecs.hpp>

#include "pg/camera/cameras_io.h"
#include "pg/depth/test_scene.h"
#include "pg/gpu/device.h"
#include "pg/image/depth_exr.h"
#include "pg/testing/testing.h"

namespace fs = std::filesystem;
using pg::testing::run_tool;
using pg::testing::TempDir;

namespace {

// Two views of the analytic scene and the exact depth of the first.
struct Scene {
  TempDir dir;
  cv::Mat1f depth;
  Scene() {
    pg::CameraSet set;
    fs::create_directories(dir / "images");
    for (int i = 0; i < 2; ++i) {
      pg::Camera camera =
          pg::depth_testing::look_at_camera("view_" + std::to_string(i), {-0.1 + 0.2 * i, 0, 0}, {0, 0.1, 4});
      camera.image = "images/" + camera.id + ".png";
      const pg::depth_testing::RenderedView view = pg::depth_testing::render(camera);
      cv::imwrite((dir / camera.image).string(), view.image);
      if (i == 0) depth = view.depth;
      set.cameras.push_back(camera);
    }
    pg::write_cameras(dir / "cameras.json", set);
  }
};

// The median of |a - b| / |b| over pixels valid in both, and the share of such pixels.
double median_relative_difference(const cv::Mat1f& a, const cv::Mat1f& b, double& coverage) {
  std::vector<double> differences;
  for (int y = 0; y < b.rows; ++y)
    for (int x = 0; x < b.cols; ++x)
      if (std::isfinite(a(y, x)) && std::isfinite(b(y, x)))
        differences.push_back(std::abs(a(y, x) - b(y, x)) / std::abs(b(y, x)));
  coverage = double(differences.size()) / double(b.total());
  if (differences.empty()) return INFINITY;
  std::nth_element(differences.begin(), differences.begin() + differences.size() / 2, differences.end());
  return differences[differences.size() / 2];
}

struct DeviceRun {
  cv::Mat1f depth;
  std::string device;  // the report's "device" metric
};

DeviceRun run_on(const Scene& scene, const std::string& device, const std::string& mode) {
  const fs::path out = scene.dir / (device + "-" + mode),
                 report = scene.dir / (device + "-" + mode + ".json");
  const auto result =
      run_tool("pg-depth", {"--cameras", (scene.dir / "cameras.json").string(), "--out-dir", out.string(),
                            "--mode", mode, "--device", device, "--report", report.string()});
  EXPECT_EQ(result.exit_code, 0) << result.stderr_text;
  DeviceRun run;
  if (result.exit_code != 0) return run;
  run.depth = pg::read_depth_exr(out / "view_0-view_1.exr").depth;
  const auto json = nlohmann::json::parse(pg::testing::read_text(report));
  run.device = json.at("metrics").value("device", "");
  return run;
}

class PgDepthDevice : public ::testing::TestWithParam<std::string> {};

TEST_P(PgDepthDevice, OpenClDepthMatchesTheCpuAndTheReportNamesTheDevice) {
  if (!pg::gpu::opencl_unavailable_reason().empty())
    GTEST_SKIP() << "no OpenCL device (" << pg::gpu::opencl_unavailable_reason() << "); CPU path only";
  const Scene scene;
  const DeviceRun cpu = run_on(scene, "cpu", GetParam()), opencl = run_on(scene, "opencl", GetParam());
  ASSERT_FALSE(cpu.depth.empty());
  ASSERT_FALSE(opencl.depth.empty());
  EXPECT_EQ(cpu.device, "cpu");
  EXPECT_EQ(opencl.device.rfind("opencl (", 0), 0u) << opencl.device;
  double coverage = 0;
  EXPECT_LT(median_relative_difference(opencl.depth, cpu.depth, coverage), 1e-3);
  EXPECT_GT(coverage, 0.8);
  // Both are depth maps of the scene, not merely equal to each other.
  EXPECT_LT(median_relative_difference(opencl.depth, scene.depth, coverage), 0.01);
  EXPECT_LT(median_relative_difference(cpu.depth, scene.depth, coverage), 0.01);
}

INSTANTIATE_TEST_SUITE_P(Modes, PgDepthDevice, ::testing::Values("epipolar", "free"));

}  // namespace

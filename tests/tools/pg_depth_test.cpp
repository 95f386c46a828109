// pg-depth run as a tool on an analytic scene written by the test: outputs, accuracy and bad input.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <opencv2/imgcodecs.hpp>

#include "pg/camera/cameras_io.h"
#include "pg/depth/test_scene.h"
#include "pg/image/depth_exr.h"
#include "pg/testing/testing.h"

namespace fs = std::filesystem;
using pg::testing::run_tool;
using pg::testing::TempDir;

namespace {

// Three views on an arc, their images and exact depths.
struct Shot {
  TempDir dir;
  std::vector<cv::Mat1f> depths;
  Shot() {
    pg::CameraSet set;
    fs::create_directories(dir / "images");
    for (int i = 0; i < 3; ++i) {
      pg::Camera camera = pg::depth_testing::look_at_camera("view_" + std::to_string(i),
                                                            {-0.15 + 0.15 * i, 0, 0}, {0, 0.1, 4});
      camera.image = "images/" + camera.id + ".png";
      const pg::depth_testing::RenderedView view = pg::depth_testing::render(camera);
      cv::imwrite((dir / camera.image).string(), view.image);
      depths.push_back(view.depth);
      set.cameras.push_back(camera);
    }
    pg::write_cameras(dir / "cameras.json", set);
  }
};

double median_relative_error(const cv::Mat& estimate, const cv::Mat1f& truth, double& coverage) {
  std::vector<double> errors;
  for (int y = 0; y < truth.rows; ++y)
    for (int x = 0; x < truth.cols; ++x) {
      const float d = estimate.at<float>(y, x);
      if (std::isfinite(d)) errors.push_back(std::abs(d - truth(y, x)) / truth(y, x));
    }
  coverage = static_cast<double>(errors.size()) / truth.total();
  std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
  return errors[errors.size() / 2];
}

TEST(PgDepth, ConsecutivePairsGiveAccurateDepthMapsAndOptionalOutputs) {
  Shot shot;
  const fs::path out = shot.dir / "depth";
  const auto result = run_tool(
      "pg-depth", {"--cameras", (shot.dir / "cameras.json").string(), "--out-dir", out.string(), "--ply",
                   "--mesh", "--preview", "--flow-png", "--report", (shot.dir / "report.json").string()});
  ASSERT_EQ(result.exit_code, 0) << result.stderr_text;
  for (const char* name : {"view_0-view_1.exr", "view_1-view_2.exr", "view_0-view_1.ply",
                           "view_0-view_1-mesh.ply", "view_0-view_1-depth.png", "view_0-view_1-flow.png"})
    EXPECT_TRUE(fs::exists(out / name)) << name;
  EXPECT_FALSE(fs::exists(out / "view_0-view_2.exr"));
  const pg::DepthMap map = pg::read_depth_exr(out / "view_1-view_2.exr");
  EXPECT_EQ(map.camera.id, "view_1");
  // Its provenance names its own pair's images, not the other pair's.
  const std::string inputs = nlohmann::json(map.provenance.inputs).dump();
  EXPECT_NE(inputs.find("view_2.png"), std::string::npos) << inputs;
  EXPECT_EQ(inputs.find("view_0.png"), std::string::npos) << inputs;
  EXPECT_FALSE(map.confidence.empty());
  EXPECT_FALSE(map.normals.empty());
  double coverage = 0;
  EXPECT_LT(median_relative_error(map.depth, shot.depths[1], coverage), 0.005);
  EXPECT_GT(coverage, 0.8);
  const auto report = nlohmann::json::parse(pg::testing::read_text(shot.dir / "report.json"));
  EXPECT_NE(report.dump().find("valid_fraction"), std::string::npos);
}

TEST(PgDepth, ExplicitPairRangeScaleAndKeepAll) {
  Shot shot;
  const fs::path out = shot.dir / "d";
  const auto result =
      run_tool("pg-depth", {"--cameras", (shot.dir / "cameras.json").string(), "--out-dir", out.string(),
                            "--pair", "view_2:view_0", "--pair", "view_0:view_1", "--range", "0,1", "--scale",
                            "0.5", "--keep-all", "--mode", "free"});
  ASSERT_EQ(result.exit_code, 0) << result.stderr_text;
  EXPECT_TRUE(fs::exists(out / "view_2-view_0.exr"));
  EXPECT_FALSE(fs::exists(out / "view_0-view_1.exr"));
  const pg::DepthMap map = pg::read_depth_exr(out / "view_2-view_0.exr");
  EXPECT_EQ(map.depth.cols, 160);
  EXPECT_EQ(map.camera.width, 160);
}

// --search-range starts from the discrete search, --fill-occlusions keeps the pixels hidden in the
// other view with their line's background: more valid pixels, still accurate, the filled share
// reported; filling needs the epipolar mode.
TEST(PgDepth, SearchAndFilledOcclusions) {
  Shot shot;
  const fs::path out = shot.dir / "f";
  const std::string cameras = (shot.dir / "cameras.json").string();
  const auto result = run_tool("pg-depth", {"--cameras", cameras, "--out-dir", out.string(), "--pair",
                                            "view_0:view_1", "--search-range", "0.1", "--fill-occlusions",
                                            "--report", (shot.dir / "report.json").string()});
  ASSERT_EQ(result.exit_code, 0) << result.stderr_text;
  const auto report = nlohmann::json::parse(pg::testing::read_text(shot.dir / "report.json"));
  const std::string text = report.dump();
  EXPECT_NE(text.find("filled_fraction"), std::string::npos);
  double coverage = 0;
  EXPECT_LT(
      median_relative_error(pg::read_depth_exr(out / "view_0-view_1.exr").depth, shot.depths[0], coverage),
      0.005);
  EXPECT_GT(coverage, 0.8);
  const auto free = run_tool(
      "pg-depth", {"--cameras", cameras, "--out-dir", out.string(), "--mode", "free", "--fill-occlusions"});
  EXPECT_EQ(free.exit_code, 2);
  EXPECT_NE(free.stderr_text.find("epipolar"), std::string::npos);
}

TEST(PgDepth, BadInputsGiveClearErrors) {
  Shot shot;
  const std::string cameras = (shot.dir / "cameras.json").string(), out = (shot.dir / "o").string();
  auto r = run_tool("pg-depth", {"--cameras", cameras, "--out-dir", out, "--pair", "view_0:nope"});
  EXPECT_EQ(r.exit_code, 3);
  EXPECT_NE(r.stderr_text.find("nope"), std::string::npos);
  r = run_tool("pg-depth", {"--cameras", cameras, "--out-dir", out, "--range", "7,2"});
  EXPECT_EQ(r.exit_code, 2);
  // No pair to compute was exit 0 with nothing written: a chunk of no pairs, one camera.
  r = run_tool("pg-depth", {"--cameras", cameras, "--out-dir", out, "--range", "0,0"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.stderr_text.find("COUNT at least 1"), std::string::npos) << r.stderr_text;
  pg::CameraSet one = pg::read_cameras(cameras);
  one.cameras.resize(1);
  pg::write_cameras(shot.dir / "one.json", one);
  r = run_tool("pg-depth", {"--cameras", (shot.dir / "one.json").string(), "--out-dir", out});
  EXPECT_EQ(r.exit_code, 3);
  EXPECT_NE(r.stderr_text.find("one.json: holds 1 camera: no pair"), std::string::npos) << r.stderr_text;
  // A pair given twice would write one depth map over the other: refused before either is computed.
  r = run_tool("pg-depth", {"--cameras", cameras, "--out-dir", out, "--pair", "view_0:view_1", "--pair",
                            "view_0:view_1"});
  EXPECT_EQ(r.exit_code, 6) << r.stderr_text;
  EXPECT_NE(r.stderr_text.find("named for two outputs"), std::string::npos) << r.stderr_text;
  EXPECT_FALSE(fs::exists(shot.dir / "o" / "view_0-view_1.exr"));
  // A mask, then an image, whose size differs from its camera's: found from the headers before any
  // pair is computed, so the first pair (view_0:view_1) leaves no depth map either.
  fs::create_directories(shot.dir / "masks");
  cv::imwrite((shot.dir / "masks/view_1.png").string(), cv::Mat1b(12, 12, uchar(255)));
  r = run_tool("pg-depth",
               {"--cameras", cameras, "--out-dir", out, "--masks", (shot.dir / "masks").string()});
  EXPECT_EQ(r.exit_code, 3);
  EXPECT_NE(r.stderr_text.find("mask is 12x12 but camera 'view_1'"), std::string::npos) << r.stderr_text;
  cv::imwrite((shot.dir / "images/view_2.png").string(), cv::Mat3b(10, 10, cv::Vec3b(1, 2, 3)));
  r = run_tool("pg-depth", {"--cameras", cameras, "--out-dir", out});
  EXPECT_EQ(r.exit_code, 3);
  EXPECT_NE(r.stderr_text.find("view_2.png: image is 10x10 but camera 'view_2'"), std::string::npos)
      << r.stderr_text;
  EXPECT_FALSE(fs::exists(shot.dir / "o" / "view_0-view_1.exr"));
  // Two cameras at the same centre.
  pg::CameraSet set = pg::read_cameras(cameras);
  set.cameras[2].cam_from_world = set.cameras[0].cam_from_world;
  pg::write_cameras(shot.dir / "same.json", set);
  r = run_tool("pg-depth",
               {"--cameras", (shot.dir / "same.json").string(), "--out-dir", out, "--pair", "view_0:view_2"});
  EXPECT_EQ(r.exit_code, 3);
  EXPECT_NE(r.stderr_text.find("same centre"), std::string::npos);
  // A pair of cameras of two sizes (each image its camera's size), after a good pair: found before the
  // good pair is computed.
  set = pg::read_cameras(cameras);
  set.cameras[2].width = set.cameras[2].height = 10;
  pg::write_cameras(shot.dir / "sizes.json", set);
  r = run_tool("pg-depth", {"--cameras", (shot.dir / "sizes.json").string(), "--out-dir", out});
  EXPECT_EQ(r.exit_code, 3);
  EXPECT_NE(r.stderr_text.find("differ in size"), std::string::npos) << r.stderr_text;
  EXPECT_FALSE(fs::exists(shot.dir / "o" / "view_0-view_1.exr"));
  // A mistyped masks folder is an error, not a run without masks.
  r = run_tool("pg-depth", {"--cameras", cameras, "--out-dir", out, "--masks", (shot.dir / "maks").string()});
  EXPECT_EQ(r.exit_code, 3);
  EXPECT_NE(r.stderr_text.find("maks: no such folder"), std::string::npos) << r.stderr_text;
}

}  // namespace

// pg-eval run as a tool on files written by the test: exit codes, the --out JSON and the run report.
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <numbers>
#include <opencv2/imgcodecs.hpp>

#include "pg/camera/cameras_io.h"
#include "pg/eval/flo_io.h"
#include "pg/image/depth_exr.h"
#include "pg/mesh/mesh_io.h"
#include "pg/testing/testing.h"

namespace fs = std::filesystem;
using pg::testing::run_tool;
using pg::testing::TempDir;

namespace {

nlohmann::json read_json(const fs::path& path) {
  return nlohmann::json::parse(pg::testing::read_text(path));
}

std::size_t line_count(const std::string& text) {
  return std::count(text.begin(), text.end(), '\n');
}

pg::CameraSet ring_of_cameras() {
  pg::CameraSet set;
  for (int i = 0; i < 6; ++i) {
    double a = 2 * std::numbers::pi * i / 6;
    pg::Camera c;
    c.id = "cam" + std::to_string(i);
    c.width = 640;
    c.height = 480;
    c.intrinsics = {500, 500, 319.5, 239.5};
    c.cam_from_world = pg::Rigid3::look_at({4 * std::cos(a), 4 * std::sin(a), 0.5 * (i % 2)}, {0, 0, 0});
    set.cameras.push_back(c);
  }
  return set;
}

pg::Mesh square(float z) {
  pg::Mesh m;
  m.positions = {{0, 0, z}, {1, 0, z}, {1, 1, z}, {0, 1, z}};
  m.faces = {{0, 1, 2}, {0, 2, 3}};
  return m;
}

pg::DepthMap depth_map(float factor) {
  pg::DepthMap d;
  d.camera.id = "cam0";
  d.camera.width = 32;
  d.camera.height = 24;
  d.camera.intrinsics = {30, 30, 15.5, 11.5};
  d.depth = cv::Mat1f(24, 32);
  for (int row = 0; row < 24; ++row)
    for (int col = 0; col < 32; ++col)
      d.depth.at<float>(row, col) = factor * (2.0f + 0.05f * col + 0.1f * row);
  return d;
}

cv::Mat2f flow_field(float du, float dv) {
  cv::Mat2f f(20, 30);
  for (int row = 0; row < 20; ++row)
    for (int col = 0; col < 30; ++col) f(row, col) = cv::Vec2f(0.1f * col + du, -0.2f * row + dv);
  return f;
}

}  // namespace

TEST(PgEval, CamerasUnderAKnownSimilarity) {
  TempDir dir;
  pg::CameraSet truth = ring_of_cameras(), estimate = truth;
  const double s = 0.5;
  const Eigen::Quaterniond R(Eigen::AngleAxisd(1.1, Eigen::Vector3d(0, 1, 1).normalized()));
  const Eigen::Vector3d t(3, 0, -1);
  for (pg::Camera& c : estimate.cameras) {  // truth_world = s R estimate_world + t
    const pg::Rigid3 p = c.cam_from_world;
    c.cam_from_world.rotation = p.rotation * R;
    c.cam_from_world.translation = (p.rotation * t + p.translation) / s;
  }
  pg::write_cameras(dir / "truth.json", truth);
  pg::write_cameras(dir / "estimate.json", estimate);
  auto r = run_tool("pg-eval", {"cameras", "--estimate", (dir / "estimate.json").string(), "--truth",
                                (dir / "truth.json").string(), "--out", (dir / "eval.json").string(),
                                "--report", (dir / "report.json").string()});
  ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
  EXPECT_NE(r.stdout_text.find("6 cameras matched"), std::string::npos) << r.stdout_text;
  nlohmann::json j = read_json(dir / "eval.json");
  EXPECT_EQ(j["format"], "pg-eval");
  EXPECT_EQ(j["version"], 1);
  EXPECT_EQ(j["provenance"]["tool"], "pg-eval");
  EXPECT_EQ(j["evaluation"], "cameras");
  EXPECT_NEAR(j["result"]["alignment"]["scale"].get<double>(), s, 1e-9);
  EXPECT_LT(j["result"]["centre_error"]["max"].get<double>(), 1e-9);
  EXPECT_LT(j["result"]["rotation_error_deg"]["max"].get<double>(), 1e-7);
  nlohmann::json report = read_json(dir / "report.json");
  EXPECT_LT(report["metrics"]["centre_error_rms"].get<double>(), 1e-9);
  EXPECT_EQ(report["metrics"]["cameras_matched"], 6);
}

TEST(PgEval, DepthWithAKnownMultiplicativeError) {
  TempDir dir;
  pg::write_depth_exr(dir / "truth.exr", depth_map(1.0f));
  pg::write_depth_exr(dir / "estimate.exr", depth_map(1.02f));
  auto r = run_tool("pg-eval", {"depth", "--estimate", (dir / "estimate.exr").string(), "--truth",
                                (dir / "truth.exr").string(), "--out", (dir / "eval.json").string()});
  ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
  nlohmann::json res = read_json(dir / "eval.json")["result"];
  EXPECT_NEAR(res["relative_error"]["mean"].get<double>(), 0.02, 1e-6);
  EXPECT_NEAR(res["relative_error"]["max"].get<double>(), 0.02, 1e-6);
  EXPECT_EQ(res["coverage"], 1.0);
  EXPECT_EQ(res["fraction_below"][0]["fraction"], 0.0);  // 1%
  EXPECT_EQ(res["fraction_below"][2]["fraction"], 1.0);  // 5%

  r = run_tool("pg-eval",
               {"depth", "--estimate", (dir / "estimate.exr").string(), "--truth",
                (dir / "truth.exr").string(), "--align-scale", "--out", (dir / "scaled.json").string()});
  ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
  res = read_json(dir / "scaled.json")["result"];
  EXPECT_NEAR(res["scale"].get<double>(), 1 / 1.02, 1e-6);
  EXPECT_LT(res["relative_error"]["max"].get<double>(), 1e-6);
}

TEST(PgEval, MeshShiftedAlongItsNormal) {
  TempDir dir;
  pg::write_mesh(dir / "truth.ply", square(0.0f));
  pg::write_mesh(dir / "estimate.obj", square(0.01f));
  auto r = run_tool("pg-eval",
                    {"mesh", "--estimate", (dir / "estimate.obj").string(), "--truth",
                     (dir / "truth.ply").string(), "--samples", "3000", "--thresholds", "0.005,0.02", "--out",
                     (dir / "eval.json").string(), "--report", (dir / "report.json").string()});
  ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
  nlohmann::json res = read_json(dir / "eval.json")["result"];
  EXPECT_EQ(res["estimate_points"], 3004);
  EXPECT_NEAR(res["accuracy"]["mean"].get<double>(), 0.01, 1e-5);
  EXPECT_NEAR(res["completeness"]["p99"].get<double>(), 0.01, 1e-5);
  EXPECT_EQ(res["thresholds"][0]["fscore"], 0.0);
  EXPECT_EQ(res["thresholds"][1]["fscore"], 1.0);
  EXPECT_EQ(read_json(dir / "report.json")["metrics"]["fscore_0.02"], 1.0);
}

TEST(PgEval, FlowWithAConstantOffsetAndOcclusions) {
  TempDir dir;
  pg::write_flo(dir / "truth.flo", flow_field(0, 0));
  pg::write_flo(dir / "estimate.flo", flow_field(0.3f, 0.4f));
  cv::Mat1b occlusions(20, 30, std::uint8_t(0));
  occlusions.colRange(0, 15).setTo(255);
  cv::imwrite((dir / "occ.png").string(), occlusions);
  auto r = run_tool("pg-eval", {"flow", "--estimate", (dir / "estimate.flo").string(), "--truth",
                                (dir / "truth.flo").string(), "--occlusions", (dir / "occ.png").string(),
                                "--out", (dir / "eval.json").string()});
  ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
  nlohmann::json res = read_json(dir / "eval.json")["result"];
  EXPECT_NEAR(res["epe_all"].get<double>(), 0.5, 1e-5);
  EXPECT_NEAR(res["epe_occluded"].get<double>(), 0.5, 1e-5);
  EXPECT_NEAR(res["epe_non_occluded"].get<double>(), 0.5, 1e-5);
  EXPECT_EQ(res["occluded_pixels"], 300);
  EXPECT_EQ(res["bad_1"], 0.0);
}

TEST(PgEval, MalformedInputsExitWithCode3AndNameTheFile) {
  TempDir dir;
  pg::write_flo(dir / "truth.flo", flow_field(0, 0));
  pg::testing::write_text(dir / "bad.flo", "this is not a flow file");
  auto r = run_tool(
      "pg-eval", {"flow", "--estimate", (dir / "bad.flo").string(), "--truth", (dir / "truth.flo").string()});
  EXPECT_EQ(r.exit_code, 3);
  EXPECT_EQ(line_count(r.stderr_text), 1u) << r.stderr_text;
  EXPECT_NE(r.stderr_text.find((dir / "bad.flo").string()), std::string::npos) << r.stderr_text;

  cv::Mat1b small(5, 5, std::uint8_t(0));
  cv::imwrite((dir / "small.png").string(), small);
  r = run_tool("pg-eval", {"flow", "--estimate", (dir / "truth.flo").string(), "--truth",
                           (dir / "truth.flo").string(), "--invalid", (dir / "small.png").string()});
  EXPECT_EQ(r.exit_code, 3);
  EXPECT_NE(r.stderr_text.find((dir / "small.png").string()), std::string::npos) << r.stderr_text;

  pg::write_cameras(dir / "truth.json", ring_of_cameras());
  pg::testing::write_text(dir / "broken.json", R"({"format": "pg-cameras", "version": 1, "cameras": [)");
  r = run_tool("pg-eval", {"cameras", "--estimate", (dir / "broken.json").string(), "--truth",
                           (dir / "truth.json").string()});
  EXPECT_EQ(r.exit_code, 3);
  EXPECT_EQ(line_count(r.stderr_text), 1u) << r.stderr_text;
  EXPECT_NE(r.stderr_text.find((dir / "broken.json").string()), std::string::npos) << r.stderr_text;

  pg::write_depth_exr(dir / "truth.exr", depth_map(1.0f));
  pg::DepthMap other = depth_map(1.0f);
  other.camera.width = other.camera.height = 8;
  other.depth = cv::Mat1f(8, 8, 1.0f);
  pg::write_depth_exr(dir / "other.exr", other);
  r = run_tool("pg-eval", {"depth", "--estimate", (dir / "other.exr").string(), "--truth",
                           (dir / "truth.exr").string()});
  EXPECT_EQ(r.exit_code, 3);
  EXPECT_NE(r.stderr_text.find((dir / "other.exr").string()), std::string::npos) << r.stderr_text;

  r = run_tool("pg-eval", {"mesh", "--estimate", (dir / "missing.ply").string(), "--truth",
                           (dir / "truth.exr").string()});
  EXPECT_EQ(r.exit_code, 3);
  EXPECT_NE(r.stderr_text.find("missing.ply"), std::string::npos) << r.stderr_text;
}

TEST(PgEval, NeedsExactlyOneSubcommand) {
  EXPECT_EQ(run_tool("pg-eval", {}).exit_code, 2);
  EXPECT_EQ(run_tool("pg-eval", {"cameras", "--estimate", "a.json"}).exit_code, 2);
}

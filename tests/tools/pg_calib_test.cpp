// pg-calib end to end: real photographs (OpenCV's sample boards), boards rendered by pg-synth with a
// known lens, flattening, and the error paths (exit code, nothing written).
#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "pg/calib/calibrate.h"
#include "pg/calib/detect.h"
#include "pg/camera/cameras_io.h"
#include "pg/image/image_io.h"
#include "pg/testing/testing.h"

namespace fs = std::filesystem;
using pg::testing::run_tool;
using pg::testing::TempDir;

namespace {

nlohmann::json read_json(const fs::path& p) {
  return nlohmann::json::parse(pg::testing::read_text(p));
}

std::string left_glob(const fs::path& dir) {
  return (dir / "left[0-9]*.jpg").string();
}

TEST(PgCalib, CalibratesLeftSampleBeyondOpenCv) {
  PG_REQUIRE_REAL_DATA(dir, "calib/opencv-chessboard");
  TempDir tmp;
  const auto r = run_tool("pg-calib", {"calibrate", "--images", left_glob(dir), "--board", "9x6", "--square",
                                       "0.025", "--board-warp", "--out", (tmp / "left.json").string()});
  ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
  for (const char* f : {"left.json", "left.calibration.json", "left.calibration.coverage.png",
                        "left.calibration.distortion.png"})
    EXPECT_TRUE(fs::exists(tmp / f)) << f;
  const nlohmann::json report = read_json(tmp / "left.calibration.json");
  EXPECT_EQ(report["format"], "pg-calibration-report");
  const nlohmann::json& c = report["calibrations"][0];
  EXPECT_LE(c["rms_px"].get<double>(), 0.17);
  EXPECT_LT(c["rms_px"].get<double>(), c["opencv_rms_px"].get<double>());
  EXPECT_EQ(c["views"].size(), 13u);
  EXPECT_EQ(c["views"][0]["residuals"].size(), 54u);
  EXPECT_EQ(c["projection_uncertainty"].size(), 5u);
  const pg::CameraSet set = pg::read_cameras(tmp / "left.json");
  ASSERT_EQ(set.cameras.size(), 1u);
  EXPECT_NEAR(set.cameras[0].intrinsics.fx, 533.2, 0.003 * 533.2);
  ASSERT_TRUE(set.cameras[0].stddev);
  EXPECT_GT((*set.cameras[0].stddev)[0], 0.0);
  const cv::Mat coverage = cv::imread((tmp / "left.calibration.coverage.png").string());
  EXPECT_EQ(coverage.cols, 640);
}

TEST(PgCalib, StereoPairBaseline) {
  PG_REQUIRE_REAL_DATA(dir, "calib/opencv-chessboard");
  TempDir tmp;
  const auto r =
      run_tool("pg-calib", {"calibrate", "--images", left_glob(dir), "--stereo-images",
                            (dir / "right[0-9]*.jpg").string(), "--board", "9x6", "--square", "0.025", "--id",
                            "left", "--stereo-id", "right", "--out", (tmp / "rig.json").string()});
  ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
  const pg::CameraSet set = pg::read_cameras(tmp / "rig.json");
  ASSERT_EQ(set.cameras.size(), 2u);
  ASSERT_EQ(set.rigs.size(), 1u);
  EXPECT_NEAR(set.cameras[1].cam_from_world.translation.norm(), 0.0832, 0.001);
  EXPECT_NEAR(read_json(tmp / "rig.calibration.json")["stereo"]["baseline_m"].get<double>(), 0.0832, 0.001);

  // The rig flattens: one of its cameras over --images (the images leave the rig), each camera its
  // own image (the rig stays), or one camera alone (the rig, half flattened, goes).
  const auto flatten = [&](const fs::path& cameras, std::vector<std::string> extra, const std::string& out) {
    std::vector<std::string> args = {"flatten", "--cameras", cameras.string(), "--out", (tmp / out).string()};
    args.insert(args.end(), extra.begin(), extra.end());
    const auto run = run_tool("pg-calib", args);
    EXPECT_EQ(run.exit_code, 0) << run.stderr_text;
    return pg::read_cameras(tmp / out / "cameras.json");
  };
  pg::CameraSet flat =
      flatten(tmp / "rig.json", {"--camera-id", "left", "--images", (dir / "left12.jpg").string()}, "a");
  ASSERT_EQ(flat.cameras.size(), 1u);
  EXPECT_TRUE(flat.rigs.empty());
  EXPECT_FALSE(flat.cameras[0].rig);
  pg::CameraSet with_images = set;
  with_images.cameras[0].image = (dir / "left12.jpg").string();
  with_images.cameras[1].image = (dir / "right12.jpg").string();
  pg::write_cameras(tmp / "rig-images.json", with_images);
  flat = flatten(tmp / "rig-images.json", {}, "b");
  ASSERT_EQ(flat.cameras.size(), 2u);
  ASSERT_EQ(flat.rigs.size(), 1u);
  EXPECT_EQ(flat.cameras[1].rig, set.rigs[0].id);
  flat = flatten(tmp / "rig-images.json", {"--camera-id", "right"}, "c");
  ASSERT_EQ(flat.cameras.size(), 1u);
  EXPECT_TRUE(flat.rigs.empty());
  EXPECT_FALSE(flat.cameras[0].rig);
}

TEST(PgCalib, FlattenKeepsBitDepthAndStraightensLines) {
  PG_REQUIRE_REAL_DATA(dir, "calib/opencv-chessboard");
  TempDir tmp;
  ASSERT_EQ(run_tool("pg-calib", {"calibrate", "--images", left_glob(dir), "--board", "9x6", "--square",
                                  "0.025", "--out", (tmp / "left.json").string()})
                .exit_code,
            0);
  // The same photograph as 8-bit JPEG, 16-bit PNG and float EXR.
  const cv::Mat gray8 = pg::read_image(dir / "left12.jpg");
  cv::Mat gray16, grayf;
  gray8.convertTo(gray16, CV_16U, 257.0);
  gray8.convertTo(grayf, CV_32F, 1.0 / 255.0);
  pg::write_image(tmp / "deep.png", gray16);
  pg::write_image(tmp / "float.exr", grayf);
  const auto r =
      run_tool("pg-calib", {"flatten", "--cameras", (tmp / "left.json").string(), "--images",
                            (dir / "left12.jpg").string(), (tmp / "deep.png").string(),
                            (tmp / "float.exr").string(), "--alpha", "0", "--out", (tmp / "flat").string()});
  ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
  const pg::CameraSet flat = pg::read_cameras(tmp / "flat" / "cameras.json");
  ASSERT_EQ(flat.cameras.size(), 3u);
  // An image of another size than the camera, after a good one: found from the headers before the
  // good one is flattened, so nothing is written.
  cv::Mat small;
  cv::resize(gray8, small, {320, 240});
  pg::write_image(tmp / "small.png", small);
  const auto bad = run_tool("pg-calib", {"flatten", "--cameras", (tmp / "left.json").string(), "--images",
                                         (dir / "left12.jpg").string(), (tmp / "small.png").string(), "--out",
                                         (tmp / "flat2").string()});
  EXPECT_EQ(bad.exit_code, 3);
  EXPECT_NE(bad.stderr_text.find("small.png: image is 320x240 but camera 'small' is 640x480"),
            std::string::npos)
      << bad.stderr_text;
  EXPECT_FALSE(fs::exists(tmp / "flat2" / "left12.jpg"));
  EXPECT_TRUE(flat.cameras[0].distortion.is_zero());
  EXPECT_EQ(flat.cameras[1].image, "deep.png");
  EXPECT_EQ(pg::read_image(tmp / "flat" / "deep.png").depth(), CV_16U);
  EXPECT_EQ(pg::read_image(tmp / "flat" / "float.exr").depth(), CV_32F);
  const pg::calib::BoardSpec board{9, 6, 0.025};
  for (const char* name : {"left12.jpg", "deep.png", "float.exr"}) {
    const pg::calib::Detection d = pg::calib::detect_board(pg::read_image(tmp / "flat" / name), board);
    ASSERT_TRUE(d.found) << name;
    EXPECT_LT(pg::calib::line_fit_rms(d.corners, board), 0.1) << name;
  }
}

TEST(PgCalib, ClearErrorsAndNothingWritten) {
  PG_REQUIRE_REAL_DATA(dir, "calib/opencv-chessboard");
  TempDir tmp;
  fs::create_directories(tmp / "empty");
  const std::string out = (tmp / "out.json").string();
  const auto expect_failure = [&](const std::vector<std::string>& images, const std::string& board, int code,
                                  const std::string& message) {
    std::vector<std::string> args = {"calibrate", "--images"};
    args.insert(args.end(), images.begin(), images.end());
    args.insert(args.end(), {"--board", board, "--square", "0.025", "--out", out});
    const auto r = run_tool("pg-calib", args);
    EXPECT_EQ(r.exit_code, code) << r.stderr_text;
    EXPECT_NE(r.stderr_text.find(message), std::string::npos) << r.stderr_text;
    EXPECT_FALSE(fs::exists(out));
    EXPECT_FALSE(fs::exists(tmp / "out.calibration.json"));
  };
  expect_failure({(tmp / "empty").string()}, "9x6", 3, "no images");
  cv::Mat small;
  cv::resize(pg::read_image(dir / "left01.jpg"), small, {320, 240});
  pg::write_image(tmp / "small.png", small);
  expect_failure({(dir / "left01.jpg").string(), (tmp / "small.png").string()}, "9x6", 3, "one image size");
  // Found from the headers before any board is searched for: the first image, without a board, is
  // not reported as boardless.
  pg::write_image(tmp / "blank.png", cv::Mat1b(pg::read_image(dir / "left01.jpg").size(), std::uint8_t(128)));
  expect_failure({(tmp / "blank.png").string(), (dir / "left01.jpg").string(), (tmp / "small.png").string()},
                 "9x6", 3, "small.png: is 320x240 but");
  {
    std::vector<std::string> args = {"calibrate",
                                     "--images",
                                     (tmp / "blank.png").string(),
                                     (dir / "left01.jpg").string(),
                                     (tmp / "small.png").string(),
                                     "--board",
                                     "9x6",
                                     "--square",
                                     "0.025",
                                     "--out",
                                     out};
    EXPECT_EQ(run_tool("pg-calib", args).stderr_text.find("blank.png: "), std::string::npos);
  }
  expect_failure({(dir / "left01.jpg").string(), (dir / "left02.jpg").string()}, "12x12", 4,
                 "no 12x12 board");
  expect_failure({(dir / "left01.jpg").string(), (dir / "left02.jpg").string()}, "9x6", 4,
                 "needs at least 3");
  expect_failure({(dir / "left01.jpg").string()}, "9by6", 2, "COLSxROWS");
}

// Boards rendered by pg-synth through a known lens: the calibration recovers it. The renders are
// 16-bit linear light (an 8-bit sRGB encoding after the area integral bends every edge's profile and
// biases the distortion field by ~0.14 px); 10 of the scene's views already fill the frame's corners.
void expect_synthetic_lens_recovered(const std::string& lens) {
  if (!fs::exists(pg::testing::bin_dir() / "pg-synth")) GTEST_SKIP() << "pg-synth not built";
  TempDir tmp;
  const auto synth = run_tool("pg-synth", {"checkerboard", "--lens", lens, "--views", "10", "--encoding",
                                           "linear16", "--no-depth", "--out", (tmp / "scene").string()});
  ASSERT_EQ(synth.exit_code, 0) << synth.stderr_text;
  const nlohmann::json scene = read_json(tmp / "scene" / "scene.json");
  const auto corners = scene["extras"]["inner_corners"];
  const std::string board =
      std::to_string(corners[0].get<int>()) + "x" + std::to_string(corners[1].get<int>());
  const auto r = run_tool(
      "pg-calib", {"calibrate", "--images", (tmp / "scene" / "images").string(), "--board", board, "--square",
                   std::to_string(scene["extras"]["square_size"].get<double>()), "--model",
                   lens == "fisheye" ? "fisheye" : "pinhole-k3", "--out", (tmp / "calib.json").string()});
  ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
  const pg::Camera truth = pg::read_cameras(tmp / "scene" / "cameras.json").cameras.at(0);
  const pg::Camera found = pg::read_cameras(tmp / "calib.json").cameras.at(0);
  EXPECT_NEAR(found.intrinsics.fx, truth.intrinsics.fx, 0.002 * truth.intrinsics.fx);
  EXPECT_NEAR(found.intrinsics.fy, truth.intrinsics.fy, 0.002 * truth.intrinsics.fy);
  EXPECT_NEAR(found.intrinsics.cx, truth.intrinsics.cx, 0.5);
  EXPECT_NEAR(found.intrinsics.cy, truth.intrinsics.cy, 0.5);
  // The distortion field over the part of the image the boards covered (within 20 px of a detected
  // corner); beyond it the polynomial is extrapolated and the report's uncertainty says so.
  const nlohmann::json report = read_json(tmp / "calib.calibration.json");
  cv::Mat covered(truth.height, truth.width, CV_8U, cv::Scalar(0));
  const pg::calib::BoardSpec spec{corners[0].get<int>(), corners[1].get<int>(), 0.025};
  for (const auto& entry : fs::directory_iterator(tmp / "scene" / "images")) {
    const cv::Mat image = pg::read_image(entry.path());
    EXPECT_EQ(image.depth(), CV_16U);
    const pg::calib::Detection d = pg::calib::detect_board(image, spec);
    for (const cv::Point2f& p : d.corners) cv::circle(covered, p, 20, cv::Scalar(255), -1);
  }
  // The boards reach into every corner of the frame, where distortion is largest.
  const int w = truth.width, h = truth.height, reach = 70;
  for (const cv::Rect& corner :
       {cv::Rect(0, 0, reach, reach), cv::Rect(w - reach, 0, reach, reach),
        cv::Rect(0, h - reach, reach, reach), cv::Rect(w - reach, h - reach, reach, reach)})
    EXPECT_GT(cv::countNonZero(covered(corner)), 0) << "no corner near the frame corner at " << corner;
  EXPECT_GT(cv::countNonZero(covered), 0.6 * w * h);
  double worst = 0;
  for (int y = 0; y < truth.height; y += 8)
    for (int x = 0; x < truth.width; x += 8)
      if (covered.at<std::uint8_t>(y, x))
        worst = std::max(worst, (pg::calib::distortion_displacement(truth, {x, y}) -
                                 pg::calib::distortion_displacement(found, {x, y}))
                                    .norm());
  EXPECT_LT(worst, 0.1);
  EXPECT_EQ(report["calibrations"][0]["views_used"], scene["views"]);
}

TEST(PgCalib, SyntheticPinholeK3) {
  expect_synthetic_lens_recovered("pinhole");
}
TEST(PgCalib, SyntheticFisheye) {
  expect_synthetic_lens_recovered("fisheye");
}

}  // namespace

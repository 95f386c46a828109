// pg-track on the synthetic orbit from pg-synth (exact ground truth): accuracy after similarity
// alignment, self-calibration of the focal length, the outputs, and the errors for bad input.
#include <gtest/gtest.h>

#include <map>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "pg/camera/cameras_io.h"
#include "pg/core/json_file.h"
#include "pg/eval/camera_eval.h"
#include "pg/eval/orientation_error.h"
#include "pg/mesh/point_cloud.h"
#include "pg/testing/exif_writer.h"
#include "pg/testing/testing.h"
#include "pg/track/tracks.h"

namespace fs = std::filesystem;
using pg::testing::run_tool;
using pg::testing::TempDir;

namespace {

// One orbit scene for every test of the suite, each in its own process (rendering it is the slow
// part). The tests only read it.
class PgTrack : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    const pg::testing::SharedOutput orbit =
        pg::testing::shared_tool_output("pg-track-orbit", "pg-synth", {"set"});
    ASSERT_EQ(orbit.run.exit_code, 0) << orbit.run.stderr_text;
    scene_ = orbit.folder;
  }
  static fs::path scene() { return scene_; }

  static double path_extent(const pg::CameraSet& set) {
    double extent = 0;
    for (const pg::Camera& a : set.cameras)
      for (const pg::Camera& b : set.cameras)
        extent = std::max(extent, (a.cam_from_world.centre() - b.cam_from_world.centre()).norm());
    return extent;
  }

 private:
  static fs::path scene_;
};
fs::path PgTrack::scene_;

// Whether a run got as far as tracking: pg-track logs the tracks it made before recovering cameras.
bool tracked(const pg::testing::ToolResult& run) {
  return run.stderr_text.find(" tracks over ") != std::string::npos;
}

TEST_F(PgTrack, OrbitWithExactIntrinsicsMeetsTheAccuracyTargets) {
  TempDir out;
  const auto r = run_tool("pg-track", {"--images", (scene() / "images").string(), "--cameras",
                                       (scene() / "cameras.json").string(), "--out", out.path().string(),
                                       "--report", (out / "report.json").string()});
  ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
  const pg::CameraSet truth = pg::read_cameras(scene() / "cameras.json");
  const pg::CameraSet estimate = pg::read_cameras(out / "cameras.json");
  ASSERT_EQ(estimate.cameras.size(), truth.cameras.size());
  const pg::CameraEvalResult eval = pg::evaluate_cameras(estimate, truth);
  const double extent = path_extent(truth);
  std::vector<double> orientation = pg::orientation_aligned_rotation_errors_deg(estimate, truth);
  std::sort(orientation.begin(), orientation.end());
  std::cout << "[ measured ] synthetic orbit, exact intrinsics: centre error median "
            << 100 * eval.centre_error.median / extent << "% max " << 100 * eval.centre_error.max / extent
            << "% of the path extent, rotation median " << eval.rotation_error_deg.median << " deg max "
            << eval.rotation_error_deg.max << " deg, orientation-aligned median "
            << orientation[orientation.size() / 2] << " deg max " << orientation.back() << " deg\n";
  EXPECT_LT(eval.centre_error.median, 0.001 * extent);
  EXPECT_LT(eval.centre_error.max, 0.002 * extent);
  // The centre similarity also carries its own error into every rotation; the orientation-aligned
  // error (pg/eval/orientation_error.h) is each camera's own, held to the 0.05 degrees.
  EXPECT_LT(eval.rotation_error_deg.median, 0.05);
  EXPECT_LT(eval.rotation_error_deg.max, 0.1);
  EXPECT_LT(orientation.back(), 0.05);
  for (const pg::Camera& c : estimate.cameras) {
    ASSERT_TRUE(c.quality.has_value());
    EXPECT_GT(*c.quality, 0.5) << c.id;
    // Image paths are relative to the cameras file's folder (formats/cameras.md), so the file still
    // finds its images when read from another working directory.
    EXPECT_FALSE(fs::path(c.image).is_absolute()) << c.image;
    EXPECT_TRUE(fs::exists(out / c.image)) << c.image;
  }

  // The sparse points lie on the true surface: after the same alignment, they sit within the scene.
  const pg::PointCloud points = pg::read_point_cloud_ply(out / "points.ply");
  EXPECT_GT(points.size(), 1000u);
  ASSERT_EQ(points.track_length.size(), points.size());
  for (std::uint32_t length : points.track_length) EXPECT_GE(length, 2u);

  // The tracks file names every frame and links reconstructed tracks to points.
  const nlohmann::json tracks = nlohmann::json::parse(pg::testing::read_text(out / "tracks.json"));
  EXPECT_EQ(tracks["format"], "pg-tracks");
  EXPECT_EQ(tracks["frames"].size(), 16u);
  std::size_t with_point = 0;
  for (const auto& t : tracks["tracks"])
    if (t.contains("point")) ++with_point;
  EXPECT_EQ(with_point, points.size());

  const nlohmann::json report = nlohmann::json::parse(pg::testing::read_text(out / "report.json"));
  EXPECT_EQ(report["metrics"]["registered"], 16);
  EXPECT_GE(report["metrics"]["inconsistent_observations"].get<int>(), 0);
  // Most observations are aligned onto their tracks.
  EXPECT_GT(report["metrics"]["refined_observations"].get<int>(),
            4 * report["metrics"]["unrefined_observations"].get<int>());
  EXPECT_LT(report["metrics"]["reprojection_rms_px"].get<double>(), 0.5);
  EXPECT_TRUE(fs::exists(out / "top_view.png"));
}

// The outlier bound follows the observations' noise (about 0.03 px on these rendered images): with
// it held at --max-error (--error-sigmas 0), a tail of observations 0.2-1.5 px off pulls the
// cameras. Measured: rotation median 0.007 deg against 0.018 deg.
TEST_F(PgTrack, TheOutlierBoundFollowsTheNoiseUnlessHeld) {
  const pg::CameraSet truth = pg::read_cameras(scene() / "cameras.json");
  std::map<std::string, double> rotation;
  for (const std::string sigmas : {"10", "0"}) {
    TempDir out;
    const auto r = run_tool("pg-track", {"--images", (scene() / "images").string(), "--cameras",
                                         (scene() / "cameras.json").string(), "--error-sigmas", sigmas,
                                         "--out", out.path().string()});
    ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
    rotation[sigmas] =
        pg::evaluate_cameras(pg::read_cameras(out / "cameras.json"), truth).rotation_error_deg.median;
  }
  std::cout << "[ measured ] synthetic orbit rotation median: bound following the noise " << rotation["10"]
            << " deg, held at 1.5 px " << rotation["0"] << " deg\n";
  EXPECT_LT(rotation["10"], 0.6 * rotation["0"]);
}

// The two runs' cameras, points and tracks have the same bytes (pg-info digest leaves provenance out).
void expect_same_outputs(const TempDir& a, const TempDir& b) {
  for (const char* name : {"cameras.json", "points.ply", "tracks.json"}) {
    const auto digest = [&](const TempDir& dir) {
      const auto r = run_tool("pg-info", {"digest", (dir / name).string()});
      EXPECT_EQ(r.exit_code, 0) << r.stderr_text;
      return r.stdout_text.substr(0, r.stdout_text.find(' '));
    };
    const std::string da = digest(a), db = digest(b);
    EXPECT_EQ(da.size(), 64u) << name;
    EXPECT_EQ(da, db) << name;
  }
}

// Same inputs and options, one worker thread instead of all: the same bytes (without provenance).
TEST_F(PgTrack, OutputsDoNotDependOnTheThreadCount) {
  TempDir one, all;
  for (const auto& [dir, threads] : {std::pair{&one, "1"}, std::pair{&all, "0"}}) {
    const auto r = run_tool("pg-track", {"--images", (scene() / "images").string(), "--range", "0:8", "--out",
                                         dir->path().string(), "--threads", threads});
    ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
  }
  expect_same_outputs(one, all);
}

// Runs pg-track on the scene's first eight frames on two threads into `dir`, with `extra` options,
// and returns its report's metrics.
nlohmann::json track_metrics(const fs::path& images, const TempDir& dir, std::vector<std::string> extra) {
  std::vector<std::string> args = {
      "--images",          images.string(), "--range", "0:8",      "--out",
      dir.path().string(), "--threads",     "2",       "--report", (dir / "report.json").string()};
  args.insert(args.end(), extra.begin(), extra.end());
  const auto r = run_tool("pg-track", args);
  EXPECT_EQ(r.exit_code, 0) << r.stderr_text;
  return pg::read_json_file(dir / "report.json")["metrics"];
}

// --max-memory with room for one SIFT detection at a time on two threads: a 640x480 frame's scale
// space takes about 73 MiB, beside 12 MiB for the eight frames and their features. The detections run
// one by one instead of two at once; the working images, no longer within half the budget, are
// dropped after detection and decoded again for the position refinement; the outputs are the same.
TEST_F(PgTrack, AMemoryBudgetRunsOneDetectionAtATimeWithTheSameOutputs) {
  TempDir free, budget;
  const nlohmann::json free_metrics = track_metrics(scene() / "images", free, {});
  const nlohmann::json budget_metrics = track_metrics(scene() / "images", budget, {"--max-memory", "140M"});
  EXPECT_EQ(free_metrics.value("sift_detections_at_once", 0), 2);
  EXPECT_TRUE(free_metrics.value("images_held", false));
  EXPECT_EQ(budget_metrics.value("sift_detections_at_once", 0), 1);
  EXPECT_FALSE(budget_metrics.value("images_held", true));
  expect_same_outputs(free, budget);
}

// KLT with the same budget: the features and one detection fit, but with the working images they
// take more than half of it (the detection alone does), so the frames stream through the tracker two
// at a time and are decoded again for the SIFT loop matching and the position refinement; the
// outputs are the same as with them all held.
TEST_F(PgTrack, AMemoryBudgetStreamsKltFramesWithTheSameOutputs) {
  TempDir free, budget;
  const nlohmann::json free_metrics = track_metrics(scene() / "images", free, {"--matcher", "klt"});
  const nlohmann::json budget_metrics =
      track_metrics(scene() / "images", budget, {"--matcher", "klt", "--max-memory", "140M"});
  EXPECT_FALSE(free_metrics.value("klt_frames_streamed", true));
  EXPECT_TRUE(free_metrics.value("images_held", false));
  EXPECT_TRUE(budget_metrics.value("klt_frames_streamed", false));
  EXPECT_FALSE(budget_metrics.value("images_held", true));
  expect_same_outputs(free, budget);
}

// pg-track makes no random choice (descriptor matching is exhaustive, OpenCV's RANSAC seeds itself):
// another --seed gives the same tracks and cameras, and they meet the targets.
TEST_F(PgTrack, TheOutputsDoNotDependOnTheSeed) {
  TempDir first, other;
  for (const auto& [dir, seed] : {std::pair{&first, "1"}, std::pair{&other, "7"}}) {
    const auto r = run_tool("pg-track", {"--images", (scene() / "images").string(), "--cameras",
                                         (scene() / "cameras.json").string(), "--range", "0:8", "--out",
                                         dir->path().string(), "--seed", seed});
    ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
  }
  const pg::TrackSet tracks = pg::read_tracks(first / "tracks.json"),
                     other_tracks = pg::read_tracks(other / "tracks.json");
  ASSERT_EQ(tracks.tracks.size(), other_tracks.tracks.size());
  for (std::size_t t = 0; t < tracks.tracks.size(); ++t) {
    const auto& a = tracks.tracks[t].observations;
    const auto& b = other_tracks.tracks[t].observations;
    ASSERT_EQ(a.size(), b.size()) << "track " << t;
    for (std::size_t o = 0; o < a.size(); ++o)
      EXPECT_TRUE(a[o].frame == b[o].frame && a[o].x == b[o].x && a[o].y == b[o].y) << "track " << t;
  }
  const pg::CameraSet truth = pg::read_cameras(scene() / "cameras.json");
  const pg::CameraSet estimate = pg::read_cameras(first / "cameras.json"),
                      other_estimate = pg::read_cameras(other / "cameras.json");
  ASSERT_EQ(estimate.cameras.size(), 8u);
  ASSERT_EQ(other_estimate.cameras.size(), 8u);
  for (std::size_t c = 0; c < 8; ++c)
    EXPECT_TRUE(estimate.cameras[c].cam_from_world.translation ==
                other_estimate.cameras[c].cam_from_world.translation);
  pg::CameraSet seen;
  for (const pg::Camera& c : estimate.cameras) seen.cameras.push_back(*truth.find(c.id));
  const pg::CameraEvalResult eval = pg::evaluate_cameras(estimate, truth);
  EXPECT_LT(eval.centre_error.median, 0.001 * path_extent(seen));
  EXPECT_LT(eval.rotation_error_deg.median, 0.05);
}

TEST_F(PgTrack, OrbitSelfCalibratesTheFocalLength) {
  TempDir out;
  const auto r =
      run_tool("pg-track", {"--images", (scene() / "images").string(), "--out", out.path().string()});
  ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
  const pg::CameraSet truth = pg::read_cameras(scene() / "cameras.json");
  const pg::CameraSet estimate = pg::read_cameras(out / "cameras.json");
  ASSERT_EQ(estimate.cameras.size(), truth.cameras.size());
  const pg::CameraEvalResult eval = pg::evaluate_cameras(estimate, truth);
  std::cout << "[ measured ] synthetic orbit, self-calibrated: focal error "
            << 100 * eval.focal_relative_error.max << "% (started from " << 1.2 * 640
            << " px), centre error median " << 100 * eval.centre_error.median / path_extent(truth) << "%\n";
  EXPECT_LT(eval.focal_relative_error.max, 0.005);
  EXPECT_LT(eval.centre_error.median, 0.001 * path_extent(truth));
}

// Photos that carry EXIF start from the focal length it gives, not from a guess.
TEST_F(PgTrack, SelfCalibrationStartsFromTheExifFocalLength) {
  const pg::CameraSet truth = pg::read_cameras(scene() / "cameras.json");
  const pg::Camera& first = truth.cameras.front();
  TempDir in, out;
  pg::testing::ExifFields exif;
  exif.focal_mm = first.intrinsics.fx / 100;  // a sensor of 100 px per mm
  exif.plane_px_per_unit = 100;
  exif.plane_unit = 4;
  exif.pixel_width = first.width;
  for (int i = 0; i < 6; ++i) {
    const std::string id = truth.cameras[i].id;
    std::vector<unsigned char> jpeg;
    cv::imencode(".jpg", cv::imread((scene() / "images" / (id + ".png")).string()), jpeg,
                 {cv::IMWRITE_JPEG_QUALITY, 97});
    pg::testing::write_bytes(in / (id + ".jpg"), pg::testing::with_exif(jpeg, exif));
  }
  const auto r = run_tool("pg-track", {"--images", in.path().string(), "--out", out.path().string(),
                                       "--report", (out / "report.json").string()});
  ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
  const nlohmann::json report = nlohmann::json::parse(pg::testing::read_text(out / "report.json"));
  EXPECT_EQ(report["metrics"]["initial_focal_source"].get<std::string>().rfind("EXIF (6 of 6", 0), 0u)
      << report["metrics"]["initial_focal_source"];
  EXPECT_NEAR(report["metrics"]["initial_focal_px"].get<double>(), first.intrinsics.fx,
              1e-3 * first.intrinsics.fx);
  const pg::CameraSet estimate = pg::read_cameras(out / "cameras.json");
  ASSERT_EQ(estimate.cameras.size(), 6u);
  // Six JPEG frames constrain the focal length less than the full orbit (held to 0.5% above).
  EXPECT_NEAR(estimate.cameras[0].intrinsics.fx, first.intrinsics.fx, 0.01 * first.intrinsics.fx);
}

// A checkerboard of known square size seen in the sequence puts the reconstruction in metres.
TEST(PgTrackScale, ACheckerboardInTheImagesGivesMetres) {
  TempDir scene, out;
  ASSERT_EQ(run_tool("pg-synth", {"checkerboard", "--width", "480", "--height", "360", "--views", "8",
                                  "--no-depth", "--supersample", "2", "--out", scene.path().string()})
                .exit_code,
            0);
  const nlohmann::json manifest = nlohmann::json::parse(pg::testing::read_text(scene / "scene.json"));
  const auto& corners = manifest["extras"]["inner_corners"];
  const std::string board =
      std::to_string(corners[0].get<int>()) + "x" + std::to_string(corners[1].get<int>());
  const std::string square = std::to_string(manifest["extras"]["square_size"].get<double>());
  const auto r =
      run_tool("pg-track", {"--images", (scene / "images").string(), "--cameras",
                            (scene / "cameras.json").string(), "--scale-board", board, square, "--out",
                            out.path().string(), "--report", (out / "report.json").string()});
  ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
  const pg::CameraSet truth = pg::read_cameras(scene / "cameras.json");
  const pg::CameraSet estimate = pg::read_cameras(out / "cameras.json");
  ASSERT_EQ(estimate.cameras.size(), truth.cameras.size());
  // Every camera-to-camera distance comes out in metres.
  double worst = 0;
  for (std::size_t a = 0; a < truth.cameras.size(); ++a)
    for (std::size_t b = a + 1; b < truth.cameras.size(); ++b) {
      const double true_distance =
          (truth.cameras[a].cam_from_world.centre() - truth.cameras[b].cam_from_world.centre()).norm();
      const double distance =
          (estimate.cameras[a].cam_from_world.centre() - estimate.cameras[b].cam_from_world.centre()).norm();
      worst = std::max(worst, std::abs(distance / true_distance - 1));
    }
  std::cout << "[ measured ] checkerboard scale: worst relative baseline error " << 100 * worst << "%\n";
  EXPECT_LT(worst, 0.005);
  const nlohmann::json report = nlohmann::json::parse(pg::testing::read_text(out / "report.json"));
  EXPECT_EQ(report["metrics"]["scale_board_views"].size(), 8u);

  // A board that is not in the images is a computation failure naming the board, not a silent no-op.
  const auto missing = run_tool(
      "pg-track", {"--images", (scene / "images").string(), "--cameras", (scene / "cameras.json").string(),
                   "--scale-board", "12x10", square, "--out", (out / "again").string()});
  EXPECT_EQ(missing.exit_code, 4) << missing.stderr_text;
  EXPECT_NE(missing.stderr_text.find("12x10"), std::string::npos) << missing.stderr_text;
}

TEST_F(PgTrack, RangeTracksASubSequence) {
  TempDir out;
  const auto r = run_tool(
      "pg-track", {"--images", (scene() / "images").string(), "--cameras",
                   (scene() / "cameras.json").string(), "--range", "2:5", "--out", out.path().string()});
  ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
  const pg::CameraSet estimate = pg::read_cameras(out / "cameras.json");
  ASSERT_EQ(estimate.cameras.size(), 5u);
  EXPECT_EQ(estimate.cameras.front().id, "view_002");
  EXPECT_EQ(estimate.cameras.back().id, "view_006");
}

TEST_F(PgTrack, FewerThanTwoImagesIsAUsageError) {
  TempDir out;
  const auto r = run_tool(
      "pg-track", {"--images", (scene() / "images" / "view_000.png").string(), "--out", out.path().string()});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.stderr_text.find("at least 2 images"), std::string::npos) << r.stderr_text;
}

TEST_F(PgTrack, ImagesOfDifferentSizesUnderOneCameraNameTheFrames) {
  TempDir in, out;
  for (int i = 0; i < 3; ++i) {
    const std::string name = "view_00" + std::to_string(i) + ".png";
    cv::Mat image = cv::imread((scene() / "images" / name).string());
    if (i == 2) cv::resize(image, image, cv::Size(480, 360));
    cv::imwrite((in / name).string(), image);
  }
  const auto r = run_tool("pg-track", {"--images", in.path().string(), "--out", out.path().string()});
  EXPECT_EQ(r.exit_code, 3) << r.stderr_text;
  EXPECT_NE(r.stderr_text.find("view_002"), std::string::npos) << r.stderr_text;
  EXPECT_NE(r.stderr_text.find("different sizes"), std::string::npos) << r.stderr_text;
  EXPECT_FALSE(tracked(r)) << "the headers tell the sizes before any image is tracked";
}

// Options that cannot be carried out fail before any image is decoded, not after tracking the whole
// sequence (which takes hours on a long one).
TEST_F(PgTrack, BadOptionsFailBeforeTracking) {
  TempDir out;
  fs::copy_file(scene() / "cameras.json", out / "cameras.json");  // an input where an output goes
  struct Case {
    std::vector<std::string> args;
    int exit_code;
    std::string message;
  };
  const std::vector<Case> cases = {
      {{"--scale", "view_000", "view_099", "1.5"}, 2, "no image named view_099"},
      {{"--scale", "view_000", "view_001", "1.5m"}, 2, "\"1.5m\" is not a number"},
      {{"--scale", "view_000", "view_001", "0"}, 2, "must be positive"},
      {{"--scale", "view_001", "view_001", "1"}, 2, "two different cameras"},
      {{"--focal", "-800"}, 2, "--focal: must be greater than 0, got -800"},
      {{"--max-error", "0"}, 2, "--max-error: must be greater than 0"},
      {{"--max-features", "0"}, 2, "--max-features"},
      {{"--masks", (out / "no-such-folder").string()}, 3, "not a folder"},
      {{"--report", (out / "cameras.json").string()}, 6, "named for two outputs"},
      {{"--cameras", (out / "cameras.json").string()}, 6, "refusing to overwrite an input"},
  };
  for (const Case& c : cases) {
    std::vector<std::string> args = {"--images", (scene() / "images").string(), "--out", out.path().string()};
    args.insert(args.end(), c.args.begin(), c.args.end());
    const auto r = run_tool("pg-track", args);
    EXPECT_EQ(r.exit_code, c.exit_code) << c.args[0] << ": " << r.stderr_text;
    EXPECT_NE(r.stderr_text.find(c.message), std::string::npos) << r.stderr_text;
    EXPECT_FALSE(tracked(r)) << c.args[0];
  }
}

// Masks read as in every pg stage (nonzero = ignore, <image stem>.png): with the left quarter of
// each view masked, no observation lies there, and the views still register from the rest.
TEST_F(PgTrack, MaskedPixelsGiveNoObservations) {
  TempDir masks, out;
  int width = 0;
  for (const auto& entry : fs::directory_iterator(scene() / "images")) {
    const cv::Mat image = cv::imread(entry.path().string());
    width = image.cols;
    cv::Mat1b mask(image.size(), uchar(0));
    mask.colRange(0, image.cols / 4).setTo(200);
    cv::imwrite((masks / (entry.path().stem().string() + ".png")).string(), mask);
  }
  const auto r = run_tool("pg-track", {"--images", (scene() / "images").string(), "--cameras",
                                       (scene() / "cameras.json").string(), "--masks", masks.path().string(),
                                       "--out", out.path().string()});
  ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
  const pg::TrackSet tracks = pg::read_tracks(out / "tracks.json");
  std::size_t observations = 0, masked = 0;
  for (const pg::Track& track : tracks.tracks)
    for (const pg::TrackObservation& o : track.observations) {
      ++observations;
      // Position refinement may move a point by up to 2 px from where the detector found it.
      if (o.x < width / 4.0 - 2.5) ++masked;
    }
  EXPECT_GT(observations, 1000u);
  EXPECT_EQ(masked, 0u);
  EXPECT_EQ(pg::read_cameras(out / "cameras.json").cameras.size(),
            pg::read_cameras(scene() / "cameras.json").cameras.size());
}

// A mask or a calibration of another size than its image, and an image without a camera in a
// per-image calibration, are found from the file headers before anything is tracked.
TEST_F(PgTrack, InputsOfTheWrongSizeFailBeforeTracking) {
  TempDir masks, out;
  cv::imwrite((masks / "view_003.png").string(), cv::Mat(240, 320, CV_8UC1, cv::Scalar(255)));
  const auto mask = run_tool("pg-track", {"--images", (scene() / "images").string(), "--masks",
                                          masks.path().string(), "--out", out.path().string()});
  EXPECT_EQ(mask.exit_code, 3) << mask.stderr_text;
  EXPECT_NE(mask.stderr_text.find("view_003.png: mask is 320x240 but image"), std::string::npos)
      << mask.stderr_text;
  EXPECT_FALSE(tracked(mask));

  pg::CameraSet cameras = pg::read_cameras(scene() / "cameras.json");
  ASSERT_GT(cameras.cameras.size(), 4u);
  cameras.cameras[4].width /= 2;
  pg::write_cameras(out / "small.json", cameras);
  cameras.cameras[4].width *= 2;
  cameras.cameras.erase(cameras.cameras.begin() + 2);
  pg::write_cameras(out / "missing.json", cameras);
  const std::vector<std::pair<std::string, std::string>> calibrations = {
      {"small.json", "view_004.png: image is 640x480 but camera 'view_004' is 320x480"},
      {"missing.json", "has no camera with the id of image"}};
  for (const auto& [file, message] : calibrations) {
    const auto r = run_tool("pg-track", {"--images", (scene() / "images").string(), "--cameras",
                                         (out / file).string(), "--out", (out / "track").string()});
    EXPECT_EQ(r.exit_code, 3) << r.stderr_text;
    EXPECT_NE(r.stderr_text.find(message), std::string::npos) << r.stderr_text;
    EXPECT_FALSE(tracked(r)) << file;
  }
}

TEST_F(PgTrack, UnrelatedImagesFailNamingTheProblem) {
  TempDir in, out;
  cv::Mat noise_a(480, 640, CV_8UC1), noise_b(480, 640, CV_8UC1);
  cv::randu(noise_a, 0, 255);
  cv::randu(noise_b, 0, 255);
  cv::imwrite((in / "a.png").string(), noise_a);
  cv::imwrite((in / "b.png").string(), noise_b);
  const auto r = run_tool("pg-track", {"--images", in.path().string(), "--out", out.path().string()});
  EXPECT_EQ(r.exit_code, 4) << r.stderr_text;
  EXPECT_NE(r.stderr_text.find("do not overlap"), std::string::npos) << r.stderr_text;
}

}  // namespace

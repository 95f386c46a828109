// pg-sphdepth run as a tool: the synthetic room's panorama pair (vertical and horizontal baselines,
// 8-bit and HDR), its mesh against the true surface, bad input, and the real 360SD pairs.
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <numbers>

#include "pg/camera/cameras_io.h"
#include "pg/eval/depth_eval.h"
#include "pg/eval/mesh_eval.h"
#include "pg/image/depth_exr.h"
#include "pg/image/image_io.h"
#include "pg/mesh/mesh_io.h"
#include "pg/synth/scenes.h"
#include "pg/synth/write_scene.h"
#include "pg/testing/testing.h"

namespace fs = std::filesystem;
using pg::testing::run_tool;
using pg::testing::TempDir;

namespace {

constexpr int panorama_height = 256;  // 512 x 256: fast on two cores
constexpr double pole_band_deg = 10;  // pg-sphdepth's default

// The room with its two panoramas, the second `offset_world` (metres, world z up) from the first.
pg::synth::Scene room_scene(const Eigen::Vector3d& offset_world) {
  pg::synth::SceneOptions options;
  options.height = panorama_height;
  pg::synth::Scene scene = pg::synth::make_room_scene(options);
  pg::Camera& lower = scene.cameras.cameras[0];
  pg::Camera& other = scene.cameras.cameras[1];
  const Eigen::Vector3d centre = lower.cam_from_world.centre() + offset_world;
  other.cam_from_world = pg::Rigid3::look_at(centre, centre + Eigen::Vector3d::UnitX());
  scene.cameras.rigs[0].offset = lower.cam_from_world.rotation * offset_world;
  return scene;
}

fs::path write_room(const fs::path& folder, const Eigen::Vector3d& offset_world) {
  pg::synth::write_scene(room_scene(offset_world), folder, {});
  return folder / "cameras.json";
}

struct Measured {
  pg::DepthEvalResult eval;
  double coverage_outside_poles = 0;  // valid share of the pixels outside the baseline's pole bands
};

Measured measure(const fs::path& estimate_path, const fs::path& truth_path, const Eigen::Vector3d& baseline) {
  const pg::DepthMap estimate = pg::read_depth_exr(estimate_path);
  const pg::DepthMap truth = pg::read_depth_exr(truth_path);
  EXPECT_EQ(estimate.kind, pg::DepthKind::spherical_range);
  EXPECT_EQ(estimate.camera.model, pg::CameraModel::equirectangular);
  Measured m;
  m.eval = pg::evaluate_depth(estimate, truth);
  const cv::Mat1f depth = estimate.depth, confidence = estimate.confidence;
  std::size_t outside = 0, valid = 0;
  const double band = pole_band_deg * std::numbers::pi / 180;
  for (int y = 0; y < depth.rows; ++y)
    for (int x = 0; x < depth.cols; ++x) {
      const Eigen::Vector3d ray =
          pg::equirect_direction_from_pixel(depth.cols, depth.rows, Eigen::Vector2d(x, y));
      const double theta = std::acos(std::clamp(ray.dot(baseline.normalized()), -1.0, 1.0));
      const bool in_band = theta < band || theta > std::numbers::pi - band;
      if (in_band) {
        EXPECT_TRUE(std::isnan(depth(y, x))) << "pole band pixel " << x << "," << y << " has a range";
        continue;
      }
      ++outside;
      if (std::isfinite(depth(y, x))) {
        ++valid;
        EXPECT_GT(confidence(y, x), 0.0f);
        EXPECT_LE(confidence(y, x), 1.0f);
      }
    }
  m.coverage_outside_poles = static_cast<double>(valid) / outside;
  return m;
}

// Share of the mesh's triangles whose front (counter-clockwise) side faces the panorama's centre.
double share_facing_centre(const pg::Mesh& mesh, const Eigen::Vector3f& centre) {
  std::size_t facing = 0;
  for (const auto& f : mesh.faces) {
    const Eigen::Vector3f& a = mesh.positions[f[0]];
    const Eigen::Vector3f normal = (mesh.positions[f[1]] - a).cross(mesh.positions[f[2]] - a);
    facing += normal.dot(centre - a) > 0;
  }
  return static_cast<double>(facing) / mesh.faces.size();
}

}  // namespace

TEST(PgSphdepth, VerticalPairOfTheRoomGivesAccurateRangesAndATexturedMesh) {
  TempDir dir;
  const fs::path cameras = write_room(dir / "room", {0, 0, 0.27});
  const fs::path out = dir / "geo";
  const auto result = run_tool("pg-sphdepth", {"--cameras", cameras.string(), "--out-dir", out.string(),
                                               "--report", (dir / "report.json").string()});
  ASSERT_EQ(result.exit_code, 0) << result.stderr_text;
  for (const char* name : {"pano_lower.exr", "pano_lower-mesh.ply", "pano_lower-range.png"})
    EXPECT_TRUE(fs::exists(out / name)) << name;

  // Vertical rig: the baseline is the camera's -y (up).
  const Measured m = measure(out / "pano_lower.exr", dir / "room/depth/pano_lower.exr", {0, -1, 0});
  std::cout << "vertical pair: " << m.eval.to_text() << " coverage outside the pole bands "
            << m.coverage_outside_poles << "\n";
  EXPECT_LT(m.eval.relative_error.median, 0.02);
  EXPECT_GE(m.coverage_outside_poles, 0.85);

  // The mesh lies on the true surface, in world coordinates, faces the camera and carries UVs.
  const pg::Mesh mesh = pg::read_mesh(out / "pano_lower-mesh.ply");
  ASSERT_GT(mesh.face_count(), 100000u);
  ASSERT_EQ(mesh.uvs.size(), mesh.vertex_count());
  for (const Eigen::Vector2f& uv : mesh.uvs) {
    EXPECT_GE(uv.x(), 0.0f);
    EXPECT_LE(uv.x(), 1.0f + 1.0f / (2 * panorama_height));
    EXPECT_GE(uv.y(), 0.0f);
    EXPECT_LE(uv.y(), 1.0f);
  }
  const pg::Mesh truth = pg::read_mesh(dir / "room/mesh.ply");
  pg::MeshEvalOptions eval_options;
  eval_options.samples = 50000;
  const pg::MeshEvalResult mesh_eval = pg::evaluate_mesh(mesh, truth, eval_options);
  std::cout << "mesh: " << mesh_eval.to_text() << "\n";
  EXPECT_LT(mesh_eval.accuracy.median, 0.03);  // metres, walls about 3 m away
  const pg::CameraSet set = pg::read_cameras(cameras);
  EXPECT_GT(share_facing_centre(mesh, set.cameras[0].cam_from_world.centre().cast<float>()), 0.99);

  // The run report gives the floor fit: the lower camera is 1.35 m above the floor.
  const nlohmann::json report = nlohmann::json::parse(pg::testing::read_text(dir / "report.json"));
  const nlohmann::json& floor = report.at("metrics").at("planes").at("floor");
  EXPECT_NEAR(floor.at("distance").get<double>(), 1.35, 0.03);
  EXPECT_LT(floor.at("rms").get<double>(), 0.03);
}

// --fill-occlusions: the pixels failing the forward-backward check (beside the room's furniture, as
// seen from the other centre, and mismatches) take their meridian's background range instead of
// being invalid; consistent pixels keep theirs. The room has few such pixels (0.13% at 512 x 256:
// measured 9.6% median error filled, 12.9% for the raw flow there); on the real 360SD pairs 7% are.
TEST(PgSphdepth, FilledOcclusionsTakeTheBackgroundRange) {
  TempDir dir;
  const fs::path cameras = write_room(dir / "room", {0, 0, 0.27});
  for (const std::string mode : {"plain", "raw", "filled"}) {
    std::vector<std::string> args = {"--cameras", cameras.string(),
                                     "--out-dir", (dir / mode).string(),
                                     "--report",  (dir / (mode + ".json")).string()};
    if (mode == "filled") args.push_back("--fill-occlusions");
    if (mode == "raw") args.push_back("--keep-all");
    const auto result = run_tool("pg-sphdepth", args);
    ASSERT_EQ(result.exit_code, 0) << result.stderr_text;
  }
  const pg::DepthMap plain = pg::read_depth_exr(dir / "plain/pano_lower.exr");
  const pg::DepthMap filled = pg::read_depth_exr(dir / "filled/pano_lower.exr");
  const cv::Mat1f raw = pg::read_depth_exr(dir / "raw/pano_lower.exr").depth;
  const pg::DepthMap truth = pg::read_depth_exr(dir / "room/depth/pano_lower.exr");
  const cv::Mat1f a = plain.depth, b = filled.depth, t = truth.depth, confidence = filled.confidence;
  std::vector<double> filled_errors, raw_errors;
  for (int y = 0; y < b.rows; ++y)
    for (int x = 0; x < b.cols; ++x) {
      if (std::isfinite(a(y, x))) {
        EXPECT_EQ(a(y, x), b(y, x)) << "a consistent pixel changed at " << x << "," << y;
      } else if (std::isfinite(b(y, x))) {
        filled_errors.push_back(std::abs(b(y, x) - t(y, x)) / t(y, x));
        raw_errors.push_back(std::isfinite(raw(y, x)) ? std::abs(raw(y, x) - t(y, x)) / t(y, x) : 1e9);
        EXPECT_LE(confidence(y, x), 0.5f);
      }
    }
  ASSERT_FALSE(filled_errors.empty());
  std::sort(filled_errors.begin(), filled_errors.end());
  std::sort(raw_errors.begin(), raw_errors.end());
  const double median = filled_errors[filled_errors.size() / 2];
  std::cout << "raw flow there: median " << raw_errors[raw_errors.size() / 2] << ", p90 "
            << raw_errors[raw_errors.size() * 9 / 10] << "\n";
  const nlohmann::json report = nlohmann::json::parse(pg::testing::read_text(dir / "filled.json"));
  const double filled_fraction = report.at("metrics").at("filled_fraction").get<double>();
  std::cout << filled_errors.size() << " pixels filled (" << 100 * filled_fraction
            << "%), median relative error " << median << ", p90 "
            << filled_errors[filled_errors.size() * 9 / 10] << "\n";
  EXPECT_NEAR(filled_fraction, double(filled_errors.size()) / b.total(), 1e-9);
  EXPECT_LT(median, 0.12);
  EXPECT_LT(median, raw_errors[raw_errors.size() / 2]);
  const Measured m = measure(dir / "filled/pano_lower.exr", dir / "room/depth/pano_lower.exr", {0, -1, 0});
  EXPECT_LT(m.eval.relative_error.median, 0.02);
  EXPECT_GT(m.coverage_outside_poles, 0.999);
}

TEST(PgSphdepth, HorizontalPairOfTheRoomGivesAccurateRanges) {
  TempDir dir;
  const Eigen::Vector3d offset_world(0, 0.27, 0);  // sideways, 27 cm
  const fs::path cameras = write_room(dir / "room", offset_world);
  const fs::path out = dir / "geo";
  const auto result = run_tool("pg-sphdepth", {"--cameras", cameras.string(), "--out-dir", out.string()});
  ASSERT_EQ(result.exit_code, 0) << result.stderr_text;
  const pg::CameraSet set = pg::read_cameras(cameras);
  const Eigen::Vector3d baseline = set.cameras[0].cam_from_world.rotation * offset_world;
  const Measured m = measure(out / "pano_lower.exr", dir / "room/depth/pano_lower.exr", baseline);
  std::cout << "horizontal pair: " << m.eval.to_text() << " coverage outside the pole bands "
            << m.coverage_outside_poles << "\n";
  EXPECT_LT(m.eval.relative_error.median, 0.02);
  EXPECT_GE(m.coverage_outside_poles, 0.85);

  // --alpha weighs the smoothness of the flow along the meridians (it once set a weight that mode
  // does not read, and changed nothing).
  const auto smooth = run_tool("pg-sphdepth", {"--cameras", cameras.string(), "--out-dir",
                                               (dir / "smooth").string(), "--alpha", "30"});
  ASSERT_EQ(smooth.exit_code, 0) << smooth.stderr_text;
  const cv::Mat a = pg::read_depth_exr(out / "pano_lower.exr").depth;
  const cv::Mat b = pg::read_depth_exr(dir / "smooth" / "pano_lower.exr").depth;
  cv::Mat differ = (a != b) & (a == a) & (b == b);  // finite in both, and different
  EXPECT_GT(cv::countNonZero(differ), int(a.total() / 10));
}

TEST(PgSphdepth, HdrPanoramasWithAnOffsetAreMatchedUnclipped) {
  TempDir dir;
  write_room(dir / "room", {0, 0, 0.27});
  // Linear float panoramas with highlights well above 1, as an HDRI: 8 x the sRGB-decoded image.
  for (const char* id : {"pano_lower", "pano_upper"}) {
    cv::Mat image =
        pg::read_image(dir / "room/images" / (std::string(id) + ".png"), pg::ReadMode::color_float);
    cv::pow(image, 2.2, image);
    pg::write_image(dir / (std::string(id) + ".exr"), image * 8);
  }
  const fs::path out = dir / "geo";
  const auto result = run_tool("pg-sphdepth", {"--reference", (dir / "pano_lower.exr").string(), "--other",
                                               (dir / "pano_upper.exr").string(), "--offset", "0,-0.27,0",
                                               "--out-dir", out.string(), "--mesh-format", "obj"});
  ASSERT_EQ(result.exit_code, 0) << result.stderr_text;
  EXPECT_TRUE(fs::exists(out / "pano_lower-mesh.obj"));
  const Measured m = measure(out / "pano_lower.exr", dir / "room/depth/pano_lower.exr", {0, -1, 0});
  std::cout << "HDR pair: " << m.eval.to_text() << "\n";
  EXPECT_LT(m.eval.relative_error.median, 0.02);
  EXPECT_GE(m.coverage_outside_poles, 0.85);
}

TEST(PgSphdepth, BadInputIsRefusedWithClearErrors) {
  TempDir dir;
  pg::write_image(dir / "a.png", cv::Mat3b(64, 128, cv::Vec3b(10, 20, 30)));
  pg::write_image(dir / "b.png", cv::Mat3b(64, 128, cv::Vec3b(10, 20, 30)));
  pg::write_image(dir / "small.png", cv::Mat3b(32, 64, cv::Vec3b(10, 20, 30)));
  pg::write_image(dir / "square.png", cv::Mat3b(64, 64, cv::Vec3b(10, 20, 30)));
  const auto run = [&](const std::string& other, const std::string& offset) {
    return run_tool("pg-sphdepth",
                    {"--reference", (dir / "a.png").string(), "--other", (dir / other).string(), "--offset",
                     offset, "--out-dir", (dir / "out").string()});
  };
  auto result = run("square.png", "0,-0.2,0");
  EXPECT_EQ(result.exit_code, 3);
  EXPECT_NE(result.stderr_text.find("square.png: is 64x64, not a 2:1 equirectangular panorama"),
            std::string::npos)
      << result.stderr_text;
  result = run("small.png", "0,-0.2,0");
  EXPECT_EQ(result.exit_code, 3);
  EXPECT_NE(result.stderr_text.find("small.png: is 64x32 but"), std::string::npos) << result.stderr_text;
  result = run("b.png", "0,0,0");
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.stderr_text.find("--offset is zero"), std::string::npos) << result.stderr_text;
  result = run("b.png", "0,-0.2");
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.stderr_text.find("expected X,Y,Z"), std::string::npos) << result.stderr_text;
}

TEST(PgSphdepth, RealVerticalPairsGivePlanarFloorsAndWallsAtRightAngles) {
  PG_REQUIRE_REAL_DATA(data, "panorama/360sd-realworld");
  TempDir dir;
  // The range maps stay in the build tree for a person to look at, wherever the test runs from.
  const fs::path previews = pg::testing::bin_dir().parent_path() / "artifacts" / "360sd-realworld";
  fs::create_directories(previews);
  for (const std::string scene : {"hall", "room", "stairs"}) {
    const fs::path report_path = dir / (scene + ".json");
    // image_up is about 0.2 m above image_down. The panoramas are 1024 x 512, used whole: at half that,
    // a wall 4 m away is 3 pixels of disparity and the walls' planes are lost in the noise.
    const auto result = run_tool(
        "pg-sphdepth", {"--reference", (data / "image_down" / (scene + ".png")).string(), "--other",
                        (data / "image_up" / (scene + ".png")).string(), "--offset", "0,-0.2,0", "--out-dir",
                        (dir / "out").string(), "--stem", scene, "--report", report_path.string()});
    ASSERT_EQ(result.exit_code, 0) << scene << ": " << result.stderr_text;
    const fs::path preview = dir / "out" / (scene + "-range.png");
    ASSERT_TRUE(fs::exists(preview)) << scene;
    fs::copy_file(preview, previews / preview.filename(), fs::copy_options::overwrite_existing);
    std::cout << scene << ": range map " << (previews / preview.filename()).string() << "\n";
    const pg::Mesh mesh = pg::read_mesh(dir / "out" / (scene + "-mesh.ply"));
    EXPECT_GT(mesh.face_count(), 200000u) << scene;
    EXPECT_EQ(mesh.uvs.size(), mesh.vertex_count()) << scene;

    const nlohmann::json metrics = nlohmann::json::parse(pg::testing::read_text(report_path)).at("metrics");
    const nlohmann::json& planes = metrics.at("planes");
    std::cout << scene << ": valid " << metrics.at("valid_fraction") << ", planes " << planes.dump() << "\n";
    EXPECT_GT(metrics.at("valid_fraction").get<double>(), 0.6) << scene;
    // A tripod-height floor, planar to a couple of centimetres.
    ASSERT_FALSE(planes.at("floor").is_null()) << scene;
    EXPECT_GT(planes.at("floor").at("distance").get<double>(), 1.0) << scene;
    EXPECT_LT(planes.at("floor").at("distance").get<double>(), 1.7) << scene;
    EXPECT_LT(planes.at("floor").at("rms").get<double>(), 0.025) << scene;
    // The stairs scene's large planes are the staircase's, not a room's walls.
    if (scene == "stairs") continue;
    // Each wall is fitted in 3-D, so its angle to the floor is measured: vertical within 7 degrees.
    const auto& floor_angles = planes.at("wall_floor_angles_deg");
    ASSERT_GE(floor_angles.size(), 3u) << scene;
    for (const nlohmann::json& angle : floor_angles) EXPECT_NEAR(angle.get<double>(), 90, 7) << scene;
    // The three largest walls meet at right angles or are parallel, within 5 degrees. (Pairs are listed
    // (0,1), (0,2), ..., so the first two of wall 0's and the first of wall 1's are theirs.) The hall's
    // fourth wall, 3 m away, stands 11-12 degrees off its largest one.
    const auto& wall_angles = planes.at("wall_wall_angles_deg");
    const std::size_t walls = floor_angles.size();
    for (const std::size_t pair : {std::size_t{0}, std::size_t{1}, walls - 1}) {
      const double angle = wall_angles.at(pair).get<double>();
      EXPECT_LT(std::min(angle, 90 - angle), 5) << scene << ": pair " << pair << " at " << angle;
    }
  }
}

TEST(PgSphdepth, PgMergeFusesTheRangeMapWithAPerspectiveDepthMap) {
  TempDir dir;
  const pg::synth::Scene scene = room_scene({0, 0, 0.27});
  pg::synth::write_scene(scene, dir / "room", {});
  const auto sph = run_tool("pg-sphdepth", {"--cameras", (dir / "room/cameras.json").string(), "--out-dir",
                                            (dir / "geo").string()});
  ASSERT_EQ(sph.exit_code, 0) << sph.stderr_text;

  // A perspective depth map of the same room from another corner, exact (rendered).
  pg::Camera camera;
  camera.id = "corner";
  camera.width = 320;
  camera.height = 240;
  camera.intrinsics = {220, 220, 159.5, 119.5};
  camera.cam_from_world = pg::Rigid3::look_at({-2.2, 1.8, 1.6}, {1.0, -0.5, 0.6});
  pg::synth::ViewRenderer renderer(scene, 1);
  pg::DepthMap perspective;
  perspective.camera = camera;
  perspective.kind = pg::DepthKind::perspective_z;
  perspective.depth = renderer.render(camera).depth;
  pg::write_depth_exr(dir / "corner.exr", perspective);

  const fs::path merged = dir / "merged.ply";
  const auto merge =
      run_tool("pg-merge", {"volume", "--depth", (dir / "geo/pano_lower.exr").string(),
                            (dir / "corner.exr").string(), "--voxel-size", "0.04", "--out", merged.string()});
  ASSERT_EQ(merge.exit_code, 0) << merge.stderr_text;
  pg::MeshEvalOptions options;
  options.samples = 50000;
  const pg::MeshEvalResult eval = pg::evaluate_mesh(pg::read_mesh(merged), scene.mesh, options);
  std::cout << "merged: " << eval.to_text() << "\n";
  EXPECT_LT(eval.accuracy.median, 0.04);
  EXPECT_LT(eval.completeness.median, 0.06);
}

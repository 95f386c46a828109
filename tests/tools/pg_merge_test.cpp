// pg-merge end to end: depth EXRs with cameras in their headers merged into a mesh and a .vdb, the
// farm split (integrate + combine) against a single run, pg-synth scenes, and the documented errors.
#include <gtest/gtest.h>

#include "pg/camera/cameras_io.h"
#include "pg/eval/mesh_eval.h"
#include "pg/fusion/fusion_test_scenes.h"
#include "pg/image/depth_exr.h"
#include "pg/image/image_io.h"
#include "pg/mesh/mesh_io.h"
#include "pg/testing/testing.h"

namespace fs = std::filesystem;
using namespace pg;
using pg::testing::run_tool;
using pg::testing::TempDir;

namespace {

Mesh sphere_scene() {
  Mesh scene = fusion::testing::ground(1.5f);
  fusion::testing::append(scene, fusion::testing::sphere({0, 0, 0.5f}, 0.45f));
  return scene;
}

// Writes exact depth EXRs of the scene from an orbit; returns their paths.
std::vector<std::string> write_depth_maps(const Mesh& scene, const fs::path& folder, int views) {
  fs::create_directories(folder);
  const TriangleBvh bvh(scene);
  std::vector<std::string> paths;
  for (const Camera& camera : fusion::testing::orbit(views, 2.5, 1.6, {0, 0, 0.3}, 96, 72, 85)) {
    DepthMap map = fusion::testing::render_depth(bvh, camera);
    map.provenance = Provenance::current();
    paths.push_back((folder / (camera.id + ".exr")).string());
    write_depth_exr(paths.back(), map);
  }
  return paths;
}

std::vector<std::string> args(std::vector<std::string> head, const std::vector<std::string>& tail) {
  head.insert(head.end(), tail.begin(), tail.end());
  return head;
}

TEST(PgMerge, DepthMapsMergeIntoAMeshAndAVdb) {
  TempDir dir;
  const double voxel = 0.03;
  const Mesh scene = sphere_scene();
  const auto depth = write_depth_maps(scene, dir / "depth", 8);
  const auto r = run_tool(
      "pg-merge", args({"volume", "--voxel-size", "0.03", "--out", (dir / "m.ply").string(), "--vdb",
                        (dir / "m.vdb").string(), "--report", (dir / "report.json").string(), "--depth"},
                       depth));
  ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
  ASSERT_TRUE(fs::exists(dir / "m.vdb"));
  const Mesh merged = read_mesh(dir / "m.ply");
  EXPECT_EQ(merged.vertex_properties.at("confidence").size(), merged.vertex_count());
  const MeshEvalResult eval = evaluate_mesh(merged, scene, {.samples = 20000, .thresholds = {voxel}});
  EXPECT_LT(eval.accuracy.p90, voxel);
  const auto report = nlohmann::json::parse(pg::testing::read_text(dir / "report.json"));
  EXPECT_EQ(report["metrics"]["faces"].get<std::size_t>(), merged.face_count());
}

TEST(PgMerge, IntegrateAndCombineEqualASingleRun) {
  TempDir dir;
  const auto depth = write_depth_maps(sphere_scene(), dir / "depth", 6);
  const std::vector<std::string> grid{"--voxel-size", "0.04"};
  auto run = [&](std::vector<std::string> a) {
    a.insert(a.end(), grid.begin(), grid.end());
    a.push_back("--depth");
    a.insert(a.end(), depth.begin(), depth.end());
    const auto r = run_tool("pg-merge", a);
    ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
  };
  run({"volume", "--out", (dir / "single.ply").string()});
  run({"integrate", "--range-start", "0", "--range-size", "4", "--vdb", (dir / "a.vdb").string()});
  run({"integrate", "--range-start", "4", "--vdb", (dir / "b.vdb").string()});
  const auto r = run_tool("pg-merge", {"combine", "--partials", (dir / "a.vdb").string(),
                                       (dir / "b.vdb").string(), "--out", (dir / "combined.ply").string()});
  ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
  const Mesh single = read_mesh(dir / "single.ply"), combined = read_mesh(dir / "combined.ply");
  ASSERT_EQ(single.vertex_count(), combined.vertex_count());
  ASSERT_EQ(single.face_count(), combined.face_count());
  float worst = 0;
  for (std::size_t i = 0; i < single.vertex_count(); ++i)
    worst = std::max(worst, (single.positions[i] - combined.positions[i]).norm());
  EXPECT_LT(worst, 1e-5f);  // float precision of the weighted means, in scene units (voxel 0.04)
}

TEST(PgMerge, BadInputsAreClearErrors) {
  TempDir dir;
  const auto depth = write_depth_maps(sphere_scene(), dir / "depth", 1);
  // Depth with no valid sample.
  DepthMap nan_map = read_depth_exr(depth[0]);
  nan_map.depth.setTo(NAN);
  write_depth_exr(dir / "nan.exr", nan_map);
  auto r = run_tool("pg-merge", {"volume", "--voxel-size", "0.03", "--out", (dir / "o.ply").string(),
                                 "--depth", (dir / "nan.exr").string()});
  EXPECT_EQ(r.exit_code, 3);
  EXPECT_NE(r.stderr_text.find("nan.exr: the depth map holds no valid depth"), std::string::npos)
      << r.stderr_text;
  // A depth EXR without a camera (a plain EXR from another tool).
  write_image(dir / "plain.exr", cv::Mat1f(72, 96, 2.0f));
  r = run_tool("pg-merge", {"volume", "--voxel-size", "0.03", "--out", (dir / "o.ply").string(), "--depth",
                            (dir / "plain.exr").string()});
  EXPECT_EQ(r.exit_code, 3);
  EXPECT_NE(r.stderr_text.find("plain.exr"), std::string::npos) << r.stderr_text;
  // After a good map, found from its header before the good one is integrated.
  r = run_tool("pg-merge", {"volume", "--voxel-size", "0.03", "--out", (dir / "o.ply").string(), "--depth",
                            depth[0], (dir / "plain.exr").string()});
  EXPECT_EQ(r.exit_code, 3);
  EXPECT_NE(r.stderr_text.find("plain.exr"), std::string::npos) << r.stderr_text;
  EXPECT_EQ(r.stderr_text.find("integrated 1/2"), std::string::npos) << r.stderr_text;
  // A mask of the wrong size, the second map's: found before the first map is integrated.
  const auto two = write_depth_maps(sphere_scene(), dir / "two", 2);
  fs::create_directories(dir / "masks");
  write_image(dir / "masks" / "view_1.png", cv::Mat1b(10, 10, std::uint8_t(0)));
  r = run_tool("pg-merge", {"volume", "--voxel-size", "0.03", "--out", (dir / "o.ply").string(), "--masks",
                            (dir / "masks").string(), "--depth", two[0], two[1]});
  EXPECT_EQ(r.exit_code, 3);
  EXPECT_NE(r.stderr_text.find("view_1.png: mask is 10x10 but the depth map"), std::string::npos)
      << r.stderr_text;
  EXPECT_EQ(r.stderr_text.find("integrated 1/2"), std::string::npos) << r.stderr_text;
  // A depth map outside this job's --range is not read: the chunk of the good map alone merges.
  r = run_tool("pg-merge", {"volume", "--voxel-size", "0.03", "--out", (dir / "chunk.ply").string(),
                            "--range-size", "1", "--depth", depth[0], (dir / "plain.exr").string()});
  EXPECT_EQ(r.exit_code, 0) << r.stderr_text;
  // A voxel size that needs more memory than allowed: exit 5 before allocating.
  r = run_tool("pg-merge", {"volume", "--voxel-size", "0.001", "--max-memory", "16M", "--out",
                            (dir / "o.ply").string(), "--depth", depth[0]});
  EXPECT_EQ(r.exit_code, 5);
  EXPECT_NE(r.stderr_text.find("--max-memory"), std::string::npos) << r.stderr_text;
  EXPECT_FALSE(fs::exists(dir / "o.ply"));
  // A band of more than 256 voxels is refused (1e300 marked voxels along each ray without end).
  r = run_tool("pg-merge", {"volume", "--voxel-size", "0.03", "--truncation", "1e300", "--out",
                            (dir / "o.ply").string(), "--depth", depth[0]});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.stderr_text.find("must be from one to 256 voxels"), std::string::npos) << r.stderr_text;
}

// Writes the scene's depth from an orbit as RGB-D frames: 16-bit PNG depth in millimetres
// (<folder>/<id>.png, 0 where nothing is seen) and their cameras (<folder>/cameras.json).
void write_rgbd_frames(const Mesh& scene, const fs::path& folder, int views) {
  fs::create_directories(folder);
  const TriangleBvh bvh(scene);
  CameraSet cameras;
  for (const Camera& camera : fusion::testing::orbit(views, 2.5, 1.6, {0, 0, 0.3}, 96, 72, 85)) {
    const DepthMap map = fusion::testing::render_depth(bvh, camera);
    cv::Mat1w millimetres(map.depth.size(), std::uint16_t(0));
    for (int y = 0; y < map.depth.rows; ++y)
      for (int x = 0; x < map.depth.cols; ++x)
        if (const float z = map.depth.at<float>(y, x); std::isfinite(z))
          millimetres(y, x) = static_cast<std::uint16_t>(std::lround(z * 1000));
    write_image(folder / (camera.id + ".png"), millimetres);
    cameras.cameras.push_back(camera);
  }
  write_cameras(folder / "cameras.json", cameras);
}

// RGB-D frames (a cameras.json and 16-bit depth images) merge like depth maps, to within a voxel of
// the scene. Their files are checked before the first is integrated: a depth image or mask of the
// wrong size for the second frame fails with exit 3 and a message naming it, and nothing is written.
TEST(PgMerge, RgbdFramesMergeAndAreCheckedFirst) {
  TempDir dir;
  const double voxel = 0.03;
  const Mesh scene = sphere_scene();
  write_rgbd_frames(scene, dir / "rgbd", 8);
  const std::vector<std::string> common{"volume",
                                        "--voxel-size",
                                        "0.03",
                                        "--rgbd-cameras",
                                        (dir / "rgbd" / "cameras.json").string(),
                                        "--rgbd-depth",
                                        (dir / "rgbd" / "{id}.png").string()};
  auto r = run_tool("pg-merge", args(common, {"--out", (dir / "m.ply").string()}));
  ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
  const MeshEvalResult eval =
      evaluate_mesh(read_mesh(dir / "m.ply"), scene, {.samples = 20000, .thresholds = {voxel}});
  EXPECT_LT(eval.accuracy.p90, voxel);

  const std::string second = read_cameras(dir / "rgbd" / "cameras.json").cameras[1].id;
  fs::create_directories(dir / "masks");
  write_image(dir / "masks" / (second + ".png"), cv::Mat1b(10, 10, std::uint8_t(0)));
  r = run_tool("pg-merge",
               args(common, {"--out", (dir / "bad.ply").string(), "--masks", (dir / "masks").string()}));
  EXPECT_EQ(r.exit_code, 3);
  EXPECT_NE(r.stderr_text.find(second + ".png: mask is 10x10 but the depth map"), std::string::npos)
      << r.stderr_text;
  EXPECT_EQ(r.stderr_text.find("integrated 1/"), std::string::npos) << r.stderr_text;

  write_image(dir / "rgbd" / (second + ".png"), cv::Mat1w(36, 48, std::uint16_t(1000)));
  r = run_tool("pg-merge", args(common, {"--out", (dir / "bad.ply").string()}));
  EXPECT_EQ(r.exit_code, 3);
  EXPECT_NE(r.stderr_text.find(second + ".png: depth image is 48x36 but camera '" + second + "' is 96x72"),
            std::string::npos)
      << r.stderr_text;
  EXPECT_EQ(r.stderr_text.find("integrated 1/"), std::string::npos) << r.stderr_text;
  EXPECT_FALSE(fs::exists(dir / "bad.ply"));

  // A farm job checks only its own inputs: the first frame alone still merges.
  r = run_tool("pg-merge", args(common, {"--out", (dir / "first.ply").string(), "--range-size", "1"}));
  EXPECT_EQ(r.exit_code, 0) << r.stderr_text;
}

TEST(PgMerge, PgSynthSetMergesBelowOneVoxel) {
  if (!fs::exists(pg::testing::bin_dir() / "pg-synth")) GTEST_SKIP() << "pg-synth is not built";
  TempDir dir;
  const double voxel = 0.05;
  auto r = run_tool("pg-synth", {"set", "--out", (dir / "set").string(), "--views", "8", "--width", "160",
                                 "--height", "120", "--supersample", "1"});
  ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
  std::vector<std::string> depth;
  for (const auto& entry : fs::directory_iterator(dir / "set" / "depth"))
    depth.push_back(entry.path().string());
  std::sort(depth.begin(), depth.end());
  r = run_tool("pg-merge",
               args({"volume", "--voxel-size", "0.05", "--images", (dir / "set" / "images").string(), "--out",
                     (dir / "merged.ply").string(), "--depth"},
                    depth));
  ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
  const Mesh merged = read_mesh(dir / "merged.ply");
  EXPECT_EQ(merged.colors.size(), merged.vertex_count());
  // Completeness over the part of the set some view sees.
  const Mesh truth = read_mesh(dir / "set" / "mesh.ply");
  std::vector<DepthMap> maps;
  for (const auto& d : depth) maps.push_back(read_depth_exr(d));
  Mesh seen;
  seen.positions = truth.positions;
  for (const auto& f : truth.faces) {
    const Eigen::Vector3d c =
        ((truth.positions[f[0]] + truth.positions[f[1]] + truth.positions[f[2]]) / 3.0f).cast<double>();
    for (const DepthMap& m : maps) {
      const Eigen::Vector3d p = m.camera.cam_from_world * c;
      Eigen::Vector2d px;
      if (!m.camera.project(p, px) || !m.camera.in_image(px)) continue;
      const float d = m.depth.at<float>(int(std::lround(px.y())), int(std::lround(px.x())));
      if (std::isfinite(d) && std::abs(d - p.z()) < voxel / 2) {
        seen.faces.push_back(f);
        break;
      }
    }
  }
  const MeshEvalResult eval =
      evaluate_mesh(merged, seen, {.samples = 30000, .include_vertices = false, .thresholds = {2 * voxel}});
  std::cout << "pg-synth set, 8 views 160x120, voxel " << voxel << ": accuracy p90 " << eval.accuracy.p90
            << ", completeness within 2v " << eval.recall[0] << "\n";
  EXPECT_LT(eval.accuracy.p90, voxel);
  EXPECT_GT(eval.recall[0], 0.95);
}

}  // namespace

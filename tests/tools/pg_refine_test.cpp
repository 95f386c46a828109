// pg-refine run as a tool on the deform scene written by pg-synth: the refinement, its caches, the
// brush (paint, erase, strokes, rebase), the run report and the errors for bad input.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <nlohmann/json.hpp>

#include "pg/camera/cameras_io.h"
#include "pg/core/hash.h"
#include "pg/eval/mesh_eval.h"
#include "pg/image/image_io.h"
#include "pg/mesh/mesh_io.h"
#include "pg/mesh/vertex_mask.h"
#include "pg/testing/testing.h"

namespace fs = std::filesystem;
using pg::testing::run_tool;
using pg::testing::TempDir;

namespace {

// The deform scene at 320x240, written once for all tests of this file.
const fs::path& scene_folder() {
  static TempDir dir;
  static const fs::path folder = [] {
    const fs::path out = dir / "deform";
    const auto r = run_tool("pg-synth", {"deform", "--out", out.string(), "--width", "320", "--height", "240",
                                         "--supersample", "2", "--no-depth", "--progress", "off"});
    EXPECT_EQ(r.exit_code, 0) << r.stderr_text;
    return out;
  }();
  return folder;
}

bool same_positions(const pg::Mesh& a, const pg::Mesh& b) {
  return a.positions.size() == b.positions.size() &&
         std::memcmp(a.positions.data(), b.positions.data(), a.positions.size() * sizeof(Eigen::Vector3f)) ==
             0;
}

double accuracy(const fs::path& mesh, const fs::path& truth) {
  pg::MeshEvalOptions options;
  options.samples = 20000;
  return pg::evaluate_mesh(pg::read_mesh(mesh), pg::read_mesh(truth), options).accuracy.mean;
}

void write_mask(const fs::path& path, const pg::Mesh& mesh, const std::string& name,
                std::vector<float> weights) {
  pg::VertexMask mask;
  mask.name = name;
  mask.topology = pg::topology_id(mesh);
  mask.weights = std::move(weights);
  pg::write_vertex_mask(path, mask);
}

const std::vector<std::string> views_args = {"--views", "view_000,view_001,view_002,view_011", "--pairs",
                                             "view_000:view_001,view_001:view_002,view_011:view_000"};

std::vector<std::string> run_args(const fs::path& out, std::vector<std::string> extra = {}) {
  const fs::path s = scene_folder();
  std::vector<std::string> args = {"--mesh",       (s / "initial.ply").string(),
                                   "--cameras",    (s / "cameras.json").string(),
                                   "--out",        out.string(),
                                   "--scale",      "1",
                                   "--iterations", "3",
                                   "--progress",   "off"};
  args.insert(args.end(), views_args.begin(), views_args.end());
  args.insert(args.end(), extra.begin(), extra.end());
  return args;
}

TEST(PgRefine, RefinesWritesCachesReportAndErrorImages) {
  TempDir dir;
  const fs::path s = scene_folder();
  const auto r = run_tool(
      "pg-refine",
      run_args(dir / "refined.ply",
               {"--pre-cache", (dir / "pre.ply").string(), "--post-cache", (dir / "post.ply").string(),
                "--error-images", (dir / "err").string(), "--report", (dir / "report.json").string()}));
  ASSERT_EQ(r.exit_code, 0) << r.stderr_text;

  const pg::Mesh initial = pg::read_mesh(s / "initial.ply");
  const pg::Mesh refined = pg::read_mesh(dir / "refined.ply");
  EXPECT_EQ(refined.faces, initial.faces);
  ASSERT_EQ(refined.vertex_properties.count("displacement"), 1u);
  EXPECT_TRUE(same_positions(pg::read_mesh(dir / "pre.ply"), initial));
  EXPECT_TRUE(same_positions(pg::read_mesh(dir / "post.ply"), refined));
  // Only part of the rock is seen by these four views: the whole mesh still gets closer to the truth.
  EXPECT_LT(accuracy(dir / "refined.ply", s / "mesh.ply"),
            0.55 * accuracy(s / "initial.ply", s / "mesh.ply"));
  EXPECT_TRUE(fs::exists(dir / "err" / "error_before.png"));
  EXPECT_TRUE(fs::exists(dir / "err" / "error_after.png"));

  const auto report = nlohmann::json::parse(pg::testing::read_text(dir / "report.json"));
  const auto& metrics = report.at("metrics");
  ASSERT_EQ(metrics.at("iterations").size(), 3u);
  EXPECT_EQ(metrics.at("pairs").size(), 3u);
  EXPECT_EQ(metrics.at("flow_mode"), "epipolar");
  const auto& first = metrics.at("iterations")[0];
  EXPECT_EQ(first.at("error_before").size(), 6u);  // both directions of 3 pairs
  EXPECT_GT(first.at("mean_displacement").get<double>(), 0.0);
  EXPECT_LT(metrics.at("ncc_error_after").get<double>(), metrics.at("ncc_error_before").get<double>() - 0.3);
  for (std::size_t k = 0; k < 6; ++k)
    EXPECT_LT(metrics.at("iterations")[2].at("error_after")[k].at("ncc_error").get<double>(),
              first.at("error_before")[k].at("ncc_error").get<double>());
}

// A scene-linear EXR plate may carry NaN or infinite pixels (a comp's division by zero). They are read
// as black, so they cannot spread through the flow's smoothing or the metrics: before, one NaN pixel
// made every photometric metric of the report null.
TEST(PgRefine, AnExrViewWithNonFinitePixelsRefinesAsWell) {
  TempDir dir;
  const fs::path s = scene_folder();
  pg::CameraSet cameras = pg::read_cameras(s / "cameras.json");
  for (pg::Camera& camera : cameras.cameras) camera.image = (s / camera.image).string();
  pg::Camera& plate = *std::find_if(cameras.cameras.begin(), cameras.cameras.end(),
                                    [](const pg::Camera& c) { return c.id == "view_001"; });
  cv::Mat values = pg::read_image(plate.image, pg::ReadMode::color_float);
  values.at<cv::Vec3f>(120, 160) = cv::Vec3f(NAN, NAN, NAN);
  values.at<cv::Vec3f>(40, 200) = cv::Vec3f(INFINITY, 0.5f, -INFINITY);
  plate.image = (dir / "view_001.exr").string();
  pg::write_image(plate.image, values);
  pg::write_cameras(dir / "cameras.json", cameras);
  std::vector<std::string> args = run_args(dir / "refined.ply", {"--report", (dir / "report.json").string()});
  args[3] = (dir / "cameras.json").string();
  const auto r = run_tool("pg-refine", args);
  ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
  const auto metrics = nlohmann::json::parse(pg::testing::read_text(dir / "report.json")).at("metrics");
  ASSERT_TRUE(metrics.at("ncc_error_after").is_number()) << metrics.dump();
  EXPECT_LT(metrics.at("ncc_error_after").get<double>(), metrics.at("ncc_error_before").get<double>() - 0.3);
  EXPECT_LT(accuracy(dir / "refined.ply", s / "mesh.ply"),
            0.55 * accuracy(s / "initial.ply", s / "mesh.ply"));
}

// A mesh that came with normals leaves with the normals of its new shape where it moved, and with
// its own (say, authored) normals where nothing around a vertex moved.
TEST(PgRefine, RefinedMeshesCarryTheNormalsOfTheirNewShape) {
  TempDir dir;
  const fs::path s = scene_folder();
  pg::Mesh initial = pg::read_mesh(s / "initial.ply");
  initial.compute_vertex_normals();
  initial.normals[0] = initial.normals[0].cross(Eigen::Vector3f::UnitX()).normalized();  // "authored"
  pg::write_mesh(dir / "with-normals.ply", initial);
  std::vector<std::string> args = run_args(dir / "refined.ply");
  args[1] = (dir / "with-normals.ply").string();
  const auto r = run_tool("pg-refine", args);
  ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
  const pg::Mesh refined = pg::read_mesh(dir / "refined.ply");
  pg::Mesh fresh = refined;
  fresh.compute_vertex_normals();
  std::vector<std::uint8_t> around_moved(refined.vertex_count(), 0);
  for (const auto& f : refined.faces)
    for (std::uint32_t v : f)
      if (refined.positions[v] != initial.positions[v])
        around_moved[f[0]] = around_moved[f[1]] = around_moved[f[2]] = 1;
  std::size_t moved = 0, kept = 0;
  for (std::size_t v = 0; v < refined.vertex_count(); ++v) {
    if (around_moved[v]) {
      ++moved;
      EXPECT_GT(refined.normals[v].dot(fresh.normals[v]), 0.99999f) << v;
    } else {
      ++kept;
      EXPECT_EQ(refined.normals[v], initial.normals[v]) << v;
    }
  }
  EXPECT_GT(moved, 100u);
  EXPECT_GT(kept, 100u);
}

TEST(PgRefine, BrushPaintsErasesAndRebases) {
  TempDir dir;
  const fs::path s = scene_folder();
  ASSERT_EQ(
      run_tool("pg-refine", run_args(dir / "refined.ply", {"--pre-cache", (dir / "pre.ply").string(),
                                                           "--post-cache", (dir / "post.ply").string()}))
          .exit_code,
      0);
  const pg::Mesh pre = pg::read_mesh(dir / "pre.ply"), post = pg::read_mesh(dir / "post.ply");
  const std::size_t n = pre.vertex_count();
  write_mask(dir / "ones.json", pre, "brush_weight", std::vector<float>(n, 1.0f));
  write_mask(dir / "zeros.json", pre, "brush_weight", std::vector<float>(n, 0.0f));
  const std::vector<std::string> caches = {"--pre", (dir / "pre.ply").string(), "--post",
                                           (dir / "post.ply").string()};
  auto paint = [&](const fs::path& mesh, const fs::path& out, std::vector<std::string> extra) {
    std::vector<std::string> args = {"paint", "--mesh", mesh.string(), "--out", out.string()};
    args.insert(args.end(), caches.begin(), caches.end());
    args.insert(args.end(), extra.begin(), extra.end());
    const auto r = run_tool("pg-refine", args);
    EXPECT_EQ(r.exit_code, 0) << r.stderr_text;
    return pg::read_mesh(out);
  };
  // Weight 1 everywhere = the iteration; weight 0 = nothing; erase with 1 = back to the pre state.
  EXPECT_TRUE(same_positions(
      paint(dir / "pre.ply", dir / "painted.ply", {"--weights", (dir / "ones.json").string()}), post));
  EXPECT_TRUE(same_positions(
      paint(dir / "pre.ply", dir / "none.ply", {"--weights", (dir / "zeros.json").string()}), pre));
  EXPECT_TRUE(same_positions(paint(dir / "painted.ply", dir / "erased.ply",
                                   {"--mode", "erase", "--weights", (dir / "ones.json").string()}),
                             pre));

  // A world-space stroke touches only vertices within its radius, and no further than the post cache.
  const Eigen::Vector3f centre = post.positions[n / 3];
  pg::testing::write_text(dir / "strokes.json",
                          nlohmann::json{{"format", "pg-brush-strokes"},
                                         {"version", 1},
                                         {"strokes",
                                          {{{"space", "world"},
                                            {"points", {{centre.x(), centre.y(), centre.z()}}},
                                            {"radius", 0.15},
                                            {"strength", 0.6},
                                            {"falloff", "smooth"}}}}}
                              .dump());
  const pg::Mesh stroked =
      paint(dir / "pre.ply", dir / "stroked.ply", {"--strokes", (dir / "strokes.json").string()});
  std::size_t touched = 0;
  for (std::size_t v = 0; v < n; ++v) {
    const float to_post = (post.positions[v] - pre.positions[v]).norm();
    const float moved = (stroked.positions[v] - pre.positions[v]).norm();
    if ((pre.positions[v] - centre).norm() > 0.2f) {
      EXPECT_EQ(moved, 0.0f) << v;
    } else {
      EXPECT_LE(moved, 0.6f * to_post + 1e-6f) << v;
      touched += moved > 0;
    }
  }
  EXPECT_GT(touched, 50u);

  // Rebase: the stroked mesh becomes the new pre cache; erasing towards it is then a no-op. The
  // common flags may come before the subcommand; the post cache read may not be overwritten.
  const std::string post_before = pg::sha256_file(dir / "post.ply");
  const auto overwrite =
      run_tool("pg-refine", {"rebase", "--mesh", (dir / "stroked.ply").string(), "--out",
                             (dir / "post.ply").string(), "--post", (dir / "post.ply").string()});
  EXPECT_EQ(overwrite.exit_code, 6) << overwrite.stderr_text;
  EXPECT_EQ(pg::sha256_file(dir / "post.ply"), post_before);
  const auto rebased =
      run_tool("pg-refine", {"--progress", "off", "rebase", "--mesh", (dir / "stroked.ply").string(), "--out",
                             (dir / "pre2.ply").string(), "--post", (dir / "post.ply").string()});
  ASSERT_EQ(rebased.exit_code, 0) << rebased.stderr_text;
  const auto r =
      run_tool("pg-refine", {"paint", "--mode", "erase", "--mesh", (dir / "stroked.ply").string(), "--pre",
                             (dir / "pre2.ply").string(), "--post", (dir / "post.ply").string(), "--weights",
                             (dir / "ones.json").string(), "--out", (dir / "same.ply").string()});
  ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
  EXPECT_TRUE(same_positions(pg::read_mesh(dir / "same.ply"), stroked));
}

TEST(PgRefine, RejectsBadInputWithClearErrors) {
  TempDir dir;
  const fs::path s = scene_folder();
  const pg::Mesh initial = pg::read_mesh(s / "initial.ply");

  // A view the cameras file does not have.
  auto r = run_tool("pg-refine",
                    {"--mesh", (s / "initial.ply").string(), "--cameras", (s / "cameras.json").string(),
                     "--out", (dir / "o.ply").string(), "--views", "view_000,view_099"});
  EXPECT_EQ(r.exit_code, 3);
  EXPECT_NE(r.stderr_text.find("no camera 'view_099'"), std::string::npos) << r.stderr_text;

  // A camera with no image (cameras.md allows "image": ""): left out of the default views, and named
  // by --pairs it is an error that says so.
  pg::CameraSet imageless = pg::read_cameras(s / "cameras.json");
  imageless.cameras[1].image.clear();
  for (auto& c : imageless.cameras)
    if (!c.image.empty()) c.image = (s / c.image).string();
  pg::write_cameras(dir / "imageless.json", imageless);
  r = run_tool("pg-refine",
               {"--mesh", (s / "initial.ply").string(), "--cameras", (dir / "imageless.json").string(),
                "--out", (dir / "o.ply").string(), "--pairs", "view_000:view_001"});
  EXPECT_EQ(r.exit_code, 3);
  EXPECT_NE(r.stderr_text.find("camera 'view_001' names no image"), std::string::npos) << r.stderr_text;

  // An option's value that reads like a subcommand name is still a value.
  r = run_tool("pg-refine",
               {"--mesh", (s / "initial.ply").string(), "--cameras", (s / "cameras.json").string(), "--out",
                (dir / "o.ply").string(), "--pinned", "run"});
  EXPECT_EQ(r.exit_code, 3) << r.stderr_text;
  EXPECT_NE(r.stderr_text.find("run: no such file"), std::string::npos) << r.stderr_text;

  // The mesh far away from every camera.
  pg::Mesh far = initial;
  for (auto& p : far.positions) p.z() -= 100.0f;
  pg::write_mesh(dir / "far.ply", far);
  r = run_tool("pg-refine", {"--mesh", (dir / "far.ply").string(), "--cameras", (s / "cameras.json").string(),
                             "--out", (dir / "o.ply").string(), "--pairs", "view_000:view_001"});
  EXPECT_EQ(r.exit_code, 3);
  EXPECT_NE(r.stderr_text.find("does not see the mesh"), std::string::npos) << r.stderr_text;

  // A mask made for another mesh.
  pg::Mesh other = initial;
  other.faces.pop_back();
  write_mask(dir / "other.json", other, "pinned", std::vector<float>(other.vertex_count(), 1.0f));
  r = run_tool("pg-refine", run_args(dir / "o.ply", {"--pinned", (dir / "other.json").string()}));
  EXPECT_EQ(r.exit_code, 3);
  EXPECT_NE(r.stderr_text.find("other.json"), std::string::npos) << r.stderr_text;

  // Writing over the input mesh is refused.
  r = run_tool("pg-refine", run_args(s / "initial.ply"));
  EXPECT_EQ(r.exit_code, 6) << r.stderr_text;

  // paint needs exactly one of --weights / --strokes.
  r = run_tool("pg-refine",
               {"paint", "--mesh", (s / "initial.ply").string(), "--pre", (s / "initial.ply").string(),
                "--post", (s / "mesh.ply").string(), "--out", (dir / "p.ply").string()});
  EXPECT_EQ(r.exit_code, 2) << r.stderr_text;
}

}  // namespace

// pg-remesh run as a tool: a deformed plane remeshed in its deformed region with pinned vertices and
// a carried mask; the report, histogram and new masks; exit codes for bad input.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "pg/mesh/mesh_io.h"
#include "pg/mesh/vertex_mask.h"
#include "pg/remesh/test_shapes.h"
#include "pg/testing/testing.h"

namespace fs = std::filesystem;
using pg::testing::run_tool;
using pg::testing::TempDir;

namespace {

struct Scene {
  TempDir dir;
  pg::Mesh before = pg::test::flat_plane(40);
  pg::Mesh after = pg::test::bumped_plane(40, 0.25f, 0.1f);
  std::vector<std::size_t> pinned;

  Scene() {
    pg::write_mesh(dir / "before.ply", before);
    pg::write_mesh(dir / "after.ply", after);
    // Pinned: every fifth vertex on the bump's crest ring; working set: the left half.
    auto& pins = after.vertex_properties["pinned"];
    auto& working_set = after.vertex_properties["working_set"];
    for (std::size_t i = 0; i < after.vertex_count(); ++i) {
      const float r = (after.positions[i].head<2>() - Eigen::Vector2f(0.5f, 0.5f)).norm();
      const bool pin = r > 0.1f && r < 0.15f && i % 5 == 0;
      if (pin) pinned.push_back(i);
      pins.push_back(pin ? 1.0f : 0.0f);
      working_set.push_back(after.positions[i].x() < 0.5f ? 1.0f : 0.0f);
    }
    pg::write_vertex_mask(dir / "pinned.pgmask.json", pg::mask_from_property(after, "pinned"));
    pg::write_vertex_mask(dir / "working_set.pgmask.json", pg::mask_from_property(after, "working_set"));
  }
  std::string path(const std::string& name) const { return (dir / name).string(); }
};

nlohmann::json read_json(const fs::path& path) {
  return nlohmann::json::parse(pg::testing::read_text(path));
}

}  // namespace

TEST(PgRemesh, RemeshesTheDeformedRegionKeepingPinsAndMasks) {
  Scene s;
  const auto r =
      run_tool("pg-remesh",
               {"--in", s.path("after.ply"), "--out", s.path("out.ply"), "--deformed-from",
                s.path("before.ply"), "--target-length", "0.015", "--pinned", s.path("pinned.pgmask.json"),
                "--carry-mask", s.path("working_set.pgmask.json"), "--quality-report", s.path("quality.json"),
                "--histogram", s.path("quality.png"), "--report", s.path("run.json")});
  ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
  const pg::Mesh out = pg::read_mesh(s.dir / "out.ply");
  EXPECT_GT(out.vertex_count(), s.after.vertex_count());  // the bump got shorter edges
  // Pinned vertices are still there, exactly.
  for (std::size_t v : s.pinned)
    EXPECT_NE(std::find(out.positions.begin(), out.positions.end(), s.after.positions[v]),
              out.positions.end());
  // New masks for the new topology: the pins and the left half are still marked.
  const pg::VertexMask pinned = pg::read_vertex_mask(s.dir / "out.pinned.pgmask.json");
  const pg::VertexMask working_set = pg::read_vertex_mask(s.dir / "out.working_set.pgmask.json");
  EXPECT_NO_THROW(pg::check_fits(pinned, out, "out.pinned.pgmask.json"));
  EXPECT_NO_THROW(pg::check_fits(working_set, out, "out.working_set.pgmask.json"));
  for (std::size_t v : s.pinned) {
    const auto at =
        std::find(out.positions.begin(), out.positions.end(), s.after.positions[v]) - out.positions.begin();
    EXPECT_EQ(pinned.weights[at], 1.0f);
  }
  for (std::size_t i = 0; i < out.vertex_count(); ++i)
    if (std::abs(out.positions[i].x() - 0.5f) > 0.03f) {
      EXPECT_EQ(working_set.weights[i], out.positions[i].x() < 0.5f ? 1.0f : 0.0f);
    }
  const nlohmann::json q = read_json(s.dir / "quality.json");
  EXPECT_EQ(q["format"], "pg-remesh-report");
  EXPECT_EQ(q["version"], 1);
  EXPECT_EQ(q["counts"]["output_faces"], out.face_count());
  EXPECT_GT(double(q["quality"]["after"]["min_angle_above_30"]), 0.9);
  EXPECT_LT(double(q["hausdorff"]["relative_to_target"]), 0.25);
  // The plane around the bump is smooth; the smooth part's distance is at most the whole one's.
  EXPECT_EQ(q["hausdorff_smooth"]["radius_factor"], 3);
  EXPECT_GT(double(q["hausdorff_smooth"]["input_fraction"]), 0.2);
  EXPECT_LE(double(q["hausdorff_smooth"]["distance"]), double(q["hausdorff"]["distance"]));
  EXPECT_EQ(q["masks_written"].size(), 2u);
  const cv::Mat png = cv::imread(s.path("quality.png"));
  EXPECT_EQ(png.cols, 1260);
  EXPECT_EQ(png.rows, 300);
  const nlohmann::json run = read_json(s.dir / "run.json");
  EXPECT_EQ(run["metrics"]["output_faces"], out.face_count());
  EXPECT_EQ(run["metrics"]["smooth_fraction"], q["hausdorff_smooth"]["input_fraction"]);
}

TEST(PgRemesh, SameOutputForAnyThreadCount) {
  Scene s;
  for (const std::string threads : {"1", "2"}) {
    const auto r =
        run_tool("pg-remesh", {"--in", s.path("after.ply"), "--out", s.path("out" + threads + ".ply"),
                               "--threads", threads, "--iterations", "4"});
    ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
  }
  const pg::Mesh one = pg::read_mesh(s.dir / "out1.ply"), two = pg::read_mesh(s.dir / "out2.ply");
  EXPECT_EQ(one.positions, two.positions);
  EXPECT_EQ(one.faces, two.faces);
}

// The recipe remeshes what refinement moved (--deformed-from); when it moved nothing, the mesh
// passes through unchanged rather than failing the shot.
TEST(PgRemesh, NothingDeformedPassesTheMeshThrough) {
  Scene s;
  const auto r = run_tool("pg-remesh", {"--in", s.path("after.ply"), "--deformed-from", s.path("after.ply"),
                                        "--out", s.path("same.ply")});
  ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
  const pg::Mesh same = pg::read_mesh(s.dir / "same.ply");
  EXPECT_EQ(same.positions, s.after.positions);
  EXPECT_EQ(same.faces, s.after.faces);
}

// A mask given as the region (--mask) and as a mask to carry has one output: before, the two
// declarations of out.<name>.pgmask.json failed the run (exit 6, two outputs in one file).
TEST(PgRemesh, AMaskGivenTwiceIsWrittenOnce) {
  Scene s;
  const auto r = run_tool("pg-remesh", {"--in", s.path("after.ply"), "--out", s.path("out.ply"), "--mask",
                                        s.path("working_set.pgmask.json"), "--carry-mask",
                                        s.path("working_set.pgmask.json"), "--target-length", "0.015"});
  ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
  const pg::Mesh out = pg::read_mesh(s.dir / "out.ply");
  EXPECT_NO_THROW(pg::check_fits(pg::read_vertex_mask(s.dir / "out.working_set.pgmask.json"), out,
                                 "out.working_set.pgmask.json"));
}

TEST(PgRemesh, ClearErrorsForBadInput) {
  Scene s;
  pg::testing::write_text(s.dir / "nan.ply",
                          "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                          "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                          "end_header\n0 0 0\n1 0 0\n0 nan 0\n3 0 1 2\n");
  auto nan =
      run_tool("pg-remesh", {"--in", s.path("nan.ply"), "--out", s.path("o.ply"), "--target-length", "0.2"});
  EXPECT_EQ(nan.exit_code, 3);
  EXPECT_NE(nan.stderr_text.find("nan.ply: vertex 2 has a non-finite y"), std::string::npos)
      << nan.stderr_text;

  pg::write_mesh(s.dir / "other.ply", pg::test::flat_plane(10));
  auto r = run_tool("pg-remesh", {"--in", s.path("other.ply"), "--out", s.path("o.ply"), "--mask",
                                  s.path("working_set.pgmask.json")});
  EXPECT_EQ(r.exit_code, 3);
  EXPECT_NE(r.stderr_text.find("working_set.pgmask.json"), std::string::npos) << r.stderr_text;

  r = run_tool("pg-remesh", {"--in", s.path("after.ply"), "--out", s.path("o.ply"), "--target-length", "5"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.stderr_text.find("larger than the mesh"), std::string::npos) << r.stderr_text;

  pg::Mesh fin = pg::test::flat_plane(4);
  fin.positions.emplace_back(0.1f, 0.0f, 1.0f);
  fin.positions.emplace_back(0.1f, 0.0f, -1.0f);
  fin.faces.push_back({1, 0, 25});
  fin.faces.push_back({0, 1, 26});
  pg::write_mesh(s.dir / "fin.ply", fin);
  r = run_tool("pg-remesh", {"--in", s.path("fin.ply"), "--out", s.path("o.ply")});
  EXPECT_EQ(r.exit_code, 3);
  EXPECT_NE(r.stderr_text.find("not a manifold"), std::string::npos) << r.stderr_text;
  EXPECT_NE(r.stderr_text.find("edge (0, 1)"), std::string::npos) << r.stderr_text;

  r = run_tool("pg-remesh", {"--in", s.path("after.ply"), "--out", s.path("o.ply"), "--deformed-from",
                             s.path("other.ply")});
  EXPECT_EQ(r.exit_code, 3);
  EXPECT_NE(r.stderr_text.find("other.ply"), std::string::npos) << r.stderr_text;
  EXPECT_FALSE(fs::exists(s.dir / "o.ply"));
}

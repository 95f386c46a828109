#include "pg/refine/brush.h"

#include <gtest/gtest.h>

#include <cstring>

#include "pg/core/error.h"
#include "pg/mesh/mesh_io.h"
#include "pg/refine/brush_strokes.h"
#include "pg/refine/refine.h"
#include "pg/refine/refine_caches.h"
#include "pg/synth/shapes.h"
#include "pg/testing/testing.h"

namespace {

bool same_bits(const std::vector<Eigen::Vector3f>& a, const std::vector<Eigen::Vector3f>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(Eigen::Vector3f)) == 0;
}

// A small plane (pre) and a bumped copy (post), as a refinement would leave them.
struct States {
  pg::Mesh pre, post;
};
States plane_states() {
  pg::synth::MeshBuilder b;
  b.add_grid(
      20, 20, [](float u, float v) { return Eigen::Vector3f(u - 0.5f, v - 0.5f, 0.0f); }, 0);
  States s{b.mesh, b.mesh};
  for (auto& p : s.post.positions)
    p.z() = 0.1f * std::cos(3.0f * p.x()) * std::sin(2.0f * p.y() + 0.3f) + 0.013f;
  return s;
}

TEST(Brush, WeightOneLandsOnTheTargetExactlyAndWeightZeroChangesNothing) {
  const States s = plane_states();
  const std::size_t n = s.pre.vertex_count();
  std::vector<Eigen::Vector3f> current = s.pre.positions;
  pg::blend_towards(current, s.post.positions, std::vector<float>(n, 0.0f));
  EXPECT_TRUE(same_bits(current, s.pre.positions));
  pg::blend_towards(current, s.post.positions,
                    std::vector<float>(n, 1.0f));  // paint everywhere = the iteration
  EXPECT_TRUE(same_bits(current, s.post.positions));
  pg::blend_towards(current, s.pre.positions, std::vector<float>(n, 1.0f));  // erase everywhere = undo
  EXPECT_TRUE(same_bits(current, s.pre.positions));
}

TEST(Brush, RepeatedStrokesConvergeWithoutOvershoot) {
  const States s = plane_states();
  const std::size_t n = s.pre.vertex_count();
  std::vector<Eigen::Vector3f> current = s.pre.positions;
  std::vector<float> weights(n);
  for (std::size_t v = 0; v < n; ++v) weights[v] = 0.05f + 0.9f * float(v % 7) / 6.0f;
  for (int stroke = 0; stroke < 400; ++stroke) {
    pg::blend_towards(current, s.post.positions, weights);
    for (std::size_t v = 0; v < n; ++v)
      for (int c = 0; c < 3; ++c) {
        const float lo = std::min(s.pre.positions[v][c], s.post.positions[v][c]);
        const float hi = std::max(s.pre.positions[v][c], s.post.positions[v][c]);
        ASSERT_GE(current[v][c], lo);
        ASSERT_LE(current[v][c], hi);
      }
  }
  for (std::size_t v = 0; v < n; ++v) EXPECT_LT((current[v] - s.post.positions[v]).norm(), 1e-6f);
  // Half-strength strokes halve the remaining distance each time.
  std::vector<Eigen::Vector3f> half = s.pre.positions;
  pg::blend_towards(half, s.post.positions, std::vector<float>(n, 0.5f));
  for (std::size_t v = 0; v < n; ++v)
    EXPECT_NEAR(half[v].z(), 0.5f * (s.pre.positions[v].z() + s.post.positions[v].z()), 1e-6f);
}

TEST(Brush, RespectsWorkingSetAndPins) {
  const States s = plane_states();
  const std::size_t n = s.pre.vertex_count();
  pg::BrushLimits limits;
  limits.working_set.assign(n, 1.0f);
  limits.pinned.assign(n, 0.0f);
  for (std::size_t v = 0; v < n; v += 3) limits.working_set[v] = 0.0f;
  for (std::size_t v = 1; v < n; v += 5) limits.pinned[v] = 1.0f;
  std::vector<Eigen::Vector3f> current = s.pre.positions;
  pg::blend_towards(current, s.post.positions, std::vector<float>(n, 1.0f), limits);
  for (std::size_t v = 0; v < n; ++v) {
    const bool frozen = limits.working_set[v] == 0.0f || limits.pinned[v] == 1.0f;
    EXPECT_EQ(std::memcmp(current[v].data(), (frozen ? s.pre : s.post).positions[v].data(), 12), 0) << v;
  }
  EXPECT_THROW(pg::blend_towards(current, s.post.positions, std::vector<float>(3, 1.0f)), pg::UsageError);
}

TEST(Brush, WorldStrokeWeightsFollowTheFalloff) {
  const States s = plane_states();
  pg::BrushStroke stroke;
  stroke.points = {Eigen::Vector3d(-0.2, 0, 0), Eigen::Vector3d(0.2, 0, 0)};
  stroke.radius = 0.1;
  stroke.strength = 0.8;
  stroke.falloff = pg::BrushFalloff::linear;
  const std::vector<float> w = pg::stroke_weights(s.pre, stroke);
  for (std::size_t v = 0; v < w.size(); ++v) {
    const Eigen::Vector3f p = s.pre.positions[v];
    // Distance to the segment from (-0.2, 0) to (0.2, 0).
    const double dx = std::max(0.0, std::abs(double(p.x())) - 0.2), d = std::hypot(dx, double(p.y()));
    EXPECT_NEAR(w[v], 0.8 * std::max(0.0, 1 - d / 0.1), 1e-5) << v;
  }
  EXPECT_DOUBLE_EQ(pg::falloff_value(pg::BrushFalloff::smooth, 0.5), 0.5);
  EXPECT_DOUBLE_EQ(pg::falloff_value(pg::BrushFalloff::constant, 0.99), 1.0);
  EXPECT_DOUBLE_EQ(pg::falloff_value(pg::BrushFalloff::gaussian, 1.0), 0.0);
}

TEST(Brush, ScreenStrokesReachOnlyVerticesTheViewSees) {
  // Two parallel planes; a camera above sees only the upper one.
  pg::synth::MeshBuilder b;
  b.add_grid(
      10, 10, [](float u, float v) { return Eigen::Vector3f(u - 0.5f, v - 0.5f, 0.2f); }, 0);
  b.add_grid(
      10, 10, [](float u, float v) { return Eigen::Vector3f(u - 0.5f, v - 0.5f, 0.0f); }, 0);
  pg::Camera camera;
  camera.id = "top";
  camera.width = 200;
  camera.height = 200;
  camera.intrinsics = {200, 200, 99.5, 99.5};
  camera.cam_from_world = pg::Rigid3::look_at({0, 0, 2}, {0, 0, 0}, Eigen::Vector3d::UnitY());
  pg::BrushStroke stroke;
  stroke.screen = true;
  stroke.view = "top";
  stroke.points = {Eigen::Vector3d(99.5, 99.5, 0)};
  stroke.radius = 60;
  stroke.falloff = pg::BrushFalloff::constant;
  const std::vector<float> w = pg::stroke_weights(b.mesh, stroke, &camera);
  std::size_t upper = 0, lower = 0;
  for (std::size_t v = 0; v < w.size(); ++v) (v < 121 ? upper : lower) += w[v] > 0;
  EXPECT_GT(upper, 10u);
  EXPECT_EQ(lower, 0u);
  EXPECT_THROW(pg::stroke_weights(b.mesh, stroke, nullptr), pg::UsageError);
}

TEST(BrushStrokes, RoundTripAndRejections) {
  pg::testing::TempDir dir;
  pg::BrushStrokes strokes;
  pg::BrushStroke world;
  world.points = {Eigen::Vector3d(0.1, 0.2, 0.3), Eigen::Vector3d(0.2, 0.2, 0.3)};
  world.radius = 0.05;
  world.strength = 0.5;
  world.falloff = pg::BrushFalloff::gaussian;
  pg::BrushStroke screen;
  screen.mode = pg::BrushMode::erase;
  screen.screen = true;
  screen.view = "view_003";
  screen.points = {Eigen::Vector3d(120, 80, 0)};
  screen.radius = 25;
  strokes.strokes = {world, screen};
  pg::write_brush_strokes(dir / "strokes.json", strokes);
  const pg::BrushStrokes back = pg::read_brush_strokes(dir / "strokes.json");
  ASSERT_EQ(back.strokes.size(), 2u);
  EXPECT_EQ(back.strokes[0].points, world.points);
  EXPECT_EQ(back.strokes[0].falloff, pg::BrushFalloff::gaussian);
  EXPECT_DOUBLE_EQ(back.strokes[0].strength, 0.5);
  EXPECT_EQ(back.strokes[1].mode, pg::BrushMode::erase);
  EXPECT_TRUE(back.strokes[1].screen);
  EXPECT_EQ(back.strokes[1].view, "view_003");
  EXPECT_EQ(back.strokes[1].points[0], Eigen::Vector3d(120, 80, 0));

  const std::string header = R"({"format": "pg-brush-strokes", "version": 1, "strokes": [)";
  const std::vector<std::pair<std::string, std::string>> bad = {
      {R"({"space": "world", "points": [[0, 0]], "radius": 1})", "points[0]"},
      {R"({"space": "screen", "points": [[0, 0]], "radius": 1})", "view"},
      {R"({"space": "world", "points": [[0, 0, 0]], "radius": -1})", "radius"},
      {R"({"space": "world", "points": [[0, 0, 0]], "radius": 1, "strength": 2})", "strength"},
      {R"({"space": "world", "points": [[0, 0, 0]], "radius": 1, "falloff": "spiky"})", "falloff"},
      {R"({"space": "world", "points": [], "radius": 1})", "empty"},
      {R"({"space": "world", "points": [[0, 0, 0]], "radius": 1, "colour": 3})", "colour"},
  };
  for (const auto& [stroke, word] : bad) {
    pg::testing::write_text(dir / "bad.json", header + stroke + "]}");
    try {
      pg::read_brush_strokes(dir / "bad.json");
      ADD_FAILURE() << "accepted " << stroke;
    } catch (const pg::InputError& e) {
      EXPECT_NE(std::string(e.what()).find(word), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("bad.json"), std::string::npos) << e.what();
    }
  }
  pg::testing::write_text(dir / "future.json",
                          R"({"format": "pg-brush-strokes", "version": 9, "strokes": []})");
  EXPECT_THROW(pg::read_brush_strokes(dir / "future.json"), pg::InputError);
}

TEST(RefineCaches, RefuseACacheOfAnotherMesh) {
  pg::testing::TempDir dir;
  const States s = plane_states();
  pg::write_refine_cache(dir / "post.ply", s.post);
  const pg::Mesh back = pg::read_refine_cache(dir / "post.ply", s.pre);
  EXPECT_TRUE(same_bits(back.positions, s.post.positions));
  pg::Mesh other = s.pre;
  std::swap(other.faces[0][1], other.faces[0][2]);
  try {
    pg::read_refine_cache(dir / "post.ply", other);
    ADD_FAILURE() << "accepted a cache of another mesh";
  } catch (const pg::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("another mesh"), std::string::npos) << e.what();
  }
}

}  // namespace

#include <gtest/gtest.h>

#include "pg/synth/scenes.h"
#include "pg/synth/shapes.h"

using pg::synth::MeshBuilder;

namespace {
// Signed volume of a closed mesh: positive when faces are counter-clockwise seen from outside.
double signed_volume(const pg::Mesh& m) {
  double v = 0;
  for (const auto& f : m.faces) {
    Eigen::Vector3d a = m.positions[f[0]].cast<double>(), b = m.positions[f[1]].cast<double>(),
                    c = m.positions[f[2]].cast<double>();
    v += a.dot(b.cross(c)) / 6.0;
  }
  return v;
}
}  // namespace

TEST(Shapes, BoxIsClosedOutwardAndHasItsVolume) {
  MeshBuilder b;
  b.add_box({1, 2, 3}, {2, 3, 4}, 0.7f, 3, 0);
  EXPECT_NEAR(signed_volume(b.mesh), 24.0, 1e-4);
  MeshBuilder inward;
  inward.add_box({0, 0, 0}, {2, 3, 4}, 0.0f, 2, 0, true);
  EXPECT_NEAR(signed_volume(inward.mesh), -24.0, 1e-4);
}

TEST(Shapes, SphereIsOutwardWithNearlyItsVolume) {
  MeshBuilder b;
  b.add_sphere(
      {0, 0, 0}, 4, [](const Eigen::Vector3f&) { return 2.0f; }, 0);
  EXPECT_EQ(b.mesh.faces.size(), 20u * 256u);
  double exact = 4.0 / 3.0 * M_PI * 8.0;
  EXPECT_NEAR(signed_volume(b.mesh) / exact, 1.0, 0.01);
  for (const auto& p : b.mesh.positions) EXPECT_NEAR(p.norm(), 2.0f, 1e-5f);
}

TEST(Scenes, DeterministicForASeedAndDifferentAcrossSeeds) {
  pg::synth::SceneOptions o;
  auto a = pg::synth::make_set_scene(o), b = pg::synth::make_set_scene(o);
  o.seed = 2;
  auto c = pg::synth::make_set_scene(o);
  ASSERT_EQ(a.mesh.positions.size(), b.mesh.positions.size());
  EXPECT_EQ(a.mesh.positions, b.mesh.positions);
  EXPECT_NE(a.mesh.positions, c.mesh.positions);
  EXPECT_EQ(a.cameras.cameras.size(), 16u);
  EXPECT_GT(a.mesh.faces.size(), 90000u);  // ~100k triangles, as the render benchmark assumes
}

TEST(Scenes, SetCamerasSeeTheCentre) {
  auto scene = pg::synth::make_set_scene({});
  for (const auto& c : scene.cameras.cameras) {
    Eigen::Vector2d px;
    ASSERT_TRUE(c.project_world({0, 0, 0.3}, px));
    EXPECT_NEAR(px.x(), (c.width - 1) / 2.0, 1e-6);
    EXPECT_NEAR(px.y(), (c.height - 1) / 2.0, 1e-6);
  }
}

TEST(Scenes, CheckerboardCornersAreInsideEveryView) {
  auto scene = pg::synth::make_checkerboard_scene({});
  ASSERT_EQ(scene.cameras.cameras.size(), 15u);
  double square = scene.extras["square_size"];
  for (const auto& c : scene.cameras.cameras)
    for (int j = 0; j < 6; ++j)
      for (int i = 0; i < 9; ++i) {
        Eigen::Vector2d px;
        ASSERT_TRUE(c.project_world({i * square, j * square, 0}, px));
        EXPECT_TRUE(c.in_image(px, 10)) << c.id << " corner " << i << "," << j << " at " << px.transpose();
      }
}

TEST(Scenes, BoardAlbedoIsACheckerWithAMargin) {
  auto scene = pg::synth::make_checkerboard_scene({});
  // Find the board face under board-local points and check the colour parity.
  double square = scene.extras["square_size"];
  auto albedo_at = [&](double x, double y) {
    for (std::uint32_t f = 0; f < scene.mesh.faces.size(); ++f) {
      if (scene.face_material[f] != int(pg::synth::Material::board)) continue;
      const auto& face = scene.mesh.faces[f];
      Eigen::Vector2d a = scene.mesh.positions[face[0]].head<2>().cast<double>();
      Eigen::Vector2d b = scene.mesh.positions[face[1]].head<2>().cast<double>();
      Eigen::Vector2d c = scene.mesh.positions[face[2]].head<2>().cast<double>();
      Eigen::Matrix2d m;
      m << b - a, c - a;
      Eigen::Vector2d w = m.inverse() * (Eigen::Vector2d(x, y) - a);
      if (w.x() >= 0 && w.y() >= 0 && w.sum() <= 1) return scene.albedo(f, float(w.x()), float(w.y())).x();
    }
    return -1.0f;
  };
  EXPECT_LT(albedo_at(-0.5 * square, -0.5 * square), 0.1f);  // first square is dark
  EXPECT_GT(albedo_at(0.5 * square, -0.5 * square), 0.9f);
  EXPECT_GT(albedo_at(-1.5 * square, 2 * square), 0.9f);  // margin
}

TEST(Scenes, RoomPanoramasAre27cmApartVertically) {
  auto scene = pg::synth::make_room_scene({});
  ASSERT_EQ(scene.cameras.cameras.size(), 2u);
  Eigen::Vector3d d =
      scene.cameras.cameras[1].cam_from_world.centre() - scene.cameras.cameras[0].cam_from_world.centre();
  EXPECT_NEAR((d - Eigen::Vector3d(0, 0, 0.27)).norm(), 0, 1e-12);
  ASSERT_EQ(scene.cameras.rigs.size(), 1u);
  EXPECT_NEAR((*scene.cameras.rigs[0].offset - Eigen::Vector3d(0, -0.27, 0)).norm(), 0, 1e-12);
}

TEST(Scenes, DeformTruthDiffersFromInitialByABoundedSmoothField) {
  auto scene = pg::synth::make_deform_scene({});
  ASSERT_TRUE(scene.initial_mesh.has_value());
  ASSERT_EQ(scene.initial_mesh->faces, scene.mesh.faces);
  double max_move = 0;
  for (std::size_t i = 0; i < scene.mesh.positions.size(); ++i)
    max_move =
        std::max(max_move, double((scene.mesh.positions[i] - scene.initial_mesh->positions[i]).norm()));
  EXPECT_GT(max_move, 0.02);
  EXPECT_LE(max_move, 0.04 * 1.5 + 1e-6);
}

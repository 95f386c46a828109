#include "pg/refine/refine.h"

#include <gtest/gtest.h>

#include <cstring>
#include <numbers>

#include "pg/core/error.h"
#include "pg/core/parallel.h"
#include "pg/refine/pair_estimate.h"
#include "pg/refine/refine_test_scene.h"
#include "pg/synth/shapes.h"

namespace {

using pg::testing::DeformFixture;

// One in-memory deform scene shared by the tests (rendering it is the slow part).
const DeformFixture& deform() {
  static const DeformFixture fixture = pg::testing::make_deform_fixture(320, 240);
  return fixture;
}

std::vector<pg::Camera> cameras_of(const std::vector<pg::RefineView>& views) {
  std::vector<pg::Camera> cameras;
  for (const auto& v : views) cameras.push_back(v.camera);
  return cameras;
}

pg::RefineOptions test_options(int iterations) {
  pg::RefineOptions options;
  options.scale = 1.0;  // the fixture is already small
  options.iterations = iterations;
  return options;
}

bool same_bits(const Eigen::Vector3f& a, const Eigen::Vector3f& b) {
  return std::memcmp(a.data(), b.data(), sizeof(float) * 3) == 0;
}

TEST(Refine, ConformsTheDeformSceneToThePhotographs) {
  const DeformFixture& f = deform();
  const pg::Mesh& initial = *f.scene.initial_mesh;
  const pg::RefineResult result = pg::refine_mesh(initial, f.views, {}, {}, test_options(4));

  // Topology identical, every vertex accounted for.
  EXPECT_EQ(result.mesh.faces, initial.faces);
  EXPECT_EQ(pg::topology_id(result.mesh), pg::topology_id(initial));
  ASSERT_EQ(result.mesh.vertex_properties.at("displacement").size(), initial.vertex_count());

  // The target, over every vertex: the mean distance to the true surface drops by >= 80%.
  // (The deformation fades out on the rock's underside, which no camera sees: there the mesh is
  // already right and must stay so, carried only by the smoothing.)
  const pg::TriangleBvh truth(f.scene.mesh);
  const double before = pg::testing::mean_vertex_distance(initial, truth, {});
  const double after = pg::testing::mean_vertex_distance(result.mesh, truth, {});
  EXPECT_GT(before, 0.01);  // a quarter of the 4 cm amplitude, on average over the whole rock
  EXPECT_LT(after, 0.2 * before) << "all vertices: " << before << " -> " << after;
  // The underside, which no pair observes, is not pushed off the truth by the smoothing.
  const auto observed = pg::testing::observed_vertices(initial, cameras_of(f.views));
  std::vector<std::uint8_t> unobserved(observed.size());
  for (std::size_t v = 0; v < observed.size(); ++v) unobserved[v] = !observed[v];
  EXPECT_LT(pg::testing::mean_vertex_distance(result.mesh, truth, unobserved), 0.05 * before);

  // The photographs agree better on every pair, and the displacement shrinks as it converges.
  ASSERT_EQ(result.iterations.size(), 4u);
  const auto& first = result.iterations.front().before;
  const auto& last = result.iterations.back().after;
  ASSERT_EQ(first.size(), 2 * result.pairs.size());
  for (std::size_t k = 0; k < first.size(); ++k)
    EXPECT_LT(last[k].ncc_error, first[k].ncc_error - 0.2)
        << k << ": " << first[k].ncc_error << " -> " << last[k].ncc_error;
  EXPECT_LT(result.iterations.back().mean_displacement, 0.1 * result.iterations.front().mean_displacement);
  EXPECT_EQ(result.error_before.size(), result.error_after.size());
}

// --mesh-accuracy: a prior on the input mesh weighs each pixel by how precisely its pair resolves depth.
// Errors far above the pairs' precision are still corrected; a mesh already right is left nearly so.
TEST(Refine, AMeshAccuracyPriorCorrectsLargeErrorsAndLeavesAnAccurateMeshAlone) {
  const DeformFixture& f = deform();
  const pg::TriangleBvh truth(f.scene.mesh);
  pg::RefineOptions options = test_options(4);
  options.mesh_accuracy = 0.04;  // the deformation's amplitude
  const pg::Mesh& initial = *f.scene.initial_mesh;
  const double before = pg::testing::mean_vertex_distance(initial, truth, {});
  const double after =
      pg::testing::mean_vertex_distance(pg::refine_mesh(initial, f.views, {}, {}, options).mesh, truth, {});
  std::cout << "[ measured ] deformed rock with a 4 cm prior: " << before << " -> " << after << "\n";
  EXPECT_LT(after, 0.25 * before);

  // The true surface itself: the photographs' noise is all a refinement can add.
  options.iterations = 2;
  options.mesh_accuracy = 0;
  const double unknown = pg::testing::mean_vertex_distance(
      pg::refine_mesh(f.scene.mesh, f.views, {}, {}, options).mesh, truth, {});
  options.mesh_accuracy = 0.0005;
  const double known = pg::testing::mean_vertex_distance(
      pg::refine_mesh(f.scene.mesh, f.views, {}, {}, options).mesh, truth, {});
  std::cout << "[ measured ] true surface refined: " << unknown << " without a prior, " << known
            << " with 0.5 mm\n";
  EXPECT_LT(known, 0.5 * unknown);
}

// The lines of the epipolar mode: moving a surface point along A's ray moves its B image along the
// line through its pixel, towards A's side of the line for points nearer A.
TEST(Refine, EpipolarLinesCarryTheSurfacePointsAlongARay) {
  const DeformFixture& f = deform();
  const pg::Mesh& mesh = f.scene.mesh;
  pg::RefineViewState a = pg::make_view_state(f.views[0], 1.0), b = pg::make_view_state(f.views[1], 1.0);
  pg::render_view_state(mesh, a);
  pg::render_view_state(mesh, b);
  pg::SyntheticView synthetic;
  pg::synthesize(mesh, a, b, 0.01, synthetic);
  const pg::EpipolarField field = pg::surface_epipolar_field(mesh, a, b, synthetic);
  ASSERT_EQ(field.base.size(), synthetic.valid.size());
  std::size_t checked = 0;
  for (int y = 0; y < b.camera.height; y += 3)
    for (int x = 0; x < b.camera.width; x += 3) {
      const cv::Vec2f d = field.direction(y, x);
      ASSERT_NEAR(std::hypot(d[0], d[1]), 1.0, 1e-5);  // every pixel has a line, borrowed or own
      EXPECT_EQ(field.base(y, x), cv::Vec2f(0, 0));
      if (!synthetic.valid(y, x)) continue;
      const std::size_t i = b.buffers.index(x, y);
      const auto& face = mesh.faces[b.buffers.triangle[i]];
      const Eigen::Vector3d point =
          (1.0 - b.buffers.b1[i] - b.buffers.b2[i]) * mesh.positions[face[0]].cast<double>() +
          b.buffers.b1[i] * mesh.positions[face[1]].cast<double>() +
          b.buffers.b2[i] * mesh.positions[face[2]].cast<double>();
      const Eigen::Vector3d towards_a = (a.centre - point).normalized();
      for (double t : {-0.03, 0.03}) {  // 3 cm along A's ray, either way
        Eigen::Vector2d moved;
        ASSERT_TRUE(b.camera.project_world(point + t * towards_a, moved));
        const Eigen::Vector2d offset = moved - Eigen::Vector2d(x, y);
        const double along = offset.x() * d[0] + offset.y() * d[1];
        const double across = std::abs(offset.x() * d[1] - offset.y() * d[0]);
        EXPECT_LT(across, 0.02 + 0.002 * std::abs(along)) << x << "," << y;  // the pixel is a hit's centre
        EXPECT_GT(along * t, 0.0) << x << "," << y;
      }
      ++checked;
    }
  EXPECT_GT(checked, 500u);
}

// The weights ramp up from the image's edge as from the co-visible region's: before, a pixel on the
// edge of B's image had the full weight.
TEST(Refine, BorderTaperRampsFromTheImageEdgeAndTheRegionBorder) {
  cv::Mat1b valid(20, 30, std::uint8_t{255});
  valid(cv::Rect(20, 0, 10, 20)).setTo(0);
  const cv::Mat1f taper = pg::border_taper(valid, 4);
  EXPECT_FLOAT_EQ(taper(10, 0), 0.25f);   // on the left edge
  EXPECT_FLOAT_EQ(taper(0, 10), 0.25f);   // on the top edge
  EXPECT_FLOAT_EQ(taper(10, 19), 0.25f);  // next to the invalid part
  EXPECT_FLOAT_EQ(taper(10, 2), 0.75f);
  EXPECT_FLOAT_EQ(taper(10, 10), 1.0f);
  EXPECT_FLOAT_EQ(taper(10, 25), 0.0f);
  EXPECT_EQ(cv::countNonZero(pg::border_taper(valid, 0) != 1.0f), 0);
  // A panorama's left edge continues its right one: only the invalid band is a border.
  valid.setTo(255);
  valid(cv::Rect(10, 0, 5, 20)).setTo(0);
  const cv::Mat1f wrapped = pg::border_taper(valid, 4, true);
  EXPECT_FLOAT_EQ(wrapped(10, 0), 1.0f);
  EXPECT_FLOAT_EQ(wrapped(0, 25), 1.0f);
  EXPECT_FLOAT_EQ(wrapped(10, 29), 1.0f);
  EXPECT_FLOAT_EQ(wrapped(10, 16), 0.5f);
}

TEST(Refine, PinsAndVerticesOutsideTheWorkingSetStayBitForBit) {
  const DeformFixture& f = deform();
  const pg::Mesh& initial = *f.scene.initial_mesh;
  const std::size_t n = initial.vertex_count();
  pg::RefineMasks masks;
  masks.working_set.assign(n, 0.0f);
  masks.pinned.assign(n, 0.0f);
  // Working set: the upper half of the rock; pins: a band through it, and one soft weight.
  for (std::size_t v = 0; v < n; ++v) {
    const Eigen::Vector3f& p = initial.positions[v];
    if (p.z() > 0.45f) masks.working_set[v] = p.z() > 0.5f ? 1.0f : 0.5f;
    if (std::abs(p.x()) < 0.08f) masks.pinned[v] = 1.0f;
  }
  const pg::RefineResult result = pg::refine_mesh(initial, f.views, {{0, 1}, {1, 2}}, masks, test_options(1));
  std::size_t moved = 0;
  for (std::size_t v = 0; v < n; ++v) {
    const bool must_stay = masks.working_set[v] == 0.0f || masks.pinned[v] == 1.0f;
    if (must_stay)
      EXPECT_TRUE(same_bits(result.mesh.positions[v], initial.positions[v])) << "vertex " << v;
    else
      moved += !same_bits(result.mesh.positions[v], initial.positions[v]);
  }
  EXPECT_GT(moved, 500u);
  EXPECT_EQ(result.mesh.faces, initial.faces);
}

TEST(Refine, ResultsDoNotDependOnTheThreadCount) {
  const DeformFixture& f = deform();
  const pg::Mesh& initial = *f.scene.initial_mesh;
  pg::set_thread_count(1);
  const pg::RefineResult one = pg::refine_mesh(initial, f.views, {{3, 4}}, {}, test_options(1));
  pg::set_thread_count(0);
  const pg::RefineResult all = pg::refine_mesh(initial, f.views, {{3, 4}}, {}, test_options(1));
  ASSERT_EQ(one.mesh.positions.size(), all.mesh.positions.size());
  for (std::size_t v = 0; v < one.mesh.positions.size(); ++v)
    ASSERT_TRUE(same_bits(one.mesh.positions[v], all.mesh.positions[v])) << "vertex " << v;
}

// A flat, finely subdivided plane becomes a relief by refinement alone (with the free 2-D flow).
TEST(Refine, SubdividedPlaneConformsToARelief) {
  auto relief = [](float x, float y) {
    return 0.06f * std::exp(-((x - 0.1f) * (x - 0.1f) + y * y) / 0.08f) -
           0.04f * std::exp(-((x + 0.25f) * (x + 0.25f) + (y - 0.2f) * (y - 0.2f)) / 0.03f);
  };
  auto grid = [&](bool raised) {
    pg::synth::MeshBuilder b;
    b.add_grid(
        48, 48,
        [&](float u, float v) {
          const float x = -0.6f + 1.2f * u, y = -0.6f + 1.2f * v;
          return Eigen::Vector3f(x, y, raised ? relief(x, y) : 0.0f);
        },
        int(pg::synth::Material::rock));
    return b;
  };
  pg::synth::MeshBuilder truth_builder = grid(true);
  pg::synth::Scene scene;
  scene.name = "relief";
  scene.mesh = truth_builder.mesh;
  scene.face_material = truth_builder.face_material;
  scene.texture_points = scene.mesh.positions;
  scene.texture = pg::synth::SolidTexture(7, 0.35f);
  for (int i = 0; i < 4; ++i) {
    const double angle = std::numbers::pi / 2 * i + 0.3;
    pg::Camera c;
    c.id = "top_" + std::to_string(i);
    c.width = 320;
    c.height = 240;
    c.intrinsics = {300, 300, 159.5, 119.5};
    c.cam_from_world = pg::Rigid3::look_at({0.5 * std::cos(angle), 0.5 * std::sin(angle), 1.6}, {0, 0, 0},
                                           Eigen::Vector3d::UnitY());
    scene.cameras.cameras.push_back(c);
  }
  pg::synth::ViewRenderer renderer(scene, 2);
  std::vector<pg::RefineView> views;
  for (const auto& c : scene.cameras.cameras)
    views.push_back({c, pg::synth::to_srgb8(renderer.render(c).color)});

  const pg::Mesh plane = grid(false).mesh;
  pg::RefineOptions options = test_options(5);
  options.flow_mode = pg::RefineFlow::free;  // the deform scene tests the default (epipolar) mode
  const pg::RefineResult result =
      pg::refine_mesh(plane, views, {{0, 1}, {1, 2}, {2, 3}, {3, 0}}, {}, options);
  const pg::TriangleBvh truth(scene.mesh);
  // Vertex-to-truth distances over the central part every view sees.
  std::vector<std::uint8_t> centre(plane.vertex_count());
  for (std::size_t v = 0; v < centre.size(); ++v)
    centre[v] = plane.positions[v].head<2>().cwiseAbs().maxCoeff() < 0.4f;
  const double before = pg::testing::mean_vertex_distance(plane, truth, centre);
  const double after = pg::testing::mean_vertex_distance(result.mesh, truth, centre);
  EXPECT_GT(before, 0.01);
  EXPECT_LT(after, 0.25 * before) << before << " -> " << after;
}

TEST(Refine, ChoosesNeighbouringViewsAsPairs) {
  const DeformFixture& f = deform();
  const auto pairs = pg::select_view_pairs(*f.scene.initial_mesh, cameras_of(f.views));
  // Twelve views on a ring, 30 degrees apart: each pairs with its two neighbours.
  ASSERT_EQ(pairs.size(), 12u);
  for (const auto& p : pairs) {
    const int gap = std::abs(p.a - p.b);
    EXPECT_TRUE(gap == 1 || gap == 11) << p.a << "-" << p.b;
  }
}

TEST(Refine, RejectsBadPairsOptionsAndMasks) {
  const DeformFixture& f = deform();
  const pg::Mesh& initial = *f.scene.initial_mesh;
  EXPECT_THROW(pg::refine_mesh(initial, f.views, {{0, 0}}, {}, test_options(1)), pg::UsageError);
  EXPECT_THROW(pg::refine_mesh(initial, f.views, {{0, 40}}, {}, test_options(1)), pg::UsageError);
  pg::RefineOptions bad = test_options(1);
  bad.step = 0;
  EXPECT_THROW(pg::refine_mesh(initial, f.views, {{0, 1}}, {}, bad), pg::UsageError);
  pg::RefineMasks short_mask;
  short_mask.pinned.assign(10, 1.0f);
  EXPECT_THROW(pg::refine_mesh(initial, f.views, {{0, 1}}, short_mask, test_options(1)), pg::UsageError);
  // A camera turned away from the mesh.
  std::vector<pg::RefineView> turned = {f.views[0], f.views[1]};
  turned[1].camera.cam_from_world = pg::Rigid3::look_at({0, 0, 5}, {0, 0, 10});
  EXPECT_FALSE(pg::camera_sees_mesh(initial, turned[1].camera));
  EXPECT_TRUE(pg::camera_sees_mesh(initial, turned[0].camera));
  EXPECT_THROW(pg::refine_mesh(initial, turned, {{0, 1}}, {}, test_options(1)), pg::FailedError);
}

}  // namespace

#include "pg/render/rasterizer.h"

#include <gtest/gtest.h>

#include <cstring>

#include "pg/core/error.h"
#include "pg/core/parallel.h"
#include "pg/render/render_test_scenes.h"

namespace pg {
namespace {

using namespace render_test;

// Analytic depth of the camera-frame ray d hitting at range t, in the buffer's convention.
double depth_of(const RenderBuffers& b, const Eigen::Vector3d& d, double t) {
  return b.depth_kind == DepthMeasure::z ? t * d.z() : t;
}

class EveryModel : public ::testing::TestWithParam<int> {
 protected:
  Camera camera() const { return all_models()[GetParam()]; }
};

// Planes around the camera: in front, behind (across the equirectangular seam), above (the pole).
std::vector<Quad> planes_around() {
  return {{{0.3, -0.2, 5}, {4, 0.5, 0.4}, {0.2, 3, -0.6}},
          {{0.5, 0.2, -3}, {60, 0, 1}, {0, 40, 0.5}},
          {{0.1, -2, 0.4}, {30, 0.2, 0}, {0, -0.3, 30}}};
}

TEST_P(EveryModel, PlaneDepthMatchesAnalyticRayPlaneDepth) {
  const Camera cam = camera();
  const auto quads = planes_around();
  const RenderBuffers b = render(quads_mesh(cam, quads), cam);
  EXPECT_EQ(b.depth_kind, cam.is_perspective() ? DepthMeasure::z : DepthMeasure::range);
  int covered = 0;
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; ++x) {
      const Eigen::Vector3d d = cam.unproject(Eigen::Vector2d(x, y));
      const float depth = b.depth.at<float>(y, x);
      if (quads_hit(quads, d, -1e-3)) {
        ASSERT_NE(b.triangle_at(x, y), kNoTriangle) << x << "," << y;
      }
      if (b.triangle_at(x, y) == kNoTriangle) {
        EXPECT_TRUE(std::isnan(depth));
        continue;
      }
      ++covered;
      const auto grown = quads_hit(quads, d, 1e-3), shrunk = quads_hit(quads, d, -1e-3);
      ASSERT_TRUE(grown) << x << "," << y;
      if (!shrunk || *shrunk != *grown) continue;  // the ray passes within 1e-3 of a quad's edge
      const double expected = depth_of(b, d, *grown);
      ASSERT_LT(std::abs(depth - expected), 1e-4 * std::abs(expected)) << x << "," << y;
    }
  EXPECT_GT(covered, cam.width * cam.height / 4);
}

TEST_P(EveryModel, BarycentricPointLiesOnThePixelRay) {
  const Camera cam = camera();
  const auto quads = planes_around();
  const Mesh mesh = quads_mesh(cam, quads);
  const RenderBuffers b = render(mesh, cam);
  // Angle between the pixel's ray and the direction to the surface point: 2e-5 rad is 1% of a pixel.
  double worst = 0;
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; ++x) {
      if (b.triangle_at(x, y) == kNoTriangle) continue;
      const Eigen::Vector3d to_point = (cam.cam_from_world * surface_point(mesh, b, x, y)).normalized();
      worst = std::max(worst, (to_point - cam.unproject(Eigen::Vector2d(x, y))).norm());
    }
  EXPECT_LT(worst, 2e-5);
}

TEST_P(EveryModel, SmallTriangleVertexLandsWhereTheCameraProjectsIt) {
  const Camera cam = camera();
  // One small triangle per probe pixel q: vertex 0 projects 0.05 px up-left of q, vertices 1 and 2
  // 1.5 px to the right and below, so q is inside, close to vertex 0, and pixel q - (1, 1) is not.
  Mesh mesh;
  std::vector<Eigen::Vector2i> probes;
  for (int y = 8; y < cam.height - 8; y += 37)
    for (int x = 8; x < cam.width - 8; x += 41) probes.emplace_back(x, y);
  for (const auto& q : probes) {
    const Eigen::Vector2d c = q.cast<double>() - Eigen::Vector2d(0.05, 0.05);
    const double range = 2.0 + 0.01 * q.x();
    const auto base = std::uint32_t(mesh.positions.size());
    for (const Eigen::Vector2d& offset :
         {Eigen::Vector2d(0, 0), Eigen::Vector2d(1.5, 0), Eigen::Vector2d(0, 1.5)})
      mesh.positions.push_back(world_from_cam(cam, range * cam.unproject(c + offset)).cast<float>());
    mesh.faces.push_back({base, base + 1, base + 2});
  }
  const RenderBuffers b = render(mesh, cam);
  for (std::size_t i = 0; i < probes.size(); ++i) {
    const Eigen::Vector2i q = probes[i];
    ASSERT_EQ(b.triangle_at(q.x(), q.y()), i) << q.transpose();
    EXPECT_GT(b.barycentric_at(q.x(), q.y())[0], 0.9f);
    EXPECT_EQ(b.triangle_at(q.x() - 1, q.y() - 1), kNoTriangle);
    // The vertex itself, projected by the camera model, lands 0.05 px from the pixel it was drawn at.
    Eigen::Vector2d pixel;
    cam.project_world(mesh.positions[mesh.faces[i][0]].cast<double>(), pixel);
    EXPECT_LT((pixel - q.cast<double>()).norm(), 0.08) << q.transpose();
  }
}

TEST_P(EveryModel, ClosedSphereAroundTheCameraCoversEveryPixel) {
  const Camera cam = camera();
  const Eigen::Vector3d centre = cam.cam_from_world.centre();
  // Coarse and fine, with poles on the camera's vertical axis (equirectangular poles and seam on
  // mesh vertices and edges) and tilted.
  const Eigen::Vector3d cam_up = cam.cam_from_world.rotation.conjugate() * Eigen::Vector3d(0, -1, 0);
  const Eigen::Vector3d cam_back = cam.cam_from_world.rotation.conjugate() * Eigen::Vector3d(0, 0, -1);
  for (const Mesh& sphere :
       {uv_sphere(centre, 3, 6, 8, cam_up), uv_sphere(centre, 3, 40, 80, cam_up, 0.0),
        uv_sphere(centre, 3, 40, 80, cam_back), uv_sphere(centre, 3, 17, 29, {1, 2, 3}, 0.3)}) {
    const RenderBuffers b = render(sphere, cam);
    int holes = 0;
    for (std::uint32_t t : b.triangle) holes += t == kNoTriangle;
    EXPECT_EQ(holes, 0);
    // Seen from inside, every face is a back face.
    RenderOptions cull;
    cull.cull_back_faces = true;
    const RenderBuffers culled = render(sphere, cam, cull);
    int hits = 0;
    for (std::uint32_t t : culled.triangle) hits += t != kNoTriangle;
    EXPECT_EQ(hits, 0);
  }
}

TEST_P(EveryModel, TessellatedSphereDepthWithinTessellationError) {
  const Camera cam = camera();
  const bool inside = !cam.is_perspective();
  // Perspective: a sphere ahead; equirectangular: the camera inside, off the sphere's centre.
  const Eigen::Vector3d centre_cam = inside ? Eigen::Vector3d(0.2, -0.1, 0.3) : Eigen::Vector3d(0.3, 0.2, 6);
  const double radius = 2;
  const Eigen::Vector3d centre = world_from_cam(cam, centre_cam);
  const Mesh sphere = uv_sphere(centre, radius, 48, 96, {0.3, 1, 0.2});
  // Largest distance from the sphere to a face plane: radius * (1 - cos(angular face diameter)).
  double max_angle = 0;
  for (const auto& f : sphere.faces)
    for (int i = 0; i < 3; ++i) {
      Eigen::Vector3d p = sphere.positions[f[i]].cast<double>() - centre,
                      q = sphere.positions[f[(i + 1) % 3]].cast<double>() - centre;
      max_angle = std::max(max_angle, std::acos(std::clamp(p.normalized().dot(q.normalized()), -1.0, 1.0)));
    }
  const double sagitta = radius * (1 - std::cos(max_angle));
  for (bool cull : {false, true}) {
    RenderOptions options;
    options.cull_back_faces = cull && !inside;
    const RenderBuffers b = render(sphere, cam, options);
    int checked = 0;
    for (int y = 0; y < cam.height; ++y)
      for (int x = 0; x < cam.width; ++x) {
        const Eigen::Vector3d d = cam.unproject(Eigen::Vector2d(x, y));
        const double along = d.dot(centre_cam), c = centre_cam.squaredNorm() - radius * radius;
        const double disc = along * along - c;
        if (disc <= 0) continue;
        const double t = inside ? along + std::sqrt(disc) : along - std::sqrt(disc);
        if (!(t > 0)) continue;
        const double incidence = std::abs(d.dot((t * d - centre_cam).normalized()));
        if (incidence < 0.3) continue;
        ASSERT_NE(b.triangle_at(x, y), kNoTriangle) << x << "," << y;
        const double range = b.depth.at<float>(y, x) / (b.depth_kind == DepthMeasure::z ? d.z() : 1.0);
        // The polyhedron is inscribed: the front hit is behind the sphere (outside), before it (inside).
        const double gap = inside ? t - range : range - t;
        ASSERT_GT(gap, -1e-5 * t) << x << "," << y;
        ASSERT_LT(gap, 1.5 * sagitta / incidence + 1e-5 * t) << x << "," << y;
        ++checked;
      }
    EXPECT_GT(checked, 1000);
  }
}

INSTANTIATE_TEST_SUITE_P(Models, EveryModel, ::testing::Values(0, 1, 2), [](const auto& info) {
  return std::string(to_string(all_models()[info.param].model));
});

TEST(Rasterizer, BitIdenticalWithOneAndTwoThreads) {
  for (const Camera& cam : all_models()) {
    Mesh scene = uv_sphere(world_from_cam(cam, {0.2, 0.1, 4}), 1.5, 64, 128, {1, 0.5, 0});
    const Mesh around = uv_sphere(cam.cam_from_world.centre(), 8, 20, 40);
    const auto offset = std::uint32_t(scene.positions.size());
    scene.positions.insert(scene.positions.end(), around.positions.begin(), around.positions.end());
    for (auto f : around.faces) scene.faces.push_back({f[0] + offset, f[1] + offset, f[2] + offset});
    scene.uvs.clear();
    RenderBuffers one, two;
    set_thread_count(1);
    one = render(scene, cam);
    set_thread_count(2);
    two = render(scene, cam);
    set_thread_count(0);
    ASSERT_EQ(one.triangle, two.triangle);
    ASSERT_EQ(0, std::memcmp(one.b1.data(), two.b1.data(), one.b1.size() * sizeof(float)));
    ASSERT_EQ(0, std::memcmp(one.b2.data(), two.b2.data(), one.b2.size() * sizeof(float)));
    ASSERT_EQ(0, std::memcmp(one.depth.data, two.depth.data, one.depth.total() * sizeof(float)));
  }
}

TEST(Rasterizer, NearestSurfaceWinsAndDepthKindIsConfigurable) {
  const Camera cam = pinhole_distorted();
  const std::vector<Quad> quads = {{{0, 0, 8}, {10, 0, 0}, {0, 10, 0}},
                                   {{0, 0, 4}, {0.5, 0, 0}, {0, 0.5, 0}}};
  RenderOptions options;
  options.depth_kind = DepthMeasure::range;
  const RenderBuffers b = render(quads_mesh(cam, quads), cam, options);
  EXPECT_EQ(b.depth_kind, DepthMeasure::range);
  for (int y = 0; y < cam.height; y += 3)
    for (int x = 0; x < cam.width; x += 3) {
      const Eigen::Vector3d d = cam.unproject(Eigen::Vector2d(x, y));
      const auto t = quads_hit(quads, d, -1e-3);
      if (!t) continue;
      EXPECT_NEAR(b.depth.at<float>(y, x), *t, 1e-4 * *t);
      EXPECT_EQ(b.triangle_at(x, y) / 2, *t < 6 ? 1u : 0u);
    }
}

TEST(Rasterizer, RejectsARayTableOfAnotherCamera) {
  Camera a = pinhole_distorted(), b = a;
  b.intrinsics.fx += 1;
  RayTable rays(a);
  RenderBuffers out;
  EXPECT_THROW(Renderer().render(Mesh{}, b, rays, {}, out), Error);
  EXPECT_NO_THROW(Renderer().render(Mesh{}, a, rays, {}, out));
  EXPECT_EQ(out.triangle.size(), std::size_t(a.width * a.height));
}

}  // namespace
}  // namespace pg

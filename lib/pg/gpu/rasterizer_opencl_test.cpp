#include "pg/gpu/rasterizer_opencl.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <string>

#include "pg/core/error.h"
#include "pg/gpu/test_support.h"
#include "pg/render/render_test_scenes.h"
#include "pg/synth/scenes.h"

namespace pg::gpu {
namespace {

using namespace render_test;

// The sphere, overlapping quads (each two triangles sharing a diagonal) and planes around the camera,
// across the equirectangular seam and over the pole: every kind of edge and tie the renderer resolves.
Mesh test_scene(const Camera& camera) {
  Mesh mesh = quads_mesh(camera, {{{0.3, -0.2, 5}, {4, 0.5, 0.4}, {0.2, 3, -0.6}},
                                  {{0.5, 0.2, -3}, {60, 0, 1}, {0, 40, 0.5}},
                                  {{0.1, -2, 0.4}, {30, 0.2, 0}, {0, -0.3, 30}},
                                  {{-0.4, 0.1, 3}, {0.8, 0.1, 0}, {0, 0.7, 0.2}},
                                  {{0.2, 0.3, 3.2}, {0.9, 0, 0.3}, {0.1, 0.6, 0}}});
  const Mesh sphere = uv_sphere(world_from_cam(camera, {0.6, 0.1, 2.2}), 0.5, 24, 48);
  const auto base = std::uint32_t(mesh.positions.size());
  mesh.positions.insert(mesh.positions.end(), sphere.positions.begin(), sphere.positions.end());
  mesh.uvs.insert(mesh.uvs.end(), sphere.uvs.begin(), sphere.uvs.end());
  for (const auto& f : sphere.faces) mesh.faces.push_back({base + f[0], base + f[1], base + f[2]});
  return mesh;
}

struct Agreement {
  std::size_t pixels = 0, hits = 0, same_id = 0, exact = 0;
  std::size_t id_off_edge = 0, nan_mismatch = 0;  // must stay 0
  double depth = 0, barycentric = 0;              // largest relative depth and barycentric differences
  std::string first_problem;
};

// Compares two renders; ids may differ only where the CPU's barycentrics put the pixel on an edge.
Agreement compare(const RenderBuffers& cpu, const RenderBuffers& gpu) {
  Agreement a;
  EXPECT_EQ(cpu.width, gpu.width);
  EXPECT_EQ(cpu.height, gpu.height);
  EXPECT_EQ(cpu.depth_kind, gpu.depth_kind);
  a.pixels = cpu.triangle.size();
  const auto problem = [&](int x, int y, const char* what) {
    if (a.first_problem.empty())
      a.first_problem = std::string(what) + " at " + std::to_string(x) + "," + std::to_string(y) +
                        " cpu id " + std::to_string(cpu.triangle_at(x, y)) + " gpu id " +
                        std::to_string(gpu.triangle_at(x, y));
  };
  for (int y = 0; y < cpu.height; ++y)
    for (int x = 0; x < cpu.width; ++x) {
      const std::size_t i = cpu.index(x, y);
      const float dc = cpu.depth.at<float>(y, x), dg = gpu.depth.at<float>(y, x);
      a.hits += cpu.triangle[i] != kNoTriangle;
      if (cpu.triangle[i] != gpu.triangle[i]) {
        if (!(cpu.barycentric_at(x, y).minCoeff() < 1e-4f))
          ++a.id_off_edge, problem(x, y, "ids differ off an edge");
        continue;
      }
      ++a.same_id;
      if (cpu.triangle[i] == kNoTriangle) {
        if (std::isnan(dg))
          ++a.exact;
        else
          ++a.nan_mismatch, problem(x, y, "depth where no face is hit");
        continue;
      }
      a.exact += std::memcmp(&dc, &dg, 4) == 0 && cpu.b1[i] == gpu.b1[i] && cpu.b2[i] == gpu.b2[i];
      a.depth = std::max(a.depth, double(std::abs(dc - dg)) / std::abs(dc));
      a.barycentric = std::max(
          {a.barycentric, double(std::abs(cpu.b1[i] - gpu.b1[i])), double(std::abs(cpu.b2[i] - gpu.b2[i]))});
    }
  return a;
}

void expect_agreement(const Agreement& a, std::size_t min_hits) {
  EXPECT_GE(a.hits, min_hits);
  EXPECT_EQ(a.id_off_edge, 0u) << a.first_problem;
  EXPECT_EQ(a.nan_mismatch, 0u) << a.first_problem;
  EXPECT_GE(double(a.same_id), 0.999 * double(a.pixels));
  EXPECT_LE(a.depth, 1e-4);
  EXPECT_LE(a.barycentric, 1e-4);
  ::testing::Test::RecordProperty("bit_identical_pixels",
                                  std::to_string(a.exact) + " of " + std::to_string(a.pixels));
}

// The kernel runs the CPU's float operations in its order, so PoCL (the CPU's own arithmetic) gives
// bit-identical images; a GPU driver is only held to the tolerances.
void expect_bit_identical_on_a_cpu_device(const Agreement& a) {
  static const bool gpu = [] {
    for (const DeviceInfo& d : list_devices())
      if (d.kind == DeviceKind::opencl && d.is_gpu) return true;
    return false;
  }();
  if (!gpu) {
    EXPECT_EQ(a.exact, a.pixels) << a.first_problem;
  }
}

class EveryModel : public ::testing::TestWithParam<int> {
 protected:
  Camera camera() const { return all_models()[GetParam()]; }
};

TEST_P(EveryModel, OpenClEqualsTheCpuRenderer) {
  PG_REQUIRE_OPENCL();
  const Camera cam = camera();
  const Mesh mesh = test_scene(cam);
  const RayTable rays(cam);
  for (const bool cull : {false, true}) {
    RenderOptions options;
    options.cull_back_faces = cull;
    options.near = cull ? 1.9 : 0;  // also cuts into the sphere
    RenderBuffers cpu, gpu;
    Renderer().render(mesh, cam, rays, options, cpu);
    OpenClRenderer renderer(rays);
    renderer.render(mesh, cam, options, gpu);
    SCOPED_TRACE(cull ? "culled, near plane" : "all faces");
    const Agreement a = compare(cpu, gpu);
    expect_agreement(a, std::size_t(cam.width) * cam.height / (cull ? 100 : 4));
    expect_bit_identical_on_a_cpu_device(a);
  }
}

TEST_P(EveryModel, BandsOfRowsGiveTheSameImage) {
  PG_REQUIRE_OPENCL();
  const Camera cam = camera();
  const Mesh mesh = test_scene(cam);
  const RayTable rays(cam);
  OpenClRenderer whole(rays), banded(rays);
  banded.limit_band_rows(100);  // bands of 96 rows, the last one shorter
  RenderBuffers a, b;
  whole.render(mesh, cam, {}, a);
  banded.render(mesh, cam, {}, b);
  EXPECT_EQ(a.triangle, b.triangle);
  EXPECT_EQ(a.b1, b.b1);
  EXPECT_EQ(a.b2, b.b2);
  EXPECT_EQ(cv::norm(a.depth, b.depth, cv::NORM_INF | cv::NORM_RELATIVE), 0.0);  // NaNs at the same pixels
  EXPECT_EQ(cv::countNonZero(a.depth == a.depth), cv::countNonZero(b.depth == b.depth));
}

INSTANTIATE_TEST_SUITE_P(Rasterizer, EveryModel, ::testing::Values(0, 1, 2),
                         [](const auto& info) { return all_models()[info.param].id; });

TEST(RasterizerOpenCl, DeformRockAcrossRendersAndShading) {
  PG_REQUIRE_OPENCL();
  synth::SceneOptions scene_options;
  scene_options.width = 400, scene_options.height = 300, scene_options.views = 3;
  const synth::Scene scene = synth::make_deform_scene(scene_options);
  RenderOptions options;
  options.shading = Shading::white;
  options.lambert = true;
  for (const Camera& cam : scene.cameras.cameras) {
    const RayTable rays(cam);
    OpenClRenderer renderer(rays);
    Renderer cpu_renderer;
    // The same renderer twice with different meshes: the ray table stays uploaded, the faces do not.
    for (const Mesh* mesh : {&scene.mesh, &*scene.initial_mesh}) {
      RenderBuffers cpu, gpu;
      cpu_renderer.render(*mesh, cam, rays, options, cpu);
      renderer.render(*mesh, cam, options, gpu);
      const Agreement a = compare(cpu, gpu);
      expect_agreement(a, std::size_t(cam.width) * cam.height / 20);
      expect_bit_identical_on_a_cpu_device(a);
      ASSERT_EQ(gpu.color.size(), cpu.color.size());
      EXPECT_EQ(cv::norm(cpu.color, gpu.color, cv::NORM_INF), 0.0);
    }
  }
}

TEST(RasterizerOpenCl, DispatchRunsTheCpuRendererOrTheKernel) {
  const Camera cam = pinhole_distorted();
  const Mesh mesh = test_scene(cam);
  const auto rays = std::make_shared<const RayTable>(cam);
  Renderer reference;
  RenderBuffers expected, on_cpu;
  reference.render(mesh, cam, *rays, {}, expected);
  ViewRenderer cpu(rays, DeviceKind::cpu);
  cpu.render(mesh, cam, {}, on_cpu);
  EXPECT_FALSE(cpu.on_device());
  EXPECT_EQ(on_cpu.triangle, expected.triangle);
  EXPECT_EQ(on_cpu.b1, expected.b1);
  EXPECT_EQ(on_cpu.b2, expected.b2);
  PG_REQUIRE_OPENCL();
  RenderBuffers on_device;
  ViewRenderer device(rays, DeviceKind::opencl);
  device.render(mesh, cam, {}, on_device);
  EXPECT_TRUE(device.on_device());
  expect_agreement(compare(expected, on_device), std::size_t(cam.width) * cam.height / 4);
}

TEST(RasterizerOpenCl, EmptyMeshAndUnusableRaysBehaveAsOnTheCpu) {
  PG_REQUIRE_OPENCL();
  const Camera cam = equirect();
  const RayTable rays(cam);
  OpenClRenderer renderer(rays);
  RenderBuffers out;
  renderer.render(Mesh{}, cam, {}, out);
  EXPECT_EQ(std::count(out.triangle.begin(), out.triangle.end(), kNoTriangle), cam.width * cam.height);
  EXPECT_EQ(cv::countNonZero(out.depth == out.depth), 0);  // all NaN
  EXPECT_THROW(renderer.render(Mesh{}, pinhole_distorted(), {}, out), UsageError);
}

}  // namespace
}  // namespace pg::gpu

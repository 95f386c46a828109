// pg-refine on the accelerated device (--device opencl) against the CPU: the renders of each view and
// the refined mesh.
#include <gtest/gtest.h>

#include "pg/gpu/device.h"
#include "pg/gpu/test_support.h"
#include "pg/refine/pair_estimate.h"
#include "pg/refine/refine.h"
#include "pg/refine/refine_test_scene.h"

namespace {

using pg::gpu::DeviceKind;

const pg::testing::DeformFixture& deform() {
  static const pg::testing::DeformFixture fixture = pg::testing::make_deform_fixture(200, 150, 6);
  return fixture;
}

// Sets the requested device for one scope (the process-wide default is automatic).
struct DeviceScope {
  explicit DeviceScope(DeviceKind kind) { pg::gpu::set_requested_device(kind); }
  ~DeviceScope() { pg::gpu::set_requested_device(DeviceKind::automatic); }
};

// Renders of one mesh on the CPU (a) and the device (b): equal within the rasterizer's tolerance.
void expect_same_render(const pg::RenderBuffers& a, const pg::RenderBuffers& b) {
  ASSERT_EQ(a.triangle.size(), b.triangle.size());
  std::size_t same = 0, hits = 0;
  for (std::size_t i = 0; i < a.triangle.size(); ++i) {
    same += a.triangle[i] == b.triangle[i];
    hits += a.triangle[i] != pg::kNoTriangle;
    if (a.triangle[i] != b.triangle[i] || a.triangle[i] == pg::kNoTriangle) continue;
    EXPECT_NEAR(b.b1[i], a.b1[i], 1e-4f);
    EXPECT_NEAR(b.b2[i], a.b2[i], 1e-4f);
    const float da = a.depth.ptr<float>()[i], db = b.depth.ptr<float>()[i];
    EXPECT_LE(std::abs(da - db), 1e-4f * da);
  }
  EXPECT_GT(hits, a.triangle.size() / 10);
  EXPECT_GE(double(same), 0.999 * double(a.triangle.size()));
}

TEST(RefineDevice, ViewsRenderTheSameOnTheDevice) {
  PG_REQUIRE_OPENCL();
  const auto& f = deform();
  for (const pg::RefineView& view : f.views) {
    pg::RefineViewState cpu = pg::make_view_state(view, 1.0), gpu = pg::make_view_state(view, 1.0);
    {
      const DeviceScope scope(DeviceKind::cpu);
      pg::render_view_state(*f.scene.initial_mesh, cpu);
    }
    {
      const DeviceScope scope(DeviceKind::opencl);
      pg::render_view_state(*f.scene.initial_mesh, gpu);
    }
    EXPECT_FALSE(cpu.renderer->on_device());
    EXPECT_TRUE(gpu.renderer->on_device());
    expect_same_render(cpu.buffers, gpu.buffers);
    // The next iteration's mesh, with the view's rays still on the device.
    pg::render_view_state(f.scene.mesh, cpu);
    pg::render_view_state(f.scene.mesh, gpu);
    EXPECT_TRUE(gpu.renderer->on_device());
    expect_same_render(cpu.buffers, gpu.buffers);
  }
}

TEST(RefineDevice, RefinedMeshMatchesTheCpu) {
  PG_REQUIRE_OPENCL();
  const auto& f = deform();
  const pg::Mesh& initial = *f.scene.initial_mesh;
  pg::RefineOptions options;
  options.scale = 1.0;
  options.iterations = 2;
  const std::vector<pg::ViewPair> pairs = {{0, 1}, {1, 2}};
  const auto refine_on = [&](DeviceKind kind) {
    const DeviceScope scope(kind);
    return pg::refine_mesh(initial, f.views, pairs, {}, options);
  };
  const pg::RefineResult cpu = refine_on(DeviceKind::cpu), gpu = refine_on(DeviceKind::opencl);
  ASSERT_EQ(cpu.mesh.positions.size(), gpu.mesh.positions.size());
  const double size = initial.bounds().diagonal().norm();
  double worst = 0, moved = 0;
  for (std::size_t v = 0; v < cpu.mesh.positions.size(); ++v) {
    worst = std::max(worst, double((cpu.mesh.positions[v] - gpu.mesh.positions[v]).norm()));
    moved = std::max(moved, double((cpu.mesh.positions[v] - initial.positions[v]).norm()));
  }
  EXPECT_GT(moved, 1e-3 * size);  // refinement did move the mesh
  EXPECT_LE(worst, 1e-4 * size) << "largest vertex difference " << worst << " of a " << size << " scene";
}

}  // namespace

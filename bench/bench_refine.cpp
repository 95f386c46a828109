// Refinement benchmark: one iteration with 3 views at 1536x1024 on a mesh of about 200k triangles
// (a textured, displaced sphere; the mesh refined is the same sphere with a smooth bulge removed).
// Prints the wall time of the iteration with its breakdown (render, flow, displacement) on each device:
// the CPU, then every accelerated backend this build can use (OpenCL, CUDA), or those named on the
// command line (`bench_refine cpu cuda`). The seed system (Newcombe & Davison's GPU implementation)
// took about 2 s per iteration on a 2012 GPU.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <numbers>

#include <string>
#include <vector>

#include "pg/core/parallel.h"
#include "pg/gpu/device.h"
#include "pg/refine/refine.h"
#include "pg/synth/scenes.h"
#include "pg/synth/write_scene.h"

namespace {

pg::Mesh displaced_sphere(int rings, int segments, double bulge) {
  pg::Mesh mesh;
  for (int i = 0; i <= rings; ++i)
    for (int j = 0; j <= segments; ++j) {
      const double theta = std::numbers::pi * i / rings, phi = 2 * std::numbers::pi * j / segments;
      const double r = 0.5 * (1 + 0.05 * std::sin(9 * theta) * std::cos(7 * phi)) +
                       bulge * std::sin(2 * theta + 0.4) * std::cos(1.5 * phi);
      mesh.positions.emplace_back(float(r * std::sin(theta) * std::cos(phi)),
                                  float(r * std::sin(theta) * std::sin(phi)),
                                  float(0.5 + r * std::cos(theta)));
    }
  auto id = [&](int i, int j) { return std::uint32_t(i * (segments + 1) + j); };
  for (int i = 0; i < rings; ++i)
    for (int j = 0; j < segments; ++j) {
      if (i > 0) mesh.faces.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
      if (i + 1 < rings) mesh.faces.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
    }
  return mesh;
}

// The devices named on the command line, else the CPU and every usable accelerated backend.
std::vector<pg::gpu::DeviceKind> devices_to_run(int argc, char** argv) {
  std::vector<pg::gpu::DeviceKind> kinds;
  for (int i = 1; i < argc; ++i) kinds.push_back(pg::gpu::parse_device_kind(argv[i]));
  if (!kinds.empty()) return kinds;
  kinds.push_back(pg::gpu::DeviceKind::cpu);
  if (pg::gpu::opencl_unavailable_reason().empty()) kinds.push_back(pg::gpu::DeviceKind::opencl);
  if (pg::gpu::cuda_unavailable_reason().empty()) kinds.push_back(pg::gpu::DeviceKind::cuda);
  return kinds;
}

}  // namespace

int main(int argc, char** argv) {
  const int width = 1536, height = 1024;
  pg::synth::SceneOptions scene_options;
  scene_options.width = width;
  scene_options.height = height;
  pg::synth::Scene scene = pg::synth::make_deform_scene(scene_options);  // for its cameras
  scene.mesh = displaced_sphere(250, 400, 0.02);
  scene.face_material.assign(scene.mesh.faces.size(), int(pg::synth::Material::rock));
  scene.texture_points = scene.mesh.positions;
  const pg::Mesh initial = displaced_sphere(250, 400, 0.0);

  std::vector<pg::RefineView> views;
  pg::synth::ViewRenderer renderer(scene, 1);
  for (int i = 0; i < 3; ++i) {
    const pg::Camera& camera = scene.cameras.cameras[i];
    views.push_back({camera, pg::synth::to_srgb8(renderer.render(camera).color)});
  }

  pg::RefineOptions options;
  options.iterations = 1;
  std::printf(
      "refine: %zu triangles, %zu vertices, 3 views at %dx%d, pairs 0-1 and 1-2 (both directions), %d "
      "threads\n",
      initial.face_count(), initial.vertex_count(), width, height, pg::thread_count());
  // On each device: the full 1536x1024 working resolution, then the default half resolution (768x512
  // flow); each with the default epipolar flow and the free 2-D flow.
  for (const pg::gpu::DeviceKind device : devices_to_run(argc, argv)) {
    pg::gpu::set_requested_device(device);
    std::printf("device %s\n", pg::gpu::describe_active_device().c_str());
    if (device != pg::gpu::DeviceKind::cpu) {  // the first use compiles the device's kernels: not timed
      options.scale = 0.5;
      pg::refine_mesh(initial, views, {{0, 1}, {1, 2}}, {}, options);
    }
    for (const double scale : {1.0, 0.5})
      for (const pg::RefineFlow mode : {pg::RefineFlow::epipolar, pg::RefineFlow::free}) {
        options.scale = scale;
        options.flow_mode = mode;
        const auto start = std::chrono::steady_clock::now();
        const pg::RefineResult result = pg::refine_mesh(initial, views, {{0, 1}, {1, 2}}, {}, options);
        const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        const pg::IterationStats& it = result.iterations.front();
        double before = 0, after = 0;
        for (std::size_t k = 0; k < it.before.size(); ++k)
          before += it.before[k].ncc_error, after += it.after[k].ncc_error;
        std::printf(
            "scale %.1f, %s flow: one iteration %.2f s (render %.2f s, flow %.2f s, displacement %.2f s), "
            "%.2f s wall with the setup and the final evaluation; 1 - NCC %.3f -> %.3f; mean displacement "
            "%.4f\n",
            scale, mode == pg::RefineFlow::epipolar ? "epipolar" : "free",
            it.render_seconds + it.flow_seconds + it.displacement_seconds, it.render_seconds, it.flow_seconds,
            it.displacement_seconds, wall, before / it.before.size(), after / it.after.size(),
            it.mean_displacement);
      }
  }
  std::printf("seed system: about 2 s per iteration on a 2012 GPU\n");
  return 0;
}

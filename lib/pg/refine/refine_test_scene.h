#pragma once
// The deform scene of pg-synth rendered in memory at a small size, for the refinement tests.
#include <vector>

#include <cmath>

#include "pg/eval/mesh_eval.h"
#include "pg/mesh/bvh.h"
#include "pg/refine/refine.h"
#include "pg/render/rasterizer.h"
#include "pg/synth/scenes.h"
#include "pg/synth/write_scene.h"

namespace pg::testing {

struct DeformFixture {
  synth::Scene scene;
  std::vector<RefineView> views;
};

inline DeformFixture make_deform_fixture(int width = 320, int height = 240, int views = 12) {
  synth::SceneOptions options;
  options.width = width;
  options.height = height;
  options.views = views;
  DeformFixture fixture{synth::make_deform_scene(options), {}};
  synth::ViewRenderer renderer(fixture.scene, 2);
  for (const Camera& camera : fixture.scene.cameras.cameras)
    fixture.views.push_back({camera, synth::to_srgb8(renderer.render(camera).color)});
  return fixture;
}

// Vertices of `mesh` that at least two cameras see (in the image, in front, not occluded): what
// refinement can observe. The rest (the underside of the deform scene's rock) it can only smooth.
inline std::vector<std::uint8_t> observed_vertices(const Mesh& mesh, const std::vector<Camera>& cameras) {
  std::vector<int> seen(mesh.vertex_count(), 0);
  for (const Camera& camera : cameras) {
    const RenderBuffers buffers = render(mesh, camera);
    for (std::size_t v = 0; v < mesh.vertex_count(); ++v) {
      const Eigen::Vector3d p = camera.cam_from_world * mesh.positions[v].cast<double>();
      Eigen::Vector2d pixel;
      if (!camera.project(p, pixel) || !camera.in_image(pixel)) continue;
      const float depth = buffers.depth.at<float>(int(std::lround(pixel.y())), int(std::lround(pixel.x())));
      if (std::isfinite(depth) && p.z() <= depth * 1.01) ++seen[v];
    }
  }
  std::vector<std::uint8_t> observed(mesh.vertex_count());
  for (std::size_t v = 0; v < observed.size(); ++v) observed[v] = seen[v] >= 2;
  return observed;
}

// Mean distance from the vertices of `mesh` (those with `subset` set, when given) to `truth`'s surface.
inline double mean_vertex_distance(const Mesh& mesh, const TriangleBvh& truth,
                                   const std::vector<std::uint8_t>& subset) {
  double sum = 0;
  std::size_t count = 0;
  for (std::size_t v = 0; v < mesh.vertex_count(); ++v)
    if (subset.empty() || subset[v]) {
      sum += (truth.closest_point(mesh.positions[v]).point - mesh.positions[v]).norm();
      ++count;
    }
  return count ? sum / double(count) : 0.0;
}

// Mean distance from the vertices of `mesh` to the surface of `truth`.
inline double mean_vertex_distance(const Mesh& mesh, const Mesh& truth) {
  MeshEvalOptions options;
  options.samples = 1;
  return evaluate_mesh(mesh, truth, options).accuracy.mean;
}

}  // namespace pg::testing

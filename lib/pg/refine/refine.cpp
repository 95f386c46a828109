#include "pg/refine/refine.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <set>

#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/core/parallel.h"
#include "pg/core/progress.h"
#include "pg/refine/pair_estimate.h"
#include "pg/refine/photometric.h"
#include "pg/refine/vertex_field.h"

namespace pg {
namespace {

void require(bool ok, const char* field, const std::string& rule) {
  if (!ok) throw UsageError(str("refine option ", field, ": ", rule));
}

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

void check_pairs(const std::vector<ViewPair>& pairs, std::size_t views) {
  for (const auto& p : pairs) {
    if (p.a < 0 || p.b < 0 || std::size_t(p.a) >= views || std::size_t(p.b) >= views)
      throw UsageError(str("view pair (", p.a, ", ", p.b, ") names a view that does not exist"));
    if (p.a == p.b) throw UsageError(str("view pair (", p.a, ", ", p.b, ") pairs a view with itself"));
  }
}

PairError pair_error(const ViewPair& directed, const SyntheticView& synthetic, const RefineViewState& b) {
  const PhotometricError e = photometric_error(synthetic.image, b.gray, synthetic.valid);
  return {directed.a, directed.b, e.ncc_error, e.mean_abs_error, e.pixels};
}

}  // namespace

void RefineOptions::check() const {
  require(iterations >= 0 && iterations <= 10000, "iterations", "must be in [0, 10000]");
  require(scale > 0 && scale <= 4, "scale", "must be in (0, 4]");
  require(step > 0 && step <= 2, "step", "must be in (0, 2]");
  require(smoothness >= 0 && std::isfinite(smoothness), "smoothness", "must be >= 0");
  require(mesh_accuracy >= 0 && std::isfinite(mesh_accuracy), "mesh_accuracy", "must be >= 0");
  require(flow_precision_px > 0 && std::isfinite(flow_precision_px), "flow_precision_px", "must be > 0");
  require(smoothing_iterations >= 0 && smoothing_iterations <= 100000, "smoothing_iterations",
          "must be >= 0");
  require(tolerance >= 0, "tolerance", "must be >= 0");
  require(max_displacement >= 0, "max_displacement", "must be >= 0");
  require(border_taper_px >= 0, "border_taper_px", "must be >= 0");
  require(working_set_taper_rings >= 0, "working_set_taper_rings", "must be >= 0");
  require(relative_depth_tolerance > 0 && relative_depth_tolerance < 1, "relative_depth_tolerance",
          "must be in (0, 1)");
  require(confidence_sigma > 0, "confidence_sigma", "must be > 0");
  require(min_triangulation_angle_deg >= 0 && min_triangulation_angle_deg < 90, "min_triangulation_angle_deg",
          "must be in [0, 90)");
  flow.check();
}

FlowOptions refine_flow_options(const std::string& preset) {
  FlowOptions flow = FlowOptions::preset(preset);
  flow.alpha = 1.0;
  flow.epipolar_alpha = 1.0;
  return flow;
}

bool camera_sees_mesh(const Mesh& mesh, const Camera& camera) {
  for (const auto& p : mesh.positions) {
    Eigen::Vector2d pixel;
    if (camera.project_world(p.cast<double>(), pixel) && camera.in_image(pixel)) return true;
  }
  return false;
}

std::vector<ViewPair> select_view_pairs(const Mesh& mesh, const std::vector<Camera>& cameras, int per_view,
                                        double min_angle_deg, double max_angle_deg) {
  const std::size_t n = cameras.size();
  if (n < 2) return {};
  // A subsample of vertices with normals: which views see each (in the image, facing the camera).
  Mesh sampled = mesh;
  if (sampled.normals.size() != sampled.positions.size()) sampled.compute_vertex_normals();
  const std::size_t stride = std::max<std::size_t>(1, mesh.vertex_count() / 20000);
  std::vector<std::vector<std::uint8_t>> sees(n);
  for (std::size_t c = 0; c < n; ++c) {
    const Camera& camera = cameras[c];
    const Eigen::Vector3d centre = camera.cam_from_world.centre();
    for (std::size_t v = 0; v < mesh.vertex_count(); v += stride) {
      const Eigen::Vector3d p = mesh.positions[v].cast<double>();
      Eigen::Vector2d pixel;
      const bool visible = camera.project_world(p, pixel) && camera.in_image(pixel) &&
                           sampled.normals[v].cast<double>().dot(centre - p) > 0;
      sees[c].push_back(visible);
    }
  }
  // Score each pair: shared vertices whose triangulation angle is in range.
  const double min_angle = min_angle_deg * M_PI / 180, max_angle = max_angle_deg * M_PI / 180;
  std::vector<std::vector<std::pair<std::size_t, int>>> candidates(n);  // (shared count, other view)
  for (std::size_t a = 0; a < n; ++a)
    for (std::size_t b = a + 1; b < n; ++b) {
      const Eigen::Vector3d ca = cameras[a].cam_from_world.centre(), cb = cameras[b].cam_from_world.centre();
      std::size_t shared = 0, good = 0;
      for (std::size_t k = 0, v = 0; k < sees[a].size(); ++k, v += stride) {
        if (!sees[a][k] || !sees[b][k]) continue;
        ++shared;
        const Eigen::Vector3d p = mesh.positions[v].cast<double>();
        const double angle =
            std::acos(std::clamp((ca - p).normalized().dot((cb - p).normalized()), -1.0, 1.0));
        if (angle >= min_angle && angle <= max_angle) ++good;
      }
      if (good * 2 < shared || good == 0) continue;  // most of the overlap must triangulate well
      candidates[a].push_back({good, int(b)});
      candidates[b].push_back({good, int(a)});
    }
  std::set<std::pair<int, int>> chosen;
  for (std::size_t a = 0; a < n; ++a) {
    auto& list = candidates[a];
    std::sort(list.begin(), list.end(), [](const auto& l, const auto& r) {
      return l.first != r.first ? l.first > r.first : l.second < r.second;
    });
    for (int k = 0; k < per_view && k < int(list.size()); ++k)
      chosen.insert({std::min(int(a), list[k].second), std::max(int(a), list[k].second)});
  }
  std::vector<ViewPair> pairs;
  for (const auto& [a, b] : chosen) pairs.push_back({a, b});
  return pairs;
}

RefineResult refine_mesh(const Mesh& mesh, const std::vector<RefineView>& views, std::vector<ViewPair> pairs,
                         const RefineMasks& masks, const RefineOptions& options) {
  options.check();
  mesh.check_consistent();
  const std::size_t n = mesh.vertex_count();
  if ((!masks.working_set.empty() && masks.working_set.size() != n) ||
      (!masks.pinned.empty() && masks.pinned.size() != n))
    throw UsageError("refine: a mask's size differs from the mesh's vertex count");
  std::vector<Camera> cameras;
  for (const auto& v : views) cameras.push_back(v.camera);
  if (pairs.empty()) pairs = select_view_pairs(mesh, cameras);
  check_pairs(pairs, views.size());
  if (pairs.empty())
    throw FailedError("refine: no pair of views overlaps on the mesh with a useful baseline");

  // Views in use, at the working scale; both directions of every pair.
  std::map<int, RefineViewState> states;
  for (const auto& p : pairs)
    for (int v : {p.a, p.b})
      if (!states.count(v)) states.emplace(v, make_view_state(views[v], options.scale));
  std::vector<ViewPair> directed;
  for (const auto& p : pairs) {
    directed.push_back(p);
    directed.push_back({p.b, p.a});
  }

  const VertexGraph graph = vertex_graph(mesh);
  const std::vector<float> factor =
      motion_factors(graph, masks.working_set, masks.pinned, options.working_set_taper_rings);
  std::vector<std::uint8_t> fixed(n);
  for (std::size_t v = 0; v < n; ++v) fixed[v] = factor[v] == 0.0f;
  const double max_displacement = options.max_displacement > 0
                                      ? options.max_displacement
                                      : 0.05 * double(mesh.bounds().diagonal().norm());

  RefineResult result;
  result.pairs = pairs;
  result.mesh = mesh;
  Mesh& current = result.mesh;
  std::vector<Eigen::Vector3f> total(n, Eigen::Vector3f::Zero());
  SyntheticView synthetic;
  DisplacementSums sums;

  auto render_all = [&](Mesh& m) {
    for (auto& [index, state] : states) {
      render_view_state(m, state);
      if (std::none_of(state.buffers.triangle.begin(), state.buffers.triangle.end(),
                       [](std::uint32_t t) { return t != kNoTriangle; }))
        throw FailedError(str("refine: view '", state.camera.id,
                              "' does not see the mesh (it is behind the camera or outside the image)"));
    }
  };

  Progress progress("refine", options.iterations);
  for (int iteration = 0; iteration < options.iterations; ++iteration) {
    IterationStats stats;
    stats.iteration = iteration;
    auto start = std::chrono::steady_clock::now();
    render_all(current);
    stats.render_seconds += seconds_since(start);
    sums.reset(n);
    sums.prior_precision =
        options.mesh_accuracy > 0 ? 1 / (options.mesh_accuracy * options.mesh_accuracy) : 0;
    for (std::size_t k = 0; k < directed.size(); ++k) {
      const ViewPair& d = directed[k];
      const RefineViewState &a = states.at(d.a), &b = states.at(d.b);
      start = std::chrono::steady_clock::now();
      synthesize(current, a, b, options.relative_depth_tolerance, synthetic);
      stats.render_seconds += seconds_since(start);
      stats.before.push_back(pair_error(d, synthetic, b));
      if (iteration == 0 && k == 0)
        result.error_before = error_image(synthetic.image, b.gray, synthetic.valid);
      start = std::chrono::steady_clock::now();
      double flow_seconds = 0;
      estimate_displacements(current, a, b, synthetic, options, max_displacement, sums, &flow_seconds);
      stats.flow_seconds += flow_seconds;
      stats.displacement_seconds += seconds_since(start) - flow_seconds;
    }

    start = std::chrono::steady_clock::now();
    // Per-vertex mean displacement and its confidence (coverage in pixel weights, saturating).
    std::vector<Eigen::Vector3f> observed(n, Eigen::Vector3f::Zero());
    std::vector<float> confidence(n, 0.0f);
    for (std::size_t v = 0; v < n; ++v)
      if (sums.weight[v] > 0) {
        observed[v] = sums.solve(v).cast<float>();
        // With a prior: the share of the vertex's information that comes from the photographs.
        const double saturation = sums.prior_precision > 0 ? sums.prior_precision : 1.0;
        confidence[v] = float(sums.weight[v] / (sums.weight[v] + saturation));
      }
    std::vector<Eigen::Vector3f> displacement = smooth_displacements(
        graph, observed, confidence, fixed, options.smoothness, options.smoothing_iterations);
    if (options.normal_only) {
      Mesh shape;
      shape.positions = current.positions;
      shape.faces = current.faces;
      shape.compute_vertex_normals();
      for (std::size_t v = 0; v < n; ++v)
        displacement[v] = displacement[v].dot(shape.normals[v]) * shape.normals[v];
    }
    double sum = 0;
    for (std::size_t v = 0; v < n; ++v) {
      if (factor[v] == 0.0f) continue;  // bit for bit: never touched
      const Eigen::Vector3f move = float(options.step) * factor[v] * displacement[v];
      const double length = move.norm();
      if (length == 0) continue;
      current.positions[v] += move;
      total[v] += move;
      sum += length;
      stats.max_displacement = std::max(stats.max_displacement, length);
      ++stats.moved_vertices;
    }
    stats.mean_displacement = stats.moved_vertices ? sum / double(stats.moved_vertices) : 0.0;
    stats.displacement_seconds += seconds_since(start);
    log::info("iteration ", iteration + 1, "/", options.iterations, ": mean displacement ",
              stats.mean_displacement, ", max ", stats.max_displacement, ", ", stats.moved_vertices,
              " vertices moved");
    result.iterations.push_back(std::move(stats));
    progress.advance();
    if (options.tolerance > 0 && result.iterations.back().mean_displacement < options.tolerance) break;
  }

  // The photometric error after the last update (and the "after" of each iteration).
  render_all(current);
  std::vector<PairError> final_errors;
  for (std::size_t k = 0; k < directed.size(); ++k) {
    const RefineViewState &a = states.at(directed[k].a), &b = states.at(directed[k].b);
    synthesize(current, a, b, options.relative_depth_tolerance, synthetic);
    final_errors.push_back(pair_error(directed[k], synthetic, b));
    if (k == 0) {
      result.error_after = error_image(synthetic.image, b.gray, synthetic.valid);
      if (result.error_before.empty()) result.error_before = result.error_after.clone();
    }
  }
  for (std::size_t i = 0; i < result.iterations.size(); ++i)
    result.iterations[i].after =
        i + 1 < result.iterations.size() ? result.iterations[i + 1].before : final_errors;
  if (result.iterations.empty()) {
    IterationStats evaluation;
    evaluation.before = evaluation.after = final_errors;
    result.iterations.push_back(evaluation);
  }

  std::vector<float>& magnitude = current.vertex_properties["displacement"];
  magnitude.resize(n);
  for (std::size_t v = 0; v < n; ++v) magnitude[v] = total[v].norm();
  current.update_moved_normals(mesh.positions);
  return result;
}

}  // namespace pg

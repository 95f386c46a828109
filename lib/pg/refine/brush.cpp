#include "pg/refine/brush.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/core/parallel.h"
#include "pg/render/rasterizer.h"

namespace pg {
namespace {

// Distance from p to the polyline through `points` (a single point: the distance to it).
template <int N>
double polyline_distance(const Eigen::Matrix<double, N, 1>& p,
                         const std::vector<Eigen::Matrix<double, N, 1>>& points) {
  double best = std::numeric_limits<double>::infinity();
  if (points.size() == 1) return (p - points[0]).norm();
  for (std::size_t i = 0; i + 1 < points.size(); ++i) {
    const auto segment = points[i + 1] - points[i];
    const double length2 = segment.squaredNorm();
    const double t = length2 > 0 ? std::clamp((p - points[i]).dot(segment) / length2, 0.0, 1.0) : 0.0;
    best = std::min(best, (p - (points[i] + t * segment)).norm());
  }
  return best;
}

}  // namespace

BrushMode brush_mode_from_string(const std::string& name) {
  if (name == "paint") return BrushMode::paint;
  if (name == "erase") return BrushMode::erase;
  throw UsageError("unknown brush mode '" + name + "' (paint or erase)");
}

std::string to_string(BrushMode mode) {
  return mode == BrushMode::paint ? "paint" : "erase";
}

BrushFalloff brush_falloff_from_string(const std::string& name) {
  if (name == "constant") return BrushFalloff::constant;
  if (name == "linear") return BrushFalloff::linear;
  if (name == "smooth") return BrushFalloff::smooth;
  if (name == "gaussian") return BrushFalloff::gaussian;
  throw UsageError("unknown brush falloff '" + name + "' (constant, linear, smooth or gaussian)");
}

std::string to_string(BrushFalloff falloff) {
  switch (falloff) {
    case BrushFalloff::constant:
      return "constant";
    case BrushFalloff::linear:
      return "linear";
    case BrushFalloff::smooth:
      return "smooth";
    case BrushFalloff::gaussian:
      return "gaussian";
  }
  return "smooth";
}

double falloff_value(BrushFalloff falloff, double t) {
  if (!(t < 1)) return 0;  // NaN too
  t = std::max(0.0, t);
  switch (falloff) {
    case BrushFalloff::constant:
      return 1;
    case BrushFalloff::linear:
      return 1 - t;
    case BrushFalloff::smooth:
      return 1 - t * t * (3 - 2 * t);
    case BrushFalloff::gaussian:
      return std::exp(-4.5 * t * t);
  }
  return 0;
}

void blend_towards(std::vector<Eigen::Vector3f>& current, const std::vector<Eigen::Vector3f>& target,
                   const std::vector<float>& weights, const BrushLimits& limits) {
  const std::size_t n = current.size();
  if (target.size() != n || weights.size() != n)
    throw UsageError("brush: the meshes and weights differ in vertex count");
  if ((!limits.working_set.empty() && limits.working_set.size() != n) ||
      (!limits.pinned.empty() && limits.pinned.size() != n))
    throw UsageError("brush: a mask's size differs from the mesh's vertex count");
  for (std::size_t v = 0; v < n; ++v) {
    float w = std::clamp(std::isfinite(weights[v]) ? weights[v] : 0.0f, 0.0f, 1.0f);
    if (!limits.working_set.empty()) w *= limits.working_set[v];
    if (!limits.pinned.empty()) w *= 1.0f - limits.pinned[v];
    if (w <= 0) continue;
    if (w >= 1) {
      current[v] = target[v];
      continue;
    }
    // Each coordinate stays between where it was and the target: no overshoot from rounding.
    for (int c = 0; c < 3; ++c) {
      const float from = current[v][c], to = target[v][c];
      current[v][c] = std::clamp(from + w * (to - from), std::min(from, to), std::max(from, to));
    }
  }
}

std::vector<float> stroke_weights(const Mesh& mesh, const BrushStroke& stroke, const Camera* camera) {
  if (!(stroke.radius > 0)) throw UsageError("brush stroke: radius must be > 0");
  if (!(stroke.strength >= 0 && stroke.strength <= 1))
    throw UsageError("brush stroke: strength must be in [0, 1]");
  if (stroke.points.empty()) throw UsageError("brush stroke: no points");
  const std::size_t n = mesh.vertex_count();
  std::vector<float> weights(n, 0.0f);
  if (!stroke.screen) {
    parallel_chunks(std::int64_t(n), 4096, [&](std::int64_t begin, std::int64_t end) {
      for (std::int64_t v = begin; v < end; ++v) {
        const double d = polyline_distance<3>(mesh.positions[v].cast<double>(), stroke.points);
        weights[v] = float(stroke.strength * falloff_value(stroke.falloff, d / stroke.radius));
      }
    });
    return weights;
  }
  if (!camera) throw UsageError("brush stroke: a screen stroke needs its view's camera");
  std::vector<Eigen::Vector2d> pixels;
  for (const auto& p : stroke.points) pixels.push_back(p.head<2>());
  // Only what the view sees: the vertex's depth must match the rendered surface at its pixel.
  const RenderBuffers buffers = render(mesh, *camera);
  const bool range_depth = !camera->is_perspective();
  parallel_chunks(std::int64_t(n), 4096, [&](std::int64_t begin, std::int64_t end) {
    for (std::int64_t v = begin; v < end; ++v) {
      const Eigen::Vector3d in_camera = camera->cam_from_world * mesh.positions[v].cast<double>();
      Eigen::Vector2d pixel;
      if (!camera->project(in_camera, pixel) || !camera->in_image(pixel)) continue;
      const int x = std::clamp(int(std::lround(pixel.x())), 0, camera->width - 1);
      const int y = std::clamp(int(std::lround(pixel.y())), 0, camera->height - 1);
      const double own = range_depth ? in_camera.norm() : in_camera.z();
      // The nearest surface in a 3x3 neighbourhood: vertices on silhouettes still count as seen.
      double seen = std::numeric_limits<double>::infinity();
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int sx = x + dx, sy = y + dy;
          if (sx < 0 || sy < 0 || sx >= camera->width || sy >= camera->height) continue;
          const float depth = buffers.depth.at<float>(sy, sx);
          if (std::isfinite(depth)) seen = std::min(seen, double(depth));
        }
      if (!(own <= seen * 1.01)) continue;
      const double d = polyline_distance<2>(pixel, pixels);
      weights[v] = float(stroke.strength * falloff_value(stroke.falloff, d / stroke.radius));
    }
  });
  return weights;
}

}  // namespace pg

#pragma once
// The details brush, headless: the pre-iteration and post-iteration states of a refinement are kept
// as caches (formats/refine-caches.md); painting blends the current mesh towards the post cache,
// erasing back towards the pre cache, by per-vertex weights (a painted mask or brush strokes,
// formats/brush-strokes.md). Each blend moves a vertex a fraction w of the way to its target, so
// repeated strokes converge to the target and never overshoot it; w = 1 lands on it exactly and
// w = 0 leaves the vertex bit for bit.
#include <Eigen/Core>
#include <filesystem>
#include <string>
#include <vector>

#include "pg/camera/camera.h"
#include "pg/mesh/mesh.h"

namespace pg {

enum class BrushMode { paint, erase };
BrushMode brush_mode_from_string(const std::string& name);  // "paint" or "erase"; throws UsageError
std::string to_string(BrushMode mode);

// Limits every blend: the effective weight is w * working_set * (1 - pinned) (empty = all / none),
// so vertices outside the working set or fully pinned never change.
struct BrushLimits {
  std::vector<float> working_set;
  std::vector<float> pinned;
};

// Moves each current position a fraction weights[v] (clamped to [0, 1]) of the way to target[v].
// Sizes must agree (UsageError otherwise).
void blend_towards(std::vector<Eigen::Vector3f>& current, const std::vector<Eigen::Vector3f>& target,
                   const std::vector<float>& weights, const BrushLimits& limits = {});

// One stroke: a polyline of points (3-D world points, or pixels of a view) with a radius (scene
// units, or pixels), a strength in [0, 1] and a falloff profile from the centre line to the radius.
enum class BrushFalloff { constant, linear, smooth, gaussian };
BrushFalloff brush_falloff_from_string(const std::string& name);  // throws UsageError
std::string to_string(BrushFalloff falloff);
// Profile value at t = distance / radius: 1 at t = 0, 0 at t >= 1 (gaussian: exp(-4.5 t^2), cut at 1).
double falloff_value(BrushFalloff falloff, double t);

struct BrushStroke {
  BrushMode mode = BrushMode::paint;
  bool screen = false;  // points are pixels of `view` (x, y, 0) rather than world points
  std::string view;     // camera id, for screen strokes
  std::vector<Eigen::Vector3d> points;
  double radius = 0;
  double strength = 1;
  BrushFalloff falloff = BrushFalloff::smooth;
};

// Per-vertex weights of a stroke: strength * falloff(distance to the stroke's polyline / radius).
// Screen strokes measure in `camera`'s pixels and reach only the vertices the camera sees (depth
// test against a render of `mesh`); `camera` is ignored for world strokes.
std::vector<float> stroke_weights(const Mesh& mesh, const BrushStroke& stroke,
                                  const Camera* camera = nullptr);

}  // namespace pg

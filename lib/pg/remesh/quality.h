#pragma once
// Triangle-mesh quality as the remeshing report shows it: edge lengths relative to the target,
// minimum angles, valences, and the Hausdorff distance between two surfaces.
#include <nlohmann/json.hpp>
#include <vector>

#include "pg/mesh/mesh.h"

namespace pg {

// counts[i] holds values in [lo + i w, lo + (i + 1) w), w = (hi - lo) / counts.size(); values below
// lo go to the first bin, values at or above hi to the last.
struct Histogram {
  double lo = 0, hi = 1;
  std::vector<std::size_t> counts;
  void add(double value);
  std::size_t total() const;
};

struct MeshQuality {
  std::size_t faces = 0, edges = 0, vertices = 0;                // measured elements
  Histogram edge_ratio{0, 2, std::vector<std::size_t>(20)};      // edge length / local target
  Histogram min_angle_deg{0, 60, std::vector<std::size_t>(12)};  // smallest angle of each triangle
  Histogram valence{3, 11, std::vector<std::size_t>(8)};         // interior vertices: 3 .. 10 and more
  double edges_in_range = 0;      // fraction of edges with 0.8 <= length / target <= 1.33
  double angles_above_30 = 0;     // fraction of triangles with minimum angle above 30 degrees
  double valence_6 = 0;           // fraction of interior vertices with valence 6
  double smallest_angle_deg = 0;  // over all measured triangles
  double mean_edge_ratio = 0;
  nlohmann::ordered_json to_json() const;
};

// Measures the faces whose three vertices are selected, the edges whose two vertices are, and the
// selected vertices off the boundary (every element when `selected` is empty). `target` is the
// target edge length per vertex (an edge's target is the mean of its two).
MeshQuality measure_quality(const Mesh& mesh, const std::vector<bool>& selected,
                            const std::vector<float>& target);

struct HausdorffDistance {
  double distance = 0;  // max of the two one-sided distances
  double a_to_b = 0, b_to_a = 0;
  std::size_t samples = 0;
};

// Symmetric Hausdorff distance between the selected faces of a and of b (each measured against the
// other whole surface), from the vertices and a barycentric lattice on every selected face with
// points at most `spacing` apart (at most 64 steps along an edge: faces longer than 64 spacings are
// sampled more coarsely). Empty selections mean every face. Deterministic and threaded.
HausdorffDistance hausdorff_distance(const Mesh& a, const std::vector<bool>& a_faces, const Mesh& b,
                                     const std::vector<bool>& b_faces, float spacing);

// Where the surface is smooth at scale `length`: vertices off the boundary whose largest principal
// curvature radius (max_abs_curvature at the vertex itself, not averaged, so that a vertex standing
// out of its ring counts as curved) is at least radius_factor * length. An equilateral triangle of side 4/3 L
// (the split bound) inscribed in a sphere of radius R leaves it by 0.3 L^2 / R, so radius_factor 3 is where
// an isotropic mesh at L can stay within 0.1 L of the surface at all.
std::vector<bool> smooth_vertices(const Mesh& mesh, float length, float radius_factor);

struct SmoothRegionHausdorff {
  float radius_factor = 3;
  double input_fraction = 0;    // of the selected input faces, those that are smooth
  HausdorffDistance hausdorff;  // zero when nothing is smooth
};

// hausdorff_distance restricted to where `input` is smooth at scale `length` (smooth_vertices):
// the selected input faces (empty = every face) with three smooth vertices, and the output's faces
// whose three vertices are closest to such faces; each measured against the other whole surface.
SmoothRegionHausdorff smooth_region_hausdorff(const Mesh& output, const Mesh& input,
                                              const std::vector<bool>& input_faces, float length,
                                              float radius_factor, float spacing);

// Faces whose three vertices are selected.
std::vector<bool> faces_within(const Mesh& mesh, const std::vector<bool>& selected);

}  // namespace pg

#pragma once
// Isotropic remeshing of a region of a triangle mesh (Botsch & Kobbelt 2004; Botsch et al.,
// "Polygon Mesh Processing" 2010, ch. 6): split edges longer than 4/3 L, collapse edges shorter than
// 4/5 L, flip edges towards valence 6, relax vertices tangentially and project them back onto the
// input surface. Feature edges (dihedral angle above a threshold, and boundaries) are kept: never
// flipped or collapsed across, their vertices slide only along the input feature lines, corners stay.
//
// Only the region changes: a vertex outside it keeps its exact position and every face whose three
// vertices lie outside keeps its vertices (and its place in the output order). Pinned vertices keep
// their exact position and are never removed. The output is the same for any thread count.
#include <cstdint>
#include <string>
#include <vector>

#include "pg/mesh/mesh.h"

namespace pg {

struct RemeshOptions {
  // Target edge length L; 0 = the mean edge length of the region's edges.
  float target_length = 0;
  int iterations = 10;
  // Edges whose faces meet at more than this dihedral angle are features (boundaries always are).
  float feature_angle_deg = 45;
  // Adaptive sizing: the target shrinks where curvature is high, to keep the chord error near
  // approximation_error; clamped to [min_length, max_length]. Zeros take 0.05 L, 0.25 L and 2 L.
  bool adaptive = false;
  float approximation_error = 0;
  float min_length = 0;
  float max_length = 0;
  // Per input vertex; empty = every vertex. Vertices outside the region are locked.
  std::vector<bool> region;
  // Per input vertex; empty = none. Pinned vertices keep their exact position and are never removed.
  std::vector<bool> pinned;
  // Named in error messages (the input file).
  std::string input_name = "input mesh";
};

struct RemeshStats {
  std::size_t unused_vertices_dropped = 0;
  std::size_t region_vertices = 0;  // input vertices in the region (after dropping unused ones)
  std::size_t pinned_vertices = 0;
  std::size_t feature_edges = 0;  // in the input region
  std::size_t corner_vertices = 0;
  std::size_t splits = 0, collapses = 0, flips = 0;
};

struct RemeshResult {
  // Positions and faces, plus every attribute and named property of the input: copied for vertices
  // that did not move, interpolated at the closest input surface point for the others. A property
  // holding only 0 and 1 (a mask) stays 0/1 (rounded at 0.5); colours are rounded.
  Mesh mesh;
  // Per output vertex: the input vertex it is (index in the input as given), or -1 for new vertices.
  std::vector<std::int64_t> source_vertex;
  // Per output vertex: true when it lies in the remeshed region (new, or an input region vertex).
  std::vector<bool> in_region;
  // Per output vertex: the target edge length there (L everywhere unless adaptive).
  std::vector<float> target;
  // Per kept input vertex (unused ones dropped, input order): in region, and the target there.
  std::vector<bool> input_in_region;
  std::vector<float> input_target;
  Mesh input;  // the input without its unused vertices, as remeshed
  float target_length = 0;
  RemeshStats stats;
};

// Throws UsageError for L <= 0, L larger than the mesh's bounding-box diagonal, or region/pinned
// sizes that do not match the mesh; InputError(options.input_name, ...) when the mesh is not a
// manifold, naming where.
RemeshResult remesh(const Mesh& input, const RemeshOptions& options);

// The mean length of the edges with both end vertices in `region` (every edge when it is empty);
// 0 when there are none.
float mean_edge_length(const Mesh& mesh, const std::vector<bool>& region = {});

}  // namespace pg

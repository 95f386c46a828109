#pragma once
// Per-vertex fields over a mesh's edge graph: neighbour lists, how much each vertex may move (working
// set, pins, taper) and smoothing of a displacement field.
#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "pg/mesh/mesh.h"

namespace pg {

// Vertex neighbours (edge graph) in compressed rows: neighbours of v are
// indices[offsets[v] .. offsets[v + 1]), sorted and unique.
struct VertexGraph {
  std::vector<std::uint32_t> offsets, indices;
  std::size_t size() const { return offsets.empty() ? 0 : offsets.size() - 1; }
};
VertexGraph vertex_graph(const Mesh& mesh);

// Motion factor per vertex in [0, 1]: working_set * (1 - pinned) * taper, where taper is
// r / (rings + 1) at r rings from the nearest vertex that may not move (factor 0), for r = 1 to
// `rings`, and 1 beyond: 1 / (rings + 1) next to it, 1 from ring rings + 1 on.
// Empty masks mean "all" and "none". Exactly 0 where the working set is 0 or pinned is 1.
std::vector<float> motion_factors(const VertexGraph& graph, const std::vector<float>& working_set,
                                  const std::vector<float>& pinned, int taper_rings);

// Smooths a per-vertex displacement field observed with confidence `weight` (>= 0): `sweeps` Jacobi
// sweeps of  d_v = (w_v o_v + lambda sum_n d_n) / (w_v + lambda deg_v)  where o is the observation.
// Vertices with `fixed` set keep displacement 0 (they anchor their neighbours). lambda = 0 returns
// the observations. Deterministic (each sweep reads only the previous one).
std::vector<Eigen::Vector3f> smooth_displacements(const VertexGraph& graph,
                                                  const std::vector<Eigen::Vector3f>& observed,
                                                  const std::vector<float>& weight,
                                                  const std::vector<std::uint8_t>& fixed, double lambda,
                                                  int sweeps);

}  // namespace pg

#include "pg/refine/vertex_field.h"

#include <algorithm>
#include <limits>

#include "pg/core/error.h"
#include "pg/core/parallel.h"

namespace pg {

VertexGraph vertex_graph(const Mesh& mesh) {
  const std::size_t n = mesh.vertex_count();
  // Each face contributes both directions of its three edges; counting first keeps one allocation.
  std::vector<std::uint32_t> counts(n + 1, 0);
  for (const auto& f : mesh.faces)
    for (int k = 0; k < 3; ++k) counts[f[k] + 1] += 2;
  VertexGraph graph;
  graph.offsets.assign(n + 1, 0);
  for (std::size_t v = 0; v < n; ++v) graph.offsets[v + 1] = graph.offsets[v] + counts[v + 1];
  std::vector<std::uint32_t> raw(graph.offsets[n]);
  std::vector<std::uint32_t> fill(graph.offsets.begin(), graph.offsets.end() - 1);
  for (const auto& f : mesh.faces)
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t v = f[k];
      raw[fill[v]++] = f[(k + 1) % 3];
      raw[fill[v]++] = f[(k + 2) % 3];
    }
  // Sort and deduplicate each row, compacting in place.
  graph.indices.reserve(raw.size() / 2);
  std::vector<std::uint32_t> compact_offsets(n + 1, 0);
  for (std::size_t v = 0; v < n; ++v) {
    auto begin = raw.begin() + graph.offsets[v], end = raw.begin() + graph.offsets[v + 1];
    std::sort(begin, end);
    end = std::unique(begin, end);
    graph.indices.insert(graph.indices.end(), begin, end);
    compact_offsets[v + 1] = std::uint32_t(graph.indices.size());
  }
  graph.offsets = std::move(compact_offsets);
  return graph;
}

std::vector<float> motion_factors(const VertexGraph& graph, const std::vector<float>& working_set,
                                  const std::vector<float>& pinned, int taper_rings) {
  const std::size_t n = graph.size();
  if ((!working_set.empty() && working_set.size() != n) || (!pinned.empty() && pinned.size() != n))
    throw UsageError("motion_factors: a mask's size differs from the mesh's vertex count");
  std::vector<float> factor(n, 1.0f);
  for (std::size_t v = 0; v < n; ++v) {
    if (!working_set.empty()) factor[v] *= working_set[v];
    if (!pinned.empty()) factor[v] *= 1.0f - pinned[v];
  }
  if (taper_rings <= 0) return factor;
  // Breadth-first ring distance from the vertices that may not move.
  constexpr std::uint32_t far = std::numeric_limits<std::uint32_t>::max();
  std::vector<std::uint32_t> ring(n, far);
  std::vector<std::uint32_t> frontier;
  for (std::size_t v = 0; v < n; ++v)
    if (factor[v] == 0.0f) {
      ring[v] = 0;
      frontier.push_back(std::uint32_t(v));
    }
  for (int r = 1; r <= taper_rings && !frontier.empty(); ++r) {
    std::vector<std::uint32_t> next;
    for (std::uint32_t v : frontier)
      for (std::uint32_t k = graph.offsets[v]; k < graph.offsets[v + 1]; ++k) {
        const std::uint32_t u = graph.indices[k];
        if (ring[u] == far) {
          ring[u] = std::uint32_t(r);
          next.push_back(u);
        }
      }
    frontier = std::move(next);
  }
  for (std::size_t v = 0; v < n; ++v)
    if (ring[v] != 0 && ring[v] != far) factor[v] *= float(ring[v]) / float(taper_rings + 1);
  return factor;
}

std::vector<Eigen::Vector3f> smooth_displacements(const VertexGraph& graph,
                                                  const std::vector<Eigen::Vector3f>& observed,
                                                  const std::vector<float>& weight,
                                                  const std::vector<std::uint8_t>& fixed, double lambda,
                                                  int sweeps) {
  const std::size_t n = graph.size();
  if (observed.size() != n || weight.size() != n || fixed.size() != n)
    throw UsageError("smooth_displacements: field sizes differ from the graph");
  std::vector<Eigen::Vector3f> current(n), next(n);
  for (std::size_t v = 0; v < n; ++v) current[v] = fixed[v] ? Eigen::Vector3f::Zero() : observed[v];
  if (lambda <= 0 || sweeps <= 0) return current;
  const float l = float(lambda);
  for (int sweep = 0; sweep < sweeps; ++sweep) {
    parallel_chunks(std::int64_t(n), 4096, [&](std::int64_t begin, std::int64_t end) {
      for (std::int64_t v = begin; v < end; ++v) {
        if (fixed[v]) {
          next[v].setZero();
          continue;
        }
        Eigen::Vector3f sum = Eigen::Vector3f::Zero();
        for (std::uint32_t k = graph.offsets[v]; k < graph.offsets[v + 1]; ++k)
          sum += current[graph.indices[k]];
        const float degree = float(graph.offsets[v + 1] - graph.offsets[v]);
        const float denominator = weight[v] + l * degree;
        next[v] = denominator > 0 ? Eigen::Vector3f((weight[v] * observed[v] + l * sum) / denominator)
                                  : Eigen::Vector3f::Zero();
      }
    });
    std::swap(current, next);
  }
  return current;
}

}  // namespace pg

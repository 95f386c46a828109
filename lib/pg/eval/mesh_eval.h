#pragma once
// A reconstructed surface against a ground-truth surface: accuracy (how far the estimate lies from
// the truth) and completeness (how far the truth lies from the estimate), measured from area-uniform
// surface samples plus the vertices, by closest-point queries on a BVH.
#include <Eigen/Core>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "pg/eval/stats.h"
#include "pg/mesh/mesh.h"

namespace pg {

struct MeshEvalOptions {
  std::size_t samples = 200000;  // area-uniform samples per surface, besides the vertices
  bool include_vertices = true;
  std::uint64_t seed = 1;          // same meshes and seed, same samples and numbers, at any thread count
  std::vector<double> thresholds;  // distances in scene units for precision / recall / F-score
};

struct MeshEvalResult {
  std::size_t estimate_points = 0, truth_points = 0;  // samples plus vertices measured on each side
  ErrorStats accuracy;                                // distances from estimate points to the truth surface
  ErrorStats completeness;                            // distances from truth points to the estimate surface
  double chamfer = 0;                                 // (accuracy.mean + completeness.mean) / 2
  std::vector<double> thresholds;
  std::vector<double> precision;  // fraction of estimate points within each threshold of the truth
  std::vector<double> recall;     // fraction of truth points within each threshold of the estimate
  std::vector<double> fscore;     // 2 P R / (P + R), 0 when both are 0

  nlohmann::json to_json() const;
  std::string to_text() const;
};

// `count` points uniformly distributed over the area of `mesh`, a pure function of (mesh, count, seed).
// Degenerate (zero-area) faces are never sampled. Returns nothing for a mesh without area.
std::vector<Eigen::Vector3f> sample_surface(const Mesh& mesh, std::size_t count, std::uint64_t seed);

// Throws FailedError when either mesh has no faces of non-zero area.
MeshEvalResult evaluate_mesh(const Mesh& estimate, const Mesh& truth, const MeshEvalOptions& options = {});

}  // namespace pg

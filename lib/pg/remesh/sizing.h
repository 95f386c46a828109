#pragma once
// Adaptive target edge lengths from curvature: an edge of length h on a circle of radius r = 1/k
// deviates from it by about e = h^2 k / 8 - ...; the usual bound h = sqrt(6 e / k - 3 e^2)
// (Dunyach et al. 2013) keeps the chord error near e.
#include <vector>

#include "pg/mesh/mesh.h"

namespace pg {

// Per vertex: the largest absolute principal curvature, from the cotangent mean curvature and the
// angle-deficit Gaussian curvature, averaged over the one-ring `averaging_rounds` times to calm
// noise. Boundary vertices (no full ring) take the mean of their interior neighbours.
std::vector<float> max_abs_curvature(const Mesh& mesh, int averaging_rounds = 2);

// Vertices on an edge used by one face only.
std::vector<bool> boundary_vertices(const Mesh& mesh);

// Per vertex target length sqrt(6 e / k - 3 e^2) clamped to [min_length, max_length].
std::vector<float> adaptive_target_lengths(const Mesh& mesh, float approximation_error, float min_length,
                                           float max_length);

}  // namespace pg

#pragma once
// Removal of small disconnected pieces (floaters) from extracted surfaces.
#include <cstddef>

#include "pg/mesh/mesh.h"

namespace pg::fusion {

// Removes every connected piece (faces sharing vertices) with fewer faces than
// max(min_faces, min_fraction * faces of the largest piece), then the vertices no face uses.
// Keeps per-vertex attributes and properties. Returns the number of pieces removed.
std::size_t remove_small_components(Mesh& mesh, std::size_t min_faces, double min_fraction);

// Drops vertices no face uses, renumbering faces; keeps per-vertex attributes and properties.
void remove_unused_vertices(Mesh& mesh);

}  // namespace pg::fusion

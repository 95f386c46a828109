#pragma once
// Repairs for meshes that are edge-manifold but pinched at vertices: where several separate fans of
// faces meet at one vertex (two cones touching at the apex, or a surface extracted from a volume after
// unobserved cells were dropped), each extra fan gets its own copy of the vertex. Half-edge tools
// (remeshing) need this; positions and attributes are unchanged.
#include <cstddef>

#include "pg/mesh/mesh.h"

namespace pg {

// Duplicates every vertex shared by more than one fan of faces (fans: faces around the vertex
// connected through edges that contain it). Copies are appended at the end with the same position,
// normal, colour, uv and named properties; faces of the extra fans are re-pointed to them. Returns the
// number of vertices added. Deterministic: depends only on the face order.
std::size_t split_nonmanifold_vertices(Mesh& mesh);

}  // namespace pg

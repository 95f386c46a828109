#pragma once
// Where to remesh: vertices a mask selects, or those that moved against a reference mesh, grown by
// rings of neighbours so the new triangles blend into the untouched ones.
#include <string>
#include <vector>

#include "pg/mesh/mesh.h"
#include "pg/mesh/vertex_mask.h"

namespace pg {

// Vertices whose position differs by more than `tolerance` between `before` and `after`. Throws
// InputError(before_name, ...) when `before` is not the same mesh (vertex count or faces differ).
std::vector<bool> deformed_vertices(const Mesh& after, const Mesh& before, float tolerance,
                                    const std::string& before_name);

// Adds, `rings` times, every vertex sharing a face with a selected one.
std::vector<bool> grow_region(const Mesh& mesh, std::vector<bool> region, int rings);

// Vertices with a weight above zero.
std::vector<bool> selected_vertices(const std::vector<float>& weights);

// Faces with at least one selected vertex (the region and its seam).
std::vector<bool> faces_touching(const Mesh& mesh, const std::vector<bool>& selected);

}  // namespace pg

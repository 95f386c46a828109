#pragma once
// Brush caches (formats/refine-caches.md): the pre-iteration and post-iteration states of a
// refinement, each a mesh file (PLY or OBJ) with the refined mesh's exact topology.
#include <filesystem>

#include "pg/mesh/mesh.h"

namespace pg {

// Writes `state` as a cache (atomically; PLY keeps the "displacement" property).
void write_refine_cache(const std::filesystem::path& path, const Mesh& state);

// Reads a cache and checks it belongs to `mesh`: InputError(path, ...) when its vertex count, face
// count or face list differ (a cache of another mesh, or of a remeshed one).
Mesh read_refine_cache(const std::filesystem::path& path, const Mesh& mesh);

// The same check for a mesh already read.
void check_same_topology(const Mesh& candidate, const Mesh& mesh,
                         const std::filesystem::path& candidate_file);

}  // namespace pg

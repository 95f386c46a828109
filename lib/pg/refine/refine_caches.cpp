#include "pg/refine/refine_caches.h"

#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/mesh/mesh_io.h"

namespace pg {

void write_refine_cache(const std::filesystem::path& path, const Mesh& state) {
  Mesh copy = state;
  copy.provenance = Provenance::current();
  write_mesh(path, copy);
}

void check_same_topology(const Mesh& candidate, const Mesh& mesh,
                         const std::filesystem::path& candidate_file) {
  const TopologyId have = topology_id(candidate), want = topology_id(mesh);
  if (have == want) return;
  throw InputError(candidate_file,
                   str("belongs to another mesh: ", have.vertex_count, " vertices and ", have.face_count,
                       " faces (faces ", have.faces_fnv1a64, ") but the mesh has ", want.vertex_count,
                       " vertices and ", want.face_count, " faces (faces ", want.faces_fnv1a64, ")"));
}

Mesh read_refine_cache(const std::filesystem::path& path, const Mesh& mesh) {
  Mesh cache = read_mesh(path);
  check_same_topology(cache, mesh, path);
  return cache;
}

}  // namespace pg

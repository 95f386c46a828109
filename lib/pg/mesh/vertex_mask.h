#pragma once
// Per-vertex weights in [0, 1] tied to one mesh's topology (formats/vertex-masks.md): which vertices
// a stage may move ("working_set"), must keep ("pinned"), or how strongly a brush acts ("brush_weight").
// The TopologyId survives vertex moves (refinement) and is refused on a remeshed mesh.
#include <filesystem>
#include <string>
#include <vector>

#include "pg/core/provenance.h"
#include "pg/mesh/mesh.h"

namespace pg {

struct VertexMask {
  std::string name;            // e.g. "working_set", "pinned", "brush_weight"; also the vertex property name
  TopologyId topology;         // the mesh it belongs to
  std::vector<float> weights;  // one per vertex, each in [0, 1]
  Provenance provenance;
};

enum class MaskEncoding {
  automatic,  // sparse when fewer than a quarter of the weights are non-zero, else dense
  dense,
  sparse,
};

// Throws InputError(path, ...) for a wrong format or version, a missing field, weights outside
// [0, 1] or NaN, indices out of range or repeated, or sizes that disagree with the topology.
VertexMask read_vertex_mask(const std::filesystem::path& path);
// Writes atomically; throws pg::Error (internal) when the mask itself is invalid.
void write_vertex_mask(const std::filesystem::path& path, const VertexMask& mask,
                       MaskEncoding encoding = MaskEncoding::automatic);

// Refuses (InputError naming mask_file) a mask made for a mesh with another vertex count, face
// count or face list.
void check_fits(const VertexMask& mask, const Mesh& mesh, const std::filesystem::path& mask_file);

// A mask from a named vertex property of `mesh`. Throws pg::Error (bad_input) when the property is
// missing or holds values outside [0, 1].
VertexMask mask_from_property(const Mesh& mesh, const std::string& property);
// Stores the mask's weights as the vertex property mask.name. Throws pg::Error (bad_input) when the
// mask does not fit the mesh.
void set_property_from_mask(Mesh& mesh, const VertexMask& mask);

}  // namespace pg

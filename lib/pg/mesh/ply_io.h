#pragma once
// Meshes as PLY files (formats/meshes.md).
#include <filesystem>

#include "pg/mesh/mesh.h"
#include "pg/mesh/ply_format.h"

namespace pg {

// Reads ascii, binary little- and big-endian PLY with any scalar types. Vertex x y z, nx ny nz,
// red green blue (uchar, or float in [0, 1]), uv as s t / u v / texture_u texture_v; every other
// scalar vertex property lands in vertex_properties. Polygons are fan-triangulated; unknown elements
// are skipped. Throws InputError(path, ...) for malformed, truncated or implausibly large files.
Mesh read_mesh_ply(const std::filesystem::path& path);

// Writes positions, faces and whichever attributes and properties are present, atomically, with
// "comment pg-format pg-mesh 1" and "comment pg-provenance <JSON>" (mesh.provenance).
void write_mesh_ply(const std::filesystem::path& path, const Mesh& mesh,
                    PlyEncoding encoding = PlyEncoding::binary_little_endian);

}  // namespace pg

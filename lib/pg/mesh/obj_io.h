#pragma once
// Meshes as Wavefront OBJ files (formats/meshes.md), and reading/writing a mesh by file extension.
#include <filesystem>

#include "pg/mesh/mesh.h"

namespace pg {

// Reads v (optionally "v x y z r g b" with colours in [0, 1]), vt, vn and f lines (v, v/vt, v//vn,
// v/vt/vn, negative indices, polygons fan-triangulated). A vertex used with different vt/vn pairs is
// split so the mesh stays per-vertex. Other statements (o, g, s, usemtl, mtllib, l, p) are ignored.
// Throws InputError(path, ...) naming the line for malformed input.
Mesh read_mesh_obj(const std::filesystem::path& path);

// Writes v/vt/vn/f with "# pg-format pg-mesh 1" and "# pg-provenance <JSON>" comments, atomically.
// OBJ cannot hold named vertex properties: they are dropped with a warning (use PLY to keep them).
void write_mesh_obj(const std::filesystem::path& path, const Mesh& mesh);

// By extension, case-insensitive: .ply or .obj. Other extensions: InputError / OutputError.
Mesh read_mesh(const std::filesystem::path& path);
void write_mesh(const std::filesystem::path& path, const Mesh& mesh);

}  // namespace pg

#pragma once
// The PLY container shared by meshes and point clouds (formats/meshes.md, formats/point-clouds.md):
// a bounded, validating reader of the vertex and face elements and a writer. Higher-level readers
// map the columns onto Mesh or PointCloud.
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <filesystem>
#include <initializer_list>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "pg/core/provenance.h"

namespace pg {

enum class PlyEncoding { ascii, binary_little_endian, binary_big_endian };

namespace ply {

enum class Type : std::uint8_t { int8, uint8, int16, uint16, int32, uint32, float32, float64 };
std::size_t size_of(Type type);
const char* name_of(Type type);  // the canonical PLY 1.0 name: char, uchar, short, ..., double

// One scalar vertex property. Every PLY scalar type converts to double exactly.
struct VertexColumn {
  std::string name;
  Type type = Type::float32;
  std::vector<double> values;
};

// A colour channel as uchar: uchar as is, float/double in [0, 1] scaled by 255, ushort divided by 257,
// other integers clamped to [0, 255].
std::uint8_t color_channel(const VertexColumn& column, double value);

struct Contents {
  PlyEncoding encoding = PlyEncoding::ascii;
  std::vector<std::string> comments;  // text after "comment ", in file order
  std::uint64_t vertex_count = 0;
  std::vector<VertexColumn> vertex_columns;  // scalar vertex properties in file order
  bool has_faces = false;
  std::vector<std::array<std::uint32_t, 3>> triangles;  // polygons fan-triangulated

  const VertexColumn* find(std::string_view name) const;
};

// Reads a PLY file. With read_faces false the face element is skipped like any unknown element.
// Throws InputError(path, ...) for anything malformed, truncated or implausibly large.
Contents read(const std::filesystem::path& path, bool read_faces);

// Meshes and point clouds: positions and normals must be finite (conventions.md: readers reject
// non-finite numbers); other properties may use NaN for "none". Scans skip such points instead
// (rgbd-inputs.md). Throws InputError(path, ...) naming the vertex.
void require_finite_positions(const Contents& contents, const std::filesystem::path& path);

// The pg-format comment must name one of `accepted_formats` with a version <= 1 when present; the
// pg-provenance comment, when present, is parsed into `provenance`.
void read_pg_comments(const Contents& contents, const std::filesystem::path& path,
                      std::initializer_list<std::string_view> accepted_formats, Provenance& provenance);

// A vertex column to write: `count` values of `type` at data, data + stride, data + 2 * stride...
struct OutColumn {
  std::string name;
  Type type = Type::float32;
  const void* data = nullptr;
  std::size_t stride = 0;  // bytes between consecutive vertices
};

struct WriteRequest {
  PlyEncoding encoding = PlyEncoding::binary_little_endian;
  std::string format_name;  // written as "comment pg-format <name> 1"
  Provenance provenance;    // written as "comment pg-provenance <one-line JSON>"
  std::size_t vertex_count = 0;
  std::vector<OutColumn> columns;
  bool write_faces = false;
  std::span<const std::array<std::uint32_t, 3>> faces;
};

// Appends the standard point columns: x y z, then nx ny nz and red green blue unless those vectors are
// empty. Without positions, only the three coordinate columns (a file of no vertices).
void add_point_columns(WriteRequest& request, const std::vector<Eigen::Vector3f>& positions,
                       const std::vector<Eigen::Vector3f>& normals,
                       const std::vector<std::array<std::uint8_t, 3>>& colors);

// Writes atomically; throws OutputError on failure or on property names PLY cannot hold.
void write(const std::filesystem::path& path, const WriteRequest& request);

}  // namespace ply
}  // namespace pg

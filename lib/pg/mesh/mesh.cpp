#include "pg/mesh/mesh.h"

#include "pg/core/error.h"
#include "pg/core/hash.h"
#include "pg/core/log.h"

namespace pg {
namespace {

void check_size(const char* what, std::size_t size, std::size_t vertex_count) {
  if (size != 0 && size != vertex_count)
    throw Error(ExitCode::internal,
                str("mesh: ", what, " has ", size, " entries for ", vertex_count, " vertices"));
}

}  // namespace

void Mesh::check_consistent() const {
  const std::size_t n = positions.size();
  if (n > max_vertex_count) throw Error(ExitCode::internal, str("mesh: ", n, " vertices is too many"));
  check_size("normals", normals.size(), n);
  check_size("colors", colors.size(), n);
  check_size("uvs", uvs.size(), n);
  for (const auto& [name, values] : vertex_properties)
    check_size(("vertex property \"" + name + "\"").c_str(), values.size(), n);
  for (std::size_t f = 0; f < faces.size(); ++f)
    for (std::uint32_t v : faces[f])
      if (v >= n) throw Error(ExitCode::internal, str("mesh: face ", f, " uses vertex ", v, " of ", n));
}

void Mesh::compute_vertex_normals() {
  // The cross product's length is twice the triangle area, so summing unnormalised face normals
  // weights each face by its area. Vertices on no face (or only degenerate ones) get a zero normal.
  normals.assign(positions.size(), Eigen::Vector3f::Zero());
  for (const auto& f : faces) {
    const Eigen::Vector3f n = (positions[f[1]] - positions[f[0]]).cross(positions[f[2]] - positions[f[0]]);
    for (std::uint32_t v : f) normals[v] += n;
  }
  for (auto& n : normals) {
    const float length = n.norm();
    if (length > 0) n /= length;
  }
}

void Mesh::update_moved_normals(const std::vector<Eigen::Vector3f>& before) {
  if (normals.empty()) return;
  std::vector<std::uint8_t> affected(positions.size(), 0);
  for (const auto& f : faces)
    if (positions[f[0]] != before[f[0]] || positions[f[1]] != before[f[1]] || positions[f[2]] != before[f[2]])
      for (std::uint32_t v : f) affected[v] = 1;
  const std::vector<Eigen::Vector3f> kept = normals;
  compute_vertex_normals();
  for (std::size_t v = 0; v < positions.size(); ++v)
    if (!affected[v]) normals[v] = kept[v];
}

Eigen::AlignedBox3f Mesh::bounds() const {
  Eigen::AlignedBox3f box;  // default constructed empty
  for (const auto& p : positions) box.extend(p);
  return box;
}

TopologyId topology_id(const Mesh& mesh) {
  // Hash the faces as little-endian uint32 triples, independent of the host's byte order.
  std::uint64_t hash = fnv1a64(nullptr, 0);
  constexpr std::size_t faces_per_block = 4096;
  std::vector<std::uint8_t> block;
  block.reserve(faces_per_block * 12);
  for (std::size_t begin = 0; begin < mesh.faces.size(); begin += faces_per_block) {
    const std::size_t end = std::min(mesh.faces.size(), begin + faces_per_block);
    block.clear();
    for (std::size_t f = begin; f < end; ++f)
      for (std::uint32_t v : mesh.faces[f])
        for (int byte = 0; byte < 4; ++byte) block.push_back(std::uint8_t(v >> (8 * byte)));
    hash = fnv1a64(block.data(), block.size(), hash);
  }
  TopologyId id;
  id.vertex_count = mesh.positions.size();
  id.face_count = mesh.faces.size();
  id.faces_fnv1a64 = hex64(hash);
  return id;
}

}  // namespace pg

#pragma once
// A triangle mesh as flat arrays (cache-friendly for the rasterizer, BVH and TSDF), with optional
// per-vertex attributes and named per-vertex properties (formats/meshes.md). Algorithms that need
// connectivity (remeshing) convert to OpenMesh.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "pg/core/provenance.h"

namespace pg {

struct Mesh {
  std::vector<Eigen::Vector3f> positions;
  std::vector<std::array<std::uint32_t, 3>> faces;  // counter-clockwise seen from outside
  std::vector<Eigen::Vector3f> normals;             // per vertex, empty or positions.size()
  std::vector<std::array<std::uint8_t, 3>> colors;  // per vertex RGB, empty or positions.size()
  std::vector<Eigen::Vector2f> uvs;                 // per vertex, empty or positions.size()
  // Named per-vertex float properties: "quality", "working_set", "pinned", "brush_weight", "confidence"...
  // Each vector is empty or positions.size(). Bool properties are stored as 0/1 floats.
  std::map<std::string, std::vector<float>> vertex_properties;
  Provenance provenance;  // as read from the file, or set before writing

  std::size_t vertex_count() const { return positions.size(); }
  std::size_t face_count() const { return faces.size(); }
  // Throws std::invalid_argument-like pg::Error (internal) if attribute sizes or face indices are
  // inconsistent.
  void check_consistent() const;
  // Area-weighted vertex normals from the faces.
  void compute_vertex_normals();
  // After vertices moved from `before` (the positions they had; same count): the area-weighted
  // normal of every vertex on a face that changed shape, when the mesh has normals. Other vertices
  // keep theirs (authored normals where nothing moved stay as they were).
  void update_moved_normals(const std::vector<Eigen::Vector3f>& before);
  // Empty box when there are no vertices.
  Eigen::AlignedBox3f bounds() const;
};

// Largest vertex count any mesh, point-cloud or mask reader accepts (faces index vertices as uint32).
inline constexpr std::uint64_t max_vertex_count = (std::uint64_t{1} << 31) - 1;

// Identity of a mesh's connectivity: vertex count, face count and FNV-1a 64 of the face index list.
// Stays the same when vertices move (refinement), changes when topology changes (remeshing).
struct TopologyId {
  std::uint64_t vertex_count = 0;
  std::uint64_t face_count = 0;
  std::string faces_fnv1a64;  // 16 lowercase hex digits
  bool operator==(const TopologyId&) const = default;
};
TopologyId topology_id(const Mesh& mesh);

}  // namespace pg

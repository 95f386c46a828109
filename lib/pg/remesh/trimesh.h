#pragma once
// The OpenMesh half-edge mesh the remesher works on, and the conversion from pg::Mesh that refuses
// non-manifold input with the places where it is non-manifold.
#include <OpenMesh/Core/IO/MeshIO.hh>  // must precede the mesh headers
#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <string>

#include "pg/mesh/mesh.h"

namespace pg {

struct RemeshTraits : public OpenMesh::DefaultTraits {
  using Point = OpenMesh::Vec3f;
  VertexAttributes(OpenMesh::Attributes::Status);
  EdgeAttributes(OpenMesh::Attributes::Status);
  HalfedgeAttributes(OpenMesh::Attributes::Status);
  FaceAttributes(OpenMesh::Attributes::Status);
};
using TriMesh = OpenMesh::TriMesh_ArrayKernelT<RemeshTraits>;

inline Eigen::Vector3f to_eigen(const OpenMesh::Vec3f& p) {
  return {p[0], p[1], p[2]};
}
inline OpenMesh::Vec3f to_openmesh(const Eigen::Vector3f& p) {
  return {p.x(), p.y(), p.z()};
}

// Up to `limit` descriptions of non-manifold places ("edge (3, 9) is shared by 3 faces at (x, y, z)",
// "vertex 7 joins 2 separate fans of faces at (x, y, z)", "face 12 repeats vertex 4"), and the total
// number found. Empty when the mesh is a manifold (with or without boundary), consistently oriented.
struct ManifoldCheck {
  std::vector<std::string> places;
  std::size_t count = 0;
};
ManifoldCheck find_non_manifold(const Mesh& mesh, std::size_t limit = 5);

// Vertex i and face f of `mesh` become handles i and f. Throws InputError(name, ...) listing where
// the mesh is non-manifold. Unused vertices must have been dropped first.
TriMesh to_trimesh(const Mesh& mesh, const std::string& name);

}  // namespace pg

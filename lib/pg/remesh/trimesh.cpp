#include "pg/remesh/trimesh.h"

#include <algorithm>
#include <unordered_map>

#include "pg/core/error.h"
#include "pg/core/log.h"

namespace pg {
namespace {

std::string at(const Eigen::Vector3f& p) {
  return str("(", p.x(), ", ", p.y(), ", ", p.z(), ")");
}

std::uint64_t edge_key(std::uint32_t a, std::uint32_t b) {
  return (std::uint64_t(std::min(a, b)) << 32) | std::max(a, b);
}

struct Problems {
  ManifoldCheck check;
  std::size_t limit;
  void add(std::string text) {
    if (check.places.size() < limit) check.places.push_back(std::move(text));
    ++check.count;
  }
};

// Counts, per undirected edge, the faces using it in each direction.
void check_edges(const Mesh& mesh, Problems& problems) {
  struct Use {
    std::uint32_t forward = 0, backward = 0;
  };
  std::unordered_map<std::uint64_t, Use> uses;
  uses.reserve(mesh.faces.size() * 2);
  for (const auto& f : mesh.faces)
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t a = f[k], b = f[(k + 1) % 3];
      Use& use = uses[edge_key(a, b)];
      (a < b ? use.forward : use.backward)++;
    }
  std::vector<std::uint64_t> bad;
  for (const auto& [key, use] : uses)
    if (use.forward + use.backward > 2 || use.forward > 1 || use.backward > 1) bad.push_back(key);
  std::sort(bad.begin(), bad.end());  // report in a stable order
  for (std::uint64_t key : bad) {
    const auto a = std::uint32_t(key >> 32), b = std::uint32_t(key & 0xffffffffu);
    const Use& use = uses[key];
    const Eigen::Vector3f where = 0.5f * (mesh.positions[a] + mesh.positions[b]);
    if (use.forward + use.backward > 2)
      problems.add(
          str("edge (", a, ", ", b, ") is shared by ", use.forward + use.backward, " faces at ", at(where)));
    else
      problems.add(str("edge (", a, ", ", b, ") joins two faces of opposite orientation at ", at(where)));
  }
}

// Checks the mesh and builds the half-edge mesh in `tri` on the way.
ManifoldCheck check_and_build(const Mesh& mesh, std::size_t limit, TriMesh& tri) {
  Problems problems{{}, limit};
  for (std::size_t f = 0; f < mesh.faces.size(); ++f) {
    const auto& v = mesh.faces[f];
    if (v[0] == v[1] || v[1] == v[2] || v[0] == v[2])
      problems.add(str("face ", f, " repeats a vertex (", v[0], ", ", v[1], ", ", v[2], ") at ",
                       at(mesh.positions[v[0]])));
  }
  check_edges(mesh, problems);
  if (problems.check.count > 0) return problems.check;

  // Edges are fine; a vertex can still join several fans of faces (two cones touching at the apex).
  tri.reserve(mesh.positions.size(), mesh.faces.size() * 3 / 2 + 3, mesh.faces.size());
  for (const auto& p : mesh.positions) tri.add_vertex(to_openmesh(p));
  std::vector<std::uint32_t> faces_at(mesh.positions.size(), 0);
  for (std::size_t f = 0; f < mesh.faces.size(); ++f) {
    const auto& v = mesh.faces[f];
    for (std::uint32_t i : v) ++faces_at[i];
    const auto face = tri.add_face(TriMesh::VertexHandle(int(v[0])), TriMesh::VertexHandle(int(v[1])),
                                   TriMesh::VertexHandle(int(v[2])));
    if (!face.is_valid())
      problems.add(str("face ", f, " (", v[0], ", ", v[1], ", ", v[2],
                       ") meets its neighbours at a non-manifold vertex near ", at(mesh.positions[v[0]])));
  }
  if (problems.check.count > 0) return problems.check;
  for (std::size_t i = 0; i < mesh.positions.size(); ++i) {
    const TriMesh::VertexHandle v{int(i)};
    std::uint32_t around = 0, gaps = 0;
    for (const auto h : tri.voh_range(v)) {
      around += !tri.is_boundary(h);
      gaps += tri.is_boundary(h);
    }
    if (around != faces_at[i] || gaps > 1)
      problems.add(str("vertex ", i, " joins separate fans of faces at ", at(mesh.positions[i])));
  }
  return problems.check;
}

}  // namespace

ManifoldCheck find_non_manifold(const Mesh& mesh, std::size_t limit) {
  TriMesh tri;
  return check_and_build(mesh, limit, tri);
}

TriMesh to_trimesh(const Mesh& mesh, const std::string& name) {
  TriMesh tri;
  const ManifoldCheck check = check_and_build(mesh, 5, tri);
  if (check.count > 0) {
    std::string text =
        str("the mesh is not a manifold in ", check.count, " place", check.count > 1 ? "s" : "", ": ");
    for (std::size_t i = 0; i < check.places.size(); ++i) text += (i ? "; " : "") + check.places[i];
    if (check.count > check.places.size()) text += "; ...";
    throw InputError(name, text);
  }
  return tri;
}

}  // namespace pg

#include "pg/mesh/manifold.h"

#include <numeric>
#include <vector>

namespace pg {
namespace {

struct UnionFind {
  std::vector<std::uint32_t> parent;
  explicit UnionFind(std::size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0u); }
  std::uint32_t find(std::uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  }
  void unite(std::uint32_t a, std::uint32_t b) {
    a = find(a), b = find(b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
};

template <class T>
void append_copy(std::vector<T>& values, std::uint32_t from) {
  if (!values.empty()) values.push_back(values[from]);
}

}  // namespace

std::size_t split_nonmanifold_vertices(Mesh& mesh) {
  const std::size_t n = mesh.positions.size();
  // Faces around each vertex (CSR), in face order.
  std::vector<std::uint32_t> offsets(n + 1, 0);
  for (const auto& f : mesh.faces)
    for (std::uint32_t v : f) ++offsets[v + 1];
  std::partial_sum(offsets.begin(), offsets.end(), offsets.begin());
  std::vector<std::uint32_t> around(offsets[n]);
  std::vector<std::uint32_t> fill(offsets.begin(), offsets.end() - 1);
  for (std::uint32_t f = 0; f < mesh.faces.size(); ++f)
    for (std::uint32_t v : mesh.faces[f]) around[fill[v]++] = f;

  std::size_t added = 0;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> first_face_with;  // (other vertex, local face)
  for (std::uint32_t v = 0; v < n; ++v) {
    const std::uint32_t begin = offsets[v], count = offsets[v + 1] - begin;
    if (count < 2) continue;
    // Two faces around v are in one fan when they share an edge (v, x): union them by x.
    UnionFind fans(count);
    first_face_with.clear();
    for (std::uint32_t i = 0; i < count; ++i)
      for (std::uint32_t x : mesh.faces[around[begin + i]])
        if (x != v) first_face_with.emplace_back(x, i);
    std::sort(first_face_with.begin(), first_face_with.end());
    for (std::size_t k = 1; k < first_face_with.size(); ++k)
      if (first_face_with[k].first == first_face_with[k - 1].first)
        fans.unite(first_face_with[k].second, first_face_with[k - 1].second);
    // The fan holding the first face keeps v; each other fan gets a copy.
    std::vector<std::uint32_t> copy_of_root(count, UINT32_MAX);
    const std::uint32_t keep_root = fans.find(0);
    for (std::uint32_t i = 0; i < count; ++i) {
      const std::uint32_t root = fans.find(i);
      if (root == keep_root) continue;
      if (copy_of_root[root] == UINT32_MAX) {
        copy_of_root[root] = std::uint32_t(mesh.positions.size());
        mesh.positions.push_back(mesh.positions[v]);
        append_copy(mesh.normals, v);
        append_copy(mesh.colors, v);
        append_copy(mesh.uvs, v);
        for (auto& [name, values] : mesh.vertex_properties) append_copy(values, v);
        ++added;
      }
      for (std::uint32_t& corner : mesh.faces[around[begin + i]])
        if (corner == v) corner = copy_of_root[root];
    }
  }
  return added;
}

}  // namespace pg

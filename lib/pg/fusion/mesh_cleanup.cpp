#include "pg/fusion/mesh_cleanup.h"

#include <algorithm>
#include <numeric>
#include <vector>

namespace pg::fusion {
namespace {

std::uint32_t find_root(std::vector<std::uint32_t>& parent, std::uint32_t v) {
  while (parent[v] != v) v = parent[v] = parent[parent[v]];
  return v;
}

template <class T>
void keep_entries(std::vector<T>& values, const std::vector<std::uint32_t>& new_index, std::size_t count) {
  if (values.empty()) return;
  std::vector<T> kept(count);
  for (std::size_t i = 0; i < new_index.size(); ++i)
    if (new_index[i] != UINT32_MAX) kept[new_index[i]] = values[i];
  values = std::move(kept);
}

}  // namespace

void remove_unused_vertices(Mesh& mesh) {
  std::vector<std::uint32_t> new_index(mesh.positions.size(), UINT32_MAX);
  std::uint32_t count = 0;
  for (auto& face : mesh.faces)
    for (auto& v : face) {
      if (new_index[v] == UINT32_MAX) new_index[v] = count++;
      v = new_index[v];
    }
  keep_entries(mesh.positions, new_index, count);
  keep_entries(mesh.normals, new_index, count);
  keep_entries(mesh.colors, new_index, count);
  keep_entries(mesh.uvs, new_index, count);
  for (auto& [name, values] : mesh.vertex_properties) keep_entries(values, new_index, count);
}

std::size_t remove_small_components(Mesh& mesh, std::size_t min_faces, double min_fraction) {
  std::vector<std::uint32_t> parent(mesh.positions.size());
  std::iota(parent.begin(), parent.end(), 0u);
  for (const auto& f : mesh.faces) {
    const std::uint32_t a = find_root(parent, f[0]);
    for (int k = 1; k < 3; ++k) {
      const std::uint32_t b = find_root(parent, f[k]);
      if (a != b) parent[b] = a;
    }
  }
  std::vector<std::size_t> faces_of(mesh.positions.size(), 0);
  for (const auto& f : mesh.faces) ++faces_of[find_root(parent, f[0])];
  const std::size_t largest = faces_of.empty() ? 0 : *std::max_element(faces_of.begin(), faces_of.end());
  const double threshold = std::max(double(min_faces), min_fraction * double(largest));
  std::size_t removed = 0;
  for (std::size_t v = 0; v < faces_of.size(); ++v)
    removed += faces_of[v] > 0 && double(faces_of[v]) < threshold;
  std::erase_if(mesh.faces,
                [&](const auto& f) { return double(faces_of[find_root(parent, f[0])]) < threshold; });
  remove_unused_vertices(mesh);
  return removed;
}

}  // namespace pg::fusion

#include "pg/remesh/region.h"

#include "pg/core/error.h"
#include "pg/core/log.h"

namespace pg {

std::vector<bool> deformed_vertices(const Mesh& after, const Mesh& before, float tolerance,
                                    const std::string& before_name) {
  if (before.vertex_count() != after.vertex_count() || before.faces != after.faces)
    throw InputError(before_name,
                     str("is not the same mesh as the input (", before.vertex_count(), " vertices and ",
                         before.face_count(), " faces against ", after.vertex_count(), " and ",
                         after.face_count(), ", or other faces)"));
  std::vector<bool> moved(after.vertex_count());
  for (std::size_t i = 0; i < moved.size(); ++i)
    moved[i] = (after.positions[i] - before.positions[i]).norm() > tolerance;
  return moved;
}

std::vector<bool> grow_region(const Mesh& mesh, std::vector<bool> region, int rings) {
  for (int ring = 0; ring < rings; ++ring) {
    std::vector<bool> grown = region;
    for (const auto& f : mesh.faces)
      if (region[f[0]] || region[f[1]] || region[f[2]]) grown[f[0]] = grown[f[1]] = grown[f[2]] = true;
    region = std::move(grown);
  }
  return region;
}

std::vector<bool> selected_vertices(const std::vector<float>& weights) {
  std::vector<bool> selected(weights.size());
  for (std::size_t i = 0; i < weights.size(); ++i) selected[i] = weights[i] > 0;
  return selected;
}

std::vector<bool> faces_touching(const Mesh& mesh, const std::vector<bool>& selected) {
  std::vector<bool> faces(mesh.face_count());
  for (std::size_t f = 0; f < faces.size(); ++f) {
    const auto& v = mesh.faces[f];
    faces[f] = selected[v[0]] || selected[v[1]] || selected[v[2]];
  }
  return faces;
}

}  // namespace pg

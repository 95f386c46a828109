#include "pg/synth/shapes.h"

#include <Eigen/Geometry>
#include <map>

namespace pg::synth {

std::uint32_t MeshBuilder::add_vertex(const Eigen::Vector3f& p) {
  mesh.positions.push_back(p);
  return std::uint32_t(mesh.positions.size() - 1);
}

void MeshBuilder::add_face(std::uint32_t a, std::uint32_t b, std::uint32_t c, int material) {
  mesh.faces.push_back({a, b, c});
  face_material.push_back(material);
}

void MeshBuilder::add_grid(int nu, int nv, const std::function<Eigen::Vector3f(float, float)>& point,
                           int material) {
  auto base = std::uint32_t(mesh.positions.size());
  for (int j = 0; j <= nv; ++j)
    for (int i = 0; i <= nu; ++i) add_vertex(point(float(i) / float(nu), float(j) / float(nv)));
  auto at = [&](int i, int j) { return base + std::uint32_t(j * (nu + 1) + i); };
  for (int j = 0; j < nv; ++j)
    for (int i = 0; i < nu; ++i) {
      // Alternate the diagonal so the grid has no directional bias.
      if ((i + j) % 2 == 0) {
        add_face(at(i, j), at(i + 1, j), at(i + 1, j + 1), material);
        add_face(at(i, j), at(i + 1, j + 1), at(i, j + 1), material);
      } else {
        add_face(at(i, j), at(i + 1, j), at(i, j + 1), material);
        add_face(at(i + 1, j), at(i + 1, j + 1), at(i, j + 1), material);
      }
    }
}

void MeshBuilder::add_box(const Eigen::Vector3f& centre, const Eigen::Vector3f& size, float yaw,
                          int subdivisions, int material, bool inward) {
  Eigen::Matrix3f r = Eigen::AngleAxisf(yaw, Eigen::Vector3f::UnitZ()).toRotationMatrix();
  Eigen::Vector3f h = size / 2;
  // Each side: origin corner and two edge vectors with e1 x e2 pointing out of the box.
  struct Side {
    Eigen::Vector3f origin, e1, e2;
  };
  const Side sides[6] = {
      {{-1, -1, -1}, {0, 2, 0}, {2, 0, 0}},  // bottom (-z)
      {{-1, -1, 1}, {2, 0, 0}, {0, 2, 0}},   // top (+z)
      {{-1, -1, -1}, {2, 0, 0}, {0, 0, 2}},  // -y
      {{1, 1, -1}, {-2, 0, 0}, {0, 0, 2}},   // +y
      {{-1, 1, -1}, {0, -2, 0}, {0, 0, 2}},  // -x
      {{1, -1, -1}, {0, 2, 0}, {0, 0, 2}},   // +x
  };
  for (const Side& s : sides) {
    Eigen::Vector3f e1 = s.e1, e2 = s.e2, o = s.origin;
    if (inward) std::swap(e1, e2), o = s.origin;
    add_grid(
        subdivisions, subdivisions,
        [&](float u, float v) {
          Eigen::Vector3f local = o + u * e1 + v * e2;
          return Eigen::Vector3f(centre + r * local.cwiseProduct(h));
        },
        material);
  }
}

void MeshBuilder::add_sphere(const Eigen::Vector3f& centre, int level,
                             const std::function<float(const Eigen::Vector3f&)>& radius, int material) {
  const float t = (1.0f + std::sqrt(5.0f)) / 2.0f;
  std::vector<Eigen::Vector3f> dirs = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0},
                                       {0, -1, t}, {0, 1, t}, {0, -1, -t}, {0, 1, -t},
                                       {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  for (auto& d : dirs) d.normalize();
  std::vector<std::array<std::uint32_t, 3>> tris = {
      {0, 11, 5},  {0, 5, 1},  {0, 1, 7},  {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
      {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
      {3, 8, 9},   {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  for (int l = 0; l < level; ++l) {
    std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> midpoints;
    auto midpoint = [&](std::uint32_t a, std::uint32_t b) {
      auto key = std::minmax(a, b);
      auto it = midpoints.find(key);
      if (it != midpoints.end()) return it->second;
      dirs.push_back((dirs[a] + dirs[b]).normalized());
      auto index = std::uint32_t(dirs.size() - 1);
      midpoints.emplace(key, index);
      return index;
    };
    std::vector<std::array<std::uint32_t, 3>> next;
    next.reserve(tris.size() * 4);
    for (const auto& f : tris) {
      std::uint32_t a = midpoint(f[0], f[1]), b = midpoint(f[1], f[2]), c = midpoint(f[2], f[0]);
      next.push_back({f[0], a, c});
      next.push_back({f[1], b, a});
      next.push_back({f[2], c, b});
      next.push_back({a, b, c});
    }
    tris.swap(next);
  }
  auto base = std::uint32_t(mesh.positions.size());
  for (const auto& d : dirs) add_vertex(centre + radius(d) * d);
  for (const auto& f : tris) add_face(base + f[0], base + f[1], base + f[2], material);
}

}  // namespace pg::synth

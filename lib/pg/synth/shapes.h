#pragma once
// Mesh builders for the synthetic scenes. Each appends to a mesh and records a material per face.
#include <Eigen/Core>
#include <functional>
#include <vector>

#include "pg/mesh/mesh.h"

namespace pg::synth {

// A mesh plus the material of each face, built up piece by piece.
struct MeshBuilder {
  Mesh mesh;
  std::vector<int> face_material;

  std::uint32_t add_vertex(const Eigen::Vector3f& p);
  void add_face(std::uint32_t a, std::uint32_t b, std::uint32_t c, int material);

  // Regular grid over [x0,x1] x [y0,y1] in its own (u, v) parameters mapped to 3-D by `point`;
  // faces wound so that d(point)/du x d(point)/dv is the outside.
  void add_grid(int nu, int nv, const std::function<Eigen::Vector3f(float u, float v)>& point, int material);
  // Axis-aligned box rotated by `yaw` about z, outward facing, each side a `subdivisions`^2 grid.
  void add_box(const Eigen::Vector3f& centre, const Eigen::Vector3f& size, float yaw, int subdivisions,
               int material, bool inward = false);
  // Icosphere of `level` subdivisions, radius given per unit direction (displaced spheres).
  void add_sphere(const Eigen::Vector3f& centre, int level,
                  const std::function<float(const Eigen::Vector3f&)>& radius, int material);
};

}  // namespace pg::synth

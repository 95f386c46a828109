#pragma once
// The input surface the remesher projects onto: closest points on its triangles (through a BVH),
// barycentric interpolation of per-vertex values there, and closest points on its feature lines.
#include <Eigen/Core>
#include <array>
#include <memory>
#include <vector>

#include "pg/mesh/bvh.h"
#include "pg/mesh/mesh.h"

namespace pg {

using Segment = std::array<Eigen::Vector3f, 2>;

class ReferenceSurface {
 public:
  // Copies what it needs from `mesh`; `features` are the input's feature edges (may be empty).
  ReferenceSurface(const Mesh& mesh, std::vector<Segment> features);

  struct Location {
    std::uint32_t face = 0;
    Eigen::Vector3f point = Eigen::Vector3f::Zero();
    Eigen::Vector3f barycentric = Eigen::Vector3f(1, 0, 0);  // weights of the face's three vertices
  };
  // The closest point on the surface.
  Location locate(const Eigen::Vector3f& p) const;
  // The closest point on any feature segment; p itself when there are none.
  Eigen::Vector3f closest_on_features(const Eigen::Vector3f& p) const;
  // sum_k barycentric[k] * values[face vertex k]
  float interpolate(const std::vector<float>& values, const Location& at) const;
  const std::array<std::uint32_t, 3>& face(std::uint32_t f) const { return faces_[f]; }

 private:
  std::vector<Eigen::Vector3f> positions_;
  std::vector<std::array<std::uint32_t, 3>> faces_;
  TriangleBvh surface_;
  std::unique_ptr<TriangleBvh> features_;  // degenerate triangles (a, b, b): closest points on segments
};

// Barycentric coordinates of p (on or near triangle a b c) clamped to the triangle.
Eigen::Vector3f barycentric(const Eigen::Vector3f& p, const Eigen::Vector3f& a, const Eigen::Vector3f& b,
                            const Eigen::Vector3f& c);

}  // namespace pg

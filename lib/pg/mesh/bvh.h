#pragma once
// A bounding volume hierarchy over a mesh's triangles for closest-point and ray queries (used by
// refinement, projection of masks and the rasterizer's visibility tests). Binned-SAH build, flat
// node array, stack traversal. Const queries are thread-safe.
#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <vector>

#include "pg/mesh/mesh.h"

namespace pg {

class TriangleBvh {
 public:
  explicit TriangleBvh(const Mesh& mesh);  // copies what it needs; mesh may be destroyed after

  struct ClosestHit {
    float distance = INFINITY;
    std::uint32_t face = UINT32_MAX;
    Eigen::Vector3f point = Eigen::Vector3f::Constant(NAN);
  };
  // The closest point on any triangle within max_distance (inclusive); face UINT32_MAX when none.
  ClosestHit closest_point(const Eigen::Vector3f& query, float max_distance = INFINITY) const;

  struct RayHit {
    bool hit = false;
    float t = INFINITY;
    std::uint32_t face = UINT32_MAX;
    float b1 = 0, b2 = 0;  // hit point = (1 - b1 - b2) * v0 + b1 * v1 + b2 * v2 of the face
  };
  // The nearest hit with 0 <= t <= t_max along origin + t * direction (direction need not be unit;
  // t is in its units). Both triangle sides count.
  RayHit intersect(const Eigen::Vector3f& origin, const Eigen::Vector3f& direction,
                   float t_max = INFINITY) const;

  std::size_t face_count() const { return face_ids_.size(); }

 private:
  struct Node {
    Eigen::Vector3f lo, hi;
    std::uint32_t first = 0;  // leaf: first triangle; inner: left child (right child = first + 1)
    std::uint32_t count = 0;  // leaf: triangle count; 0 for inner nodes
  };
  struct Triangle {
    Eigen::Vector3f a, b, c;
  };
  struct Builder;

  std::vector<Node> nodes_;
  std::vector<Triangle> triangles_;      // in leaf order
  std::vector<std::uint32_t> face_ids_;  // mesh face index of each entry of triangles_
};

// Exact closest point to p on triangle (a, b, c) (Ericson, Real-Time Collision Detection 5.1.5);
// degenerate triangles are handled as their edges.
Eigen::Vector3f closest_point_on_triangle(const Eigen::Vector3f& p, const Eigen::Vector3f& a,
                                          const Eigen::Vector3f& b, const Eigen::Vector3f& c);

}  // namespace pg

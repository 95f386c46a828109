#include "pg/mesh/bvh.h"

#include <algorithm>
#include <array>
#include <atomic>

#include <tbb/parallel_invoke.h>

#include "pg/core/error.h"

namespace pg {
namespace {

using Vec3 = Eigen::Vector3f;

constexpr int bin_count = 16;
constexpr std::uint32_t max_leaf_size = 4;
// Past this depth the builder splits at the median, so the depth (and the traversal stack) stays bounded.
constexpr int max_sah_depth = 48;
constexpr int stack_size = 128;
// Ranges at least this large build their two children in parallel.
constexpr std::uint32_t parallel_threshold = 1 << 15;
// Ranges larger than this are binned along one axis only.
constexpr std::uint32_t all_axes_below = 1 << 12;

struct Box {
  Vec3 lo = Vec3::Constant(INFINITY), hi = Vec3::Constant(-INFINITY);
  void extend(const Vec3& p) {
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], p[k]);
      hi[k] = std::max(hi[k], p[k]);
    }
  }
  void extend(const Box& b) {
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], b.lo[k]);
      hi[k] = std::max(hi[k], b.hi[k]);
    }
  }
  float half_area() const {
    if (!(hi.x() >= lo.x())) return 0;
    const Vec3 e = hi - lo;
    return e.x() * e.y() + e.y() * e.z() + e.z() * e.x();
  }
};

Vec3 closest_on_segment(const Vec3& p, const Vec3& a, const Vec3& b) {
  const Vec3 ab = b - a;
  const float length2 = ab.squaredNorm();
  const float t = length2 > 0 ? std::clamp((p - a).dot(ab) / length2, 0.0f, 1.0f) : 0.0f;
  return a + t * ab;
}

float box_distance2(const Vec3& lo, const Vec3& hi, const Vec3& p) {
  return (lo - p).cwiseMax(p - hi).cwiseMax(0.0f).squaredNorm();
}

// Entry distance of the ray into the box, or INFINITY when it misses within [0, t_max].
float ray_box(const Vec3& lo, const Vec3& hi, const Vec3& origin, const Vec3& inv_direction, float t_max) {
  float t_near = 0, t_far = t_max;
  for (int k = 0; k < 3; ++k) {
    float t0 = (lo[k] - origin[k]) * inv_direction[k];
    float t1 = (hi[k] - origin[k]) * inv_direction[k];
    if (t0 > t1) std::swap(t0, t1);
    // Written so a NaN (origin on a slab plane of a zero direction component) leaves the interval.
    if (t0 > t_near) t_near = t0;
    if (t1 < t_far) t_far = t1;
  }
  return t_near <= t_far ? t_near : INFINITY;
}

}  // namespace

Vec3 closest_point_on_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 ab = b - a, ac = c - a;
  // Degenerate (zero-area) triangles: the nearest of the three edges.
  if (!(ab.cross(ac).squaredNorm() > 1e-12f * ab.squaredNorm() * ac.squaredNorm())) {
    const Vec3 candidates[3] = {closest_on_segment(p, a, b), closest_on_segment(p, b, c),
                                closest_on_segment(p, c, a)};
    return *std::min_element(std::begin(candidates), std::end(candidates), [&](const Vec3& x, const Vec3& y) {
      return (x - p).squaredNorm() < (y - p).squaredNorm();
    });
  }
  const Vec3 ap = p - a;
  const float d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Vec3 bp = p - b;
  const float d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const float vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + (d1 / (d1 - d3)) * ab;
  const Vec3 cp = p - c;
  const float d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const float vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + (d2 / (d2 - d6)) * ac;
  const float va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) return b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b);
  const float denominator = 1.0f / (va + vb + vc);
  return a + ab * (vb * denominator) + ac * (vc * denominator);
}

struct TriangleBvh::Builder {
  // A triangle while building: its box, the centre of that box, and its face index.
  struct Primitive {
    Box box;
    Vec3 centroid;
    std::uint32_t face;
  };
  // A node's range of primitives with the bounds of their boxes and of their centroids.
  struct Range {
    std::uint32_t begin = 0, end = 0;
    Box bounds, centroid_bounds;
  };
  struct Bin {
    Box bounds, centroid_bounds;
    std::uint32_t count = 0;
  };

  TriangleBvh& bvh;
  const Mesh& mesh;
  std::vector<Primitive> primitives;
  std::atomic<std::uint32_t> node_count{1};

  void build() {
    const std::size_t n = mesh.faces.size();
    if (n == 0) return;
    if (n >= std::size_t(UINT32_MAX / 2)) throw Error(ExitCode::internal, "TriangleBvh: too many faces");
    mesh.check_consistent();
    primitives.resize(n);
    Range root{0, std::uint32_t(n), {}, {}};
    for (std::size_t f = 0; f < n; ++f) {
      Box box;
      for (std::uint32_t v : mesh.faces[f]) box.extend(mesh.positions[v]);
      primitives[f] = {box, 0.5f * (box.lo + box.hi), std::uint32_t(f)};
      root.bounds.extend(box);
      root.centroid_bounds.extend(primitives[f].centroid);
    }
    bvh.nodes_.resize(2 * n - 1);  // a binary tree with at most n leaves
    split(0, root, 0);
    bvh.nodes_.resize(node_count.load());
    bvh.nodes_.shrink_to_fit();
    bvh.triangles_.resize(n);
    bvh.face_ids_.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      const auto& face = mesh.faces[primitives[i].face];
      bvh.triangles_[i] = {mesh.positions[face[0]], mesh.positions[face[1]], mesh.positions[face[2]]};
      bvh.face_ids_[i] = primitives[i].face;
    }
  }

  // Children are built in parallel for large ranges. Node indices then depend on scheduling, but
  // the tree's shape does not, and queries depend only on the shape.
  void split(std::uint32_t node, const Range& range, int depth) {
    bvh.nodes_[node].lo = range.bounds.lo;
    bvh.nodes_[node].hi = range.bounds.hi;
    const std::uint32_t count = range.end - range.begin;
    Range left, right;
    const bool split_found = depth < max_sah_depth ? sah_split(range, left, right) : false;
    if (!split_found) {
      if (count <= max_leaf_size || (depth < max_sah_depth && left.end == range.end)) {
        bvh.nodes_[node].first = range.begin;
        bvh.nodes_[node].count = count;
        return;
      }
      median_split(range, left, right);
    }
    const std::uint32_t first = node_count.fetch_add(2);
    bvh.nodes_[node].first = first;
    bvh.nodes_[node].count = 0;
    if (count >= parallel_threshold) {
      tbb::parallel_invoke([&] { split(first, left, depth + 1); },
                           [&] { split(first + 1, right, depth + 1); });
    } else {
      split(first, left, depth + 1);
      split(first + 1, right, depth + 1);
    }
  }

  // Binned SAH in one pass over the primitives. Returns false when a leaf is cheaper (then sets
  // left.end = range.end) or no plane separates the centroids (left.end stays 0).
  bool sah_split(const Range& range, Range& left, Range& right) {
    const std::uint32_t count = range.end - range.begin;
    if (count <= 1) {
      left.end = range.end;
      return false;
    }
    const Vec3 lo = range.centroid_bounds.lo;
    const Vec3 extent = range.centroid_bounds.hi - lo;
    Vec3 scale;
    for (int k = 0; k < 3; ++k) scale[k] = extent[k] > 1e-30f ? bin_count / extent[k] : 0.0f;
    // Large ranges are binned along their widest axis only: three times less work where it costs
    // most, and the widest axis is almost always the best one there.
    if (count > all_axes_below) {
      int widest = 0;
      extent.maxCoeff(&widest);
      for (int k = 0; k < 3; ++k)
        if (k != widest) scale[k] = 0;
    }
    if (scale == Vec3::Zero()) return false;
    // Small ranges use fewer bins: setting up and sweeping 16 bins would cost more than the binning.
    const int bins_used = std::min<int>(bin_count, std::max<std::uint32_t>(4, count));
    scale *= float(bins_used) / bin_count;
    std::array<std::array<Bin, bin_count>, 3> bins;
    const auto bin_of = [&](const Vec3& centroid, int axis) {
      return std::min(bins_used - 1, int((centroid[axis] - lo[axis]) * scale[axis]));
    };
    for (std::uint32_t i = range.begin; i < range.end; ++i) {
      const Primitive& p = primitives[i];
      for (int k = 0; k < 3; ++k) {
        if (scale[k] == 0) continue;
        Bin& bin = bins[k][bin_of(p.centroid, k)];
        bin.bounds.extend(p.box);
        bin.centroid_bounds.extend(p.centroid);
        ++bin.count;
      }
    }
    float best_cost = INFINITY;
    int best_axis = -1, best_plane = 0;
    for (int axis = 0; axis < 3; ++axis) {
      if (scale[axis] == 0) continue;
      // Sweep from the right for the right-hand costs, then from the left to price each plane.
      std::array<float, bin_count> right_cost{};
      Box right_box;
      std::uint32_t right_n = 0;
      for (int b = bins_used - 1; b > 0; --b) {
        right_box.extend(bins[axis][b].bounds);
        right_n += bins[axis][b].count;
        right_cost[b] = right_n ? right_box.half_area() * float(right_n) : INFINITY;
      }
      Box left_box;
      std::uint32_t left_n = 0;
      for (int plane = 1; plane < bins_used; ++plane) {
        left_box.extend(bins[axis][plane - 1].bounds);
        left_n += bins[axis][plane - 1].count;
        if (left_n == 0) continue;
        const float cost = left_box.half_area() * float(left_n) + right_cost[plane];
        if (cost < best_cost) {
          best_cost = cost;
          best_axis = axis;
          best_plane = plane;
        }
      }
    }
    if (best_axis < 0) return false;
    // Visiting a node costs about as much as testing one triangle.
    const float area = range.bounds.half_area();
    if (count <= max_leaf_size && area * float(count) <= area + best_cost) {
      left.end = range.end;
      return false;
    }
    for (int b = 0; b < bins_used; ++b) {
      Range& side = b < best_plane ? left : right;
      side.bounds.extend(bins[best_axis][b].bounds);
      side.centroid_bounds.extend(bins[best_axis][b].centroid_bounds);
    }
    const auto middle =
        std::partition(primitives.begin() + range.begin, primitives.begin() + range.end,
                       [&](const Primitive& p) { return bin_of(p.centroid, best_axis) < best_plane; });
    left.begin = range.begin;
    left.end = right.begin = std::uint32_t(middle - primitives.begin());
    right.end = range.end;
    return true;
  }

  // Halves the range at the median centroid of its widest axis (also when all centroids coincide).
  void median_split(const Range& range, Range& left, Range& right) {
    int axis = 0;
    (range.centroid_bounds.hi - range.centroid_bounds.lo).maxCoeff(&axis);
    const std::uint32_t middle = range.begin + (range.end - range.begin) / 2;
    std::nth_element(
        primitives.begin() + range.begin, primitives.begin() + middle, primitives.begin() + range.end,
        [&](const Primitive& x, const Primitive& y) { return x.centroid[axis] < y.centroid[axis]; });
    left = {range.begin, middle, {}, {}};
    right = {middle, range.end, {}, {}};
    for (Range* side : {&left, &right})
      for (std::uint32_t i = side->begin; i < side->end; ++i) {
        side->bounds.extend(primitives[i].box);
        side->centroid_bounds.extend(primitives[i].centroid);
      }
  }
};

TriangleBvh::TriangleBvh(const Mesh& mesh) {
  Builder{*this, mesh, {}}.build();
}

TriangleBvh::ClosestHit TriangleBvh::closest_point(const Vec3& query, float max_distance) const {
  ClosestHit best;
  if (nodes_.empty() || !(max_distance >= 0)) return best;
  float best_d2 = max_distance * max_distance;
  bool found = false;
  std::uint32_t stack[stack_size];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& node = nodes_[stack[--top]];
    if (box_distance2(node.lo, node.hi, query) > best_d2) continue;
    if (node.count > 0) {
      for (std::uint32_t i = node.first; i < node.first + node.count; ++i) {
        const Triangle& t = triangles_[i];
        const Vec3 p = closest_point_on_triangle(query, t.a, t.b, t.c);
        const float d2 = (p - query).squaredNorm();
        if (d2 < best_d2 || (!found && d2 <= best_d2)) {
          found = true;
          best_d2 = d2;
          best.face = face_ids_[i];
          best.point = p;
        }
      }
      continue;
    }
    // Push the farther child first so the nearer one is searched first and shrinks the radius.
    const float d_left = box_distance2(nodes_[node.first].lo, nodes_[node.first].hi, query);
    const float d_right = box_distance2(nodes_[node.first + 1].lo, nodes_[node.first + 1].hi, query);
    const std::uint32_t near = d_left <= d_right ? node.first : node.first + 1;
    const std::uint32_t far = d_left <= d_right ? node.first + 1 : node.first;
    if (std::max(d_left, d_right) <= best_d2) stack[top++] = far;
    if (std::min(d_left, d_right) <= best_d2) stack[top++] = near;
  }
  if (found) best.distance = std::sqrt(best_d2);
  return best;
}

TriangleBvh::RayHit TriangleBvh::intersect(const Vec3& origin, const Vec3& direction, float t_max) const {
  RayHit best;
  if (nodes_.empty() || !(t_max >= 0)) return best;
  const Vec3 inv_direction = direction.cwiseInverse();
  float best_t = t_max;
  std::uint32_t stack[stack_size];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& node = nodes_[stack[--top]];
    if (ray_box(node.lo, node.hi, origin, inv_direction, best_t) == INFINITY) continue;
    if (node.count > 0) {
      for (std::uint32_t i = node.first; i < node.first + node.count; ++i) {
        // Möller–Trumbore.
        const Triangle& tri = triangles_[i];
        const Vec3 e1 = tri.b - tri.a, e2 = tri.c - tri.a;
        const Vec3 p = direction.cross(e2);
        const float det = e1.dot(p);
        if (det == 0) continue;
        const float inv_det = 1.0f / det;
        const Vec3 s = origin - tri.a;
        const float u = s.dot(p) * inv_det;
        if (u < 0 || u > 1) continue;
        const Vec3 q = s.cross(e1);
        const float v = direction.dot(q) * inv_det;
        if (v < 0 || u + v > 1) continue;
        const float t = e2.dot(q) * inv_det;
        if (t < 0 || t > best_t || (best.hit && t == best_t)) continue;
        best = {true, t, face_ids_[i], u, v};
        best_t = t;
      }
      continue;
    }
    const float t_left = ray_box(nodes_[node.first].lo, nodes_[node.first].hi, origin, inv_direction, best_t);
    const float t_right =
        ray_box(nodes_[node.first + 1].lo, nodes_[node.first + 1].hi, origin, inv_direction, best_t);
    const std::uint32_t near = t_left <= t_right ? node.first : node.first + 1;
    const std::uint32_t far = t_left <= t_right ? node.first + 1 : node.first;
    if (std::max(t_left, t_right) != INFINITY) stack[top++] = far;
    if (std::min(t_left, t_right) != INFINITY) stack[top++] = near;
  }
  return best;
}

}  // namespace pg

#include "pg/remesh/remesh.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>

#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/core/parallel.h"
#include "pg/remesh/reference_surface.h"
#include "pg/remesh/sizing.h"
#include "pg/remesh/trimesh.h"

namespace pg {
namespace {

using VertexHandle = TriMesh::VertexHandle;
using EdgeHandle = TriMesh::EdgeHandle;
using HalfedgeHandle = TriMesh::HalfedgeHandle;
using FaceHandle = TriMesh::FaceHandle;
using Vec3 = OpenMesh::Vec3f;

constexpr float split_factor = 4.0f / 3.0f;
constexpr float collapse_factor = 4.0f / 5.0f;

Vec3 triangle_normal(const Vec3& a, const Vec3& b, const Vec3& c) {
  return OpenMesh::cross(b - a, c - a);  // length = twice the area
}

// Below this smallest angle (degrees) a change must not make a triangle worse than it was.
constexpr float sliver_angle_deg = 5.0f;

float smallest_angle_deg(const Vec3& a, const Vec3& b, const Vec3& c) {
  const auto angle = [](const Vec3& u, const Vec3& v) {
    return std::atan2(OpenMesh::cross(u, v).norm(), OpenMesh::dot(u, v)) *
           (180.0f / std::numbers::pi_v<float>);
  };
  return std::min({angle(b - a, c - a), angle(c - b, a - b), angle(a - c, b - c)});
}

// Whether replacing triangle `before` by `after` keeps its orientation and makes no new sliver.
bool acceptable_change(const Vec3 (&before)[3], const Vec3 (&after)[3]) {
  const Vec3 n0 = triangle_normal(before[0], before[1], before[2]);
  const Vec3 n1 = triangle_normal(after[0], after[1], after[2]);
  if (OpenMesh::dot(n0, n1) <= 0) return false;
  const float angle = smallest_angle_deg(after[0], after[1], after[2]);
  return angle >= sliver_angle_deg || angle >= smallest_angle_deg(before[0], before[1], before[2]);
}

// The input without its unused vertices, and where each kept vertex came from.
struct Compacted {
  Mesh mesh;
  std::vector<std::uint32_t> original;  // per kept vertex: its index in the input
};

Compacted drop_unused_vertices(const Mesh& input) {
  std::vector<bool> used(input.vertex_count(), false);
  for (const auto& f : input.faces)
    for (std::uint32_t v : f) used[v] = true;
  Compacted out;
  std::vector<std::uint32_t> index(input.vertex_count(), UINT32_MAX);
  for (std::size_t i = 0; i < used.size(); ++i)
    if (used[i]) {
      index[i] = std::uint32_t(out.original.size());
      out.original.push_back(std::uint32_t(i));
    }
  Mesh& m = out.mesh;
  m.provenance = input.provenance;
  const auto keep = [&](const auto& from, auto& to) {
    if (from.empty()) return;
    to.reserve(out.original.size());
    for (std::uint32_t i : out.original) to.push_back(from[i]);
  };
  keep(input.positions, m.positions);
  keep(input.normals, m.normals);
  keep(input.colors, m.colors);
  keep(input.uvs, m.uvs);
  for (const auto& [name, values] : input.vertex_properties) keep(values, m.vertex_properties[name]);
  m.faces.reserve(input.faces.size());
  for (const auto& f : input.faces) m.faces.push_back({index[f[0]], index[f[1]], index[f[2]]});
  return out;
}

std::vector<bool> keep_flags(const std::vector<bool>& flags, const std::vector<std::uint32_t>& original) {
  if (flags.empty()) return {};
  std::vector<bool> out(original.size());
  for (std::size_t i = 0; i < original.size(); ++i) out[i] = flags[original[i]];
  return out;
}

// Per-element properties of the half-edge mesh; they follow OpenMesh's garbage collection.
struct Properties {
  OpenMesh::VPropHandleT<std::int64_t> vsource;  // input vertex index + 1; 0 for new vertices
  OpenMesh::VPropHandleT<char> vlocked;          // outside the region
  OpenMesh::VPropHandleT<char> vpinned;
  OpenMesh::VPropHandleT<char> vcorner;
  OpenMesh::VPropHandleT<char> vfeature;
  OpenMesh::VPropHandleT<float> vtarget;
  OpenMesh::EPropHandleT<char> efeature;
  OpenMesh::FPropHandleT<std::int64_t> fsource;  // input face index + 1; 0 for changed or new faces

  Properties(const Properties&) = default;
  explicit Properties(TriMesh& mesh) {
    mesh.add_property(vsource);
    mesh.add_property(vlocked);
    mesh.add_property(vpinned);
    mesh.add_property(vcorner);
    mesh.add_property(vfeature);
    mesh.add_property(vtarget);
    mesh.add_property(efeature);
    mesh.add_property(fsource);
  }
};

// The remesher's state: the half-edge mesh with its properties, the reference surface.
class IsotropicRemesher : private Properties {
 public:
  IsotropicRemesher(TriMesh& mesh, const Properties& properties, const ReferenceSurface& surface,
                    const std::vector<float>& reference_target, bool uniform, float feature_cos)
      : Properties(properties),
        mesh_(mesh),
        surface_(surface),
        reference_target_(reference_target),
        uniform_(uniform),
        feature_cos_(feature_cos) {}

  void run(int iterations) {
    for (int i = 0; i < iterations; ++i) {
      split_long_edges();
      collapse_short_edges();
      mesh_.garbage_collection();
      equalize_valences();
      tangential_relaxation();
    }
    if (iterations > 0) remove_obtuse_pairs();
  }

  RemeshStats stats;

 private:
  TriMesh& mesh_;
  const ReferenceSurface& surface_;
  const std::vector<float>& reference_target_;
  bool uniform_;
  float feature_cos_;

  bool fixed(VertexHandle v) const {
    return mesh_.property(vlocked, v) || mesh_.property(vpinned, v) || mesh_.property(vcorner, v);
  }
  bool locked(EdgeHandle e) const {
    const HalfedgeHandle h = mesh_.halfedge_handle(e, 0);
    return mesh_.property(vlocked, mesh_.from_vertex_handle(h)) ||
           mesh_.property(vlocked, mesh_.to_vertex_handle(h));
  }
  float edge_target(VertexHandle a, VertexHandle b) const {
    return 0.5f * (mesh_.property(vtarget, a) + mesh_.property(vtarget, b));
  }
  float squared_length(HalfedgeHandle h) const {
    return (mesh_.point(mesh_.to_vertex_handle(h)) - mesh_.point(mesh_.from_vertex_handle(h))).sqrnorm();
  }
  int target_valence(VertexHandle v) const { return mesh_.is_boundary(v) ? 4 : 6; }

  void split_long_edges() {
    for (int pass = 0; pass < 10; ++pass) {
      bool changed = false;
      const std::size_t edges = mesh_.n_edges();  // edges made in this pass wait for the next one
      for (std::size_t i = 0; i < edges; ++i) {
        const EdgeHandle e{int(i)};
        if (mesh_.status(e).deleted() || locked(e)) continue;
        const HalfedgeHandle h = mesh_.halfedge_handle(e, 0);
        const VertexHandle v0 = mesh_.from_vertex_handle(h), v1 = mesh_.to_vertex_handle(h);
        const float target = edge_target(v0, v1);
        if (squared_length(h) <= split_factor * split_factor * target * target) continue;
        split(e, v0, v1, target);
        changed = true;
      }
      if (!changed) break;
    }
  }

  void split(EdgeHandle e, VertexHandle v0, VertexHandle v1, float target) {
    const bool feature = mesh_.property(efeature, e);
    const VertexHandle m = mesh_.split(e, (mesh_.point(v0) + mesh_.point(v1)) * 0.5f);
    mesh_.property(vsource, m) = 0;
    mesh_.property(vlocked, m) = 0;
    mesh_.property(vpinned, m) = 0;
    mesh_.property(vcorner, m) = 0;
    mesh_.property(vfeature, m) = feature;
    mesh_.property(vtarget, m) = target;
    for (const HalfedgeHandle h : mesh_.voh_range(m)) {
      const VertexHandle w = mesh_.to_vertex_handle(h);
      mesh_.property(efeature, mesh_.edge_handle(h)) = feature && (w == v0 || w == v1);
      if (!mesh_.is_boundary(h)) mesh_.property(fsource, mesh_.face_handle(h)) = 0;
      const HalfedgeHandle o = mesh_.opposite_halfedge_handle(h);
      if (!mesh_.is_boundary(o)) mesh_.property(fsource, mesh_.face_handle(o)) = 0;
    }
    ++stats.splits;
  }

  // Where the kept vertex goes: the edge midpoint when both ends may move freely, else its place.
  Vec3 collapse_point(HalfedgeHandle h) const {
    const VertexHandle v0 = mesh_.from_vertex_handle(h), v1 = mesh_.to_vertex_handle(h);
    const bool free = !fixed(v1) && !mesh_.property(vfeature, v0) && !mesh_.property(vfeature, v1);
    return free ? (mesh_.point(v0) + mesh_.point(v1)) * 0.5f : mesh_.point(v1);
  }

  // Whether collapsing h (removing its from-vertex v0, moving its to-vertex v1 to collapse_point)
  // keeps features, pins, the region, the topology and the orientation of every face, and makes no
  // edge too long.
  bool can_collapse(HalfedgeHandle h) const {
    const VertexHandle v0 = mesh_.from_vertex_handle(h), v1 = mesh_.to_vertex_handle(h);
    const EdgeHandle e = mesh_.edge_handle(h);
    if (fixed(v0) || mesh_.property(vpinned, v1)) return false;
    if (mesh_.property(vfeature, v0)) {
      if (!mesh_.property(efeature, e)) return false;  // would pull a feature line off its place
      for (const HalfedgeHandle side : {h, mesh_.opposite_halfedge_handle(h)}) {
        if (mesh_.is_boundary(side)) continue;
        const VertexHandle opposite = mesh_.to_vertex_handle(mesh_.next_halfedge_handle(side));
        const HalfedgeHandle shortcut = mesh_.find_halfedge(v0, opposite);
        if (mesh_.property(efeature, mesh_.edge_handle(shortcut))) return false;
      }
    }
    if (!mesh_.is_collapse_ok(h)) return false;
    const Vec3 p = collapse_point(h);
    const bool moves_v1 = p != mesh_.point(v1);
    for (const VertexHandle end : {v0, v1}) {
      if (end == v1 && !moves_v1) continue;
      for (const VertexHandle w : mesh_.vv_range(end)) {
        if (w == v0 || w == v1) continue;
        const float limit = split_factor * edge_target(v1, w);
        if ((p - mesh_.point(w)).sqrnorm() > limit * limit) return false;
      }
      for (const FaceHandle f : mesh_.vf_range(end)) {
        Vec3 before[3], after[3];
        int k = 0, ends = 0;
        for (const VertexHandle w : mesh_.fv_range(f)) {
          const bool on_edge = w == v0 || w == v1;
          ends += on_edge;
          before[k] = mesh_.point(w);
          after[k] = on_edge ? p : before[k];
          ++k;
        }
        if (ends == 2) continue;  // disappears with the collapse
        if (!acceptable_change(before, after)) return false;
      }
    }
    return true;
  }

  void collapse_short_edges() {
    for (int pass = 0; pass < 5; ++pass) {
      bool changed = false;
      for (std::size_t i = 0; i < mesh_.n_edges(); ++i) {
        const EdgeHandle e{int(i)};
        if (mesh_.status(e).deleted() || locked(e)) continue;
        const HalfedgeHandle h01 = mesh_.halfedge_handle(e, 0), h10 = mesh_.halfedge_handle(e, 1);
        const VertexHandle v0 = mesh_.from_vertex_handle(h01), v1 = mesh_.to_vertex_handle(h01);
        const float target = collapse_factor * edge_target(v0, v1);
        if (squared_length(h01) >= target * target) continue;
        bool ok01 = can_collapse(h01), ok10 = can_collapse(h10);
        if (ok01 && ok10) (mesh_.valence(v0) < mesh_.valence(v1) ? ok10 : ok01) = false;
        if (!ok01 && !ok10) continue;
        const HalfedgeHandle h = ok01 ? h01 : h10;
        for (const FaceHandle f : mesh_.vf_range(mesh_.from_vertex_handle(h))) mesh_.property(fsource, f) = 0;
        const Vec3 p = collapse_point(h);
        const VertexHandle kept = mesh_.to_vertex_handle(h);
        mesh_.collapse(h);
        mesh_.set_point(kept, p);
        ++stats.collapses;
        changed = true;
      }
      if (!changed) break;
    }
  }

  // The two ends of e and the two vertices facing it: a flip moves e from a-b to c-d.
  struct FlipQuad {
    VertexHandle a, b, c, d;
  };
  FlipQuad flip_quad(EdgeHandle e) const {
    const HalfedgeHandle h0 = mesh_.halfedge_handle(e, 0), h1 = mesh_.halfedge_handle(e, 1);
    return {mesh_.from_vertex_handle(h0), mesh_.to_vertex_handle(h0),
            mesh_.to_vertex_handle(mesh_.next_halfedge_handle(h0)),
            mesh_.to_vertex_handle(mesh_.next_halfedge_handle(h1))};
  }

  // Flips an edge when that brings the four vertices nearer their ideal valence and keeps the shape.
  bool flip_improves(const FlipQuad& q, const std::vector<int>& valence) const {
    const int va = valence[q.a.idx()], vb = valence[q.b.idx()], vc = valence[q.c.idx()],
              vd = valence[q.d.idx()];
    const int ta = target_valence(q.a), tb = target_valence(q.b), tc = target_valence(q.c),
              td = target_valence(q.d);
    const int before = std::abs(va - ta) + std::abs(vb - tb) + std::abs(vc - tc) + std::abs(vd - td);
    const int after =
        std::abs(va - 1 - ta) + std::abs(vb - 1 - tb) + std::abs(vc + 1 - tc) + std::abs(vd + 1 - td);
    return after < before;
  }

  // Whether flipping e keeps both new faces oriented like the old pair, creates no crease sharper
  // than the feature angle and no new sliver.
  bool flip_keeps_shape(EdgeHandle e) const {
    if (!mesh_.is_flip_ok(e)) return false;
    const FlipQuad q = flip_quad(e);
    const Vec3 &pa = mesh_.point(q.a), &pb = mesh_.point(q.b), &pc = mesh_.point(q.c), &pd = mesh_.point(q.d);
    const Vec3 old_normal = triangle_normal(pa, pb, pc) + triangle_normal(pb, pa, pd);
    const Vec3 n1 = triangle_normal(pa, pd, pc), n2 = triangle_normal(pd, pb, pc);
    const float l1 = n1.norm(), l2 = n2.norm();
    if (!(l1 > 0) || !(l2 > 0)) return false;
    if (OpenMesh::dot(n1, old_normal) <= 0 || OpenMesh::dot(n2, old_normal) <= 0) return false;
    if (OpenMesh::dot(n1, n2) <= feature_cos_ * l1 * l2) return false;
    const float worst_before = std::min(smallest_angle_deg(pa, pb, pc), smallest_angle_deg(pb, pa, pd));
    const float worst_after = std::min(smallest_angle_deg(pa, pd, pc), smallest_angle_deg(pd, pb, pc));
    return worst_after >= sliver_angle_deg || worst_after >= worst_before;
  }

  // Whether the two angles facing e sum to more than 180 degrees (e is not locally Delaunay) and
  // flipping it raises the smaller of the two faces' smallest angles.
  bool flip_widens_angles(EdgeHandle e) const {
    const FlipQuad q = flip_quad(e);
    const Vec3 &pa = mesh_.point(q.a), &pb = mesh_.point(q.b), &pc = mesh_.point(q.c), &pd = mesh_.point(q.d);
    const auto angle = [](const Vec3& u, const Vec3& v) {
      return std::atan2(OpenMesh::cross(u, v).norm(), OpenMesh::dot(u, v));
    };
    if (angle(pa - pc, pb - pc) + angle(pa - pd, pb - pd) <= std::numbers::pi_v<float>) return false;
    const float worst_before = std::min(smallest_angle_deg(pa, pb, pc), smallest_angle_deg(pb, pa, pd));
    const float worst_after = std::min(smallest_angle_deg(pa, pd, pc), smallest_angle_deg(pd, pb, pc));
    return worst_after > worst_before;
  }

  // A last pass after the iterations: flips that widen the smallest angles (caps and needles that
  // valence flips and relaxation left), features, boundaries and the locked part untouched.
  void remove_obtuse_pairs() {
    flip_while([&](EdgeHandle e) { return flip_widens_angles(e) && flip_keeps_shape(e); });
  }

  // Valences are kept in an array through the passes: OpenMesh counts them by circulating, which was
  // a fifth of the remesher's time when asked four times per edge.
  void equalize_valences() {
    std::vector<int> valence(mesh_.n_vertices());
    for (const VertexHandle v : mesh_.vertices()) valence[v.idx()] = int(mesh_.valence(v));
    flip_while([&](EdgeHandle e) {
      const FlipQuad q = flip_quad(e);
      if (!flip_improves(q, valence) || !flip_keeps_shape(e)) return false;
      --valence[q.a.idx()], --valence[q.b.idx()], ++valence[q.c.idx()], ++valence[q.d.idx()];
      return true;  // flip_while flips e
    });
  }

  // Up to five passes over the free edges (not locked, feature or boundary), flipping those
  // `should_flip` accepts, until a pass flips none.
  template <class ShouldFlip>
  void flip_while(const ShouldFlip& should_flip) {
    for (int pass = 0; pass < 5; ++pass) {
      bool changed = false;
      for (std::size_t i = 0; i < mesh_.n_edges(); ++i) {
        const EdgeHandle e{int(i)};
        if (mesh_.status(e).deleted() || locked(e) || mesh_.property(efeature, e) || mesh_.is_boundary(e))
          continue;
        if (!should_flip(e)) continue;
        flip(e);
        changed = true;
      }
      if (!changed) break;
    }
  }

  void flip(EdgeHandle e) {
    mesh_.flip(e);
    const HalfedgeHandle h = mesh_.halfedge_handle(e, 0);
    mesh_.property(fsource, mesh_.face_handle(h)) = 0;
    mesh_.property(fsource, mesh_.opposite_face_handle(h)) = 0;
    ++stats.flips;
  }

  // The new position of a free vertex: towards the area-weighted centroid of its faces within its
  // tangent plane, back onto the surface; feature vertices along their feature line, back onto it.
  Vec3 relaxed_position(VertexHandle v, const std::vector<Vec3>& normals, float& target) const {
    const Vec3 p = mesh_.point(v);
    if (mesh_.property(vfeature, v)) {
      VertexHandle ends[2];
      int count = 0;
      for (const HalfedgeHandle h : mesh_.voh_range(v))
        if (mesh_.property(efeature, mesh_.edge_handle(h)) && count++ < 2)
          ends[count - 1] = mesh_.to_vertex_handle(h);
      if (count != 2) return p;
      const Vec3 a = mesh_.point(ends[0]), b = mesh_.point(ends[1]);
      Vec3 direction = b - a;
      const float length = direction.norm();
      if (!(length > 0)) return p;
      direction /= length;
      const Vec3 moved = p + direction * OpenMesh::dot(direction, (a + b) * 0.5f - p);
      const Eigen::Vector3f on_line = surface_.closest_on_features(to_eigen(moved));
      if (!uniform_) target = surface_.interpolate(reference_target_, surface_.locate(on_line));
      return to_openmesh(on_line);
    }
    Vec3 centroid(0, 0, 0);
    float area = 0;
    for (const FaceHandle f : mesh_.vf_range(v)) {
      Vec3 q[3];
      int k = 0;
      for (const VertexHandle w : mesh_.fv_range(f)) q[k++] = mesh_.point(w);
      const float a = triangle_normal(q[0], q[1], q[2]).norm();
      centroid += (q[0] + q[1] + q[2]) * (a / 3.0f);
      area += a;
    }
    if (!(area > 0)) return p;
    centroid /= area;
    const Vec3& n = normals[v.idx()];
    Vec3 step = centroid - p;
    step -= n * OpenMesh::dot(n, step);
    const ReferenceSurface::Location at = surface_.locate(to_eigen(p + step));
    if (!uniform_) target = surface_.interpolate(reference_target_, at);
    return to_openmesh(at.point);
  }

  // Whether moving v to q keeps every face around it oriented as before and makes no new sliver
  // (neighbours where they are).
  bool acceptable_move(VertexHandle v, const Vec3& q) const {
    for (const FaceHandle f : mesh_.vf_range(v)) {
      Vec3 before[3], after[3];
      int k = 0;
      for (const VertexHandle w : mesh_.fv_range(f)) {
        before[k] = mesh_.point(w);
        after[k] = w == v ? q : before[k];
        ++k;
      }
      if (!acceptable_change(before, after)) return false;
    }
    return true;
  }

  void tangential_relaxation() {
    const auto n = std::int64_t(mesh_.n_vertices());
    std::vector<Vec3> normals(n, Vec3(0, 0, 0));
    parallel_chunks(n, 2048, [&](std::int64_t begin, std::int64_t end) {
      for (std::int64_t i = begin; i < end; ++i) {
        const VertexHandle v{int(i)};
        Vec3 sum(0, 0, 0);
        for (const FaceHandle f : mesh_.vf_range(v)) {
          Vec3 q[3];
          int k = 0;
          for (const VertexHandle w : mesh_.fv_range(f)) q[k++] = mesh_.point(w);
          sum += triangle_normal(q[0], q[1], q[2]);
        }
        const float length = sum.norm();
        normals[i] = length > 0 ? sum / length : sum;
      }
    });
    // Jacobi update: every new position from the old ones, so the result does not depend on order.
    std::vector<Vec3> moved(n);
    std::vector<float> targets(n);
    parallel_chunks(n, 1024, [&](std::int64_t begin, std::int64_t end) {
      for (std::int64_t i = begin; i < end; ++i) {
        const VertexHandle v{int(i)};
        moved[i] = mesh_.point(v);
        targets[i] = mesh_.property(vtarget, v);
        if (mesh_.status(v).deleted() || fixed(v) || mesh_.is_isolated(v)) continue;
        float target = targets[i];
        const Vec3 q = relaxed_position(v, normals, target);
        if (!acceptable_move(v, q)) continue;
        moved[i] = q;
        targets[i] = target;
      }
    });
    for (std::int64_t i = 0; i < n; ++i) {
      const VertexHandle v{int(i)};
      mesh_.set_point(v, moved[i]);
      mesh_.property(vtarget, v) = targets[i];
    }
  }
};

// A face's unit normal, or nullopt for a face of (almost) no area, whose normal says nothing: its
// cross product is below 1e-6 of its longest edge squared (collinear or coinciding corners).
std::optional<Vec3> proper_normal(const TriMesh& mesh, FaceHandle f) {
  auto v = mesh.cfv_iter(f);
  const Vec3 a = mesh.point(*v), b = mesh.point(*++v), c = mesh.point(*++v);
  const Vec3 n = OpenMesh::cross(b - a, c - a);
  const float longest = std::max({(b - a).sqrnorm(), (c - b).sqrnorm(), (a - c).sqrnorm()});
  if (!(n.norm() > 1e-6f * longest)) return std::nullopt;
  return n.normalized();
}

// Whether the edge of halfedge h is sharp: its two faces meet at more than the feature angle. A face
// without area has no normal of its own (its zero or, after rounding, arbitrary normal made all its
// edges features and kept the sliver); it stands in for the faces across its other two edges, so a
// sliver on a crease keeps the crease and one on a smooth part is remeshed away.
bool sharp_edge(const TriMesh& mesh, HalfedgeHandle h, float feature_cos) {
  const std::optional<Vec3> n0 = proper_normal(mesh, mesh.face_handle(h));
  const std::optional<Vec3> n1 = proper_normal(mesh, mesh.opposite_face_handle(h));
  if (n0 && n1) return OpenMesh::dot(*n0, *n1) < feature_cos;
  if (!n0 && !n1) return false;
  const Vec3 known = n0 ? *n0 : *n1;
  const HalfedgeHandle inside = n0 ? mesh.opposite_halfedge_handle(h) : h;  // in the sliver
  for (const HalfedgeHandle other : {mesh.next_halfedge_handle(inside), mesh.prev_halfedge_handle(inside)}) {
    if (mesh.is_boundary(mesh.edge_handle(other))) continue;
    const std::optional<Vec3> across = proper_normal(mesh, mesh.opposite_face_handle(other));
    if (across && OpenMesh::dot(known, *across) < feature_cos) return true;
  }
  return false;
}

// Marks feature edges (boundaries, and dihedral angles above the threshold) and corner vertices
// (feature vertices where the feature edges do not continue as one line).
void mark_features(TriMesh& mesh, const Properties& r, float feature_cos) {
  for (const auto e : mesh.edges()) {
    bool feature = mesh.is_boundary(e);
    if (!feature) feature = sharp_edge(mesh, mesh.halfedge_handle(e, 0), feature_cos);
    mesh.property(r.efeature, e) = feature;
  }
  for (const auto v : mesh.vertices()) {
    // Feature edges leaving in one direction count once (a sliver on a crease lays two of its edges
    // along the crease).
    int count = 0;
    Vec3 directions[2];
    for (const HalfedgeHandle h : mesh.voh_range(v))
      if (mesh.property(r.efeature, mesh.edge_handle(h))) {
        const Vec3 d = (mesh.point(mesh.to_vertex_handle(h)) - mesh.point(v)).normalized();
        const bool seen = std::any_of(directions, directions + std::min(count, 2),
                                      [&](const Vec3& e) { return OpenMesh::dot(d, e) > 1 - 1e-5f; });
        if (seen) continue;
        if (count < 2) directions[count] = d;
        ++count;
      }
    mesh.property(r.vfeature, v) = count > 0;
    // Two feature edges continue one line when they are nearly opposite.
    const bool bends = count == 2 && OpenMesh::dot(directions[0], -directions[1]) < feature_cos;
    mesh.property(r.vcorner, v) = (count > 0 && count != 2) || bends;
  }
}

std::vector<Segment> feature_segments(const TriMesh& mesh, const OpenMesh::EPropHandleT<char>& efeature) {
  std::vector<Segment> segments;
  for (const auto e : mesh.edges())
    if (mesh.property(efeature, e)) {
      const HalfedgeHandle h = mesh.halfedge_handle(e, 0);
      segments.push_back(
          {to_eigen(mesh.point(mesh.from_vertex_handle(h))), to_eigen(mesh.point(mesh.to_vertex_handle(h)))});
    }
  return segments;
}

bool is_binary(const std::vector<float>& values) {
  return std::all_of(values.begin(), values.end(), [](float v) { return v == 0.0f || v == 1.0f; });
}

// Attributes of output vertex `out` at `at` on the input surface.
void interpolate_attributes(const Mesh& input, const ReferenceSurface& surface,
                            const ReferenceSurface::Location& at, const std::map<std::string, bool>& binary,
                            Mesh& output, std::size_t out) {
  const auto& f = surface.face(at.face);
  const Eigen::Vector3f& w = at.barycentric;
  if (!input.normals.empty()) {
    const Eigen::Vector3f n =
        w[0] * input.normals[f[0]] + w[1] * input.normals[f[1]] + w[2] * input.normals[f[2]];
    output.normals[out] = n.norm() > 0 ? n.normalized() : input.normals[f[0]];
  }
  if (!input.colors.empty())
    for (int c = 0; c < 3; ++c) {
      const float value =
          w[0] * input.colors[f[0]][c] + w[1] * input.colors[f[1]][c] + w[2] * input.colors[f[2]][c];
      output.colors[out][c] = std::uint8_t(std::clamp(std::lround(value), 0L, 255L));
    }
  if (!input.uvs.empty())
    output.uvs[out] = w[0] * input.uvs[f[0]] + w[1] * input.uvs[f[1]] + w[2] * input.uvs[f[2]];
  for (const auto& [name, values] : input.vertex_properties) {
    if (values.empty()) continue;
    const float value = surface.interpolate(values, at);
    output.vertex_properties[name][out] = binary.at(name) ? (value >= 0.5f ? 1.0f : 0.0f) : value;
  }
}

void size_attributes(const Mesh& input, Mesh& output, std::size_t n) {
  if (!input.normals.empty()) output.normals.resize(n);
  if (!input.colors.empty()) output.colors.resize(n);
  if (!input.uvs.empty()) output.uvs.resize(n);
  for (const auto& [name, values] : input.vertex_properties)
    output.vertex_properties[name].resize(values.empty() ? 0 : n);
}

void copy_attributes(const Mesh& input, std::size_t in, Mesh& output, std::size_t out) {
  if (!input.normals.empty()) output.normals[out] = input.normals[in];
  if (!input.colors.empty()) output.colors[out] = input.colors[in];
  if (!input.uvs.empty()) output.uvs[out] = input.uvs[in];
  for (const auto& [name, values] : input.vertex_properties)
    if (!values.empty()) output.vertex_properties[name][out] = values[in];
}

// Builds the output: kept input vertices in input order, then new vertices; unchanged input faces in
// input order, then the others. Attributes copied where a vertex did not move, interpolated elsewhere.
void export_result(const TriMesh& tri, const Properties& r, const Compacted& input,
                   const std::vector<bool>& region, const ReferenceSurface& surface, RemeshResult& result) {
  std::vector<VertexHandle> order;
  order.reserve(tri.n_vertices());
  for (const auto v : tri.vertices()) order.push_back(v);
  std::stable_sort(order.begin(), order.end(), [&](VertexHandle a, VertexHandle b) {
    const std::int64_t sa = tri.property(r.vsource, a), sb = tri.property(r.vsource, b);
    if ((sa == 0) != (sb == 0)) return sa != 0;  // input vertices first
    return sa < sb;
  });
  std::vector<std::uint32_t> index(tri.n_vertices());
  for (std::size_t i = 0; i < order.size(); ++i) index[order[i].idx()] = std::uint32_t(i);

  const Mesh& in = input.mesh;
  Mesh& out = result.mesh;
  out.provenance = in.provenance;
  const std::size_t n = order.size();
  out.positions.resize(n);
  size_attributes(in, out, n);
  result.source_vertex.assign(n, -1);
  result.in_region.assign(n, true);
  result.target.assign(n, 0.0f);
  std::map<std::string, bool> binary;
  for (const auto& [name, values] : in.vertex_properties) binary[name] = is_binary(values);
  std::vector<char> interpolated(n, 0);
  for (std::size_t i = 0; i < n; ++i) {
    const VertexHandle v = order[i];
    out.positions[i] = to_eigen(tri.point(v));
    result.target[i] = tri.property(r.vtarget, v);
    const std::int64_t source = tri.property(r.vsource, v) - 1;
    if (source >= 0) {
      result.source_vertex[i] = input.original[source];
      result.in_region[i] = region[source];
      if (out.positions[i] == in.positions[source]) {
        copy_attributes(in, std::size_t(source), out, i);
        continue;
      }
    }
    interpolated[i] = 1;
  }
  parallel_chunks(std::int64_t(n), 1024, [&](std::int64_t begin, std::int64_t end) {
    for (std::int64_t i = begin; i < end; ++i)
      if (interpolated[i])
        interpolate_attributes(in, surface, surface.locate(out.positions[i]), binary, out, i);
  });

  // Faces: an input face is unchanged when its three vertices are still the input's, in cyclic order.
  struct OutFace {
    std::int64_t source;  // input face index, or -1
    std::array<std::uint32_t, 3> vertices;
  };
  std::vector<OutFace> faces;
  faces.reserve(tri.n_faces());
  for (const auto f : tri.faces()) {
    OutFace face{-1, {}};
    int k = 0;
    for (const VertexHandle v : tri.fv_range(f)) face.vertices[k++] = index[v.idx()];
    const std::int64_t source = tri.property(r.fsource, f) - 1;
    if (source >= 0) {
      const auto& original = in.faces[source];
      for (int rotation = 0; rotation < 3; ++rotation) {
        bool same = true;
        for (int j = 0; j < 3; ++j) {
          const std::int64_t s = tri.property(r.vsource, order[face.vertices[(j + rotation) % 3]]) - 1;
          same &= s == std::int64_t(original[j]);
        }
        if (same) {
          face.source = source;
          face.vertices = {face.vertices[rotation], face.vertices[(rotation + 1) % 3],
                           face.vertices[(rotation + 2) % 3]};
          break;
        }
      }
    }
    faces.push_back(face);
  }
  std::stable_sort(faces.begin(), faces.end(), [](const OutFace& a, const OutFace& b) {
    if ((a.source < 0) != (b.source < 0)) return a.source >= 0;
    return a.source < b.source;
  });
  out.faces.reserve(faces.size());
  for (const OutFace& f : faces) out.faces.push_back(f.vertices);
}

}  // namespace

float mean_edge_length(const Mesh& mesh, const std::vector<bool>& region) {
  std::vector<std::uint64_t> edges;
  edges.reserve(mesh.faces.size() * 3);
  for (const auto& f : mesh.faces)
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t a = f[k], b = f[(k + 1) % 3];
      if (!region.empty() && !(region[a] && region[b])) continue;
      edges.push_back((std::uint64_t(std::min(a, b)) << 32) | std::max(a, b));
    }
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  if (edges.empty()) return 0;
  double sum = 0;
  for (std::uint64_t e : edges)
    sum += (mesh.positions[e >> 32] - mesh.positions[e & 0xffffffffu]).cast<double>().norm();
  return float(sum / double(edges.size()));
}

RemeshResult remesh(const Mesh& original_input, const RemeshOptions& options) {
  original_input.check_consistent();
  const std::size_t n_original = original_input.vertex_count();
  if (!options.region.empty() && options.region.size() != n_original)
    throw UsageError(str("the region has ", options.region.size(), " vertices, the mesh ", n_original));
  if (!options.pinned.empty() && options.pinned.size() != n_original)
    throw UsageError(str("the pinned set has ", options.pinned.size(), " vertices, the mesh ", n_original));
  if (options.iterations < 0) throw UsageError("iterations must not be negative");
  if (!(options.feature_angle_deg > 0 && options.feature_angle_deg <= 180))
    throw UsageError(str("feature angle ", options.feature_angle_deg, " is not in (0, 180] degrees"));
  if (original_input.faces.empty()) throw InputError(options.input_name, "the mesh has no faces");

  RemeshResult result;
  Compacted input = drop_unused_vertices(original_input);
  result.stats.unused_vertices_dropped = n_original - input.original.size();
  if (result.stats.unused_vertices_dropped > 0)
    log::info("dropped ", result.stats.unused_vertices_dropped, " unused vertices (in no face) of ",
              n_original);
  const std::size_t n = input.mesh.vertex_count();
  std::vector<bool> region = keep_flags(options.region, input.original);
  if (region.empty()) region.assign(n, true);
  std::vector<bool> pinned = keep_flags(options.pinned, input.original);
  if (pinned.empty()) pinned.assign(n, false);
  result.stats.region_vertices = std::size_t(std::count(region.begin(), region.end(), true));
  for (std::size_t i = 0; i < n; ++i) result.stats.pinned_vertices += region[i] && pinned[i];

  // Target length: given, or the region's mean edge length (edges touching it when none lies inside).
  const float diagonal = input.mesh.bounds().diagonal().norm();
  float length = options.target_length;
  if (length == 0 && result.stats.region_vertices == 0) {
    // Nothing to remesh (say, a refinement that moved no vertex): the mesh passes through, and the
    // whole mesh's mean edge length fills the report.
    log::info("no vertex lies in the region to remesh: the mesh passes through unchanged");
    length = mean_edge_length(input.mesh, std::vector<bool>(n, true));
  } else if (length == 0) {
    length = mean_edge_length(input.mesh, region);
    if (length == 0) {
      std::vector<bool> touching = region;
      for (const auto& f : input.mesh.faces)
        if (region[f[0]] || region[f[1]] || region[f[2]])
          touching[f[0]] = touching[f[1]] = touching[f[2]] = true;
      length = mean_edge_length(input.mesh, touching);
    }
  }
  if (!(length > 0) || !std::isfinite(length))
    throw UsageError(str("target edge length ", length, " must be positive"));
  if (length > diagonal)
    throw UsageError(str("target edge length ", length, " is larger than the mesh (bounding-box diagonal ",
                         diagonal, ")"));
  result.target_length = length;

  TriMesh tri = to_trimesh(input.mesh, options.input_name);
  const float feature_cos = std::cos(options.feature_angle_deg * std::numbers::pi_v<float> / 180.0f);

  std::vector<float> reference_target(n, length);
  if (options.adaptive) {
    const float error = options.approximation_error > 0 ? options.approximation_error : 0.05f * length;
    const float min_length = options.min_length > 0 ? options.min_length : 0.25f * length;
    const float max_length = options.max_length > 0 ? options.max_length : 2.0f * length;
    if (min_length > max_length)
      throw UsageError(str("min length ", min_length, " is larger than max length ", max_length));
    reference_target = adaptive_target_lengths(input.mesh, error, min_length, max_length);
  }

  const Properties properties(tri);
  for (const auto v : tri.vertices()) {
    const auto i = std::size_t(v.idx());
    tri.property(properties.vsource, v) = std::int64_t(i) + 1;
    tri.property(properties.vlocked, v) = !region[i];
    tri.property(properties.vpinned, v) = pinned[i];
    tri.property(properties.vtarget, v) = reference_target[i];
  }
  for (const auto f : tri.faces()) tri.property(properties.fsource, f) = f.idx() + 1;
  mark_features(tri, properties, feature_cos);
  for (const auto e : tri.edges()) {
    const HalfedgeHandle h = tri.halfedge_handle(e, 0);
    const bool touches_region =
        region[tri.from_vertex_handle(h).idx()] || region[tri.to_vertex_handle(h).idx()];
    result.stats.feature_edges += touches_region && tri.property(properties.efeature, e);
  }
  for (const auto v : tri.vertices())
    result.stats.corner_vertices += region[v.idx()] && tri.property(properties.vcorner, v);

  const ReferenceSurface surface(input.mesh, feature_segments(tri, properties.efeature));
  IsotropicRemesher remesher(tri, properties, surface, reference_target, !options.adaptive, feature_cos);
  if (result.stats.region_vertices > 0) remesher.run(options.iterations);
  const RemeshStats& counts = remesher.stats;
  result.stats.splits = counts.splits;
  result.stats.collapses = counts.collapses;
  result.stats.flips = counts.flips;

  export_result(tri, properties, input, region, surface, result);
  result.input_in_region = region;
  result.input_target = reference_target;
  result.input = std::move(input.mesh);
  return result;
}

}  // namespace pg

#include "pg/remesh/remesh.h"

#include <gtest/gtest.h>

#include <set>

#include "pg/core/error.h"
#include "pg/core/parallel.h"
#include "pg/mesh/bvh.h"
#include "pg/mesh/mesh_io.h"
#include "pg/remesh/quality.h"
#include "pg/remesh/reference_surface.h"
#include "pg/remesh/region.h"
#include "pg/remesh/test_shapes.h"
#include "pg/remesh/trimesh.h"
#include "pg/testing/testing.h"

namespace pg {
namespace {

// Faces as cyclically normalised triples, so the same face reads the same whatever vertex starts it.
std::array<std::uint32_t, 3> canonical(std::array<std::uint32_t, 3> f) {
  while (f[0] > f[1] || f[0] > f[2]) f = {f[1], f[2], f[0]};
  return f;
}

float distance_to_segment(const Eigen::Vector3f& p, const Segment& s) {
  const Eigen::Vector3f d = s[1] - s[0];
  const float t = std::clamp((p - s[0]).dot(d) / d.squaredNorm(), 0.0f, 1.0f);
  return (s[0] + t * d - p).norm();
}

// The twelve edges of the box [0, size].
std::vector<Segment> box_edges(const Eigen::Vector3f& size) {
  std::vector<Segment> edges;
  for (int axis = 0; axis < 3; ++axis)
    for (int a = 0; a < 2; ++a)
      for (int b = 0; b < 2; ++b) {
        Eigen::Vector3f p = Eigen::Vector3f::Zero();
        p[(axis + 1) % 3] = float(a) * size[(axis + 1) % 3];
        p[(axis + 2) % 3] = float(b) * size[(axis + 2) % 3];
        Eigen::Vector3f q = p;
        q[axis] = size[axis];
        edges.push_back({p, q});
      }
  return edges;
}

void expect_target_quality(const RemeshResult& r, const Mesh& reference,
                           const std::vector<bool>& selected = {}) {
  const MeshQuality q = measure_quality(r.mesh, selected.empty() ? r.in_region : selected, r.target);
  EXPECT_GE(q.edges_in_range, 0.95);
  EXPECT_GE(q.angles_above_30, 0.95);
  const HausdorffDistance h = hausdorff_distance(r.mesh, {}, reference, {}, 0.25f * r.target_length);
  EXPECT_LT(h.distance, 0.1 * r.target_length);
}

TEST(Remesh, SphereReachesTheTargetQualityAndStaysOnTheSphere) {
  const Mesh sphere = test::uv_sphere(32, 64, 1.0f);  // slivers at the poles, long edges at the equator
  RemeshOptions options;
  options.target_length = 0.05f;
  const RemeshResult r = remesh(sphere, options);
  expect_target_quality(r, sphere);
  // About the area of the sphere over the area of an equilateral triangle of side L.
  const double expected_faces = 4 * std::numbers::pi / (std::sqrt(3.0) / 4 * 0.05 * 0.05);
  EXPECT_NEAR(double(r.mesh.face_count()), expected_faces, 0.1 * expected_faces);
  for (const auto& p : r.mesh.positions)
    EXPECT_NEAR(p.norm(), 1.0f, 0.005f);  // chords of the input lie inside
}

// A sliver of no area (an edge split on one side only, its midpoint closing the gap) has no normal:
// its edges are no features, so it is remeshed away like any bad triangle. Before, its zero normal
// made its three edges features and the sliver stayed.
TEST(Remesh, FacesWithoutAreaAreNoFeaturesAndDoNotSurvive) {
  Mesh sphere = test::uv_sphere(16, 32, 1.0f);
  const std::array<std::uint32_t, 3> face = sphere.faces[200];
  const std::uint32_t a = face[0], b = face[1], c = face[2];
  const auto m = std::uint32_t(sphere.positions.size());
  sphere.positions.push_back(0.5f * (sphere.positions[b] + sphere.positions[c]));
  sphere.faces[200] = {a, b, m};
  sphere.faces.push_back({a, m, c});
  sphere.faces.push_back({b, c, m});  // collinear: no area
  RemeshOptions options;
  options.target_length = 0.1f;
  const RemeshResult r = remesh(sphere, options);
  EXPECT_EQ(r.stats.feature_edges, 0u);
  EXPECT_EQ(r.stats.corner_vertices, 0u);
  for (const auto& f : r.mesh.faces) {
    const Eigen::Vector3f p = r.mesh.positions[f[0]], q = r.mesh.positions[f[1]], t = r.mesh.positions[f[2]];
    EXPECT_GT((q - p).cross(t - p).norm(), 0.01f * options.target_length * options.target_length);
  }
}

// A sliver on a crease (an edge of the box split on one side only) keeps the crease: the faces across
// the sliver say its edges are sharp, and its two edges along the crease leave their end in one
// direction, so the box still has its 8 corners and no others, and the crease stays straight.
TEST(Remesh, ASliverOnACreaseKeepsTheCrease) {
  const Eigen::Vector3f size(1.0f, 0.6f, 0.8f);
  Mesh box = test::box(size, 7);
  const std::vector<Segment> lines = box_edges(size);
  const auto on_a_line = [&](std::uint32_t v) {
    for (const Segment& s : lines)
      if (distance_to_segment(box.positions[v], s) < 1e-6f) return true;
    return false;
  };
  for (std::size_t f = 0; f < box.faces.size(); ++f) {
    const auto face = box.faces[f];
    int k = 0;
    while (k < 3 && !(on_a_line(face[(k + 1) % 3]) && on_a_line(face[(k + 2) % 3]))) ++k;
    if (k == 3 || on_a_line(face[k])) continue;  // no edge on a crease, or a corner triangle
    const std::uint32_t a = face[k], b = face[(k + 1) % 3], c = face[(k + 2) % 3];
    const auto m = std::uint32_t(box.positions.size());
    box.positions.push_back(0.5f * (box.positions[b] + box.positions[c]));
    box.faces[f] = {a, b, m};
    box.faces.push_back({a, m, c});
    box.faces.push_back({b, c, m});  // collinear: no area
    break;
  }
  ASSERT_EQ(box.faces.size(), test::box(size, 7).faces.size() + 2);
  RemeshOptions options;
  options.target_length = 0.05f;
  const RemeshResult r = remesh(box, options);
  EXPECT_EQ(r.stats.corner_vertices, 8u);
  // Every output vertex stays on the box's surface, and those on its crease lines stay there.
  for (std::size_t v = 0; v < r.mesh.vertex_count(); ++v) {
    const Eigen::Vector3f p = r.mesh.positions[v];
    const float outside = (p.cwiseMax(Eigen::Vector3f::Zero()) - p).norm() + (p - p.cwiseMin(size)).norm();
    const Eigen::Vector3f to_sides = p.cwiseMin(size - p);
    EXPECT_LT(outside + to_sides.minCoeff(), 1e-5f) << p.transpose();
  }
}

TEST(Remesh, BoxKeepsItsSharpEdgesAndCorners) {
  const Eigen::Vector3f size(1.0f, 0.6f, 0.8f);
  const Mesh box = test::box(size, 7);
  RemeshOptions options;
  options.target_length = 0.05f;
  const RemeshResult r = remesh(box, options);
  EXPECT_EQ(r.stats.corner_vertices, 8u);
  EXPECT_EQ(r.stats.feature_edges, 12u * 7u);
  const std::vector<Segment> lines = box_edges(size);
  const auto distance_to_lines = [&](const Eigen::Vector3f& p) {
    float best = INFINITY;
    for (const Segment& s : lines) best = std::min(best, distance_to_segment(p, s));
    return best;
  };
  // Every output edge whose faces meet at a sharp angle lies on the input's feature lines.
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::vector<Eigen::Vector3f>> edge_normals;
  for (const auto& f : r.mesh.faces) {
    const Eigen::Vector3f n = (r.mesh.positions[f[1]] - r.mesh.positions[f[0]])
                                  .cross(r.mesh.positions[f[2]] - r.mesh.positions[f[0]])
                                  .normalized();
    for (int k = 0; k < 3; ++k) edge_normals[std::minmax(f[k], f[(k + 1) % 3])].push_back(n);
  }
  std::size_t sharp = 0;
  double sharp_length = 0;
  for (const auto& [edge, normals] : edge_normals) {
    ASSERT_EQ(normals.size(), 2u);
    if (normals[0].dot(normals[1]) > std::cos(45.0 * std::numbers::pi / 180)) continue;
    ++sharp;
    const Eigen::Vector3f &a = r.mesh.positions[edge.first], &b = r.mesh.positions[edge.second];
    sharp_length += (b - a).norm();
    EXPECT_LT(distance_to_lines(a), 1e-6f);
    EXPECT_LT(distance_to_lines(b), 1e-6f);
  }
  EXPECT_GT(sharp, 0u);
  EXPECT_NEAR(sharp_length, 4 * (size.x() + size.y() + size.z()), 1e-4);  // the lines are complete
  for (int corner = 0; corner < 8; ++corner) {
    const Eigen::Vector3f c(corner & 1 ? size.x() : 0, corner & 2 ? size.y() : 0, corner & 4 ? size.z() : 0);
    EXPECT_TRUE(std::find(r.mesh.positions.begin(), r.mesh.positions.end(), c) != r.mesh.positions.end())
        << "corner " << c.transpose();
  }
  // Flat sides: every vertex stays on the box surface.
  for (const auto& p : r.mesh.positions) {
    const float to_side = std::min({std::abs(p.x()), std::abs(p.x() - size.x()), std::abs(p.y()),
                                    std::abs(p.y() - size.y()), std::abs(p.z()), std::abs(p.z() - size.z())});
    EXPECT_LT(to_side, 1e-6f);
  }
  const MeshQuality q = measure_quality(r.mesh, {}, r.target);
  EXPECT_GE(q.edges_in_range, 0.9);
  EXPECT_GE(q.angles_above_30, 0.9);
}

// A plane whose middle was pushed into a bump (the refined mesh) and the flat plane before.
struct DeformedPlane {
  Mesh before = test::flat_plane(40);
  Mesh after = test::bumped_plane(40, 0.25f, 0.1f);
};

TEST(Remesh, OnlyTheDeformedRegionChanges) {
  DeformedPlane plane;
  RemeshOptions options;
  options.region = grow_region(plane.after, deformed_vertices(plane.after, plane.before, 0, "before"), 1);
  options.target_length = 0.02f;
  const RemeshResult r = remesh(plane.after, options);
  EXPECT_GT(r.stats.splits, 0u);
  // Outside the region: every vertex at its exact place, every face with its vertices.
  std::vector<std::int64_t> output_of(plane.after.vertex_count(), -1);
  for (std::size_t i = 0; i < r.source_vertex.size(); ++i)
    if (r.source_vertex[i] >= 0) output_of[r.source_vertex[i]] = std::int64_t(i);
  for (std::size_t v = 0; v < plane.after.vertex_count(); ++v) {
    if (options.region[v]) continue;
    ASSERT_GE(output_of[v], 0) << "vertex " << v << " was removed";
    EXPECT_EQ(r.mesh.positions[output_of[v]], plane.after.positions[v]);
  }
  std::set<std::array<std::uint32_t, 3>> faces;
  for (const auto& f : r.mesh.faces) faces.insert(canonical(f));
  std::size_t outside_faces = 0;
  for (const auto& f : plane.after.faces) {
    if (options.region[f[0]] || options.region[f[1]] || options.region[f[2]]) continue;
    ++outside_faces;
    const std::array<std::uint32_t, 3> mapped{std::uint32_t(output_of[f[0]]), std::uint32_t(output_of[f[1]]),
                                              std::uint32_t(output_of[f[2]])};
    EXPECT_TRUE(faces.count(canonical(mapped))) << "an outside face lost its vertices";
  }
  EXPECT_GT(outside_faces, 1000u);
  // Inside: the bump is remeshed to the target and stays on it.
  for (std::size_t i = 0; i < r.mesh.vertex_count(); ++i) {
    const Eigen::Vector3f& p = r.mesh.positions[i];
    EXPECT_NEAR(p.z(), test::bump_height(p.x(), p.y(), 0.25f, 0.1f), 2e-3f);
  }
  std::vector<bool> inner(r.mesh.vertex_count());  // away from the seam, where old edges remain
  for (std::size_t i = 0; i < inner.size(); ++i)
    inner[i] = (r.mesh.positions[i].head<2>() - Eigen::Vector2f(0.5f, 0.5f)).norm() < 0.2f;
  const MeshQuality q = measure_quality(r.mesh, inner, r.target);
  EXPECT_GE(q.edges_in_range, 0.95);
  EXPECT_GE(q.angles_above_30, 0.95);
}

TEST(Remesh, PinnedVerticesStayExactly) {
  DeformedPlane plane;
  RemeshOptions options;
  options.region = grow_region(plane.after, deformed_vertices(plane.after, plane.before, 0, "before"), 1);
  options.target_length = 0.02f;
  options.pinned.assign(plane.after.vertex_count(), false);
  std::vector<std::size_t> pinned;
  for (std::size_t v = 0; v < plane.after.vertex_count(); v += 7)
    if (options.region[v]) {
      options.pinned[v] = true;
      pinned.push_back(v);
    }
  ASSERT_GT(pinned.size(), 20u);
  const RemeshResult r = remesh(plane.after, options);
  for (std::size_t v : pinned) {
    const auto it = std::find(r.source_vertex.begin(), r.source_vertex.end(), std::int64_t(v));
    ASSERT_NE(it, r.source_vertex.end()) << "pinned vertex " << v << " was removed";
    EXPECT_EQ(r.mesh.positions[it - r.source_vertex.begin()], plane.after.positions[v]);
  }
}

TEST(Remesh, CarriesPropertiesAndMasks) {
  DeformedPlane plane;
  Mesh mesh = plane.after;
  const std::size_t n = mesh.vertex_count();
  auto& working_set = mesh.vertex_properties["working_set"];
  auto& brush = mesh.vertex_properties["brush_weight"];
  for (const auto& p : mesh.positions) {
    working_set.push_back(p.x() < 0.5f ? 1.0f : 0.0f);  // the left half, crossing the bump
    brush.push_back(p.y());                             // a linear ramp
    mesh.colors.push_back({std::uint8_t(255 * p.x()), 0, 0});
  }
  ASSERT_EQ(working_set.size(), n);
  RemeshOptions options;
  options.target_length = 0.02f;
  const RemeshResult r = remesh(mesh, options);
  const auto& ws = r.mesh.vertex_properties.at("working_set");
  const auto& bw = r.mesh.vertex_properties.at("brush_weight");
  ASSERT_EQ(ws.size(), r.mesh.vertex_count());
  ASSERT_EQ(r.mesh.colors.size(), r.mesh.vertex_count());
  for (std::size_t i = 0; i < r.mesh.vertex_count(); ++i) {
    const Eigen::Vector3f& p = r.mesh.positions[i];
    if (std::abs(p.x() - 0.5f) > 0.03f) {
      EXPECT_EQ(ws[i], p.x() < 0.5f ? 1.0f : 0.0f) << p.transpose();
    }
    EXPECT_TRUE(ws[i] == 0.0f || ws[i] == 1.0f);         // a mask stays a mask
    EXPECT_NEAR(bw[i], p.y(), 1e-4f);                    // a linear field is interpolated exactly
    EXPECT_NEAR(r.mesh.colors[i][0], 255 * p.x(), 1.5);  // the input truncated, the output rounds
  }
}

TEST(Remesh, SameResultForAnyThreadCount) {
  const Mesh sphere = test::uv_sphere(24, 48, 1.0f);
  RemeshOptions options;
  options.target_length = 0.06f;
  set_thread_count(1);
  const RemeshResult one = remesh(sphere, options);
  set_thread_count(4);
  const RemeshResult four = remesh(sphere, options);
  set_thread_count(0);
  EXPECT_EQ(one.mesh.positions, four.mesh.positions);
  EXPECT_EQ(one.mesh.faces, four.mesh.faces);
}

TEST(Remesh, AdaptiveSizingShortensEdgesWhereCurvatureIsHigh) {
  // Two spheres of radius 1 and 0.25 joined in one mesh: the small one is four times as curved.
  Mesh mesh = test::uv_sphere(32, 64, 1.0f);
  const Mesh small = test::uv_sphere(16, 32, 0.25f);
  const auto offset = std::uint32_t(mesh.positions.size());
  for (const auto& p : small.positions) mesh.positions.push_back(p + Eigen::Vector3f(3, 0, 0));
  for (const auto& f : small.faces) mesh.faces.push_back({f[0] + offset, f[1] + offset, f[2] + offset});
  RemeshOptions options;
  options.target_length = 0.1f;
  options.adaptive = true;
  options.approximation_error = 0.001f;
  options.min_length = 0.01f;
  options.max_length = 1.0f;
  const RemeshResult r = remesh(mesh, options);
  // sqrt(6 e / k - 3 e^2) for k = 1 / radius.
  const auto expected = [&](float radius) { return std::sqrt(6 * 0.001f * radius - 3 * 0.001f * 0.001f); };
  double big_sum = 0, small_sum = 0;
  std::size_t big_count = 0, small_count = 0;
  for (std::size_t i = 0; i < r.target.size(); ++i) {
    const bool on_small = r.mesh.positions[i].x() > 2;
    (on_small ? small_sum : big_sum) += r.target[i];
    ++(on_small ? small_count : big_count);
  }
  EXPECT_NEAR(big_sum / double(big_count), expected(1.0f), 0.1 * expected(1.0f));
  EXPECT_NEAR(small_sum / double(small_count), expected(0.25f), 0.1 * expected(0.25f));
  const MeshQuality q = measure_quality(r.mesh, {}, r.target);
  EXPECT_GE(q.edges_in_range, 0.9);
  EXPECT_GE(q.angles_above_30, 0.9);
}

TEST(Remesh, RefusesBadTargetsAndNonManifoldInput) {
  const Mesh sphere = test::uv_sphere(8, 16, 1.0f);
  RemeshOptions options;
  options.target_length = -1;
  EXPECT_THROW(remesh(sphere, options), UsageError);
  options.target_length = 10;  // the bounding-box diagonal is 2 sqrt(3)
  EXPECT_THROW(remesh(sphere, options), UsageError);

  Mesh fin = test::flat_plane(4);  // two fins on the boundary edge (0, 1): three faces share it
  fin.positions.emplace_back(0.1f, 0.0f, 1.0f);
  fin.positions.emplace_back(0.1f, 0.0f, -1.0f);
  fin.faces.push_back({1, 0, std::uint32_t(fin.positions.size() - 2)});
  fin.faces.push_back({0, 1, std::uint32_t(fin.positions.size() - 1)});
  options = {};
  options.input_name = "fin.ply";
  try {
    remesh(fin, options);
    FAIL() << "non-manifold input accepted";
  } catch (const InputError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("fin.ply: "), std::string::npos) << message;
    EXPECT_NE(message.find("edge (0, 1) is shared by 3 faces at (0.125, 0, 0)"), std::string::npos)
        << message;
  }

  Mesh cones;  // two fans touching at vertex 0 only
  cones.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {-1, 0, 0}, {0, -1, 0}};
  cones.faces = {{0, 1, 2}, {0, 3, 4}};
  EXPECT_FALSE(find_non_manifold(cones).places.empty());
  ASSERT_EQ(find_non_manifold(cones).count, 1u);
  EXPECT_NE(find_non_manifold(cones).places[0].find("vertex 0"), std::string::npos)
      << find_non_manifold(cones).places[0];
}

TEST(Remesh, DropsUnusedVerticesAndSaysSo) {
  Mesh mesh = test::uv_sphere(16, 32, 1.0f);
  mesh.positions.insert(mesh.positions.begin(), Eigen::Vector3f(5, 5, 5));  // vertex 0 in no face
  for (auto& f : mesh.faces)
    for (auto& v : f) ++v;
  RemeshOptions options;
  options.iterations = 0;
  const RemeshResult r = remesh(mesh, options);
  EXPECT_EQ(r.stats.unused_vertices_dropped, 1u);
  EXPECT_EQ(r.mesh.vertex_count(), mesh.vertex_count() - 1);
  EXPECT_EQ(r.source_vertex[0], 1);
  for (std::size_t f = 0; f < mesh.face_count(); ++f)  // nothing else changed
    for (int k = 0; k < 3; ++k) EXPECT_EQ(r.mesh.faces[f][k] + 1, mesh.faces[f][k]);
}

TEST(RemeshBunny, ReachesTheTargetQuality) {
  PG_REQUIRE_REAL_DATA(path, "meshes/stanford-bunny/reconstruction/bun_zipper.ply");
  const Mesh bunny = read_mesh(path);
  const RemeshResult r = remesh(bunny, {});
  EXPECT_EQ(r.stats.unused_vertices_dropped, 1113u);
  EXPECT_NEAR(r.target_length, mean_edge_length(r.input), 1e-9);
  const MeshQuality q = measure_quality(r.mesh, {}, r.target);
  EXPECT_GE(q.edges_in_range, 0.95);
  EXPECT_GE(q.angles_above_30, 0.95);
  // Scan noise, the ears and the boundary make the bunny rough at its own edge length: over the
  // whole surface the distance is set by them. Where it is smooth at scale L (half the faces),
  // the remeshed surface stays within 0.1 L.
  const float spacing = 0.25f * r.target_length;
  const HausdorffDistance h = hausdorff_distance(r.mesh, {}, r.input, {}, spacing);
  EXPECT_LT(h.distance, 0.5 * r.target_length);
  const SmoothRegionHausdorff smooth =
      smooth_region_hausdorff(r.mesh, r.input, {}, r.target_length, 3, spacing);
  EXPECT_GT(smooth.input_fraction, 0.45);
  EXPECT_LT(smooth.hausdorff.distance, 0.1 * r.target_length);
}

}  // namespace
}  // namespace pg

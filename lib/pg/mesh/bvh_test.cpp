#include <gtest/gtest.h>

#include <random>
#include <thread>

#include "pg/mesh/bvh.h"
#include "pg/mesh/test_meshes.h"

namespace pg {
namespace {

using Vec3 = Eigen::Vector3f;
using Vec3d = Eigen::Vector3d;

// Reference geometry in double precision, written independently of the library's routines.
Vec3d closest_on_segment_reference(const Vec3d& p, const Vec3d& a, const Vec3d& b) {
  const Vec3d ab = b - a;
  const double length2 = ab.squaredNorm();
  const double t = length2 > 0 ? std::clamp((p - a).dot(ab) / length2, 0.0, 1.0) : 0.0;
  return a + t * ab;
}

// Projection onto the plane when it falls inside the triangle, else the nearest edge point.
double distance_reference(const Vec3& pf, const Vec3& af, const Vec3& bf, const Vec3& cf) {
  const Vec3d p = pf.cast<double>(), a = af.cast<double>(), b = bf.cast<double>(), c = cf.cast<double>();
  const Vec3d n = (b - a).cross(c - a);
  if (n.squaredNorm() > 1e-20) {
    const Vec3d q = p - (p - a).dot(n) / n.squaredNorm() * n;
    if ((b - a).cross(q - a).dot(n) >= 0 && (c - b).cross(q - b).dot(n) >= 0 &&
        (a - c).cross(q - c).dot(n) >= 0)
      return (p - q).norm();
  }
  return std::min({(p - closest_on_segment_reference(p, a, b)).norm(),
                   (p - closest_on_segment_reference(p, b, c)).norm(),
                   (p - closest_on_segment_reference(p, c, a)).norm()});
}

struct ReferenceHit {
  double t = INFINITY;
  bool grazing = false;  // within a hair of an edge or parallel, where float and double may disagree
};

ReferenceHit intersect_reference(const Mesh& mesh, const Vec3& of, const Vec3& df, double t_max) {
  const Vec3d o = of.cast<double>(), d = df.cast<double>();
  ReferenceHit best;
  for (const auto& f : mesh.faces) {
    const Vec3d a = mesh.positions[f[0]].cast<double>(), b = mesh.positions[f[1]].cast<double>(),
                c = mesh.positions[f[2]].cast<double>();
    // Solve o + t d = a + u (b - a) + v (c - a) by Cramer's rule on the columns (-d, b - a, c - a).
    const Vec3d e1 = b - a, e2 = c - a, s = o - a;
    const double det = (-d).dot(e1.cross(e2));
    if (std::abs(det) < 1e-14) continue;
    const double t = s.dot(e1.cross(e2)) / det, u = (-d).dot(s.cross(e2)) / det,
                 v = (-d).dot(e1.cross(s)) / det;
    const double margin = std::min({u, v, 1 - u - v});
    if (margin < -1e-5 || t < -1e-6 || t > t_max) continue;
    const bool grazing = margin < 1e-5 || std::abs(det) < 1e-6 || t < 1e-6;
    if (margin < 0 && !grazing) continue;
    if (t < best.t) {
      best.t = t;
      best.grazing = grazing;
    } else if (std::abs(t - best.t) < 1e-6) {
      best.grazing = best.grazing || grazing;
    }
  }
  return best;
}

Mesh bumpy_grid() {
  Mesh mesh = test::grid_mesh(40, 30, 0.025f);
  for (auto& p : mesh.positions) p.z() = 0.1f * std::sin(9 * p.x()) * std::cos(7 * p.y());
  return mesh;
}

TEST(ClosestPointOnTriangle, MatchesReferenceInEveryRegion) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> coord(-1.0f, 1.0f);
  for (int i = 0; i < 20000; ++i) {
    const Vec3 a{coord(rng), coord(rng), coord(rng)}, b{coord(rng), coord(rng), coord(rng)},
        c = i % 50 == 0 ? b : Vec3{coord(rng), coord(rng), coord(rng)};
    const Vec3 p = 2 * Vec3{coord(rng), coord(rng), coord(rng)};
    const Vec3 q = closest_point_on_triangle(p, a, b, c);
    ASSERT_NEAR((q - p).norm(), distance_reference(p, a, b, c), 2e-5) << i;
    // The point is on the triangle: its distance to the triangle is zero.
    ASSERT_NEAR(distance_reference(q, a, b, c), 0.0, 2e-5) << i;
  }
}

void check_closest_against_brute_force(const Mesh& mesh, std::uint32_t seed) {
  const TriangleBvh bvh(mesh);
  ASSERT_EQ(bvh.face_count(), mesh.face_count());
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> coord(-0.3f, 1.3f);
  for (int i = 0; i < 3000; ++i) {
    const Vec3 query{coord(rng), coord(rng), coord(rng) * 0.5f};
    float brute = INFINITY;
    double reference = INFINITY;
    for (const auto& f : mesh.faces) {
      const Vec3& a = mesh.positions[f[0]];
      const Vec3& b = mesh.positions[f[1]];
      const Vec3& c = mesh.positions[f[2]];
      brute = std::min(brute, (closest_point_on_triangle(query, a, b, c) - query).norm());
      reference = std::min(reference, distance_reference(query, a, b, c));
    }
    const auto hit = bvh.closest_point(query);
    ASSERT_LT(hit.face, mesh.face_count());
    ASSERT_FLOAT_EQ(hit.distance, brute) << i;
    ASSERT_NEAR(hit.distance, reference, 2e-5) << i;
    const auto& f = mesh.faces[hit.face];
    ASSERT_NEAR(
        distance_reference(hit.point, mesh.positions[f[0]], mesh.positions[f[1]], mesh.positions[f[2]]), 0.0,
        2e-5);
    ASSERT_NEAR((hit.point - query).norm(), hit.distance, 1e-6);
    // A search radius just short of the answer finds nothing; just beyond it finds the same distance.
    const auto none = bvh.closest_point(query, hit.distance * 0.999f - 1e-6f);
    EXPECT_EQ(none.face, UINT32_MAX);
    EXPECT_EQ(none.distance, INFINITY);
    EXPECT_FLOAT_EQ(bvh.closest_point(query, hit.distance * 1.001f + 1e-6f).distance, hit.distance);
  }
}

TEST(TriangleBvh, ClosestPointEqualsBruteForceOnTriangleSoup) {
  check_closest_against_brute_force(test::random_soup(3000, 0.05f, 1), 2);
}

TEST(TriangleBvh, ClosestPointEqualsBruteForceOnBumpyGrid) {
  check_closest_against_brute_force(bumpy_grid(), 3);
}

void check_rays_against_brute_force(const Mesh& mesh, std::uint32_t seed) {
  const TriangleBvh bvh(mesh);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> coord(-0.5f, 1.5f), unit(0.0f, 1.0f);
  int hits = 0, grazing_disagreements = 0;
  const int rays = 3000;
  for (int i = 0; i < rays; ++i) {
    const Vec3 origin{coord(rng), coord(rng), coord(rng)};
    // Most rays aim into the mesh's box; some go anywhere; direction lengths vary.
    const Vec3 target =
        i % 4 == 0 ? Vec3{coord(rng), coord(rng), coord(rng)} : Vec3{unit(rng), unit(rng), 0.5f * unit(rng)};
    const Vec3 direction = (target - origin) * (0.5f + unit(rng));
    const float t_max = i % 5 == 0 ? 0.8f : INFINITY;
    const ReferenceHit reference = intersect_reference(mesh, origin, direction, t_max);
    const auto hit = bvh.intersect(origin, direction, t_max);
    const bool agrees = hit.hit == std::isfinite(reference.t) &&
                        (!hit.hit || std::abs(hit.t - reference.t) <= 1e-4 * (1 + reference.t));
    if (!agrees) {
      ASSERT_TRUE(reference.grazing) << "ray " << i << ": bvh t " << hit.t << ", reference t " << reference.t;
      ++grazing_disagreements;
      continue;
    }
    if (!hit.hit) {
      EXPECT_EQ(hit.face, UINT32_MAX);
      continue;
    }
    ++hits;
    ASSERT_LE(hit.t, t_max);
    // The barycentric coordinates give the same point as the ray parameter.
    const auto& f = mesh.faces[hit.face];
    const Vec3 on_face = (1 - hit.b1 - hit.b2) * mesh.positions[f[0]] + hit.b1 * mesh.positions[f[1]] +
                         hit.b2 * mesh.positions[f[2]];
    ASSERT_LT((on_face - (origin + hit.t * direction)).norm(), 1e-4) << i;
    ASSERT_GE(hit.b1, 0.0f);
    ASSERT_GE(hit.b2, 0.0f);
    ASSERT_LE(hit.b1 + hit.b2, 1.0f + 1e-6f);
  }
  EXPECT_GT(hits, rays / 4);
  EXPECT_LE(grazing_disagreements, rays / 200);
}

TEST(TriangleBvh, RayHitsEqualBruteForceOnTriangleSoup) {
  check_rays_against_brute_force(test::random_soup(3000, 0.05f, 4), 5);
}

TEST(TriangleBvh, RayHitsEqualBruteForceOnBumpyGrid) {
  check_rays_against_brute_force(bumpy_grid(), 6);
}

TEST(TriangleBvh, AxisAlignedRaysAndKnownHit) {
  const Mesh mesh = test::grid_mesh(4, 4, 0.25f);  // the unit square at z = 0
  const TriangleBvh bvh(mesh);
  const auto down = bvh.intersect(Vec3(0.3f, 0.6f, 2.0f), Vec3(0, 0, -1));
  ASSERT_TRUE(down.hit);
  EXPECT_FLOAT_EQ(down.t, 2.0f);
  EXPECT_FALSE(bvh.intersect(Vec3(0.3f, 0.6f, 2.0f), Vec3(0, 0, -1), 1.9f).hit);
  EXPECT_FALSE(bvh.intersect(Vec3(0.3f, 0.6f, 2.0f), Vec3(0, 0, 1)).hit);   // pointing away
  EXPECT_FALSE(bvh.intersect(Vec3(1.5f, 0.6f, 2.0f), Vec3(0, 0, -1)).hit);  // beside the square
  EXPECT_FALSE(bvh.intersect(Vec3(0.3f, 0.6f, 1.0f), Vec3(1, 0, 0)).hit);   // parallel above it
  const auto up = bvh.intersect(Vec3(0.3f, 0.6f, -1.0f), Vec3(0, 0, 4));    // from below, scaled direction
  ASSERT_TRUE(up.hit);
  EXPECT_FLOAT_EQ(up.t, 0.25f);
  const auto closest = bvh.closest_point(Vec3(2.0f, 0.5f, 1.0f));
  EXPECT_FLOAT_EQ(closest.distance, std::sqrt(2.0f));
  EXPECT_TRUE(closest.point.isApprox(Vec3(1.0f, 0.5f, 0.0f)));
}

TEST(TriangleBvh, EmptyMeshAndDestroyedSource) {
  const TriangleBvh empty{Mesh{}};
  EXPECT_EQ(empty.face_count(), 0u);
  EXPECT_EQ(empty.closest_point(Vec3::Zero()).face, UINT32_MAX);
  EXPECT_FALSE(empty.intersect(Vec3::Zero(), Vec3(1, 0, 0)).hit);
  auto mesh = std::make_unique<Mesh>(test::grid_mesh(2, 2));
  const TriangleBvh bvh(*mesh);
  mesh.reset();
  EXPECT_FLOAT_EQ(bvh.closest_point(Vec3(0.5f, 0.5f, 3.0f)).distance, 3.0f);
}

TEST(TriangleBvh, CoincidentTrianglesStillBuild) {
  // Thousands of triangles with the same centroid: no plane separates them.
  Mesh mesh;
  for (std::uint32_t i = 0; i < 5000; ++i) {
    const float s = 1.0f + float(i % 7);
    mesh.positions.insert(mesh.positions.end(), {Vec3(-s, -s, 0), Vec3(2 * s, -s, 0), Vec3(-s, 2 * s, 0)});
    mesh.faces.push_back({3 * i, 3 * i + 1, 3 * i + 2});
  }
  const TriangleBvh bvh(mesh);
  EXPECT_FLOAT_EQ(bvh.closest_point(Vec3(0, 0, 2)).distance, 2.0f);
  EXPECT_FLOAT_EQ(bvh.intersect(Vec3(0, 0, 2), Vec3(0, 0, -1)).t, 2.0f);
}

TEST(TriangleBvh, ConcurrentQueriesMatchSequentialOnes) {
  const Mesh mesh = test::random_soup(20000, 0.02f, 9);
  const TriangleBvh bvh(mesh);
  std::mt19937 rng(10);
  std::uniform_real_distribution<float> coord(0.0f, 1.0f);
  std::vector<Vec3> queries(4000);
  for (auto& q : queries) q = Vec3{coord(rng), coord(rng), coord(rng)};
  std::vector<TriangleBvh::ClosestHit> sequential;
  for (const auto& q : queries) sequential.push_back(bvh.closest_point(q));
  std::vector<std::vector<TriangleBvh::ClosestHit>> per_thread(4);
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t)
    threads.emplace_back([&, t] {
      for (const auto& q : queries) per_thread[t].push_back(bvh.closest_point(q));
    });
  for (auto& thread : threads) thread.join();
  for (const auto& results : per_thread)
    for (std::size_t i = 0; i < queries.size(); ++i) {
      ASSERT_EQ(results[i].face, sequential[i].face);
      ASSERT_EQ(results[i].distance, sequential[i].distance);
    }
}

}  // namespace
}  // namespace pg

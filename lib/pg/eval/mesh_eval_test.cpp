#include <gtest/gtest.h>

#include <cmath>
#include <map>

#include "pg/core/error.h"
#include "pg/core/parallel.h"
#include "pg/eval/mesh_eval.h"

namespace {

// The unit square at height z as an n x n grid of quads split into triangles.
pg::Mesh plane(int n, float z) {
  pg::Mesh m;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) m.positions.emplace_back(float(i) / n, float(j) / n, z);
  auto v = [n](int i, int j) { return std::uint32_t(j * (n + 1) + i); };
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      m.faces.push_back({v(i, j), v(i + 1, j), v(i + 1, j + 1)});
      m.faces.push_back({v(i, j), v(i + 1, j + 1), v(i, j + 1)});
    }
  return m;
}

// An icosphere of the given radius (subdivided icosahedron, vertices projected onto the sphere).
pg::Mesh icosphere(int level, float radius) {
  const float t = (1.0f + std::sqrt(5.0f)) / 2.0f;
  std::vector<Eigen::Vector3f> p = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0},
                                    {0, -1, t}, {0, 1, t}, {0, -1, -t}, {0, 1, -t},
                                    {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  for (auto& q : p) q.normalize();
  std::vector<std::array<std::uint32_t, 3>> f = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                                 {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                                 {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                                 {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (int l = 0; l < level; ++l) {
    std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> midpoints;
    auto mid = [&](std::uint32_t a, std::uint32_t b) {
      auto key = std::minmax(a, b);
      auto [it, inserted] = midpoints.try_emplace({key.first, key.second}, std::uint32_t(p.size()));
      if (inserted) p.push_back((p[a] + p[b]).normalized());
      return it->second;
    };
    std::vector<std::array<std::uint32_t, 3>> next;
    for (const auto& [a, b, c] : f) {
      std::uint32_t ab = mid(a, b), bc = mid(b, c), ca = mid(c, a);
      next.insert(next.end(), {{a, ab, ca}, {b, bc, ab}, {c, ca, bc}, {ab, bc, ca}});
    }
    f = std::move(next);
  }
  pg::Mesh m;
  for (const auto& q : p) m.positions.push_back(radius * q);
  m.faces = f;
  return m;
}

}  // namespace

TEST(EvaluateMesh, PlaneShiftedAlongItsNormal) {
  pg::MeshEvalOptions options;
  options.samples = 20000;
  options.thresholds = {0.005, 0.02};
  pg::MeshEvalResult r = pg::evaluate_mesh(plane(10, 0.01f), plane(10, 0.0f), options);
  EXPECT_EQ(r.estimate_points, 20000u + 121u);
  EXPECT_EQ(r.truth_points, 20000u + 121u);
  for (const pg::ErrorStats* s : {&r.accuracy, &r.completeness}) {
    EXPECT_NEAR(s->mean, 0.01, 1e-5);
    EXPECT_NEAR(s->median, 0.01, 1e-5);
    EXPECT_NEAR(s->p99, 0.01, 1e-5);
    EXPECT_NEAR(s->max, 0.01, 1e-5);
  }
  EXPECT_NEAR(r.chamfer, 0.01, 1e-5);
  EXPECT_EQ(r.precision, (std::vector<double>{0, 1}));
  EXPECT_EQ(r.recall, (std::vector<double>{0, 1}));
  EXPECT_EQ(r.fscore, (std::vector<double>{0, 1}));
}

TEST(EvaluateMesh, ConcentricSpheres) {
  // Same tessellation at radii 1 and 1.05: facets are parallel, so every distance lies in
  // [0.05 h, 0.05] where h (> 0.999 at level 5) is the smallest facet-plane distance of the unit sphere.
  const float d = 0.05f;
  pg::MeshEvalOptions options;
  options.samples = 50000;
  pg::MeshEvalResult r = pg::evaluate_mesh(icosphere(5, 1.0f + d), icosphere(5, 1.0f), options);
  for (const pg::ErrorStats* s : {&r.accuracy, &r.completeness}) {
    EXPECT_NEAR(s->mean, d, 1e-4);
    EXPECT_NEAR(s->median, d, 1e-4);
    EXPECT_LT(s->max, d + 1e-5);
    EXPECT_GT(s->median, d * 0.999);
  }
}

TEST(EvaluateMesh, MissingPartLowersCompletenessOnly) {
  // The estimate covers only the left half of the truth plane: accuracy stays 0, and the truth's right
  // half lies up to 0.5 away, so about half of the truth points are beyond 0.01.
  pg::Mesh truth = plane(10, 0.0f);
  pg::Mesh half;
  half.positions = truth.positions;
  for (const auto& f : truth.faces)
    if (truth.positions[f[0]].x() + truth.positions[f[1]].x() + truth.positions[f[2]].x() < 1.5f)
      half.faces.push_back(f);
  pg::MeshEvalOptions options;
  options.samples = 40000;
  options.thresholds = {0.01};
  pg::MeshEvalResult r = pg::evaluate_mesh(half, truth, options);
  EXPECT_LT(r.accuracy.max, 1e-6);
  EXPECT_NEAR(r.completeness.max, 0.5, 1e-3);
  EXPECT_NEAR(r.recall[0], 0.51, 0.02);  // the half plus a 0.01 band
  EXPECT_EQ(r.precision[0], 1.0);
  // Distances on the missing half are uniform in [0, 0.5]: mean over all truth points ~ 0.5 * 0.25.
  EXPECT_NEAR(r.completeness.mean, 0.125, 0.01);
}

TEST(EvaluateMesh, DeterministicAcrossThreadCounts) {
  pg::MeshEvalOptions options;
  options.samples = 30000;
  options.seed = 7;
  pg::Mesh a = icosphere(3, 1.0f), b = icosphere(2, 1.1f);
  pg::set_thread_count(1);
  pg::MeshEvalResult one = pg::evaluate_mesh(a, b, options);
  pg::set_thread_count(2);
  pg::MeshEvalResult two = pg::evaluate_mesh(a, b, options);
  pg::set_thread_count(0);
  EXPECT_EQ(one.to_json(), two.to_json());
  options.seed = 8;
  EXPECT_NE(pg::evaluate_mesh(a, b, options).accuracy.mean, one.accuracy.mean);
}

TEST(SampleSurface, IsAreaUniformAndOnTheSurface) {
  // Two triangles with areas 1 and 3 in the plane z = 2; a degenerate third face is never sampled.
  pg::Mesh m;
  m.positions = {{0, 0, 2}, {2, 0, 2}, {0, 1, 2}, {10, 0, 2}, {13, 0, 2}, {10, 2, 2}, {5, 5, 5}};
  m.faces = {{0, 1, 2}, {3, 4, 5}, {6, 6, 6}};
  std::vector<Eigen::Vector3f> s = pg::sample_surface(m, 100000, 3);
  ASSERT_EQ(s.size(), 100000u);
  std::size_t in_big = 0;
  for (const auto& p : s) {
    ASSERT_FLOAT_EQ(p.z(), 2.0f);
    bool big = p.x() >= 10;
    in_big += big;
    Eigen::Vector2f q = big ? Eigen::Vector2f(p.x() - 10, p.y()) : Eigen::Vector2f(p.x(), p.y());
    float legs = big ? 3 : 2, height = big ? 2 : 1;  // right triangles at the origin of q
    ASSERT_GE(q.x(), -1e-5f);
    ASSERT_GE(q.y(), -1e-5f);
    ASSERT_LE(q.x() / legs + q.y() / height, 1 + 1e-5f);
  }
  EXPECT_NEAR(double(in_big) / s.size(), 0.75, 0.01);
  EXPECT_EQ(pg::sample_surface(m, 100000, 3), s);
}

TEST(EvaluateMesh, RejectsMeshesWithoutSurface) {
  pg::Mesh empty;
  EXPECT_THROW(pg::evaluate_mesh(empty, plane(2, 0)), pg::FailedError);
  EXPECT_THROW(pg::evaluate_mesh(plane(2, 0), empty), pg::FailedError);
}

#include "pg/remesh/quality.h"

#include <gtest/gtest.h>

#include "pg/core/error.h"
#include "pg/remesh/region.h"
#include "pg/remesh/test_shapes.h"

namespace pg {
namespace {

TEST(Quality, RightTrianglesOfAGrid) {
  // A grid of right isosceles triangles: angles 45, edges 1 (sides) and sqrt 2 (diagonals).
  const Mesh grid = test::flat_plane(4);
  const MeshQuality q = measure_quality(grid, {}, std::vector<float>(grid.vertex_count(), 0.25f));
  EXPECT_EQ(q.faces, 32u);
  EXPECT_EQ(q.edges, 40u + 16u);  // 2 * 4 * 5 sides and 16 diagonals
  EXPECT_NEAR(q.smallest_angle_deg, 45, 1e-4);
  EXPECT_EQ(q.angles_above_30, 1.0);
  EXPECT_NEAR(q.edges_in_range, 40.0 / 56.0, 1e-12);  // sqrt 2 = 1.41 is out of range
  EXPECT_EQ(q.min_angle_deg.counts[9], 32u);          // [45, 50)
  EXPECT_EQ(q.vertices, 9u);                          // interior vertices, all of valence 6
  EXPECT_EQ(q.valence_6, 1.0);
  EXPECT_EQ(q.valence.counts[3], 9u);
}

TEST(Quality, SelectionLimitsWhatIsMeasured) {
  const Mesh grid = test::flat_plane(4);
  std::vector<bool> selected(grid.vertex_count(), false);
  selected[0] = selected[1] = selected[6] = true;  // the first triangle (0, 1, 6)
  const MeshQuality q = measure_quality(grid, selected, std::vector<float>(grid.vertex_count(), 0.25f));
  EXPECT_EQ(q.faces, 1u);
  EXPECT_EQ(q.edges, 3u);
  EXPECT_EQ(faces_within(grid, selected)[0], true);
  EXPECT_EQ(faces_touching(grid, selected)[1], true);  // (0, 6, 5) touches the selection
}

TEST(Quality, HausdorffOfParallelPlanesIsTheirDistance) {
  const Mesh a = test::flat_plane(5);
  Mesh b = test::flat_plane(3);
  for (auto& p : b.positions) p.z() = 0.125f;
  const HausdorffDistance h = hausdorff_distance(a, {}, b, {}, 0.05f);
  EXPECT_NEAR(h.distance, 0.125, 1e-6);
  EXPECT_NEAR(h.a_to_b, 0.125, 1e-6);
  EXPECT_GT(h.samples, 2u * 36u);
  // A bump of height 0.1 against the flat plane: the top of the bump is the farthest point.
  const HausdorffDistance bump =
      hausdorff_distance(test::bumped_plane(40, 0.25f, 0.1f), {}, test::flat_plane(40), {}, 0.01f);
  EXPECT_NEAR(bump.distance, 0.1, 1e-6);
  EXPECT_NEAR(bump.b_to_a, 0.1 * 0.5 * (1 + std::cos(std::numbers::pi * 0.0125 / 0.25)), 2e-3);
}

TEST(Quality, SmoothWhereTheCurvatureRadiusIsLargeAgainstL) {
  const Mesh sphere = test::uv_sphere(32, 64, 1.0f);
  const std::vector<bool> at_quarter = smooth_vertices(sphere, 0.25f, 3);  // R = 4 L
  const std::vector<bool> at_half = smooth_vertices(sphere, 0.5f, 3);      // R = 2 L
  EXPECT_EQ(std::count(at_quarter.begin(), at_quarter.end(), true), std::ptrdiff_t(sphere.vertex_count()));
  EXPECT_EQ(std::count(at_half.begin(), at_half.end(), true), 0);
  // A box at L = its grid step: flat sides are smooth, except the crease vertices and the ring next
  // to them (within L of a crease), leaving 5 x 5 of each side's 9 x 9 vertices.
  const Mesh box = test::box({1, 1, 1}, 8);
  const std::vector<bool> smooth = smooth_vertices(box, 0.125f, 3);
  EXPECT_EQ(std::count(smooth.begin(), smooth.end(), true), 6 * 25);
  const SmoothRegionHausdorff self = smooth_region_hausdorff(box, box, {}, 0.125f, 3, 0.05f);
  EXPECT_NEAR(self.input_fraction, 6.0 * 32 / double(box.face_count()), 1e-12);
  EXPECT_LT(self.hausdorff.distance, 1e-6);
  EXPECT_GT(self.hausdorff.samples, 0u);
}

TEST(Region, DeformedVerticesGrownByRings) {
  const Mesh before = test::flat_plane(10);
  Mesh after = before;
  after.positions[60].z() = 0.5f;  // interior vertex (5, 5)
  const std::vector<bool> moved = deformed_vertices(after, before, 1e-6f, "before.ply");
  EXPECT_EQ(std::count(moved.begin(), moved.end(), true), 1);
  const std::vector<bool> one = grow_region(after, moved, 1), two = grow_region(after, moved, 2);
  EXPECT_EQ(std::count(one.begin(), one.end(), true), 7);   // valence 6 + itself
  EXPECT_EQ(std::count(two.begin(), two.end(), true), 19);  // hexagonal ring of 12 more
  after.positions[60].z() = 1e-7f;
  const std::vector<bool> within_tolerance = deformed_vertices(after, before, 1e-6f, "before.ply");
  EXPECT_EQ(std::count(within_tolerance.begin(), within_tolerance.end(), true), 0);
  EXPECT_THROW(deformed_vertices(after, test::flat_plane(9), 0, "before.ply"), InputError);
}

}  // namespace
}  // namespace pg

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "pg/core/error.h"
#include "pg/depth/depth_geometry.h"
#include "pg/depth/depth_pair.h"
#include "pg/depth/test_scene.h"

namespace {

using pg::depth_testing::look_at_camera;
using pg::depth_testing::render;

struct Scene {
  pg::Camera left = look_at_camera("left", {-0.15, 0, 0}, {0, 0.1, 4});
  pg::Camera right = look_at_camera("right", {0.15, 0, 0}, {0, 0.1, 4});
  pg::depth_testing::RenderedView left_view = render(left), right_view = render(right);
};

const Scene& scene() {
  static const Scene s;
  return s;
}

// Pixels of `a` whose true surface point is seen by `b` (in its image and not occluded).
cv::Mat1b visible_in(const pg::Camera& a, const cv::Mat1f& depth_a, const pg::Camera& b,
                     const cv::Mat1f& depth_b) {
  cv::Mat1b visible(depth_a.size(), std::uint8_t{0});
  const pg::Rigid3 b_from_a = b.cam_from_world * a.cam_from_world.inverse();
  for (int y = 0; y < depth_a.rows; ++y)
    for (int x = 0; x < depth_a.cols; ++x) {
      const Eigen::Vector3d p =
          b_from_a * pg::point_from_depth(a, pg::DepthKind::perspective_z, {x, y}, depth_a(y, x));
      Eigen::Vector2d q;
      if (!b.project(p, q) || !b.in_image(q, 1)) continue;
      const float seen = depth_b(static_cast<int>(std::lround(q.y())), static_cast<int>(std::lround(q.x())));
      visible(y, x) = std::abs(seen - p.z()) < 0.01 * p.z() ? 255 : 0;
    }
  return visible;
}

pg::DepthPairResult run(bool epipolar, bool keep_all = false, bool fill_occlusions = false) {
  pg::DepthPairInput input;
  input.reference = scene().left;
  input.other = scene().right;
  input.reference_image = scene().left_view.image;
  input.other_image = scene().right_view.image;
  pg::DepthPairOptions options;
  options.epipolar = epipolar;
  options.filter.keep_all = keep_all;
  options.fill_occlusions = fill_occlusions;
  return pg::compute_depth_pair(input, options);
}

struct Accuracy {
  double median = 0, p90 = 0, coverage = 0;
};

Accuracy accuracy(const pg::DepthMap& map) {
  const cv::Mat1b visible =
      visible_in(scene().left, scene().left_view.depth, scene().right, scene().right_view.depth);
  std::vector<double> errors;
  std::size_t visible_count = 0;
  for (int y = 0; y < visible.rows; ++y)
    for (int x = 0; x < visible.cols; ++x) {
      if (!visible(y, x)) continue;
      ++visible_count;
      const float d = map.depth.at<float>(y, x), truth = scene().left_view.depth(y, x);
      if (std::isfinite(d)) errors.push_back(std::abs(d - truth) / truth);
    }
  std::sort(errors.begin(), errors.end());
  Accuracy a;
  a.coverage = static_cast<double>(errors.size()) / visible_count;
  a.median = errors[errors.size() / 2];
  a.p90 = errors[errors.size() * 9 / 10];
  return a;
}

TEST(DepthPair, EpipolarDepthMatchesExactDepth) {
  const pg::DepthPairResult result = run(true);
  const Accuracy a = accuracy(result.depth.map);
  ::testing::Test::RecordProperty("median_relative_error", std::to_string(a.median));
  ::testing::Test::RecordProperty("p90_relative_error", std::to_string(a.p90));
  ::testing::Test::RecordProperty("coverage", std::to_string(a.coverage));
  EXPECT_LT(a.median, 0.005);
  EXPECT_LT(a.p90, 0.02);
  EXPECT_GT(a.coverage, 0.90);
  EXPECT_EQ(result.depth.map.kind, pg::DepthKind::perspective_z);
  EXPECT_EQ(result.depth.map.camera.id, "left");
}

TEST(DepthPair, FreeFlowDepthMatchesExactDepth) {
  const Accuracy a = accuracy(run(false).depth.map);
  EXPECT_LT(a.median, 0.01);
  EXPECT_LT(a.p90, 0.03);
  EXPECT_GT(a.coverage, 0.85);
}

TEST(DepthPair, KeepAllKeepsRejectedDepthsWithZeroConfidence) {
  const pg::DepthPairResult filtered = run(true), all = run(true, true);
  std::size_t kept_rejected = 0;
  for (int y = 0; y < all.depth.map.depth.rows; ++y)
    for (int x = 0; x < all.depth.map.depth.cols; ++x)
      if (!std::isfinite(filtered.depth.map.depth.at<float>(y, x)) &&
          std::isfinite(all.depth.map.depth.at<float>(y, x))) {
        ++kept_rejected;
        EXPECT_EQ(all.depth.map.confidence.at<float>(y, x), 0.f);
      }
  EXPECT_GT(kept_rejected, 0u);
}

// The wall and floor just beside the sphere that the right view cannot see take the depth of the
// background next to them: close to their true depth, at half confidence; visible pixels keep theirs.
TEST(DepthPair, FilledOcclusionsTakeTheBackgroundDepth) {
  const pg::DepthPairResult plain = run(true), filled = run(true, false, true);
  const cv::Mat1b visible =
      visible_in(scene().left, scene().left_view.depth, scene().right, scene().right_view.depth);
  std::vector<double> errors;
  for (int y = 0; y < visible.rows; ++y)
    for (int x = 0; x < visible.cols; ++x) {
      const float d = filled.depth.map.depth.at<float>(y, x), truth = scene().left_view.depth(y, x);
      if (visible(y, x) || !std::isfinite(d) || std::isfinite(plain.depth.map.depth.at<float>(y, x)))
        continue;
      errors.push_back(std::abs(d - truth) / truth);
      EXPECT_LE(filled.depth.map.confidence.at<float>(y, x), 0.5f + 1e-4f);
    }
  ASSERT_GT(errors.size(), 200u);  // the sphere hides a crescent of the wall from the right view
  std::sort(errors.begin(), errors.end());
  ::testing::Test::RecordProperty("filled_median_relative_error", std::to_string(errors[errors.size() / 2]));
  EXPECT_LT(errors[errors.size() / 2], 0.03);
  EXPECT_GT(filled.filled, errors.size());
  EXPECT_GT(filled.depth.valid, plain.depth.valid);
  EXPECT_LT(accuracy(filled.depth.map).median, 0.005);
  // A hidden pixel whose line has no background keeps its own flow, which failed the consistency
  // check: it is not counted (nor published) as filled.
  std::size_t changed = 0;
  for (int y = 0; y < visible.rows; ++y)
    for (int x = 0; x < visible.cols; ++x) changed += filled.flow(y, x) != plain.flow(y, x);
  EXPECT_EQ(filled.filled, changed);
  pg::DepthPairOptions free_fill;
  free_fill.epipolar = false;
  free_fill.fill_occlusions = true;
  EXPECT_THROW(free_fill.check(), pg::UsageError);
}

TEST(DepthPair, RejectsCamerasWithoutBaselineAndMismatchedImages) {
  pg::DepthPairInput input;
  input.reference = scene().left;
  input.other = scene().left;
  input.other.id = "twin";
  input.reference_image = scene().left_view.image;
  input.other_image = scene().right_view.image;
  EXPECT_THROW(pg::compute_depth_pair(input), pg::UsageError);
  input.other = scene().right;
  input.other_image = cv::Mat3b(10, 10);
  EXPECT_THROW(pg::compute_depth_pair(input), pg::UsageError);
}

// Flow from the true depth: each pixel of `a` moves to where its true point projects in `b`.
cv::Mat2f exact_flow(const pg::Camera& a, const pg::Camera& b) {
  cv::Mat2f flow(a.height, a.width);
  for (int y = 0; y < a.height; ++y)
    for (int x = 0; x < a.width; ++x) {
      const Eigen::Vector3d p =
          a.cam_from_world.inverse() *
          pg::point_from_depth(a, pg::DepthKind::perspective_z, {x, y}, scene().left_view.depth(y, x));
      Eigen::Vector2d q;
      b.project_world(p, q);
      flow(y, x) = cv::Vec2f(static_cast<float>(q.x() - x), static_cast<float>(q.y() - y));
    }
  return flow;
}

// The left view, the right view and the exact flow between them.
pg::DepthFromFlowInput exact_input() {
  pg::DepthFromFlowInput input;
  input.reference = &scene().left;
  input.other = &scene().right;
  input.flow = exact_flow(scene().left, scene().right);
  return input;
}

TEST(DepthFromFlow, ExactFlowTriangulatesExactlyAndMasksAreHonoured) {
  const pg::Camera& a = scene().left;
  pg::DepthFromFlowInput input = exact_input();
  input.reference_mask = cv::Mat1b::zeros(a.height, a.width);
  input.reference_mask(cv::Rect(0, 0, 40, 40)).setTo(255);
  const pg::DepthFromFlowResult result = pg::depth_from_flow(input);
  EXPECT_EQ(result.rejections.masked, 1600u);
  EXPECT_TRUE(std::isnan(result.map.depth.at<float>(10, 10)));
  EXPECT_EQ(result.map.mask.at<std::uint8_t>(10, 10), 255);
  const int y = 120, x = 160;  // on the sphere
  EXPECT_NEAR(result.map.depth.at<float>(y, x), scene().left_view.depth(y, x), 1e-4);
  // The sphere's normal at the pixel: from the centre to the surface point, in the camera frame.
  const Eigen::Vector3d p =
      pg::point_from_depth(a, pg::DepthKind::perspective_z, {x, y}, scene().left_view.depth(y, x));
  const Eigen::Vector3d centre_cam = a.cam_from_world * Eigen::Vector3d(0, 0.1, 4);
  const Eigen::Vector3d expected = (p - centre_cam).normalized();
  const cv::Vec3f n = result.map.normals.at<cv::Vec3f>(y, x);
  EXPECT_GT(expected.dot(Eigen::Vector3d(n[0], n[1], n[2])), 0.999);
  EXPECT_GT(result.valid_fraction(), 0.8);
}

// Textureless pixels are rejected after the other checks: --keep-all keeps their (triangulated)
// depth, and a pixel the other view's mask hides counts as masked, not textureless. Before, they
// were rejected before triangulation, so --keep-all left them NaN.
TEST(DepthFromFlow, TexturelessPixelsAreTriangulatedAndCountedLast) {
  const pg::Camera& a = scene().left;
  const pg::Camera& b = scene().right;
  pg::DepthFromFlowInput input = exact_input();
  input.texture = cv::Mat1f(a.height, a.width, 1.0f);
  const cv::Rect flat(150, 110, 20, 20);  // on the sphere, seen by both views
  input.texture(flat).setTo(0.0f);
  pg::DepthFilterOptions options;
  const pg::DepthFromFlowResult filtered = pg::depth_from_flow(input, options);
  EXPECT_EQ(filtered.rejections.textureless, std::size_t(flat.area()));
  EXPECT_TRUE(std::isnan(filtered.map.depth.at<float>(120, 160)));

  options.keep_all = true;
  const pg::DepthFromFlowResult all = pg::depth_from_flow(input, options);
  EXPECT_EQ(all.rejections.textureless, std::size_t(flat.area()));
  EXPECT_EQ(all.valid, filtered.valid);
  for (int y = flat.y; y < flat.br().y; ++y)
    for (int x = flat.x; x < flat.br().x; ++x) {
      EXPECT_NEAR(all.map.depth.at<float>(y, x), scene().left_view.depth(y, x), 1e-4) << x << "," << y;
      EXPECT_EQ(all.map.confidence.at<float>(y, x), 0.f);
    }

  input.other_mask = cv::Mat1b(b.height, b.width, std::uint8_t{255});
  const pg::DepthFromFlowResult hidden = pg::depth_from_flow(input, options);
  EXPECT_EQ(hidden.rejections.textureless, 0u);
  EXPECT_EQ(hidden.valid, 0u);
  EXPECT_GE(hidden.rejections.masked, filtered.valid + std::size_t(flat.area()));
}

// A target on the image's left edge (x = -0.5, inside the image) reads the other mask's first column:
// the nearest column was lround(-0.5) = -1, outside the mask.
TEST(DepthFromFlow, TargetsOnTheImageEdgeReadTheOtherMasksEdge) {
  const pg::Camera& a = scene().left;
  const pg::Camera& b = scene().right;
  pg::DepthFromFlowInput input = exact_input();
  for (int y = 0; y < a.height; ++y)
    for (int x = 0; x < a.width; ++x) input.flow(y, x) = cv::Vec2f(-0.5f - float(x), 0.0f);
  input.other_mask = cv::Mat1b::zeros(b.height, b.width);
  input.other_mask.col(0).setTo(255);
  const pg::DepthFromFlowResult result = pg::depth_from_flow(input);
  EXPECT_EQ(result.rejections.masked, std::size_t(a.width) * std::size_t(a.height));
}

TEST(DepthGeometry, GridMeshFacesTheCameraAndSkipsInvalidPixels) {
  pg::DepthMap map;
  map.camera = look_at_camera("c", {0, 0, 0}, {0, 0, 1}, 3, 3, 3);
  map.depth = cv::Mat1f(3, 3, 2.f);
  map.depth.at<float>(2, 2) = NAN;
  const pg::Mesh mesh = pg::depth_grid_mesh(map);
  EXPECT_EQ(mesh.vertex_count(), 8u);
  EXPECT_EQ(mesh.face_count(), 7u);  // 8 triangles less the one touching the invalid corner
  for (const Eigen::Vector3f& n : mesh.normals)
    EXPECT_NEAR(n.z(), -1.f, 1e-5);  // towards the camera at z = 0
  const pg::PointCloud cloud = pg::depth_point_cloud(map);
  EXPECT_EQ(cloud.size(), 8u);
  EXPECT_NEAR(cloud.positions[4].z(), 2.f, 1e-6);
}

}  // namespace

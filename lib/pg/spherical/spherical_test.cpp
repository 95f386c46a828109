// Unit tests of the spherical module against independent formulas: rectification, triangulation on
// the sphere, equirectangular resampling, the sphere-grid mesh and the room-plane fits.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "pg/camera/camera.h"
#include "pg/core/error.h"
#include "pg/flow/flow_memory.h"
#include "pg/spherical/room_planes.h"
#include "pg/spherical/sphere_depth.h"
#include "pg/spherical/sphere_depth_memory.h"
#include "pg/spherical/sphere_geometry.h"
#include "pg/spherical/sphere_mesh.h"

namespace pg {
namespace {

constexpr double pi = std::numbers::pi;

TEST(SphereGeometry, RectifyingRotationSendsTheBaselineToTheNorthPole) {
  EXPECT_TRUE(rectifying_rotation({0, -0.27, 0}).isIdentity(1e-12));
  for (const Eigen::Vector3d& b :
       {Eigen::Vector3d(0.3, 0, 0), Eigen::Vector3d(0.1, 0.2, -0.3), Eigen::Vector3d(0, 0.5, 0)}) {
    const Eigen::Matrix3d r = rectifying_rotation(b);
    EXPECT_TRUE((r * r.transpose()).isIdentity(1e-12));
    EXPECT_NEAR(r.determinant(), 1, 1e-12);
    EXPECT_TRUE((r * b.normalized()).isApprox(Eigen::Vector3d(0, -1, 0), 1e-12));
  }
  EXPECT_THROW(rectifying_rotation(Eigen::Vector3d::Zero()), UsageError);
}

TEST(SphereGeometry, RangeFromAngularDisparityMatchesTwoRayTriangulation) {
  // Points in the plane of the axis (second centre at (0, b) along the axis), triangulated back from
  // the two polar angles by intersecting the rays.
  const double b = 0.27;
  for (const double theta : {0.3, 1.0, pi / 2, 2.4}) {
    for (const double range : {0.8, 2.5, 9.0}) {
      const double gamma = angular_disparity_from_range(b, theta, range);
      const Eigen::Vector2d p = range * Eigen::Vector2d(std::sin(theta), std::cos(theta));
      const double theta_other = std::atan2(p.x(), p.y() - b);
      EXPECT_NEAR(gamma, theta_other - theta, 1e-12);
      EXPECT_NEAR(range_from_angular_disparity(b, theta, gamma), range, 1e-9 * range);
    }
  }
  EXPECT_TRUE(std::isnan(range_from_angular_disparity(b, 1.0, 0.0)));
  EXPECT_TRUE(std::isnan(range_from_angular_disparity(b, 3.0, 0.2)));
}

TEST(SphereGeometry, RotatingAnEquirectangularImageThereAndBackRestoresIt) {
  // A smooth function of the direction: rotation must move it exactly as the sphere turns.
  const int width = 256, height = 128;
  const auto field = [](const Eigen::Vector3d& d) {
    return static_cast<float>(0.5 + 0.3 * d.x() - 0.2 * d.y() * d.z());
  };
  cv::Mat1f image(height, width);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) image(y, x) = field(equirect_direction_from_pixel(width, height, {x, y}));
  const Eigen::Matrix3d rotation = rectifying_rotation({0.4, 0.1, 0.3});
  const cv::Mat1f rotated = rotate_equirect(image, rotation, image.size());
  double worst = 0;
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const Eigen::Vector3d d = equirect_direction_from_pixel(width, height, {x, y});
      worst = std::max<double>(worst, std::abs(rotated(y, x) - field(rotation.transpose() * d)));
    }
  EXPECT_LT(worst, 2e-3);  // bilinear interpolation of a smooth field, including across seam and poles
  const cv::Mat padded = pad_longitude(image, 8);
  EXPECT_EQ(padded.cols, width + 16);
  EXPECT_EQ(padded.at<float>(5, 0), image(5, width - 8));
  EXPECT_EQ(padded.at<float>(5, width + 8), image(5, 0));
}

DepthMap constant_range_map(int width, int height, float range) {
  DepthMap map;
  map.kind = DepthKind::spherical_range;
  map.camera.model = CameraModel::equirectangular;
  map.camera.width = width;
  map.camera.height = height;
  map.depth = cv::Mat1f(height, width, range);
  map.confidence = cv::Mat1f(height, width, 1.0f);
  return map;
}

TEST(SphereMesh, ASphereOfConstantRangeIsClosedAcrossTheSeamAndFacesItsCentre) {
  const int width = 32, height = 16;
  DepthMap map = constant_range_map(width, height, 2.0f);
  map.camera.cam_from_world.translation = Eigen::Vector3d(0, 0, -1);  // centre at world (0, 0, 1)
  map.depth.at<float>(8, 5) = std::numeric_limits<float>::quiet_NaN();
  const Mesh mesh = sphere_grid_mesh(map);
  EXPECT_EQ(mesh.vertex_count(), static_cast<std::size_t>((width + 1) * height - 1));  // seam column repeated
  // Every 2x2 block over the full turn gives two triangles, less the 6 touching the hole.
  EXPECT_EQ(mesh.face_count(), static_cast<std::size_t>(2 * width * (height - 1) - 6));
  const Eigen::Vector3f centre(0, 0, 1);
  for (const Eigen::Vector3f& p : mesh.positions) EXPECT_NEAR((p - centre).norm(), 2.0f, 1e-5f);
  for (const auto& f : mesh.faces) {
    const Eigen::Vector3f& a = mesh.positions[f[0]];
    EXPECT_GT((mesh.positions[f[1]] - a).cross(mesh.positions[f[2]] - a).dot(centre - a), 0);
  }
  ASSERT_EQ(mesh.uvs.size(), mesh.vertex_count());
  EXPECT_NEAR(mesh.uvs.front().x(), 0.5f / width, 1e-6f);
  EXPECT_NEAR(mesh.uvs.front().y(), 1 - 0.5f / height, 1e-6f);
  EXPECT_EQ(mesh.vertex_properties.at("confidence").size(), mesh.vertex_count());
}

TEST(SphereMesh, NoTriangleSpansARangeDiscontinuity) {
  DepthMap map = constant_range_map(32, 16, 2.0f);
  cv::Mat1f depth = map.depth;
  depth(cv::Rect(10, 4, 6, 6)).setTo(1.0f);  // a near box in front of the far wall
  const Mesh mesh = sphere_grid_mesh(map);
  for (const auto& f : mesh.faces) {
    const float a = mesh.positions[f[0]].norm(), b = mesh.positions[f[1]].norm(),
                c = mesh.positions[f[2]].norm();
    EXPECT_LT(std::max({a, b, c}) / std::min({a, b, c}), 1.1f);
  }
}

// The range map of a camera at height h above the floor of a box room (walls at +-a along x, +-c
// along z, ceiling 3 m above the floor).
DepthMap box_room_map(int width, int height, double h, double a, double c) {
  DepthMap map = constant_range_map(width, height, 0);
  cv::Mat1f depth = map.depth;
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const Eigen::Vector3d d = equirect_direction_from_pixel(width, height, {x, y});
      double t = std::numeric_limits<double>::infinity();
      if (d.y() > 0) t = std::min(t, h / d.y());
      if (d.y() < 0) t = std::min(t, (3 - h) / -d.y());
      if (d.x() != 0) t = std::min(t, a / std::abs(d.x()));
      if (d.z() != 0) t = std::min(t, c / std::abs(d.z()));
      depth(y, x) = static_cast<float>(t);
    }
  return map;
}

TEST(RoomPlanes, TheFloorAndWallsOfABoxRoomAreFoundAtRightAngles) {
  const DepthMap map = box_room_map(256, 128, 1.4, 2.0, 2.6);
  const RoomPlanes planes = fit_room_planes(map);
  ASSERT_TRUE(planes.floor);
  EXPECT_NEAR(planes.floor->offset, 1.4, 1e-3);
  EXPECT_TRUE(planes.floor->normal.isApprox(Eigen::Vector3d(0, -1, 0), 1e-4))
      << planes.floor->normal.transpose();
  EXPECT_LT(planes.floor->rms, 1e-4);
  ASSERT_EQ(planes.walls.size(), 4u);
  for (const double angle : planes.wall_floor_angles_deg) EXPECT_NEAR(angle, 90, 0.5);
  for (const double angle : planes.wall_wall_angles_deg)
    EXPECT_TRUE(angle < 0.5 || angle > 89.5) << angle;  // corner points tilt a fit slightly
  for (const PlaneFit& wall : planes.walls) {
    EXPECT_TRUE(std::abs(wall.offset - 2.0) < 0.01 || std::abs(wall.offset - 2.6) < 0.01) << wall.offset;
  }
}

// A panorama pair's range error grows with the square of the range: a room 4 m x 7 m seen from off
// its centre, with the range noise of a 0.2 m vertical baseline (up to a third of a pixel of disparity
// at 512 x 256), and a table-height box of clutter. The walls come out at right angles and at their
// distances; the clutter, below the centre, is not taken for a wall.
TEST(RoomPlanes, WallsOfANoisyPanoramaPairAreFoundWithTheRangeErrorOfTheBaseline) {
  const int width = 512, height = 256;
  DepthMap map = box_room_map(width, height, 1.4, 2.0, 3.5);
  std::mt19937 random(7);
  std::uniform_real_distribution<float> noise(-1, 1);
  const double pixel = 2 * std::numbers::pi / width, baseline = 0.2;
  cv::Mat1f depth = map.depth;
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const Eigen::Vector3d d = equirect_direction_from_pixel(width, height, {x, y});
      float& range = depth(y, x);
      // Clutter: a box 1 m deep across the room, from the floor to 0.6 m below the centre.
      const double to_box = 1.0 / std::max(d.z(), 1e-9);
      if (d.z() > 0 && (to_box * d.y() > 0.6) && to_box < range) range = static_cast<float>(to_box);
      const double sin_to_baseline = std::sqrt(1 - d.y() * d.y());
      range += static_cast<float>(noise(random) * pixel / 3 * range * range /
                                  (baseline * std::max(sin_to_baseline, 0.1)));
    }
  RoomPlaneOptions options;
  options.baseline = {0, -baseline, 0};
  const RoomPlanes planes = fit_room_planes(map, options);
  ASSERT_TRUE(planes.floor);
  ASSERT_EQ(planes.walls.size(), 4u);
  // The end walls' few hundred points, up to 0.2 m off, fix their tilt to a degree or two.
  for (const double angle : planes.wall_floor_angles_deg) EXPECT_NEAR(angle, 90, 3);
  for (const double angle : planes.wall_wall_angles_deg) EXPECT_TRUE(angle < 3 || angle > 87) << angle;
  for (const PlaneFit& wall : planes.walls)
    EXPECT_TRUE(std::abs(wall.offset - 2.0) < 0.05 || std::abs(wall.offset - 3.5) < 0.1) << wall.offset;
}

// The estimate holds the panoramas and the padded flow (measured: 275 MiB for the 1024 x 512 360SD
// pairs, against 410 MB peak resident of which 135 MB is the process itself), and grows with pixels.
TEST(SphereDepthMemory, HoldsThePanoramasAndThePaddedFlowAndGrowsWithPixels) {
  const SphereDepthOptions options;
  const cv::Size input(4096, 2048);
  const std::uint64_t estimate = sphere_depth_memory_bytes(input, 16, 3, options);
  const cv::Size padded(4096 + 2 * 256, 2048);  // seam padding 1/16 of the width each side
  const std::uint64_t images = 2ull * 4096 * 2048 * 16;
  EXPECT_GT(estimate, images + bidirectional_flow_memory_bytes(padded, 3, options.flow, true));
  EXPECT_LT(estimate, 2 * (images + bidirectional_flow_memory_bytes(padded, 3, options.flow, true)));
  EXPECT_NEAR(double(sphere_depth_memory_bytes({8192, 4096}, 16, 3, options)) / double(estimate), 4.0, 0.02);
  SphereDepthOptions half = options;
  half.scale = 0.5;
  EXPECT_LT(sphere_depth_memory_bytes(input, 16, 3, half), estimate / 2);
}

TEST(SphereDepth, InvalidPairsAndOptionsAreRefused) {
  SpherePair pair;
  pair.reference = cv::Mat3b(16, 32, cv::Vec3b(1, 2, 3));
  pair.other = cv::Mat3b(16, 32, cv::Vec3b(1, 2, 3));
  pair.reference_camera.model = CameraModel::equirectangular;
  pair.reference_camera.width = 32;
  pair.reference_camera.height = 16;
  EXPECT_THROW(compute_sphere_depth(pair), UsageError);  // zero baseline
  pair.baseline = {0, -0.2, 0};
  pair.other = cv::Mat3b(8, 16);
  EXPECT_THROW(compute_sphere_depth(pair), UsageError);  // sizes differ
  SphereDepthOptions options;
  options.scale = 0;
  EXPECT_THROW(options.check(), UsageError);
}

}  // namespace
}  // namespace pg

#include <gtest/gtest.h>

#include <random>

#include "pg/core/error.h"
#include "pg/geometry/rigid.h"
#include "pg/geometry/similarity.h"
#include "pg/geometry/triangulation.h"

namespace pg {
namespace {

Eigen::Quaterniond random_rotation(std::mt19937& rng) {
  std::normal_distribution<double> n(0, 1);
  return Eigen::Quaterniond{n(rng), n(rng), n(rng), n(rng)}.normalized();
}

Eigen::Vector3d random_vector(std::mt19937& rng, double scale) {
  std::uniform_real_distribution<double> u(-scale, scale);
  return {u(rng), u(rng), u(rng)};
}

Rigid3 random_rigid(std::mt19937& rng) {
  return {random_rotation(rng), random_vector(rng, 5)};
}

TEST(Rigid3, CompositionMatchesMatrices) {
  std::mt19937 rng(1);
  for (int trial = 0; trial < 50; ++trial) {
    const Rigid3 a = random_rigid(rng), b = random_rigid(rng);
    const Eigen::Vector3d p = random_vector(rng, 10);
    EXPECT_LT(((a * b) * p - a * (b * p)).norm(), 1e-12);
    Eigen::Matrix4d ma = Eigen::Matrix4d::Identity(), mb = Eigen::Matrix4d::Identity();
    ma.topRows<3>() = a.matrix();
    mb.topRows<3>() = b.matrix();
    Eigen::Matrix4d mab = Eigen::Matrix4d::Identity();
    mab.topRows<3>() = (a * b).matrix();
    EXPECT_LT((ma * mb - mab).norm(), 1e-12);
  }
}

TEST(Rigid3, InverseAndCentre) {
  std::mt19937 rng(2);
  for (int trial = 0; trial < 50; ++trial) {
    const Rigid3 a = random_rigid(rng);
    const Eigen::Vector3d p = random_vector(rng, 10);
    EXPECT_LT((a.inverse() * (a * p) - p).norm(), 1e-12);
    EXPECT_LT((a * a.centre()).norm(), 1e-12);  // the centre maps to the camera origin
    EXPECT_LT((a.inverse().translation - a.centre()).norm(), 1e-12);
  }
}

TEST(Rigid3, LookAtPointsTheAxes) {
  std::mt19937 rng(3);
  for (int trial = 0; trial < 100; ++trial) {
    const Eigen::Vector3d centre = random_vector(rng, 10), target = random_vector(rng, 10);
    const Eigen::Vector3d up = trial % 2 ? Eigen::Vector3d::UnitZ() : random_vector(rng, 1).normalized();
    const Rigid3 pose = Rigid3::look_at(centre, target, up);
    const Eigen::Matrix3d r = pose.rotation_matrix();
    EXPECT_LT((r * r.transpose() - Eigen::Matrix3d::Identity()).norm(), 1e-12);
    EXPECT_NEAR(r.determinant(), 1.0, 1e-12);
    EXPECT_LT((pose.centre() - centre).norm(), 1e-12);
    // The target lies on the optical axis, in front.
    const Eigen::Vector3d t = pose * target;
    EXPECT_NEAR(t.x(), 0, 1e-12);
    EXPECT_NEAR(t.y(), 0, 1e-12);
    EXPECT_NEAR(t.z(), (target - centre).norm(), 1e-12);
    // Image y (row 1 in world) is the unit vector closest to -up among those perpendicular to the view.
    const Eigen::Vector3d view = (target - centre).normalized();
    const Eigen::Vector3d expected_down = -(up - up.dot(view) * view).normalized();
    EXPECT_LT((r.row(1).transpose() - expected_down).norm(), 1e-12);
  }
}

TEST(Rigid3, LookAtFromAboveWithUpAlongView) {
  const Rigid3 pose = Rigid3::look_at({0, 0, 10}, {0, 0, 0}, Eigen::Vector3d::UnitZ());
  const Eigen::Matrix3d r = pose.rotation_matrix();
  EXPECT_NEAR(r.determinant(), 1.0, 1e-12);
  EXPECT_LT((r.row(2).transpose() - Eigen::Vector3d(0, 0, -1)).norm(), 1e-12);
  EXPECT_LT((pose * Eigen::Vector3d::Zero() - Eigen::Vector3d(0, 0, 10)).norm(), 1e-12);
}

TEST(Rigid3, LookAtConventionalCamera) {
  // Camera at the origin looking along +y (world z up): image right is world +x... looking along +y with
  // z up, right-hand rule gives right = view x up = (0,1,0) x (0,0,1) = (1,0,0).
  const Rigid3 pose = Rigid3::look_at({0, 0, 0}, {0, 5, 0});
  EXPECT_LT((pose * Eigen::Vector3d(1, 5, 0) - Eigen::Vector3d(1, 0, 5)).norm(), 1e-12);
  EXPECT_LT((pose * Eigen::Vector3d(0, 5, 1) - Eigen::Vector3d(0, -1, 5)).norm(), 1e-12);
}

Sim3 random_sim3(std::mt19937& rng) {
  std::uniform_real_distribution<double> s(0.1, 10);
  return {s(rng), random_rotation(rng), random_vector(rng, 20)};
}

TEST(Sim3, InverseAndTransformPose) {
  std::mt19937 rng(4);
  for (int trial = 0; trial < 50; ++trial) {
    const Sim3 s = random_sim3(rng);
    const Eigen::Vector3d p = random_vector(rng, 10);
    EXPECT_LT((s.inverse() * (s * p) - p).norm(), 1e-11);
    const Rigid3 cam_from_a = random_rigid(rng);
    const Rigid3 cam_from_b = s.transform_pose(cam_from_a);
    EXPECT_LT((cam_from_b.centre() - s * cam_from_a.centre()).norm(), 1e-10);
    // A point seen from the camera keeps its direction and scales its depth.
    const Eigen::Vector3d in_cam_a = cam_from_a * p, in_cam_b = cam_from_b * (s * p);
    EXPECT_LT((in_cam_b - s.scale * in_cam_a).norm(), 1e-10);
  }
}

TEST(AlignSimilarity, RecoversExactTransform) {
  std::mt19937 rng(5);
  for (int trial = 0; trial < 20; ++trial) {
    const Sim3 truth = random_sim3(rng);
    std::vector<Eigen::Vector3d> src, dst;
    for (int i = 0; i < 3 + trial; ++i) {
      src.push_back(random_vector(rng, 10));
      dst.push_back(truth * src.back());
    }
    const Sim3 estimate = align_similarity(src, dst);
    EXPECT_NEAR(estimate.scale, truth.scale, 1e-9 * truth.scale);
    EXPECT_LT(estimate.rotation.angularDistance(truth.rotation), 1e-9);
    EXPECT_LT((estimate.translation - truth.translation).norm(), 1e-9);
  }
}

TEST(AlignSimilarity, NoisyPointsWithinTolerance) {
  std::mt19937 rng(6);
  std::normal_distribution<double> noise(0, 1e-3);
  const Sim3 truth = random_sim3(rng);
  std::vector<Eigen::Vector3d> src, dst;
  for (int i = 0; i < 2000; ++i) {
    src.push_back(random_vector(rng, 10));
    dst.push_back(truth * src.back() + Eigen::Vector3d{noise(rng), noise(rng), noise(rng)});
  }
  const Sim3 estimate = align_similarity(src, dst);
  // Noise 1e-3 over 2000 points spread over 10 units: parameter errors of order 1e-3 / (10 sqrt(2000)).
  EXPECT_NEAR(estimate.scale, truth.scale, 1e-4 * truth.scale);
  EXPECT_LT(estimate.rotation.angularDistance(truth.rotation), 1e-4);
  EXPECT_LT((estimate.translation - truth.translation).norm(), 1e-3);
}

TEST(AlignSimilarity, RejectsDegenerateInput) {
  std::vector<Eigen::Vector3d> line = {{0, 0, 0}, {1, 1, 1}, {2, 2, 2}, {3, 3, 3}};
  EXPECT_THROW(align_similarity(line, line), FailedError);
  std::vector<Eigen::Vector3d> two = {{0, 0, 0}, {1, 0, 0}};
  EXPECT_THROW(align_similarity(two, two), FailedError);
  std::vector<Eigen::Vector3d> three = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  EXPECT_THROW(align_similarity(three, two), std::invalid_argument);
  // Planar points are enough.
  const Sim3 identity = align_similarity(three, three);
  EXPECT_NEAR(identity.scale, 1.0, 1e-12);
  EXPECT_LT(identity.rotation.angularDistance(Eigen::Quaterniond::Identity()), 1e-12);
}

// Cameras on a ring around the origin looking at it, at distance `radius`.
std::vector<Rigid3> ring_of_cameras(int count, double radius) {
  std::vector<Rigid3> poses;
  for (int i = 0; i < count; ++i) {
    const double angle = 0.4 * i;
    poses.push_back(
        Rigid3::look_at({radius * std::cos(angle), radius * std::sin(angle), 0.3 * i}, {0, 0, 0}));
  }
  return poses;
}

TEST(Triangulate, ExactRays) {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 100; ++trial) {
    const auto poses = ring_of_cameras(2 + trial % 5, 10);
    const Eigen::Vector3d point = random_vector(rng, 2);
    std::vector<Eigen::Vector3d> rays;
    for (const Rigid3& pose : poses) rays.push_back((pose * point).normalized());
    for (bool refine : {false, true}) {
      const auto estimate = triangulate(poses, rays, {.refine = refine});
      ASSERT_TRUE(estimate.has_value());
      EXPECT_LT((*estimate - point).norm(), 1e-9);
    }
  }
}

TEST(Triangulate, LargeTranslationsStayAccurate) {
  // Georeferenced coordinates: the conditioning must remove the large offset.
  const Eigen::Vector3d offset(4.5e5, 5.3e6, 120);
  std::vector<Rigid3> poses;
  for (int i = 0; i < 3; ++i)
    poses.push_back(
        Rigid3::look_at(offset + Eigen::Vector3d(3.0 * i, -20, 1), offset + Eigen::Vector3d(1, 0, 0)));
  const Eigen::Vector3d point = offset + Eigen::Vector3d(0.5, 0.25, -0.75);
  std::vector<Eigen::Vector3d> rays;
  for (const Rigid3& pose : poses) rays.push_back((pose * point).normalized());
  const auto estimate = triangulate(poses, rays);
  ASSERT_TRUE(estimate.has_value());
  EXPECT_LT((*estimate - point).norm(), 1e-6);  // 1e-6 m at 5e6 m is a few ulps of the coordinates
}

TEST(Triangulate, RefinementLowersAngularErrorWithNoise) {
  std::mt19937 rng(8);
  std::normal_distribution<double> noise(0, 1e-3);
  const auto poses = ring_of_cameras(6, 10);
  const Eigen::Vector3d point(0.3, -0.2, 0.5);
  std::vector<Eigen::Vector3d> rays;
  for (const Rigid3& pose : poses)
    rays.push_back(
        ((pose * point).normalized() + Eigen::Vector3d{noise(rng), noise(rng), noise(rng)}).normalized());
  auto total_error = [&](const Eigen::Vector3d& x) {
    double sum = 0;
    for (std::size_t i = 0; i < poses.size(); ++i)
      sum += std::pow(std::tan(angular_error(poses[i], rays[i], x)), 2);
    return sum;
  };
  const auto linear = triangulate(poses, rays, {.refine = false});
  const auto refined = triangulate(poses, rays);
  ASSERT_TRUE(linear && refined);
  EXPECT_LE(total_error(*refined), total_error(*linear));
  EXPECT_LT((*refined - point).norm(), 0.05);
}

TEST(Triangulate, RejectsBadConfigurations) {
  const auto poses = ring_of_cameras(2, 10);
  const Eigen::Vector3d point(0, 0, 0);
  std::vector<Eigen::Vector3d> rays = {(poses[0] * point).normalized(), (poses[1] * point).normalized()};
  EXPECT_FALSE(triangulate({poses[0]}, {rays[0]}).has_value());
  EXPECT_FALSE(triangulate(poses, {rays[0]}).has_value());
  // Both rays reversed: the solution lies behind both cameras.
  EXPECT_FALSE(triangulate(poses, {-rays[0], -rays[1]}).has_value());
  // Same centre twice.
  EXPECT_FALSE(triangulate({poses[0], poses[0]}, {rays[0], rays[0]}).has_value());
}

TEST(TriangulateMidpoint, ExactAndSkewRays) {
  const Eigen::Vector3d a(0, 0, 0), b(2, 0, 0), point(1, 3, 4);
  const auto exact = triangulate_midpoint(a, point - a, b, point - b);
  ASSERT_TRUE(exact.has_value());
  EXPECT_LT((*exact - point).norm(), 1e-12);
  // Skew lines x-axis at z=0 through (0,0,0)... and y-direction at z=1 through (5,-5,1): closest points
  // are (5,0,0) and (5,0,1).
  const auto skew = triangulate_midpoint({0, 0, 0}, {1, 0, 0}, {5, -5, 1}, {0, 1, 0});
  ASSERT_TRUE(skew.has_value());
  EXPECT_LT((*skew - Eigen::Vector3d(5, 0, 0.5)).norm(), 1e-12);
  EXPECT_FALSE(triangulate_midpoint(a, {0, 0, 1}, b, {0, 0, 1}).has_value());  // parallel
  EXPECT_FALSE(triangulate_midpoint(a, a - point, b, b - point).has_value());  // behind
}

TEST(TriangulationAngle, KnownAngles) {
  EXPECT_NEAR(triangulation_angle({1, 0, 0}, {0, 1, 0}, {0, 0, 0}), M_PI / 2, 1e-15);
  EXPECT_NEAR(triangulation_angle({-1, 1, 0}, {1, 1, 0}, {0, 0, 0}), M_PI / 2, 1e-15);
  EXPECT_NEAR(triangulation_angle({1, 0, 0}, {2, 0, 0}, {0, 0, 0}), 0, 1e-15);
  EXPECT_EQ(triangulation_angle({0, 0, 0}, {2, 0, 0}, {0, 0, 0}), 0);
}

}  // namespace
}  // namespace pg

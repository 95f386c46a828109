#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "pg/core/error.h"
#include "pg/eval/camera_eval.h"

namespace {

// Eight cameras on a ring of radius 5 around the origin, at varying heights, looking at the origin.
pg::CameraSet ring_of_cameras() {
  pg::CameraSet set;
  for (int i = 0; i < 8; ++i) {
    double a = 2 * std::numbers::pi * i / 8;
    pg::Camera c;
    c.id = "cam" + std::to_string(i);
    c.width = 640;
    c.height = 480;
    c.intrinsics = {500, 510, 319.5, 239.5};
    c.cam_from_world = pg::Rigid3::look_at({5 * std::cos(a), 5 * std::sin(a), 0.3 * (i % 3)}, {0, 0, 0});
    set.cameras.push_back(c);
  }
  return set;
}

// Moves a camera's centre by `offset` keeping its orientation.
void move_centre(pg::Camera& c, const Eigen::Vector3d& offset) {
  Eigen::Vector3d centre = c.cam_from_world.centre() + offset;
  c.cam_from_world.translation = -(c.cam_from_world.rotation * centre);
}

}  // namespace

TEST(EvaluateCameras, RecoversAKnownSimilarityExactly) {
  pg::CameraSet truth = ring_of_cameras();
  // The estimate lives in another frame: truth_world = s * R * estimate_world + t.
  const double s = 2.5;
  const Eigen::Quaterniond R(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()));
  const Eigen::Vector3d t(1, -2, 0.5);
  pg::CameraSet estimate = truth;
  for (pg::Camera& c : estimate.cameras) {
    const pg::Rigid3 p = c.cam_from_world;
    // x_cam = R_t (s R x_e + t) + t_t, expressed in estimate units (divided by s).
    c.cam_from_world.rotation = p.rotation * R;
    c.cam_from_world.translation = (p.rotation * t + p.translation) / s;
  }
  pg::CameraEvalResult r = pg::evaluate_cameras(estimate, truth);
  ASSERT_EQ(r.cameras.size(), 8u);
  EXPECT_EQ(r.aligned_on, 8u);
  EXPECT_NEAR(r.alignment.scale, s, 1e-9);
  EXPECT_NEAR(r.alignment.rotation.angularDistance(R), 0, 1e-9);
  EXPECT_LT(r.centre_error.max, 1e-9);
  EXPECT_LT(r.rotation_error_deg.max, 1e-7);
  EXPECT_LT(r.focal_relative_error.max, 1e-15);
  EXPECT_EQ(r.focal_relative_error.count, 8u);
  EXPECT_TRUE(r.missing_in_estimate.empty());
  EXPECT_TRUE(r.extra_in_estimate.empty());
}

TEST(EvaluateCameras, ReportsAKnownCentreErrorWithoutAlignment) {
  pg::CameraSet truth = ring_of_cameras();
  pg::CameraSet estimate = truth;
  move_centre(estimate.cameras[3], {0.06, 0, 0.08});  // |offset| = 0.1
  pg::CameraEvalOptions options;
  options.alignment = pg::CameraAlignment::none;
  pg::CameraEvalResult r = pg::evaluate_cameras(estimate, truth, options);
  EXPECT_NEAR(r.cameras[3].centre_error, 0.1, 1e-12);
  EXPECT_NEAR(r.centre_error.max, 0.1, 1e-12);
  EXPECT_NEAR(r.centre_error.mean, 0.1 / 8, 1e-12);
  EXPECT_NEAR(r.centre_error.rms, 0.1 / std::sqrt(8.0), 1e-12);
  EXPECT_NEAR(r.centre_error.median, 0, 1e-12);
  EXPECT_LT(r.rotation_error_deg.max, 1e-9);
  EXPECT_EQ(r.alignment.scale, 1.0);
}

TEST(EvaluateCameras, AlignsOnASubsetAndMeasuresTheHeldOutCamera) {
  pg::CameraSet truth = ring_of_cameras();
  pg::CameraSet estimate = truth;
  move_centre(estimate.cameras[5], {0, 0.2, 0});
  pg::CameraEvalOptions options;
  options.align_on = {"cam0", "cam1", "cam2", "cam3"};
  pg::CameraEvalResult r = pg::evaluate_cameras(estimate, truth, options);
  EXPECT_EQ(r.aligned_on, 4u);
  EXPECT_NEAR(r.alignment.scale, 1, 1e-12);
  EXPECT_NEAR(r.cameras[5].centre_error, 0.2, 1e-9);
  EXPECT_NEAR(r.cameras[0].centre_error, 0, 1e-9);

  options.align_on = {"cam0", "nope"};
  EXPECT_THROW(pg::evaluate_cameras(estimate, truth, options), pg::UsageError);
}

TEST(EvaluateCameras, ReportsAKnownRotationAndFocalError) {
  pg::CameraSet truth = ring_of_cameras();
  pg::CameraSet estimate = truth;
  // Roll camera 2 by 2 degrees about its optical axis: its centre stays, its rotation is off by 2 deg.
  pg::Camera& c = estimate.cameras[2];
  Eigen::Vector3d centre = c.cam_from_world.centre();
  c.cam_from_world.rotation =
      Eigen::AngleAxisd(2 * std::numbers::pi / 180, Eigen::Vector3d::UnitZ()) * c.cam_from_world.rotation;
  c.cam_from_world.translation = -(c.cam_from_world.rotation * centre);
  estimate.cameras[4].intrinsics.fx *= 1.01;
  estimate.cameras[4].intrinsics.cx += 3;
  estimate.cameras[4].intrinsics.cy -= 4;
  pg::CameraEvalResult r = pg::evaluate_cameras(estimate, truth);
  EXPECT_NEAR(r.cameras[2].rotation_error_deg, 2, 1e-9);
  EXPECT_NEAR(r.rotation_error_deg.max, 2, 1e-9);
  EXPECT_LT(r.centre_error.max, 1e-9);
  EXPECT_NEAR(*r.cameras[4].focal_relative_error, 0.01, 1e-12);
  EXPECT_NEAR(*r.cameras[4].principal_point_error_px, 5, 1e-12);
  EXPECT_NEAR(r.focal_relative_error.max, 0.01, 1e-12);
  // The orientation-only alignment absorbs a share of the one rolled camera, so its own error stays
  // near but under 2 degrees, and the others' near zero; reported per camera and summarised.
  ASSERT_EQ(r.orientation_error_deg.count, truth.cameras.size());
  EXPECT_GT(r.cameras[2].orientation_error_deg, 1.5);
  EXPECT_LT(r.cameras[2].orientation_error_deg, 2.0 + 1e-9);
  EXPECT_NEAR(r.orientation_error_deg.max, r.cameras[2].orientation_error_deg, 1e-12);
  EXPECT_LT(r.cameras[0].orientation_error_deg, 0.5);
  EXPECT_TRUE(r.to_json().contains("orientation_error_deg"));
}

TEST(EvaluateCameras, ComparesIntrinsicsAcrossResolutions) {
  pg::CameraSet truth = ring_of_cameras();
  pg::CameraSet estimate = truth;
  for (pg::Camera& c : estimate.cameras) {  // the same cameras at half resolution
    c.width /= 2;
    c.height /= 2;
    c.intrinsics = {c.intrinsics.fx / 2, c.intrinsics.fy / 2, (c.intrinsics.cx + 0.5) / 2 - 0.5,
                    (c.intrinsics.cy + 0.5) / 2 - 0.5};
  }
  pg::CameraEvalResult r = pg::evaluate_cameras(estimate, truth);
  EXPECT_LT(r.focal_relative_error.max, 1e-12);
  EXPECT_LT(r.principal_point_error_px.max, 1e-12);
}

TEST(EvaluateCameras, ListsUnmatchedIdsAndNeedsThreeToAlign) {
  pg::CameraSet truth = ring_of_cameras();
  pg::CameraSet estimate;
  estimate.cameras = {truth.cameras[0], truth.cameras[1], truth.cameras[2]};
  estimate.cameras[2].id = "extra";
  EXPECT_THROW(pg::evaluate_cameras(estimate, truth), pg::FailedError);

  estimate.cameras.push_back(truth.cameras[6]);
  pg::CameraEvalResult r = pg::evaluate_cameras(estimate, truth);
  EXPECT_EQ(r.cameras.size(), 3u);
  EXPECT_EQ(r.extra_in_estimate, std::vector<std::string>{"extra"});
  EXPECT_EQ(r.missing_in_estimate, (std::vector<std::string>{"cam2", "cam3", "cam4", "cam5", "cam7"}));
  nlohmann::json j = r.to_json();
  EXPECT_EQ(j["matched"], 3);
  EXPECT_EQ(j["missing_in_estimate"].size(), 5u);
  EXPECT_NE(r.to_text().find("3 cameras matched"), std::string::npos);

  pg::CameraSet disjoint;
  disjoint.cameras = {estimate.cameras[2]};
  pg::CameraEvalOptions none;
  none.alignment = pg::CameraAlignment::none;
  EXPECT_THROW(pg::evaluate_cameras(disjoint, truth, none), pg::FailedError);
}

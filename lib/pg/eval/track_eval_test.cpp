#include "pg/eval/track_eval.h"

#include <gtest/gtest.h>

#include "pg/core/error.h"

namespace pg {
namespace {

// Two cameras a metre apart looking at points 4 m away: exact projections agree to rounding, and
// an observation moved by 1 px shows up in its track's error, shared between its two observations.
TEST(TrackAgreement, ExactProjectionsAgreeAndAMovedObservationShows) {
  std::vector<Camera> cameras(2);
  for (int f = 0; f < 2; ++f) {
    cameras[f].width = 640;
    cameras[f].height = 480;
    cameras[f].intrinsics = {500, 500, 319.5, 239.5};
    cameras[f].cam_from_world.translation = {-1.0 * f, 0, 0};
  }
  TrackSet set;
  for (int i = 0; i < 20; ++i) {
    const Eigen::Vector3d point(0.1 * i - 1, 0.05 * i - 0.5, 4 + 0.1 * i);
    Track t;
    for (int f = 0; f < 2; ++f) {
      Eigen::Vector2d pixel;
      ASSERT_TRUE(cameras[f].project_world(point, pixel));
      t.observations.push_back({f, static_cast<float>(pixel.x()), static_cast<float>(pixel.y())});
    }
    set.tracks.push_back(t);
  }
  const TrackAgreement exact = track_agreement(set, cameras);
  EXPECT_EQ(exact.tracks_used, 20u);
  EXPECT_LT(exact.observation_error_px.max, 1e-3);  // float positions
  set.tracks[3].observations[1].y += 1.0f;          // off the epipolar line: cannot be absorbed
  const TrackAgreement moved = track_agreement(set, cameras);
  EXPECT_NEAR(moved.track_error_px.max, 0.5, 0.01);
  EXPECT_LT(moved.track_error_px.median, 1e-3);
  set.tracks[0].observations[0].frame = 2;
  EXPECT_THROW(track_agreement(set, cameras), UsageError);
}

}  // namespace
}  // namespace pg

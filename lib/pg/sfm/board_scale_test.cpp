#include "pg/sfm/board_scale.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include "pg/core/error.h"
#include "pg/synth/scenes.h"
#include "pg/synth/write_scene.h"
#include "pg/testing/testing.h"

namespace pg {
namespace {

// The checkerboard scene's exact cameras moved into an arbitrary similarity frame, as a
// reconstruction without metric scale would give them: the board recovers the scale.
TEST(BoardScale, RecoversTheMetricScaleOfAReconstructionFromTheBoardViews) {
  synth::SceneOptions options;
  options.width = 480;
  options.height = 360;
  options.views = 6;
  const synth::Scene scene = synth::make_checkerboard_scene(options);
  pg::testing::TempDir dir;
  synth::write_scene(scene, dir.path(), {.supersample = 2, .write_depth = false});

  const double units_per_metre = 0.37;
  const Eigen::Quaterniond turn(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()));
  const Eigen::Vector3d shift(4, -2, 9);
  std::vector<Camera> cameras;
  std::vector<std::filesystem::path> images;
  for (const Camera& truth : scene.cameras.cameras) {
    Camera c = truth;
    const Eigen::Vector3d centre = units_per_metre * (turn * truth.cam_from_world.centre()) + shift;
    c.cam_from_world.rotation = truth.cam_from_world.rotation * turn.conjugate();
    c.cam_from_world.translation = -(c.cam_from_world.rotation * centre);
    cameras.push_back(c);
    images.push_back(dir / "images" / (c.id + ".png"));
  }
  calib::BoardSpec board;
  board.cols = scene.board->inner_x;
  board.rows = scene.board->inner_y;
  board.square_size = scene.board->square;
  const BoardScale scale = scale_from_board(cameras, images, board);
  std::cout << "[ measured ] board scale from " << scale.views << " views: " << scale.metres_per_unit
            << " m/unit (truth " << 1 / units_per_metre << "), spread " << scale.relative_spread << "\n";
  EXPECT_EQ(scale.views, 6);
  EXPECT_NEAR(scale.metres_per_unit * units_per_metre, 1.0, 0.001);
  EXPECT_LT(scale.relative_spread, 0.005);

  // One view is not enough to triangulate the board.
  EXPECT_THROW(scale_from_board({cameras[0]}, {images[0]}, board), FailedError);
}

}  // namespace
}  // namespace pg

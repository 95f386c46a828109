#include "pg/depth/depth_memory.h"

#include <gtest/gtest.h>

#include "pg/flow/flow_memory.h"
#include "pg/image/image_io.h"
#include "pg/image/pyramid.h"

namespace {

pg::Camera camera_of_size(const std::string& id, int width, int height) {
  pg::Camera camera;
  camera.id = id;
  camera.width = width;
  camera.height = height;
  camera.intrinsics = {1000, 1000, (width - 1) / 2.0, (height - 1) / 2.0};
  return camera;
}

double pair_estimate(int width, int height, const pg::DepthPairOptions& options = {}) {
  return static_cast<double>(pg::depth_pair_memory_bytes(camera_of_size("a", width, height),
                                                         camera_of_size("b", width, height), 3,
                                                         pg::max_flow_channels, options));
}

TEST(DepthMemory, EstimateIsLinearInPixels) {
  // Four times the pixels, four times the bytes: only the tiny coarsest pyramid levels differ.
  EXPECT_NEAR(pair_estimate(3072, 2048) / pair_estimate(1536, 1024), 4.0, 0.01);
  EXPECT_NEAR(pair_estimate(1536, 2048) / pair_estimate(1536, 1024), 2.0, 0.01);
}

TEST(DepthMemory, PairEstimateLiesBetweenTheSolversPlanesAndTwiceThem) {
  // Counted independently from level_solver.h: the finest level's 12 motion-tensor entries, psi,
  // two edge weights, du, dv and 11 red-black fields; five derivative planes per colour channel of
  // each image and the smoothness weight; 4 bytes each.
  const double pixels = 1536.0 * 1024.0;
  const double solver_planes = 12 + 1 + 2 + 2 + 11;
  const double level_planes = solver_planes + 2 * 3 * 5 + 1;
  const double counted = 4 * pixels * level_planes;
  const double estimate = pair_estimate(1536, 1024);
  EXPECT_GT(estimate, counted);
  EXPECT_LT(estimate, 2 * counted);
}

TEST(DepthMemory, ScaleShrinksTheFlowWithThePixels) {
  pg::DepthPairOptions half;
  half.scale = 0.5;
  const double full_images = 2.0 * 1536 * 1024 * (3 + 1);  // decoded images and masks, kept at full size
  const double scaled = pair_estimate(1536, 1024, half) - full_images;
  const double full = pair_estimate(1536, 1024) - full_images;
  EXPECT_NEAR(scaled / full, 0.25, 0.01);
}

TEST(DepthMemory, PyramidPixelsMatchTheBuiltPyramid) {
  const pg::FlowOptions options = pg::FlowOptions::preset("balanced");
  const cv::Mat1f image(150, 200, 0.5f);
  std::uint64_t built = 0;
  for (const cv::Mat1f& level :
       pg::build_pyramid(image, {options.pyramid_factor, options.min_side, options.max_levels}))
    built += static_cast<std::uint64_t>(level.total());
  EXPECT_EQ(pg::flow_pyramid_pixels(image.size(), options), built);
  // The geometric series 1 / (1 - factor^2) bounds it.
  EXPECT_LT(static_cast<double>(built), 200.0 * 150 / (1 - 0.9 * 0.9));
}

TEST(DepthMemory, SkippedFinestLevelsSaveTheSolversBuffers) {
  pg::FlowOptions fast = pg::FlowOptions::preset("balanced");
  fast.finest_level = 1;
  const cv::Size size(1536, 1024);
  const std::uint64_t full = pg::flow_memory_bytes(size, 3, pg::FlowOptions::preset("balanced"), true);
  const std::uint64_t skipped = pg::flow_memory_bytes(size, 3, fast, true);
  // Level 1 is 0.9 x 0.9 of level 0: the solver and derivative planes shrink by 19%, but the line
  // field is resized to level 1 (base and direction, 2 channels each).
  const double level_planes = pg::flow_solver_planes + 2 * 3 * pg::flow_derivative_planes_per_channel + 1;
  const double saved = 4 * level_planes * (1536.0 * 1024 - 1382.0 * 922) - 4 * 4 * 1382.0 * 922;
  EXPECT_NEAR(static_cast<double>(full - skipped), saved, 1e-6 * saved);
}

TEST(DepthMemory, DecodedBytesPerPixelFollowTheFileType) {
  EXPECT_EQ(pg::decoded_image_bytes_per_pixel("a/view.JPG"), 3u);
  EXPECT_EQ(pg::decoded_image_bytes_per_pixel("view.png"), 8u);
  EXPECT_EQ(pg::decoded_image_bytes_per_pixel("view.exr"), 16u);
}

}  // namespace

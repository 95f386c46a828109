// Real data: Strecha Herz-Jesus-P8 with its true cameras. Depth maps of two consecutive pairs
// (0000-0001 and 0001-0002) at quarter resolution must agree where they overlap.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "pg/depth/depth_geometry.h"
#include "pg/depth/depth_pair.h"
#include "pg/eval/truth_import.h"
#include "pg/image/image_io.h"
#include "pg/testing/testing.h"

namespace {

namespace fs = std::filesystem;

TEST(DepthReal, HerzJesusPairsAgreeWhereTheyOverlap) {
  PG_REQUIRE_REAL_DATA(dir, "multiview/strecha/Herz-Jesus-P8");
  const double scale = 0.25;
  const pg::CameraSet truth = pg::import_strecha_cameras(dir / "gt_dense_cameras", dir / "images", scale);
  std::vector<pg::Camera> cameras;
  std::vector<cv::Mat> images;
  for (const char* id : {"0000", "0001", "0002"}) {
    ASSERT_NE(truth.find(id), nullptr) << id;
    cameras.push_back(*truth.find(id));
    cv::Mat image;
    cv::resize(pg::read_image(cameras.back().image), image, {cameras.back().width, cameras.back().height}, 0,
               0, cv::INTER_AREA);
    images.push_back(image);
  }
  const auto depth = [&](int reference, int other) {
    pg::DepthPairInput input;
    input.reference_image = images[reference], input.other_image = images[other];
    input.reference = cameras[reference], input.other = cameras[other];
    return pg::compute_depth_pair(input).depth.map;
  };
  const pg::DepthMap a = depth(0, 1), b = depth(1, 2);

  // Each valid point of pair A seen from B's reference camera, against B's depth at that pixel.
  const pg::Camera& view = cameras[1];
  const cv::Mat1f depth_b = b.depth;
  std::vector<double> distances, depths;
  for (int y = 0; y < a.depth.rows; ++y)
    for (int x = 0; x < a.depth.cols; ++x) {
      const float z = a.depth.at<float>(y, x);
      if (!std::isfinite(z)) continue;
      const Eigen::Vector3d world = a.camera.cam_from_world.inverse() *
                                    pg::point_from_depth(a.camera, a.kind, Eigen::Vector2d(x, y), z);
      const Eigen::Vector3d in_view = view.cam_from_world * world;
      Eigen::Vector2d pixel;
      if (!view.project(in_view, pixel)) continue;
      // B's depth sampled bilinearly where its four pixels are valid (NaN propagates otherwise).
      const int px = static_cast<int>(std::floor(pixel.x())), py = static_cast<int>(std::floor(pixel.y()));
      if (px < 0 || py < 0 || px + 1 >= depth_b.cols || py + 1 >= depth_b.rows) continue;
      const double ax = pixel.x() - px, ay = pixel.y() - py;
      const double seen_depth = (1 - ay) * ((1 - ax) * depth_b(py, px) + ax * depth_b(py, px + 1)) +
                                ay * ((1 - ax) * depth_b(py + 1, px) + ax * depth_b(py + 1, px + 1));
      if (!std::isfinite(seen_depth)) continue;
      const Eigen::Vector3d seen = pg::point_from_depth(view, b.kind, pixel, seen_depth);
      distances.push_back((seen - in_view).norm());
      depths.push_back(in_view.z());
    }
  ASSERT_GT(distances.size(), static_cast<std::size_t>(a.depth.total() / 4));
  const auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
  };
  const double median_distance = median(distances), scene_depth = median(depths);
  ::testing::Test::RecordProperty("median_distance_over_depth",
                                  std::to_string(median_distance / scene_depth));
  ::testing::Test::RecordProperty("overlap_points", std::to_string(distances.size()));
  EXPECT_LT(median_distance, 0.005 * scene_depth);
}

}  // namespace

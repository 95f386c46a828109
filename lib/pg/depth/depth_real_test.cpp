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
#include "pg/image/image_io.h"
#include "pg/testing/testing.h"

namespace {

namespace fs = std::filesystem;

// A Strecha camera file: K (3 lines), radial distortion (1 line, zero), R camera-to-world
// (3 lines), centre C (1 line), "w h": x_cam = R^T (X - C).
pg::Camera read_strecha_camera(const fs::path& file, const std::string& id) {
  std::ifstream in(file);
  Eigen::Matrix3d k, r;
  Eigen::Vector3d distortion, centre;
  for (int i = 0; i < 9; ++i) in >> k(i / 3, i % 3);
  for (int i = 0; i < 3; ++i) in >> distortion(i);
  for (int i = 0; i < 9; ++i) in >> r(i / 3, i % 3);
  for (int i = 0; i < 3; ++i) in >> centre(i);
  pg::Camera camera;
  in >> camera.width >> camera.height;
  EXPECT_TRUE(in) << file;
  camera.id = id;
  camera.intrinsics = {k(0, 0), k(1, 1), k(0, 2), k(1, 2)};
  const Eigen::Matrix3d cam_from_world = r.transpose();
  camera.cam_from_world.rotation = Eigen::Quaterniond(cam_from_world);
  camera.cam_from_world.translation = -cam_from_world * centre;
  return camera;
}

TEST(DepthReal, HerzJesusPairsAgreeWhereTheyOverlap) {
  PG_REQUIRE_REAL_DATA(dir, "multiview/strecha/Herz-Jesus-P8");
  const double scale = 0.25;
  std::vector<pg::Camera> cameras;
  std::vector<cv::Mat> images;
  for (const char* id : {"0000", "0001", "0002"}) {
    const std::string name = std::string(id) + ".jpg";
    cameras.push_back(
        pg::scale_camera(read_strecha_camera(dir / "gt_dense_cameras" / (name + ".camera"), id), scale));
    cv::Mat image;
    cv::resize(pg::read_image(dir / "images" / name), image, {cameras.back().width, cameras.back().height}, 0,
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

#include <gtest/gtest.h>

#include "pg/camera/cameras_io.h"
#include "pg/core/json_file.h"
#include "pg/image/depth_exr.h"
#include "pg/image/image_io.h"
#include "pg/mesh/bvh.h"
#include "pg/mesh/mesh_io.h"
#include "pg/synth/write_scene.h"
#include "pg/testing/testing.h"

namespace fs = std::filesystem;

namespace {
pg::synth::WriteOptions one_sample(bool depth) {
  pg::synth::WriteOptions options;
  options.supersample = 1;
  options.write_depth = depth;
  return options;
}

// Every valid depth pixel, lifted to 3-D with the file's own camera, lies on the true mesh.
void expect_depth_on_mesh(const fs::path& folder, double tolerance_relative) {
  auto cameras = pg::read_cameras(folder / "cameras.json");
  pg::Mesh truth = pg::read_mesh(folder / "mesh.ply");
  pg::TriangleBvh bvh(truth);
  for (const auto& camera : cameras.cameras) {
    auto depth = pg::read_depth_exr(folder / "depth" / (camera.id + ".exr"));
    ASSERT_EQ(depth.camera.width, camera.width);
    int valid = 0;
    double worst = 0;
    for (int y = 0; y < depth.depth.rows; y += 3)
      for (int x = 0; x < depth.depth.cols; x += 3) {
        float d = depth.depth.at<float>(y, x);
        if (std::isnan(d)) continue;
        ++valid;
        Eigen::Vector3d ray = camera.unproject({double(x), double(y)});
        // perspective_z: scale the unit ray to the z plane; spherical_range: along the ray.
        Eigen::Vector3d p_cam = depth.kind == pg::DepthKind::perspective_z ? ray * (d / ray.z()) : ray * d;
        Eigen::Vector3d p = camera.cam_from_world.inverse() * p_cam;
        double distance = bvh.closest_point(p.cast<float>()).distance;
        worst = std::max(worst, distance / d);
      }
    EXPECT_GT(valid, 100) << camera.id;
    EXPECT_LT(worst, tolerance_relative) << camera.id;
  }
}
}  // namespace

TEST(WriteScene, SetDepthMapsLieOnTheTrueMesh) {
  pg::testing::TempDir dir;
  pg::synth::SceneOptions o;
  o.width = 160;
  o.height = 120;
  o.views = 3;
  pg::synth::write_scene(pg::synth::make_set_scene(o), dir.path(), one_sample(true));
  expect_depth_on_mesh(dir.path(), 1e-4);
  cv::Mat image = pg::read_image(dir / "images/view_000.png");
  EXPECT_EQ(image.cols, 160);
  EXPECT_EQ(image.type(), CV_8UC3);
}

TEST(WriteScene, PanoramaRangeMapsLieOnTheTrueMesh) {
  pg::testing::TempDir dir;
  pg::synth::SceneOptions o;
  o.height = 64;
  pg::synth::write_scene(pg::synth::make_room_scene(o), dir.path(), one_sample(true));
  expect_depth_on_mesh(dir.path(), 1e-4);
  auto depth = pg::read_depth_exr(dir / "depth/pano_lower.exr");
  EXPECT_EQ(depth.kind, pg::DepthKind::spherical_range);
  // Inside a closed room every pixel sees a surface.
  EXPECT_EQ(cv::countNonZero(depth.depth == depth.depth), 128 * 64);
}

TEST(WriteScene, ManifestStartsWithFormatVersionAndProvenance) {
  pg::testing::TempDir dir;
  pg::synth::SceneOptions o;
  o.width = 64;
  o.height = 48;
  o.views = 1;
  pg::synth::write_scene(pg::synth::make_checkerboard_scene(o), dir.path(), one_sample(false));
  auto doc = pg::read_json_file(dir / "scene.json");
  EXPECT_EQ(pg::check_format_header(doc, dir / "scene.json", "pg-synth-scene", 1), 1);
  EXPECT_EQ(doc["extras"]["inner_corners"][0], 9);
  const std::string text = pg::testing::read_text(dir / "scene.json");
  EXPECT_LT(text.find("\"format\""), text.find("\"version\""));
  EXPECT_LT(text.find("\"version\""), text.find("\"provenance\""));
  EXPECT_LT(text.find("\"provenance\""), text.find("\"scene\""));
}

// Refinement on real photographs: Strecha et al.'s Herz-Jesus-P8 with its true cameras. A coarse mesh
// of the facade (a 24-pixel grid of depths from one flow, smoothed) is refined against three views;
// the re-rendered views must agree better with the real ones on every pair.
#include <gtest/gtest.h>

#include <fstream>
#include <iostream>
#include <opencv2/imgproc.hpp>

#include "pg/eval/truth_import.h"
#include "pg/flow/flow.h"
#include "pg/geometry/triangulation.h"
#include "pg/image/image_io.h"
#include "pg/refine/refine.h"
#include "pg/testing/testing.h"

namespace fs = std::filesystem;

namespace {

// A coarse grid mesh of what `reference` sees, from the flow to `other` at low resolution.
pg::Mesh coarse_mesh(const pg::RefineView& reference, const pg::RefineView& other, int step) {
  const double scale = 384.0 / reference.camera.width;
  const pg::Camera ref = pg::resized_camera(reference.camera, scale),
                   oth = pg::resized_camera(other.camera, scale);
  cv::Mat ref_image, oth_image;
  cv::resize(pg::to_float_gray(reference.image), ref_image, cv::Size(ref.width, ref.height), 0, 0,
             cv::INTER_AREA);
  cv::resize(pg::to_float_gray(other.image), oth_image, cv::Size(oth.width, oth.height), 0, 0,
             cv::INTER_AREA);
  const cv::Mat2f flow = pg::compute_flow(ref_image, oth_image, pg::FlowOptions::preset("balanced"));
  const int cols = ref.width / step + 1, rows = ref.height / step + 1;
  cv::Mat1f depth(rows, cols, std::numeric_limits<float>::quiet_NaN());
  const Eigen::Vector3d c_ref = ref.cam_from_world.centre(), c_oth = oth.cam_from_world.centre();
  for (int j = 0; j < rows; ++j)
    for (int i = 0; i < cols; ++i) {
      const int x = std::min(i * step, ref.width - 1), y = std::min(j * step, ref.height - 1);
      const cv::Vec2f f = flow(y, x);
      const Eigen::Vector3d ray_ref = ref.cam_from_world.rotation.conjugate() * ref.unproject({x, y});
      const Eigen::Vector3d ray_oth =
          oth.cam_from_world.rotation.conjugate() * oth.unproject({x + f[0], y + f[1]});
      const auto point = pg::triangulate_midpoint(c_ref, ray_ref, c_oth, ray_oth);
      if (point) depth(j, i) = float((ref.cam_from_world * *point).z());
    }
  // Coarse: a median over 5x5 grid cells removes outliers and detail alike.
  cv::patchNaNs(depth, 0);
  cv::Mat1f smooth;
  cv::medianBlur(depth, smooth, 5);
  pg::Mesh mesh;
  for (int j = 0; j < rows; ++j)
    for (int i = 0; i < cols; ++i) {
      const Eigen::Vector2d pixel(std::min(i * step, ref.width - 1), std::min(j * step, ref.height - 1));
      const Eigen::Vector3d ray = ref.unproject(pixel);
      const Eigen::Vector3d p_cam = ray / ray.z() * std::max(1.0f, smooth(j, i));
      mesh.positions.push_back((ref.cam_from_world.inverse() * p_cam).cast<float>());
    }
  for (int j = 0; j + 1 < rows; ++j)
    for (int i = 0; i + 1 < cols; ++i) {
      const auto v = [&](int a, int b) { return std::uint32_t(b * cols + a); };
      mesh.faces.push_back({v(i, j), v(i, j + 1), v(i + 1, j)});
      mesh.faces.push_back({v(i + 1, j), v(i, j + 1), v(i + 1, j + 1)});
    }
  return mesh;
}

TEST(RefineReal, HerzJesusPhotometricErrorImprovesOnEveryPair) {
  PG_REQUIRE_REAL_DATA(folder, "multiview/strecha/Herz-Jesus-P8");
  const pg::CameraSet truth = pg::import_strecha_cameras(folder / "gt_dense_cameras", folder / "images");
  std::vector<pg::RefineView> views;
  for (const std::string name : {"0003", "0004", "0005"}) {
    ASSERT_NE(truth.find(name), nullptr) << name;
    const pg::Camera& camera = *truth.find(name);
    views.push_back({camera, pg::read_image(camera.image)});
    ASSERT_EQ(views.back().image.cols, views.back().camera.width);
  }
  const pg::Mesh coarse = coarse_mesh(views[1], views[0], 24);
  pg::RefineOptions options;
  options.scale = 0.25;  // 768 x 512
  options.iterations = 4;
  const pg::RefineResult result = pg::refine_mesh(coarse, views, {{0, 1}, {1, 2}}, {}, options);
  EXPECT_EQ(result.mesh.faces, coarse.faces);
  const auto& before = result.iterations.front().before;
  const auto& after = result.iterations.back().after;
  ASSERT_EQ(before.size(), 4u);
  for (std::size_t k = 0; k < before.size(); ++k) {
    std::cout << "pair " << views[before[k].a].camera.id << " -> " << views[before[k].b].camera.id
              << ": 1 - NCC " << before[k].ncc_error << " -> " << after[k].ncc_error << ", mean |difference| "
              << before[k].mean_abs_error << " -> " << after[k].mean_abs_error << " over " << after[k].pixels
              << " pixels\n";
    EXPECT_LT(after[k].ncc_error, 0.9 * before[k].ncc_error) << k;
    EXPECT_LT(after[k].mean_abs_error, before[k].mean_abs_error) << k;
    EXPECT_GT(after[k].pixels, 0.5 * before[k].pixels) << k;
  }
}

}  // namespace

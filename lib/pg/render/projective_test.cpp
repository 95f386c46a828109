#include "pg/render/projective.h"

#include <gtest/gtest.h>

#include "pg/render/render_test_scenes.h"

namespace pg {
namespace {

using namespace render_test;

cv::Mat smooth_image(const Camera& camera) {
  cv::Mat image(camera.height, camera.width, CV_32FC3);
  for (int y = 0; y < camera.height; ++y)
    for (int x = 0; x < camera.width; ++x)
      image.at<cv::Vec3f>(y, x) = {std::sin(0.05f * x) + 1, std::cos(0.07f * y) + 1, 0.001f * (x + y)};
  return image;
}

TEST(Projective, SameCameraReproducesTheImage) {
  const Camera a = pinhole_distorted();
  const std::vector<Quad> quads = {{{0.2, -0.1, 4}, {1.5, 0.2, 0.5}, {-0.1, 1.2, 0.2}},
                                   {{0, 0, 9}, {8, 0, 0}, {0, 6, 1}}};
  const Mesh mesh = quads_mesh(a, quads);
  const cv::Mat image = smooth_image(a);
  const RenderBuffers source = render(mesh, a);
  const ProjectedImage out = render_projected(mesh, a, image, source.depth, a);
  ASSERT_EQ(out.image.type(), CV_32FC3);
  int checked = 0;
  for (int y = 0; y < a.height; ++y)
    for (int x = 0; x < a.width; ++x) {
      if (source.triangle_at(x, y) == kNoTriangle) {
        EXPECT_EQ(out.valid.at<std::uint8_t>(y, x), 0);
        continue;
      }
      ASSERT_EQ(out.valid.at<std::uint8_t>(y, x), 255) << x << "," << y;
      const cv::Vec2f at = out.source_pixel.at<cv::Vec2f>(y, x);
      EXPECT_LT(cv::norm(at - cv::Vec2f(x, y)), 1e-2);
      EXPECT_LT(cv::norm(out.image.at<cv::Vec3f>(y, x) - image.at<cv::Vec3f>(y, x)), 2e-3) << x << "," << y;
      ++checked;
    }
  EXPECT_GT(checked, a.width * a.height / 2);
}

TEST(Projective, PointsOccludedInTheSourceAreMasked) {
  const Camera a = pinhole_distorted();
  Camera b = a;
  Rigid3 shift;
  shift.translation = Eigen::Vector3d(-1, 0, 0);  // b's centre is 1 to the right of a's
  b.cam_from_world = shift * a.cam_from_world;
  const Quad occluder{{0, 0, 5}, {0.8, 0, 0}, {0, 0.8, 0}};
  const std::vector<Quad> quads = {occluder, {{0, 0, 10}, {20, 0, 0}, {0, 20, 0}}};
  const Mesh mesh = quads_mesh(a, quads);
  const RenderBuffers source = render(mesh, a);
  const ProjectedImage out = render_projected(mesh, a, smooth_image(a), source.depth, b);
  int occluded = 0, visible = 0;
  for (int y = 0; y < b.height; ++y)
    for (int x = 0; x < b.width; ++x) {
      if (out.target.triangle_at(x, y) == kNoTriangle) continue;
      const bool valid = out.valid.at<std::uint8_t>(y, x) == 255;
      const Eigen::Vector3d point = a.cam_from_world * surface_point(mesh, out.target, x, y);
      Eigen::Vector2d pixel;
      a.project(point, pixel);
      if (out.target.triangle_at(x, y) < 2) {  // on the occluder: nothing hides it from a
        // (within a pixel of its outline, a's nearest pixel may see the background instead)
        if (a.in_image(pixel, 1) && std::max(std::abs(point.x()), std::abs(point.y())) < 0.78) {
          EXPECT_TRUE(valid) << x << "," << y;
        }
        continue;
      }
      // Where the segment from a's centre to the point crosses the occluder's plane z = 5.
      const Eigen::Vector3d crossing = point * (5 / point.z());
      const double inside = std::max(std::abs(crossing.x()), std::abs(crossing.y()));
      if (inside < 0.75) {
        EXPECT_FALSE(valid) << x << "," << y;
        ++occluded;
      } else if (inside > 0.85 && a.in_image(pixel, 1)) {
        EXPECT_TRUE(valid) << x << "," << y;
        ++visible;
      }
    }
  EXPECT_GT(occluded, 1000);
  EXPECT_GT(visible, 10000);
}

TEST(Projective, RejectsMismatchedInputs) {
  const Camera a = pinhole_distorted();
  const cv::Mat depth(a.height, a.width, CV_32F, cv::Scalar(1));
  EXPECT_ANY_THROW(render_projected(Mesh{}, a, cv::Mat(10, 10, CV_32FC3), depth, a));
  EXPECT_ANY_THROW(render_projected(Mesh{}, a, smooth_image(a), cv::Mat(10, 10, CV_32F), a));
}

}  // namespace
}  // namespace pg

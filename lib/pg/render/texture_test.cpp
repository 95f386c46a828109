#include "pg/render/texture.h"

#include <gtest/gtest.h>

#include <random>

#include "pg/render/rasterizer.h"
#include "pg/render/render_test_scenes.h"

namespace pg {
namespace {

using namespace render_test;

// Texel (x, y) holds its own centre's uv and a constant: every mip level and every bilinear or
// trilinear sample away from the border reproduces (u, v, 0.25) exactly.
cv::Mat linear_texture(int size) {
  cv::Mat image(size, size, CV_32FC3);
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x)
      image.at<cv::Vec3f>(y, x) = {(x + 0.5f) / size, 1 - (y + 0.5f) / size, 0.25f};
  return image;
}

TEST(Texture, LinearTextureSamplesExactlyAtEveryLevelOfDetail) {
  const Texture texture(linear_texture(64));
  EXPECT_EQ(texture.level_count(), 7);
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> coord(0.2f, 0.8f), lod(0.0f, 3.0f);
  for (int i = 0; i < 1000; ++i) {
    const Eigen::Vector2f uv{coord(rng), coord(rng)};
    const Eigen::Vector3f c = texture.sample(uv, lod(rng));
    EXPECT_NEAR(c[0], uv.x(), 1e-5);
    EXPECT_NEAR(c[1], uv.y(), 1e-5);
    EXPECT_NEAR(c[2], 0.25f, 1e-6);
  }
}

TEST(Texture, ConstantEightBitTextureDecodesSrgbEverywhere) {
  const Texture texture(cv::Mat(37, 21, CV_8UC3, cv::Scalar(10, 128, 250)), TextureWrap::repeat);
  const Eigen::Vector3f expected(linear_from_srgb(10 / 255.0f), linear_from_srgb(128 / 255.0f),
                                 linear_from_srgb(250 / 255.0f));
  for (float u : {-1.3f, 0.0f, 0.31f, 1.0f, 2.7f})
    for (float lod : {0.0f, 1.5f, 4.0f, 100.0f})
      EXPECT_LT((texture.sample({u, 0.6f}, lod) - expected).norm(), 1e-6);
  EXPECT_NEAR(linear_from_srgb(srgb_from_linear(0.3f)), 0.3f, 1e-6);
}

TEST(Texture, LevelOfDetailIsLog2OfTheTexelFootprint) {
  const Texture texture(linear_texture(64));
  EXPECT_FLOAT_EQ(texture.lod({4.0f / 64, 0}, {0, 1.0f / 64}), 2.0f);
  EXPECT_FLOAT_EQ(texture.lod({0.5f / 64, 0}, {0, 0.5f / 64}), 0.0f);
}

TEST(Texture, EightBitConversion) {
  cv::Mat linear(1, 5, CV_32F);
  linear.at<float>(0) = 0, linear.at<float>(1) = 1, linear.at<float>(2) = 0.5f, linear.at<float>(3) = 2;
  linear.at<float>(4) = std::numeric_limits<float>::quiet_NaN();
  const cv::Mat srgb = to_8bit(linear), plain = to_8bit(linear, false);
  EXPECT_EQ(srgb.at<std::uint8_t>(0), 0);
  EXPECT_EQ(srgb.at<std::uint8_t>(1), 255);
  EXPECT_NEAR(srgb.at<std::uint8_t>(2), 255 * srgb_from_linear(0.5f), 1.0);
  EXPECT_EQ(srgb.at<std::uint8_t>(3), 255);
  EXPECT_EQ(srgb.at<std::uint8_t>(4), 0);
  EXPECT_NEAR(plain.at<std::uint8_t>(2), 127.5, 1.0);
}

// A quad seen by the distorted pinhole camera, with uvs spanning [0.25, 0.75].
struct ShadedQuad {
  Camera camera = pinhole_distorted();
  std::vector<Quad> quads = {{{0.2, -0.1, 4}, {1.5, 0.2, 0.5}, {-0.1, 1.2, 0.2}}};
  Mesh mesh = quads_mesh(camera, quads, 0.25f, 0.75f);

  // The uv at the camera-frame point p on the quad.
  Eigen::Vector2d uv_at(const Eigen::Vector3d& p) const {
    const Quad& q = quads[0];
    const Eigen::Vector3d local = p - q.centre;
    const double aa = q.a.dot(q.a), ab = q.a.dot(q.b), bb = q.b.dot(q.b), la = local.dot(q.a),
                 lb = local.dot(q.b);
    const double det = aa * bb - ab * ab, s = (la * bb - lb * ab) / det, r = (lb * aa - la * ab) / det;
    return {0.25 + 0.25 * (s + 1), 0.25 + 0.25 * (r + 1)};
  }
};

TEST(Shading, LinearTextureGivesTheAnalyticUvAtEveryPixel) {
  const ShadedQuad scene;
  const Texture texture(linear_texture(256));
  RenderOptions options;
  options.shading = Shading::texture;
  options.texture = &texture;
  const RenderBuffers b = render(scene.mesh, scene.camera, options);
  ASSERT_EQ(b.color.type(), CV_32FC3);
  int checked = 0;
  for (int y = 0; y < b.height; ++y)
    for (int x = 0; x < b.width; ++x) {
      const Eigen::Vector3d d = scene.camera.unproject(Eigen::Vector2d(x, y));
      const auto t = quads_hit(scene.quads, d, -1e-3);
      const cv::Vec3f c = b.color.at<cv::Vec3f>(y, x);
      if (!t) {
        if (!quads_hit(scene.quads, d, 1e-3)) {
          EXPECT_EQ(c, cv::Vec3f(0, 0, 0));
        }
        continue;
      }
      const Eigen::Vector2d uv = scene.uv_at(*t * d);
      ASSERT_NEAR(c[0], uv.x(), 1e-4) << x << "," << y;
      ASSERT_NEAR(c[1], uv.y(), 1e-4) << x << "," << y;
      ASSERT_NEAR(c[2], 0.25, 1e-6);
      ++checked;
    }
  EXPECT_GT(checked, 10000);
}

TEST(Shading, ConstantTextureVertexColoursAndHeadlight) {
  ShadedQuad scene;
  const Texture texture(cv::Mat(16, 16, CV_32FC3, cv::Scalar(0.2, 0.5, 0.7)));
  scene.mesh.colors.assign(scene.mesh.positions.size(), {255, 0, 51});
  RenderOptions options;
  options.texture = &texture;
  options.shading = Shading::automatic;  // texture and uvs present: the texture wins
  const RenderBuffers textured = render(scene.mesh, scene.camera, options);
  options.shading = Shading::vertex_colors;
  const RenderBuffers coloured = render(scene.mesh, scene.camera, options);
  options.shading = Shading::white;
  options.lambert = true;
  options.ambient = 0.2f;
  const RenderBuffers lit = render(scene.mesh, scene.camera, options);
  const Eigen::Vector3d normal = scene.quads[0].a.cross(scene.quads[0].b).normalized();
  int checked = 0;
  for (int y = 0; y < textured.height; ++y)
    for (int x = 0; x < textured.width; ++x) {
      if (textured.triangle_at(x, y) == kNoTriangle) continue;
      EXPECT_LT(cv::norm(textured.color.at<cv::Vec3f>(y, x) - cv::Vec3f(0.2f, 0.5f, 0.7f)), 1e-6);
      // RGB (255, 0, 51) decoded to linear, stored BGR.
      EXPECT_LT(cv::norm(coloured.color.at<cv::Vec3f>(y, x) - cv::Vec3f(linear_from_srgb(0.2f), 0, 1)), 1e-6);
      const double cosine = std::abs(normal.dot(scene.camera.unproject(Eigen::Vector2d(x, y))));
      EXPECT_NEAR(lit.color.at<cv::Vec3f>(y, x)[1], 0.2 + 0.8 * cosine, 1e-5);
      ++checked;
    }
  EXPECT_GT(checked, 10000);
  options.texture = nullptr;
  options.shading = Shading::texture;
  EXPECT_ANY_THROW(render(scene.mesh, scene.camera, options));
}

}  // namespace
}  // namespace pg

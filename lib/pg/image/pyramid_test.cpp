#include "pg/image/pyramid.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "pg/core/error.h"

namespace pg {
namespace {

cv::Mat1f ramp(cv::Size size, float a, float b, float c) {
  cv::Mat1f image(size);
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x) image(y, x) = a * x + b * y + c;
  return image;
}

TEST(Pyramid, LevelSizesFollowTheFactorAndStopAtMinSide) {
  const std::vector<cv::Size> halves = pyramid_sizes({640, 480}, {0.5, 16, 0});
  const std::vector<cv::Size> expected_halves = {{640, 480}, {320, 240}, {160, 120}, {80, 60}, {40, 30}};
  EXPECT_EQ(halves, expected_halves);  // 20 x 15 would be below 16

  // round(side * 0.8) per level: 100x50, 80x40, 64x32, 51.2->51 x 25.6->26, 40.8->41 x 20.8->21, 33 x 17.
  const std::vector<cv::Size> brox = pyramid_sizes({100, 50}, {0.8, 16, 0});
  const std::vector<cv::Size> expected_brox = {{100, 50}, {80, 40}, {64, 32}, {51, 26}, {41, 21}, {33, 17}};
  EXPECT_EQ(brox, expected_brox);

  EXPECT_EQ(pyramid_sizes({100, 50}, {0.8, 16, 3}).size(), 3u);
  // A factor near 1 rounds small sides back to themselves: the sequence stops instead of repeating.
  const std::vector<cv::Size> slow = pyramid_sizes({9, 9}, {0.95, 1, 0});
  EXPECT_EQ(slow, std::vector<cv::Size>({{9, 9}}));
  EXPECT_THROW(pyramid_sizes({10, 10}, {0.4, 1, 0}), UsageError);
  EXPECT_THROW(pyramid_sizes({10, 10}, {1.0, 1, 0}), UsageError);
}

TEST(Pyramid, BuildsLevelsOfThePlannedSizes) {
  const cv::Mat1f image = ramp({97, 61}, 0.1f, 0.2f, 1.f);
  const PyramidOptions options{0.75, 8, 0};
  const std::vector<cv::Mat1f> levels = build_pyramid(image, options);
  const std::vector<cv::Size> sizes = pyramid_sizes(image.size(), options);
  ASSERT_EQ(levels.size(), sizes.size());
  for (std::size_t k = 0; k < levels.size(); ++k) EXPECT_EQ(levels[k].size(), sizes[k]);
  EXPECT_EQ(cv::norm(levels[0], image, cv::NORM_INF), 0.0);
}

TEST(Pyramid, DownsampledRampMatchesTheRampAtMappedPixelCentres) {
  // A symmetric blur leaves a linear function unchanged away from the borders, and bilinear sampling is
  // exact on it, so level pixel (x, y) holds f((x + 0.5) * W / w - 0.5, (y + 0.5) * H / h - 0.5).
  const cv::Size size(120, 90);
  const float a = 0.75f, b = -0.5f, c = 10.f;
  for (double factor : {0.5, 0.8}) {
    const cv::Mat1f level = downsample(ramp(size, a, b, c), factor);
    ASSERT_EQ(level.size(), cv::Size(static_cast<int>(std::lround(120 * factor)),
                                     static_cast<int>(std::lround(90 * factor))));
    const double sx = 120.0 / level.cols, sy = 90.0 / level.rows;
    const int margin = 4;  // covers the blur radius mapped to the level
    for (int y = margin; y < level.rows - margin; ++y)
      for (int x = margin; x < level.cols - margin; ++x) {
        const double expected = a * ((x + 0.5) * sx - 0.5) + b * ((y + 0.5) * sy - 0.5) + c;
        ASSERT_NEAR(level(y, x), expected, 1e-3) << "factor " << factor << " at " << x << "," << y;
      }
  }
}

TEST(Pyramid, DownsampledSinusoidIsAttenuatedLikeAGaussian) {
  // Gaussian smoothing multiplies a sinusoid of frequency w by exp(-sigma^2 w^2 / 2).
  const cv::Size size(256, 8);
  const double w = 2 * M_PI / 32;
  cv::Mat1f image(size);
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x) image(y, x) = static_cast<float>(std::sin(w * x));
  const double factor = 0.5;
  const double gain = std::exp(-0.5 * std::pow(downsample_sigma(factor) * w, 2));
  const cv::Mat1f level = downsample(image, factor);
  for (int x = 4; x < level.cols - 4; ++x) {
    const double source_x = (x + 0.5) / factor - 0.5;
    // Bilinear interpolation of a sinusoid errs by at most w^2 / 8 of its amplitude.
    EXPECT_NEAR(level(2, x), gain * std::sin(w * source_x), w * w / 8 + 1e-3) << x;
  }
  EXPECT_NEAR(downsample_sigma(0.5), 0.6 * std::sqrt(3.0), 1e-12);
}

TEST(Pyramid, ConstantImageStaysConstantIncludingBorders) {
  const cv::Mat1f image(37, 23, 4.25f);
  for (const cv::Mat1f& level : build_pyramid(image, {0.8, 4, 0})) {
    double lo, hi;
    cv::minMaxLoc(level, &lo, &hi);
    EXPECT_NEAR(lo, 4.25, 1e-5);
    EXPECT_NEAR(hi, 4.25, 1e-5);
  }
}

TEST(Bilinear, ExactOnLinearRampsAndClampedOutside) {
  const cv::Size size(31, 17);
  const float a = 3.f, b = -2.f, c = 5.f;
  const cv::Mat1f image = ramp(size, a, b, c);
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> ux(0.f, 30.f), uy(0.f, 16.f);
  for (int i = 0; i < 1000; ++i) {
    const float x = ux(rng), y = uy(rng);
    ASSERT_NEAR(sample_bilinear(image, x, y), a * x + b * y + c, 1e-4f) << x << "," << y;
  }
  EXPECT_FLOAT_EQ(sample_bilinear(image, 4.f, 9.f), image(9, 4));  // integer positions hit pixels
  EXPECT_FLOAT_EQ(sample_bilinear(image, -5.f, 2.5f), a * 0 + b * 2.5f + c);
  EXPECT_FLOAT_EQ(sample_bilinear(image, 100.f, 100.f), image(16, 30));
  EXPECT_FLOAT_EQ(sample_bilinear(image, NAN, 3.f), image(3, 0));
  EXPECT_FLOAT_EQ(sample_bilinear(cv::Mat1f(1, 1, 2.f), 0.3f, 0.7f), 2.f);
}

TEST(Bilinear, ResizeMapsPixelCentres) {
  const cv::Mat1f image = ramp({40, 20}, 1.f, 2.f, 0.f);
  const cv::Mat1f up = resize_bilinear(image, {80, 40});
  // Upsampling by 2: x_src = (x + 0.5) / 2 - 0.5, inside the image except the outer half pixel.
  for (int y = 1; y < 39; ++y)
    for (int x = 1; x < 79; ++x)
      ASSERT_NEAR(up(y, x), ((x + 0.5) / 2 - 0.5) + 2 * ((y + 0.5) / 2 - 0.5), 1e-4);
  EXPECT_FLOAT_EQ(up(0, 0), image(0, 0));  // -0.25 clamps to the border
}

cv::Mat1f random_image(cv::Size size, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> value(0.f, 1.f);
  cv::Mat1f image(size);
  for (float& v : image) v = value(rng);
  return image;
}

TEST(Bilinear, ResizeEqualsSamplingEveryPixel) {
  const cv::Mat1f image = random_image({37, 23}, 3);
  for (const cv::Size size : {cv::Size(18, 11), cv::Size(80, 50), cv::Size(37, 5), cv::Size(1, 1)}) {
    const cv::Mat1f resized = resize_bilinear(image, size);
    const double sx = 37.0 / size.width, sy = 23.0 / size.height;
    for (int y = 0; y < size.height; ++y)
      for (int x = 0; x < size.width; ++x)
        ASSERT_EQ(resized(y, x), sample_bilinear(image, static_cast<float>((x + 0.5) * sx - 0.5),
                                                 static_cast<float>((y + 0.5) * sy - 0.5)))
            << size << " at " << x << "," << y;
  }
}

// The blur is the clamped-border convolution, summed tap by tap from the left, whatever the image's
// width against the kernel's (here one 3 pixels wide under a kernel 19 wide).
TEST(Blur, EqualsTheClampedConvolutionExactly) {
  for (const cv::Size size : {cv::Size(29, 13), cv::Size(3, 7)}) {
    const cv::Mat1f image = random_image(size, 5);
    const double sigma = 3.0;
    const int radius = 9;
    std::vector<float> kernel(2 * radius + 1);
    double sum = 0;
    for (int k = -radius; k <= radius; ++k) sum += std::exp(-0.5 * k * k / (sigma * sigma));
    for (int k = -radius; k <= radius; ++k)
      kernel[k + radius] = static_cast<float>(std::exp(-0.5 * k * k / (sigma * sigma)) / sum);
    cv::Mat1f horizontal(size), expected(size, 0.f);
    for (int y = 0; y < size.height; ++y)
      for (int x = 0; x < size.width; ++x) {
        float s = 0;
        for (int k = -radius; k <= radius; ++k)
          s += kernel[k + radius] * image(y, std::clamp(x + k, 0, size.width - 1));
        horizontal(y, x) = s;
      }
    for (int y = 0; y < size.height; ++y)
      for (int k = -radius; k <= radius; ++k)
        for (int x = 0; x < size.width; ++x)
          expected(y, x) += kernel[k + radius] * horizontal(std::clamp(y + k, 0, size.height - 1), x);
    const cv::Mat1f blurred = gaussian_blur(image, sigma);
    for (int y = 0; y < size.height; ++y)
      for (int x = 0; x < size.width; ++x)
        ASSERT_EQ(blurred(y, x), expected(y, x)) << size << " at " << x << "," << y;
  }
}

TEST(Blur, PreservesRampsInsideAndSumOfAnImpulse) {
  const cv::Mat1f image = ramp({50, 40}, 0.5f, 0.25f, 1.f);
  const cv::Mat1f blurred = gaussian_blur(image, 1.5);
  for (int y = 5; y < 35; ++y)
    for (int x = 5; x < 45; ++x) ASSERT_NEAR(blurred(y, x), image(y, x), 1e-4);
  cv::Mat1f impulse(41, 41, 0.f);
  impulse(20, 20) = 1.f;
  const cv::Mat1f spread = gaussian_blur(impulse, 2.0);
  EXPECT_NEAR(cv::sum(spread)[0], 1.0, 1e-5);
  // Separable kernel: the centre weight is g(0)^2 with g(0) = 1 / sum_k exp(-k^2 / 8), k in [-6, 6].
  double norm = 0;
  for (int k = -6; k <= 6; ++k) norm += std::exp(-k * k / 8.0);
  EXPECT_NEAR(spread(20, 20), 1.0 / (norm * norm), 1e-6);
  EXPECT_NEAR(spread(20, 22), std::exp(-4 / 8.0) / (norm * norm), 1e-6);
}

}  // namespace
}  // namespace pg

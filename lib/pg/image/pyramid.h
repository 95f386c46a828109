#pragma once
// Gaussian image pyramids of single-channel float images, with any scale factor in [0.5, 1) between
// levels (coarse-to-fine variational flow uses about 0.8, classic pyramids 0.5), and bilinear
// sampling with the pixel-centre convention: pixel (0, 0) is the centre of the top-left pixel.
// Work is data-parallel over rows (TBB); results do not depend on the thread count.
#include <opencv2/core.hpp>
#include <vector>

namespace pg {

// Bilinear interpolation at (x, y) in pixel coordinates; coordinates outside [0, cols-1] x [0, rows-1]
// are clamped to the border, so the result is always a value of the image's convex hull.
// Exact on images that are linear in x and y. Image must be non-empty.
float sample_bilinear(const cv::Mat1f& image, float x, float y);

// Resamples to `size` by bilinear interpolation, mapping pixel centres: source coordinate
// x_src = (x + 0.5) * cols / size.width - 0.5 (same for y). No smoothing: for upsampling flow fields
// and depth, or after gaussian_blur when shrinking.
cv::Mat1f resize_bilinear(const cv::Mat1f& image, cv::Size size);

// Separable Gaussian blur, kernel radius ceil(3 sigma), borders replicated. sigma <= 0 copies.
cv::Mat1f gaussian_blur(const cv::Mat1f& image, double sigma);

// Anti-alias smoothing applied before shrinking by `factor`: sigma = 0.6 * sqrt(1 / factor^2 - 1)
// (as in Sanchez, Monzon, Salgado, IPOL 2013 for Brox-style flow); 1.04 for factor 0.5.
double downsample_sigma(double factor);

// One level down: gaussian_blur(downsample_sigma(factor)) then resize_bilinear to
// round(cols * factor) x round(rows * factor) (at least 1 x 1). factor in [0.5, 1).
cv::Mat1f downsample(const cv::Mat1f& image, double factor);

struct PyramidOptions {
  double factor = 0.5;  // size ratio between consecutive levels, in [0.5, 1)
  int min_side = 16;    // stop before a level whose shorter side would be below this
  int max_levels = 0;   // including level 0; 0 = as many as min_side allows
};

// Level sizes: level 0 is `size`, level k+1 is round(level k * factor) per axis. Throws UsageError for
// a factor outside [0.5, 1) or min_side < 1.
std::vector<cv::Size> pyramid_sizes(cv::Size size, const PyramidOptions& options);

// Level 0 is (a copy of) the image, then each level is downsample() of the previous one.
std::vector<cv::Mat1f> build_pyramid(const cv::Mat1f& image, const PyramidOptions& options = {});

}  // namespace pg

#include "pg/image/pyramid.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "pg/core/error.h"
#include "pg/core/log.h"

namespace pg {
namespace {

void check_factor(double factor) {
  if (!(factor >= 0.5 && factor < 1.0))
    throw UsageError(str("pyramid factor ", factor, " is not in [0.5, 1)"));
}

cv::Size scaled_size(cv::Size size, double factor) {
  return {std::max(1, static_cast<int>(std::lround(size.width * factor))),
          std::max(1, static_cast<int>(std::lround(size.height * factor)))};
}

std::vector<float> gaussian_kernel(double sigma) {
  const int radius = static_cast<int>(std::ceil(3.0 * sigma));
  std::vector<float> kernel(2 * radius + 1);
  double sum = 0;
  for (int k = -radius; k <= radius; ++k) sum += std::exp(-0.5 * k * k / (sigma * sigma));
  for (int k = -radius; k <= radius; ++k)
    kernel[k + radius] = static_cast<float>(std::exp(-0.5 * k * k / (sigma * sigma)) / sum);
  return kernel;
}

template <class RowBody>
void for_each_row(int rows, const RowBody& body) {
  tbb::parallel_for(tbb::blocked_range<int>(0, rows), [&](const tbb::blocked_range<int>& range) {
    for (int y = range.begin(); y != range.end(); ++y) body(y);
  });
}

void check_not_empty(const cv::Mat1f& image, const char* what) {
  if (image.empty()) throw UsageError(str(what, ": empty image"));
}

}  // namespace

float sample_bilinear(const cv::Mat1f& image, float x, float y) {
  const float max_x = static_cast<float>(image.cols - 1), max_y = static_cast<float>(image.rows - 1);
  x = x > 0 ? std::min(x, max_x) : 0.f;  // also maps NaN to the border
  y = y > 0 ? std::min(y, max_y) : 0.f;
  const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
  const int x1 = std::min(x0 + 1, image.cols - 1), y1 = std::min(y0 + 1, image.rows - 1);
  const float ax = x - static_cast<float>(x0), ay = y - static_cast<float>(y0);
  const float* row0 = image[y0];
  const float* row1 = image[y1];
  const float top = row0[x0] + ax * (row0[x1] - row0[x0]);
  const float bottom = row1[x0] + ax * (row1[x1] - row1[x0]);
  return top + ay * (bottom - top);
}

cv::Mat1f resize_bilinear(const cv::Mat1f& image, cv::Size size) {
  check_not_empty(image, "resize_bilinear");
  if (size.width <= 0 || size.height <= 0) throw UsageError("resize_bilinear: empty target size");
  // Where each output column samples, once for every row: sample_bilinear's arithmetic, so the
  // result is the same as sampling pixel by pixel.
  struct Tap {
    int x0, x1;
    float ax;
  };
  const double scale_x = static_cast<double>(image.cols) / size.width;
  const double scale_y = static_cast<double>(image.rows) / size.height;
  const float max_x = static_cast<float>(image.cols - 1), max_y = static_cast<float>(image.rows - 1);
  std::vector<Tap> taps(size.width);
  for (int x = 0; x < size.width; ++x) {
    float source_x = static_cast<float>((x + 0.5) * scale_x - 0.5);
    source_x = source_x > 0 ? std::min(source_x, max_x) : 0.f;
    const int x0 = static_cast<int>(source_x);
    taps[x] = {x0, std::min(x0 + 1, image.cols - 1), source_x - static_cast<float>(x0)};
  }
  cv::Mat1f out(size);
  for_each_row(size.height, [&](int y) {
    float source_y = static_cast<float>((y + 0.5) * scale_y - 0.5);
    source_y = source_y > 0 ? std::min(source_y, max_y) : 0.f;
    const int y0 = static_cast<int>(source_y);
    const float ay = source_y - static_cast<float>(y0);
    const float* row0 = image[y0];
    const float* row1 = image[std::min(y0 + 1, image.rows - 1)];
    float* row = out[y];
    for (int x = 0; x < size.width; ++x) {
      const Tap& t = taps[x];
      const float top = row0[t.x0] + t.ax * (row0[t.x1] - row0[t.x0]);
      const float bottom = row1[t.x0] + t.ax * (row1[t.x1] - row1[t.x0]);
      row[x] = top + ay * (bottom - top);
    }
  });
  return out;
}

cv::Mat1f gaussian_blur(const cv::Mat1f& image, double sigma) {
  check_not_empty(image, "gaussian_blur");
  if (sigma <= 0) return image.clone();
  const std::vector<float> kernel = gaussian_kernel(sigma);
  const int radius = static_cast<int>(kernel.size() / 2);
  const int cols = image.cols, rows = image.rows;
  cv::Mat1f horizontal(image.size()), out(image.size());
  // Horizontal pass on a copy of the row padded with its border values, so the inner loop runs over
  // contiguous memory without clamping (and vectorises); the same sums in the same order.
  tbb::parallel_for(tbb::blocked_range<int>(0, rows), [&](const tbb::blocked_range<int>& range) {
    std::vector<float> padded(cols + 2 * radius);
    for (int y = range.begin(); y != range.end(); ++y) {
      const float* in = image[y];
      std::fill(padded.begin(), padded.begin() + radius, in[0]);
      std::copy(in, in + cols, padded.begin() + radius);
      std::fill(padded.begin() + radius + cols, padded.end(), in[cols - 1]);
      float* row = horizontal[y];
      std::fill(row, row + cols, 0.f);
      for (int k = 0; k <= 2 * radius; ++k) {
        const float weight = kernel[k];
        const float* shifted = padded.data() + k;
        for (int x = 0; x < cols; ++x) row[x] += weight * shifted[x];
      }
    }
  });
  for_each_row(rows, [&](int y) {
    float* row = out[y];
    std::fill(row, row + cols, 0.f);
    for (int k = -radius; k <= radius; ++k) {
      const float* in = horizontal[std::clamp(y + k, 0, rows - 1)];
      const float weight = kernel[k + radius];
      for (int x = 0; x < cols; ++x) row[x] += weight * in[x];
    }
  });
  return out;
}

double downsample_sigma(double factor) {
  check_factor(factor);
  return 0.6 * std::sqrt(1.0 / (factor * factor) - 1.0);
}

cv::Mat1f downsample(const cv::Mat1f& image, double factor) {
  check_not_empty(image, "downsample");
  return resize_bilinear(gaussian_blur(image, downsample_sigma(factor)), scaled_size(image.size(), factor));
}

std::vector<cv::Size> pyramid_sizes(cv::Size size, const PyramidOptions& options) {
  check_factor(options.factor);
  if (options.min_side < 1) throw UsageError("pyramid min_side must be at least 1");
  if (options.max_levels < 0) throw UsageError("pyramid max_levels must not be negative");
  std::vector<cv::Size> sizes = {size};
  while (options.max_levels == 0 || static_cast<int>(sizes.size()) < options.max_levels) {
    const cv::Size next = scaled_size(sizes.back(), options.factor);
    // A factor near 1 can round a small side back to itself: stop rather than repeat a level.
    if (std::min(next.width, next.height) < options.min_side || next == sizes.back()) break;
    sizes.push_back(next);
  }
  return sizes;
}

std::vector<cv::Mat1f> build_pyramid(const cv::Mat1f& image, const PyramidOptions& options) {
  check_not_empty(image, "build_pyramid");
  const std::vector<cv::Size> sizes = pyramid_sizes(image.size(), options);
  const double sigma = downsample_sigma(options.factor);
  std::vector<cv::Mat1f> levels = {image.clone()};
  for (std::size_t k = 1; k < sizes.size(); ++k)
    levels.push_back(resize_bilinear(gaussian_blur(levels.back(), sigma), sizes[k]));
  return levels;
}

}  // namespace pg

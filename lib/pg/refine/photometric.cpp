#include "pg/refine/photometric.h"

#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "pg/core/error.h"

namespace pg {

PhotometricError photometric_error(const cv::Mat1f& synthetic, const cv::Mat1f& real, const cv::Mat1b& valid,
                                   int window) {
  if (synthetic.size() != real.size() || synthetic.size() != valid.size())
    throw UsageError("photometric_error: image sizes differ");
  PhotometricError result;
  cv::Mat1f mask;
  valid.convertTo(mask, CV_32F, 1.0 / 255.0);
  cv::Mat1f x = synthetic.mul(mask), y = real.mul(mask);
  double abs_sum = 0;
  for (int r = 0; r < valid.rows; ++r)
    for (int c = 0; c < valid.cols; ++c)
      if (valid(r, c)) {
        abs_sum += std::abs(synthetic(r, c) - real(r, c));
        ++result.pixels;
      }
  if (result.pixels == 0) {
    result.ncc_error = result.mean_abs_error = std::numeric_limits<double>::quiet_NaN();
    return result;
  }
  result.mean_abs_error = abs_sum / double(result.pixels);

  // Windowed sums over valid pixels only (box filters of masked products, not normalised).
  const cv::Size box(window, window);
  auto window_sum = [&](const cv::Mat1f& m) {
    cv::Mat1f out;
    cv::boxFilter(m, out, CV_32F, box, cv::Point(-1, -1), false, cv::BORDER_CONSTANT);
    return out;
  };
  const cv::Mat1f n = window_sum(mask), sx = window_sum(x), sy = window_sum(y);
  const cv::Mat1f sxx = window_sum(x.mul(x)), syy = window_sum(y.mul(y)), sxy = window_sum(x.mul(y));
  const float min_support = 0.5f * float(window * window);
  const double min_variance =
      1e-5;  // ~0.003 standard deviation on the [0, 1] scale: flat windows say nothing
  double ncc_sum = 0;
  std::size_t ncc_count = 0;
  for (int r = 0; r < valid.rows; ++r)
    for (int c = 0; c < valid.cols; ++c) {
      if (!valid(r, c) || n(r, c) < min_support) continue;
      const double count = n(r, c), mx = sx(r, c) / count, my = sy(r, c) / count;
      const double vx = sxx(r, c) / count - mx * mx, vy = syy(r, c) / count - my * my;
      if (vx < min_variance || vy < min_variance) continue;
      ncc_sum += std::clamp((sxy(r, c) / count - mx * my) / std::sqrt(vx * vy), -1.0, 1.0);
      ++ncc_count;
    }
  result.ncc_error = ncc_count ? 1.0 - ncc_sum / double(ncc_count) : std::numeric_limits<double>::quiet_NaN();
  return result;
}

cv::Mat1f error_image(const cv::Mat1f& synthetic, const cv::Mat1f& real, const cv::Mat1b& valid) {
  cv::Mat1f error(synthetic.size(), std::numeric_limits<float>::quiet_NaN());
  for (int r = 0; r < valid.rows; ++r)
    for (int c = 0; c < valid.cols; ++c)
      if (valid(r, c)) error(r, c) = std::abs(synthetic(r, c) - real(r, c));
  return error;
}

cv::Mat error_visualisation(const cv::Mat1f& error, double full_scale) {
  cv::Mat1b level(error.size(), 0);
  for (int r = 0; r < error.rows; ++r)
    for (int c = 0; c < error.cols; ++c) {
      const float e = error(r, c);
      if (std::isfinite(e))
        level(r, c) = cv::saturate_cast<std::uint8_t>(16 + 239 * std::min(1.0, e / full_scale));
    }
  cv::Mat colour;
  cv::applyColorMap(level, colour, cv::COLORMAP_INFERNO);
  colour.setTo(cv::Scalar::all(0), level == 0);
  return colour;
}

}  // namespace pg

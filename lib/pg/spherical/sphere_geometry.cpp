#include "pg/spherical/sphere_geometry.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "pg/camera/camera.h"
#include "pg/core/error.h"

namespace pg {

Eigen::Matrix3d rectifying_rotation(const Eigen::Vector3d& baseline) {
  if (!baseline.allFinite() || baseline.norm() == 0)
    throw UsageError("rectifying_rotation: the baseline must be finite and non-zero");
  return Eigen::Quaterniond::FromTwoVectors(baseline, -Eigen::Vector3d::UnitY()).toRotationMatrix();
}

namespace {

// Bilinear sample at (u, v) of an equirectangular CV_32F image: columns wrap, and a row beyond a pole
// continues on the opposite meridian (half a turn away), as the sphere does.
void sample_equirect(const cv::Mat& image, double u, double v, float* out) {
  const int width = image.cols, height = image.rows, channels = image.channels();
  const int x0 = static_cast<int>(std::floor(u)), y0 = static_cast<int>(std::floor(v));
  const float fx = static_cast<float>(u - x0), fy = static_cast<float>(v - y0);
  for (int c = 0; c < channels; ++c) out[c] = 0;
  for (int dy = 0; dy < 2; ++dy) {
    for (int dx = 0; dx < 2; ++dx) {
      const float weight = (dx ? fx : 1 - fx) * (dy ? fy : 1 - fy);
      if (weight == 0) continue;
      int x = x0 + dx, y = y0 + dy;
      if (y < 0) y = -1 - y, x += width / 2;
      if (y >= height) y = 2 * height - 1 - y, x += width / 2;
      y = std::clamp(y, 0, height - 1);
      x = ((x % width) + width) % width;
      const float* pixel = image.ptr<float>(y) + static_cast<std::ptrdiff_t>(x) * channels;
      for (int c = 0; c < channels; ++c) out[c] += weight * pixel[c];
    }
  }
}

}  // namespace

cv::Mat rotate_equirect(const cv::Mat& source, const Eigen::Matrix3d& target_from_source, cv::Size size) {
  if (source.empty() || source.depth() != CV_32F)
    throw UsageError("rotate_equirect: the source must be a non-empty CV_32F image");
  cv::Mat target(size, source.type());
  const Eigen::Matrix3d source_from_target = target_from_source.transpose();
  tbb::parallel_for(tbb::blocked_range<int>(0, size.height), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y != rows.end(); ++y) {
      float* row = target.ptr<float>(y);
      for (int x = 0; x < size.width; ++x) {
        const Eigen::Vector3d ray =
            equirect_direction_from_pixel(size.width, size.height, Eigen::Vector2d(x, y));
        const Eigen::Vector2d pixel =
            equirect_pixel_from_direction(source.cols, source.rows, source_from_target * ray);
        sample_equirect(source, pixel.x(), pixel.y(),
                        row + static_cast<std::ptrdiff_t>(x) * source.channels());
      }
    }
  });
  return target;
}

double range_from_angular_disparity(double baseline, double theta, double gamma) {
  if (!(gamma > 0) || !(theta + gamma < std::numbers::pi)) return std::numeric_limits<double>::quiet_NaN();
  return baseline * std::sin(theta + gamma) / std::sin(gamma);
}

double angular_disparity_from_range(double baseline, double theta, double range) {
  // The point in the plane of the axis: (across, along) = range * (sin theta, cos theta); the second
  // centre sits at (0, baseline).
  const double across = range * std::sin(theta), along = range * std::cos(theta) - baseline;
  return std::atan2(across, along) - theta;
}

cv::Mat pad_longitude(const cv::Mat& image, int columns) {
  if (columns < 0 || columns > image.cols)
    throw UsageError("pad_longitude: padding must be in [0, image width]");
  cv::Mat padded;
  cv::copyMakeBorder(image, padded, 0, 0, columns, columns, cv::BORDER_WRAP);
  return padded;
}

}  // namespace pg

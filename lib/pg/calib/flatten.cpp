#include "pg/calib/flatten.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/core/parallel.h"

namespace pg::calib {
namespace {

// Normalised undistorted coordinates (x/z, y/z) of the source image's border, walked edge by edge.
struct Border {
  std::vector<Eigen::Vector2d> left, right, top, bottom;
};

Border undistorted_border(const Camera& camera) {
  const int samples = 64;
  const double w = camera.width - 1, h = camera.height - 1;
  Border border;
  const auto normalised = [&](double u, double v, std::vector<Eigen::Vector2d>& edge) {
    const Eigen::Vector3d ray = camera.unproject({u, v});
    // Rays at or beyond 90 degrees from the axis have no pinhole image: a fisheye's far field is cut.
    if (ray.z() > 0.1) edge.emplace_back(ray.x() / ray.z(), ray.y() / ray.z());
  };
  for (int i = 0; i <= samples; ++i) {
    const double t = double(i) / samples;
    normalised(0, t * h, border.left);
    normalised(w, t * h, border.right);
    normalised(t * w, 0, border.top);
    normalised(t * w, h, border.bottom);
  }
  if (border.left.empty() || border.right.empty() || border.top.empty() || border.bottom.empty())
    throw FailedError(
        str("camera '", camera.id, "' sees no part of its border in front of it; cannot flatten"));
  return border;
}

}  // namespace

FlattenMaps flatten_maps(const Camera& source, double alpha) {
  if (!(alpha >= 0 && alpha <= 1)) throw UsageError(str("--alpha ", alpha, " must be in [0, 1]"));
  if (!source.is_perspective())
    throw UsageError(str("camera '", source.id, "' is equirectangular; cannot flatten"));
  const Border b = undistorted_border(source);
  const auto min_x = [](const auto& e) {
    double m = 1e300;
    for (const auto& p : e) m = std::min(m, p.x());
    return m;
  };
  const auto max_x = [](const auto& e) {
    double m = -1e300;
    for (const auto& p : e) m = std::max(m, p.x());
    return m;
  };
  const auto min_y = [](const auto& e) {
    double m = 1e300;
    for (const auto& p : e) m = std::min(m, p.y());
    return m;
  };
  const auto max_y = [](const auto& e) {
    double m = -1e300;
    for (const auto& p : e) m = std::max(m, p.y());
    return m;
  };
  // Inner rectangle: inside every edge (only valid pixels); outer: around every edge (all pixels).
  const double inner[4] = {max_x(b.left), min_x(b.right), max_y(b.top), min_y(b.bottom)};
  std::vector<Eigen::Vector2d> all = b.left;
  for (const auto* e : {&b.right, &b.top, &b.bottom}) all.insert(all.end(), e->begin(), e->end());
  const double outer[4] = {min_x(all), max_x(all), min_y(all), max_y(all)};
  if (inner[1] <= inner[0] || inner[3] <= inner[2])
    throw FailedError(
        str("camera '", source.id, "': its distortion leaves no valid rectangle to flatten into"));

  const double span_u = source.width - 1, span_v = source.height - 1;
  // One focal length for both axes; the inner view must cover the image, the outer must fit in it.
  const double f_inner = std::max(span_u / (inner[1] - inner[0]), span_v / (inner[3] - inner[2]));
  const double f_outer = std::min(span_u / (outer[1] - outer[0]), span_v / (outer[3] - outer[2]));
  const double f = std::pow(f_inner, 1 - alpha) * std::pow(f_outer, alpha);
  const double centre_x = (1 - alpha) * 0.5 * (inner[0] + inner[1]) + alpha * 0.5 * (outer[0] + outer[1]);
  const double centre_y = (1 - alpha) * 0.5 * (inner[2] + inner[3]) + alpha * 0.5 * (outer[2] + outer[3]);

  FlattenMaps maps;
  maps.pinhole = source;
  maps.pinhole.model = CameraModel::pinhole;
  maps.pinhole.distortion = {};
  maps.pinhole.stddev.reset();
  maps.pinhole.intrinsics = {f, f, 0.5 * span_u - f * centre_x, 0.5 * span_v - f * centre_y};
  maps.source_x.create(source.height, source.width, CV_32FC1);
  maps.source_y.create(source.height, source.width, CV_32FC1);
  const Intrinsics& k = maps.pinhole.intrinsics;
  std::vector<std::int64_t> valid_rows(source.height, 0);
  parallel_chunks(source.height, 16, [&](std::int64_t begin, std::int64_t end) {
    for (std::int64_t v = begin; v < end; ++v) {
      float* sx = maps.source_x.ptr<float>(int(v));
      float* sy = maps.source_y.ptr<float>(int(v));
      for (int u = 0; u < source.width; ++u) {
        const Eigen::Vector3d ray((u - k.cx) / k.fx, (double(v) - k.cy) / k.fy, 1.0);
        Eigen::Vector2d pixel;
        if (source.project(ray, pixel) && source.in_image(pixel)) {
          sx[u] = float(pixel.x());
          sy[u] = float(pixel.y());
          ++valid_rows[v];
        } else {
          sx[u] = sy[u] = -1e6f;  // outside: remap's constant border
        }
      }
    }
  });
  std::int64_t valid = 0;
  for (std::int64_t n : valid_rows) valid += n;
  maps.valid_fraction = double(valid) / (double(source.width) * source.height);
  return maps;
}

cv::Mat flatten_image(const cv::Mat& image, const FlattenMaps& maps) {
  if (image.cols != maps.pinhole.width || image.rows != maps.pinhole.height)
    throw UsageError(str("image is ", image.cols, "x", image.rows, ", the camera ", maps.pinhole.width, "x",
                         maps.pinhole.height));
  cv::Mat out;
  cv::remap(image, out, maps.source_x, maps.source_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT,
            cv::Scalar::all(0));
  return out;
}

}  // namespace pg::calib

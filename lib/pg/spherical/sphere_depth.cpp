#include "pg/spherical/sphere_depth.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numbers>
#include <opencv2/imgproc.hpp>

#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/spherical/sphere_geometry.h"

namespace pg {

void SphereDepthOptions::check() const {
  flow.check();
  const auto require = [](bool ok, const char* field, double value, const char* rule) {
    if (!ok) throw UsageError(str("spherical depth option ", field, " = ", value, ": ", rule));
  };
  require(scale > 0 && scale <= 1, "scale", scale, "must be in (0, 1]");
  require(pole_band_deg >= 0 && pole_band_deg < 90, "pole_band_deg", pole_band_deg, "must be in [0, 90)");
  require(max_fb_error > 0, "max_fb_error", max_fb_error, "must be positive");
  require(seam_padding >= 0 && seam_padding <= 0.5, "seam_padding", seam_padding, "must be in [0, 0.5]");
  require(max_range >= 0, "max_range", max_range, "must not be negative");
}

double polar_angle_from_baseline(int width, int height, int x, int y, const Eigen::Vector3d& baseline) {
  const Eigen::Vector3d ray = equirect_direction_from_pixel(width, height, Eigen::Vector2d(x, y));
  return std::acos(std::clamp(ray.dot(baseline.normalized()), -1.0, 1.0));
}

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// Intensities for matching: 8-bit / 255 and 16-bit / 65535 as the flow engine scales them; float
// (HDR) data in a log domain, log(x + eps) with eps a hundredth of the median, mapped affinely so that
// the 1st and 99th percentiles land on 0 and 1. Nothing is clipped: highlights stay above 1. The same
// mapping (from the reference) is applied to both panoramas so their intensities stay comparable.
struct Intensity {
  bool log = false;
  double eps = 1, offset = 0, scale = 1;
};

Intensity intensity_mapping(const cv::Mat& reference) {
  if (reference.depth() != CV_32F && reference.depth() != CV_64F) return {};
  cv::Mat values;
  reference.reshape(1, 1).convertTo(values, CV_32F);
  std::vector<float> sample;
  const int step = std::max(1, values.cols / 200000);
  for (int i = 0; i < values.cols; i += step)
    if (std::isfinite(values.at<float>(i))) sample.push_back(std::max(values.at<float>(i), 0.0f));
  if (sample.empty()) return {};
  const auto quantile = [&](double q) {
    std::nth_element(sample.begin(), sample.begin() + static_cast<std::ptrdiff_t>(q * (sample.size() - 1)),
                     sample.end());
    return static_cast<double>(sample[static_cast<std::size_t>(q * (sample.size() - 1))]);
  };
  Intensity mapping;
  mapping.log = true;
  mapping.eps = std::max(0.01 * quantile(0.5), 1e-6);
  const double low = std::log(quantile(0.01) + mapping.eps), high = std::log(quantile(0.99) + mapping.eps);
  mapping.offset = -low;
  mapping.scale = high > low ? 1 / (high - low) : 1;
  return mapping;
}

cv::Mat to_matching_intensity(const cv::Mat& image, const Intensity& mapping) {
  cv::Mat out;
  const double scale = image.depth() == CV_8U ? 1.0 / 255 : image.depth() == CV_16U ? 1.0 / 65535 : 1.0;
  image.convertTo(out, CV_MAKETYPE(CV_32F, image.channels()), scale);
  if (!mapping.log) return out;
  out = cv::max(out, 0.0);
  cv::patchNaNs(out, 0.0);
  cv::log(out + mapping.eps, out);
  out = (out + mapping.offset) * mapping.scale;
  return out;
}

void check_pair(const SpherePair& pair) {
  if (pair.reference.empty() || pair.other.empty()) throw UsageError("spherical depth: empty panorama");
  if (pair.reference.size() != pair.other.size())
    throw UsageError(str("spherical depth: panoramas differ in size (", pair.reference.cols, "x",
                         pair.reference.rows, " and ", pair.other.cols, "x", pair.other.rows, ")"));
  if (pair.reference.channels() != pair.other.channels())
    throw UsageError("spherical depth: panoramas differ in channel count");
  const Camera& camera = pair.reference_camera;
  if (camera.model != CameraModel::equirectangular)
    throw UsageError("spherical depth: the reference camera must be equirectangular");
  if (camera.width != pair.reference.cols || camera.height != pair.reference.rows)
    throw UsageError("spherical depth: the reference camera's size differs from its panorama");
  if (!pair.baseline.allFinite() || pair.baseline.norm() == 0)
    throw UsageError(
        "spherical depth: the baseline is zero; the panoramas must be shot from different points");
  if (!pair.other_from_reference.allFinite() ||
      !(pair.other_from_reference * pair.other_from_reference.transpose()).isIdentity(1e-6))
    throw UsageError("spherical depth: other_from_reference is not a rotation");
}

// The rectified panoramas: `reference` and `other` at `size`, both with the baseline at the north pole.
struct Rectified {
  cv::Mat reference, other;
};

Rectified rectify(const SpherePair& pair, const Eigen::Matrix3d& rect_from_reference, cv::Size size) {
  const Intensity mapping = intensity_mapping(pair.reference);
  const auto prepare = [&](const cv::Mat& image, const Eigen::Matrix3d& rect_from_camera) {
    cv::Mat image_float = to_matching_intensity(image, mapping);
    if (image_float.size() != size) cv::resize(image_float, image_float, size, 0, 0, cv::INTER_AREA);
    // No resampling when the rotation is the identity (a vertical rig): the pixels stay exact.
    if (rect_from_camera.isIdentity(1e-12)) return image_float;
    return rotate_equirect(image_float, rect_from_camera, size);
  };
  return {prepare(pair.reference, rect_from_reference),
          prepare(pair.other, rect_from_reference * pair.other_from_reference.transpose())};
}

// Disparity along the meridians in rectified pixels (downwards, away from the north pole), the
// forward-backward error, and the pixels whose disparity is their meridian's background instead
// (nonzero; with fill_occlusions only); all cropped back to the rectified size.
struct MeridianFlow {
  cv::Mat1f along, fb_error;
  cv::Mat1b filled;
};

MeridianFlow solve_meridian_flow(const Rectified& rect, const SphereDepthOptions& options,
                                 const FlowOptions& flow, int padding) {
  const cv::Mat reference = pad_longitude(rect.reference, padding);
  const cv::Mat other = pad_longitude(rect.other, padding);
  const auto meridian_field = [&](float direction) {
    EpipolarField field;
    field.base = cv::Mat2f(reference.size(), cv::Vec2f(0, 0));
    field.direction = cv::Mat2f(reference.size(), cv::Vec2f(0, direction));
    return field;
  };
  // Seen from the other centre (further towards the north pole) a point lies further south.
  const EpipolarFlow forward = compute_epipolar_flow(reference, other, meridian_field(1.0f), flow);
  const EpipolarFlow backward = compute_epipolar_flow(other, reference, meridian_field(-1.0f), flow);
  const cv::Rect crop(padding, 0, rect.reference.cols, rect.reference.rows);
  MeridianFlow result;
  result.fb_error = forward_backward_error(forward.flow, backward.flow);
  result.filled = cv::Mat1b(reference.size(), uchar(0));
  cv::Mat1f along = forward.along;
  if (options.fill_occlusions) {
    cv::Mat1b occluded = occlusion_mask(result.fb_error, forward.flow, options.max_fb_error, 0);
    const int band = static_cast<int>(std::lround(options.pole_band_deg / 180 * reference.rows));
    occluded.rowRange(0, band).setTo(255);
    occluded.rowRange(reference.rows - band, reference.rows).setTo(255);
    const cv::Mat2f filled = fill_occlusions_along_lines(forward.flow, occluded, meridian_field(1.0f));
    along = cv::Mat1f(reference.size());
    for (int y = 0; y < reference.rows; ++y)
      for (int x = 0; x < reference.cols; ++x) {
        along(y, x) = filled(y, x)[1];  // the field's base is 0 and its direction (0, 1)
        // Pixels that found no background keep their flow, and their failed check.
        result.filled(y, x) = occluded(y, x) && filled(y, x) != forward.flow(y, x) ? 255 : 0;
      }
  }
  result.along = along(crop).clone();
  result.fb_error = result.fb_error(crop).clone();
  result.filled = result.filled(crop).clone();
  return result;
}

// Bilinear sample of a rectified CV_32FC1 map with wrapped columns; NaN if any weighted neighbour is.
float sample_wrapped(const cv::Mat1f& map, const Eigen::Vector2d& pixel) {
  const int x0 = static_cast<int>(std::floor(pixel.x())), y0 = static_cast<int>(std::floor(pixel.y()));
  const double fx = pixel.x() - x0, fy = pixel.y() - y0;
  double sum = 0;
  for (int dy = 0; dy < 2; ++dy) {
    for (int dx = 0; dx < 2; ++dx) {
      const double weight = (dx ? fx : 1 - fx) * (dy ? fy : 1 - fy);
      if (weight <= 1e-9) continue;
      const int y = std::clamp(y0 + dy, 0, map.rows - 1);
      const int x = (((x0 + dx) % map.cols) + map.cols) % map.cols;
      sum += weight * map(y, x);
    }
  }
  return static_cast<float>(sum);
}

}  // namespace

SphereDepthResult compute_sphere_depth(const SpherePair& pair, const SphereDepthOptions& options) {
  options.check();
  check_pair(pair);
  const cv::Size size(std::max(4, static_cast<int>(std::lround(pair.reference.cols * options.scale))),
                      std::max(2, static_cast<int>(std::lround(pair.reference.rows * options.scale))));
  const Eigen::Matrix3d rect_from_reference = rectifying_rotation(pair.baseline);
  FlowOptions flow = options.flow;
  flow.hdr_log = false;  // float input is already in the log domain (to_matching_intensity)

  const Clock::time_point flow_start = Clock::now();
  const Rectified rect = rectify(pair, rect_from_reference, size);
  const int padding = static_cast<int>(std::lround(options.seam_padding * size.width));
  const MeridianFlow meridian = solve_meridian_flow(rect, options, flow, padding);
  SphereDepthResult result;
  result.flow_seconds = seconds_since(flow_start);

  const Clock::time_point triangulation_start = Clock::now();
  const double baseline = pair.baseline.norm();
  const double radians_per_pixel = std::numbers::pi / size.height;
  const double pole_band = options.pole_band_deg * std::numbers::pi / 180;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  DepthMap& map = result.map;
  map.kind = DepthKind::spherical_range;
  map.camera = pair.reference_camera;
  map.camera.width = size.width;
  map.camera.height = size.height;
  cv::Mat1f depth(size, nan), confidence(size, 0.0f);
  result.disparity = cv::Mat1f(size, nan);
  // `filled`: valid with its meridian's background disparity.
  enum Outcome : std::uint8_t { valid, filled, pole, inconsistent, untriangulated, too_far };
  cv::Mat1b outcome(size);
  tbb::parallel_for(tbb::blocked_range<int>(0, size.height), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y != rows.end(); ++y) {
      for (int x = 0; x < size.width; ++x) {
        const Eigen::Vector3d ray = rect_from_reference * equirect_direction_from_pixel(
                                                              size.width, size.height, Eigen::Vector2d(x, y));
        const double theta = std::acos(std::clamp(-ray.y(), -1.0, 1.0));  // from the north pole (-y)
        const Eigen::Vector2d rect_pixel = equirect_pixel_from_direction(size.width, size.height, ray);
        const double gamma = sample_wrapped(meridian.along, rect_pixel) * radians_per_pixel;
        const double fb_error = sample_wrapped(meridian.fb_error, rect_pixel);
        // Nearest rectified pixel: a filled disparity replaces the check.
        const int rx = (static_cast<int>(std::lround(rect_pixel.x())) % size.width + size.width) % size.width;
        const int ry = std::clamp(static_cast<int>(std::lround(rect_pixel.y())), 0, size.height - 1);
        const bool background = meridian.filled(ry, rx) != 0;
        const double range = range_from_angular_disparity(baseline, theta, gamma);
        result.disparity(y, x) = static_cast<float>(gamma);
        Outcome o = valid;
        if (theta < pole_band || theta > std::numbers::pi - pole_band)
          o = pole;
        else if (!std::isfinite(range))
          o = untriangulated;
        else if (!background && !(fb_error <= options.max_fb_error))
          o = inconsistent;
        else if (options.max_range > 0 && range > options.max_range)
          o = too_far;
        else if (background)
          o = filled;
        outcome(y, x) = o;
        if (o == valid || o == filled) {
          depth(y, x) = static_cast<float>(range);
          const double consistency = o == filled ? 0.5 : 1 - fb_error / options.max_fb_error;
          confidence(y, x) = static_cast<float>(std::sin(theta) * consistency);
        } else if (options.keep_all && std::isfinite(range)) {
          depth(y, x) = static_cast<float>(range);
        }
      }
    }
  });
  map.depth = depth;
  map.confidence = confidence;
  for (int y = 0; y < size.height; ++y) {
    for (int x = 0; x < size.width; ++x) {
      switch (outcome(y, x)) {
        case valid:
          ++result.valid;
          break;
        case filled:
          ++result.valid, ++result.filled;
          break;
        case pole:
          ++result.pole_band;
          break;
        case inconsistent:
          ++result.inconsistent;
          break;
        case untriangulated:
          ++result.untriangulated;
          break;
        case too_far:
          ++result.too_far;
          break;
      }
    }
  }
  result.triangulation_seconds = seconds_since(triangulation_start);
  return result;
}

}  // namespace pg

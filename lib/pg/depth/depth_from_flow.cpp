#include "pg/depth/depth_from_flow.h"

#include <opencv2/imgproc.hpp>

#include "pg/image/image_io.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/depth/depth_geometry.h"
#include "pg/geometry/triangulation.h"

namespace pg {
namespace {

// Per-pixel outcome codes, in the order the checks run (first failing reason wins).
enum Outcome : std::uint8_t {
  kept,
  masked,
  untriangulated,
  inconsistent,
  small_angle,
  epipolar,
  grazing,
  discontinuity,
  textureless
};

double radians(double degrees) {
  return degrees * std::numbers::pi / 180.0;
}

}  // namespace

void DepthFilterOptions::check() const {
  const auto require = [](bool ok, const char* field, double value, const char* rule) {
    if (!ok) throw UsageError(str("depth filter ", field, " = ", value, ": ", rule));
  };
  require(min_triangulation_angle_deg >= 0 && min_triangulation_angle_deg < 90, "min_triangulation_angle_deg",
          min_triangulation_angle_deg, "must be in [0, 90)");
  require(max_fb_error > 0, "max_fb_error", max_fb_error, "must be positive");
  require(max_epipolar_residual > 0, "max_epipolar_residual", max_epipolar_residual, "must be positive");
  require(max_grazing_angle_deg > 0 && max_grazing_angle_deg <= 90, "max_grazing_angle_deg",
          max_grazing_angle_deg, "must be in (0, 90]");
  require(max_depth_jump > 0, "max_depth_jump", max_depth_jump, "must be positive");
  require(min_texture >= 0, "min_texture", min_texture, "must not be negative");
}

double DepthFromFlowResult::valid_fraction() const {
  const double total = static_cast<double>(map.depth.total());
  return total > 0 ? static_cast<double>(valid) / total : 0.0;
}

cv::Mat1f local_texture(const cv::Mat& image) {
  const cv::Mat1f g = to_float_gray(image);
  cv::Mat1f gx, gy;
  cv::Sobel(g, gx, CV_32F, 1, 0, 3, 1.0 / 8);  // per-pixel derivative
  cv::Sobel(g, gy, CV_32F, 0, 1, 3, 1.0 / 8);
  cv::Mat1f energy = gx.mul(gx) + gy.mul(gy);
  cv::boxFilter(energy, energy, CV_32F, cv::Size(7, 7));
  cv::sqrt(energy, energy);
  return energy;
}

DepthFromFlowResult depth_from_flow(const DepthFromFlowInput& input, const DepthFilterOptions& options) {
  options.check();
  if (!input.reference || !input.other) throw UsageError("depth_from_flow: both cameras are required");
  const Camera& ref = *input.reference;
  const Camera& other = *input.other;
  const cv::Size size(ref.width, ref.height);
  if (input.flow.size() != size)
    throw UsageError(str("depth_from_flow: flow is ", input.flow.cols, "x", input.flow.rows, ", camera '",
                         ref.id, "' is ", ref.width, "x", ref.height));
  if (!input.fb_error.empty() && input.fb_error.size() != size)
    throw UsageError("depth_from_flow: forward-backward error size differs from the flow");
  if (!input.filled.empty() && input.filled.size() != size)
    throw UsageError("depth_from_flow: filled-pixel mask size differs from the flow");
  if (!input.reference_mask.empty() && input.reference_mask.size() != size)
    throw UsageError("depth_from_flow: reference mask size differs from the camera");
  if (!input.other_mask.empty() && input.other_mask.size() != cv::Size(other.width, other.height))
    throw UsageError("depth_from_flow: other mask size differs from its camera");
  if (!input.texture.empty() && input.texture.size() != size)
    throw UsageError("depth_from_flow: texture size differs from the camera");
  const Eigen::Vector3d centre_ref = ref.cam_from_world.centre(),
                        centre_other = other.cam_from_world.centre();
  if ((centre_ref - centre_other).norm() <= 1e-12 * std::max(1.0, centre_ref.norm()))
    throw UsageError("cameras '" + ref.id + "' and '" + other.id +
                     "' share their centre: no baseline to triangulate");

  const DepthKind kind = ref.is_perspective() ? DepthKind::perspective_z : DepthKind::spherical_range;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const Eigen::Matrix3d ref_to_world = ref.cam_from_world.rotation_matrix().transpose();
  const Eigen::Matrix3d other_to_world = other.cam_from_world.rotation_matrix().transpose();
  cv::Mat1f depth(size, nan), angle(size, 0.f), residual(size, nan);
  // Textureless pixels are triangulated like the others (so that --keep-all keeps their depth and a
  // pixel masked in the other view counts as masked) but set aside: their depth, only interpolated
  // by the flow's smoothness, takes no part in the normals or the discontinuity cuts.
  cv::Mat1f flat_depth(size, nan);
  cv::Mat1b outcome(size, static_cast<std::uint8_t>(kept));

  // 1. Triangulate every pixel with its flow.
  tbb::parallel_for(tbb::blocked_range<int>(0, size.height), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y != rows.end(); ++y)
      for (int x = 0; x < size.width; ++x) {
        const cv::Vec2f f = input.flow(y, x);
        const Eigen::Vector2d pixel(x, y), target(x + f[0], y + f[1]);
        if (!input.reference_mask.empty() && input.reference_mask(y, x) != 0) {
          outcome(y, x) = masked;
          continue;
        }
        if (!target.allFinite() || !other.in_image(target)) {
          outcome(y, x) = untriangulated;
          continue;
        }
        // The nearest pixel; in_image lets a target reach half a pixel past the edge centres.
        const auto nearest = [](double v, int size) {
          return std::clamp(static_cast<int>(std::floor(v + 0.5)), 0, size - 1);
        };
        if (!input.other_mask.empty() && input.other_mask(nearest(target.y(), input.other_mask.rows),
                                                          nearest(target.x(), input.other_mask.cols)) != 0) {
          outcome(y, x) = masked;
          continue;
        }
        const std::optional<Eigen::Vector3d> point =
            triangulate_midpoint(centre_ref, ref_to_world * ref.unproject(pixel), centre_other,
                                 other_to_world * other.unproject(target));
        if (!point) {
          outcome(y, x) = untriangulated;
          continue;
        }
        const Eigen::Vector3d point_ref = ref.cam_from_world * *point;
        Eigen::Vector2d back_ref, back_other;
        if (!ref.project(point_ref, back_ref) || !other.project_world(*point, back_other)) {
          outcome(y, x) = untriangulated;
          continue;
        }
        const bool flat = !input.texture.empty() && input.texture(y, x) < options.min_texture;
        (flat ? flat_depth : depth)(y, x) = static_cast<float>(depth_of_point(kind, point_ref));
        angle(y, x) = static_cast<float>(triangulation_angle(centre_ref, centre_other, *point));
        residual(y, x) =
            static_cast<float>(std::max((back_ref - pixel).norm(), (back_other - target).norm()));
      }
  });

  // 2. Normals from the raw depth, then the per-pixel checks.
  cv::Mat3f normals = normals_from_depth(depth, ref, kind);
  const double min_angle = radians(options.min_triangulation_angle_deg);
  const double cos_grazing = std::cos(radians(options.max_grazing_angle_deg));
  cv::Mat1f confidence(size, 0.f);
  tbb::parallel_for(tbb::blocked_range<int>(0, size.height), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y != rows.end(); ++y)
      for (int x = 0; x < size.width; ++x) {
        if (outcome(y, x) != kept) continue;
        const cv::Vec2f f = input.flow(y, x);
        const bool filled = !input.filled.empty() && input.filled(y, x) != 0;
        const float fb = input.fb_error.empty() || filled ? 0.f : input.fb_error(y, x);
        const double fb_limit = options.max_fb_error + fb_error_per_flow * std::hypot(f[0], f[1]);
        const cv::Vec3f n = normals(y, x);
        const Eigen::Vector3d ray = ref.unproject(Eigen::Vector2d(x, y));
        // Facing: cosine between the normal and the direction back to the camera (the pixel's ray).
        const double facing = std::isfinite(n[0]) ? -(n[0] * ray.x() + n[1] * ray.y() + n[2] * ray.z()) : 1.0;
        Outcome o = kept;
        if (!(fb <= fb_limit))
          o = inconsistent;  // NaN: the backward flow could not be sampled
        else if (angle(y, x) < min_angle)
          o = small_angle;
        else if (residual(y, x) > options.max_epipolar_residual)
          o = epipolar;
        else if (facing < cos_grazing)
          o = grazing;
        else if (std::isfinite(flat_depth(y, x)))
          o = textureless;
        outcome(y, x) = o;
        if (o == kept) {
          const double fb_term = filled ? 0.0 : 1.0 - std::min(1.0, fb / fb_limit);
          const double angle_term = std::min(1.0, angle(y, x) / (3.0 * std::max(min_angle, 1e-6)));
          confidence(y, x) = static_cast<float>((0.5 + 0.5 * fb_term) * angle_term * facing);
        }
      }
  });

  // 3. Discontinuities: smoothness blurs the flow across depth edges, so both sides of a large
  // relative step between 4-neighbours are cut.
  cv::Mat1b cut(size, std::uint8_t{0});
  const float jump = static_cast<float>(options.max_depth_jump);
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x) {
      const float d = depth(y, x);
      if (!std::isfinite(d)) continue;
      for (const auto& [dx, dy] : {std::pair{1, 0}, std::pair{0, 1}}) {
        if (x + dx >= size.width || y + dy >= size.height) continue;
        const float e = depth(y + dy, x + dx);
        if (std::isfinite(e) && std::abs(d - e) > jump * std::min(d, e)) cut(y, x) = cut(y + dy, x + dx) = 1;
      }
    }

  DepthFromFlowResult result;
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x) {
      if (outcome(y, x) == kept && cut(y, x)) outcome(y, x) = discontinuity;
      switch (outcome(y, x)) {
        case kept:
          ++result.valid;
          break;
        case masked:
          ++result.rejections.masked;
          break;
        case untriangulated:
          ++result.rejections.untriangulated;
          break;
        case inconsistent:
          ++result.rejections.inconsistent;
          break;
        case small_angle:
          ++result.rejections.small_angle;
          break;
        case epipolar:
          ++result.rejections.epipolar;
          break;
        case grazing:
          ++result.rejections.grazing;
          break;
        case discontinuity:
          ++result.rejections.discontinuity;
          break;
        case textureless:
          ++result.rejections.textureless;
          break;
      }
      if (outcome(y, x) != kept) {
        confidence(y, x) = 0.f;
        if (!options.keep_all || outcome(y, x) == masked)
          depth(y, x) = nan;
        else if (std::isfinite(flat_depth(y, x)))
          depth(y, x) = flat_depth(y, x);
      }
    }

  DepthMap& map = result.map;
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x)
      if (!std::isfinite(depth(y, x))) normals(y, x) = cv::Vec3f(nan, nan, nan);
  map.depth = depth;
  map.confidence = confidence;
  map.normals = normals;
  if (!input.reference_mask.empty()) {
    cv::Mat1b mask;
    cv::compare(input.reference_mask, 0, mask, cv::CMP_NE);  // 255 where excluded
    map.mask = mask;
  }
  map.kind = kind;
  map.camera = ref;
  return result;
}

}  // namespace pg

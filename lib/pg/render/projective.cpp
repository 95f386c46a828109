#include "pg/render/projective.h"

#include <algorithm>
#include <cmath>
#include <optional>

#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/core/parallel.h"

namespace pg {
namespace {

// Bilinear sample of a float image at pixel (x, y); columns wrap when `wrap`, else clamp at the border.
void sample_bilinear(const cv::Mat& image, double x, double y, bool wrap, float* out) {
  const int cn = image.channels(), w = image.cols, h = image.rows;
  const double fx = std::floor(x), fy = std::floor(y);
  const float ax = float(x - fx), ay = float(y - fy);
  auto column = [&](int c) { return wrap ? ((c % w) + w) % w : std::clamp(c, 0, w - 1); };
  const int x0 = column(int(fx)), x1 = column(int(fx) + 1);
  const float* r0 = image.ptr<float>(std::clamp(int(fy), 0, h - 1));
  const float* r1 = image.ptr<float>(std::clamp(int(fy) + 1, 0, h - 1));
  for (int c = 0; c < cn; ++c) {
    const float top = r0[x0 * cn + c] * (1 - ax) + r0[x1 * cn + c] * ax;
    const float bottom = r1[x0 * cn + c] * (1 - ax) + r1[x1 * cn + c] * ax;
    out[c] = top * (1 - ay) + bottom * ay;
  }
}

}  // namespace

ProjectedImage render_projected(const Mesh& mesh, const Camera& source, const cv::Mat& source_image,
                                const cv::Mat& source_depth, const Camera& target,
                                const ProjectionOptions& options, const RayTable* target_rays) {
  const cv::Size source_size(source.width, source.height);
  if (source_image.size() != source_size || source_image.channels() < 1 || source_image.channels() > 4)
    throw UsageError(str("render_projected: the source image must be ", source.width, "x", source.height,
                         " with 1 to 4 channels"));
  if (source_depth.size() != source_size || source_depth.type() != CV_32F)
    throw UsageError("render_projected: the source depth must be CV_32F and the size of the source camera");
  cv::Mat image;
  source_image.convertTo(image, CV_32F);

  std::optional<RayTable> own_rays;
  if (!target_rays || !target_rays->matches(target)) target_rays = &own_rays.emplace(target);
  ProjectedImage out;
  RenderOptions render_options = options.target;
  render_options.shading = Shading::none;
  Renderer().render(mesh, target, *target_rays, render_options, out.target);

  const int cn = image.channels();
  const bool wrap = source.model == CameraModel::equirectangular;
  const DepthMeasure kind = resolve_depth_measure(options.source_depth_kind, source);
  out.image = cv::Mat::zeros(target.height, target.width, CV_MAKETYPE(CV_32F, cn));
  out.valid = cv::Mat::zeros(target.height, target.width, CV_8U);
  out.source_pixel.create(target.height, target.width, CV_32FC2);
  out.source_pixel.setTo(cv::Scalar::all(std::numeric_limits<float>::quiet_NaN()));
  parallel_chunks(target.height, 8, [&](std::int64_t y_begin, std::int64_t y_end) {
    for (int y = int(y_begin); y < int(y_end); ++y)
      for (int x = 0; x < target.width; ++x) {
        if (out.target.triangle_at(x, y) == kNoTriangle) continue;
        const Eigen::Vector3d point = source.cam_from_world * surface_point(mesh, out.target, x, y);
        Eigen::Vector2d pixel = Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
        const bool imaged = source.project(point, pixel);
        // The equidistant fisheye images rays beyond 90 degrees, which project() reports as not imaged.
        if (!pixel.allFinite() || !(imaged || source.model == CameraModel::fisheye)) continue;
        out.source_pixel.at<cv::Vec2f>(y, x) = {float(pixel.x()), float(pixel.y())};
        int nx = int(std::lround(pixel.x())), ny = int(std::lround(pixel.y()));
        if (wrap) nx = ((nx % source.width) + source.width) % source.width;
        if (nx < 0 || ny < 0 || nx >= source.width || ny >= source.height) continue;
        const double seen = source_depth.at<float>(ny, nx);
        const double own = kind == DepthMeasure::z ? point.z() : point.norm();
        if (!(std::abs(seen - own) <= options.relative_depth_tolerance * std::abs(own))) continue;  // NaN too
        sample_bilinear(image, pixel.x(), pixel.y(), wrap, out.image.ptr<float>(y) + x * cn);
        out.valid.at<std::uint8_t>(y, x) = 255;
      }
  });
  return out;
}

}  // namespace pg

#include "pg/refine/pair_estimate.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "pg/core/error.h"
#include "pg/core/parallel.h"
#include "pg/image/image_io.h"

namespace pg {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

// Column c of an image `width` wide: clamped to the image, except that a panorama's columns wrap
// around (the seam at 180 degrees of longitude joins its last column to its first).
int column_index(int c, int width, bool wraps) {
  return wraps ? (c % width + width) % width : std::clamp(c, 0, width - 1);
}

// Bilinear, clamped at the edges, the columns of a panorama wrapped.
float sample_bilinear(const cv::Mat1f& image, double x, double y, bool wraps) {
  const double fx = std::floor(x), fy = std::floor(y);
  const float ax = float(x - fx), ay = float(y - fy);
  const int x0 = column_index(int(fx), image.cols, wraps), x1 = column_index(int(fx) + 1, image.cols, wraps);
  const int y0 = std::clamp(int(fy), 0, image.rows - 1), y1 = std::clamp(int(fy) + 1, 0, image.rows - 1);
  const float top = image(y0, x0) * (1 - ax) + image(y0, x1) * ax;
  const float bottom = image(y1, x0) * (1 - ax) + image(y1, x1) * ax;
  return top * (1 - ay) + bottom * ay;
}

// The surface point a pixel of `buffers` sees (the buffers must hold a hit there).
Eigen::Vector3d hit_point(const Mesh& mesh, const RenderBuffers& buffers, std::size_t i) {
  const auto& f = mesh.faces[buffers.triangle[i]];
  const double w1 = buffers.b1[i], w2 = buffers.b2[i];
  return (1 - w1 - w2) * mesh.positions[f[0]].cast<double>() + w1 * mesh.positions[f[1]].cast<double>() +
         w2 * mesh.positions[f[2]].cast<double>();
}

Eigen::Vector3d face_normal(const Mesh& mesh, std::uint32_t triangle) {
  const auto& f = mesh.faces[triangle];
  const Eigen::Vector3d p0 = mesh.positions[f[0]].cast<double>();
  return (mesh.positions[f[1]].cast<double>() - p0)
      .cross(mesh.positions[f[2]].cast<double>() - p0)
      .normalized();
}

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

RefineViewState make_view_state(const RefineView& view, double scale) {
  RefineViewState state;
  state.camera = resized_camera(view.camera, scale);
  const cv::Size size(state.camera.width, state.camera.height);
  cv::Mat1f gray = to_float_gray(view.image);
  if (gray.size() != size) {
    cv::Mat1f resized;
    cv::resize(gray, resized, size, 0, 0, cv::INTER_AREA);
    gray = resized;
  }
  state.gray = gray;
  state.rays = std::make_shared<const RayTable>(state.camera);
  state.renderer = std::make_unique<gpu::ViewRenderer>(state.rays);
  state.world_from_cam_rotation = state.camera.cam_from_world.rotation_matrix().transpose();
  state.centre = state.camera.cam_from_world.centre();
  return state;
}

void render_view_state(const Mesh& mesh, RefineViewState& state) {
  RenderOptions options;
  options.shading = Shading::none;
  state.renderer->render(mesh, state.camera, options, state.buffers);
}

void synthesize(const Mesh& mesh, const RefineViewState& a, const RefineViewState& b,
                double relative_depth_tolerance, SyntheticView& out) {
  const int w = b.camera.width, h = b.camera.height;
  out.image.create(h, w);
  out.valid.create(h, w);
  const bool a_panorama = !a.camera.is_perspective();  // range depth, and columns that wrap
  parallel_chunks(h, 8, [&](std::int64_t y0, std::int64_t y1) {
    for (int y = int(y0); y < int(y1); ++y)
      for (int x = 0; x < w; ++x) {
        out.image(y, x) = b.gray(y, x);
        out.valid(y, x) = 0;
        const std::size_t i = b.buffers.index(x, y);
        if (b.buffers.triangle[i] == kNoTriangle) continue;
        const Eigen::Vector3d in_a = a.camera.cam_from_world * hit_point(mesh, b.buffers, i);
        Eigen::Vector2d pixel;
        if (!a.camera.project(in_a, pixel) || !a.camera.in_image(pixel)) continue;
        const int nx = column_index(int(std::lround(pixel.x())), a.camera.width, a_panorama);
        const int ny = std::clamp(int(std::lround(pixel.y())), 0, a.camera.height - 1);
        const double seen = a.buffers.depth.at<float>(ny, nx);
        const double own = a_panorama ? in_a.norm() : in_a.z();
        if (!(std::abs(seen - own) <= relative_depth_tolerance * std::abs(own))) continue;  // NaN too
        out.image(y, x) = sample_bilinear(a.gray, pixel.x(), pixel.y(), a_panorama);
        out.valid(y, x) = 255;
      }
  });
}

void DisplacementSums::reset(std::size_t vertices) {
  weight.assign(vertices, 0.0);
  normal_matrix.assign(vertices, Eigen::Matrix3d::Zero());
  rhs.assign(vertices, Eigen::Vector3d::Zero());
}

Eigen::Vector3d DisplacementSums::solve(std::size_t v) const {
  if (weight[v] <= 0) return Eigen::Vector3d::Zero();
  // A small ridge keeps directions no pixel constrains (tangents of flat parts) at zero; the prior,
  // when given, is that ridge (isotropic: the mesh may be off in any direction).
  const double ridge = prior_precision > 0 ? prior_precision : 0.01 * weight[v];
  const Eigen::Matrix3d m = normal_matrix[v] + ridge * Eigen::Matrix3d::Identity();
  return m.ldlt().solve(rhs[v]);
}

// The true surface point behind a synthetic-B pixel lies on A's ray through the current one, so its B
// image lies on the line. Parameterised from the pixel itself (base 0), s is the signed correction
// along the line, zero for the current surface at every pyramid level, and the flow's smoothness
// acts on the correction, as in the free mode. (Measuring s from the point at infinity instead, as
// epipolar_field does, makes the smoothness act on a field that varies from pixel to pixel even for a
// perfect mesh: it biased the refinement and left 20% more error.) Pixels without a line (not
// co-visible, where the synthetic image is B's own) borrow the direction of the nearest pixel with
// one, so the smoothness of s sees no false edge at the border of the co-visible region.
EpipolarField surface_epipolar_field(const Mesh& mesh, const RefineViewState& a, const RefineViewState& b,
                                     const SyntheticView& synthetic) {
  const int w = b.camera.width, h = b.camera.height;
  cv::Mat2f tangent(h, w, cv::Vec2f(kNaN, kNaN));
  const Eigen::Matrix3d b_from_world = b.camera.cam_from_world.rotation_matrix();
  const Eigen::Vector3d b_translation = b.camera.cam_from_world.translation;
  parallel_chunks(h, 8, [&](std::int64_t y0, std::int64_t y1) {
    for (int y = int(y0); y < int(y1); ++y)
      for (int x = 0; x < w; ++x) {
        if (!synthetic.valid(y, x)) continue;
        const Eigen::Vector3d point = hit_point(mesh, b.buffers, b.buffers.index(x, y));
        // Central difference along A's ray, a thousandth of the point's distance either side.
        const Eigen::Vector3d step = 1e-3 * (a.centre - point);
        Eigen::Vector2d nearer, farther;
        if (!b.camera.project(b_from_world * (point + step) + b_translation, nearer) ||
            !b.camera.project(b_from_world * (point - step) + b_translation, farther))
          continue;
        const Eigen::Vector2d d = nearer - farther;
        const double length = d.norm();
        if (length > 1e-9 && d.allFinite())
          tangent(y, x) = cv::Vec2f(float(d.x() / length), float(d.y() / length));
      }
  });
  // The nearest pixel with a line, for every pixel (labels of the zero pixels of `no_line`).
  cv::Mat1b no_line(h, w);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) no_line(y, x) = std::isfinite(tangent(y, x)[0]) ? 0 : 255;
  EpipolarField field;
  field.base = cv::Mat2f(h, w, cv::Vec2f(0, 0));
  if (cv::countNonZero(no_line) == w * h) {
    field.direction = cv::Mat2f(h, w, cv::Vec2f(kNaN, kNaN));
    return field;
  }
  cv::Mat1f distance;
  cv::Mat1i labels;
  cv::distanceTransform(no_line, distance, labels, cv::DIST_L2, 3, cv::DIST_LABEL_PIXEL);
  std::vector<cv::Vec2f> label_tangent(std::size_t(w) * h + 1, cv::Vec2f(kNaN, kNaN));
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (!no_line(y, x)) label_tangent[labels(y, x)] = tangent(y, x);
  field.direction.create(h, w);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      field.direction(y, x) = no_line(y, x) ? label_tangent[labels(y, x)] : tangent(y, x);
  return field;
}

namespace {

// The distance from A's centre along the unit ray u to where B's ray through `pixel` passes closest.
double ray_parameter(const RefineViewState& b, const Eigen::Vector3d& u, const Eigen::Vector2d& pixel,
                     const Eigen::Vector3d& w0) {
  const Eigen::Vector3d v = (b.world_from_cam_rotation * b.camera.unproject(pixel)).normalized();
  const double uv = u.dot(v), denominator = 1 - uv * uv;
  return (uv * v.dot(w0) - u.dot(w0)) / denominator;
}

// Standard error of a pixel's normal offset for a flow error of `flow_sigma_px` along the epipolar
// line in B; NaN where the line is undefined.
double offset_sigma(const RefineViewState& a, const RefineViewState& b, const Eigen::Vector3d& point,
                    const Eigen::Vector3d& u, const Eigen::Vector2d& corrected, const Eigen::Vector3d& w0,
                    const Eigen::Vector3d& normal, double flow_sigma_px) {
  const Eigen::Matrix3d b_from_world = b.camera.cam_from_world.rotation_matrix();
  const Eigen::Vector3d step = 1e-3 * (a.centre - point);
  Eigen::Vector2d nearer, farther;
  if (!b.camera.project(b_from_world * (point + step) + b.camera.cam_from_world.translation, nearer) ||
      !b.camera.project(b_from_world * (point - step) + b.camera.cam_from_world.translation, farther))
    return kNaN;
  const Eigen::Vector2d line = nearer - farther;
  if (!(line.norm() > 1e-12)) return kNaN;
  const Eigen::Vector2d moved = corrected + flow_sigma_px * line.normalized();
  const double dt = ray_parameter(b, u, moved, w0) - ray_parameter(b, u, corrected, w0);
  return std::abs(dt * u.dot(normal));
}

}  // namespace

cv::Mat1f border_taper(const cv::Mat1b& valid, double taper_px, bool panorama) {
  if (!(taper_px > 0)) return cv::Mat1f(valid.size(), 1.0f);
  cv::Mat1b framed;
  cv::Rect inside;
  if (panorama) {
    // No edge: the columns wrap (copies of the other side, wide enough for the ramp) and the poles
    // are no border of the flow.
    const int pad = std::min(valid.cols, int(std::ceil(taper_px)) + 1);
    cv::copyMakeBorder(valid, framed, 0, 0, pad, pad, cv::BORDER_WRAP);
    inside = cv::Rect(pad, 0, valid.cols, valid.rows);
  } else {
    // The frame of zeros makes the image's edge a border too (the flow is least sure there); without
    // it the distance transform takes the outside for far away.
    cv::copyMakeBorder(valid, framed, 1, 1, 1, 1, cv::BORDER_CONSTANT, cv::Scalar(0));
    inside = cv::Rect(1, 1, valid.cols, valid.rows);
  }
  cv::Mat1f distance;
  cv::distanceTransform(framed, distance, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  cv::Mat1f taper = distance(inside) * (1.0 / taper_px);
  cv::min(taper, 1.0, taper);
  return taper;
}

std::size_t estimate_displacements(const Mesh& mesh, const RefineViewState& a, const RefineViewState& b,
                                   const SyntheticView& synthetic, const RefineOptions& options,
                                   double max_displacement, DisplacementSums& sums, double* flow_seconds) {
  const int w = b.camera.width, h = b.camera.height;
  const auto flow_start = std::chrono::steady_clock::now();
  cv::Mat2f flow;
  if (options.flow_mode == RefineFlow::epipolar) {
    // s starts at zero everywhere: the current surface (and no discrete search is run).
    const EpipolarField field = surface_epipolar_field(mesh, a, b, synthetic);
    flow = compute_epipolar_flow(synthetic.image, b.gray, field, options.flow, cv::Mat1f::zeros(h, w)).flow;
  } else {
    flow = compute_flow(synthetic.image, b.gray, options.flow);
  }
  if (flow_seconds) *flow_seconds += seconds_since(flow_start);

  const cv::Mat1f taper = border_taper(synthetic.valid, options.border_taper_px, !b.camera.is_perspective());

  const double sin_min_angle = std::sin(options.min_triangulation_angle_deg * M_PI / 180.0);
  const double min_denominator = sin_min_angle * sin_min_angle;
  const double sigma2 = options.confidence_sigma * options.confidence_sigma;
  // Per pixel: weight (0 = no contribution) and displacement; gathered per vertex afterwards in row
  // order so the sums do not depend on the thread count.
  std::vector<float> pixel_weight(std::size_t(w) * h, 0.0f);
  std::vector<float> pixel_offset(std::size_t(w) * h);  // along the face normal
  parallel_chunks(h, 8, [&](std::int64_t y0, std::int64_t y1) {
    for (int y = int(y0); y < int(y1); ++y)
      for (int x = 0; x < w; ++x) {
        if (!synthetic.valid(y, x)) continue;
        const cv::Vec2f f = flow(y, x);
        if (!std::isfinite(f[0]) || !std::isfinite(f[1])) continue;
        const Eigen::Vector2d corrected(x + f[0], y + f[1]);
        if (!b.camera.in_image(corrected)) continue;
        const std::size_t i = b.buffers.index(x, y);
        const Eigen::Vector3d point = hit_point(mesh, b.buffers, i);
        // A's ray through the point, and B's ray through where the flow says the point really is.
        Eigen::Vector3d u = point - a.centre;
        const double t_current = u.norm();
        u /= t_current;
        const Eigen::Vector3d v = (b.world_from_cam_rotation * b.camera.unproject(corrected)).normalized();
        const Eigen::Vector3d w0 = a.centre - b.centre;
        const double uv = u.dot(v), denominator = 1 - uv * uv;
        if (denominator < min_denominator) continue;
        const double uw = u.dot(w0), vw = v.dot(w0);
        const double t = (uv * vw - uw) / denominator, s = (vw - uv * uw) / denominator;
        if (t <= 0 || s <= 0) continue;
        const Eigen::Vector3d displacement = (t - t_current) * u;
        if (!(displacement.norm() <= max_displacement)) continue;
        const double residual = synthetic.image(y, x) - sample_bilinear(b.gray, corrected.x(), corrected.y(),
                                                                        !b.camera.is_perspective());
        const double confidence = 1.0 / (1.0 + residual * residual / sigma2);
        const Eigen::Vector3d normal = face_normal(mesh, b.buffers.triangle[i]);
        double precision = 1;
        if (options.mesh_accuracy > 0) {
          // The offset's standard error: re-triangulate with the flow moved by its own error along
          // the epipolar line (the only direction that changes depth).
          const double sigma = offset_sigma(a, b, point, u, corrected, w0, normal, options.flow_precision_px);
          if (!(sigma > 0)) continue;
          precision = 1 / (sigma * sigma);
        }
        pixel_weight[i] = float(confidence * taper(y, x) * precision);
        pixel_offset[i] = float(displacement.dot(normal));
      }
  });

  std::size_t contributing = 0;
  for (std::size_t i = 0; i < pixel_weight.size(); ++i) {
    const double pw = pixel_weight[i];
    if (pw <= 0) continue;
    ++contributing;
    const std::uint32_t triangle = b.buffers.triangle[i];
    const auto& face = mesh.faces[triangle];
    const double bary[3] = {1.0 - b.buffers.b1[i] - b.buffers.b2[i], b.buffers.b1[i], b.buffers.b2[i]};
    const Eigen::Vector3d n = face_normal(mesh, triangle);
    const Eigen::Matrix3d nn = n * n.transpose();
    for (int k = 0; k < 3; ++k) {
      const double weight = pw * std::max(0.0, bary[k]);
      sums.weight[face[k]] += weight;
      sums.normal_matrix[face[k]] += weight * nn;
      sums.rhs[face[k]] += (weight * pixel_offset[i]) * n;
    }
  }
  return contributing;
}

}  // namespace pg

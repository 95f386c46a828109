#include "pg/track/position_refinement.h"

#include <tbb/parallel_for.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>

#include "pg/core/parallel.h"

namespace pg {

namespace {

// Bilinear sample of an 8-bit image; nullopt outside the interpolable area.
std::optional<float> sample(const cv::Mat& image, double x, double y) {
  if (!(x >= 0 && y >= 0 && x <= image.cols - 1 && y <= image.rows - 1)) return std::nullopt;
  const int x0 = std::min(static_cast<int>(x), image.cols - 2),
            y0 = std::min(static_cast<int>(y), image.rows - 2);
  const float fx = static_cast<float>(x - x0), fy = static_cast<float>(y - y0);
  const unsigned char* r0 = image.ptr<unsigned char>(y0) + x0;
  const unsigned char* r1 = image.ptr<unsigned char>(y0 + 1) + x0;
  return (1 - fy) * ((1 - fx) * r0[0] + fx * r0[1]) + fy * ((1 - fx) * r1[0] + fx * r1[1]);
}

// Samples image at centre + A * (u, v) for u, v in [-r, r] (row-major); false when any falls outside.
bool sample_patch(const cv::Mat& image, const cv::Point2d& centre, const Eigen::Matrix2d& a, int r,
                  std::vector<float>& out) {
  const int side = 2 * r + 1;
  out.resize(static_cast<std::size_t>(side) * side);
  for (int v = -r; v <= r; ++v)
    for (int u = -r; u <= r; ++u) {
      const auto value =
          sample(image, centre.x + a(0, 0) * u + a(0, 1) * v, centre.y + a(1, 0) * u + a(1, 1) * v);
      if (!value) return false;
      out[static_cast<std::size_t>(v + r) * side + (u + r)] = *value;
    }
  return true;
}

double correlation(const std::vector<float>& a, const std::vector<float>& b) {
  double ma = 0, mb = 0;
  for (std::size_t i = 0; i < a.size(); ++i) ma += a[i], mb += b[i];
  ma /= a.size(), mb /= b.size();
  double ab = 0, aa = 0, bb = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const double da = a[i] - ma, db = b[i] - mb;
    ab += da * db, aa += da * da, bb += db * db;
  }
  return aa > 0 && bb > 0 ? ab / std::sqrt(aa * bb) : 0.0;
}

// The detectors' shapes as the affine map from reference patch offsets to target patch offsets.
// A target rotated by +phi from the reference (image axes, y down) has angle_target - angle_ref = phi
// (checked by the tests: a wrong sign leaves most rotated points unrefined).
Eigen::Matrix2d initial_warp(const PointShape& reference, const PointShape& target) {
  if (reference.size <= 0 || target.size <= 0) return Eigen::Matrix2d::Identity();
  const double scale = static_cast<double>(target.size) / reference.size;
  const double phi = (target.angle_deg - reference.angle_deg) * std::numbers::pi / 180.0;
  Eigen::Matrix2d a;
  a << std::cos(phi), -std::sin(phi), std::sin(phi), std::cos(phi);
  return scale * a;
}

// Measured against the true cameras of Herz-Jesu-P8 and templeSparseRing (observations' reprojection
// error after triangulation with them): the best window grows with the image, 5 at 640x480, 7 to 10
// at 1536x1024, 14 at 3072x2048, beyond which it stops helping.
int automatic_half_window(const cv::Size& size) {
  return std::clamp(static_cast<int>(std::lround(std::max(size.width, size.height) / 220.0)), 5, 16);
}

struct Alignment {
  cv::Point2d position;
  double correlation = 0;
};

// Gauss-Newton on r(u) = gain * I(A u + t) + offset - T(u) over the 8 parameters (A, t, gain,
// offset). The warped patch is sampled one pixel wider than the template so its derivatives come
// from central differences in patch coordinates: d/du I(A u + t) = grad I^T A.
std::optional<Alignment> align(const std::vector<float>& templ, int r, const cv::Mat& image, cv::Point2d t,
                               Eigen::Matrix2d a, const PositionRefinementOptions& options) {
  const int wide = r + 1, wide_side = 2 * wide + 1;
  std::vector<float> warped;
  double gain = 1, offset = 0;
  const cv::Point2d start = t;
  for (int iteration = 0; iteration < options.max_iterations; ++iteration) {
    if (!sample_patch(image, t, a, wide, warped)) return std::nullopt;
    const Eigen::Matrix2d a_inv = a.inverse();
    Eigen::Matrix<double, 8, 8> h = Eigen::Matrix<double, 8, 8>::Zero();
    Eigen::Matrix<double, 8, 1> g = Eigen::Matrix<double, 8, 1>::Zero();
    for (int v = -r; v <= r; ++v)
      for (int u = -r; u <= r; ++u) {
        const std::size_t at = static_cast<std::size_t>(v + wide) * wide_side + (u + wide);
        const double value = warped[at];
        const Eigen::RowVector2d patch_gradient(0.5 * (warped[at + 1] - warped[at - 1]),
                                                0.5 * (warped[at + wide_side] - warped[at - wide_side]));
        const Eigen::RowVector2d image_gradient = gain * patch_gradient * a_inv;
        Eigen::Matrix<double, 8, 1> j;
        j << image_gradient(0) * u, image_gradient(0) * v, image_gradient(1) * u, image_gradient(1) * v,
            image_gradient(0), image_gradient(1), value, 1.0;
        const double residual =
            gain * value + offset - templ[static_cast<std::size_t>(v + r) * (2 * r + 1) + (u + r)];
        h.selfadjointView<Eigen::Lower>().rankUpdate(j);
        g += j * residual;
      }
    h = h.selfadjointView<Eigen::Lower>();
    const Eigen::LDLT<Eigen::Matrix<double, 8, 8>> solver(h);
    if (solver.info() != Eigen::Success) return std::nullopt;
    const Eigen::Matrix<double, 8, 1> step = -solver.solve(g);
    if (!step.allFinite()) return std::nullopt;
    a(0, 0) += step(0), a(0, 1) += step(1), a(1, 0) += step(2), a(1, 1) += step(3);
    t += cv::Point2d(step(4), step(5));
    gain += step(6), offset += step(7);
    if (std::hypot(t.x - start.x, t.y - start.y) > options.max_shift_px || !(gain > 0)) return std::nullopt;
    if (std::hypot(step(4), step(5)) < 1e-3) break;
  }
  // A warp that has collapsed or blown up is a false alignment on a patch without 2-D structure.
  const Eigen::JacobiSVD<Eigen::Matrix2d> svd(a);
  const Eigen::Vector2d singular = svd.singularValues();
  if (!(singular(1) > 0.25 && singular(0) < 4)) return std::nullopt;
  std::vector<float> aligned;
  if (!sample_patch(image, t, a, r, aligned)) return std::nullopt;
  return Alignment{t, correlation(templ, aligned)};
}

}  // namespace

PositionRefinementStats refine_track_positions(const std::vector<cv::Mat>& images,
                                               std::vector<std::vector<cv::Point2f>>& points,
                                               const std::vector<std::vector<PointShape>>& shapes,
                                               const std::vector<NodeTrack>& tracks,
                                               const PositionRefinementOptions& options) {
  const int n = static_cast<int>(images.size());
  return refine_track_positions(
      n, [&](int f) { return images[f]; }, n, points, shapes, tracks, options);
}

PositionRefinementStats refine_track_positions(int frame_count, const std::function<cv::Mat(int)>& load,
                                               int frames_at_once,
                                               std::vector<std::vector<cv::Point2f>>& points,
                                               const std::vector<std::vector<PointShape>>& shapes,
                                               const std::vector<NodeTrack>& tracks,
                                               const PositionRefinementOptions& options) {
  // Pass 1: each track's reference patch, around its middle observation in frame order, which stays.
  std::vector<std::vector<int>> referenced_in(frame_count);
  for (std::size_t k = 0; k < tracks.size(); ++k)
    if (tracks[k].size() >= 2)
      referenced_in[tracks[k][tracks[k].size() / 2].first].push_back(static_cast<int>(k));
  std::vector<std::vector<float>> templates(tracks.size());
  std::vector<int> radius(tracks.size(), 0);  // 0: no reference patch (too near the border)
  parallel_for_bounded(frame_count, frames_at_once, [&](int f) {
    if (referenced_in[f].empty()) return;
    const cv::Mat image = load(f);
    const int r = options.half_window > 0 ? options.half_window : automatic_half_window(image.size());
    tbb::parallel_for(std::size_t(0), referenced_in[f].size(), [&](std::size_t i) {
      const int k = referenced_in[f][i];
      const auto [frame, index] = tracks[k][tracks[k].size() / 2];
      if (sample_patch(image, points[frame][index], Eigen::Matrix2d::Identity(), r, templates[k]))
        radius[k] = r;
    });
  });

  // Pass 2: every other observation aligned onto its track's reference patch, frame by frame.
  std::vector<std::vector<std::pair<int, int>>> observed_in(frame_count);  // (track, node) pairs
  std::vector<std::vector<double>> shift(tracks.size());                   // NaN: refused
  for (std::size_t k = 0; k < tracks.size(); ++k) {
    if (radius[k] == 0) continue;
    shift[k].assign(tracks[k].size(), std::numeric_limits<double>::quiet_NaN());
    for (std::size_t i = 0; i < tracks[k].size(); ++i)
      if (i != tracks[k].size() / 2)
        observed_in[tracks[k][i].first].push_back({static_cast<int>(k), static_cast<int>(i)});
  }
  parallel_for_bounded(frame_count, frames_at_once, [&](int f) {
    if (observed_in[f].empty()) return;
    const cv::Mat image = load(f);
    tbb::parallel_for(std::size_t(0), observed_in[f].size(), [&](std::size_t o) {
      const auto [k, i] = observed_in[f][o];
      const auto [ref_frame, ref_index] = tracks[k][tracks[k].size() / 2];
      const auto [frame, index] = tracks[k][i];
      cv::Point2f& p = points[frame][index];
      const auto found = align(templates[k], radius[k], image, p,
                               initial_warp(shapes[ref_frame][ref_index], shapes[frame][index]), options);
      if (!found || found->correlation < options.min_correlation) return;
      shift[k][i] = std::hypot(found->position.x - p.x, found->position.y - p.y);
      p = cv::Point2f(static_cast<float>(found->position.x), static_cast<float>(found->position.y));
    });
  });

  // Totals in track order, each track's in node order, whatever order the frames ran in.
  PositionRefinementStats out;
  for (std::size_t k = 0; k < tracks.size(); ++k) {
    if (tracks[k].size() < 2) continue;
    if (radius[k] == 0) {
      out.refused += static_cast<int>(tracks[k].size()) - 1;
      continue;
    }
    double track_shift = 0;
    for (std::size_t i = 0; i < tracks[k].size(); ++i) {
      if (i == tracks[k].size() / 2) continue;
      if (std::isnan(shift[k][i])) {
        ++out.refused;
      } else {
        track_shift += shift[k][i];
        ++out.refined;
      }
    }
    out.mean_shift_px += track_shift;
  }
  if (out.refined > 0) out.mean_shift_px /= out.refined;
  return out;
}

}  // namespace pg

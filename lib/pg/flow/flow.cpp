#include "pg/flow/flow.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cmath>

#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/flow/level_solver.h"
#include "pg/flow/line_search.h"
#include "pg/image/image_io.h"
#include "pg/image/pyramid.h"

namespace pg {
namespace {

using flow_detail::LevelImages;
using flow_detail::LevelSolver;

// The image as float channels on a [0, 1] scale, pre-smoothed.
std::vector<cv::Mat1f> flow_channels(const cv::Mat& image, const FlowOptions& options) {
  cv::Mat as_float;
  switch (image.depth()) {
    case CV_8U:
      image.convertTo(as_float, CV_32F, 1.0 / 255.0);
      break;
    case CV_16U:
      image.convertTo(as_float, CV_32F, 1.0 / 65535.0);
      break;
    case CV_32F:
    case CV_64F:
      image.convertTo(as_float, CV_32F);
      if (options.hdr_log) {
        cv::max(as_float, 0.0, as_float);
        as_float += 1.0;
        cv::log(as_float, as_float);
        as_float *= 1.0 / std::log(2.0);
      }
      break;
    default:
      throw UsageError("flow: images must be 8-bit, 16-bit or float");
  }
  std::vector<cv::Mat> planes;
  cv::split(as_float, planes);
  if (planes.size() == 4) planes.pop_back();  // alpha
  std::vector<cv::Mat1f> channels;
  for (const cv::Mat& plane : planes) {
    cv::Mat1f channel = plane;
    zero_non_finite(channel);
    channels.push_back(gaussian_blur(channel, options.presmooth_sigma));
  }
  return channels;
}

void check_pair(const cv::Mat& from, const cv::Mat& to) {
  if (from.empty() || to.empty()) throw UsageError("flow: empty image");
  if (from.size() != to.size())
    throw UsageError(
        str("flow: image sizes differ (", from.cols, "x", from.rows, " and ", to.cols, "x", to.rows, ")"));
  if (from.channels() != to.channels()) throw UsageError("flow: images have different channel counts");
  if (from.channels() == 2 || from.channels() > 4)
    throw UsageError("flow: images must have 1, 3 or 4 channels");
  if (from.cols < 2 || from.rows < 2) throw UsageError("flow: images must be at least 2x2 pixels");
}

// Both images' pyramids, channel by channel: levels[level][channel].
struct PyramidPair {
  std::vector<cv::Size> sizes;
  std::vector<std::vector<cv::Mat1f>> from, to;
};

PyramidPair build_pyramids(const cv::Mat& from, const cv::Mat& to, const FlowOptions& options) {
  const PyramidOptions pyramid{options.pyramid_factor, options.min_side, options.max_levels};
  PyramidPair pair;
  pair.sizes = pyramid_sizes(from.size(), pyramid);
  pair.from.resize(pair.sizes.size());
  pair.to.resize(pair.sizes.size());
  for (const auto& [image, levels] : {std::pair{&from, &pair.from}, std::pair{&to, &pair.to}}) {
    for (const cv::Mat1f& channel : flow_channels(*image, options)) {
      std::vector<cv::Mat1f> pyramid_levels = build_pyramid(channel, pyramid);
      for (std::size_t level = 0; level < pyramid_levels.size(); ++level)
        (*levels)[level].push_back(std::move(pyramid_levels[level]));
    }
  }
  return pair;
}

// A field (flow component or s) resized to `size`, its values multiplied by `scale`.
cv::Mat1f rescale(const cv::Mat1f& field, cv::Size size, double scale) {
  cv::Mat1f out = field.size() == size ? field.clone() : resize_bilinear(field, size);
  if (scale != 1.0) out *= scale;
  return out;
}

cv::Mat2f merge_flow(const cv::Mat1f& u, const cv::Mat1f& v) {
  cv::Mat2f flow;
  cv::merge(std::vector<cv::Mat>{u, v}, flow);
  return flow;
}

int first_level(const PyramidPair& pair) {
  return static_cast<int>(pair.sizes.size()) - 1;
}
int last_level(const PyramidPair& pair, const FlowOptions& options) {
  return std::min(options.finest_level, first_level(pair));
}

}  // namespace

cv::Mat2f compute_flow(const cv::Mat& from, const cv::Mat& to, const FlowOptions& options,
                       const cv::Mat2f& initial) {
  options.check();
  check_pair(from, to);
  if (!initial.empty() && initial.size() != from.size())
    throw UsageError("flow: initial flow size differs from the images");
  const PyramidPair pair = build_pyramids(from, to, options);
  const cv::Size full = pair.sizes.front();
  cv::Mat1f u, v;
  if (!initial.empty()) {
    std::vector<cv::Mat1f> parts;
    cv::split(initial, parts);
    u = parts[0], v = parts[1];
    cv::patchNaNs(u, 0.0);
    cv::patchNaNs(v, 0.0);
  } else {
    u = cv::Mat1f::zeros(full);
    v = cv::Mat1f::zeros(full);
  }
  // Buffers for the largest level solved, reused by every level.
  const cv::Size largest = pair.sizes[last_level(pair, options)];
  flow_detail::PlanePool pool(largest);
  LevelSolver solver(largest, options);
  for (int level = first_level(pair); level >= last_level(pair, options); --level) {
    const cv::Size size = pair.sizes[level];
    u = rescale(u, size, static_cast<double>(size.width) / u.cols);
    v = rescale(v, size, static_cast<double>(size.height) / v.rows);
    pool.release_all();
    const LevelImages images = flow_detail::prepare_level(pair.from[level], pair.to[level], options, pool);
    solver.solve(images, u, v);
  }
  u = rescale(u, full, static_cast<double>(full.width) / u.cols);
  v = rescale(v, full, static_cast<double>(full.height) / v.rows);
  return merge_flow(u, v);
}

EpipolarFlow compute_epipolar_flow(const cv::Mat& from, const cv::Mat& to, const EpipolarField& field,
                                   const FlowOptions& free_options, const cv::Mat1f& initial_along) {
  free_options.check();
  FlowOptions options = free_options;
  options.alpha = free_options.epipolar_alpha;
  options.edge_weight = free_options.epipolar_edge_weight;
  check_pair(from, to);
  if (field.empty() || field.base.size() != from.size() || field.direction.size() != from.size())
    throw UsageError("flow: the epipolar field's size differs from the images");
  if (!initial_along.empty() && initial_along.size() != from.size())
    throw UsageError("flow: initial_along size differs from the images");
  const PyramidPair pair = build_pyramids(from, to, options);
  const cv::Size full = pair.sizes.front();
  cv::Mat1f s = initial_along.clone();
  int start = first_level(pair);
  const int finest = last_level(pair, options);
  if (s.empty() && options.search_range > 0) {
    // The discrete search at the finest level it can afford; coarser levels are skipped.
    const auto radius_at = [&](int level) {
      return std::max(1, static_cast<int>(std::ceil(options.search_range * pair.sizes[level].width)));
    };
    start = finest;
    while (start < first_level(pair) &&
           flow_detail::line_search_cost(pair.sizes[start], radius_at(start)) > options.search_budget)
      ++start;
    const cv::Size size = pair.sizes[start];
    const EpipolarField level_field = start == 0 ? field : resize_epipolar_field(field, size);
    s = flow_detail::search_along_lines(pair.from[start], pair.to[start], level_field.base,
                                        level_field.direction, radius_at(start));
  } else if (s.empty()) {
    // Start from the smallest flow on each line (its foot from the pixel itself), as the free flow
    // starts from zero: converging cameras put the point at infinity far from the pixel.
    s = cv::Mat1f(full);
    for (int y = 0; y < full.height; ++y)
      for (int x = 0; x < full.width; ++x) s(y, x) = -field.base(y, x).dot(field.direction(y, x));
  }
  cv::patchNaNs(s, 0.0);
  const cv::Size largest = pair.sizes[finest];
  flow_detail::PlanePool pool(largest);
  LevelSolver solver(largest, options);
  for (int level = start; level >= finest; --level) {
    const cv::Size size = pair.sizes[level];
    s = rescale(s, size, static_cast<double>(size.width) / s.cols);
    const EpipolarField level_field = level == 0 ? field : resize_epipolar_field(field, size);
    pool.release_all();
    const LevelImages images = flow_detail::prepare_level(pair.from[level], pair.to[level], options, pool);
    solver.solve_along(images, s, level_field.base, level_field.direction);
  }
  EpipolarFlow result;
  result.along = rescale(s, full, static_cast<double>(full.width) / s.cols);
  result.flow = cv::Mat2f(full);
  tbb::parallel_for(tbb::blocked_range<int>(0, full.height), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y != rows.end(); ++y)
      for (int x = 0; x < full.width; ++x)
        result.flow(y, x) = field.base(y, x) + result.along(y, x) * field.direction(y, x);
  });
  return result;
}

BidirectionalFlow compute_flow_bidirectional(const cv::Mat& from, const cv::Mat& to,
                                             const FlowOptions& options) {
  BidirectionalFlow result;
  result.forward = compute_flow(from, to, options);
  result.backward = compute_flow(to, from, options);
  result.fb_error = forward_backward_error(result.forward, result.backward);
  result.occluded = occlusion_mask(result.fb_error, result.forward);
  return result;
}

BidirectionalFlow compute_epipolar_flow_bidirectional(const cv::Mat& from, const cv::Mat& to,
                                                      const Camera& from_camera, const Camera& to_camera,
                                                      const FlowOptions& options) {
  const auto field_at_image_size = [](const Camera& a, const Camera& b, cv::Size size) {
    EpipolarField field = epipolar_field(a, b);
    return field.base.size() == size ? field : resize_epipolar_field(field, size);
  };
  return compute_epipolar_flow_bidirectional(from, to,
                                             field_at_image_size(from_camera, to_camera, from.size()),
                                             field_at_image_size(to_camera, from_camera, to.size()), options);
}

BidirectionalFlow compute_epipolar_flow_bidirectional(const cv::Mat& from, const cv::Mat& to,
                                                      const EpipolarField& forward,
                                                      const EpipolarField& backward,
                                                      const FlowOptions& options) {
  BidirectionalFlow result;
  result.forward = compute_epipolar_flow(from, to, forward, options).flow;
  result.backward = compute_epipolar_flow(to, from, backward, options).flow;
  result.fb_error = forward_backward_error(result.forward, result.backward);
  result.occluded = occlusion_mask(result.fb_error, result.forward);
  return result;
}

}  // namespace pg

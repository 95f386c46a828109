#pragma once
// Depth maps from dense correspondences: each pixel of the reference view and its flow into a second
// view are triangulated with both cameras, then filtered (formats/depth-exr.md for the output).
#include <cstddef>
#include <opencv2/core.hpp>

#include "pg/camera/camera.h"
#include "pg/image/depth_exr.h"

namespace pg {

struct DepthFilterOptions {
  double min_triangulation_angle_deg = 1.0;  // rays closer to parallel than this give noisy depth
  double max_fb_error = 1.0;                 // forward-backward flow error, pixels (+ fb_error_per_flow)
  double max_epipolar_residual = 1.0;        // reprojection error of the triangulated point, pixels
  double max_grazing_angle_deg = 80.0;       // angle between the surface normal and the viewing ray
  double max_depth_jump = 0.04;              // relative depth step to a 4-neighbour: a discontinuity
  // Local image texture (RMS intensity gradient per pixel over a 7x7 window, intensities in [0, 1])
  // below which the flow is only interpolated by its smoothness term (sky, blank walls): no depth there.
  double min_texture = 0.004;
  // Rejected pixels keep their depth; rejections show only in the confidence channel (for scoring
  // against dense ground truth).
  bool keep_all = false;
  void check() const;  // throws UsageError
};

// The forward-backward limit grows by this fraction of the flow's length (pixels per pixel).
inline constexpr double fb_error_per_flow = 0.02;

// Why pixels were rejected (a pixel counts under the first reason that applies, in this order).
struct DepthRejections {
  std::size_t masked = 0;          // user mask of either view
  std::size_t untriangulated = 0;  // flow unknown, leaves the other image, or rays do not meet in front
  std::size_t inconsistent = 0;    // forward-backward check
  std::size_t small_angle = 0;
  std::size_t epipolar = 0;
  std::size_t grazing = 0;
  std::size_t discontinuity = 0;
  std::size_t textureless = 0;  // passes the checks above but the reference is too flat (min_texture)
};

struct DepthFromFlowResult {
  DepthMap map;  // depth (NaN where rejected unless keep_all), confidence, normals, mask, camera
  DepthRejections rejections;
  std::size_t valid = 0;  // pixels passing every check
  double valid_fraction() const;
};

struct DepthFromFlowInput {
  const Camera* reference = nullptr;  // the flow's `from` view; its size is the flow's size
  const Camera* other = nullptr;
  cv::Mat2f flow;      // reference -> other, pixels
  cv::Mat1f fb_error;  // optional: forward_backward_error(flow, backward)
  // Optional, nonzero = the flow was filled in (fill_occlusions_along_lines) where it failed the
  // forward-backward check: such a pixel skips that check and its term of the confidence is 0.
  cv::Mat1b filled;
  cv::Mat1b reference_mask;  // optional, reference size: nonzero = ignore
  cv::Mat1b other_mask;      // optional, other camera's size: nonzero = ignore
  cv::Mat1f texture;         // optional, reference size: local_texture(reference image)
};

// RMS intensity gradient over a 7x7 window of a grey or colour image (scaled to [0, 1] intensities),
// the measure DepthFilterOptions::min_texture is compared with.
cv::Mat1f local_texture(const cv::Mat& image);

// Throws UsageError for missing cameras, mismatched sizes or cameras sharing their centre.
DepthFromFlowResult depth_from_flow(const DepthFromFlowInput& input, const DepthFilterOptions& options = {});

}  // namespace pg

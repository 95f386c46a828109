#pragma once
// One depth map from an image pair: flow (epipolar-constrained or free) forward and backward, then
// triangulation and filtering (depth_from_flow).
#include <opencv2/core.hpp>

#include "pg/depth/depth_from_flow.h"
#include "pg/flow/flow.h"

namespace pg {

struct DepthPairOptions {
  FlowOptions flow;
  bool epipolar = true;  // constrain the flow to epipolar lines (static scenes; faster and more robust)
  double scale = 1.0;    // resolution of the computation relative to the images, in (0, 1]
  // Epipolar mode: pixels failing the forward-backward check (by filter.max_fb_error, hidden in the
  // other view) take the background of their epipolar line (fill_occlusions_along_lines) instead of
  // being rejected as inconsistent; they pass that check with at most half the confidence of a
  // consistent pixel, and the other checks still apply.
  bool fill_occlusions = false;
  DepthFilterOptions filter;
  void check() const;  // throws UsageError
};

struct DepthPairInput {
  cv::Mat reference_image, other_image;  // sizes must equal the cameras' sizes
  Camera reference, other;
  cv::Mat1b reference_mask, other_mask;  // optional, nonzero = ignore
};

struct DepthPairResult {
  DepthFromFlowResult depth;  // at scale x the reference camera's resolution
  cv::Mat2f flow;             // forward flow at that resolution (filled where fill_occlusions filled it)
  std::size_t filled = 0;     // pixels fill_occlusions filled
  double flow_seconds = 0, triangulation_seconds = 0;
};

// Throws UsageError for images that do not match their cameras, cameras sharing their centre or
// invalid options.
DepthPairResult compute_depth_pair(const DepthPairInput& input, const DepthPairOptions& options = {});

}  // namespace pg

#pragma once
// Projective texturing (synthetic views for refinement): render a target camera B, carry each surface
// point it sees into a source camera A, and sample A's image where A sees that same point.
#include <opencv2/core.hpp>

#include "pg/render/rasterizer.h"

namespace pg {

struct ProjectionOptions {
  RenderOptions target;  // how B is rendered (culling, near); its shading is ignored
  // X is visible in A when A's depth at the nearest pixel to X's projection agrees with X's own depth:
  // |depth_A - depth_X| <= relative_depth_tolerance * depth_X.
  double relative_depth_tolerance = 0.01;
  DepthMeasure source_depth_kind = DepthMeasure::automatic;  // what source_depth holds
};

struct ProjectedImage {
  cv::Mat image;         // CV_32FC(channels of A's image), zero where invalid
  cv::Mat valid;         // CV_8U, 255 where B sees the mesh and A sees the same point
  cv::Mat source_pixel;  // CV_32FC2: where B's surface point projects in A; NaN where B sees nothing
  RenderBuffers target;  // B's buffers: triangle ids and barycentrics give each pixel's surface point
};

// source_image: A's image (any depth, 1 to 4 channels; converted to float without rescaling);
// source_depth: CV_32F, as rendered for A (NaN where empty). target_rays: B's RayTable when cached.
ProjectedImage render_projected(const Mesh& mesh, const Camera& source, const cv::Mat& source_image,
                                const cv::Mat& source_depth, const Camera& target,
                                const ProjectionOptions& options = {}, const RayTable* target_rays = nullptr);

}  // namespace pg

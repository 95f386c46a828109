#pragma once
// Peak memory of pg-sphdepth's run, estimated from the panoramas' size before they are decoded, so
// that a huge HDRI pair fails early over its --max-memory budget (exit code 5) instead of being
// killed. Keep the counts in step with sphere_depth.cpp and sphere_mesh.cpp.
#include <cstdint>
#include <opencv2/core.hpp>

#include "pg/spherical/sphere_depth.h"

namespace pg {

// Bytes of one compute_sphere_depth and the sphere-grid mesh after it, the decoded panoramas
// included:
//   the two panoramas:        2 x input pixels x image_bytes_per_pixel
//   their matching copies:    float, `channels` (at most 3) per pixel, at the input size and, when
//                             scaled, at the working size; then rectified and longitude-padded
//   the flow:                 bidirectional_flow_memory_bytes on the padded working size, epipolar,
//                             plus the two meridian line fields (4 planes each)
//   then the outputs:         range, confidence, disparity and the sampled fields (6 planes), the
//                             mesh (a vertex with position, UV, colour and confidence, two triangles per
//                             pixel) and its colours, at the working size
// The flow and output phases do not overlap; the peak is the larger one over what both hold.
std::uint64_t sphere_depth_memory_bytes(cv::Size input, std::uint64_t image_bytes_per_pixel, int channels,
                                        const SphereDepthOptions& options);

}  // namespace pg

#pragma once
// Peak memory of one depth pair, estimated from its cameras before any image is decoded, so that
// pg-depth can refuse a pair over its --max-memory budget (exit code 5) instead of being killed.
#include <cstdint>

#include "pg/camera/camera.h"
#include "pg/depth/depth_pair.h"

namespace pg {

// Bytes a caller of compute_depth_pair needs for this pair, images included:
//   decoded images and masks:  (reference + other pixels) * (image_bytes_per_pixel + 1)
//   their copies at --scale:   the same at the scaled size, when scale < 1
//   the flow:                  bidirectional_flow_memory_bytes at the scaled size (flow_memory.h)
// Triangulation, filtering and the optional point cloud and mesh run after the flow has released its
// pyramids and solver and hold about 20 planes against the flow's 60 to 100, so the flow is the peak.
// `channels`: the images' channel count (max_flow_channels when not yet known).
std::uint64_t depth_pair_memory_bytes(const Camera& reference, const Camera& other,
                                      std::uint64_t image_bytes_per_pixel, int channels,
                                      const DepthPairOptions& options);

}  // namespace pg

#pragma once
// Internal: the inputs of one warp's increments gathered into one host region, so that the device
// path uploads them with a single copy from pinned (page-locked) memory instead of one slow pageable
// copy per plane. Shared by the OpenCL and CUDA paths; the order is the device buffers' order.
#include <cstddef>
#include <vector>

#include "pg/gpu/flow_increments.h"

namespace pg::gpu::detail {

struct PlaneSource {
  const float* data;
  std::size_t floats;
};

// A continuous float matrix's data (all its channels), and a tensor's six planes in order.
PlaneSource plane_source(const cv::Mat& m);
std::vector<PlaneSource> tensor_sources(const std::array<cv::Mat1f, 6>& tensor);

// Free mode: brightness (6 planes), gradient (6), u, v, smoothness: 15 planes.
std::vector<PlaneSource> upload_planes(const FlowIncrementInput& input);
// Line mode: brightness (6), gradient (6), s, smoothness, direction (2 interleaved): 16 planes.
std::vector<PlaneSource> upload_planes(const LineIncrementInput& input);
std::size_t total_floats(const std::vector<PlaneSource>& planes);
// Copies the planes one after another into `destination` (total_floats of room), in parallel.
void gather(const std::vector<PlaneSource>& planes, float* destination);

}  // namespace pg::gpu::detail

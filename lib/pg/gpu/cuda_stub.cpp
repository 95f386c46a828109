// The CUDA entry points of a build without CUDA: no device, with the reason.
#include "pg/gpu/cuda_backend.h"

#if !PG_GPU_HAVE_CUDA
#include "pg/core/error.h"

namespace pg::gpu::detail {

std::vector<DeviceInfo> cuda_devices(std::string& reason) {
  reason = "this build has no CUDA support (configure with PG_WITH_CUDA=ON where nvcc exists)";
  return {};
}

void cuda_flow_increments(const FlowIncrementInput&, cv::Mat1f&, cv::Mat1f&) {
  throw FailedError("CUDA flow increments called in a build without CUDA");
}

void cuda_line_increments(const LineIncrementInput&, cv::Mat1f&) {
  throw FailedError("CUDA line increments called in a build without CUDA");
}

std::unique_ptr<FlowLevelBackend> cuda_flow_level(const std::vector<cv::Mat1f>&,
                                                  const std::vector<cv::Mat1f>&, const cv::Mat1f&, float) {
  throw FailedError("CUDA flow level asked for in a build without CUDA");
}

}  // namespace pg::gpu::detail
#endif

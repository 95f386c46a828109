#pragma once
// Internal: the optional CUDA path (cuda/flow_increments.cu, built with PG_WITH_CUDA). Without it, or
// without a usable GPU at run time, cuda_devices() is empty and gives the reason.
#include <memory>
#include <string>
#include <vector>

#include "pg/gpu/device.h"
#include "pg/gpu/flow_increments.h"
#include "pg/gpu/flow_level.h"

namespace pg::gpu::detail {

std::vector<DeviceInfo> cuda_devices(std::string& reason);
// Runs the flow increments on CUDA device 0; only called when cuda_devices() is non-empty.
void cuda_flow_increments(const FlowIncrementInput& input, cv::Mat1f& du, cv::Mat1f& dv);
void cuda_line_increments(const LineIncrementInput& input, cv::Mat1f& ds);
// A pyramid level on CUDA device 0 (flow_level.h).
std::unique_ptr<FlowLevelBackend> cuda_flow_level(const std::vector<cv::Mat1f>& from,
                                                  const std::vector<cv::Mat1f>& to,
                                                  const cv::Mat1f& smoothness, float zeta_squared);

}  // namespace pg::gpu::detail

#include "pg/gpu/flow_level.h"

#include "pg/core/error.h"
#include "pg/gpu/cuda_backend.h"

namespace pg::gpu {

FlowLevel::FlowLevel(DeviceKind device, const std::vector<cv::Mat1f>& from, const std::vector<cv::Mat1f>& to,
                     const cv::Mat1f& smoothness, float zeta_squared) {
  if (from.empty() || from.size() != to.size())
    throw UsageError("flow level: both images need the same, non-zero number of channels");
  for (const auto* channels : {&from, &to})
    for (const cv::Mat1f& c : *channels)
      if (c.size() != smoothness.size() || !c.isContinuous())
        throw UsageError("flow level: channels must be continuous and of the smoothness weight's size");
  if (device == DeviceKind::opencl)
    backend_ = detail::opencl_flow_level(from, to, smoothness, zeta_squared);
  else if (device == DeviceKind::cuda)
    backend_ = detail::cuda_flow_level(from, to, smoothness, zeta_squared);
  else
    throw UsageError("flow level: the device must be opencl or cuda");
}

FlowLevel::~FlowLevel() = default;

void FlowLevel::flow_increments(const cv::Mat1f& u, const cv::Mat1f& v, const FlowIncrementOptions& options,
                                cv::Mat1f& du, cv::Mat1f& dv) {
  backend_->flow_increments(u, v, options, du, dv);
}

void FlowLevel::line_increments(const cv::Mat1f& u, const cv::Mat1f& v, const cv::Mat1f& s,
                                const cv::Mat2f& direction, const FlowIncrementOptions& options,
                                cv::Mat1f& ds) {
  backend_->line_increments(u, v, s, direction, options, ds);
}

std::array<cv::Mat1f, 12> FlowLevel::tensors(const cv::Mat1f& u, const cv::Mat1f& v) {
  return backend_->tensors(u, v);
}

DeviceFootprint level_footprint(cv::Size size, int channels) {
  const std::uint64_t plane = std::uint64_t(std::max(size.area(), 0)) * sizeof(float);
  // The images' planes (six per channel and image, one buffer), and every buffer of either mode's
  // warps: tensors (12), u, v, s, direction (2), smoothness, the increments and the work planes (12).
  const std::uint64_t images = 12 * std::uint64_t(channels) * plane;
  return {images + 28 * plane, std::max(images, 6 * plane)};
}

}  // namespace pg::gpu

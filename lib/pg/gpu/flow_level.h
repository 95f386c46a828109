#pragma once
// One pyramid level of the flow solver held on the accelerated device, so that a warp runs there
// whole: the level's image derivatives are computed there once (five-point differences, as
// pg/flow/level_solver.cpp), and each warp samples the second image's derivatives at x + (u, v)
// (bilinear), builds the brightness and gradient constancy tensors and runs the fixed-point
// iterations of flow_increments.h on them; only the flow goes up and the increments come down. The
// arithmetic is the CPU reference's, in its order (no FMA contraction), so the tensors agree with
// LevelSolver's to rounding and the flows within the stated 0.01 px.
//
// The solver uses it for a level that fits the device whole and has no CLG blur of the tensors;
// otherwise the tensors stay on the CPU (flow_increments.h, in bands where needed).
#include <array>
#include <memory>
#include <opencv2/core.hpp>
#include <vector>

#include "pg/gpu/flow_increments.h"

namespace pg::gpu {

namespace detail {
class FlowLevelBackend;
}

class FlowLevel {
 public:
  // Uploads a level on `device` (opencl or cuda): the channels of both images (each rows x cols,
  // continuous, patched for NaN), the smoothness weight, and zeta^2 as the CPU solver rounds it (the
  // data terms' normalisation; 0 = off).
  // Throws FailedError when the device cannot take it. One level at a time holds the device.
  FlowLevel(DeviceKind device, const std::vector<cv::Mat1f>& from, const std::vector<cv::Mat1f>& to,
            const cv::Mat1f& smoothness, float zeta_squared);
  ~FlowLevel();
  FlowLevel(const FlowLevel&) = delete;
  FlowLevel& operator=(const FlowLevel&) = delete;

  // One warp of the free mode at flow (u, v): its increments (du, dv), reallocated to the size.
  void flow_increments(const cv::Mat1f& u, const cv::Mat1f& v, const FlowIncrementOptions& options,
                       cv::Mat1f& du, cv::Mat1f& dv);
  // One warp of the epipolar mode: the tensors at (u, v) = base + s * direction, the increment ds.
  void line_increments(const cv::Mat1f& u, const cv::Mat1f& v, const cv::Mat1f& s, const cv::Mat2f& direction,
                       const FlowIncrementOptions& options, cv::Mat1f& ds);
  // The twelve tensor planes at (u, v): brightness 11 12 22 13 23 33, then gradient (for the tests).
  std::array<cv::Mat1f, 12> tensors(const cv::Mat1f& u, const cv::Mat1f& v);

 private:
  std::unique_ptr<detail::FlowLevelBackend> backend_;
};

// Device memory a FlowLevel and its warps need, in either mode (all buffers; the largest is the
// level's images).
DeviceFootprint level_footprint(cv::Size size, int channels);

namespace detail {

// What each backend implements (flow_increments_opencl.cpp, cuda/flow_increments.cu).
class FlowLevelBackend {
 public:
  virtual ~FlowLevelBackend() = default;
  virtual void flow_increments(const cv::Mat1f& u, const cv::Mat1f& v, const FlowIncrementOptions& options,
                               cv::Mat1f& du, cv::Mat1f& dv) = 0;
  virtual void line_increments(const cv::Mat1f& u, const cv::Mat1f& v, const cv::Mat1f& s,
                               const cv::Mat2f& direction, const FlowIncrementOptions& options,
                               cv::Mat1f& ds) = 0;
  virtual std::array<cv::Mat1f, 12> tensors(const cv::Mat1f& u, const cv::Mat1f& v) = 0;
};

std::unique_ptr<FlowLevelBackend> opencl_flow_level(const std::vector<cv::Mat1f>& from,
                                                    const std::vector<cv::Mat1f>& to,
                                                    const cv::Mat1f& smoothness, float zeta_squared);

}  // namespace detail
}  // namespace pg::gpu

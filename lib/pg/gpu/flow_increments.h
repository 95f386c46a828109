#pragma once
// The inner iterations of the variational flow solver (pg/flow/level_solver.cpp) for one warp: the
// lagged-nonlinearity fixed-point iterations, each rebuilding the robust smoothness and data weights
// and solving the linearised 2x2-per-pixel system with red-black SOR sweeps. This is the solver's hot
// loop. Here the motion tensors come from the CPU; a level that fits the device whole computes them
// there too (flow_level.h). Buffers and a pinned upload area persist between warps.
//
// flow_increments_cpu is the reference (the same arithmetic as LevelSolver::solve, in float). The
// OpenCL and CUDA versions run the same float operations in the same order (no contraction into FMA,
// correctly rounded division and square root), so they agree with it to rounding: the tests accept
// 1e-4 px in (du, dv), well below the 0.01 px flow EPE tolerance.
//
// The epipolar mode (LevelSolver::solve_along) has its own scalar system: the flow is base + s * d
// with one unknown s per pixel; line_increments_* compute its increment ds the same way (CPU reference,
// OpenCL and CUDA).
//
// A level that does not fit the device is solved in horizontal bands, each with halos as tall as a
// warp's reach (increments_reach: 115 rows at the defaults) and kept only for its own rows, so the
// result is the same as in one piece; a level too wide for even one band stays on the CPU.
#include <array>
#include <cstdint>
#include <opencv2/core.hpp>

#include "pg/gpu/device.h"

namespace pg::gpu {

struct FlowIncrementOptions {
  float epsilon = 0.001f;  // Charbonnier epsilon
  float delta = 0.5f;      // brightness constancy weight
  float gamma = 5.0f;      // gradient constancy weight
  float omega = 1.6f;      // SOR over-relaxation
  int fixed_point_iterations = 5;
  int sor_iterations = 10;
};

struct FlowIncrementInput {
  // Motion tensors of brightness and gradient constancy, entries 11 12 22 13 23 33 of w^T J w for
  // w = (du, dv, 1), each rows x cols (LevelSolver's b.. and g..).
  std::array<cv::Mat1f, 6> brightness, gradient;
  cv::Mat1f smoothness;  // alpha * g(x) per pixel
  cv::Mat1f u, v;        // the flow the tensors were computed at
  FlowIncrementOptions options;
  cv::Size size() const { return u.size(); }
};

struct LineIncrementInput {
  std::array<cv::Mat1f, 6> brightness, gradient;  // as in FlowIncrementInput, at base + s * direction
  cv::Mat1f smoothness;                           // alpha * g(x) per pixel
  cv::Mat1f s;                                    // the position along the line the tensors were computed at
  cv::Mat2f direction;                            // the line direction d per pixel; non-finite: no data term
  FlowIncrementOptions options;
  cv::Size size() const { return s.size(); }
};

// The increments (du, dv) of one warp, starting from zero. du and dv are (re)allocated to the size.
void flow_increments_cpu(const FlowIncrementInput& input, cv::Mat1f& du, cv::Mat1f& dv);
void flow_increments_opencl(const FlowIncrementInput& input, cv::Mat1f& du, cv::Mat1f& dv);
// On `device` (cpu, opencl or cuda; automatic = active_device()).
void flow_increments(const FlowIncrementInput& input, cv::Mat1f& du, cv::Mat1f& dv,
                     DeviceKind device = DeviceKind::automatic);

// The increment ds of one warp of the epipolar mode, starting from zero; ds is (re)allocated.
void line_increments_cpu(const LineIncrementInput& input, cv::Mat1f& ds);
void line_increments_opencl(const LineIncrementInput& input, cv::Mat1f& ds);
// On `device` (cpu, opencl or cuda; automatic = active_device()).
void line_increments(const LineIncrementInput& input, cv::Mat1f& ds,
                     DeviceKind device = DeviceKind::automatic);

// Rows on either side that one row's increments depend on: fixed_point_iterations * (2 *
// sor_iterations + 3).
int increments_reach(const FlowIncrementOptions& options);

// Device memory one warp needs at `size`: all buffers together and the largest single one (bytes).
struct DeviceFootprint {
  std::uint64_t total = 0, largest_buffer = 0;
};
enum class IncrementMode { free, line };
DeviceFootprint increments_footprint(cv::Size size, IncrementMode mode);
// Whether that fits the device's global memory and per-allocation limit. False for a CPU DeviceInfo.
bool fits_on(const DeviceFootprint& footprint, const DeviceInfo& device);

// Rows per band for a level of `size` on `device`: the whole height when it fits in one piece, else
// an even count that fits together with two halos of increments_reach rows; 0 when not even two
// rows do (or on the CPU). flow_increments and line_increments band by it.
int increments_band_rows(cv::Size size, IncrementMode mode, const FlowIncrementOptions& options,
                         const DeviceInfo& device);

// The device `device` names (automatic = active_device()) as the flow increments see it: its memory
// capped by limit_flow_device_memory. A default DeviceInfo (kind cpu) when there is none.
DeviceInfo flow_device_info(DeviceKind device = DeviceKind::automatic);
// Caps the device memory the flow increments see (bytes; 0 = no cap), as on a smaller device: levels
// that no longer fit are solved in bands. For the tests.
void limit_flow_device_memory(std::uint64_t bytes);

// The same increments computed in bands of `band_rows` rows (even) on `device`, as for a device too
// small for the level; equal to the unbanded result. For the tests.
void flow_increments_banded(const FlowIncrementInput& input, cv::Mat1f& du, cv::Mat1f& dv, DeviceKind device,
                            int band_rows);
void line_increments_banded(const LineIncrementInput& input, cv::Mat1f& ds, DeviceKind device, int band_rows);

}  // namespace pg::gpu

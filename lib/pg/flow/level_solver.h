#pragma once
// Internal: one pyramid level of the variational flow solver (see flow.h for the energy).
#include <array>
#include <cstddef>
#include <memory>
#include <opencv2/core.hpp>
#include <vector>

#include "pg/flow/flow.h"
#include "pg/gpu/flow_increments.h"
#include "pg/gpu/flow_level.h"

namespace pg::flow_detail {

// Float planes reused from level to level. Each holds as many pixels as the largest level and is
// handed out as a continuous view of the size asked for, so solving coarse to fine allocates (and
// page-faults) the memory once instead of once per level. Views stay valid until release_all.
class PlanePool {
 public:
  // Room for largest.area() pixels and a few more per row (a SplitField's padding).
  explicit PlanePool(cv::Size largest)
      : capacity_(static_cast<std::size_t>(largest.width + split_padding) * largest.height) {}
  // An uninitialised rows x cols plane (a fresh allocation if it exceeds the capacity).
  cv::Mat1f take(int rows, int cols);
  cv::Mat1f take(cv::Size size) { return take(size.height, size.width); }
  void release_all() { used_ = 0; }

 private:
  static constexpr int split_padding = 8;
  std::size_t capacity_;
  std::size_t used_ = 0;
  std::vector<cv::Mat1f> planes_;
};

// One channel of one image at one level with the derivatives the data term needs.
struct ImageDerivatives {
  cv::Mat1f image, x, y, xx, xy, yy;
};

// A field in red-black order: each row's even and odd pixels in two contiguous arrays, with one zero
// slot at either end, so an SOR half-sweep reads and writes contiguous memory and vectorises.
class SplitField {
 public:
  void create(int rows, int cols, PlanePool& pool);  // padding zero, pixels uninitialised
  // Pixels of `parity` in row y: pixel x = 2k + parity at index k; indices -1 and count(parity) hold 0.
  float* row(int parity, int y) { return parts_[parity][y] + 1; }
  const float* row(int parity, int y) const { return parts_[parity][y] + 1; }
  int count(int parity) const { return (cols_ - parity + 1) / 2; }
  void set_zero();
  void merge_into(cv::Mat1f& field) const;
  // Pixels start .. start + n - 1 (start even) of row y, given contiguous.
  void split_block(int y, int start, int n, const float* values);

 private:
  cv::Mat1f parts_[2];
  int cols_ = 0;
};

// Both images at one level, channel by channel, and the smoothness weight of each pixel.
struct LevelImages {
  std::vector<ImageDerivatives> from, to;
  cv::Mat1f smoothness;  // alpha * g(x)
  cv::Size size() const { return from.front().image.size(); }
};

// Derivatives of both images and the smoothness weight for one level, in planes from `pool`.
LevelImages prepare_level(const std::vector<cv::Mat1f>& from, const std::vector<cv::Mat1f>& to,
                          const FlowOptions& options, PlanePool& pool);

// Solves the levels one after the other: warps, lagged fixed-point iterations and red-black SOR.
// Buffers are allocated once, for the largest level, and reused; the per-pixel loops allocate
// nothing. With an accelerated device active (pg/gpu/device.h) a level that fits the device's memory
// runs its warps there whole (pg/gpu/flow_level.h: derivatives, the warp, the tensors and the
// fixed-point iterations), in both modes; the median filter stays here. In CLG mode, or where only
// bands of the level fit, the tensors are computed here and the fixed-point iterations run there
// (pg/gpu/flow_increments.h).
class LevelSolver {
 public:
  // Levels up to `largest` pixels; `options` must outlive the solver.
  LevelSolver(cv::Size largest, const FlowOptions& options);

  // Free 2-D flow (u, v) at `images`' level, refined in place. `images` must outlive the call.
  void solve(const LevelImages& images, cv::Mat1f& u, cv::Mat1f& v);
  // Flow base + s * direction; s refined in place. NaN base: no data term there.
  void solve_along(const LevelImages& images, cv::Mat1f& s, const cv::Mat2f& base,
                   const cv::Mat2f& direction);
  // The motion tensors at flow (u, v): brightness 11 12 22 13 23 33, then gradient (for the tests
  // that compare the device's with these).
  std::array<cv::Mat1f, 12> tensors(const LevelImages& images, const cv::Mat1f& u, const cv::Mat1f& v);

 private:
  // Whether this level's increments run on the active accelerated device: one is active and the
  // level fits its memory (else the CPU reference, with a one-line notice).
  bool use_device(gpu::IncrementMode mode) const;
  // This level on the active device for whole warps, or null where it does not fit, the tensors are
  // blurred (CLG) or the upload fails (then the tensors stay here).
  std::unique_ptr<gpu::FlowLevel> device_level() const;
  // One warp's increments du_, dv_ (free mode) from the current tensors, on the CPU or the device
  // (false when the device failed: the caller falls back to the CPU).
  void cpu_increments(const cv::Mat1f& u, const cv::Mat1f& v);
  bool device_increments(const cv::Mat1f& u, const cv::Mat1f& v);
  // The same for the epipolar mode: the increment of s, in du_.
  void cpu_line_increments(const cv::Mat1f& s, const cv::Mat2f& direction);
  bool device_line_increments(const cv::Mat1f& s, const cv::Mat2f& direction);
  gpu::FlowIncrementOptions increment_options() const;
  // Warps `to` by (u, v) and fills the per-pixel motion tensors (blurred in CLG mode).
  void compute_tensors(const cv::Mat1f& u, const cv::Mat1f& v);
  // Takes this level's buffers from the pool.
  void start_level(const LevelImages& images);
  // The robust smoothness weight psi_ of each pixel from the gradient of a + da (and b + db when b
  // is non-empty).
  void compute_smoothness(const cv::Mat1f& a, const cv::Mat1f& da, const cv::Mat1f& b, const cv::Mat1f& db);
  // The edge weights of row y's pixels x in [start, start + n) to the left, right, above and below
  // (the mean of both pixels' psi, zero across the border), contiguous from index 0.
  void edge_weights(int y, int start, int n, float* left, float* right, float* up, float* down) const;
  // The same, also stored in the red-black weight fields the SOR sweeps read.
  void edge_weights_for_sor(int y, int start, int n, float* left, float* right, float* up, float* down);

  // All SOR sweeps of one fixed-point iteration: the 2-D system (free flow) or, with `second` null,
  // the scalar one (epipolar mode). Bands of rows run in parallel, each sweeping its rows in a
  // wavefront that keeps the sweeps' working set in cache; the result equals that of full
  // half-sweeps one after the other (see the definition).
  void sor_sweeps(float omega, SplitField& first, SplitField* second);
  // Half-sweep `half` (colour half & 1: the pixels with x + y = colour mod 2) on row y.
  void sor_row(int half, int y, float omega, SplitField& first, SplitField* second);
  // options_.median_radius median of a flow component or s, in place (no-op at radius 0).
  void median_filter(cv::Mat1f& field) const;

  const FlowOptions& options_;
  PlanePool pool_;
  const LevelImages* images_ = nullptr;
  int rows_ = 0, cols_ = 0;
  // Motion tensors of brightness (b..) and gradient (g..) constancy: entries 11 12 22 13 23 33 of
  // the quadratic form w^T J w in w = (du, dv, 1), already normalised and summed over channels.
  cv::Mat1f b11_, b12_, b22_, b13_, b23_, b33_, g11_, g12_, g22_, g13_, g23_, g33_;
  cv::Mat1f psi_;                   // smoothness weight of each pixel
  cv::Mat1f du_, dv_;               // increments of the current warp
  SplitField split_du_, split_dv_;  // the same, in red-black order, updated by SOR
  // The linear system of the current iteration and the smoothness weights to the left, right, above
  // and below each pixel, in red-black order.
  SplitField a11_inv_, a22_inv_, a12_, rhs1_, rhs2_, weight_l_, weight_r_, weight_u_, weight_d_;
  std::vector<float> zero_split_row_;  // neighbours beyond the first and last rows (weight 0)
};

}  // namespace pg::flow_detail

#include "pg/flow/level_solver.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <bit>
#include <climits>
#include <cmath>
#include <cstdint>
#include <limits>

#include <opencv2/imgproc.hpp>

#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/image/pyramid.h"

// A loop whose arrays GCC may assume do not overlap. Clang (the sanitizer and fuzz builds, at -O1)
// is left to its own alias checks: its spelling demands vectorisation, which -O1 does not run.
#if defined(__clang__)
#define PG_NO_ALIAS_LOOP
#else
#define PG_NO_ALIAS_LOOP _Pragma("GCC ivdep")
#endif

namespace pg::flow_detail {
namespace {

// Rows in parallel, at least ~16k pixels per task so that small levels do not drown in scheduling.
template <class RowBody>
void for_rows(int rows, int cols, const RowBody& body) {
  const int grain = std::max(1, 16384 / std::max(cols, 1));
  tbb::parallel_for(tbb::blocked_range<int>(0, rows, grain), [&](const tbb::blocked_range<int>& range) {
    for (int y = range.begin(); y != range.end(); ++y) body(y);
  });
}

// The SOR rows are the solver's hottest loops: where the CPU has AVX2, a clone using it runs (chosen
// once at load time). AVX2 without FMA computes the same float operations, so the result is the same.
#if defined(__GNUC__) && defined(__x86_64__) && !defined(__clang__)
#define PG_HOT_LOOP __attribute__((target_clones("avx2", "default")))
#else
#define PG_HOT_LOOP
#endif

// One row of a red-black SOR half-sweep of the 2-D system, n pixels of one colour. `*_side` hold the
// row's other colour shifted so that [k] and [k + 1] are the left and right neighbours of pixel k;
// `*_up` and `*_down` the same colour in the rows above and below. The arithmetic (and so the
// result) matches the per-pixel form: neighbours summed left, right, up, down.
PG_HOT_LOOP void sor_row_2d(int n, float keep, float omega, float* __restrict du, float* __restrict dv,
                            const float* __restrict du_side, const float* __restrict du_up,
                            const float* __restrict du_down, const float* __restrict dv_side,
                            const float* __restrict dv_up, const float* __restrict dv_down,
                            const float* __restrict wl, const float* __restrict wr,
                            const float* __restrict wu, const float* __restrict wd,
                            const float* __restrict a11_inv, const float* __restrict a22_inv,
                            const float* __restrict a12, const float* __restrict rhs1,
                            const float* __restrict rhs2) {
  for (int k = 0; k < n; ++k) {
    const float du_sum = wl[k] * du_side[k] + wr[k] * du_side[k + 1] + wu[k] * du_up[k] + wd[k] * du_down[k];
    const float du_new = keep * du[k] + omega * (rhs1[k] + du_sum - a12[k] * dv[k]) * a11_inv[k];
    du[k] = du_new;
    const float dv_sum = wl[k] * dv_side[k] + wr[k] * dv_side[k + 1] + wu[k] * dv_up[k] + wd[k] * dv_down[k];
    dv[k] = keep * dv[k] + omega * (rhs2[k] + dv_sum - a12[k] * du_new) * a22_inv[k];
  }
}

// The same for the scalar system of the epipolar mode.
PG_HOT_LOOP void sor_row_1d(int n, float keep, float omega, float* __restrict ds,
                            const float* __restrict side, const float* __restrict up,
                            const float* __restrict down, const float* __restrict wl,
                            const float* __restrict wr, const float* __restrict wu,
                            const float* __restrict wd, const float* __restrict a_inv,
                            const float* __restrict rhs) {
  for (int k = 0; k < n; ++k) {
    const float sum = wl[k] * side[k] + wr[k] * side[k + 1] + wu[k] * up[k] + wd[k] * down[k];
    ds[k] = keep * ds[k] + omega * (rhs[k] + sum) * a_inv[k];
  }
}

// Five-point central difference (1, -8, 0, 8, -1) / 12 along x, borders replicated.
void derivative_x(const cv::Mat1f& image, cv::Mat1f& out) {
  const int cols = image.cols;
  for_rows(image.rows, cols, [&](int y) {
    const float* in = image[y];
    float* row = out[y];
    const auto at = [&](int x) { return in[std::clamp(x, 0, cols - 1)]; };
    for (int x = 0; x < cols; ++x) {
      if (x >= 2 && x < cols - 2)
        row[x] = (in[x - 2] - 8 * in[x - 1] + 8 * in[x + 1] - in[x + 2]) * (1.f / 12);
      else
        row[x] = (at(x - 2) - 8 * at(x - 1) + 8 * at(x + 1) - at(x + 2)) * (1.f / 12);
    }
  });
}

void derivative_y(const cv::Mat1f& image, cv::Mat1f& out) {
  const int cols = image.cols, rows = image.rows;
  for_rows(rows, cols, [&](int y) {
    const float* m2 = image[std::max(y - 2, 0)];
    const float* m1 = image[std::max(y - 1, 0)];
    const float* p1 = image[std::min(y + 1, rows - 1)];
    const float* p2 = image[std::min(y + 2, rows - 1)];
    float* row = out[y];
    for (int x = 0; x < cols; ++x) row[x] = (m2[x] - 8 * m1[x] + 8 * p1[x] - p2[x]) * (1.f / 12);
  });
}

// Charbonnier derivative psi'(s^2) = 1 / (2 sqrt(s^2 + eps^2)), times a weight.
inline float robust_weight(float weight, float squared, float epsilon_squared) {
  return weight * 0.5f / std::sqrt(std::max(squared, 0.f) + epsilon_squared);
}

// value where mask is all ones, +0 where it is zero: a select without a branch (vectorises).
inline float keep_if(std::uint32_t mask, float value) {
  return std::bit_cast<float>(std::bit_cast<std::uint32_t>(value) & mask);
}

// All ones for a finite value, zero for infinity and NaN.
inline std::uint32_t finite_mask(float value) {
  return std::abs(value) <= std::numeric_limits<float>::max() ? ~0u : 0u;
}

// w^T J w for w = (du, dv, 1) and J given by its entries 11 12 22 13 23 33.
inline float quadratic(float j11, float j12, float j22, float j13, float j23, float j33, float du, float dv) {
  return j11 * du * du + 2 * j12 * du * dv + j22 * dv * dv + 2 * j13 * du + 2 * j23 * dv + j33;
}

// Pixels per block of the system assembly (even: blocks start at even x, as the red-black split needs).
constexpr int system_block = 256;

// The left and right neighbours of the row block's pixels x = start .. start + n - 1, contiguous
// (the pixel itself at the row's ends, where the weight is zero), so that the system's loops run
// without index clamps and vectorise.
void neighbour_values(const float* row, int start, int n, int cols, float* left, float* right) {
  for (int i = 0; i < n; ++i) {
    const int x = start + i;
    left[i] = row[x > 0 ? x - 1 : x];
    right[i] = row[x + 1 < cols ? x + 1 : x];
  }
}

}  // namespace

cv::Mat1f PlanePool::take(int rows, int cols) {
  if (static_cast<std::size_t>(rows) * static_cast<std::size_t>(cols) > capacity_)
    return cv::Mat1f(rows, cols);
  if (used_ == planes_.size()) planes_.emplace_back(1, static_cast<int>(capacity_));
  return cv::Mat1f(rows, cols, planes_[used_++].ptr<float>());
}

LevelImages prepare_level(const std::vector<cv::Mat1f>& from, const std::vector<cv::Mat1f>& to,
                          const FlowOptions& options, PlanePool& pool) {
  LevelImages level;
  const cv::Size size = from.front().size();
  const auto derivatives = [&](const cv::Mat1f& image, ImageDerivatives& d) {
    d.image = image;
    for (cv::Mat1f* m : {&d.x, &d.y, &d.xx, &d.xy, &d.yy}) *m = pool.take(size);
    derivative_x(image, d.x);
    derivative_y(image, d.y);
    derivative_x(d.x, d.xx);
    derivative_y(d.x, d.xy);
    derivative_y(d.y, d.yy);
  };
  level.from.resize(from.size());
  level.to.resize(to.size());
  for (std::size_t c = 0; c < from.size(); ++c) {
    derivatives(from[c], level.from[c]);
    derivatives(to[c], level.to[c]);
  }
  level.smoothness = pool.take(size);
  level.smoothness.setTo(static_cast<float>(options.alpha));
  if (options.edge_weight > 0) {
    const float k = static_cast<float>(options.edge_weight), alpha = static_cast<float>(options.alpha);
    const float channel_share = 1.f / static_cast<float>(from.size());
    for_rows(size.height, size.width, [&](int y) {
      float* row = level.smoothness[y];
      for (int x = 0; x < size.width; ++x) {
        float squared = 0;
        for (const ImageDerivatives& d : level.from) squared += d.x(y, x) * d.x(y, x) + d.y(y, x) * d.y(y, x);
        row[x] = alpha * std::exp(-k * std::sqrt(squared * channel_share));
      }
    });
  }
  return level;
}

void SplitField::create(int rows, int cols, PlanePool& pool) {
  cols_ = cols;
  // Both parts in one pooled plane: 2 * rows * ((cols + 1) / 2 + 2) floats fit a plane's capacity.
  const cv::Mat1f both = pool.take(2 * rows, (cols + 1) / 2 + 2);
  for (int parity = 0; parity < 2; ++parity) {
    cv::Mat1f& part = parts_[parity];
    part = both.rowRange(parity * rows, (parity + 1) * rows);
    for (int y = 0; y < rows; ++y) part(y, 0) = part(y, count(parity) + 1) = 0.f;
  }
}

void SplitField::split_block(int y, int start, int n, const float* values) {
  float* even = row(0, y) + start / 2;
  float* odd = row(1, y) + start / 2;
  for (int k = 0; 2 * k < n; ++k) even[k] = values[2 * k];
  for (int k = 0; 2 * k + 1 < n; ++k) odd[k] = values[2 * k + 1];
}

void SplitField::set_zero() {
  for (cv::Mat1f& part : parts_) part.setTo(0);
}

void SplitField::merge_into(cv::Mat1f& field) const {
  for_rows(field.rows, field.cols, [&](int y) {
    const float* even = row(0, y);
    const float* odd = row(1, y);
    float* out = field[y];
    // Two strided loops rather than picking a row per pixel: GCC folds that pick into a pointer offset
    // between the two rows, which UBSan reports as a pointer overflow.
    for (int k = 0; 2 * k < field.cols; ++k) out[2 * k] = even[k];
    for (int k = 0; 2 * k + 1 < field.cols; ++k) out[2 * k + 1] = odd[k];
  });
}

LevelSolver::LevelSolver(cv::Size largest, const FlowOptions& options) : options_(options), pool_(largest) {}

void LevelSolver::start_level(const LevelImages& images) {
  images_ = &images;
  rows_ = images.size().height, cols_ = images.size().width;
  pool_.release_all();
  for (cv::Mat1f* m : {&b11_, &b12_, &b22_, &b13_, &b23_, &b33_, &g11_, &g12_, &g22_, &g13_, &g23_, &g33_,
                       &psi_, &du_, &dv_})
    *m = pool_.take(rows_, cols_);
  for (SplitField* f : {&split_du_, &split_dv_, &a11_inv_, &a22_inv_, &a12_, &rhs1_, &rhs2_, &weight_l_,
                        &weight_r_, &weight_u_, &weight_d_})
    f->create(rows_, cols_, pool_);
  zero_split_row_.assign((cols_ + 1) / 2 + 2, 0.f);
}

void LevelSolver::compute_tensors(const cv::Mat1f& u, const cv::Mat1f& v) {
  const float zeta_squared = static_cast<float>(options_.zeta * options_.zeta);
  const bool normalise = options_.zeta > 0;
  const int border = 4;  // reach of the second-derivative stencils
  const float max_x = static_cast<float>(cols_ - 1), max_y = static_cast<float>(rows_ - 1);
  cv::Mat1f* const outputs[12] = {&b11_, &b12_, &b22_, &b13_, &b23_, &b33_,
                                  &g11_, &g12_, &g22_, &g13_, &g23_, &g33_};
  // Blocks of a row: bilinear taps gathered first, then the tensor arithmetic runs vectorised over the
  // block (per pixel the same operations in the same order as a per-pixel loop).
  constexpr int block = 128;
  for_rows(rows_, cols_, [&](int y) {
    const float* u_row = u[y];
    const float* v_row = v[y];
    const bool interior_row = y >= border && y < rows_ - border;
    for (int start = 0; start < cols_; start += block) {
      const int n = std::min(block, cols_ - start);
      int offset[block];                                     // of the top-left tap, in floats
      float w00[block], w01[block], w10[block], w11[block];  // tap weights
      // Outside the image (or NaN) the data term is off and smoothness fills in. Within reach of the
      // border the second derivatives see replicated pixels: gradient constancy is off there.
      std::uint32_t valid[block], interior[block];  // all ones or zero
      for (int i = 0; i < n; ++i) {
        const int x = start + i;
        const float wx = static_cast<float>(x) + u_row[x], wy = static_cast<float>(y) + v_row[x];
        const bool inside = wx >= 0 && wx <= max_x && wy >= 0 && wy <= max_y;
        valid[i] = inside ? ~0u : 0u;
        interior[i] = inside && interior_row && x >= border && x < cols_ - border ? ~0u : 0u;
        if (!valid[i]) {
          offset[i] = 0, w00[i] = w01[i] = w10[i] = w11[i] = 0;
          continue;
        }
        const int x0 = std::min(static_cast<int>(wx), cols_ - 2),
                  y0 = std::min(static_cast<int>(wy), rows_ - 2);
        const float ax = wx - static_cast<float>(x0), ay = wy - static_cast<float>(y0);
        w00[i] = (1 - ax) * (1 - ay), w01[i] = ax * (1 - ay), w10[i] = (1 - ax) * ay, w11[i] = ax * ay;
        offset[i] = y0 * cols_ + x0;
      }
      float t[12][block] = {};  // b11 b12 b22 b13 b23 b33 g11 g12 g22 g13 g23 g33
      for (std::size_t c = 0; c < images_->from.size(); ++c) {
        const ImageDerivatives& i1 = images_->from[c];
        const ImageDerivatives& i2 = images_->to[c];
        // `to` and its derivatives warped back onto `from`.
        float s_image[block], s_x[block], s_y[block], s_xx[block], s_xy[block], s_yy[block];
        const auto gather = [&](const cv::Mat1f& m, float* out) {
          const float* data = m[0];
          for (int i = 0; i < n; ++i) {
            const float* r0 = data + offset[i];
            const float* r1 = r0 + cols_;
            out[i] = w00[i] * r0[0] + w01[i] * r0[1] + w10[i] * r1[0] + w11[i] * r1[1];
          }
        };
        gather(i2.image, s_image), gather(i2.x, s_x), gather(i2.y, s_y);
        gather(i2.xx, s_xx), gather(i2.xy, s_xy), gather(i2.yy, s_yy);
        const float *i1_image = i1.image[y] + start, *i1_x = i1.x[y] + start, *i1_y = i1.y[y] + start;
        const float *i1_xx = i1.xx[y] + start, *i1_xy = i1.xy[y] + start, *i1_yy = i1.yy[y] + start;
        // The normalisation switch is a template parameter: no branch inside the vectorised loop.
        const auto accumulate = [&]<bool Normalise>() {
          for (int i = 0; i < n; ++i) {
            // Spatial derivatives of the linearisation are averaged over both images (symmetric).
            const float i2x = s_x[i], i2y = s_y[i];
            const float i1x = i1_x[i], i1y = i1_y[i];
            // Brightness constancy: It + Ix du + Iy dv, normalised by the local gradient energy.
            const float ix = 0.5f * (i1x + i2x), iy = 0.5f * (i1y + i2y), it = s_image[i] - i1_image[i];
            const float nb = Normalise ? 1.f / (ix * ix + iy * iy + zeta_squared) : 1.f;
            const std::uint32_t on = valid[i];
            t[0][i] += keep_if(on, nb * ix * ix), t[1][i] += keep_if(on, nb * ix * iy);
            t[2][i] += keep_if(on, nb * iy * iy), t[3][i] += keep_if(on, nb * ix * it);
            t[4][i] += keep_if(on, nb * iy * it), t[5][i] += keep_if(on, nb * it * it);
            // Gradient constancy: (Ixt + Ixx du + Ixy dv, Iyt + Ixy du + Iyy dv), each part normalised.
            const float ixx = 0.5f * (i1_xx[i] + s_xx[i]), ixy = 0.5f * (i1_xy[i] + s_xy[i]);
            const float iyy = 0.5f * (i1_yy[i] + s_yy[i]);
            const float ixt = i2x - i1x, iyt = i2y - i1y;
            const float ngx = Normalise ? 1.f / (ixx * ixx + ixy * ixy + zeta_squared) : 1.f;
            const float ngy = Normalise ? 1.f / (ixy * ixy + iyy * iyy + zeta_squared) : 1.f;
            const std::uint32_t gradient = interior[i];
            t[6][i] += keep_if(gradient, ngx * ixx * ixx + ngy * ixy * ixy);
            t[7][i] += keep_if(gradient, ngx * ixx * ixy + ngy * ixy * iyy);
            t[8][i] += keep_if(gradient, ngx * ixy * ixy + ngy * iyy * iyy);
            t[9][i] += keep_if(gradient, ngx * ixx * ixt + ngy * ixy * iyt);
            t[10][i] += keep_if(gradient, ngx * ixy * ixt + ngy * iyy * iyt);
            t[11][i] += keep_if(gradient, ngx * ixt * ixt + ngy * iyt * iyt);
          }
        };
        if (normalise)
          accumulate.template operator()<true>();
        else
          accumulate.template operator()<false>();
      }
      for (int k = 0; k < 12; ++k) std::copy(t[k], t[k] + n, (*outputs[k])[y] + start);
    }
  });
  if (options_.clg_rho > 0)
    for (cv::Mat1f* m : {&b11_, &b12_, &b22_, &b13_, &b23_, &b33_, &g11_, &g12_, &g22_, &g13_, &g23_, &g33_})
      *m = gaussian_blur(*m, options_.clg_rho);
}

void LevelSolver::compute_smoothness(const cv::Mat1f& a, const cv::Mat1f& da, const cv::Mat1f& b,
                                     const cv::Mat1f& db) {
  const float epsilon_squared = static_cast<float>(options_.epsilon * options_.epsilon);
  const bool two = !b.empty();
  const int last = cols_ - 1;
  for_rows(rows_, cols_, [&](int y) {
    const int yn = std::min(y + 1, rows_ - 1);
    float* psi = psi_[y];
    const float* weight = images_->smoothness[y];
    const float *a_row = a[y], *da_row = da[y], *a_below = a[yn], *da_below = da[yn];
    const float *b_row = two ? b[y] : a_row, *db_row = two ? db[y] : da_row;
    const float *b_below = two ? b[yn] : a_below, *db_below = two ? db[yn] : da_below;
    // Forward differences; the last column's right neighbour is itself (xn = x).
    const auto at = [&]<bool Two>(int x, int xn) {
      const float a0 = a_row[x] + da_row[x];
      const float ax = a_row[xn] + da_row[xn] - a0, ay = a_below[x] + da_below[x] - a0;
      float squared = ax * ax + ay * ay;
      if (Two) {
        const float b0 = b_row[x] + db_row[x];
        const float bx = b_row[xn] + db_row[xn] - b0, by = b_below[x] + db_below[x] - b0;
        squared += bx * bx + by * by;
      }
      psi[x] = robust_weight(weight[x], squared, epsilon_squared);
    };
    const auto run = [&]<bool Two>() {
      for (int x = 0; x < last; ++x) at.template operator()<Two>(x, x + 1);
      at.template operator()<Two>(last, last);
    };
    if (two)
      run.template operator()<true>();
    else
      run.template operator()<false>();
  });
}

void LevelSolver::edge_weights(int y, int start, int n, float* left, float* right, float* up,
                               float* down) const {
  const float* psi = psi_[y] + start;
  const float* above = y > 0 ? psi_[y - 1] + start : nullptr;
  const float* below = y + 1 < rows_ ? psi_[y + 1] + start : nullptr;
  // Right and left of the block's interior; the row's first and last pixels have no left / right.
  const int first = start == 0 ? 1 : 0, end = start + n == cols_ ? n - 1 : n;
  for (int i = 0; i < end; ++i) right[i] = 0.5f * (psi[i] + psi[i + 1]);
  if (end < n) right[n - 1] = 0.f;
  for (int i = first; i < n; ++i) left[i] = 0.5f * (psi[i - 1] + psi[i]);
  if (first) left[0] = 0.f;
  if (above)
    for (int i = 0; i < n; ++i) up[i] = 0.5f * (above[i] + psi[i]);
  else
    std::fill(up, up + n, 0.f);
  if (below)
    for (int i = 0; i < n; ++i) down[i] = 0.5f * (psi[i] + below[i]);
  else
    std::fill(down, down + n, 0.f);
}

void LevelSolver::edge_weights_for_sor(int y, int start, int n, float* left, float* right, float* up,
                                       float* down) {
  edge_weights(y, start, n, left, right, up, down);
  weight_l_.split_block(y, start, n, left);
  weight_r_.split_block(y, start, n, right);
  weight_u_.split_block(y, start, n, up);
  weight_d_.split_block(y, start, n, down);
}

void LevelSolver::sor_row(int half, int y, float omega, SplitField& first, SplitField* second) {
  const float keep = 1 - omega;
  const int parity = (y + half) & 1, other = 1 - parity, n = first.count(parity);
  // Beyond the first and last rows the weight is zero; any finite neighbour value does.
  const auto up = [&](const SplitField& f) { return y > 0 ? f.row(parity, y - 1) : zero_split_row_.data(); };
  const auto down = [&](const SplitField& f) {
    return y + 1 < rows_ ? f.row(parity, y + 1) : zero_split_row_.data();
  };
  const auto side = [&](const SplitField& f) { return f.row(other, y) + parity - 1; };
  if (second)
    sor_row_2d(n, keep, omega, first.row(parity, y), second->row(parity, y), side(first), up(first),
               down(first), side(*second), up(*second), down(*second), weight_l_.row(parity, y),
               weight_r_.row(parity, y), weight_u_.row(parity, y), weight_d_.row(parity, y),
               a11_inv_.row(parity, y), a22_inv_.row(parity, y), a12_.row(parity, y), rhs1_.row(parity, y),
               rhs2_.row(parity, y));
  else
    sor_row_1d(n, keep, omega, first.row(parity, y), side(first), up(first), down(first),
               weight_l_.row(parity, y), weight_r_.row(parity, y), weight_u_.row(parity, y),
               weight_d_.row(parity, y), a11_inv_.row(parity, y), rhs1_.row(parity, y));
}

// Red-black SOR in a wavefront. Half-sweep h updates the pixels of colour h & 1 of each row from the
// other colour's pixels in the row and the rows above and below, as left by half-sweep h - 1. Row y's
// half-sweep h may therefore run once rows y - 1, y, y + 1 have had half-sweep h - 1 and before rows
// y - 1 and y + 1 have had h + 1 (which would overwrite those neighbours). Visiting (h, y) by
// increasing t = y + h, and h increasing within one t, meets both conditions, so the result is
// exactly that of full half-sweeps one after the other, while only about `halves` rows are live at a
// time (in cache). Bands of rows run in parallel: first each band's rows that depend on no other band
// (at half-sweep h, all but the h rows next to each inner band edge), then the strips around each inner
// edge (rows edge - h to edge + h - 1 at half-sweep h), which only depend on finished work. Neither
// the band count nor the thread count changes any value.
void LevelSolver::sor_sweeps(float omega, SplitField& first, SplitField* second) {
  const int halves = 2 * options_.sor_iterations;
  // Rows in [lo(h), hi(h)) at each half-sweep h, in wavefront order.
  const auto wavefront = [&](const auto& lo, const auto& hi) {
    int t_begin = INT_MAX, t_end = INT_MIN;
    for (int h = 0; h < halves; ++h)
      if (lo(h) < hi(h)) t_begin = std::min(t_begin, lo(h) + h), t_end = std::max(t_end, hi(h) + h);
    for (int t = t_begin; t < t_end; ++t)
      for (int h = std::max(0, t - rows_ + 1); h < halves && h <= t; ++h) {
        const int y = t - h;
        if (y >= lo(h) && y < hi(h)) sor_row(h, y, omega, first, second);
      }
  };
  // Bands at least 3 * halves rows high: the edge strips (2 * halves - 2 rows at most) stay apart.
  const int bands = std::clamp(rows_ / std::max(3 * halves, 64), 1, 16);
  const auto edge = [&](int band) {
    return static_cast<int>(static_cast<std::int64_t>(rows_) * band / bands);
  };
  tbb::parallel_for(0, bands, [&](int band) {
    const int top = edge(band), bottom = edge(band + 1);
    wavefront([&](int h) { return top == 0 ? 0 : top + h; },
              [&](int h) { return bottom == rows_ ? rows_ : bottom - h; });
  });
  tbb::parallel_for(1, bands, [&](int band) {
    const int middle = edge(band);
    wavefront([&](int h) { return middle - h; }, [&](int h) { return middle + h; });
  });
}

void LevelSolver::median_filter(cv::Mat1f& field) const {
  if (options_.median_radius == 0) return;
  cv::Mat1f filtered;
  cv::medianBlur(field, filtered, 2 * options_.median_radius + 1);
  field = filtered;
}

namespace {

// The device kernels take continuous planes; a view into a larger matrix is copied.
cv::Mat1f continuous(const cv::Mat1f& m) {
  return m.isContinuous() ? m : cv::Mat1f(m.clone());
}

// Runs a device step; a device failure (out of device memory, a driver error) is not fatal: the
// caller solves the level on the CPU instead, after a warning.
template <class Step>
bool run_on_device(const Step& step) {
  try {
    step();
    return true;
  } catch (const FailedError& e) {
    log::warn(e.what(), "; solving the rest of this level on the CPU");
    return false;
  }
}

}  // namespace

bool LevelSolver::use_device(gpu::IncrementMode mode) const {
  if (gpu::active_device() == gpu::DeviceKind::cpu) return false;
  const gpu::DeviceInfo device = gpu::flow_device_info();
  const int band_rows = gpu::increments_band_rows(images_->size(), mode, increment_options(), device);
  if (band_rows >= rows_) return true;
  const gpu::DeviceFootprint need = gpu::increments_footprint(images_->size(), mode);
  const std::string what =
      str("flow: a ", cols_, "x", rows_, " level needs ", need.total >> 20, " MiB (largest buffer ",
          need.largest_buffer >> 20, " MiB) but ", device.name, " has ", device.global_memory >> 20,
          " MiB (largest allocation ", device.max_allocation >> 20, " MiB); ");
  if (band_rows > 0) {
    log::info(what, "solving it on the device in bands of ", band_rows, " rows");
    return true;
  }
  log::info(what, "solving it on the CPU");
  return false;
}

gpu::FlowIncrementOptions LevelSolver::increment_options() const {
  gpu::FlowIncrementOptions o;
  o.epsilon = static_cast<float>(options_.epsilon);
  o.delta = static_cast<float>(options_.delta);
  o.gamma = static_cast<float>(options_.gamma);
  o.omega = static_cast<float>(options_.sor_omega);
  o.fixed_point_iterations = options_.fixed_point_iterations;
  o.sor_iterations = options_.sor_iterations;
  return o;
}

bool LevelSolver::device_increments(const cv::Mat1f& u, const cv::Mat1f& v) {
  gpu::FlowIncrementInput in;
  in.brightness = {continuous(b11_), continuous(b12_), continuous(b22_),
                   continuous(b13_), continuous(b23_), continuous(b33_)};
  in.gradient = {continuous(g11_), continuous(g12_), continuous(g22_),
                 continuous(g13_), continuous(g23_), continuous(g33_)};
  in.smoothness = continuous(images_->smoothness);
  in.u = continuous(u), in.v = continuous(v);
  in.options = increment_options();
  return run_on_device([&] { gpu::flow_increments(in, du_, dv_); });
}

bool LevelSolver::device_line_increments(const cv::Mat1f& s, const cv::Mat2f& direction) {
  gpu::LineIncrementInput in;
  in.brightness = {continuous(b11_), continuous(b12_), continuous(b22_),
                   continuous(b13_), continuous(b23_), continuous(b33_)};
  in.gradient = {continuous(g11_), continuous(g12_), continuous(g22_),
                 continuous(g13_), continuous(g23_), continuous(g33_)};
  in.smoothness = continuous(images_->smoothness);
  in.s = continuous(s);
  in.direction = direction.isContinuous() ? direction : cv::Mat2f(direction.clone());
  in.options = increment_options();
  return run_on_device([&] { gpu::line_increments(in, du_); });
}

std::unique_ptr<gpu::FlowLevel> LevelSolver::device_level() const {
  if (options_.clg_rho > 0) return nullptr;
  const int channels = static_cast<int>(images_->from.size());
  if (!gpu::fits_on(gpu::level_footprint(images_->size(), channels), gpu::flow_device_info())) return nullptr;
  std::vector<cv::Mat1f> from, to;
  for (int c = 0; c < channels; ++c) {
    from.push_back(continuous(images_->from[c].image));
    to.push_back(continuous(images_->to[c].image));
  }
  try {
    return std::make_unique<gpu::FlowLevel>(gpu::active_device(), from, to, continuous(images_->smoothness),
                                            static_cast<float>(options_.zeta * options_.zeta));
  } catch (const FailedError& e) {
    log::debug(e.what(), "; computing this level's tensors on the CPU");
    return nullptr;
  }
}

std::array<cv::Mat1f, 12> LevelSolver::tensors(const LevelImages& images, const cv::Mat1f& u,
                                               const cv::Mat1f& v) {
  start_level(images);
  compute_tensors(u, v);
  return {b11_.clone(), b12_.clone(), b22_.clone(), b13_.clone(), b23_.clone(), b33_.clone(),
          g11_.clone(), g12_.clone(), g22_.clone(), g13_.clone(), g23_.clone(), g33_.clone()};
}

void LevelSolver::solve(const LevelImages& images, cv::Mat1f& u, cv::Mat1f& v) {
  start_level(images);
  bool on_device = use_device(gpu::IncrementMode::free);
  std::unique_ptr<gpu::FlowLevel> level = on_device ? device_level() : nullptr;
  for (int warp = 0; warp < options_.warps; ++warp) {
    if (level && !run_on_device([&] { level->flow_increments(u, v, increment_options(), du_, dv_); }))
      level.reset(), on_device = false;
    if (!level) {
      compute_tensors(u, v);
      on_device = on_device && device_increments(u, v);
      if (!on_device) cpu_increments(u, v);
    }
    u += du_;
    v += dv_;
    median_filter(u);
    median_filter(v);
  }
}

void LevelSolver::cpu_increments(const cv::Mat1f& u, const cv::Mat1f& v) {
  const float epsilon_squared = static_cast<float>(options_.epsilon * options_.epsilon);
  const float delta = static_cast<float>(options_.delta), gamma = static_cast<float>(options_.gamma);
  const float omega = static_cast<float>(options_.sor_omega);
  const float damping = 1e-6f;  // keeps the diagonal positive where data and smoothness both vanish
  du_.setTo(0);
  dv_.setTo(0);
  split_du_.set_zero();
  split_dv_.set_zero();
  for (int iteration = 0; iteration < options_.fixed_point_iterations; ++iteration) {
    compute_smoothness(u, du_, v, dv_);
    // The linear system of this iteration, robust weights frozen (lagged nonlinearity), by blocks
    // of a row: contiguous and vectorised, then split into red-black order.
    for_rows(rows_, cols_, [&](int y) {
      const float *b11 = b11_[y], *b12 = b12_[y], *b22 = b22_[y], *b13 = b13_[y], *b23 = b23_[y],
                  *b33 = b33_[y];
      const float *g11 = g11_[y], *g12 = g12_[y], *g22 = g22_[y], *g13 = g13_[y], *g23 = g23_[y],
                  *g33 = g33_[y];
      const float *du_row = du_[y], *dv_row = dv_[y], *u_row = u[y], *v_row = v[y];
      const float *u_up = u[y > 0 ? y - 1 : y], *u_down = u[y + 1 < rows_ ? y + 1 : y];
      const float *v_up = v[y > 0 ? y - 1 : y], *v_down = v[y + 1 < rows_ ? y + 1 : y];
      for (int start = 0; start < cols_; start += system_block) {
        const int n = std::min(system_block, cols_ - start);
        float left[system_block], right[system_block], up[system_block], down[system_block];
        edge_weights_for_sor(y, start, n, left, right, up, down);
        float u_left[system_block], u_right[system_block], v_left[system_block], v_right[system_block];
        neighbour_values(u_row, start, n, cols_, u_left, u_right);
        neighbour_values(v_row, start, n, cols_, v_left, v_right);
        float a11_inv[system_block], a22_inv[system_block], a12[system_block], rhs1[system_block],
            rhs2[system_block];
        // The block's arrays and the planes never overlap: no alias checks (too many to vectorise).
        PG_NO_ALIAS_LOOP
        for (int i = 0; i < n; ++i) {
          const int x = start + i;
          const float du = du_row[x], dv = dv_row[x];
          const float psi_b = robust_weight(
              delta, quadratic(b11[x], b12[x], b22[x], b13[x], b23[x], b33[x], du, dv), epsilon_squared);
          const float psi_g = robust_weight(
              gamma, quadratic(g11[x], g12[x], g22[x], g13[x], g23[x], g33[x], du, dv), epsilon_squared);
          const float total = left[i] + right[i] + down[i] + up[i];
          a11_inv[i] = 1.f / (psi_b * b11[x] + psi_g * g11[x] + total + damping);
          a22_inv[i] = 1.f / (psi_b * b22[x] + psi_g * g22[x] + total + damping);
          a12[i] = psi_b * b12[x] + psi_g * g12[x];
          rhs1[i] = left[i] * u_left[i] + right[i] * u_right[i] + up[i] * u_up[x] + down[i] * u_down[x] -
                    total * u_row[x] - (psi_b * b13[x] + psi_g * g13[x]);
          rhs2[i] = left[i] * v_left[i] + right[i] * v_right[i] + up[i] * v_up[x] + down[i] * v_down[x] -
                    total * v_row[x] - (psi_b * b23[x] + psi_g * g23[x]);
        }
        a11_inv_.split_block(y, start, n, a11_inv);
        a22_inv_.split_block(y, start, n, a22_inv);
        a12_.split_block(y, start, n, a12);
        rhs1_.split_block(y, start, n, rhs1);
        rhs2_.split_block(y, start, n, rhs2);
      }
    });
    // Red-black: pixels of one colour only depend on the other, so bands of rows run in parallel and
    // the result does not depend on the thread count.
    sor_sweeps(omega, split_du_, &split_dv_);
    split_du_.merge_into(du_);
    split_dv_.merge_into(dv_);
  }
}

void LevelSolver::solve_along(const LevelImages& images, cv::Mat1f& s, const cv::Mat2f& base,
                              const cv::Mat2f& direction) {
  start_level(images);
  bool on_device = use_device(gpu::IncrementMode::line);
  std::unique_ptr<gpu::FlowLevel> level = on_device ? device_level() : nullptr;
  const cv::Mat2f continuous_direction = direction.isContinuous() ? direction : cv::Mat2f(direction.clone());
  cv::Mat1f u = pool_.take(rows_, cols_), v = pool_.take(rows_, cols_);
  cv::Mat1f& ds = du_;  // the increment of s; dv_ is unused in this mode
  for (int warp = 0; warp < options_.warps; ++warp) {
    for_rows(rows_, cols_, [&](int y) {
      for (int x = 0; x < cols_; ++x) {
        const cv::Vec2f b = base(y, x), d = direction(y, x);
        // NaN flow puts the warped position outside the image: no data term there.
        u(y, x) = b[0] + s(y, x) * d[0];
        v(y, x) = b[1] + s(y, x) * d[1];
      }
    });
    if (level && !run_on_device([&] {
          level->line_increments(u, v, continuous(s), continuous_direction, increment_options(), du_);
        }))
      level.reset(), on_device = false;
    if (!level) {
      compute_tensors(u, v);
      on_device = on_device && device_line_increments(s, direction);
      if (!on_device) cpu_line_increments(s, direction);
    }
    s += ds;
    median_filter(s);
  }
}

void LevelSolver::cpu_line_increments(const cv::Mat1f& s, const cv::Mat2f& direction) {
  const float epsilon_squared = static_cast<float>(options_.epsilon * options_.epsilon);
  const float delta = static_cast<float>(options_.delta), gamma = static_cast<float>(options_.gamma);
  const float omega = static_cast<float>(options_.sor_omega);
  const float damping = 1e-6f;  // keeps the diagonal positive where data and smoothness both vanish
  cv::Mat1f& ds = du_;
  ds.setTo(0);
  split_du_.set_zero();
  for (int iteration = 0; iteration < options_.fixed_point_iterations; ++iteration) {
    compute_smoothness(s, ds, cv::Mat1f(), cv::Mat1f());
    for_rows(rows_, cols_, [&](int y) {
      const float *b11 = b11_[y], *b12 = b12_[y], *b22 = b22_[y], *b13 = b13_[y], *b23 = b23_[y],
                  *b33 = b33_[y];
      const float *g11 = g11_[y], *g12 = g12_[y], *g22 = g22_[y], *g13 = g13_[y], *g23 = g23_[y],
                  *g33 = g33_[y];
      const float* directions = direction.ptr<float>(y);  // x and y of each pixel's direction
      const float *ds_row = ds[y], *s_row = s[y];
      const float *s_up = s[y > 0 ? y - 1 : y], *s_down = s[y + 1 < rows_ ? y + 1 : y];
      for (int start = 0; start < cols_; start += system_block) {
        const int n = std::min(system_block, cols_ - start);
        float left[system_block], right[system_block], up[system_block], down[system_block];
        edge_weights_for_sor(y, start, n, left, right, up, down);
        float s_left[system_block], s_right[system_block];
        neighbour_values(s_row, start, n, cols_, s_left, s_right);
        float a_inv[system_block], rhs[system_block];
        // The block's arrays and the planes never overlap: no alias checks (too many to vectorise).
        PG_NO_ALIAS_LOOP
        for (int i = 0; i < n; ++i) {
          const int x = start + i;
          const float d0 = directions[2 * x], d1 = directions[2 * x + 1];
          // A non-finite component counts as 0 (no data term), as a branchless select.
          const float dx = keep_if(finite_mask(d0), d0), dy = keep_if(finite_mask(d1), d1);
          const float du = ds_row[x] * dx, dv = ds_row[x] * dy;
          const float psi_b = robust_weight(
              delta, quadratic(b11[x], b12[x], b22[x], b13[x], b23[x], b33[x], du, dv), epsilon_squared);
          const float psi_g = robust_weight(
              gamma, quadratic(g11[x], g12[x], g22[x], g13[x], g23[x], g33[x], du, dv), epsilon_squared);
          // The 2-D system projected on the line direction d: d^T A d ds = -d^T c.
          const float a11 = psi_b * b11[x] + psi_g * g11[x], a12 = psi_b * b12[x] + psi_g * g12[x];
          const float a22 = psi_b * b22[x] + psi_g * g22[x];
          const float c1 = psi_b * b13[x] + psi_g * g13[x], c2 = psi_b * b23[x] + psi_g * g23[x];
          const float total = left[i] + right[i] + down[i] + up[i];
          a_inv[i] = 1.f / (dx * dx * a11 + 2 * dx * dy * a12 + dy * dy * a22 + total + damping);
          rhs[i] = left[i] * s_left[i] + right[i] * s_right[i] + up[i] * s_up[x] + down[i] * s_down[x] -
                   total * s_row[x] - (dx * c1 + dy * c2);
        }
        a11_inv_.split_block(y, start, n, a_inv);
        rhs1_.split_block(y, start, n, rhs);
      }
    });
    sor_sweeps(omega, split_du_, nullptr);
    split_du_.merge_into(ds);
  }
}

}  // namespace pg::flow_detail

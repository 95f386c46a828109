#include "pg/flow/level_solver.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "pg/image/pyramid.h"

namespace pg::flow_detail {
namespace {

template <class RowBody>
void for_rows(int rows, const RowBody& body) {
  tbb::parallel_for(tbb::blocked_range<int>(0, rows, 2), [&](const tbb::blocked_range<int>& range) {
    for (int y = range.begin(); y != range.end(); ++y) body(y);
  });
}

// Five-point central difference (1, -8, 0, 8, -1) / 12 along x, borders replicated.
void derivative_x(const cv::Mat1f& image, cv::Mat1f& out) {
  const int cols = image.cols;
  for_rows(image.rows, [&](int y) {
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
  for_rows(rows, [&](int y) {
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

// w^T J w for w = (du, dv, 1) and J given by its entries 11 12 22 13 23 33.
inline float quadratic(float j11, float j12, float j22, float j13, float j23, float j33, float du, float dv) {
  return j11 * du * du + 2 * j12 * du * dv + j22 * dv * dv + 2 * j13 * du + 2 * j23 * dv + j33;
}

}  // namespace

LevelImages prepare_level(const std::vector<cv::Mat1f>& from, const std::vector<cv::Mat1f>& to,
                          const FlowOptions& options) {
  LevelImages level;
  const cv::Size size = from.front().size();
  const auto derivatives = [&](const cv::Mat1f& image, ImageDerivatives& d) {
    d.image = image;
    for (cv::Mat1f* m : {&d.x, &d.y, &d.xx, &d.xy, &d.yy}) *m = cv::Mat1f(size);
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
  level.smoothness = cv::Mat1f(size, static_cast<float>(options.alpha));
  if (options.edge_weight > 0) {
    const float k = static_cast<float>(options.edge_weight), alpha = static_cast<float>(options.alpha);
    const float channel_share = 1.f / static_cast<float>(from.size());
    for_rows(size.height, [&](int y) {
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

LevelSolver::LevelSolver(const LevelImages& images, const FlowOptions& options)
    : images_(images), options_(options), rows_(images.size().height), cols_(images.size().width) {
  for (cv::Mat1f* m : {&b11_, &b12_,     &b22_,     &b13_, &b23_,  &b33_,          &g11_,         &g12_,
                       &g22_, &g13_,     &g23_,     &g33_, &psi_,  &weight_right_, &weight_down_, &du_,
                       &dv_,  &a11_inv_, &a22_inv_, &a12_, &rhs1_, &rhs2_})
    *m = cv::Mat1f::zeros(rows_, cols_);
  zero_row_.assign(cols_, 0.f);
}

void LevelSolver::compute_tensors(const cv::Mat1f& u, const cv::Mat1f& v) {
  const float zeta_squared = static_cast<float>(options_.zeta * options_.zeta);
  const bool normalise = options_.zeta > 0;
  const int border = 4;  // reach of the second-derivative stencils
  const float max_x = static_cast<float>(cols_ - 1), max_y = static_cast<float>(rows_ - 1);
  for_rows(rows_, [&](int y) {
    for (int x = 0; x < cols_; ++x) {
      const float wx = static_cast<float>(x) + u(y, x), wy = static_cast<float>(y) + v(y, x);
      float t[12] = {};  // b11 b12 b22 b13 b23 b33 g11 g12 g22 g13 g23 g33
      // Outside the image (or NaN) the data term is off and smoothness fills in. Within reach of the
      // border the second derivatives see replicated pixels: gradient constancy is off there.
      if (wx >= 0 && wx <= max_x && wy >= 0 && wy <= max_y) {
        const bool interior = x >= border && y >= border && x < cols_ - border && y < rows_ - border;
        const int x0 = std::min(static_cast<int>(wx), cols_ - 2),
                  y0 = std::min(static_cast<int>(wy), rows_ - 2);
        const float ax = wx - static_cast<float>(x0), ay = wy - static_cast<float>(y0);
        const float w00 = (1 - ax) * (1 - ay), w01 = ax * (1 - ay), w10 = (1 - ax) * ay, w11 = ax * ay;
        const auto sample = [&](const cv::Mat1f& m) {
          const float* r0 = m[y0];
          const float* r1 = m[y0 + 1];
          return w00 * r0[x0] + w01 * r0[x0 + 1] + w10 * r1[x0] + w11 * r1[x0 + 1];
        };
        for (std::size_t c = 0; c < images_.from.size(); ++c) {
          const ImageDerivatives& i1 = images_.from[c];
          const ImageDerivatives& i2 = images_.to[c];
          // `to` and its derivatives warped back onto `from`; spatial derivatives of the linearisation
          // are averaged over both images, which keeps it symmetric.
          const float i2x = sample(i2.x), i2y = sample(i2.y);
          const float i1x = i1.x(y, x), i1y = i1.y(y, x);
          // Brightness constancy: It + Ix du + Iy dv, normalised by the local gradient energy.
          const float ix = 0.5f * (i1x + i2x), iy = 0.5f * (i1y + i2y),
                      it = sample(i2.image) - i1.image(y, x);
          const float nb = normalise ? 1.f / (ix * ix + iy * iy + zeta_squared) : 1.f;
          t[0] += nb * ix * ix, t[1] += nb * ix * iy, t[2] += nb * iy * iy;
          t[3] += nb * ix * it, t[4] += nb * iy * it, t[5] += nb * it * it;
          if (!interior) continue;
          // Gradient constancy: (Ixt + Ixx du + Ixy dv, Iyt + Ixy du + Iyy dv), each part normalised.
          const float ixx = 0.5f * (i1.xx(y, x) + sample(i2.xx)), ixy = 0.5f * (i1.xy(y, x) + sample(i2.xy));
          const float iyy = 0.5f * (i1.yy(y, x) + sample(i2.yy));
          const float ixt = i2x - i1x, iyt = i2y - i1y;
          const float ngx = normalise ? 1.f / (ixx * ixx + ixy * ixy + zeta_squared) : 1.f;
          const float ngy = normalise ? 1.f / (ixy * ixy + iyy * iyy + zeta_squared) : 1.f;
          t[6] += ngx * ixx * ixx + ngy * ixy * ixy;
          t[7] += ngx * ixx * ixy + ngy * ixy * iyy;
          t[8] += ngx * ixy * ixy + ngy * iyy * iyy;
          t[9] += ngx * ixx * ixt + ngy * ixy * iyt;
          t[10] += ngx * ixy * ixt + ngy * iyy * iyt;
          t[11] += ngx * ixt * ixt + ngy * iyt * iyt;
        }
      }
      b11_(y, x) = t[0], b12_(y, x) = t[1], b22_(y, x) = t[2], b13_(y, x) = t[3], b23_(y, x) = t[4];
      b33_(y, x) = t[5], g11_(y, x) = t[6], g12_(y, x) = t[7], g22_(y, x) = t[8], g13_(y, x) = t[9];
      g23_(y, x) = t[10], g33_(y, x) = t[11];
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
  for_rows(rows_, [&](int y) {
    const int yn = std::min(y + 1, rows_ - 1);
    float* psi = psi_[y];
    const float* weight = images_.smoothness[y];
    for (int x = 0; x < cols_; ++x) {
      const int xn = std::min(x + 1, cols_ - 1);
      const float a0 = a(y, x) + da(y, x);
      const float ax = a(y, xn) + da(y, xn) - a0, ay = a(yn, x) + da(yn, x) - a0;
      float squared = ax * ax + ay * ay;
      if (two) {
        const float b0 = b(y, x) + db(y, x);
        const float bx = b(y, xn) + db(y, xn) - b0, by = b(yn, x) + db(yn, x) - b0;
        squared += bx * bx + by * by;
      }
      psi[x] = robust_weight(weight[x], squared, epsilon_squared);
    }
  });
  // Edge weights between neighbours: the mean of both pixels' weights; zero across the border.
  for_rows(rows_, [&](int y) {
    const float* psi = psi_[y];
    const float* below = psi_[std::min(y + 1, rows_ - 1)];
    float* right = weight_right_[y];
    float* down = weight_down_[y];
    for (int x = 0; x + 1 < cols_; ++x) right[x] = 0.5f * (psi[x] + psi[x + 1]);
    right[cols_ - 1] = 0;
    for (int x = 0; x < cols_; ++x) down[x] = y + 1 < rows_ ? 0.5f * (psi[x] + below[x]) : 0.f;
  });
}

namespace {

// Sum over the four neighbours j of w_ij * f_j.
inline float weighted_neighbours(const cv::Mat1f& f, const RowWeights& w, int y, int x) {
  const int rows = f.rows, cols = f.cols;
  const float* row = f[y];
  return w.left(x) * row[x > 0 ? x - 1 : x] + w.right[x] * row[x + 1 < cols ? x + 1 : x] +
         w.up[x] * f[y > 0 ? y - 1 : y][x] + w.down[x] * f[y + 1 < rows ? y + 1 : y][x];
}

}  // namespace

void LevelSolver::median_filter(cv::Mat1f& field) const {
  if (options_.median_radius == 0) return;
  cv::Mat1f filtered;
  cv::medianBlur(field, filtered, 2 * options_.median_radius + 1);
  field = filtered;
}

RowWeights LevelSolver::row_weights(int y) const {
  return {weight_right_[y], weight_down_[y], y > 0 ? weight_down_[y - 1] : zero_row_.data()};
}

void LevelSolver::solve(cv::Mat1f& u, cv::Mat1f& v) {
  const float epsilon_squared = static_cast<float>(options_.epsilon * options_.epsilon);
  const float delta = static_cast<float>(options_.delta), gamma = static_cast<float>(options_.gamma);
  const float omega = static_cast<float>(options_.sor_omega);
  const float damping = 1e-6f;  // keeps the diagonal positive where data and smoothness both vanish
  for (int warp = 0; warp < options_.warps; ++warp) {
    compute_tensors(u, v);
    du_.setTo(0);
    dv_.setTo(0);
    for (int iteration = 0; iteration < options_.fixed_point_iterations; ++iteration) {
      compute_smoothness(u, du_, v, dv_);
      // The linear system of this iteration, robust weights frozen (lagged nonlinearity).
      for_rows(rows_, [&](int y) {
        const RowWeights w = row_weights(y);
        for (int x = 0; x < cols_; ++x) {
          const float du = du_(y, x), dv = dv_(y, x);
          const float psi_b = robust_weight(
              delta,
              quadratic(b11_(y, x), b12_(y, x), b22_(y, x), b13_(y, x), b23_(y, x), b33_(y, x), du, dv),
              epsilon_squared);
          const float psi_g = robust_weight(
              gamma,
              quadratic(g11_(y, x), g12_(y, x), g22_(y, x), g13_(y, x), g23_(y, x), g33_(y, x), du, dv),
              epsilon_squared);
          const float total = w.total(x);
          a11_inv_(y, x) = 1.f / (psi_b * b11_(y, x) + psi_g * g11_(y, x) + total + damping);
          a22_inv_(y, x) = 1.f / (psi_b * b22_(y, x) + psi_g * g22_(y, x) + total + damping);
          a12_(y, x) = psi_b * b12_(y, x) + psi_g * g12_(y, x);
          rhs1_(y, x) =
              weighted_neighbours(u, w, y, x) - total * u(y, x) - (psi_b * b13_(y, x) + psi_g * g13_(y, x));
          rhs2_(y, x) =
              weighted_neighbours(v, w, y, x) - total * v(y, x) - (psi_b * b23_(y, x) + psi_g * g23_(y, x));
        }
      });
      for (int sweep = 0; sweep < options_.sor_iterations; ++sweep) {
        for (int colour = 0; colour < 2; ++colour) {
          // Red-black: pixels of one colour only depend on the other, so rows run in parallel and the
          // result does not depend on the thread count.
          for_rows(rows_, [&](int y) {
            const RowWeights w = row_weights(y);
            const float* a11_inv = a11_inv_[y];
            const float* a22_inv = a22_inv_[y];
            const float* a12 = a12_[y];
            const float* rhs1 = rhs1_[y];
            const float* rhs2 = rhs2_[y];
            float* du = du_[y];
            float* dv = dv_[y];
            for (int x = (y + colour) & 1; x < cols_; x += 2) {
              const float du_new =
                  (1 - omega) * du[x] +
                  omega * (rhs1[x] + weighted_neighbours(du_, w, y, x) - a12[x] * dv[x]) * a11_inv[x];
              du[x] = du_new;
              dv[x] = (1 - omega) * dv[x] +
                      omega * (rhs2[x] + weighted_neighbours(dv_, w, y, x) - a12[x] * du_new) * a22_inv[x];
            }
          });
        }
      }
    }
    u += du_;
    v += dv_;
    median_filter(u);
    median_filter(v);
  }
}

void LevelSolver::solve_along(cv::Mat1f& s, const cv::Mat2f& base, const cv::Mat2f& direction) {
  const float epsilon_squared = static_cast<float>(options_.epsilon * options_.epsilon);
  const float delta = static_cast<float>(options_.delta), gamma = static_cast<float>(options_.gamma);
  const float omega = static_cast<float>(options_.sor_omega);
  const float damping = 1e-6f;  // keeps the diagonal positive where data and smoothness both vanish
  cv::Mat1f u(rows_, cols_), v(rows_, cols_);
  cv::Mat1f& ds = du_;  // the increment of s; dv_ is unused in this mode
  for (int warp = 0; warp < options_.warps; ++warp) {
    for_rows(rows_, [&](int y) {
      for (int x = 0; x < cols_; ++x) {
        const cv::Vec2f b = base(y, x), d = direction(y, x);
        // NaN flow puts the warped position outside the image: no data term there.
        u(y, x) = b[0] + s(y, x) * d[0];
        v(y, x) = b[1] + s(y, x) * d[1];
      }
    });
    compute_tensors(u, v);
    ds.setTo(0);
    for (int iteration = 0; iteration < options_.fixed_point_iterations; ++iteration) {
      compute_smoothness(s, ds, cv::Mat1f(), cv::Mat1f());
      for_rows(rows_, [&](int y) {
        const RowWeights w = row_weights(y);
        for (int x = 0; x < cols_; ++x) {
          const cv::Vec2f d = direction(y, x);
          const float dx = std::isfinite(d[0]) ? d[0] : 0.f, dy = std::isfinite(d[1]) ? d[1] : 0.f;
          const float du = ds(y, x) * dx, dv = ds(y, x) * dy;
          const float psi_b = robust_weight(
              delta,
              quadratic(b11_(y, x), b12_(y, x), b22_(y, x), b13_(y, x), b23_(y, x), b33_(y, x), du, dv),
              epsilon_squared);
          const float psi_g = robust_weight(
              gamma,
              quadratic(g11_(y, x), g12_(y, x), g22_(y, x), g13_(y, x), g23_(y, x), g33_(y, x), du, dv),
              epsilon_squared);
          // The 2-D system projected on the line direction d: d^T A d ds = -d^T c.
          const float a11 = psi_b * b11_(y, x) + psi_g * g11_(y, x),
                      a12 = psi_b * b12_(y, x) + psi_g * g12_(y, x);
          const float a22 = psi_b * b22_(y, x) + psi_g * g22_(y, x);
          const float c1 = psi_b * b13_(y, x) + psi_g * g13_(y, x),
                      c2 = psi_b * b23_(y, x) + psi_g * g23_(y, x);
          const float total = w.total(x);
          a11_inv_(y, x) = 1.f / (dx * dx * a11 + 2 * dx * dy * a12 + dy * dy * a22 + total + damping);
          rhs1_(y, x) = weighted_neighbours(s, w, y, x) - total * s(y, x) - (dx * c1 + dy * c2);
        }
      });
      for (int sweep = 0; sweep < options_.sor_iterations; ++sweep) {
        for (int colour = 0; colour < 2; ++colour) {
          for_rows(rows_, [&](int y) {
            const RowWeights w = row_weights(y);
            const float* a_inv = a11_inv_[y];
            const float* rhs = rhs1_[y];
            float* row = ds[y];
            for (int x = (y + colour) & 1; x < cols_; x += 2)
              row[x] = (1 - omega) * row[x] + omega * (rhs[x] + weighted_neighbours(ds, w, y, x)) * a_inv[x];
          });
        }
      }
    }
    s += ds;
    median_filter(s);
  }
}

}  // namespace pg::flow_detail

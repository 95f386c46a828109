// The flow solver's inner iterations (see flow_increments.h): float arithmetic in the order of the CPU
// reference, no contraction into fused multiply-adds. One work-item per pixel; images row-major.
#pragma OPENCL FP_CONTRACT OFF

inline float robust_weight(float weight, float squared, float epsilon_squared) {
  return weight * 0.5f / sqrt(fmax(squared, 0.f) + epsilon_squared);
}

// Tensor entries are planes of one buffer: plane k of pixel i at t[k * n + i].
inline float quadratic(__global const float* t, int n, int i, float du, float dv) {
  return t[i] * du * du + 2 * t[n + i] * du * dv + t[2 * n + i] * dv * dv + 2 * t[3 * n + i] * du +
         2 * t[4 * n + i] * dv + t[5 * n + i];
}

inline float left_weight(__global const float* right, int i, int x) { return x > 0 ? right[i - 1] : 0.f; }
inline float up_weight(__global const float* down, int i, int y, int cols) { return y > 0 ? down[i - cols] : 0.f; }

inline float neighbours(__global const float* f, __global const float* right, __global const float* down, int x,
                        int y, int cols, int rows) {
  const int i = y * cols + x;
  return left_weight(right, i, x) * f[x > 0 ? i - 1 : i] + right[i] * f[x + 1 < cols ? i + 1 : i] +
         up_weight(down, i, y, cols) * f[y > 0 ? i - cols : i] + down[i] * f[y + 1 < rows ? i + cols : i];
}

__kernel void smoothness(__global const float* u, __global const float* v, __global const float* du,
                         __global const float* dv, __global const float* alpha, __global float* psi, int cols,
                         int rows, float epsilon_squared) {
  const int x = get_global_id(0), y = get_global_id(1);
  if (x >= cols || y >= rows) return;
  const int i = y * cols + x;
  const int xn = min(x + 1, cols - 1), yn = min(y + 1, rows - 1);
  const int ix = y * cols + xn, iy = yn * cols + x;
  const float a0 = u[i] + du[i];
  const float ax = u[ix] + du[ix] - a0, ay = u[iy] + du[iy] - a0;
  const float b0 = v[i] + dv[i];
  const float bx = v[ix] + dv[ix] - b0, by = v[iy] + dv[iy] - b0;
  const float squared = ax * ax + ay * ay + (bx * bx + by * by);
  psi[i] = robust_weight(alpha[i], squared, epsilon_squared);
}

__kernel void edge_weights(__global const float* psi, __global float* right, __global float* down, int cols,
                           int rows) {
  const int x = get_global_id(0), y = get_global_id(1);
  if (x >= cols || y >= rows) return;
  const int i = y * cols + x;
  right[i] = x + 1 < cols ? 0.5f * (psi[i] + psi[i + 1]) : 0.f;
  down[i] = y + 1 < rows ? 0.5f * (psi[i] + psi[i + cols]) : 0.f;
}

__kernel void linear_system(__global const float* brightness, __global const float* gradient,
                            __global const float* u, __global const float* v, __global const float* du,
                            __global const float* dv, __global const float* right, __global const float* down,
                            __global float* a11_inv, __global float* a22_inv, __global float* a12,
                            __global float* rhs1, __global float* rhs2, int cols, int rows, float epsilon_squared,
                            float delta, float gamma) {
  const int x = get_global_id(0), y = get_global_id(1);
  if (x >= cols || y >= rows) return;
  const int i = y * cols + x, n = cols * rows;
  const float damping = 1e-6f;
  const float psi_b = robust_weight(delta, quadratic(brightness, n, i, du[i], dv[i]), epsilon_squared);
  const float psi_g = robust_weight(gamma, quadratic(gradient, n, i, du[i], dv[i]), epsilon_squared);
  const float total = left_weight(right, i, x) + right[i] + down[i] + up_weight(down, i, y, cols);
  a11_inv[i] = 1.f / (psi_b * brightness[i] + psi_g * gradient[i] + total + damping);
  a22_inv[i] = 1.f / (psi_b * brightness[2 * n + i] + psi_g * gradient[2 * n + i] + total + damping);
  a12[i] = psi_b * brightness[n + i] + psi_g * gradient[n + i];
  rhs1[i] = neighbours(u, right, down, x, y, cols, rows) - total * u[i] -
            (psi_b * brightness[3 * n + i] + psi_g * gradient[3 * n + i]);
  rhs2[i] = neighbours(v, right, down, x, y, cols, rows) - total * v[i] -
            (psi_b * brightness[4 * n + i] + psi_g * gradient[4 * n + i]);
}

// One colour of a red-black SOR sweep: pixels with (x + y) % 2 == colour; global size (cols / 2, rows).
__kernel void sor_colour(__global const float* a11_inv, __global const float* a22_inv, __global const float* a12,
                         __global const float* rhs1, __global const float* rhs2, __global const float* right,
                         __global const float* down, __global float* du, __global float* dv, int cols, int rows,
                         float omega, int colour) {
  const int y = get_global_id(1);
  const int x = 2 * get_global_id(0) + ((y + colour) & 1);
  if (x >= cols || y >= rows) return;
  const int i = y * cols + x;
  const float du_new = (1 - omega) * du[i] +
                       omega * (rhs1[i] + neighbours(du, right, down, x, y, cols, rows) - a12[i] * dv[i]) *
                           a11_inv[i];
  du[i] = du_new;
  dv[i] = (1 - omega) * dv[i] +
          omega * (rhs2[i] + neighbours(dv, right, down, x, y, cols, rows) - a12[i] * du_new) * a22_inv[i];
}

// The epipolar mode (line_increments): one unknown s per pixel, the flow base + s * d.

__kernel void smoothness_scalar(__global const float* s, __global const float* ds, __global const float* alpha,
                                __global float* psi, int cols, int rows, float epsilon_squared) {
  const int x = get_global_id(0), y = get_global_id(1);
  if (x >= cols || y >= rows) return;
  const int i = y * cols + x;
  const int ix = y * cols + min(x + 1, cols - 1), iy = min(y + 1, rows - 1) * cols + x;
  const float a0 = s[i] + ds[i];
  const float ax = s[ix] + ds[ix] - a0, ay = s[iy] + ds[iy] - a0;
  psi[i] = robust_weight(alpha[i], ax * ax + ay * ay, epsilon_squared);
}

inline float finite_or_zero(float value) { return isfinite(value) ? value : 0.f; }

// The 2-D system projected on the line direction d (interleaved dx, dy): d^T A d ds = -d^T c.
__kernel void line_system(__global const float* brightness, __global const float* gradient, __global const float* s,
                          __global const float* ds, __global const float* direction, __global const float* right,
                          __global const float* down, __global float* a_inv, __global float* rhs, int cols, int rows,
                          float epsilon_squared, float delta, float gamma) {
  const int x = get_global_id(0), y = get_global_id(1);
  if (x >= cols || y >= rows) return;
  const int i = y * cols + x, n = cols * rows;
  const float damping = 1e-6f;
  const float dx = finite_or_zero(direction[2 * i]), dy = finite_or_zero(direction[2 * i + 1]);
  const float du = ds[i] * dx, dv = ds[i] * dy;
  const float psi_b = robust_weight(delta, quadratic(brightness, n, i, du, dv), epsilon_squared);
  const float psi_g = robust_weight(gamma, quadratic(gradient, n, i, du, dv), epsilon_squared);
  const float a11 = psi_b * brightness[i] + psi_g * gradient[i];
  const float a12 = psi_b * brightness[n + i] + psi_g * gradient[n + i];
  const float a22 = psi_b * brightness[2 * n + i] + psi_g * gradient[2 * n + i];
  const float c1 = psi_b * brightness[3 * n + i] + psi_g * gradient[3 * n + i];
  const float c2 = psi_b * brightness[4 * n + i] + psi_g * gradient[4 * n + i];
  const float total = left_weight(right, i, x) + right[i] + down[i] + up_weight(down, i, y, cols);
  a_inv[i] = 1.f / (dx * dx * a11 + 2 * dx * dy * a12 + dy * dy * a22 + total + damping);
  rhs[i] = neighbours(s, right, down, x, y, cols, rows) - total * s[i] - (dx * c1 + dy * c2);
}

__kernel void sor_colour_scalar(__global const float* a_inv, __global const float* rhs, __global const float* right,
                                __global const float* down, __global float* ds, int cols, int rows, float omega,
                                int colour) {
  const int y = get_global_id(1);
  const int x = 2 * get_global_id(0) + ((y + colour) & 1);
  if (x >= cols || y >= rows) return;
  const int i = y * cols + x;
  ds[i] = (1 - omega) * ds[i] + omega * (rhs[i] + neighbours(ds, right, down, x, y, cols, rows)) * a_inv[i];
}

// The warp's motion tensors on the device (pg/gpu/flow_level.h): the level's derivatives once, then per
// warp the second image's derivatives sampled at x + (u, v) and combined with the first's, in the
// order of LevelSolver::compute_tensors.

// Five-point central difference (1, -8, 0, 8, -1) / 12 along x, borders replicated: from the plane at
// offset `from` of `planes` to the one at `to`.
__kernel void derivative_x(__global float* planes, long from, long to, int cols, int rows) {
  const int x = get_global_id(0), y = get_global_id(1);
  if (x >= cols || y >= rows) return;
  __global const float* row = planes + from + (long)y * cols;
  const int last = cols - 1;
  planes[to + (long)y * cols + x] = (row[clamp(x - 2, 0, last)] - 8 * row[clamp(x - 1, 0, last)] +
                                     8 * row[clamp(x + 1, 0, last)] - row[clamp(x + 2, 0, last)]) *
                                    (1.f / 12);
}

__kernel void derivative_y(__global float* planes, long from, long to, int cols, int rows) {
  const int x = get_global_id(0), y = get_global_id(1);
  if (x >= cols || y >= rows) return;
  __global const float* in = planes + from + x;
  const int last = rows - 1;
  planes[to + (long)y * cols + x] =
      (in[(long)clamp(y - 2, 0, last) * cols] - 8 * in[(long)clamp(y - 1, 0, last) * cols] +
       8 * in[(long)clamp(y + 1, 0, last) * cols] - in[(long)clamp(y + 2, 0, last) * cols]) *
      (1.f / 12);
}

// planes: per channel c, 12 planes from 12 * c * n: the first image's image, x, y, xx, xy, yy, then the
// second's. b, g: the six entries 11 12 22 13 23 33 of each tensor, plane k at k * n.
__kernel void motion_tensors(__global const float* planes, int channels, __global const float* u,
                             __global const float* v, __global float* b, __global float* g, int cols, int rows,
                             float zeta_squared, int normalise) {
  const int x = get_global_id(0), y = get_global_id(1);
  if (x >= cols || y >= rows) return;
  const int n = cols * rows, i = y * cols + x, border = 4;
  const float wx = (float)x + u[i], wy = (float)y + v[i];
  const bool inside = wx >= 0 && wx <= (float)(cols - 1) && wy >= 0 && wy <= (float)(rows - 1);
  const bool interior = inside && y >= border && y < rows - border && x >= border && x < cols - border;
  int offset = 0;
  float w00 = 0, w01 = 0, w10 = 0, w11 = 0;
  if (inside) {
    const int x0 = min((int)wx, cols - 2), y0 = min((int)wy, rows - 2);
    const float ax = wx - (float)x0, ay = wy - (float)y0;
    w00 = (1 - ax) * (1 - ay), w01 = ax * (1 - ay), w10 = (1 - ax) * ay, w11 = ax * ay;
    offset = y0 * cols + x0;
  }
  float t[12] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0};
  for (int c = 0; c < channels; ++c) {
    __global const float* first = planes + (size_t)(12 * c) * n;
    __global const float* second = first + (size_t)6 * n;
    float s[6];  // the second image's image, x, y, xx, xy, yy at the warped position
    for (int k = 0; k < 6; ++k) {
      __global const float* r0 = second + (size_t)k * n + offset;
      __global const float* r1 = r0 + cols;
      s[k] = w00 * r0[0] + w01 * r0[1] + w10 * r1[0] + w11 * r1[1];
    }
    const float i1_image = first[i], i1x = first[n + i], i1y = first[2 * n + i];
    const float i1_xx = first[3 * n + i], i1_xy = first[4 * n + i], i1_yy = first[5 * n + i];
    const float i2x = s[1], i2y = s[2];
    const float ix = 0.5f * (i1x + i2x), iy = 0.5f * (i1y + i2y), it = s[0] - i1_image;
    const float nb = normalise ? 1.f / (ix * ix + iy * iy + zeta_squared) : 1.f;
    if (inside) {
      t[0] += nb * ix * ix, t[1] += nb * ix * iy, t[2] += nb * iy * iy;
      t[3] += nb * ix * it, t[4] += nb * iy * it, t[5] += nb * it * it;
    }
    const float ixx = 0.5f * (i1_xx + s[3]), ixy = 0.5f * (i1_xy + s[4]), iyy = 0.5f * (i1_yy + s[5]);
    const float ixt = i2x - i1x, iyt = i2y - i1y;
    const float ngx = normalise ? 1.f / (ixx * ixx + ixy * ixy + zeta_squared) : 1.f;
    const float ngy = normalise ? 1.f / (ixy * ixy + iyy * iyy + zeta_squared) : 1.f;
    if (interior) {
      t[6] += ngx * ixx * ixx + ngy * ixy * ixy;
      t[7] += ngx * ixx * ixy + ngy * ixy * iyy;
      t[8] += ngx * ixy * ixy + ngy * iyy * iyy;
      t[9] += ngx * ixx * ixt + ngy * ixy * iyt;
      t[10] += ngx * ixy * ixt + ngy * iyy * iyt;
      t[11] += ngx * ixt * ixt + ngy * iyt * iyt;
    }
  }
  for (int k = 0; k < 6; ++k) b[k * n + i] = t[k], g[k * n + i] = t[6 + k];
}

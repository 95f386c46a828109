// The CUDA path of flow_increments.h (built with PG_WITH_CUDA): the OpenCL kernels' arithmetic, with
// FMA contraction off (-fmad=false) so results match the CPU reference to rounding.
#include <cuda_runtime.h>

#include <array>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/gpu/cuda_backend.h"
#include "pg/gpu/staging.h"

namespace pg::gpu::detail {
namespace {

__device__ float robust_weight(float weight, float squared, float epsilon_squared) {
  return __fdiv_rn(weight * 0.5f, __fsqrt_rn(fmaxf(squared, 0.f) + epsilon_squared));
}

__device__ float quadratic(const float* t, int n, int i, float du, float dv) {
  return t[i] * du * du + 2 * t[n + i] * du * dv + t[2 * n + i] * dv * dv + 2 * t[3 * n + i] * du +
         2 * t[4 * n + i] * dv + t[5 * n + i];
}

__device__ float neighbours(const float* f, const float* right, const float* down, int x, int y, int cols,
                            int rows) {
  const int i = y * cols + x;
  const float left = x > 0 ? right[i - 1] : 0.f, up = y > 0 ? down[i - cols] : 0.f;
  return left * f[x > 0 ? i - 1 : i] + right[i] * f[x + 1 < cols ? i + 1 : i] + up * f[y > 0 ? i - cols : i] +
         down[i] * f[y + 1 < rows ? i + cols : i];
}

__global__ void smoothness(const float* u, const float* v, const float* du, const float* dv,
                           const float* alpha, float* psi, int cols, int rows, float epsilon_squared) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x, y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x >= cols || y >= rows) return;
  const int i = y * cols + x, ix = y * cols + min(x + 1, cols - 1), iy = min(y + 1, rows - 1) * cols + x;
  const float a0 = u[i] + du[i], ax = u[ix] + du[ix] - a0, ay = u[iy] + du[iy] - a0;
  const float b0 = v[i] + dv[i], bx = v[ix] + dv[ix] - b0, by = v[iy] + dv[iy] - b0;
  psi[i] = robust_weight(alpha[i], ax * ax + ay * ay + (bx * bx + by * by), epsilon_squared);
}

__global__ void edge_weights(const float* psi, float* right, float* down, int cols, int rows) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x, y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x >= cols || y >= rows) return;
  const int i = y * cols + x;
  right[i] = x + 1 < cols ? 0.5f * (psi[i] + psi[i + 1]) : 0.f;
  down[i] = y + 1 < rows ? 0.5f * (psi[i] + psi[i + cols]) : 0.f;
}

struct System {
  float *a11_inv, *a22_inv, *a12, *rhs1, *rhs2;
};

__global__ void linear_system(const float* b, const float* g, const float* u, const float* v, const float* du,
                              const float* dv, const float* right, const float* down, System s, int cols,
                              int rows, float epsilon_squared, float delta, float gamma) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x, y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x >= cols || y >= rows) return;
  const int i = y * cols + x, n = cols * rows;
  const float psi_b = robust_weight(delta, quadratic(b, n, i, du[i], dv[i]), epsilon_squared);
  const float psi_g = robust_weight(gamma, quadratic(g, n, i, du[i], dv[i]), epsilon_squared);
  const float total = (x > 0 ? right[i - 1] : 0.f) + right[i] + down[i] + (y > 0 ? down[i - cols] : 0.f);
  s.a11_inv[i] = __fdiv_rn(1.f, psi_b * b[i] + psi_g * g[i] + total + 1e-6f);
  s.a22_inv[i] = __fdiv_rn(1.f, psi_b * b[2 * n + i] + psi_g * g[2 * n + i] + total + 1e-6f);
  s.a12[i] = psi_b * b[n + i] + psi_g * g[n + i];
  s.rhs1[i] = neighbours(u, right, down, x, y, cols, rows) - total * u[i] -
              (psi_b * b[3 * n + i] + psi_g * g[3 * n + i]);
  s.rhs2[i] = neighbours(v, right, down, x, y, cols, rows) - total * v[i] -
              (psi_b * b[4 * n + i] + psi_g * g[4 * n + i]);
}

__global__ void sor_colour(System s, const float* right, const float* down, float* du, float* dv, int cols,
                           int rows, float omega, int colour) {
  const int y = blockIdx.y * blockDim.y + threadIdx.y;
  const int x = 2 * (blockIdx.x * blockDim.x + threadIdx.x) + ((y + colour) & 1);
  if (x >= cols || y >= rows) return;
  const int i = y * cols + x;
  const float du_new =
      (1 - omega) * du[i] +
      omega * (s.rhs1[i] + neighbours(du, right, down, x, y, cols, rows) - s.a12[i] * dv[i]) * s.a11_inv[i];
  du[i] = du_new;
  dv[i] =
      (1 - omega) * dv[i] +
      omega * (s.rhs2[i] + neighbours(dv, right, down, x, y, cols, rows) - s.a12[i] * du_new) * s.a22_inv[i];
}

// The epipolar mode (line_increments): one unknown s per pixel, the flow base + s * d.

__global__ void smoothness_scalar(const float* s, const float* ds, const float* alpha, float* psi, int cols,
                                  int rows, float epsilon_squared) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x, y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x >= cols || y >= rows) return;
  const int i = y * cols + x, ix = y * cols + min(x + 1, cols - 1), iy = min(y + 1, rows - 1) * cols + x;
  const float a0 = s[i] + ds[i], ax = s[ix] + ds[ix] - a0, ay = s[iy] + ds[iy] - a0;
  psi[i] = robust_weight(alpha[i], ax * ax + ay * ay, epsilon_squared);
}

__device__ float finite_or_zero(float value) {
  return isfinite(value) ? value : 0.f;
}

struct LineSystem {
  float *a_inv, *rhs;
};

// The 2-D system projected on the line direction d (interleaved dx, dy): d^T A d ds = -d^T c.
__global__ void line_system(const float* b, const float* g, const float* s, const float* ds,
                            const float* direction, const float* right, const float* down, LineSystem out,
                            int cols, int rows, float epsilon_squared, float delta, float gamma) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x, y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x >= cols || y >= rows) return;
  const int i = y * cols + x, n = cols * rows;
  const float dx = finite_or_zero(direction[2 * i]), dy = finite_or_zero(direction[2 * i + 1]);
  const float du = ds[i] * dx, dv = ds[i] * dy;
  const float psi_b = robust_weight(delta, quadratic(b, n, i, du, dv), epsilon_squared);
  const float psi_g = robust_weight(gamma, quadratic(g, n, i, du, dv), epsilon_squared);
  const float a11 = psi_b * b[i] + psi_g * g[i];
  const float a12 = psi_b * b[n + i] + psi_g * g[n + i];
  const float a22 = psi_b * b[2 * n + i] + psi_g * g[2 * n + i];
  const float c1 = psi_b * b[3 * n + i] + psi_g * g[3 * n + i];
  const float c2 = psi_b * b[4 * n + i] + psi_g * g[4 * n + i];
  const float total = (x > 0 ? right[i - 1] : 0.f) + right[i] + down[i] + (y > 0 ? down[i - cols] : 0.f);
  out.a_inv[i] = __fdiv_rn(1.f, dx * dx * a11 + 2 * dx * dy * a12 + dy * dy * a22 + total + 1e-6f);
  out.rhs[i] = neighbours(s, right, down, x, y, cols, rows) - total * s[i] - (dx * c1 + dy * c2);
}

__global__ void sor_colour_scalar(LineSystem system, const float* right, const float* down, float* ds,
                                  int cols, int rows, float omega, int colour) {
  const int y = blockIdx.y * blockDim.y + threadIdx.y;
  const int x = 2 * (blockIdx.x * blockDim.x + threadIdx.x) + ((y + colour) & 1);
  if (x >= cols || y >= rows) return;
  const int i = y * cols + x;
  ds[i] = (1 - omega) * ds[i] +
          omega * (system.rhs[i] + neighbours(ds, right, down, x, y, cols, rows)) * system.a_inv[i];
}

// The warp's motion tensors (flow_level.h), as kernels/flow_increments.cl: derivatives from the plane
// at offset `from` of `planes` to the one at `to`, five-point differences with replicated borders.
__global__ void derivative_x(float* planes, long long from, long long to, int cols, int rows) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x, y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x >= cols || y >= rows) return;
  const float* row = planes + from + (long long)y * cols;
  const int last = cols - 1;
  planes[to + (long long)y * cols + x] = (row[max(0, min(x - 2, last))] - 8 * row[max(0, min(x - 1, last))] +
                                          8 * row[max(0, min(x + 1, last))] - row[max(0, min(x + 2, last))]) *
                                         (1.f / 12);
}

__global__ void derivative_y(float* planes, long long from, long long to, int cols, int rows) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x, y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x >= cols || y >= rows) return;
  const float* in = planes + from + x;
  const int last = rows - 1;
  const auto at = [&](int r) { return in[(long long)max(0, min(r, last)) * cols]; };
  planes[to + (long long)y * cols + x] = (at(y - 2) - 8 * at(y - 1) + 8 * at(y + 1) - at(y + 2)) * (1.f / 12);
}

// planes: per channel c, 12 planes from 12 * c * n (the first image's image, x, y, xx, xy, yy, then the
// second's); b, g: the tensors' six planes each.
__global__ void motion_tensors(const float* planes, int channels, const float* u, const float* v, float* b,
                               float* g, int cols, int rows, float zeta_squared, int normalise) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x, y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x >= cols || y >= rows) return;
  const long long n = (long long)cols * rows;
  const int i = y * cols + x, border = 4;
  const float wx = (float)x + u[i], wy = (float)y + v[i];
  const bool inside = wx >= 0 && wx <= (float)(cols - 1) && wy >= 0 && wy <= (float)(rows - 1);
  const bool interior = inside && y >= border && y < rows - border && x >= border && x < cols - border;
  long long offset = 0;
  float w00 = 0, w01 = 0, w10 = 0, w11 = 0;
  if (inside) {
    const int x0 = min((int)wx, cols - 2), y0 = min((int)wy, rows - 2);
    const float ax = wx - (float)x0, ay = wy - (float)y0;
    w00 = (1 - ax) * (1 - ay), w01 = ax * (1 - ay), w10 = (1 - ax) * ay, w11 = ax * ay;
    offset = (long long)y0 * cols + x0;
  }
  float t[12] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0};
  for (int c = 0; c < channels; ++c) {
    const float* first = planes + 12 * c * n;
    const float* second = first + 6 * n;
    float s[6];
    for (int k = 0; k < 6; ++k) {
      const float* r0 = second + k * n + offset;
      const float* r1 = r0 + cols;
      s[k] = w00 * r0[0] + w01 * r0[1] + w10 * r1[0] + w11 * r1[1];
    }
    const float i1_image = first[i], i1x = first[n + i], i1y = first[2 * n + i];
    const float i1_xx = first[3 * n + i], i1_xy = first[4 * n + i], i1_yy = first[5 * n + i];
    const float i2x = s[1], i2y = s[2];
    const float ix = 0.5f * (i1x + i2x), iy = 0.5f * (i1y + i2y), it = s[0] - i1_image;
    const float nb = normalise ? __fdiv_rn(1.f, ix * ix + iy * iy + zeta_squared) : 1.f;
    if (inside) {
      t[0] += nb * ix * ix, t[1] += nb * ix * iy, t[2] += nb * iy * iy;
      t[3] += nb * ix * it, t[4] += nb * iy * it, t[5] += nb * it * it;
    }
    const float ixx = 0.5f * (i1_xx + s[3]), ixy = 0.5f * (i1_xy + s[4]), iyy = 0.5f * (i1_yy + s[5]);
    const float ixt = i2x - i1x, iyt = i2y - i1y;
    const float ngx = normalise ? __fdiv_rn(1.f, ixx * ixx + ixy * ixy + zeta_squared) : 1.f;
    const float ngy = normalise ? __fdiv_rn(1.f, ixy * ixy + iyy * iyy + zeta_squared) : 1.f;
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

void check(cudaError_t status, const char* what) {
  if (status != cudaSuccess) throw FailedError(str("CUDA ", what, ": ", cudaGetErrorString(status)));
}

// Device memory and pinned host staging kept from one warp to the next: a solve runs a warp per
// pyramid level and fixed-point round at few sizes, and allocating and uploading through pageable
// memory each time cost more than the iterations themselves. Grown when a larger level comes; one warp
// at a time. Never destroyed: the driver frees it with the process (at exit the CUDA runtime may
// already be gone).
class Workspace {
 public:
  static Workspace& get() {
    static Workspace* workspace = new Workspace;
    return *workspace;
  }
  std::mutex mutex;

  float* device(std::size_t floats) { return device_.at_least(floats, false); }
  // A FlowLevel's images (twelve planes per channel), apart from the warps' buffers.
  float* images(std::size_t floats) { return images_.at_least(floats, false); }
  float* host(std::size_t floats) { return host_.at_least(floats, true); }

 private:
  // Device (or pinned host) memory grown to the largest request and reused below it.
  struct Growing {
    float* data = nullptr;
    std::size_t floats = 0;
    float* at_least(std::size_t wanted, bool pinned) {
      if (wanted > floats) {
        pinned ? cudaFreeHost(data) : cudaFree(data);
        data = nullptr, floats = 0;
        check(pinned ? cudaMallocHost(&data, wanted * sizeof(float))
                     : cudaMalloc(&data, wanted * sizeof(float)),
              pinned ? "pinned allocation" : "allocation");
        floats = wanted;
      }
      return data;
    }
  };
  Growing device_, images_, host_;
};

// Gathers the inputs in pinned memory and uploads them with one copy to the start of `device`.
void upload(const std::vector<PlaneSource>& planes, Workspace& workspace, float* device) {
  const std::size_t floats = total_floats(planes);
  float* staging = workspace.host(floats);
  gather(planes, staging);
  check(cudaMemcpy(device, staging, floats * sizeof(float), cudaMemcpyHostToDevice), "upload");
}

const dim3 block(16, 8);
dim3 pixel_grid(int cols, int rows) {
  return dim3((cols + 15) / 16, (rows + 7) / 8);
}

// The fixed-point iterations of the free mode on device planes (du, dv cleared first).
void launch_free_iterations(const float* b, const float* g, const float* u, const float* v,
                            const float* alpha, float* du, float* dv, float* psi, float* right, float* down,
                            const System& s, int cols, int rows, const FlowIncrementOptions& o) {
  const std::size_t bytes = std::size_t(rows) * cols * sizeof(float);
  check(cudaMemset(du, 0, bytes), "clear");
  check(cudaMemset(dv, 0, bytes), "clear");
  const float eps2 = o.epsilon * o.epsilon;
  const dim3 grid = pixel_grid(cols, rows), half((cols / 2 + 16) / 16, (rows + 7) / 8);
  for (int iteration = 0; iteration < o.fixed_point_iterations; ++iteration) {
    smoothness<<<grid, block>>>(u, v, du, dv, alpha, psi, cols, rows, eps2);
    edge_weights<<<grid, block>>>(psi, right, down, cols, rows);
    linear_system<<<grid, block>>>(b, g, u, v, du, dv, right, down, s, cols, rows, eps2, o.delta, o.gamma);
    for (int sweep = 0; sweep < o.sor_iterations; ++sweep)
      for (int colour = 0; colour < 2; ++colour)
        sor_colour<<<half, block>>>(s, right, down, du, dv, cols, rows, o.omega, colour);
  }
  check(cudaGetLastError(), "kernel launch");
}

// The same for the epipolar mode (ds cleared first).
void launch_line_iterations(const float* b, const float* g, const float* s, const float* alpha,
                            const float* direction, float* ds, float* psi, float* right, float* down,
                            const LineSystem& system, int cols, int rows, const FlowIncrementOptions& o) {
  check(cudaMemset(ds, 0, std::size_t(rows) * cols * sizeof(float)), "clear");
  const float eps2 = o.epsilon * o.epsilon;
  const dim3 grid = pixel_grid(cols, rows), half((cols / 2 + 16) / 16, (rows + 7) / 8);
  for (int iteration = 0; iteration < o.fixed_point_iterations; ++iteration) {
    smoothness_scalar<<<grid, block>>>(s, ds, alpha, psi, cols, rows, eps2);
    edge_weights<<<grid, block>>>(psi, right, down, cols, rows);
    line_system<<<grid, block>>>(b, g, s, ds, direction, right, down, system, cols, rows, eps2, o.delta,
                                 o.gamma);
    for (int sweep = 0; sweep < o.sor_iterations; ++sweep)
      for (int colour = 0; colour < 2; ++colour)
        sor_colour_scalar<<<half, block>>>(system, right, down, ds, cols, rows, o.omega, colour);
  }
  check(cudaGetLastError(), "kernel launch");
}

void download(const float* device, int rows, int cols, cv::Mat1f& out) {
  out.create(rows, cols);
  check(cudaMemcpy(out.ptr<float>(), device, out.total() * sizeof(float), cudaMemcpyDeviceToHost),
        "download");
}

// A level on the device (flow_level.h). Warp buffers, one plane of n floats each unless said:
// b (6), g (6), u, v, alpha, du, dv, psi, right, down, the five system planes, s, direction (2).
class CudaFlowLevel final : public FlowLevelBackend {
 public:
  CudaFlowLevel(const std::vector<cv::Mat1f>& from, const std::vector<cv::Mat1f>& to,
                const cv::Mat1f& smoothness, float zeta_squared)
      : workspace_(Workspace::get()),
        lock_(workspace_.mutex),
        rows_(smoothness.rows),
        cols_(smoothness.cols),
        channels_(int(from.size())),
        n_(smoothness.total()),
        zeta_squared_(zeta_squared) {
    base_ = workspace_.device(28 * n_);
    images_ = workspace_.images(12 * channels_ * n_);
    std::vector<PlaneSource> sources{plane_source(smoothness)};
    for (int c = 0; c < channels_; ++c)
      for (const cv::Mat1f* image : {&from[c], &to[c]}) sources.push_back(plane_source(*image));
    float* staging = workspace_.host(total_floats(sources));
    gather(sources, staging);
    check(cudaMemcpy(plane(alpha), staging, n_ * sizeof(float), cudaMemcpyHostToDevice), "upload");
    const dim3 grid = pixel_grid(cols_, rows_);
    for (std::size_t k = 0; k + 1 < sources.size(); ++k) {
      const long long first = 6 * k * n_;
      check(cudaMemcpy(images_ + first, staging + (k + 1) * n_, n_ * sizeof(float), cudaMemcpyHostToDevice),
            "upload");
      const long long n = n_;
      derivative_x<<<grid, block>>>(images_, first, first + n, cols_, rows_);
      derivative_y<<<grid, block>>>(images_, first, first + 2 * n, cols_, rows_);
      derivative_x<<<grid, block>>>(images_, first + n, first + 3 * n, cols_, rows_);
      derivative_y<<<grid, block>>>(images_, first + n, first + 4 * n, cols_, rows_);
      derivative_y<<<grid, block>>>(images_, first + 2 * n, first + 5 * n, cols_, rows_);
    }
    check(cudaGetLastError(), "kernel launch");
  }

  void flow_increments(const cv::Mat1f& u, const cv::Mat1f& v, const FlowIncrementOptions& o, cv::Mat1f& du,
                       cv::Mat1f& dv) override {
    warp_tensors(u, v, {});
    launch_free_iterations(plane(b), plane(g), plane(flow_u), plane(flow_v), plane(alpha), plane(d_u),
                           plane(d_v), plane(psi), plane(right), plane(down), system(), cols_, rows_, o);
    download(plane(d_u), rows_, cols_, du);
    download(plane(d_v), rows_, cols_, dv);
  }

  void line_increments(const cv::Mat1f& u, const cv::Mat1f& v, const cv::Mat1f& s, const cv::Mat2f& direction,
                       const FlowIncrementOptions& o, cv::Mat1f& ds) override {
    warp_tensors(u, v, {plane_source(s), plane_source(direction)});
    const System full = system();
    launch_line_iterations(plane(b), plane(g), plane(line_s), plane(alpha), plane(line_direction), plane(d_u),
                           plane(psi), plane(right), plane(down), LineSystem{full.a11_inv, full.rhs1}, cols_,
                           rows_, o);
    download(plane(d_u), rows_, cols_, ds);
  }

  std::array<cv::Mat1f, 12> tensors(const cv::Mat1f& u, const cv::Mat1f& v) override {
    warp_tensors(u, v, {});
    std::array<cv::Mat1f, 12> out;
    for (int k = 0; k < 12; ++k) download(base_ + k * n_, rows_, cols_, out[k]);
    return out;
  }

 private:
  // Plane offsets (in planes of n floats) of the warp buffers.
  enum Plane {
    b = 0,
    g = 6,
    flow_u = 12,
    flow_v = 13,
    alpha = 14,
    d_u = 15,
    d_v = 16,
    psi = 17,
    right = 18,
    down = 19,
    system_planes = 20,
    line_s = 25,
    line_direction = 26
  };
  float* plane(Plane p) const { return base_ + std::size_t(p) * n_; }
  System system() const {
    float* s = plane(system_planes);
    return {s, s + n_, s + 2 * n_, s + 3 * n_, s + 4 * n_};
  }

  // Uploads (u, v) after `more` (s and direction, placed from plane line_s on), then the tensors.
  void warp_tensors(const cv::Mat1f& u, const cv::Mat1f& v, std::vector<PlaneSource> more) {
    more.push_back(plane_source(u));
    more.push_back(plane_source(v));
    const std::size_t floats = total_floats(more);
    float* staging = workspace_.host(floats);
    gather(more, staging);
    // (u, v) into their planes; s and direction, when given, into theirs.
    check(
        cudaMemcpy(plane(flow_u), staging + floats - 2 * n_, 2 * n_ * sizeof(float), cudaMemcpyHostToDevice),
        "upload");
    if (floats > 2 * n_)
      check(cudaMemcpy(plane(line_s), staging, (floats - 2 * n_) * sizeof(float), cudaMemcpyHostToDevice),
            "upload");
    motion_tensors<<<pixel_grid(cols_, rows_), block>>>(images_, channels_, plane(flow_u), plane(flow_v),
                                                        plane(b), plane(g), cols_, rows_, zeta_squared_,
                                                        zeta_squared_ > 0 ? 1 : 0);
    check(cudaGetLastError(), "kernel launch");
  }

  Workspace& workspace_;
  std::unique_lock<std::mutex> lock_;
  int rows_, cols_, channels_;
  std::size_t n_;
  float zeta_squared_;
  float* base_ = nullptr;
  float* images_ = nullptr;
};

}  // namespace

std::vector<DeviceInfo> cuda_devices(std::string& reason) {
  int count = 0;
  const cudaError_t status = cudaGetDeviceCount(&count);
  if (status != cudaSuccess) {
    reason = str("no usable CUDA device (", cudaGetErrorString(status), ")");
    return {};
  }
  std::vector<DeviceInfo> devices;
  for (int d = 0; d < count; ++d) {
    cudaDeviceProp prop{};
    if (cudaGetDeviceProperties(&prop, d) != cudaSuccess) continue;
    DeviceInfo info;
    info.kind = DeviceKind::cuda;
    info.index = d;
    info.name = prop.name;
    info.platform = "CUDA";
    info.driver = str("compute ", prop.major, ".", prop.minor);
    info.is_gpu = true;
    info.double_precision = true;
    info.global_memory = prop.totalGlobalMem;
    info.max_allocation = prop.totalGlobalMem;
    info.compute_units = prop.multiProcessorCount;
    devices.push_back(info);
  }
  if (devices.empty()) reason = "no CUDA device found";
  return devices;
}

void cuda_flow_increments(const FlowIncrementInput& in, cv::Mat1f& du, cv::Mat1f& dv) {
  const int rows = in.u.rows, cols = in.u.cols;
  const std::size_t n = std::size_t(rows) * cols;
  Workspace& workspace = Workspace::get();
  const std::lock_guard lock(workspace.mutex);
  // The uploaded planes (brightness, gradient, u, v, smoothness), then the work planes.
  float* const base = workspace.device(25 * n);
  upload(upload_planes(in), workspace, base);
  const float *b = base, *g = base + 6 * n, *u = base + 12 * n, *v = base + 13 * n, *alpha = base + 14 * n;
  float *d_du = base + 15 * n, *d_dv = base + 16 * n, *psi = base + 17 * n, *right = base + 18 * n,
        *down = base + 19 * n;
  const System s{base + 20 * n, base + 21 * n, base + 22 * n, base + 23 * n, base + 24 * n};
  launch_free_iterations(b, g, u, v, alpha, d_du, d_dv, psi, right, down, s, cols, rows, in.options);
  download(d_du, rows, cols, du);
  download(d_dv, rows, cols, dv);
}

void cuda_line_increments(const LineIncrementInput& in, cv::Mat1f& ds) {
  const int rows = in.s.rows, cols = in.s.cols;
  const std::size_t n = std::size_t(rows) * cols;
  Workspace& workspace = Workspace::get();
  const std::lock_guard lock(workspace.mutex);
  // The uploaded planes (brightness, gradient, s, smoothness, direction), then the work planes.
  float* const base = workspace.device(22 * n);
  upload(upload_planes(in), workspace, base);
  const float *b = base, *g = base + 6 * n, *s = base + 12 * n, *alpha = base + 13 * n,
              *direction = base + 14 * n;
  float *d_ds = base + 16 * n, *psi = base + 17 * n, *right = base + 18 * n, *down = base + 19 * n;
  const LineSystem system{base + 20 * n, base + 21 * n};
  launch_line_iterations(b, g, s, alpha, direction, d_ds, psi, right, down, system, cols, rows, in.options);
  download(d_ds, rows, cols, ds);
}

std::unique_ptr<FlowLevelBackend> cuda_flow_level(const std::vector<cv::Mat1f>& from,
                                                  const std::vector<cv::Mat1f>& to,
                                                  const cv::Mat1f& smoothness, float zeta_squared) {
  std::string reason;
  if (cuda_devices(reason).empty()) throw FailedError(str("CUDA flow level: ", reason));
  return std::make_unique<CudaFlowLevel>(from, to, smoothness, zeta_squared);
}

}  // namespace pg::gpu::detail

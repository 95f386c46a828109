// The CUDA path of flow_increments.h (built with PG_WITH_CUDA): the OpenCL kernels' arithmetic, with
// FMA contraction off (-fmad=false) so results match the CPU reference to rounding.
#include <cuda_runtime.h>

#include <array>
#include <string>
#include <vector>

#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/gpu/cuda_backend.h"

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

void check(cudaError_t status, const char* what) {
  if (status != cudaSuccess) throw FailedError(str("CUDA ", what, ": ", cudaGetErrorString(status)));
}

// Device buffers of one warp, freed together (also when a CUDA call throws).
class DeviceBuffers {
 public:
  DeviceBuffers() = default;
  DeviceBuffers(const DeviceBuffers&) = delete;
  DeviceBuffers& operator=(const DeviceBuffers&) = delete;
  ~DeviceBuffers() {
    for (float* p : buffers_) cudaFree(p);
  }
  float* alloc(std::size_t bytes) {
    float* p = nullptr;
    check(cudaMalloc(&p, bytes), "allocation");
    buffers_.push_back(p);
    return p;
  }
  // A device copy of a motion tensor's six planes (each rows x cols), one after another.
  float* upload(const std::array<cv::Mat1f, 6>& planes, std::size_t plane_bytes) {
    float* p = alloc(6 * plane_bytes);
    for (std::size_t k = 0; k < 6; ++k)
      check(cudaMemcpy(p + k * (plane_bytes / sizeof(float)), planes[k].ptr<float>(), plane_bytes,
                       cudaMemcpyHostToDevice),
            "upload");
    return p;
  }
  float* upload(const void* data, std::size_t bytes) {
    float* p = alloc(bytes);
    check(cudaMemcpy(p, data, bytes, cudaMemcpyHostToDevice), "upload");
    return p;
  }
  float* zeros(std::size_t bytes) {
    float* p = alloc(bytes);
    check(cudaMemset(p, 0, bytes), "clear");
    return p;
  }

 private:
  std::vector<float*> buffers_;
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
  const std::size_t bytes = std::size_t(rows) * cols * sizeof(float);
  DeviceBuffers buffers;
  float* b = buffers.upload(in.brightness, bytes);
  float* g = buffers.upload(in.gradient, bytes);
  float* u = buffers.upload(in.u.ptr<float>(), bytes);
  float* v = buffers.upload(in.v.ptr<float>(), bytes);
  float* alpha = buffers.upload(in.smoothness.ptr<float>(), bytes);
  float *d_du = buffers.zeros(bytes), *d_dv = buffers.zeros(bytes);
  float *psi = buffers.alloc(bytes), *right = buffers.alloc(bytes), *down = buffers.alloc(bytes);
  const System s{buffers.alloc(bytes), buffers.alloc(bytes), buffers.alloc(bytes), buffers.alloc(bytes),
                 buffers.alloc(bytes)};
  const FlowIncrementOptions& o = in.options;
  const float eps2 = o.epsilon * o.epsilon;
  const dim3 block(16, 8), grid((cols + 15) / 16, (rows + 7) / 8), half((cols / 2 + 16) / 16, (rows + 7) / 8);
  for (int iteration = 0; iteration < o.fixed_point_iterations; ++iteration) {
    smoothness<<<grid, block>>>(u, v, d_du, d_dv, alpha, psi, cols, rows, eps2);
    edge_weights<<<grid, block>>>(psi, right, down, cols, rows);
    linear_system<<<grid, block>>>(b, g, u, v, d_du, d_dv, right, down, s, cols, rows, eps2, o.delta,
                                   o.gamma);
    for (int sweep = 0; sweep < o.sor_iterations; ++sweep)
      for (int colour = 0; colour < 2; ++colour)
        sor_colour<<<half, block>>>(s, right, down, d_du, d_dv, cols, rows, o.omega, colour);
  }
  check(cudaGetLastError(), "kernel launch");
  du.create(rows, cols);
  dv.create(rows, cols);
  check(cudaMemcpy(du.ptr<float>(), d_du, bytes, cudaMemcpyDeviceToHost), "download");
  check(cudaMemcpy(dv.ptr<float>(), d_dv, bytes, cudaMemcpyDeviceToHost), "download");
}

void cuda_line_increments(const LineIncrementInput& in, cv::Mat1f& ds) {
  const int rows = in.s.rows, cols = in.s.cols;
  const std::size_t bytes = std::size_t(rows) * cols * sizeof(float);
  DeviceBuffers buffers;
  float* b = buffers.upload(in.brightness, bytes);
  float* g = buffers.upload(in.gradient, bytes);
  float* s = buffers.upload(in.s.ptr<float>(), bytes);
  float* alpha = buffers.upload(in.smoothness.ptr<float>(), bytes);
  float* direction = buffers.upload(in.direction.ptr<cv::Vec2f>(), 2 * bytes);
  float* d_ds = buffers.zeros(bytes);
  float *psi = buffers.alloc(bytes), *right = buffers.alloc(bytes), *down = buffers.alloc(bytes);
  const LineSystem system{buffers.alloc(bytes), buffers.alloc(bytes)};
  const FlowIncrementOptions& o = in.options;
  const float eps2 = o.epsilon * o.epsilon;
  const dim3 block(16, 8), grid((cols + 15) / 16, (rows + 7) / 8), half((cols / 2 + 16) / 16, (rows + 7) / 8);
  for (int iteration = 0; iteration < o.fixed_point_iterations; ++iteration) {
    smoothness_scalar<<<grid, block>>>(s, d_ds, alpha, psi, cols, rows, eps2);
    edge_weights<<<grid, block>>>(psi, right, down, cols, rows);
    line_system<<<grid, block>>>(b, g, s, d_ds, direction, right, down, system, cols, rows, eps2, o.delta,
                                 o.gamma);
    for (int sweep = 0; sweep < o.sor_iterations; ++sweep)
      for (int colour = 0; colour < 2; ++colour)
        sor_colour_scalar<<<half, block>>>(system, right, down, d_ds, cols, rows, o.omega, colour);
  }
  check(cudaGetLastError(), "kernel launch");
  ds.create(rows, cols);
  check(cudaMemcpy(ds.ptr<float>(), d_ds, bytes, cudaMemcpyDeviceToHost), "download");
}

}  // namespace pg::gpu::detail

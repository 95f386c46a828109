#include "pg/gpu/flow_increments.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>

#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/gpu/cuda_backend.h"
#include "pg/gpu/opencl_runtime.h"

namespace pg::gpu {
namespace {

template <class RowBody>
void for_rows(int rows, const RowBody& body) {
  tbb::parallel_for(tbb::blocked_range<int>(0, rows, 2), [&](const tbb::blocked_range<int>& range) {
    for (int y = range.begin(); y != range.end(); ++y) body(y);
  });
}

// Charbonnier derivative psi'(s^2) = 1 / (2 sqrt(s^2 + eps^2)), times a weight.
inline float robust_weight(float weight, float squared, float epsilon_squared) {
  return weight * 0.5f / std::sqrt(std::max(squared, 0.f) + epsilon_squared);
}

inline float quadratic(const std::array<cv::Mat1f, 6>& j, int y, int x, float du, float dv) {
  return j[0](y, x) * du * du + 2 * j[1](y, x) * du * dv + j[2](y, x) * dv * dv + 2 * j[3](y, x) * du +
         2 * j[4](y, x) * dv + j[5](y, x);
}

struct Weights {
  const cv::Mat1f& right;
  const cv::Mat1f& down;
  float left(int y, int x) const { return x > 0 ? right(y, x - 1) : 0.f; }
  float up(int y, int x) const { return y > 0 ? down(y - 1, x) : 0.f; }
  float total(int y, int x) const { return left(y, x) + right(y, x) + down(y, x) + up(y, x); }
  float neighbours(const cv::Mat1f& f, int y, int x) const {
    const int rows = f.rows, cols = f.cols;
    return left(y, x) * f(y, x > 0 ? x - 1 : x) + right(y, x) * f(y, x + 1 < cols ? x + 1 : x) +
           up(y, x) * f(y > 0 ? y - 1 : y, x) + down(y, x) * f(y + 1 < rows ? y + 1 : y, x);
  }
};

bool tensors_fit(const std::array<cv::Mat1f, 6>& brightness, const std::array<cv::Mat1f, 6>& gradient,
                 const cv::Mat1f& smoothness, cv::Size size) {
  bool ok = size.area() > 0 && smoothness.size() == size && smoothness.isContinuous();
  for (const auto* set : {&brightness, &gradient})
    for (const cv::Mat1f& m : *set) ok = ok && m.size() == size && m.isContinuous();
  return ok;
}

void check_input(const FlowIncrementInput& in) {
  const cv::Size size = in.size();
  if (!tensors_fit(in.brightness, in.gradient, in.smoothness, size) || in.v.size() != size ||
      !in.u.isContinuous() || !in.v.isContinuous())
    throw UsageError("flow increments: tensors, smoothness and flow must be continuous and of one size");
}

void check_input(const LineIncrementInput& in) {
  const cv::Size size = in.size();
  if (!tensors_fit(in.brightness, in.gradient, in.smoothness, size) || in.direction.size() != size ||
      !in.s.isContinuous() || !in.direction.isContinuous())
    throw UsageError(
        "line increments: tensors, smoothness, s and direction must be continuous and of one size");
}

// A non-finite direction component counts as 0: the pixel has no data term along its line.
inline float finite_or_zero(float value) {
  return std::isfinite(value) ? value : 0.f;
}

}  // namespace

void flow_increments_cpu(const FlowIncrementInput& in, cv::Mat1f& du, cv::Mat1f& dv) {
  check_input(in);
  const int rows = in.u.rows, cols = in.u.cols;
  const FlowIncrementOptions& o = in.options;
  const float epsilon_squared = o.epsilon * o.epsilon, omega = o.omega;
  const float damping = 1e-6f;  // keeps the diagonal positive where data and smoothness both vanish
  du.create(rows, cols);
  dv.create(rows, cols);
  du.setTo(0);
  dv.setTo(0);
  cv::Mat1f psi(rows, cols), right(rows, cols), down(rows, cols);
  cv::Mat1f a11_inv(rows, cols), a22_inv(rows, cols), a12(rows, cols), rhs1(rows, cols), rhs2(rows, cols);
  const Weights w{right, down};
  for (int iteration = 0; iteration < o.fixed_point_iterations; ++iteration) {
    // Robust smoothness weight of u + du and v + dv, from forward differences.
    for_rows(rows, [&](int y) {
      const int yn = std::min(y + 1, rows - 1);
      for (int x = 0; x < cols; ++x) {
        const int xn = std::min(x + 1, cols - 1);
        const float a0 = in.u(y, x) + du(y, x);
        const float ax = in.u(y, xn) + du(y, xn) - a0, ay = in.u(yn, x) + du(yn, x) - a0;
        const float b0 = in.v(y, x) + dv(y, x);
        const float bx = in.v(y, xn) + dv(y, xn) - b0, by = in.v(yn, x) + dv(yn, x) - b0;
        const float squared = ax * ax + ay * ay + (bx * bx + by * by);
        psi(y, x) = robust_weight(in.smoothness(y, x), squared, epsilon_squared);
      }
    });
    // Edge weights: the mean of both pixels' weights; zero across the border.
    for_rows(rows, [&](int y) {
      for (int x = 0; x < cols; ++x) {
        right(y, x) = x + 1 < cols ? 0.5f * (psi(y, x) + psi(y, x + 1)) : 0.f;
        down(y, x) = y + 1 < rows ? 0.5f * (psi(y, x) + psi(y + 1, x)) : 0.f;
      }
    });
    // The linear system of this iteration, robust weights frozen.
    for_rows(rows, [&](int y) {
      for (int x = 0; x < cols; ++x) {
        const float psi_b =
            robust_weight(o.delta, quadratic(in.brightness, y, x, du(y, x), dv(y, x)), epsilon_squared);
        const float psi_g =
            robust_weight(o.gamma, quadratic(in.gradient, y, x, du(y, x), dv(y, x)), epsilon_squared);
        const float total = w.total(y, x);
        a11_inv(y, x) =
            1.f / (psi_b * in.brightness[0](y, x) + psi_g * in.gradient[0](y, x) + total + damping);
        a22_inv(y, x) =
            1.f / (psi_b * in.brightness[2](y, x) + psi_g * in.gradient[2](y, x) + total + damping);
        a12(y, x) = psi_b * in.brightness[1](y, x) + psi_g * in.gradient[1](y, x);
        rhs1(y, x) = w.neighbours(in.u, y, x) - total * in.u(y, x) -
                     (psi_b * in.brightness[3](y, x) + psi_g * in.gradient[3](y, x));
        rhs2(y, x) = w.neighbours(in.v, y, x) - total * in.v(y, x) -
                     (psi_b * in.brightness[4](y, x) + psi_g * in.gradient[4](y, x));
      }
    });
    for (int sweep = 0; sweep < o.sor_iterations; ++sweep)
      for (int colour = 0; colour < 2; ++colour)
        for_rows(rows, [&](int y) {
          for (int x = (y + colour) & 1; x < cols; x += 2) {
            const float du_new =
                (1 - omega) * du(y, x) +
                omega * (rhs1(y, x) + w.neighbours(du, y, x) - a12(y, x) * dv(y, x)) * a11_inv(y, x);
            du(y, x) = du_new;
            dv(y, x) = (1 - omega) * dv(y, x) +
                       omega * (rhs2(y, x) + w.neighbours(dv, y, x) - a12(y, x) * du_new) * a22_inv(y, x);
          }
        });
  }
}

void line_increments_cpu(const LineIncrementInput& in, cv::Mat1f& ds) {
  check_input(in);
  const int rows = in.s.rows, cols = in.s.cols;
  const FlowIncrementOptions& o = in.options;
  const float epsilon_squared = o.epsilon * o.epsilon, omega = o.omega;
  const float damping = 1e-6f;
  ds.create(rows, cols);
  ds.setTo(0);
  cv::Mat1f psi(rows, cols), right(rows, cols), down(rows, cols), a_inv(rows, cols), rhs(rows, cols);
  const Weights w{right, down};
  for (int iteration = 0; iteration < o.fixed_point_iterations; ++iteration) {
    for_rows(rows, [&](int y) {
      const int yn = std::min(y + 1, rows - 1);
      for (int x = 0; x < cols; ++x) {
        const int xn = std::min(x + 1, cols - 1);
        const float a0 = in.s(y, x) + ds(y, x);
        const float ax = in.s(y, xn) + ds(y, xn) - a0, ay = in.s(yn, x) + ds(yn, x) - a0;
        psi(y, x) = robust_weight(in.smoothness(y, x), ax * ax + ay * ay, epsilon_squared);
      }
    });
    for_rows(rows, [&](int y) {
      for (int x = 0; x < cols; ++x) {
        right(y, x) = x + 1 < cols ? 0.5f * (psi(y, x) + psi(y, x + 1)) : 0.f;
        down(y, x) = y + 1 < rows ? 0.5f * (psi(y, x) + psi(y + 1, x)) : 0.f;
      }
    });
    // The 2-D system projected on the line direction d: d^T A d ds = -d^T c.
    for_rows(rows, [&](int y) {
      for (int x = 0; x < cols; ++x) {
        const cv::Vec2f d = in.direction(y, x);
        const float dx = finite_or_zero(d[0]), dy = finite_or_zero(d[1]);
        const float du = ds(y, x) * dx, dv = ds(y, x) * dy;
        const float psi_b = robust_weight(o.delta, quadratic(in.brightness, y, x, du, dv), epsilon_squared);
        const float psi_g = robust_weight(o.gamma, quadratic(in.gradient, y, x, du, dv), epsilon_squared);
        const auto mix = [&](int k) { return psi_b * in.brightness[k](y, x) + psi_g * in.gradient[k](y, x); };
        const float a11 = mix(0), a12 = mix(1), a22 = mix(2), c1 = mix(3), c2 = mix(4);
        const float total = w.total(y, x);
        a_inv(y, x) = 1.f / (dx * dx * a11 + 2 * dx * dy * a12 + dy * dy * a22 + total + damping);
        rhs(y, x) = w.neighbours(in.s, y, x) - total * in.s(y, x) - (dx * c1 + dy * c2);
      }
    });
    for (int sweep = 0; sweep < o.sor_iterations; ++sweep)
      for (int colour = 0; colour < 2; ++colour)
        for_rows(rows, [&](int y) {
          for (int x = (y + colour) & 1; x < cols; x += 2)
            ds(y, x) = (1 - omega) * ds(y, x) + omega * (rhs(y, x) + w.neighbours(ds, y, x)) * a_inv(y, x);
        });
  }
}

DeviceFootprint increments_footprint(cv::Size size, IncrementMode mode) {
  const std::uint64_t plane = std::uint64_t(std::max(size.area(), 0)) * sizeof(float);
  // Both tensors as one six-plane buffer each, the flow (or s and the two-plane direction), the
  // smoothness weight and the work planes of flow_increments_opencl / line_increments_opencl.
  const std::uint64_t planes = mode == IncrementMode::free ? 12 + 2 + 1 + 10 : 12 + 1 + 2 + 1 + 6;
  return {planes * plane, 6 * plane};
}

bool fits_on(const DeviceFootprint& footprint, const DeviceInfo& device) {
  return device.kind != DeviceKind::cpu && footprint.total <= device.global_memory &&
         footprint.largest_buffer <= device.max_allocation;
}

int increments_reach(const FlowIncrementOptions& o) {
  // Per fixed-point iteration: the robust weights and the system read up to two rows away, and each
  // of the 2 * sor_iterations colour passes one more.
  return o.fixed_point_iterations * (2 * o.sor_iterations + 3);
}

int increments_band_rows(cv::Size size, IncrementMode mode, const FlowIncrementOptions& options,
                         const DeviceInfo& device) {
  if (device.kind == DeviceKind::cpu || size.area() <= 0) return 0;
  if (fits_on(increments_footprint(size, mode), device)) return size.height;
  // The most rows of this width that fit, less the halos; even, so that bands keep the colouring.
  int fitting = size.height;
  while (fitting > 0 && !fits_on(increments_footprint({size.width, fitting}, mode), device)) fitting /= 2;
  for (int step = fitting / 2; step > 0; step /= 2)
    if (fits_on(increments_footprint({size.width, fitting + step}, mode), device)) fitting += step;
  const int halo = increments_reach(options) + (increments_reach(options) & 1);
  const int band = (fitting - 2 * halo) / 2 * 2;
  return band >= 2 ? band : 0;
}

namespace {

std::atomic<std::uint64_t> memory_limit{0};

}  // namespace

void limit_flow_device_memory(std::uint64_t bytes) {
  memory_limit = bytes;
}

DeviceInfo flow_device_info(DeviceKind device) {
  if (device == DeviceKind::automatic) device = active_device();
  DeviceInfo info;
  if (device == DeviceKind::opencl) {
    if (auto* runtime = detail::OpenClRuntime::get()) info = runtime->info();
  } else if (device == DeviceKind::cuda) {
    std::string reason;
    const std::vector<DeviceInfo> devices = detail::cuda_devices(reason);
    if (!devices.empty()) info = devices.front();
  }
  if (const std::uint64_t limit = memory_limit; limit > 0 && info.kind != DeviceKind::cpu) {
    info.global_memory = std::min(info.global_memory, limit);
    info.max_allocation = std::min(info.max_allocation, limit);
  }
  return info;
}

namespace {

cv::Mat1f rows_of(const cv::Mat1f& m, int begin, int end) {
  return m.rowRange(begin, end);  // full-width rows of a continuous matrix: continuous
}
cv::Mat2f rows_of(const cv::Mat2f& m, int begin, int end) {
  return m.rowRange(begin, end);
}
std::array<cv::Mat1f, 6> rows_of(const std::array<cv::Mat1f, 6>& tensor, int begin, int end) {
  std::array<cv::Mat1f, 6> out;
  for (int k = 0; k < 6; ++k) out[k] = rows_of(tensor[k], begin, end);
  return out;
}

FlowIncrementInput rows_of(const FlowIncrementInput& in, int begin, int end) {
  FlowIncrementInput out;
  out.brightness = rows_of(in.brightness, begin, end), out.gradient = rows_of(in.gradient, begin, end);
  out.smoothness = rows_of(in.smoothness, begin, end);
  out.u = rows_of(in.u, begin, end), out.v = rows_of(in.v, begin, end);
  out.options = in.options;
  return out;
}

LineIncrementInput rows_of(const LineIncrementInput& in, int begin, int end) {
  LineIncrementInput out;
  out.brightness = rows_of(in.brightness, begin, end), out.gradient = rows_of(in.gradient, begin, end);
  out.smoothness = rows_of(in.smoothness, begin, end);
  out.s = rows_of(in.s, begin, end), out.direction = rows_of(in.direction, begin, end);
  out.options = in.options;
  return out;
}

// Runs `solve(band input, band outputs...)` on bands of `band_rows` rows, each with halos of
// increments_reach rows (even, from an even row: the red-black colouring is the whole image's), and
// keeps each band's own rows: exactly the whole-image result, since no row's result reaches further.
template <class Input, class Solve, class... Outputs>
void in_bands(const Input& in, int band_rows, const Solve& solve, Outputs&... outputs) {
  const int rows = in.size().height, cols = in.size().width;
  const int halo = increments_reach(in.options) + (increments_reach(in.options) & 1);
  (outputs.create(rows, cols), ...);
  std::array<cv::Mat1f, sizeof...(Outputs)> band_out;
  for (int y0 = 0; y0 < rows; y0 += band_rows) {
    const int y1 = std::min(rows, y0 + band_rows);
    const int begin = std::max(0, y0 - halo), end = std::min(rows, y1 + halo);
    std::apply([&](auto&... b) { solve(rows_of(in, begin, end), b...); }, band_out);
    int k = 0;
    ((band_out[k++].rowRange(y0 - begin, y1 - begin).copyTo(outputs.rowRange(y0, y1))), ...);
  }
}

template <class Input, class Solve, class... Outputs>
void on_device(const Input& in, DeviceKind device, IncrementMode mode, const Solve& solve,
               Outputs&... outputs) {
  const DeviceInfo info = flow_device_info(device);
  if (info.kind == DeviceKind::cpu) return solve(in, outputs...);  // not usable: the backend says why
  const int band_rows = increments_band_rows(in.size(), mode, in.options, info);
  if (band_rows == 0)
    throw FailedError(str("flow increments: a ", in.size().width, "-pixel-wide level does not fit the ",
                          to_string(device), " device even in bands"));
  if (band_rows >= in.size().height) return solve(in, outputs...);
  in_bands(in, band_rows, solve, outputs...);
}

}  // namespace

void line_increments_banded(const LineIncrementInput& input, cv::Mat1f& ds, DeviceKind device,
                            int band_rows) {
  check_input(input);
  in_bands(
      input, band_rows,
      [&](const LineIncrementInput& band, cv::Mat1f& out) { line_increments(band, out, device); }, ds);
}

void flow_increments_banded(const FlowIncrementInput& input, cv::Mat1f& du, cv::Mat1f& dv, DeviceKind device,
                            int band_rows) {
  check_input(input);
  in_bands(
      input, band_rows,
      [&](const FlowIncrementInput& band, cv::Mat1f& u_out, cv::Mat1f& v_out) {
        flow_increments(band, u_out, v_out, device);
      },
      du, dv);
}

void line_increments(const LineIncrementInput& input, cv::Mat1f& ds, DeviceKind device) {
  if (device == DeviceKind::automatic) device = active_device();
  check_input(input);
  switch (device) {
    case DeviceKind::cuda:
      return on_device(input, device, IncrementMode::line, detail::cuda_line_increments, ds);
    case DeviceKind::opencl:
      return on_device(input, device, IncrementMode::line, line_increments_opencl, ds);
    default:
      return line_increments_cpu(input, ds);
  }
}

void flow_increments(const FlowIncrementInput& input, cv::Mat1f& du, cv::Mat1f& dv, DeviceKind device) {
  if (device == DeviceKind::automatic) device = active_device();
  check_input(input);
  switch (device) {
    case DeviceKind::cuda:
      return on_device(input, device, IncrementMode::free, detail::cuda_flow_increments, du, dv);
    case DeviceKind::opencl:
      return on_device(input, device, IncrementMode::free, flow_increments_opencl, du, dv);
    default:
      return flow_increments_cpu(input, du, dv);
  }
}

}  // namespace pg::gpu

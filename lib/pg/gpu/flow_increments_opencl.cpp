// The OpenCL paths of flow_increments.h and flow_level.h: all buffers stay on the device for the whole
// warp (and, for a FlowLevel, the level's images for the whole level).
#include <mutex>
#include <utility>
#include <vector>

#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/gpu/flow_increments.h"
#include "pg/gpu/flow_level.h"
#include "pg/gpu/opencl_runtime.h"
#include "pg/gpu/staging.h"

#if PG_GPU_HAVE_OPENCL
#include "pg/gpu/kernel_sources.h"
#endif

namespace pg::gpu {

#if PG_GPU_HAVE_OPENCL
namespace {

using detail::PlaneSource;

cl::NDRange round_up(int cols, int rows) {
  const auto up = [](int a, int b) { return std::size_t((a + b - 1) / b * b); };
  return cl::NDRange(up(cols, 16), up(rows, 4));
}
// Work-groups of 16 x 4 (the global sizes are multiples): left to the driver, some pick far worse.
const cl::NDRange group(16, 4);

// The device buffers, one per role. The epipolar mode reuses du for ds, a11_inv for a_inv and rhs1
// for rhs. images: a FlowLevel's derivatives, 12 planes per channel.
enum Slot {
  brightness,
  gradient,
  u,
  v,
  s,
  alpha,
  direction,
  du,
  dv,
  psi,
  right,
  down,
  a11_inv,
  a22_inv,
  a12,
  rhs1,
  rhs2,
  images,
  slot_count
};

// Device buffers and a pinned staging area kept from one warp to the next (a solve runs a warp per
// pyramid level and fixed-point round at few sizes): creating buffers from pageable memory each time
// cost more than the iterations themselves. Each grows when a larger level comes. Never destroyed,
// like the runtime it belongs to. Its mutex is held by one warp, or one FlowLevel, at a time.
class Workspace {
 public:
  static Workspace& get() {
    static Workspace* workspace = new Workspace;
    return *workspace;
  }
  std::mutex mutex;

  cl::Buffer& buffer(Slot slot, std::size_t floats, cl::Context& context) {
    auto& [buffer, capacity] = buffers_[slot];
    if (floats > capacity) {
      buffer = cl::Buffer();  // release the smaller one first
      buffer = cl::Buffer(context, CL_MEM_READ_WRITE, floats * sizeof(float));
      capacity = floats;
    }
    return buffer;
  }
  // Host memory the driver can copy from directly (page-locked where it can), mapped for good.
  float* staging(std::size_t floats, cl::Context& context, cl::CommandQueue& queue) {
    if (floats > staging_floats_) {
      if (staging_) queue.enqueueUnmapMemObject(staging_buffer_, staging_), queue.finish();
      staging_ = nullptr, staging_floats_ = 0;
      staging_buffer_ =
          cl::Buffer(context, CL_MEM_READ_WRITE | CL_MEM_ALLOC_HOST_PTR, floats * sizeof(float));
      staging_ = static_cast<float*>(queue.enqueueMapBuffer(
          staging_buffer_, CL_TRUE, CL_MAP_READ | CL_MAP_WRITE, 0, floats * sizeof(float)));
      staging_floats_ = floats;
    }
    return staging_;
  }

 private:
  std::pair<cl::Buffer, std::size_t> buffers_[slot_count];
  cl::Buffer staging_buffer_;
  float* staging_ = nullptr;
  std::size_t staging_floats_ = 0;
};

// Host planes to copy, one after another, into a slot's buffer.
struct Upload {
  Slot slot;
  std::vector<PlaneSource> planes;
};

// A warp's device buffers, each slot sized for n pixels (the tensors six planes, the direction two),
// and their uploads through the pinned staging area (written before any later command of the
// in-order queue reads them).
class WarpBuffers {
 public:
  WarpBuffers(detail::OpenClRuntime& runtime, std::size_t n) : runtime_(runtime), n_(n) {}
  cl::Buffer& operator[](Slot slot) {
    return Workspace::get().buffer(slot, floats(slot), runtime_.context());
  }
  void upload(const std::vector<Upload>& uploads) {
    std::vector<PlaneSource> all;
    for (const Upload& u : uploads) all.insert(all.end(), u.planes.begin(), u.planes.end());
    float* staging =
        Workspace::get().staging(detail::total_floats(all), runtime_.context(), runtime_.queue());
    detail::gather(all, staging);
    for (const Upload& u : uploads) {
      const std::size_t size = detail::total_floats(u.planes);
      runtime_.queue().enqueueWriteBuffer((*this)[u.slot], CL_FALSE, 0, size * sizeof(float), staging);
      staging += size;
    }
  }

 private:
  std::size_t floats(Slot slot) const {
    return slot == brightness || slot == gradient ? 6 * n_ : slot == direction ? 2 * n_ : n_;
  }
  detail::OpenClRuntime& runtime_;
  std::size_t n_;
};

void check_allocation(detail::OpenClRuntime& runtime, std::size_t n, const char* what, int cols, int rows) {
  if (6 * n * sizeof(float) > runtime.info().max_allocation)
    throw FailedError(str("OpenCL ", what, ": a ", cols, "x", rows, " level exceeds the device's ",
                          runtime.info().max_allocation >> 20, " MiB allocation limit"));
}

// The fixed-point rounds of either mode, their kernels' arguments set: the robust weights, the edge
// weights and the system per round, then the red-black SOR sweeps (the colour is the SOR kernel's
// argument `colour_arg`).
void enqueue_rounds(cl::CommandQueue& queue, cl::Kernel& smoothness, cl::Kernel& edge_weights,
                    cl::Kernel& system, cl::Kernel& sor_colour, cl_uint colour_arg, int cols, int rows,
                    const FlowIncrementOptions& o) {
  const cl::NDRange pixels = round_up(cols, rows), half = round_up((cols + 1) / 2, rows);
  for (int iteration = 0; iteration < o.fixed_point_iterations; ++iteration) {
    queue.enqueueNDRangeKernel(smoothness, cl::NullRange, pixels, group);
    queue.enqueueNDRangeKernel(edge_weights, cl::NullRange, pixels, group);
    queue.enqueueNDRangeKernel(system, cl::NullRange, pixels, group);
    for (int sweep = 0; sweep < o.sor_iterations; ++sweep)
      for (int colour = 0; colour < 2; ++colour) {
        sor_colour.setArg(colour_arg, colour);
        queue.enqueueNDRangeKernel(sor_colour, cl::NullRange, half, group);
      }
  }
}

// The fixed-point iterations of the free mode on the workspace's buffers: the tensors, u, v and alpha
// in; du, dv out.
void enqueue_free_iterations(detail::OpenClRuntime& runtime, WarpBuffers& b, int cols, int rows,
                             const FlowIncrementOptions& o) {
  cl::CommandQueue& queue = runtime.queue();
  cl::Program& program = runtime.program("flow_increments", kernels::flow_increments);
  const std::size_t bytes = std::size_t(rows) * cols * sizeof(float);
  queue.enqueueFillBuffer(b[du], 0.f, 0, bytes);
  queue.enqueueFillBuffer(b[dv], 0.f, 0, bytes);
  const float epsilon_squared = o.epsilon * o.epsilon;
  cl::Kernel smoothness(program, "smoothness"), edge_weights(program, "edge_weights");
  cl::Kernel linear_system(program, "linear_system"), sor_colour(program, "sor_colour");
  cl_uint k = 0;
  for (Slot slot : {u, v, du, dv, alpha, psi}) smoothness.setArg(k++, b[slot]);
  smoothness.setArg(6, cols), smoothness.setArg(7, rows), smoothness.setArg(8, epsilon_squared);
  edge_weights.setArg(0, b[psi]), edge_weights.setArg(1, b[right]), edge_weights.setArg(2, b[down]);
  edge_weights.setArg(3, cols), edge_weights.setArg(4, rows);
  k = 0;
  for (Slot slot : {brightness, gradient, u, v, du, dv, right, down, a11_inv, a22_inv, a12, rhs1, rhs2})
    linear_system.setArg(k++, b[slot]);
  linear_system.setArg(13, cols), linear_system.setArg(14, rows), linear_system.setArg(15, epsilon_squared);
  linear_system.setArg(16, o.delta), linear_system.setArg(17, o.gamma);
  k = 0;
  for (Slot slot : {a11_inv, a22_inv, a12, rhs1, rhs2, right, down, du, dv}) sor_colour.setArg(k++, b[slot]);
  sor_colour.setArg(9, cols), sor_colour.setArg(10, rows), sor_colour.setArg(11, o.omega);

  enqueue_rounds(queue, smoothness, edge_weights, linear_system, sor_colour, 12, cols, rows, o);
}

// The same for the epipolar mode: the tensors, s, alpha and direction in; ds (in du) out.
void enqueue_line_iterations(detail::OpenClRuntime& runtime, WarpBuffers& b, int cols, int rows,
                             const FlowIncrementOptions& o) {
  cl::CommandQueue& queue = runtime.queue();
  cl::Program& program = runtime.program("flow_increments", kernels::flow_increments);
  queue.enqueueFillBuffer(b[du], 0.f, 0, std::size_t(rows) * cols * sizeof(float));
  const float epsilon_squared = o.epsilon * o.epsilon;
  cl::Kernel smoothness(program, "smoothness_scalar"), edge_weights(program, "edge_weights");
  cl::Kernel line_system(program, "line_system"), sor_colour(program, "sor_colour_scalar");
  cl_uint k = 0;
  for (Slot slot : {s, du, alpha, psi}) smoothness.setArg(k++, b[slot]);
  smoothness.setArg(4, cols), smoothness.setArg(5, rows), smoothness.setArg(6, epsilon_squared);
  edge_weights.setArg(0, b[psi]), edge_weights.setArg(1, b[right]), edge_weights.setArg(2, b[down]);
  edge_weights.setArg(3, cols), edge_weights.setArg(4, rows);
  k = 0;
  for (Slot slot : {brightness, gradient, s, du, direction, right, down, a11_inv, rhs1})
    line_system.setArg(k++, b[slot]);
  line_system.setArg(9, cols), line_system.setArg(10, rows), line_system.setArg(11, epsilon_squared);
  line_system.setArg(12, o.delta), line_system.setArg(13, o.gamma);
  k = 0;
  for (Slot slot : {a11_inv, rhs1, right, down, du}) sor_colour.setArg(k++, b[slot]);
  sor_colour.setArg(5, cols), sor_colour.setArg(6, rows), sor_colour.setArg(7, o.omega);

  enqueue_rounds(queue, smoothness, edge_weights, line_system, sor_colour, 8, cols, rows, o);
}

void download(cl::CommandQueue& queue, cl::Buffer& buffer, int rows, int cols, cv::Mat1f& out, bool wait) {
  out.create(rows, cols);
  queue.enqueueReadBuffer(buffer, wait ? CL_TRUE : CL_FALSE, 0, out.total() * sizeof(float),
                          out.ptr<float>());
}

class OpenClFlowLevel final : public detail::FlowLevelBackend {
 public:
  OpenClFlowLevel(detail::OpenClRuntime& runtime, const std::vector<cv::Mat1f>& from,
                  const std::vector<cv::Mat1f>& to, const cv::Mat1f& smoothness, float zeta_squared)
      : runtime_(runtime),
        lock_(Workspace::get().mutex),
        rows_(smoothness.rows),
        cols_(smoothness.cols),
        channels_(int(from.size())),
        zeta_squared_(zeta_squared),
        buffers_(runtime, smoothness.total()) {
    const std::size_t n = smoothness.total();
    check_allocation(runtime, n, "flow level", cols_, rows_);
    // The smoothness weight, and each channel's two images into the first of their six planes.
    cl::Buffer& planes = Workspace::get().buffer(images, 12 * channels_ * n, runtime.context());
    std::vector<PlaneSource> sources{detail::plane_source(smoothness)};
    for (int c = 0; c < channels_; ++c)
      for (const cv::Mat1f* image : {&from[c], &to[c]}) sources.push_back(detail::plane_source(*image));
    float* staging =
        Workspace::get().staging(detail::total_floats(sources), runtime.context(), runtime.queue());
    detail::gather(sources, staging);
    cl::CommandQueue& queue = runtime.queue();
    queue.enqueueWriteBuffer(buffers_[alpha], CL_FALSE, 0, n * sizeof(float), staging);
    for (std::size_t k = 0; k + 1 < sources.size(); ++k)
      queue.enqueueWriteBuffer(planes, CL_FALSE, 6 * k * n * sizeof(float), n * sizeof(float),
                               staging + (k + 1) * n);
    // The derivatives of each image: x, y, xx, xy, yy after its image (as LevelSolver's ImageDerivatives).
    cl::Program& program = runtime.program("flow_increments", kernels::flow_increments);
    cl::Kernel dx(program, "derivative_x"), dy(program, "derivative_y");
    const auto derivative = [&](cl::Kernel& kernel, std::size_t from_plane, std::size_t to_plane) {
      kernel.setArg(0, planes), kernel.setArg(1, cl_long(from_plane * n)),
          kernel.setArg(2, cl_long(to_plane * n));
      kernel.setArg(3, cols_), kernel.setArg(4, rows_);
      queue.enqueueNDRangeKernel(kernel, cl::NullRange, round_up(cols_, rows_), group);
    };
    for (std::size_t k = 0; k + 1 < sources.size(); ++k) {
      const std::size_t base = 6 * k;
      derivative(dx, base, base + 1);
      derivative(dy, base, base + 2);
      derivative(dx, base + 1, base + 3);
      derivative(dy, base + 1, base + 4);
      derivative(dy, base + 2, base + 5);
    }
    queue.finish();  // the staging area is free again
  }

  void flow_increments(const cv::Mat1f& flow_u, const cv::Mat1f& flow_v, const FlowIncrementOptions& o,
                       cv::Mat1f& out_du, cv::Mat1f& out_dv) override {
    guarded([&] {
      warp_tensors(flow_u, flow_v);
      enqueue_free_iterations(runtime_, buffers_, cols_, rows_, o);
      download(runtime_.queue(), buffers_[du], rows_, cols_, out_du, false);
      download(runtime_.queue(), buffers_[dv], rows_, cols_, out_dv, true);
    });
  }

  void line_increments(const cv::Mat1f& flow_u, const cv::Mat1f& flow_v, const cv::Mat1f& line_s,
                       const cv::Mat2f& line_direction, const FlowIncrementOptions& o,
                       cv::Mat1f& ds) override {
    guarded([&] {
      warp_tensors(
          flow_u, flow_v,
          {{s, {detail::plane_source(line_s)}}, {direction, {detail::plane_source(line_direction)}}});
      enqueue_line_iterations(runtime_, buffers_, cols_, rows_, o);
      download(runtime_.queue(), buffers_[du], rows_, cols_, ds, true);
    });
  }

  std::array<cv::Mat1f, 12> tensors(const cv::Mat1f& flow_u, const cv::Mat1f& flow_v) override {
    std::array<cv::Mat1f, 12> out;
    guarded([&] {
      warp_tensors(flow_u, flow_v);
      const std::size_t bytes = std::size_t(rows_) * cols_ * sizeof(float);
      for (int k = 0; k < 12; ++k) {
        out[k].create(rows_, cols_);
        runtime_.queue().enqueueReadBuffer(buffers_[k < 6 ? brightness : gradient], CL_TRUE, (k % 6) * bytes,
                                           bytes, out[k].ptr<float>());
      }
    });
    return out;
  }

 private:
  template <class Body>
  void guarded(const Body& body) {
    try {
      body();
    } catch (const cl::Error& e) {
      throw FailedError(str("OpenCL flow level failed: ", e.what(), " error ", e.err()));
    }
  }

  // Uploads (u, v) and `more`, and computes the tensors into the brightness and gradient buffers.
  void warp_tensors(const cv::Mat1f& flow_u, const cv::Mat1f& flow_v, std::vector<Upload> more = {}) {
    more.push_back({u, {detail::plane_source(flow_u)}});
    more.push_back({v, {detail::plane_source(flow_v)}});
    buffers_.upload(more);
    cl::Program& program = runtime_.program("flow_increments", kernels::flow_increments);
    cl::Kernel kernel(program, "motion_tensors");
    const std::size_t n = std::size_t(rows_) * cols_;
    kernel.setArg(0, Workspace::get().buffer(images, 12 * channels_ * n, runtime_.context()));
    kernel.setArg(1, channels_), kernel.setArg(2, buffers_[u]), kernel.setArg(3, buffers_[v]);
    kernel.setArg(4, buffers_[brightness]), kernel.setArg(5, buffers_[gradient]);
    kernel.setArg(6, cols_), kernel.setArg(7, rows_), kernel.setArg(8, zeta_squared_);
    kernel.setArg(9, zeta_squared_ > 0 ? 1 : 0);
    runtime_.queue().enqueueNDRangeKernel(kernel, cl::NullRange, round_up(cols_, rows_), group);
  }

  detail::OpenClRuntime& runtime_;
  std::unique_lock<std::mutex> lock_;
  int rows_, cols_, channels_;
  float zeta_squared_;
  WarpBuffers buffers_;
};

}  // namespace

void flow_increments_opencl(const FlowIncrementInput& in, cv::Mat1f& out_du, cv::Mat1f& out_dv) {
  auto* runtime = detail::OpenClRuntime::get();
  if (!runtime) throw FailedError(str("OpenCL flow increments: ", opencl_unavailable_reason()));
  const int rows = in.u.rows, cols = in.u.cols;
  check_allocation(*runtime, in.u.total(), "flow increments", cols, rows);
  try {
    const std::lock_guard lock(Workspace::get().mutex);
    WarpBuffers b(*runtime, in.u.total());
    b.upload({{brightness, detail::tensor_sources(in.brightness)},
              {gradient, detail::tensor_sources(in.gradient)},
              {u, {detail::plane_source(in.u)}},
              {v, {detail::plane_source(in.v)}},
              {alpha, {detail::plane_source(in.smoothness)}}});
    enqueue_free_iterations(*runtime, b, cols, rows, in.options);
    download(runtime->queue(), b[du], rows, cols, out_du, false);
    download(runtime->queue(), b[dv], rows, cols, out_dv, true);
  } catch (const cl::Error& e) {
    throw FailedError(str("OpenCL flow increments failed: ", e.what(), " error ", e.err()));
  }
}

void line_increments_opencl(const LineIncrementInput& in, cv::Mat1f& ds) {
  auto* runtime = detail::OpenClRuntime::get();
  if (!runtime) throw FailedError(str("OpenCL line increments: ", opencl_unavailable_reason()));
  const int rows = in.s.rows, cols = in.s.cols;
  check_allocation(*runtime, in.s.total(), "line increments", cols, rows);
  try {
    const std::lock_guard lock(Workspace::get().mutex);
    WarpBuffers b(*runtime, in.s.total());
    b.upload({{brightness, detail::tensor_sources(in.brightness)},
              {gradient, detail::tensor_sources(in.gradient)},
              {s, {detail::plane_source(in.s)}},
              {alpha, {detail::plane_source(in.smoothness)}},
              {direction, {detail::plane_source(in.direction)}}});
    enqueue_line_iterations(*runtime, b, cols, rows, in.options);
    download(runtime->queue(), b[du], rows, cols, ds, true);
  } catch (const cl::Error& e) {
    throw FailedError(str("OpenCL line increments failed: ", e.what(), " error ", e.err()));
  }
}

namespace detail {

std::unique_ptr<FlowLevelBackend> opencl_flow_level(const std::vector<cv::Mat1f>& from,
                                                    const std::vector<cv::Mat1f>& to,
                                                    const cv::Mat1f& smoothness, float zeta_squared) {
  auto* runtime = OpenClRuntime::get();
  if (!runtime) throw FailedError(str("OpenCL flow level: ", opencl_unavailable_reason()));
  try {
    return std::make_unique<OpenClFlowLevel>(*runtime, from, to, smoothness, zeta_squared);
  } catch (const cl::Error& e) {
    throw FailedError(str("OpenCL flow level failed: ", e.what(), " error ", e.err()));
  }
}

}  // namespace detail

#else

void flow_increments_opencl(const FlowIncrementInput&, cv::Mat1f&, cv::Mat1f&) {
  throw FailedError(str("OpenCL flow increments: ", opencl_unavailable_reason()));
}

void line_increments_opencl(const LineIncrementInput&, cv::Mat1f&) {
  throw FailedError(str("OpenCL line increments: ", opencl_unavailable_reason()));
}

namespace detail {

std::unique_ptr<FlowLevelBackend> opencl_flow_level(const std::vector<cv::Mat1f>&,
                                                    const std::vector<cv::Mat1f>&, const cv::Mat1f&, float) {
  throw FailedError(str("OpenCL flow level: ", opencl_unavailable_reason()));
}

}  // namespace detail

#endif

}  // namespace pg::gpu

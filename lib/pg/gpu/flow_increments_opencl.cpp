// The OpenCL path of flow_increments.h: all buffers stay on the device for the whole warp.
#include "pg/gpu/flow_increments.h"

#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/gpu/opencl_runtime.h"

#if PG_GPU_HAVE_OPENCL
#include "pg/gpu/kernel_sources.h"
#endif

namespace pg::gpu {

#if PG_GPU_HAVE_OPENCL
namespace {

// The six tensor entries as consecutive planes of one host array.
std::vector<float> planes(const std::array<cv::Mat1f, 6>& tensor) {
  const std::size_t n = tensor[0].total();
  std::vector<float> out(6 * n);
  for (int k = 0; k < 6; ++k) std::copy(tensor[k].begin(), tensor[k].end(), out.begin() + k * n);
  return out;
}

cl::NDRange round_up(int cols, int rows) {
  const auto up = [](int a, int b) { return std::size_t((a + b - 1) / b * b); };
  return cl::NDRange(up(cols, 16), up(rows, 4));
}

void set_args(cl::Kernel& kernel, std::initializer_list<const cl::Buffer*> buffers) {
  cl_uint k = 0;
  for (const cl::Buffer* b : buffers) kernel.setArg(k++, *b);
}

}  // namespace

void flow_increments_opencl(const FlowIncrementInput& in, cv::Mat1f& du, cv::Mat1f& dv) {
  auto* runtime = detail::OpenClRuntime::get();
  if (!runtime) throw FailedError(str("OpenCL flow increments: ", opencl_unavailable_reason()));
  const int rows = in.u.rows, cols = in.u.cols;
  const std::size_t n = std::size_t(rows) * cols, bytes = n * sizeof(float);
  if (6 * bytes > runtime->info().max_allocation)
    throw FailedError(str("OpenCL flow increments: a ", cols, "x", rows, " level exceeds the device's ",
                          runtime->info().max_allocation >> 20, " MiB allocation limit"));
  try {
    cl::Context& context = runtime->context();
    cl::CommandQueue& queue = runtime->queue();
    cl::Program& program = runtime->program("flow_increments", kernels::flow_increments);
    const auto input = [&](const float* data, std::size_t size) {
      return cl::Buffer(context, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, size, const_cast<float*>(data));
    };
    std::vector<float> brightness_planes = planes(in.brightness), gradient_planes = planes(in.gradient);
    cl::Buffer brightness = input(brightness_planes.data(), 6 * bytes);
    cl::Buffer gradient = input(gradient_planes.data(), 6 * bytes);
    cl::Buffer u = input(in.u.ptr<float>(), bytes), v = input(in.v.ptr<float>(), bytes);
    cl::Buffer alpha = input(in.smoothness.ptr<float>(), bytes);
    std::vector<cl::Buffer> work;
    for (int k = 0; k < 10; ++k) work.emplace_back(context, CL_MEM_READ_WRITE, bytes);
    cl::Buffer &d_du = work[0], &d_dv = work[1], &psi = work[2], &right = work[3], &down = work[4];
    cl::Buffer &a11_inv = work[5], &a22_inv = work[6], &a12 = work[7], &rhs1 = work[8], &rhs2 = work[9];
    queue.enqueueFillBuffer(d_du, 0.f, 0, bytes);
    queue.enqueueFillBuffer(d_dv, 0.f, 0, bytes);

    const FlowIncrementOptions& o = in.options;
    const float epsilon_squared = o.epsilon * o.epsilon;
    cl::Kernel smoothness(program, "smoothness"), edge_weights(program, "edge_weights");
    cl::Kernel linear_system(program, "linear_system"), sor_colour(program, "sor_colour");
    smoothness.setArg(0, u), smoothness.setArg(1, v), smoothness.setArg(2, d_du), smoothness.setArg(3, d_dv);
    smoothness.setArg(4, alpha), smoothness.setArg(5, psi), smoothness.setArg(6, cols);
    smoothness.setArg(7, rows), smoothness.setArg(8, epsilon_squared);
    edge_weights.setArg(0, psi), edge_weights.setArg(1, right), edge_weights.setArg(2, down);
    edge_weights.setArg(3, cols), edge_weights.setArg(4, rows);
    const cl::Buffer* system_args[] = {&brightness, &gradient, &u,       &v,   &d_du, &d_dv, &right,
                                       &down,       &a11_inv,  &a22_inv, &a12, &rhs1, &rhs2};
    for (int k = 0; k < 13; ++k) linear_system.setArg(k, *system_args[k]);
    linear_system.setArg(13, cols), linear_system.setArg(14, rows), linear_system.setArg(15, epsilon_squared);
    linear_system.setArg(16, o.delta), linear_system.setArg(17, o.gamma);
    const cl::Buffer* sor_args[] = {&a11_inv, &a22_inv, &a12, &rhs1, &rhs2, &right, &down, &d_du, &d_dv};
    for (int k = 0; k < 9; ++k) sor_colour.setArg(k, *sor_args[k]);
    sor_colour.setArg(9, cols), sor_colour.setArg(10, rows), sor_colour.setArg(11, o.omega);

    const cl::NDRange pixels = round_up(cols, rows), half = round_up((cols + 1) / 2, rows);
    for (int iteration = 0; iteration < o.fixed_point_iterations; ++iteration) {
      queue.enqueueNDRangeKernel(smoothness, cl::NullRange, pixels);
      queue.enqueueNDRangeKernel(edge_weights, cl::NullRange, pixels);
      queue.enqueueNDRangeKernel(linear_system, cl::NullRange, pixels);
      for (int sweep = 0; sweep < o.sor_iterations; ++sweep)
        for (int colour = 0; colour < 2; ++colour) {
          sor_colour.setArg(12, colour);
          queue.enqueueNDRangeKernel(sor_colour, cl::NullRange, half);
        }
    }
    du.create(rows, cols);
    dv.create(rows, cols);
    queue.enqueueReadBuffer(d_du, CL_FALSE, 0, bytes, du.ptr<float>());
    queue.enqueueReadBuffer(d_dv, CL_TRUE, 0, bytes, dv.ptr<float>());
  } catch (const cl::Error& e) {
    throw FailedError(str("OpenCL flow increments failed: ", e.what(), " error ", e.err()));
  }
}

void line_increments_opencl(const LineIncrementInput& in, cv::Mat1f& ds) {
  auto* runtime = detail::OpenClRuntime::get();
  if (!runtime) throw FailedError(str("OpenCL line increments: ", opencl_unavailable_reason()));
  const int rows = in.s.rows, cols = in.s.cols;
  const std::size_t n = std::size_t(rows) * cols, bytes = n * sizeof(float);
  if (6 * bytes > runtime->info().max_allocation)
    throw FailedError(str("OpenCL line increments: a ", cols, "x", rows, " level exceeds the device's ",
                          runtime->info().max_allocation >> 20, " MiB allocation limit"));
  try {
    cl::Context& context = runtime->context();
    cl::CommandQueue& queue = runtime->queue();
    cl::Program& program = runtime->program("flow_increments", kernels::flow_increments);
    const auto input = [&](const void* data, std::size_t size) {
      return cl::Buffer(context, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, size, const_cast<void*>(data));
    };
    std::vector<float> brightness_planes = planes(in.brightness), gradient_planes = planes(in.gradient);
    cl::Buffer brightness = input(brightness_planes.data(), 6 * bytes);
    cl::Buffer gradient = input(gradient_planes.data(), 6 * bytes);
    cl::Buffer s = input(in.s.ptr<float>(), bytes), alpha = input(in.smoothness.ptr<float>(), bytes);
    cl::Buffer direction = input(in.direction.ptr<cv::Vec2f>(), 2 * bytes);
    std::vector<cl::Buffer> work;
    for (int k = 0; k < 6; ++k) work.emplace_back(context, CL_MEM_READ_WRITE, bytes);
    cl::Buffer &d_ds = work[0], &psi = work[1], &right = work[2], &down = work[3], &a_inv = work[4],
               &rhs = work[5];
    queue.enqueueFillBuffer(d_ds, 0.f, 0, bytes);

    const FlowIncrementOptions& o = in.options;
    const float epsilon_squared = o.epsilon * o.epsilon;
    cl::Kernel smoothness(program, "smoothness_scalar"), edge_weights(program, "edge_weights");
    cl::Kernel line_system(program, "line_system"), sor_colour(program, "sor_colour_scalar");
    set_args(smoothness, {&s, &d_ds, &alpha, &psi});
    smoothness.setArg(4, cols), smoothness.setArg(5, rows), smoothness.setArg(6, epsilon_squared);
    set_args(edge_weights, {&psi, &right, &down});
    edge_weights.setArg(3, cols), edge_weights.setArg(4, rows);
    set_args(line_system, {&brightness, &gradient, &s, &d_ds, &direction, &right, &down, &a_inv, &rhs});
    line_system.setArg(9, cols), line_system.setArg(10, rows), line_system.setArg(11, epsilon_squared);
    line_system.setArg(12, o.delta), line_system.setArg(13, o.gamma);
    set_args(sor_colour, {&a_inv, &rhs, &right, &down, &d_ds});
    sor_colour.setArg(5, cols), sor_colour.setArg(6, rows), sor_colour.setArg(7, o.omega);

    const cl::NDRange pixels = round_up(cols, rows), half = round_up((cols + 1) / 2, rows);
    for (int iteration = 0; iteration < o.fixed_point_iterations; ++iteration) {
      queue.enqueueNDRangeKernel(smoothness, cl::NullRange, pixels);
      queue.enqueueNDRangeKernel(edge_weights, cl::NullRange, pixels);
      queue.enqueueNDRangeKernel(line_system, cl::NullRange, pixels);
      for (int sweep = 0; sweep < o.sor_iterations; ++sweep)
        for (int colour = 0; colour < 2; ++colour) {
          sor_colour.setArg(8, colour);
          queue.enqueueNDRangeKernel(sor_colour, cl::NullRange, half);
        }
    }
    ds.create(rows, cols);
    queue.enqueueReadBuffer(d_ds, CL_TRUE, 0, bytes, ds.ptr<float>());
  } catch (const cl::Error& e) {
    throw FailedError(str("OpenCL line increments failed: ", e.what(), " error ", e.err()));
  }
}

#else

void flow_increments_opencl(const FlowIncrementInput&, cv::Mat1f&, cv::Mat1f&) {
  throw FailedError(str("OpenCL flow increments: ", opencl_unavailable_reason()));
}

void line_increments_opencl(const LineIncrementInput&, cv::Mat1f&) {
  throw FailedError(str("OpenCL line increments: ", opencl_unavailable_reason()));
}

#endif

}  // namespace pg::gpu

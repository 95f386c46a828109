// Accelerated backend benchmark: the CPU reference against the OpenCL kernels (PoCL on a machine
// without a GPU, the GPU's driver where there is one), on the same inputs:
//   flow:  one warp of the flow solver's inner iterations (5 fixed-point x 10 SOR sweeps) at 1536x1024;
//   tsdf:  one 640x480 depth frame of a sphere into ~1.9 M voxels of dense 8^3 blocks.
// Prints each path's time, the ratio and the largest difference (which the tests bound).
// The rasterizer has no OpenCL kernel yet, so it is not timed here.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <string>

#include "pg/gpu/device.h"
#include "pg/gpu/flow_increments.h"
#include "pg/gpu/tsdf_blocks.h"

namespace {

using Clock = std::chrono::steady_clock;

// The best of `repeats` runs, in seconds (the first OpenCL run also compiles the kernel; warm up once).
double best_time(int repeats, const std::function<void()>& run) {
  run();
  double best = 1e30;
  for (int i = 0; i < repeats; ++i) {
    const auto start = Clock::now();
    run();
    best = std::min(best, std::chrono::duration<double>(Clock::now() - start).count());
  }
  return best;
}

pg::gpu::FlowIncrementInput flow_problem(int cols, int rows) {
  pg::gpu::FlowIncrementInput in;
  for (auto* set : {&in.brightness, &in.gradient})
    for (cv::Mat1f& m : *set) m.create(rows, cols);
  for (int y = 0; y < rows; ++y)
    for (int x = 0; x < cols; ++x) {
      const float ix = std::cos(0.21f * x + 0.05f * y), iy = std::sin(0.17f * y - 0.07f * x);
      const float it = -(0.4f * ix - 0.3f * iy) + 0.05f * std::sin(0.01f * x * y);
      const float j[6] = {ix * ix, ix * iy, iy * iy, ix * it, iy * it, it * it};
      for (int k = 0; k < 6; ++k) in.brightness[k](y, x) = j[k], in.gradient[k](y, x) = 0.1f * j[k];
    }
  in.smoothness = cv::Mat1f(rows, cols, 0.02f);
  in.u = cv::Mat1f::zeros(rows, cols);
  in.v = cv::Mat1f::zeros(rows, cols);
  return in;
}

pg::fusion::DepthFrame sphere_frame(int width, int height) {
  pg::fusion::DepthFrame frame;
  frame.name = "sphere";
  pg::Camera& c = frame.camera;
  c.width = width, c.height = height;
  c.intrinsics = {0.9 * width, 0.9 * width, (width - 1) / 2.0, (height - 1) / 2.0};
  c.cam_from_world.translation = {0, 0, 2};
  frame.depth = cv::Mat1f(height, width, std::nanf(""));
  frame.weight = cv::Mat1f(height, width, 1.f);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const Eigen::Vector3d d = c.unproject(Eigen::Vector2d(x, y)).normalized(), o(0, 0, -2);
      const double b = o.dot(d), disc = b * b - (o.squaredNorm() - 0.25);
      if (disc >= 0) frame.depth(y, x) = float((-b - std::sqrt(disc)) * d.z());
    }
  return frame;
}

void report(const char* name, double cpu, double opencl, double difference) {
  std::printf("%-6s cpu %8.3f s   opencl %8.3f s   cpu/opencl %6.2fx   max |difference| %.2e\n", name, cpu,
              opencl, cpu / opencl, difference);
}

}  // namespace

int main() {
  std::printf("OpenCL: %s\n", pg::gpu::opencl_unavailable_reason().empty()
                                  ? "available"
                                  : pg::gpu::opencl_unavailable_reason().c_str());
  for (const auto& d : pg::gpu::list_devices())
    std::printf("device %s:%d %s [%s]%s\n", pg::gpu::to_string(d.kind).c_str(), d.index, d.name.c_str(),
                d.platform.c_str(), d.is_gpu ? " gpu" : "");
  if (!pg::gpu::opencl_unavailable_reason().empty()) return 0;

  const pg::gpu::FlowIncrementInput flow = flow_problem(1536, 1024);
  cv::Mat1f du_cpu, dv_cpu, du_cl, dv_cl;
  const double flow_cpu = best_time(2, [&] { pg::gpu::flow_increments_cpu(flow, du_cpu, dv_cpu); });
  const double flow_cl = best_time(2, [&] { pg::gpu::flow_increments_opencl(flow, du_cl, dv_cl); });
  report("flow", flow_cpu, flow_cl,
         std::max(cv::norm(du_cpu, du_cl, cv::NORM_INF), cv::norm(dv_cpu, dv_cl, cv::NORM_INF)));

  const pg::fusion::DepthFrame frame = sphere_frame(640, 480);
  const double voxel = 0.005;
  const pg::gpu::TsdfBlocks empty = pg::gpu::TsdfBlocks::covering(
      voxel, 4 * voxel, Eigen::Vector3i(-64, -64, -112), Eigen::Vector3i(63, 63, -1));
  pg::gpu::TsdfBlocks cpu = empty, cl = empty;
  const double tsdf_cpu = best_time(2, [&] { cpu = empty, pg::gpu::integrate_blocks_cpu(cpu, frame); });
  const double tsdf_cl = best_time(2, [&] { cl = empty, pg::gpu::integrate_blocks_opencl(cl, frame); });
  double difference = 0;
  for (std::size_t i = 0; i < cpu.distance.size(); ++i)
    difference = std::max(difference, double(std::abs(cpu.distance[i] - cl.distance[i])));
  report("tsdf", tsdf_cpu, tsdf_cl, difference);
  return 0;
}

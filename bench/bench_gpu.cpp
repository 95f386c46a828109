// Accelerated backend benchmark: the CPU reference against the OpenCL kernels (PoCL on a machine
// without a GPU, the GPU's driver where there is one), and the CUDA kernels where built and usable
// (flow and solver), on the same inputs:
//   flow:  one warp of the flow solver's inner iterations (5 fixed-point x 10 SOR sweeps) at 1536x1024;
//   solver: the whole flow solver (pg::compute_flow, every pyramid level, inner iterations on the
//          device as pg-depth --device runs them) on one 1024x768 pair, free and epipolar mode;
//   tsdf:  one 640x480 depth frame of a sphere into ~1.9 M voxels of dense 8^3 blocks;
//   merge: what pg-merge volume does with depth maps: 12 views (640x480) of a ground, box and sphere
//          integrated into a TsdfVolume at a 1 cm voxel (leaf collection, the kernel and the copies
//          in and out of the OpenVDB grids), on the CPU and with the OpenCL kernel.
// Prints each path's time, the ratio and the largest difference (which the tests bound).
// The rasterizer is timed by bench_render_gpu.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <string>
#include <vector>

#include "pg/flow/flow.h"
#include "pg/fusion/fusion_test_scenes.h"
#include "pg/fusion/tsdf_volume.h"
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

// A textured 1024x768 pair, the second image moved right by a smooth 1 to 5 pixels (a valid pair for
// both modes: horizontal epipolar lines).
std::pair<cv::Mat3b, cv::Mat3b> solver_pair() {
  const cv::Size size(1024, 768);
  cv::Mat3f noise(size);
  cv::RNG rng(11);
  rng.fill(noise, cv::RNG::UNIFORM, 0, 255);
  cv::GaussianBlur(noise, noise, {0, 0}, 2.0);
  cv::Mat3b from, to;
  cv::normalize(noise, noise, 0, 255, cv::NORM_MINMAX);
  noise.convertTo(from, CV_8U);
  cv::Mat1f map_x(size), map_y(size);
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x) {
      map_x(y, x) = float(x) - (3.f + 2.f * std::sin(0.006f * float(x)));
      map_y(y, x) = float(y);
    }
  cv::remap(from, to, map_x, map_y, cv::INTER_CUBIC, cv::BORDER_REFLECT);
  return {from, to};
}

// Per-pixel distance between two flows.
cv::Mat1f end_point_distance(const cv::Mat2f& a, const cv::Mat2f& b) {
  std::vector<cv::Mat> parts;
  cv::split(cv::Mat(a - b), parts);
  cv::Mat1f distance;
  cv::magnitude(parts[0], parts[1], distance);
  return distance;
}

// The whole solver on `kind`, once to warm up (kernel compilation) and once timed.
double solver_time(pg::gpu::DeviceKind kind, const std::function<cv::Mat2f()>& solve, cv::Mat2f& flow) {
  pg::gpu::set_requested_device(kind);
  const double seconds = best_time(1, [&] { flow = solve(); });
  pg::gpu::set_requested_device(pg::gpu::DeviceKind::automatic);
  return seconds;
}

// The whole flow solver on the CPU, on OpenCL and (where built and present) on CUDA.
void bench_solver() {
  const auto [from, to] = solver_pair();
  const pg::EpipolarField field{cv::Mat2f(from.size(), cv::Vec2f(0, 0)),
                                cv::Mat2f(from.size(), cv::Vec2f(1, 0))};
  const std::pair<const char*, std::function<cv::Mat2f()>> modes[] = {
      {"free", [&] { return pg::compute_flow(from, to); }},
      {"epipolar", [&] { return pg::compute_epipolar_flow(from, to, field).flow; }}};
  for (const auto& [mode, solve] : modes) {
    cv::Mat2f cpu_flow, device_flow;
    const double cpu = solver_time(pg::gpu::DeviceKind::cpu, solve, cpu_flow);
    const double opencl = solver_time(pg::gpu::DeviceKind::opencl, solve, device_flow);
    const double epe = cv::mean(end_point_distance(cpu_flow, device_flow))[0];
    std::printf(
        "solver %-8s 1024x768 cpu %7.3f s   opencl %7.3f s   cpu/opencl %6.2fx   mean |cpu - opencl| %.2e "
        "px\n",
        mode, cpu, opencl, cpu / opencl, epe);
    if (!pg::gpu::cuda_unavailable_reason().empty()) continue;
    const double cuda = solver_time(pg::gpu::DeviceKind::cuda, solve, device_flow);
    std::printf(
        "solver %-8s 1024x768 cpu %7.3f s   cuda   %7.3f s   cpu/cuda   %6.2fx   mean |cpu - cuda| %.2e px\n",
        mode, cpu, cuda, cpu / cuda, cv::mean(end_point_distance(cpu_flow, device_flow))[0]);
  }
}

// pg-merge's integration of depth maps, on the CPU and on the OpenCL device.
void bench_merge() {
  namespace scenes = pg::fusion::testing;
  pg::Mesh scene = scenes::ground(2.0f);
  scenes::append(scene, scenes::box({0.3f, -0.6f, 0.0f}, {0.9f, 0.0f, 0.5f}));
  scenes::append(scene, scenes::sphere({-0.5f, 0.4f, 0.45f}, 0.45f));
  const pg::TriangleBvh bvh(scene);
  std::vector<pg::fusion::DepthFrame> frames;
  for (const pg::Camera& camera : scenes::orbit(12, 3.0, 1.8, {0, 0, 0.2}, 640, 480, 550))
    frames.push_back(pg::fusion::make_depth_frame(scenes::render_depth(bvh, camera), camera.id, {}));
  const pg::fusion::TsdfOptions options{.voxel_size = 0.01};
  const auto merge = [&](pg::gpu::DeviceKind kind, std::optional<pg::fusion::TsdfVolume>& volume) {
    pg::gpu::set_requested_device(kind);
    const double seconds = best_time(1, [&] {
      volume.emplace(options);
      for (const auto& frame : frames) volume->integrate(frame);
    });
    pg::gpu::set_requested_device(pg::gpu::DeviceKind::automatic);
    return seconds;
  };
  std::optional<pg::fusion::TsdfVolume> cpu, opencl;
  const double cpu_time = merge(pg::gpu::DeviceKind::cpu, cpu);
  const double opencl_time = merge(pg::gpu::DeviceKind::opencl, opencl);
  const pg::fusion::TsdfVolume::Difference difference = opencl->compare(*cpu);
  std::printf(
      "merge  12 x 640x480 voxel 0.01 (%.1f M voxels) cpu %7.3f s   opencl %7.3f s   cpu/opencl %6.2fx   "
      "max |difference| %.2e, weight %.2e relative\n",
      double(cpu->active_voxel_count()) * 1e-6, cpu_time, opencl_time, cpu_time / opencl_time,
      difference.distance, difference.weight_relative);
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
  if (pg::gpu::cuda_unavailable_reason().empty()) {
    cv::Mat1f du_cuda, dv_cuda;
    const double flow_cuda =
        best_time(2, [&] { pg::gpu::flow_increments(flow, du_cuda, dv_cuda, pg::gpu::DeviceKind::cuda); });
    std::printf("flow   cpu %8.3f s   cuda   %8.3f s   cpu/cuda   %6.2fx   max |difference| %.2e\n", flow_cpu,
                flow_cuda, flow_cpu / flow_cuda,
                std::max(cv::norm(du_cpu, du_cuda, cv::NORM_INF), cv::norm(dv_cpu, dv_cuda, cv::NORM_INF)));
  }

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
  bench_merge();

  bench_solver();
  return 0;
}

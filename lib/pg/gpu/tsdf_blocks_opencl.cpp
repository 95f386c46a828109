// The OpenCL path of tsdf_blocks.h: the frame is uploaded once, blocks go in batches.
#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/gpu/opencl_runtime.h"
#include "pg/gpu/tsdf_blocks.h"

#if PG_GPU_HAVE_OPENCL
#include "pg/gpu/kernel_sources.h"
#endif

namespace pg::gpu {

#if PG_GPU_HAVE_OPENCL
namespace {

template <class Real>
std::vector<Real> frame_parameters(const fusion::DepthFrame& frame, const TsdfBlocks& blocks) {
  const Eigen::Matrix3d r = frame.camera.cam_from_world.rotation_matrix();
  const Eigen::Vector3d t = frame.camera.cam_from_world.translation;
  const Intrinsics& k = frame.camera.intrinsics;
  std::vector<double> p;
  for (int row = 0; row < 3; ++row)
    for (int col = 0; col < 3; ++col) p.push_back(r(row, col));
  p.insert(p.end(), {t.x(), t.y(), t.z(), k.fx, k.fy, k.cx, k.cy, blocks.voxel_size, blocks.truncation});
  return std::vector<Real>(p.begin(), p.end());
}

}  // namespace

void integrate_blocks_opencl(TsdfBlocks& blocks, const fusion::DepthFrame& frame) {
  if (!tsdf_kernel_supports(frame))
    throw UsageError(str(frame.name, ": the OpenCL TSDF kernel needs an undistorted pinhole camera"));
  auto* runtime = detail::OpenClRuntime::get();
  if (!runtime) throw FailedError(str("OpenCL TSDF integration: ", opencl_unavailable_reason()));
  if (blocks.distance.size() != blocks.size() * kBlockVoxels ||
      blocks.weight.size() != blocks.distance.size())
    throw UsageError("TSDF blocks: distance and weight arrays do not match the block count");
  if (frame.depth.size() != frame.weight.size() ||
      (!frame.cos_angle.empty() && frame.cos_angle.size() != frame.depth.size()))
    throw UsageError(str(frame.name, ": depth, weight and angle sizes differ"));
  const int rows = frame.depth.rows, cols = frame.depth.cols;
  const std::size_t pixel_bytes = std::size_t(rows) * cols * sizeof(float);
  const std::uint64_t limit = runtime->info().max_allocation;
  if (pixel_bytes > limit)
    throw FailedError(str(frame.name, ": a ", cols, "x", rows, " depth map exceeds the OpenCL device's ",
                          limit >> 20, " MiB allocation limit"));
  // Batches of at most 64 MiB of voxels (and the device's limit), so memory does not bound the volume.
  const std::size_t block_bytes = kBlockVoxels * sizeof(float);
  const std::size_t batch = std::max<std::size_t>(1, std::min<std::uint64_t>(limit, 64u << 20) / block_bytes);
  try {
    cl::Context& context = runtime->context();
    cl::CommandQueue& queue = runtime->queue();
    cl::Program& program = runtime->program("tsdf_blocks", kernels::tsdf_blocks);
    const auto upload = [&](const cv::Mat1f& m) {
      cv::Mat1f c = m.isContinuous() ? m : m.clone();
      return cl::Buffer(context, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, pixel_bytes, c.ptr<float>());
    };
    cl::Buffer depth = upload(frame.depth), weight = upload(frame.weight);
    cl::Buffer cos_angle = frame.cos_angle.empty() ? cl::Buffer(context, CL_MEM_READ_ONLY, sizeof(float))
                                                   : upload(frame.cos_angle);
    cl::Buffer params;
    if (runtime->info().double_precision) {
      auto p = frame_parameters<double>(frame, blocks);
      params =
          cl::Buffer(context, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, p.size() * sizeof(double), p.data());
    } else {
      auto p = frame_parameters<float>(frame, blocks);
      params =
          cl::Buffer(context, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, p.size() * sizeof(float), p.data());
    }
    cl::Kernel kernel(program, "integrate");
    kernel.setArg(3, depth), kernel.setArg(4, weight), kernel.setArg(5, cos_angle);
    kernel.setArg(6, int(!frame.cos_angle.empty())), kernel.setArg(7, cols), kernel.setArg(8, rows);
    kernel.setArg(9, int(frame.kind != DepthKind::perspective_z)), kernel.setArg(10, params);
    for (std::size_t first = 0; first < blocks.size(); first += batch) {
      const std::size_t count = std::min(batch, blocks.size() - first);
      const std::size_t bytes = count * block_bytes;
      std::vector<int> origins(3 * count);
      for (std::size_t b = 0; b < count; ++b)
        for (int a = 0; a < 3; ++a) origins[3 * b + a] = blocks.origins[first + b][a];
      float* distance_host = blocks.distance.data() + first * kBlockVoxels;
      float* weight_host = blocks.weight.data() + first * kBlockVoxels;
      cl::Buffer origin_buffer(context, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, origins.size() * sizeof(int),
                               origins.data());
      cl::Buffer distance(context, CL_MEM_READ_WRITE | CL_MEM_COPY_HOST_PTR, bytes, distance_host);
      cl::Buffer voxel_weight(context, CL_MEM_READ_WRITE | CL_MEM_COPY_HOST_PTR, bytes, weight_host);
      kernel.setArg(0, origin_buffer), kernel.setArg(1, distance), kernel.setArg(2, voxel_weight);
      queue.enqueueNDRangeKernel(kernel, cl::NullRange, cl::NDRange(kBlockVoxels, count), cl::NDRange(64, 1));
      queue.enqueueReadBuffer(distance, CL_FALSE, 0, bytes, distance_host);
      queue.enqueueReadBuffer(voxel_weight, CL_TRUE, 0, bytes, weight_host);
    }
  } catch (const cl::Error& e) {
    throw FailedError(str("OpenCL TSDF integration failed: ", e.what(), " error ", e.err()));
  }
}

#else

void integrate_blocks_opencl(TsdfBlocks&, const fusion::DepthFrame& frame) {
  throw FailedError(str(frame.name, ": OpenCL TSDF integration: ", opencl_unavailable_reason()));
}

#endif

}  // namespace pg::gpu

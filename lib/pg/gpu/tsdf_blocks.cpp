#include "pg/gpu/tsdf_blocks.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "pg/core/error.h"
#include "pg/core/log.h"

namespace pg::gpu {
namespace {

int floor_to_block(int v) {
  return v >= 0 ? v / kBlockSide * kBlockSide : -((-v + 7) / kBlockSide) * kBlockSide;
}

void check_frame(const TsdfBlocks& blocks, const fusion::DepthFrame& frame) {
  if (!(blocks.voxel_size > 0) || !(blocks.truncation > 0))
    throw UsageError("TSDF blocks: voxel size and truncation must be positive");
  if (blocks.distance.size() != blocks.size() * kBlockVoxels ||
      blocks.weight.size() != blocks.distance.size())
    throw UsageError("TSDF blocks: distance and weight arrays do not match the block count");
  if (frame.depth.size() != frame.weight.size() ||
      (!frame.cos_angle.empty() && frame.cos_angle.size() != frame.depth.size()))
    throw FailedError(str(frame.name, ": depth, weight and angle sizes differ"));
}

}  // namespace

TsdfBlocks TsdfBlocks::covering(double voxel_size, double truncation, const Eigen::Vector3i& lo,
                                const Eigen::Vector3i& hi) {
  TsdfBlocks blocks;
  blocks.voxel_size = voxel_size;
  blocks.truncation = truncation;
  for (int x = floor_to_block(lo.x()); x <= hi.x(); x += kBlockSide)
    for (int y = floor_to_block(lo.y()); y <= hi.y(); y += kBlockSide)
      for (int z = floor_to_block(lo.z()); z <= hi.z(); z += kBlockSide) blocks.origins.emplace_back(x, y, z);
  blocks.distance.assign(blocks.size() * kBlockVoxels, 0.f);
  blocks.weight.assign(blocks.size() * kBlockVoxels, 0.f);
  return blocks;
}

Eigen::Vector3d TsdfBlocks::position(std::size_t b, int n) const {
  const Eigen::Vector3i c = origins[b] + Eigen::Vector3i(n >> 6, (n >> 3) & 7, n & 7);
  return Eigen::Vector3d(c.x() * voxel_size, c.y() * voxel_size, c.z() * voxel_size);
}

bool tsdf_kernel_supports(const fusion::DepthFrame& frame) {
  return frame.camera.model == CameraModel::pinhole && frame.camera.distortion.is_zero();
}

void integrate_blocks_cpu(TsdfBlocks& blocks, const fusion::DepthFrame& frame) {
  check_frame(blocks, frame);
  const Camera& camera = frame.camera;
  const Eigen::Matrix3d rotation = camera.cam_from_world.rotation_matrix();
  const Eigen::Vector3d translation = camera.cam_from_world.translation;
  const bool plain_pinhole = tsdf_kernel_supports(frame);
  const Intrinsics& k = camera.intrinsics;
  const double truncation = blocks.truncation;
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, blocks.size()), [&](const tbb::blocked_range<std::size_t>& r) {
        for (std::size_t b = r.begin(); b < r.end(); ++b)
          for (int n = 0; n < kBlockVoxels; ++n) {
            const Eigen::Vector3d p = rotation * blocks.position(b, n) + translation;
            Eigen::Vector2d pixel;
            if (plain_pinhole) {
              if (p.z() <= 0) continue;
              pixel = {k.fx * p.x() / p.z() + k.cx, k.fy * p.y() / p.z() + k.cy};
            } else if (!camera.project(p, pixel)) {
              continue;
            }
            const int px = int(std::floor(pixel.x() + 0.5)), py = int(std::floor(pixel.y() + 0.5));
            if (px < 0 || py < 0 || px >= frame.depth.cols || py >= frame.depth.rows) continue;
            if (!(frame.weight(py, px) > 0)) continue;
            const float d = frame.depth(py, px);
            if (!std::isfinite(d)) continue;
            const double range = p.norm();
            double distance;
            if (frame.kind == DepthKind::perspective_z) {
              if (p.z() <= 0) continue;
              distance = range * (d / p.z() - 1.0);  // the z difference, scaled to a distance along the ray
            } else {
              distance = d - range;
            }
            const double cos_angle = frame.cos_angle.empty() ? 1.0 : frame.cos_angle(py, px);
            const double depth_behind = -std::min(0.0, distance * cos_angle);
            if (depth_behind >= truncation) continue;
            const float w = float(frame.weight(py, px) * (1.0 - depth_behind / truncation));
            const float sample = float(std::clamp(distance, -truncation, truncation));
            const std::size_t i = b * kBlockVoxels + n;
            const float w0 = blocks.weight[i];
            const float d0 = w0 > 0 ? blocks.distance[i] : 0.0f;
            const float w1 = w0 + w;
            blocks.distance[i] = (d0 * w0 + sample * w) / w1;
            blocks.weight[i] = w1;
          }
      });
}

void integrate_blocks(TsdfBlocks& blocks, const fusion::DepthFrame& frame, DeviceKind device) {
  if (device == DeviceKind::automatic) device = active_device();
  // No CUDA TSDF kernel: a CUDA selection uses OpenCL when it can.
  if (device != DeviceKind::cpu && tsdf_kernel_supports(frame) && opencl_unavailable_reason().empty())
    return integrate_blocks_opencl(blocks, frame);
  integrate_blocks_cpu(blocks, frame);
}

}  // namespace pg::gpu

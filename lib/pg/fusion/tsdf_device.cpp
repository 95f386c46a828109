// TsdfVolume::integrate(DepthFrame) on the accelerated device. The leaves a frame touches are copied
// into dense 8^3 blocks (pg/gpu/tsdf_blocks.h: the leaves' own voxel order), the OpenCL kernel
// averages the frame into them with the CPU's update rule (tsdf_volume.cpp: distance along the ray,
// band behind the surface measured across it, weight ramp, running weighted mean) and the blocks are
// written back leaf by leaf. Values agree with the CPU path within float rounding (tested to 1e-5).
// CUDA has no TSDF kernel: a CUDA selection uses OpenCL when there is an OpenCL device.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <atomic>

#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/core/run_report.h"
#include "pg/fusion/tsdf_grids.h"
#include "pg/gpu/tsdf_blocks.h"

namespace pg::fusion {
namespace {

using openvdb::Coord;
using Leaf = openvdb::FloatTree::LeafNodeType;
static_assert(Leaf::DIM == gpu::kBlockSide && Leaf::SIZE == gpu::kBlockVoxels,
              "the device blocks mirror OpenVDB's leaves");

// Leaves per device call: bounds the host copy (4 KiB a leaf) to 128 MiB whatever a frame touches.
// The kernel batches again by the device's allocation limit.
constexpr std::size_t leaves_per_batch = 32768;

// Frames integrated on the device in this process, for the run report.
std::atomic<std::uint64_t> device_frames{0};

// Logs `message` the first time `flag` is passed, so a run of many frames says it once.
void notice_once(std::atomic<bool>& flag, const std::string& message) {
  if (!flag.exchange(true)) log::info(message);
}

bool device_takes(const TsdfVolume::Grids& g, const DepthFrame& frame) {
  if (gpu::active_device() == gpu::DeviceKind::cpu) return false;
  static std::atomic<bool> told_opencl{false}, told_camera{false}, told_color{false};
  if (const std::string reason = gpu::opencl_unavailable_reason(); !reason.empty()) {
    notice_once(told_opencl, str("TSDF integration has no CUDA kernel and no OpenCL device (", reason,
                                 "); integrating on the CPU"));
    return false;
  }
  if (!gpu::tsdf_kernel_supports(frame)) {
    notice_once(told_camera, str(frame.name,
                                 ": the OpenCL TSDF kernel covers undistorted pinhole cameras; frames with "
                                 "other cameras are integrated on the CPU"));
    return false;
  }
  if (g.color && !frame.color.empty()) {
    notice_once(told_color, "colour frames are integrated on the CPU (the OpenCL TSDF kernel has no colour)");
    return false;
  }
  return true;
}

// The current values of leaves [first, first + count): weight 0 where a voxel is inactive.
gpu::TsdfBlocks gather(const TsdfVolume::Grids& g, const std::vector<Coord>& leaves, std::size_t first,
                       std::size_t count) {
  gpu::TsdfBlocks blocks;
  blocks.voxel_size = g.options.voxel_size;
  blocks.truncation = g.truncation;
  blocks.origins.resize(count);
  blocks.distance.resize(count * gpu::kBlockVoxels);
  blocks.weight.resize(count * gpu::kBlockVoxels);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, count), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t b = r.begin(); b < r.end(); ++b) {
      const Coord& origin = leaves[first + b];
      blocks.origins[b] = {origin.x(), origin.y(), origin.z()};
      const Leaf* surface = g.surface->tree().probeConstLeaf(origin);
      const Leaf* weight = g.weight->tree().probeConstLeaf(origin);
      for (int n = 0; n < gpu::kBlockVoxels; ++n) {
        const float w = weight->isValueOn(n) ? weight->getValue(n) : 0.0f;
        blocks.weight[b * gpu::kBlockVoxels + n] = w;
        blocks.distance[b * gpu::kBlockVoxels + n] = w > 0 ? surface->getValue(n) : 0.0f;
      }
    }
  });
  return blocks;
}

// Writes the integrated blocks back; as on the CPU, only voxels with weight become active.
void scatter(TsdfVolume::Grids& g, const gpu::TsdfBlocks& blocks, const std::vector<Coord>& leaves,
             std::size_t first) {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, blocks.size()),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t b = r.begin(); b < r.end(); ++b) {
                        Leaf* surface = g.surface->tree().probeLeaf(leaves[first + b]);
                        Leaf* weight = g.weight->tree().probeLeaf(leaves[first + b]);
                        for (int n = 0; n < gpu::kBlockVoxels; ++n) {
                          const std::size_t i = b * gpu::kBlockVoxels + n;
                          if (!(blocks.weight[i] > 0)) continue;
                          surface->setValueOn(n, blocks.distance[i]);
                          weight->setValueOn(n, blocks.weight[i]);
                        }
                      }
                    });
}

}  // namespace

std::size_t integrate_on_device(TsdfVolume::Grids& grids, const std::vector<Coord>& leaves,
                                const DepthFrame& frame) {
  if (leaves.empty() || !device_takes(grids, frame)) return 0;
  std::size_t done = 0;
  while (done < leaves.size()) {
    const std::size_t count = std::min(leaves_per_batch, leaves.size() - done);
    gpu::TsdfBlocks blocks = gather(grids, leaves, done, count);
    try {
      gpu::integrate_blocks_opencl(blocks, frame);
    } catch (const FailedError& e) {
      log::warn(e.what(), "; integrating the rest of ", frame.name, " on the CPU");
      return done;
    }
    scatter(grids, blocks, leaves, done);
    done += count;
  }
  RunReport::global().set_metric("tsdf_device_frames", ++device_frames);
  return done;
}

}  // namespace pg::fusion

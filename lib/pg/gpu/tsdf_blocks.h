#pragma once
// TSDF integration into dense 8^3 blocks: the accelerated form of TsdfVolume::integrate(DepthFrame)
// (pg/fusion/tsdf_volume.cpp). The blocks have the layout of OpenVDB leaf nodes — voxel (i, j, k) of
// a block at offset 64 i + 8 j + k — so a volume can hand its touched leaves over, integrate them on
// the device and merge the values back into its grids leaf by leaf.
//
// Each voxel at world position voxel_size * (origin + (i, j, k)) is projected into the frame; with a
// valid, weighted depth sample it gets the signed distance along the ray (positive in front of the
// surface), dropped beyond the band behind the surface, clamped to +-truncation, and averaged into
// the block with the pixel's weight ramped down behind the surface (Curless & Levoy).
//
// integrate_blocks_cpu is the reference (double geometry as in the fusion module). The OpenCL kernel
// uses double geometry where the device has fp64 and float otherwise; values agree within 1e-5 (with
// fp64 the kernel repeats the CPU's operation order; on PoCL the values come out the same bits).
// TsdfVolume::integrate(DepthFrame) hands its leaves to integrate_blocks_opencl (fusion/tsdf_device.cpp).
// Frames the kernel does not cover (cameras other than undistorted pinhole) run on the CPU.
#include <Eigen/Core>
#include <vector>

#include "pg/fusion/depth_frame.h"
#include "pg/gpu/device.h"

namespace pg::gpu {

inline constexpr int kBlockSide = 8, kBlockVoxels = 512;

struct TsdfBlocks {
  double voxel_size = 0, truncation = 0;
  std::vector<Eigen::Vector3i> origins;  // voxel coordinates of each block's voxel (0, 0, 0)
  std::vector<float> distance, weight;   // kBlockVoxels per block; weight 0 = not observed

  // Blocks covering the voxel box [lo, hi] (inclusive, voxel coordinates), all unobserved.
  static TsdfBlocks covering(double voxel_size, double truncation, const Eigen::Vector3i& lo,
                             const Eigen::Vector3i& hi);
  std::size_t size() const { return origins.size(); }
  // World position of voxel n of block b.
  Eigen::Vector3d position(std::size_t b, int n) const;
};

// True when the OpenCL kernel handles this frame (undistorted pinhole, no colour needed).
bool tsdf_kernel_supports(const fusion::DepthFrame& frame);

void integrate_blocks_cpu(TsdfBlocks& blocks, const fusion::DepthFrame& frame);
// Blocks are processed in batches that fit the device's allocation limit, so the number of blocks
// is not limited by device memory.
void integrate_blocks_opencl(TsdfBlocks& blocks, const fusion::DepthFrame& frame);
// On `device` (automatic = active_device(); frames the kernel does not cover go to the CPU).
void integrate_blocks(TsdfBlocks& blocks, const fusion::DepthFrame& frame,
                      DeviceKind device = DeviceKind::automatic);

}  // namespace pg::gpu

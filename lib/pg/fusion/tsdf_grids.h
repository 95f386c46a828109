#pragma once
// The OpenVDB grids behind TsdfVolume. Private to lib/pg/fusion: include it only in the few .cpp
// files that need OpenVDB (its headers are heavy).
#include <openvdb/openvdb.h>

#include <Eigen/Core>
#include <array>
#include <cmath>
#include <vector>

#include "pg/fusion/tsdf_volume.h"

namespace pg::fusion {

struct TsdfVolume::Grids {
  TsdfOptions options;
  double truncation = 0;
  openvdb::FloatGrid::Ptr surface;       // weighted mean truncated distance (background +truncation)
  openvdb::FloatGrid::Ptr weight;        // accumulated weight (background 0)
  openvdb::Vec3SGrid::Ptr color;         // weighted mean linear colour, or null
  openvdb::FloatGrid::Ptr color_weight;  // accumulated colour weight, or null
};

// OpenVDB's one-time registration of grid types (thread-safe, idempotent).
void initialize_openvdb();

// TsdfVolume::integrate(DepthFrame) on the accelerated device (tsdf_device.cpp): integrates a prefix
// of `leaves` (allocated already) and returns how many it did, 0 when the frame stays on the CPU
// (device cpu, a camera or colour the kernel does not cover, no OpenCL). A device failure stops it
// at a batch boundary with a warning; the caller integrates the remaining leaves on the CPU.
std::size_t integrate_on_device(TsdfVolume::Grids& grids, const std::vector<openvdb::Coord>& leaves,
                                const DepthFrame& frame);

// Index coordinate of the voxel whose centre is nearest to a world point (voxel centres at i * voxel).
inline openvdb::Coord nearest_voxel(const Eigen::Vector3d& world, double inverse_voxel) {
  return openvdb::Coord(int(std::floor(world.x() * inverse_voxel + 0.5)),
                        int(std::floor(world.y() * inverse_voxel + 0.5)),
                        int(std::floor(world.z() * inverse_voxel + 0.5)));
}

// Triangles from volumeToMesh's mixed output, each quad split along its shorter diagonal. OpenVDB
// winds its polygons clockwise seen from the positive (outside) side; pg meshes are counter-clockwise.
inline std::vector<std::array<std::uint32_t, 3>> triangles_from(const std::vector<openvdb::Vec3s>& points,
                                                                const std::vector<openvdb::Vec3I>& triangles,
                                                                const std::vector<openvdb::Vec4I>& quads) {
  std::vector<std::array<std::uint32_t, 3>> faces;
  faces.reserve(triangles.size() + 2 * quads.size());
  for (const auto& t : triangles) faces.push_back({t[0], t[2], t[1]});
  for (const auto& q : quads) {
    if ((points[q[0]] - points[q[2]]).lengthSqr() <= (points[q[1]] - points[q[3]]).lengthSqr()) {
      faces.push_back({q[0], q[2], q[1]});
      faces.push_back({q[0], q[3], q[2]});
    } else {
      faces.push_back({q[0], q[3], q[1]});
      faces.push_back({q[1], q[3], q[2]});
    }
  }
  return faces;
}

// Whether all eight voxels of the cell holding index-space point p are active in `accessor`'s grid.
template <class Accessor>
bool cell_is_active(const Accessor& accessor, const openvdb::Vec3d& p) {
  const openvdb::Coord base(int(std::floor(p.x())), int(std::floor(p.y())), int(std::floor(p.z())));
  for (int corner = 0; corner < 8; ++corner)
    if (!accessor.isValueOn(base.offsetBy(corner & 1, (corner >> 1) & 1, (corner >> 2) & 1))) return false;
  return true;
}

}  // namespace pg::fusion

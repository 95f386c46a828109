#pragma once
// Volumetric merging after Curless & Levoy 1996: a truncated signed distance and its accumulated
// weight on OpenVDB sparse grids, so memory follows the observed surface, not its bounding box.
// Frames and scans are integrated one at a time; partial volumes from farm jobs add up
// (merge_partial) to the volume of a single run over all inputs. The grids are written as a .vdb
// file Houdini opens (formats/vdb-grids.md). OpenVDB stays inside the .cpp files.
#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>

#include "pg/core/provenance.h"
#include "pg/fusion/depth_frame.h"
#include "pg/fusion/scan.h"
#include "pg/mesh/mesh.h"

namespace pg::fusion {

struct TsdfOptions {
  double voxel_size = 0;         // scene units, > 0
  double truncation = 0;         // half-width of the signed-distance band; 0 = 4 voxels; 1 to 256 voxels
  std::uint64_t max_memory = 0;  // bytes the grids may take; 0 = no limit
  bool color = false;            // keep a colour grid (frames with colour images)
};

struct ExtractOptions {
  double min_weight = 0;  // drop vertices whose accumulated weight is below this
  // Remove disconnected pieces with fewer faces than max(min_component_faces,
  // min_component_fraction * faces of the largest piece).
  std::size_t min_component_faces = 0;
  double min_component_fraction = 0;
};

class TsdfVolume {
 public:
  // The widest band, in voxels: every pixel marks 2 * truncation / voxel voxels along its ray, so a
  // band far wider than any surface's noise only costs time (1e300 never finished).
  static constexpr double max_truncation_voxels = 256;

  explicit TsdfVolume(const TsdfOptions& options);
  ~TsdfVolume();
  TsdfVolume(TsdfVolume&&) noexcept;
  TsdfVolume& operator=(TsdfVolume&&) noexcept;

  // Integrates one depth frame: every voxel within the band of a valid pixel's sample along its ray
  // gets the (truncated) distance along the ray, weighted by the pixel's weight. Throws
  // Error(out_of_memory) before allocating when the grids would exceed max_memory.
  // Undistorted pinhole frames without colour run on the active device (pg/gpu/device.h; a CUDA
  // selection uses OpenCL) with the OpenCL kernel of pg/gpu/tsdf_blocks.h, within 1e-5 of the CPU.
  void integrate(const DepthFrame& frame);
  // Integrates a scan along its sensor rays (a ray cast through each voxel near the scan).
  void integrate(const ScanSurface& scan);
  // Integrates scan points, each along its own sensor ray: every voxel the ray crosses within the
  // truncation band around the point gets the distance from the voxel centre to the point along the
  // ray. Points are applied in input order on one thread, so the result does not depend on threads.
  void integrate(const ScanPoints& points);
  // Adds a partial volume (same voxel size and truncation, else UsageError): the weighted mean of
  // both, as if all their inputs had been integrated into one volume.
  void merge_partial(const TsdfVolume& partial);

  // The zero level set as triangles, only across grid edges whose two voxels are observed and whose
  // distances differ by at most 1.5 truncations (elsewhere a crossing is the back of a frame's band).
  // Adds the vertex property "confidence" (accumulated weight, trilinear over the observed voxels of
  // the cell) and colours when the volume has them.
  Mesh extract_mesh(const ExtractOptions& options = {}) const;

  // Grids "surface" (level set, scene units), "weight", and with colour "Cd" (linear [0, 1] RGB of
  // the 8-bit inputs) and "Cd_weight", with pg metadata (formats/vdb-grids.md). Atomic.
  void write_vdb(const std::filesystem::path& path, const Provenance& provenance) const;
  // Throws InputError(path) for anything not written by write_vdb.
  static TsdfVolume read_vdb(const std::filesystem::path& path, Provenance* provenance = nullptr);
  // Whether a volume file holds colour grids, from its grid names (no grid is read); InputError for a
  // file OpenVDB cannot open.
  static bool vdb_has_color(const std::filesystem::path& path);

  double voxel_size() const;
  double truncation() const;
  bool has_color() const;
  std::size_t leaf_count() const;
  std::uint64_t active_voxel_count() const;
  std::uint64_t memory_bytes() const;  // the grids' own accounting
  // Trilinear samples at a world point (for tests and evaluation); nullopt where unobserved.
  std::optional<float> distance_at(const Eigen::Vector3d& world) const;
  float weight_at(const Eigen::Vector3d& world) const;
  // Largest |difference| of distances and relative difference of weights over both volumes' active
  // voxels (a voxel active in only one counts as infinite).
  struct Difference {
    double distance = 0, weight_relative = 0;
  };
  Difference compare(const TsdfVolume& other) const;

  struct Grids;

 private:
  explicit TsdfVolume(std::unique_ptr<Grids> grids);
  std::unique_ptr<Grids> grids_;
};

}  // namespace pg::fusion

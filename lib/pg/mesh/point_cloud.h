#pragma once
// Points with optional normals, colours, confidence and track length (formats/point-clouds.md),
// stored as a PLY vertex element without faces.
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <filesystem>
#include <vector>

#include "pg/core/provenance.h"
#include "pg/mesh/ply_format.h"

namespace pg {

struct PointCloud {
  std::vector<Eigen::Vector3f> positions;
  std::vector<Eigen::Vector3f> normals;             // empty or positions.size()
  std::vector<std::array<std::uint8_t, 3>> colors;  // empty or positions.size()
  std::vector<float> confidence;                    // empty or positions.size()
  std::vector<std::uint32_t> track_length;  // views that observed the point; empty or positions.size()
  Provenance provenance;

  std::size_t size() const { return positions.size(); }
  // Throws pg::Error (internal) if an attribute's size differs from positions.size().
  void check_consistent() const;
};

// Reads the vertex element of any PLY file (a mesh reads as the cloud of its vertices). Colours as
// in read_mesh_ply; confidence and track_length (any scalar type; track_length a non-negative
// integer) when present. Throws InputError(path, ...).
PointCloud read_point_cloud_ply(const std::filesystem::path& path);

// Writes "comment pg-format pg-point-cloud 1", the provenance, x y z and whichever of nx ny nz,
// red green blue (uchar), confidence (float) and track_length (int) are present, atomically.
void write_point_cloud_ply(const std::filesystem::path& path, const PointCloud& cloud,
                           PlyEncoding encoding = PlyEncoding::binary_little_endian);

}  // namespace pg

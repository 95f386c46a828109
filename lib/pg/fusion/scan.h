#pragma once
// Range scans (LIDAR, structured light, laser triangulation) as triangle meshes with a sensor model,
// integrated along the sensor's rays as in Curless & Levoy 1996 (formats/rgbd-inputs.md).
#include <Eigen/Core>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "pg/fusion/scan_points.h"
#include "pg/geometry/rigid.h"
#include "pg/mesh/mesh.h"

namespace pg::fusion {

// What a scan file holds: triangles (a PLY with faces, an OBJ, a Stanford range grid) or bare points
// (PLY vertices only: read_scan_points), and whether those points carry their own sensor origins.
enum class ScanKind { mesh, points };
struct ScanFileInfo {
  ScanKind kind = ScanKind::mesh;
  bool per_point_origins = false;
  bool has_color = false;  // vertex red, green and blue (PLY meshes and points)
};
// Reads only the header. Throws InputError(path) for a file that is not a PLY (or OBJ).
ScanFileInfo inspect_scan(const std::filesystem::path& path);

// Exactly one of sensor_origin (rays spread from a point: LIDAR, a camera) or sensor_direction
// (parallel rays: a linear scanner such as the Cyberware) is set. Both are in world coordinates.
struct ScanSurface {
  std::string name;
  Mesh mesh;  // world coordinates, triangles
  std::optional<Eigen::Vector3d> sensor_origin;
  std::optional<Eigen::Vector3d> sensor_direction;  // unit, the direction the rays travel
  double multiplier = 1.0;                          // per-input weight factor
  double min_cos = 0;  // samples whose triangle is more grazing than this to the ray are dropped
};

// Reads a scan as a triangle mesh in its own frame: a PLY or OBJ mesh with faces, or a Stanford range
// image PLY (ascii, vertices plus a "range_grid" element of num_rows x num_cols cells), which is
// triangulated over its grid: neighbouring cells join when no edge is longer than max_edge_factor
// times the median grid spacing (so depth discontinuities stay open).
// Throws InputError(path) for a file without faces or grid, or a malformed grid.
Mesh read_scan_mesh(const std::filesystem::path& path, double max_edge_factor = 4.0);

// A scan placement: "bmesh <file> tx ty tz qx qy qz qw" lines of a Stanford .conf file, mapping the
// scan's frame into the world as p_world = R(q)^T p + t (the convention of the Stanford repository,
// see ../shared/data INDEX.md); other lines ("camera", comments) are ignored.
struct ScanPlacement {
  std::filesystem::path file;  // resolved against the .conf file's folder
  Rigid3 world_from_scan;
};
std::vector<ScanPlacement> read_stanford_conf(const std::filesystem::path& path);

// Moves a scan's mesh into the world and sets its sensor: the sensor model is given in the scan's
// own frame (origin or direction) and transformed with it.
ScanSurface place_scan(Mesh mesh, const Rigid3& world_from_scan,
                       const std::optional<Eigen::Vector3d>& origin_in_scan,
                       const std::optional<Eigen::Vector3d>& direction_in_scan, std::string name);

}  // namespace pg::fusion

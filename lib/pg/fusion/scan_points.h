#pragma once
// Range scans stored as bare points (a LIDAR sweep: PLY vertices without faces), each integrated
// along its own sensor ray (formats/rgbd-inputs.md, "Point-cloud scans").
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "pg/geometry/rigid.h"

namespace pg::fusion {

// The points of one scan with the sensor that measured them, in world coordinates. The ray of point
// i starts at origins[i] when per-point origins were read, else at sensor_origin, else it travels
// along sensor_direction (parallel rays); exactly one of the three is given.
struct ScanPoints {
  std::string name;
  std::vector<Eigen::Vector3d> positions;
  std::vector<Eigen::Vector3d> origins;             // empty or positions.size()
  std::vector<Eigen::Vector3f> normals;             // empty or positions.size(): unit, either sign
  std::vector<float> confidence;                    // empty or positions.size()
  std::vector<std::array<std::uint8_t, 3>> colors;  // empty or positions.size(): RGB
  std::optional<Eigen::Vector3d> sensor_origin;
  std::optional<Eigen::Vector3d> sensor_direction;  // unit, the direction the rays travel
  double multiplier = 1.0;                          // per-input weight factor
  bool use_angle = true;                            // weigh by |cos(normal, ray)| where normals were read
  double min_cos = 0;          // with use_angle and normals: drop points more grazing than this
  bool use_confidence = true;  // weigh by the confidence property where it was read
  double max_range = 0;        // drop points farther than this from their origin; 0 = no limit
};

// The vertex property names of a per-point sensor origin (in the scan's frame).
inline constexpr const char* sensor_origin_properties[3] = {"sensor_x", "sensor_y", "sensor_z"};

// Reads the vertices of any PLY (ascii or binary, with or without a pg header) as scan points in the
// scan's own frame: x, y, z (any scalar type), and when present the per-point sensor origin
// sensor_x, sensor_y, sensor_z, the normal nx, ny, nz, "confidence" and the colour red, green, blue
// (any type, ply::color_channel). Faces and other elements are
// ignored. Throws InputError(path) for a malformed file, missing x/y/z or no points.
ScanPoints read_scan_points(const std::filesystem::path& path);

// Moves scan points (read in the scan's frame) into the world. Without per-point origins exactly one
// of origin_in_scan / direction_in_scan must be given (else UsageError); with them both are ignored.
ScanPoints place_scan_points(ScanPoints points, const Rigid3& world_from_scan,
                             const std::optional<Eigen::Vector3d>& origin_in_scan,
                             const std::optional<Eigen::Vector3d>& direction_in_scan);

}  // namespace pg::fusion

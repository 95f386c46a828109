#include "pg/fusion/scan_points.h"

#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/mesh/ply_format.h"

namespace pg::fusion {
namespace {

// The three columns named, or nothing when any of them is missing.
std::optional<std::array<const ply::VertexColumn*, 3>> find_triple(const ply::Contents& contents,
                                                                   const char* a, const char* b,
                                                                   const char* c) {
  const auto* x = contents.find(a);
  const auto* y = contents.find(b);
  const auto* z = contents.find(c);
  if (!x || !y || !z) return std::nullopt;
  return std::array{x, y, z};
}

Eigen::Vector3d row(const std::array<const ply::VertexColumn*, 3>& columns, std::size_t i) {
  return {columns[0]->values[i], columns[1]->values[i], columns[2]->values[i]};
}

}  // namespace

ScanPoints read_scan_points(const std::filesystem::path& path) {
  const ply::Contents contents = ply::read(path, false);
  ScanPoints scan;
  scan.name = path.string();
  const auto xyz = find_triple(contents, "x", "y", "z");
  if (!xyz) throw InputError(path, "PLY vertex element lacks x, y or z");
  const std::size_t n = contents.vertex_count;
  if (n == 0) throw InputError(path, "the scan has no points");
  scan.positions.resize(n);
  for (std::size_t i = 0; i < n; ++i) scan.positions[i] = row(*xyz, i);
  const auto [sx, sy, sz] = sensor_origin_properties;
  if (const auto origin = find_triple(contents, sx, sy, sz)) {
    scan.origins.resize(n);
    for (std::size_t i = 0; i < n; ++i) scan.origins[i] = row(*origin, i);
  }
  if (const auto normal = find_triple(contents, "nx", "ny", "nz")) {
    scan.normals.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      const Eigen::Vector3d v = row(*normal, i);
      // A zero or non-finite normal carries no angle: NaN makes the angle test drop nothing.
      scan.normals[i] =
          v.norm() > 0 ? Eigen::Vector3f(v.normalized().cast<float>()) : Eigen::Vector3f::Constant(NAN);
    }
  }
  if (const auto* confidence = contents.find("confidence")) {
    scan.confidence.resize(n);
    for (std::size_t i = 0; i < n; ++i) scan.confidence[i] = float(confidence->values[i]);
  }
  if (const auto rgb = find_triple(contents, "red", "green", "blue")) {
    scan.colors.resize(n);
    for (std::size_t i = 0; i < n; ++i)
      for (int k = 0; k < 3; ++k) scan.colors[i][k] = ply::color_channel(*(*rgb)[k], (*rgb)[k]->values[i]);
  }
  return scan;
}

ScanPoints place_scan_points(ScanPoints scan, const Rigid3& world_from_scan,
                             const std::optional<Eigen::Vector3d>& origin_in_scan,
                             const std::optional<Eigen::Vector3d>& direction_in_scan) {
  if (!scan.origins.empty()) {
    if (origin_in_scan || direction_in_scan)
      log::info(scan.name, ": the points carry their own sensor origins; the sensor option is ignored");
    scan.sensor_origin.reset();
    scan.sensor_direction.reset();
  } else {
    if (origin_in_scan.has_value() == direction_in_scan.has_value())
      throw UsageError(str(scan.name,
                           ": a point-cloud scan needs exactly one of a sensor origin or a sensor "
                           "direction (or per-point sensor_x, sensor_y, sensor_z)"));
    if (origin_in_scan) scan.sensor_origin = world_from_scan * *origin_in_scan;
    if (direction_in_scan) {
      if (!(direction_in_scan->norm() > 0)) throw UsageError("the sensor direction must not be zero");
      scan.sensor_direction = (world_from_scan.rotation * *direction_in_scan).normalized();
    }
  }
  for (auto& p : scan.positions) p = world_from_scan * p;
  for (auto& o : scan.origins) o = world_from_scan * o;
  for (auto& n : scan.normals) n = (world_from_scan.rotation * n.cast<double>()).cast<float>();
  return scan;
}

}  // namespace pg::fusion

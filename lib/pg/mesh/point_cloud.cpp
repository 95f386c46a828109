#include "pg/mesh/point_cloud.h"

#include <cmath>
#include <limits>

#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/mesh/mesh.h"

namespace fs = std::filesystem;

namespace pg {

void PointCloud::check_consistent() const {
  const auto check = [&](const char* what, std::size_t size) {
    if (size != 0 && size != positions.size())
      throw Error(ExitCode::internal,
                  str("point cloud: ", what, " has ", size, " entries for ", positions.size(), " points"));
  };
  check("normals", normals.size());
  check("colors", colors.size());
  check("confidence", confidence.size());
  check("track_length", track_length.size());
  if (positions.size() > max_vertex_count) throw Error(ExitCode::internal, "point cloud: too many points");
  for (std::uint32_t t : track_length)
    if (t > std::uint32_t(std::numeric_limits<std::int32_t>::max()))
      throw Error(ExitCode::internal, "point cloud: track_length does not fit a PLY int");
}

PointCloud read_point_cloud_ply(const fs::path& path) {
  const ply::Contents contents = ply::read(path, false);
  ply::require_finite_positions(contents, path);
  PointCloud cloud;
  ply::read_pg_comments(contents, path, {"pg-mesh", "pg-point-cloud"}, cloud.provenance);
  const std::size_t n = contents.vertex_count;
  const auto* x = contents.find("x");
  const auto* y = contents.find("y");
  const auto* z = contents.find("z");
  if (!x || !y || !z) throw InputError(path, "PLY vertex element lacks x, y or z");
  cloud.positions.resize(n);
  for (std::size_t i = 0; i < n; ++i)
    cloud.positions[i] = {float(x->values[i]), float(y->values[i]), float(z->values[i])};
  const auto* nx = contents.find("nx");
  const auto* ny = contents.find("ny");
  const auto* nz = contents.find("nz");
  if (nx && ny && nz) {
    cloud.normals.resize(n);
    for (std::size_t i = 0; i < n; ++i)
      cloud.normals[i] = {float(nx->values[i]), float(ny->values[i]), float(nz->values[i])};
  }
  const auto* red = contents.find("red");
  const auto* green = contents.find("green");
  const auto* blue = contents.find("blue");
  if (red && green && blue) {
    const ply::VertexColumn* rgb[3] = {red, green, blue};
    cloud.colors.resize(n);
    for (std::size_t i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c) cloud.colors[i][c] = ply::color_channel(*rgb[c], rgb[c]->values[i]);
  }
  if (const auto* confidence = contents.find("confidence")) {
    cloud.confidence.resize(n);
    for (std::size_t i = 0; i < n; ++i) cloud.confidence[i] = float(confidence->values[i]);
  }
  if (const auto* track = contents.find("track_length")) {
    cloud.track_length.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      const double t = track->values[i];
      if (!(t >= 0) || t != std::floor(t) || t > 4294967295.0)
        throw InputError(path, str("track_length of point ", i, " is ", t, ", not a non-negative integer"));
      cloud.track_length[i] = std::uint32_t(t);
    }
  }
  return cloud;
}

void write_point_cloud_ply(const fs::path& path, const PointCloud& cloud, PlyEncoding encoding) {
  cloud.check_consistent();
  ply::WriteRequest request;
  request.encoding = encoding;
  request.format_name = "pg-point-cloud";
  request.provenance = cloud.provenance;
  request.vertex_count = cloud.size();
  ply::add_point_columns(request, cloud.positions, cloud.normals, cloud.colors);
  if (!cloud.confidence.empty())
    request.columns.push_back({"confidence", ply::Type::float32, cloud.confidence.data(), sizeof(float)});
  // uint32 counts below 2^31 (checked above) have the same bits as the int32 the file declares.
  if (!cloud.track_length.empty())
    request.columns.push_back(
        {"track_length", ply::Type::int32, cloud.track_length.data(), sizeof(std::uint32_t)});
  ply::write(path, request);
}

}  // namespace pg

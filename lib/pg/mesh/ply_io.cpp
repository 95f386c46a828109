#include "pg/mesh/ply_io.h"

#include <algorithm>
#include <cmath>
#include <set>

#include "pg/core/error.h"
#include "pg/core/log.h"

namespace fs = std::filesystem;

namespace pg {
namespace {

// Vertex property names with a fixed meaning; a named property may not use them.
const std::set<std::string, std::less<>> reserved_names = {
    "x", "y", "z", "nx", "ny", "nz", "red", "green", "blue", "s", "t", "u", "v", "texture_u", "texture_v"};

constexpr std::pair<const char*, const char*> uv_names[] = {
    {"s", "t"}, {"u", "v"}, {"texture_u", "texture_v"}};

}  // namespace

Mesh read_mesh_ply(const fs::path& path) {
  const ply::Contents contents = ply::read(path, true);
  ply::require_finite_positions(contents, path);
  Mesh mesh;
  ply::read_pg_comments(contents, path, {"pg-mesh", "pg-point-cloud"}, mesh.provenance);
  const std::size_t n = contents.vertex_count;
  std::set<std::string, std::less<>> used;
  const auto take = [&](std::initializer_list<const char*> names) {
    std::vector<const ply::VertexColumn*> columns;
    for (const char* name : names) columns.push_back(contents.find(name));
    if (std::find(columns.begin(), columns.end(), nullptr) != columns.end()) return decltype(columns){};
    for (const char* name : names) used.insert(name);
    return columns;
  };

  const auto xyz = take({"x", "y", "z"});
  if (xyz.empty()) throw InputError(path, "PLY vertex element lacks x, y or z");
  mesh.positions.resize(n);
  for (std::size_t i = 0; i < n; ++i)
    mesh.positions[i] = {float(xyz[0]->values[i]), float(xyz[1]->values[i]), float(xyz[2]->values[i])};
  if (const auto normal = take({"nx", "ny", "nz"}); !normal.empty()) {
    mesh.normals.resize(n);
    for (std::size_t i = 0; i < n; ++i)
      mesh.normals[i] = {float(normal[0]->values[i]), float(normal[1]->values[i]),
                         float(normal[2]->values[i])};
  }
  if (const auto rgb = take({"red", "green", "blue"}); !rgb.empty()) {
    mesh.colors.resize(n);
    for (std::size_t i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c) mesh.colors[i][c] = ply::color_channel(*rgb[c], rgb[c]->values[i]);
  }
  for (const auto& [u_name, v_name] : uv_names) {
    const auto uv = take({u_name, v_name});
    if (uv.empty()) continue;
    mesh.uvs.resize(n);
    for (std::size_t i = 0; i < n; ++i) mesh.uvs[i] = {float(uv[0]->values[i]), float(uv[1]->values[i])};
    break;
  }
  for (const auto& column : contents.vertex_columns) {
    if (used.count(column.name)) continue;
    auto& values = mesh.vertex_properties[column.name];
    values.resize(n);
    std::transform(column.values.begin(), column.values.end(), values.begin(),
                   [](double v) { return float(v); });
  }
  mesh.faces = contents.triangles;
  return mesh;
}

void write_mesh_ply(const fs::path& path, const Mesh& mesh, PlyEncoding encoding) {
  mesh.check_consistent();
  ply::WriteRequest request;
  request.encoding = encoding;
  request.format_name = "pg-mesh";
  request.provenance = mesh.provenance;
  request.vertex_count = mesh.vertex_count();
  ply::add_point_columns(request, mesh.positions, mesh.normals, mesh.colors);
  if (!mesh.uvs.empty()) {
    static_assert(sizeof(Eigen::Vector2f) == 8);
    const float* uv = mesh.uvs.front().data();
    request.columns.push_back({"s", ply::Type::float32, uv, sizeof(Eigen::Vector2f)});
    request.columns.push_back({"t", ply::Type::float32, uv + 1, sizeof(Eigen::Vector2f)});
  }
  for (const auto& [name, values] : mesh.vertex_properties) {
    if (values.empty()) continue;
    if (reserved_names.count(name))
      throw OutputError(path,
                        str("vertex property \"", name, "\" would be read back as a standard attribute"));
    request.columns.push_back({name, ply::Type::float32, values.data(), sizeof(float)});
  }
  request.write_faces = true;
  request.faces = mesh.faces;
  ply::write(path, request);
}

}  // namespace pg

#include "pg/fusion/scan.h"

#include <algorithm>
#include <fstream>
#include <sstream>

#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/mesh/mesh_io.h"

namespace pg::fusion {
namespace {

constexpr std::uint64_t max_grid_cells = std::uint64_t{1} << 28;

struct RangeGridHeader {
  std::uint64_t vertices = 0, cells = 0;
  std::uint64_t rows = 0, cols = 0;
  int vertex_properties = 0, x_index = -1, y_index = -1, z_index = -1;
  bool ascii = false, has_grid = false, has_faces = false, has_vertex_list = false;
  std::vector<std::string> vertex_names;
};

RangeGridHeader read_header(std::istream& in, const std::filesystem::path& path) {
  RangeGridHeader h;
  std::string line, current;
  if (!std::getline(in, line) || line.rfind("ply", 0) != 0) throw InputError(path, "not a PLY file");
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();  // headers written on Windows
    std::istringstream words(line);
    std::string word;
    words >> word;
    if (word == "end_header") return h;
    if (word == "format") {
      std::string encoding;
      words >> encoding;
      h.ascii = encoding == "ascii";
    } else if (word == "obj_info") {
      std::string key;
      std::uint64_t value = 0;
      words >> key >> value;
      if (key == "num_cols") h.cols = value;
      if (key == "num_rows") h.rows = value;
    } else if (word == "element") {
      std::uint64_t count = 0;
      words >> current >> count;
      if (current == "vertex") h.vertices = count;
      if (current == "range_grid") h.cells = count, h.has_grid = true;
      if (current == "face") h.has_faces = count > 0;
    } else if (word == "property" && current == "vertex") {
      std::string type, name;
      words >> type >> name;
      if (type == "list") {
        h.has_vertex_list = true;
        continue;
      }
      h.vertex_names.push_back(name);
      if (name == "x") h.x_index = h.vertex_properties;
      if (name == "y") h.y_index = h.vertex_properties;
      if (name == "z") h.z_index = h.vertex_properties;
      ++h.vertex_properties;
    }
  }
  throw InputError(path, "PLY header has no end_header");
}

// Triangulates a range grid: each 2x2 block of cells gives up to two triangles (the split along the
// shorter diagonal when all four cells hold a point), refusing edges longer than max_edge.
void triangulate_grid(Mesh& mesh, const std::vector<std::int64_t>& cell_vertex, std::uint64_t rows,
                      std::uint64_t cols, double max_edge_factor) {
  auto at = [&](std::uint64_t r, std::uint64_t c) { return cell_vertex[r * cols + c]; };
  std::vector<float> spacing;
  for (std::uint64_t r = 0; r < rows; ++r)
    for (std::uint64_t c = 0; c + 1 < cols; ++c)
      if (at(r, c) >= 0 && at(r, c + 1) >= 0)
        spacing.push_back((mesh.positions[at(r, c)] - mesh.positions[at(r, c + 1)]).norm());
  if (spacing.empty()) return;
  std::nth_element(spacing.begin(), spacing.begin() + spacing.size() / 2, spacing.end());
  const float max_edge = float(max_edge_factor) * spacing[spacing.size() / 2];
  auto close = [&](std::int64_t a, std::int64_t b) {
    return (mesh.positions[a] - mesh.positions[b]).norm() <= max_edge;
  };
  auto add = [&](std::int64_t a, std::int64_t b, std::int64_t c) {
    if (a >= 0 && b >= 0 && c >= 0 && close(a, b) && close(b, c) && close(c, a))
      mesh.faces.push_back({std::uint32_t(a), std::uint32_t(b), std::uint32_t(c)});
  };
  for (std::uint64_t r = 0; r + 1 < rows; ++r)
    for (std::uint64_t c = 0; c + 1 < cols; ++c) {
      const std::int64_t a = at(r, c), b = at(r, c + 1), d = at(r + 1, c), e = at(r + 1, c + 1);
      const bool all = a >= 0 && b >= 0 && d >= 0 && e >= 0;
      if (all &&
          (mesh.positions[a] - mesh.positions[e]).norm() > (mesh.positions[b] - mesh.positions[d]).norm()) {
        add(a, b, d);
        add(b, e, d);
      } else if (all) {
        add(a, b, e);
        add(a, e, d);
      } else {
        // Three cells of the block: the one triangle they make.
        if (a < 0) add(b, e, d);
        if (b < 0) add(a, e, d);
        if (d < 0) add(a, b, e);
        if (e < 0) add(a, b, d);
      }
    }
}

Mesh read_range_grid(const std::filesystem::path& path, double max_edge_factor) {
  std::ifstream in(path);
  if (!in) throw InputError(path, "cannot open");
  const RangeGridHeader h = read_header(in, path);
  if (!h.has_grid)
    throw InputError(path, "neither faces nor a range_grid element: a scan needs its triangles or grid");
  if (!h.ascii) throw InputError(path, "only ascii range-grid PLY files are supported");
  if (h.has_vertex_list) throw InputError(path, "list properties on range-grid vertices are not supported");
  if (h.x_index < 0 || h.y_index < 0 || h.z_index < 0) throw InputError(path, "vertices lack x, y or z");
  if (h.rows == 0 || h.cols == 0 || h.rows > max_grid_cells || h.cols > max_grid_cells ||
      h.rows * h.cols != h.cells)
    throw InputError(path, str("range_grid has ", h.cells, " cells but obj_info num_rows x num_cols is ",
                               h.rows, "x", h.cols));
  if (h.cells > max_grid_cells || h.vertices > h.cells)
    throw InputError(path, "implausibly large range grid");
  // Every ascii value takes at least two bytes (a digit and a separator): a header may not claim
  // more vertices and cells than the file can hold, so allocations stay bounded by the file's size.
  std::error_code size_error;
  const std::uint64_t file_bytes = std::filesystem::file_size(path, size_error);
  if (size_error || h.cells * 2 + h.vertices * 2 * std::uint64_t(h.vertex_properties) > file_bytes)
    throw InputError(path, str("the header claims ", h.vertices, " vertices and ", h.cells,
                               " grid cells, more than the file's ", file_bytes, " bytes can hold"));

  Mesh mesh;
  mesh.positions.reserve(h.vertices);
  std::vector<double> values(h.vertex_properties);
  for (std::uint64_t i = 0; i < h.vertices; ++i) {
    for (double& v : values)
      if (!(in >> v)) throw InputError(path, str("truncated or malformed vertex ", i));
    mesh.positions.emplace_back(float(values[h.x_index]), float(values[h.y_index]), float(values[h.z_index]));
  }
  std::vector<std::int64_t> cell_vertex(h.cells, -1);
  for (std::uint64_t i = 0; i < h.cells; ++i) {
    int count = 0;
    if (!(in >> count) || count < 0 || count > 1)
      throw InputError(path, str("range_grid cell ", i, " is malformed"));
    if (count == 1) {
      std::int64_t index = -1;
      if (!(in >> index) || index < 0 || std::uint64_t(index) >= h.vertices)
        throw InputError(path, str("range_grid cell ", i, " names a vertex out of range"));
      cell_vertex[i] = index;
    }
  }
  triangulate_grid(mesh, cell_vertex, h.rows, h.cols, max_edge_factor);
  if (mesh.faces.empty()) throw InputError(path, "the range grid gives no triangles");
  return mesh;
}

bool is_obj(const std::filesystem::path& path) {
  return path.extension() == ".obj" || path.extension() == ".OBJ";
}

RangeGridHeader read_header(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "cannot open");
  return read_header(in, path);
}

}  // namespace

ScanFileInfo inspect_scan(const std::filesystem::path& path) {
  if (is_obj(path)) return {};
  const RangeGridHeader h = read_header(path);
  const auto& names = h.vertex_names;
  auto has = [&](const char* name) { return std::find(names.begin(), names.end(), name) != names.end(); };
  const bool has_color = has("red") && has("green") && has("blue");
  if (h.has_faces || h.has_grid) return {.kind = ScanKind::mesh, .has_color = h.has_faces && has_color};
  return {ScanKind::points,
          has(sensor_origin_properties[0]) && has(sensor_origin_properties[1]) &&
              has(sensor_origin_properties[2]),
          has_color};
}

Mesh read_scan_mesh(const std::filesystem::path& path, double max_edge_factor) {
  if (is_obj(path) || read_header(path).has_faces) {
    Mesh mesh = read_mesh(path);
    if (mesh.faces.empty()) throw InputError(path, "the scan has no faces");
    return mesh;
  }
  return read_range_grid(path, max_edge_factor);
}

std::vector<ScanPlacement> read_stanford_conf(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path, "cannot open the scan alignment file");
  std::vector<ScanPlacement> placements;
  std::string line;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    std::istringstream words(line);
    std::string keyword, file;
    words >> keyword;
    if (keyword != "bmesh") continue;
    double t[3], q[4];
    if (!(words >> file >> t[0] >> t[1] >> t[2] >> q[0] >> q[1] >> q[2] >> q[3]))
      throw InputError(path, str("line ", line_number, ": expected \"bmesh file tx ty tz qx qy qz qw\""));
    const Eigen::Quaterniond rotation(q[3], q[0], q[1], q[2]);
    if (!(std::abs(rotation.norm() - 1) < 1e-3))
      throw InputError(path, str("line ", line_number, ": quaternion is not unit"));
    ScanPlacement p;
    p.file = path.parent_path() / file;
    p.world_from_scan = Rigid3{rotation.normalized().conjugate(), Eigen::Vector3d(t[0], t[1], t[2])};
    placements.push_back(p);
  }
  if (placements.empty()) throw InputError(path, "no \"bmesh\" lines");
  return placements;
}

ScanSurface place_scan(Mesh mesh, const Rigid3& world_from_scan,
                       const std::optional<Eigen::Vector3d>& origin_in_scan,
                       const std::optional<Eigen::Vector3d>& direction_in_scan, std::string name) {
  if (origin_in_scan.has_value() == direction_in_scan.has_value())
    throw UsageError("a scan needs exactly one of a sensor origin or a sensor direction");
  ScanSurface scan;
  scan.name = std::move(name);
  for (auto& p : mesh.positions) p = (world_from_scan * p.cast<double>()).cast<float>();
  mesh.normals.clear();
  scan.mesh = std::move(mesh);
  if (origin_in_scan) scan.sensor_origin = world_from_scan * *origin_in_scan;
  if (direction_in_scan) {
    if (!(direction_in_scan->norm() > 0)) throw UsageError("the sensor direction must not be zero");
    scan.sensor_direction = (world_from_scan.rotation * *direction_in_scan).normalized();
  }
  return scan;
}

}  // namespace pg::fusion

#include "pg/mesh/obj_io.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <map>
#include <optional>

#include "pg/core/atomic_file.h"
#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/mesh/ply_io.h"

namespace fs = std::filesystem;

namespace pg {
namespace {

std::vector<std::string_view> split(std::string_view line, char separator_a, char separator_b) {
  std::vector<std::string_view> words;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == separator_a || line[i] == separator_b)) ++i;
    const std::size_t start = i;
    while (i < line.size() && line[i] != separator_a && line[i] != separator_b) ++i;
    if (i > start) words.push_back(line.substr(start, i - start));
  }
  return words;
}

std::optional<float> parse_float(std::string_view word) {
  if (word.size() > 1 && word.front() == '+') word.remove_prefix(1);
  float value = 0;
  const auto [ptr, ec] = std::from_chars(word.data(), word.data() + word.size(), value);
  if (ec != std::errc() || ptr != word.data() + word.size()) return std::nullopt;
  return value;
}

// A face corner: indices into the file's v, vt and vn lists (vt, vn: -1 when absent).
struct Corner {
  std::int64_t v = -1, vt = -1, vn = -1;
  auto operator<=>(const Corner&) const = default;
};

class ObjReader {
 public:
  explicit ObjReader(const fs::path& path) : path_(path) {}

  Mesh read() {
    std::error_code ec;
    if (!fs::is_regular_file(path_, ec)) throw InputError(path_, "no such file");
    std::ifstream in(path_, std::ios::binary);
    if (!in) throw InputError(path_, "cannot open for reading");
    std::string line;
    while (std::getline(in, line)) {
      ++line_number_;
      if (!line.empty() && line.back() == '\r') line.pop_back();
      parse_line(line);
    }
    if (in.bad()) throw InputError(path_, "read error");
    return build();
  }

 private:
  [[noreturn]] void fail(const std::string& problem) const {
    throw InputError(path_, str("line ", line_number_, ": ", problem));
  }

  std::vector<float> numbers(const std::vector<std::string_view>& words, std::size_t min, std::size_t max) {
    if (words.size() - 1 < min || words.size() - 1 > max)
      fail(str("\"", words[0], "\" expects ", min, (min == max ? "" : str(" to ", max)), " numbers"));
    std::vector<float> out;
    for (std::size_t i = 1; i < words.size(); ++i) {
      const auto value = parse_float(words[i]);
      if (!value) fail(str("\"", words[i], "\" is not a number"));
      if (!std::isfinite(*value)) fail(str("\"", words[i], "\" is not a finite number"));
      out.push_back(*value);
    }
    return out;
  }

  // A 1-based (or negative, relative) OBJ index into a list that currently has `count` entries.
  std::int64_t resolve(std::string_view word, std::size_t count, const char* what) {
    std::int64_t index = 0;
    const auto [ptr, ec] = std::from_chars(word.data(), word.data() + word.size(), index);
    if (ec != std::errc() || ptr != word.data() + word.size() || index == 0)
      fail(str("\"", word, "\" is not a valid ", what, " index"));
    const std::int64_t resolved = index > 0 ? index - 1 : std::int64_t(count) + index;
    if (resolved < 0 || resolved >= std::int64_t(count))
      fail(str(what, " index ", index, " out of range (", count, " defined so far)"));
    return resolved;
  }

  Corner parse_corner(std::string_view word) {
    // v, v/vt, v//vn or v/vt/vn.
    std::string_view parts[3];
    int n = 0;
    std::size_t start = 0;
    while (true) {
      const std::size_t slash = word.find('/', start);
      if (n == 3) fail(str("face corner \"", word, "\" has too many '/'"));
      parts[n++] =
          word.substr(start, slash == std::string_view::npos ? std::string_view::npos : slash - start);
      if (slash == std::string_view::npos) break;
      start = slash + 1;
    }
    Corner corner;
    corner.v = resolve(parts[0], positions_.size(), "vertex");
    if (n >= 2 && !parts[1].empty()) corner.vt = resolve(parts[1], uvs_.size(), "texture coordinate");
    if (n == 3) {
      if (parts[2].empty()) fail(str("face corner \"", word, "\" has an empty normal index"));
      corner.vn = resolve(parts[2], normals_.size(), "normal");
    }
    return corner;
  }

  void parse_line(std::string_view line) {
    if (!line.empty() && line.front() == '#') return parse_comment(line.substr(1));
    const auto words = split(line, ' ', '\t');
    if (words.empty()) return;
    const std::string_view keyword = words[0];
    if (keyword == "v") {
      const auto values = numbers(words, 3, 6);
      if (values.size() == 5) fail("\"v\" expects x y z, x y z w or x y z r g b");
      positions_.emplace_back(values[0], values[1], values[2]);
      if (values.size() == 6) colors_.push_back({colour(values[3]), colour(values[4]), colour(values[5])});
    } else if (keyword == "vt") {
      const auto values = numbers(words, 1, 3);
      uvs_.emplace_back(values[0], values.size() > 1 ? values[1] : 0.0f);
    } else if (keyword == "vn") {
      const auto values = numbers(words, 3, 3);
      normals_.emplace_back(values[0], values[1], values[2]);
    } else if (keyword == "f") {
      if (words.size() < 4) fail(str("a face has ", words.size() - 1, " vertices (at least 3 needed)"));
      std::vector<Corner> corners;
      for (std::size_t i = 1; i < words.size(); ++i) corners.push_back(parse_corner(words[i]));
      for (std::size_t i = 1; i + 1 < corners.size(); ++i)
        triangles_.push_back({corners[0], corners[i], corners[i + 1]});
    }
  }

  static std::uint8_t colour(float value) {
    return std::isnan(value) ? 0 : std::uint8_t(std::lround(std::clamp(value, 0.0f, 1.0f) * 255.0f));
  }

  void parse_comment(std::string_view text) {
    const auto words = split(text, ' ', '\t');
    if (words.empty()) return;
    if (words[0] == "pg-format") {
      if (words.size() != 3 || words[1] != "pg-mesh") fail("pg-format comment does not name pg-mesh");
      if (words[2] != "1") fail(str("pg-mesh version ", words[2], " is not supported (this build reads 1)"));
    } else if (words[0] == "pg-provenance") {
      const std::string_view json = text.substr(text.find("pg-provenance") + 13);
      try {
        const auto parsed = nlohmann::json::parse(json);
        if (!parsed.is_object()) fail("pg-provenance comment is not a JSON object");
        provenance_ = provenance_from_json(parsed);
      } catch (const nlohmann::json::exception& e) {
        fail(str("pg-provenance comment is not valid JSON: ", e.what()));
      }
    }
  }

  Mesh build() {
    if (!colors_.empty() && colors_.size() != positions_.size())
      throw InputError(path_, "some \"v\" lines have colours and others do not");
    Mesh mesh;
    mesh.provenance = provenance_;
    mesh.positions = positions_;
    if (!colors_.empty()) mesh.colors = colors_;
    const bool has_uvs = std::any_of(triangles_.begin(), triangles_.end(), [](const auto& t) {
      return std::any_of(t.begin(), t.end(), [](const Corner& c) { return c.vt >= 0; });
    });
    const bool has_normals = std::any_of(triangles_.begin(), triangles_.end(), [](const auto& t) {
      return std::any_of(t.begin(), t.end(), [](const Corner& c) { return c.vn >= 0; });
    });
    // Each file vertex first takes the vt/vn of its first use; a later use with another pair gets a
    // copy of the vertex, so meshes that need no split keep their vertex order.
    std::vector<std::optional<std::pair<std::int64_t, std::int64_t>>> first_use(positions_.size());
    std::map<Corner, std::uint32_t> copies;
    std::vector<std::int64_t> vertex_uv(positions_.size(), -1), vertex_normal(positions_.size(), -1);
    const auto vertex_for = [&](const Corner& c) -> std::uint32_t {
      auto& first = first_use[c.v];
      if (!first) first = std::pair(c.vt, c.vn);
      if (*first == std::pair(c.vt, c.vn)) {
        vertex_uv[c.v] = c.vt;
        vertex_normal[c.v] = c.vn;
        return std::uint32_t(c.v);
      }
      const auto [it, inserted] = copies.emplace(c, std::uint32_t(mesh.positions.size()));
      if (inserted) {
        if (mesh.positions.size() >= max_vertex_count)
          throw InputError(path_, "too many vertices after splitting");
        mesh.positions.push_back(positions_[c.v]);
        if (!mesh.colors.empty()) mesh.colors.push_back(colors_[c.v]);
        vertex_uv.push_back(c.vt);
        vertex_normal.push_back(c.vn);
      }
      return it->second;
    };
    mesh.faces.reserve(triangles_.size());
    for (const auto& t : triangles_)
      mesh.faces.push_back({vertex_for(t[0]), vertex_for(t[1]), vertex_for(t[2])});
    // Vertices used without a vt (or vn) get zeros.
    if (has_uvs) {
      mesh.uvs.resize(mesh.positions.size(), Eigen::Vector2f::Zero());
      for (std::size_t v = 0; v < mesh.uvs.size(); ++v)
        if (vertex_uv[v] >= 0) mesh.uvs[v] = uvs_[vertex_uv[v]];
    }
    if (has_normals) {
      mesh.normals.resize(mesh.positions.size(), Eigen::Vector3f::Zero());
      for (std::size_t v = 0; v < mesh.normals.size(); ++v)
        if (vertex_normal[v] >= 0) mesh.normals[v] = normals_[vertex_normal[v]];
    }
    return mesh;
  }

  fs::path path_;
  std::size_t line_number_ = 0;
  Provenance provenance_;
  std::vector<Eigen::Vector3f> positions_;
  std::vector<std::array<std::uint8_t, 3>> colors_;
  std::vector<Eigen::Vector2f> uvs_;
  std::vector<Eigen::Vector3f> normals_;
  std::vector<std::array<Corner, 3>> triangles_;
};

void append_float(std::string& out, float value) {
  char text[32];
  out.push_back(' ');
  out.append(text, std::to_chars(text, text + sizeof text, value).ptr);
}

std::string lowercase_extension(const fs::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return ext;
}

}  // namespace

Mesh read_mesh_obj(const fs::path& path) {
  return ObjReader(path).read();
}

void write_mesh_obj(const fs::path& path, const Mesh& mesh) {
  mesh.check_consistent();
  for (const auto& [name, values] : mesh.vertex_properties)
    if (!values.empty())
      log::warn(path.string(), ": OBJ cannot hold vertex property \"", name,
                "\"; it is not written (use .ply)");
  std::string text = "# pg-format pg-mesh 1\n# pg-provenance " +
                     to_json(mesh.provenance).dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) +
                     "\n";
  for (std::size_t v = 0; v < mesh.vertex_count(); ++v) {
    text += "v";
    for (int k = 0; k < 3; ++k) append_float(text, mesh.positions[v][k]);
    if (!mesh.colors.empty())
      for (int k = 0; k < 3; ++k) append_float(text, float(mesh.colors[v][k]) / 255.0f);
    text += "\n";
  }
  for (const auto& uv : mesh.uvs) {
    text += "vt";
    append_float(text, uv.x());
    append_float(text, uv.y());
    text += "\n";
  }
  for (const auto& n : mesh.normals) {
    text += "vn";
    for (int k = 0; k < 3; ++k) append_float(text, n[k]);
    text += "\n";
  }
  // The mesh is per-vertex, so a corner's v, vt and vn indices are the same number.
  const char* corner_suffix =
      !mesh.uvs.empty() ? (!mesh.normals.empty() ? "/%/%" : "/%") : (!mesh.normals.empty() ? "//%" : "");
  for (const auto& face : mesh.faces) {
    text += "f";
    for (std::uint32_t v : face) {
      const std::string index = std::to_string(v + 1);
      text += " " + index;
      for (const char* c = corner_suffix; *c; ++c) {
        if (*c == '%')
          text += index;
        else
          text.push_back(*c);
      }
    }
    text += "\n";
  }
  write_file_atomically(path, text);
}

Mesh read_mesh(const fs::path& path) {
  const std::string ext = lowercase_extension(path);
  if (ext == ".ply") return read_mesh_ply(path);
  if (ext == ".obj") return read_mesh_obj(path);
  throw InputError(path,
                   "unknown mesh extension \"" + path.extension().string() + "\" (expected .ply or .obj)");
}

void write_mesh(const fs::path& path, const Mesh& mesh) {
  const std::string ext = lowercase_extension(path);
  if (ext == ".ply") return write_mesh_ply(path, mesh);
  if (ext == ".obj") return write_mesh_obj(path, mesh);
  throw OutputError(path,
                    "unknown mesh extension \"" + path.extension().string() + "\" (expected .ply or .obj)");
}

}  // namespace pg

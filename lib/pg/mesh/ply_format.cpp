#include "pg/mesh/ply_format.h"

#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <optional>

#include "pg/core/atomic_file.h"
#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/mesh/mesh.h"

namespace fs = std::filesystem;

namespace pg::ply {
namespace {

// A header longer than this is not a PLY header.
constexpr std::size_t max_header_bytes = 1 << 20;

struct Property {
  std::string name;
  Type type = Type::float32;
  bool is_list = false;
  Type count_type = Type::uint8;
};

struct Element {
  std::string name;
  std::uint64_t count = 0;
  std::vector<Property> properties;
};

struct Header {
  PlyEncoding encoding = PlyEncoding::ascii;
  std::vector<std::string> comments;
  std::vector<Element> elements;
  std::size_t data_offset = 0;
};

std::optional<Type> parse_type(std::string_view name) {
  static constexpr std::pair<std::string_view, Type> names[] = {
      {"char", Type::int8},      {"int8", Type::int8},       {"uchar", Type::uint8},
      {"uint8", Type::uint8},    {"short", Type::int16},     {"int16", Type::int16},
      {"ushort", Type::uint16},  {"uint16", Type::uint16},   {"int", Type::int32},
      {"int32", Type::int32},    {"uint", Type::uint32},     {"uint32", Type::uint32},
      {"float", Type::float32},  {"float32", Type::float32}, {"double", Type::float64},
      {"float64", Type::float64}};
  for (const auto& [n, t] : names)
    if (n == name) return t;
  return std::nullopt;
}

bool is_integer(Type type) {
  return type != Type::float32 && type != Type::float64;
}

std::vector<std::string_view> split_words(std::string_view line) {
  std::vector<std::string_view> words;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r')) ++i;
    std::size_t start = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t' && line[i] != '\r') ++i;
    if (i > start) words.push_back(line.substr(start, i - start));
  }
  return words;
}

std::string read_whole_file(const fs::path& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) throw InputError(path, "no such file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "cannot open for reading");
  const auto size = fs::file_size(path, ec);
  if (ec) throw InputError(path, "cannot read the file size");
  std::string bytes(size, '\0');
  if (!in.read(bytes.data(), std::streamsize(size))) throw InputError(path, "cannot read the file");
  return bytes;
}

Header parse_header(const std::string& bytes, const fs::path& path) {
  const std::string_view text(bytes.data(), std::min(bytes.size(), max_header_bytes));
  std::size_t pos = 0;
  int line_number = 0;
  Header header;
  bool have_format = false;
  while (true) {
    const std::size_t end = text.find('\n', pos);
    if (end == std::string_view::npos) {
      if (text.substr(0, 3) != "ply") throw InputError(path, "not a PLY file (no \"ply\" magic)");
      throw InputError(path, bytes.size() > max_header_bytes ? "PLY header longer than 1 MiB"
                                                             : "PLY header has no end_header line");
    }
    std::string_view line = text.substr(pos, end - pos);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    pos = end + 1;
    ++line_number;
    const auto bad = [&](const std::string& problem) {
      throw InputError(path, str("PLY header line ", line_number, ": ", problem, ": \"", line, "\""));
    };
    if (line_number == 1) {
      if (line != "ply") throw InputError(path, "not a PLY file (no \"ply\" magic)");
      continue;
    }
    const auto words = split_words(line);
    if (words.empty()) continue;
    const std::string_view keyword = words[0];
    if (keyword == "comment") {
      std::string_view rest = line.substr(line.find("comment") + 7);
      if (!rest.empty() && (rest.front() == ' ' || rest.front() == '\t')) rest.remove_prefix(1);
      header.comments.emplace_back(rest);
    } else if (keyword == "obj_info") {
      continue;
    } else if (keyword == "format") {
      if (words.size() != 3) bad("expected \"format <encoding> 1.0\"");
      if (words[2] != "1.0") bad("unsupported PLY version");
      if (words[1] == "ascii")
        header.encoding = PlyEncoding::ascii;
      else if (words[1] == "binary_little_endian")
        header.encoding = PlyEncoding::binary_little_endian;
      else if (words[1] == "binary_big_endian")
        header.encoding = PlyEncoding::binary_big_endian;
      else
        bad("unknown encoding");
      have_format = true;
    } else if (keyword == "element") {
      if (words.size() != 3) bad("expected \"element <name> <count>\"");
      Element element;
      element.name = std::string(words[1]);
      const auto [ptr, ec] =
          std::from_chars(words[2].data(), words[2].data() + words[2].size(), element.count);
      if (ec != std::errc() || ptr != words[2].data() + words[2].size()) bad("element count is not a count");
      for (const auto& other : header.elements)
        if (other.name == element.name) bad("duplicate element name");
      header.elements.push_back(std::move(element));
    } else if (keyword == "property") {
      if (header.elements.empty()) bad("property before any element");
      Property property;
      if (words.size() == 3) {
        const auto type = parse_type(words[1]);
        if (!type) bad("unknown property type");
        property.type = *type;
        property.name = std::string(words[2]);
      } else if (words.size() == 5 && words[1] == "list") {
        const auto count_type = parse_type(words[2]);
        const auto type = parse_type(words[3]);
        if (!count_type || !type) bad("unknown property type");
        if (!is_integer(*count_type)) bad("list count type must be an integer type");
        property.is_list = true;
        property.count_type = *count_type;
        property.type = *type;
        property.name = std::string(words[4]);
      } else {
        bad("expected \"property <type> <name>\" or \"property list <count type> <type> <name>\"");
      }
      for (const auto& other : header.elements.back().properties)
        if (other.name == property.name) bad("duplicate property name");
      header.elements.back().properties.push_back(std::move(property));
    } else if (keyword == "end_header") {
      if (words.size() != 1) bad("unexpected words after end_header");
      break;
    } else {
      bad("unknown header keyword");
    }
  }
  if (!have_format) throw InputError(path, "PLY header has no format line");
  header.data_offset = pos;
  return header;
}

// Reads values from the binary body; every read is bounds checked.
class BinaryCursor {
 public:
  BinaryCursor(std::string_view body, bool big_endian) : body_(body), big_endian_(big_endian) {}
  std::size_t remaining() const { return body_.size() - pos_; }
  // Returns nullopt at the end of the data.
  std::optional<double> next(Type type) {
    const std::size_t size = size_of(type);
    if (remaining() < size) return std::nullopt;
    unsigned char raw[8];
    std::memcpy(raw, body_.data() + pos_, size);
    pos_ += size;
    if (big_endian_ != (std::endian::native == std::endian::big))
      for (std::size_t i = 0; i < size / 2; ++i) std::swap(raw[i], raw[size - 1 - i]);
    switch (type) {
      case Type::int8:
        return load<std::int8_t>(raw);
      case Type::uint8:
        return load<std::uint8_t>(raw);
      case Type::int16:
        return load<std::int16_t>(raw);
      case Type::uint16:
        return load<std::uint16_t>(raw);
      case Type::int32:
        return load<std::int32_t>(raw);
      case Type::uint32:
        return load<std::uint32_t>(raw);
      case Type::float32:
        return load<float>(raw);
      case Type::float64:
        return load<double>(raw);
    }
    return std::nullopt;
  }
  // Whether `count` values of `type` can still follow.
  bool can_hold(double count, Type type) const {
    return count * double(size_of(type)) <= double(remaining());
  }

 private:
  template <class T>
  static double load(const unsigned char* raw) {
    T value;
    std::memcpy(&value, raw, sizeof(T));
    return double(value);
  }
  std::string_view body_;
  std::size_t pos_ = 0;
  bool big_endian_;
};

// Reads whitespace-separated values from the ASCII body.
class AsciiCursor {
 public:
  explicit AsciiCursor(std::string_view body) : body_(body) {}
  std::size_t remaining() const { return body_.size() - pos_; }
  // Returns nullopt at the end of the data; throws `malformed` for a word that is not a `type`.
  std::optional<double> next(Type type) {
    while (pos_ < body_.size() && is_space(body_[pos_])) ++pos_;
    if (pos_ == body_.size()) return std::nullopt;
    std::size_t end = pos_;
    while (end < body_.size() && !is_space(body_[end])) ++end;
    std::string_view word = body_.substr(pos_, end - pos_);
    pos_ = end;
    if (word.size() > 1 && word.front() == '+') word.remove_prefix(1);
    const char* first = word.data();
    const char* last = word.data() + word.size();
    double value = 0;
    std::from_chars_result result{};
    if (type == Type::float32) {
      float f = 0;
      result = std::from_chars(first, last, f);
      value = f;
    } else if (type == Type::float64) {
      result = std::from_chars(first, last, value);
    } else {
      long long i = 0;
      result = std::from_chars(first, last, i);
      value = double(i);
      if (result.ec == std::errc() && !fits(type, value)) result.ec = std::errc::result_out_of_range;
    }
    if (result.ec != std::errc() || result.ptr != last) throw Malformed{std::string(word)};
    return value;
  }
  bool can_hold(double count, Type) const { return count * 2 <= double(remaining()) + 1; }

  struct Malformed {
    std::string word;
  };

 private:
  static bool is_space(char c) { return c == ' ' || c == '\n' || c == '\r' || c == '\t'; }
  static bool fits(Type type, double v) {
    switch (type) {
      case Type::int8:
        return v >= -128 && v <= 127;
      case Type::uint8:
        return v >= 0 && v <= 255;
      case Type::int16:
        return v >= -32768 && v <= 32767;
      case Type::uint16:
        return v >= 0 && v <= 65535;
      case Type::int32:
        return v >= -2147483648.0 && v <= 2147483647.0;
      case Type::uint32:
        return v >= 0 && v <= 4294967295.0;
      default:
        return true;
    }
  }
  std::string_view body_;
  std::size_t pos_ = 0;
};

// The fewest bytes one entry of `element` can take in the body, for bounding counts before allocating.
double min_entry_bytes(const Element& element, PlyEncoding encoding) {
  double bytes = 0;
  for (const auto& p : element.properties)
    bytes += encoding == PlyEncoding::ascii ? 2.0 : double(size_of(p.is_list ? p.count_type : p.type));
  return bytes;
}

template <class Cursor>
void read_body(Cursor& cursor, const Header& header, const fs::path& path, bool read_faces, Contents& out) {
  std::uint64_t header_vertex_count = 0;
  for (const auto& e : header.elements)
    if (e.name == "vertex") header_vertex_count = e.count;
  std::vector<double> list;
  for (const Element& element : header.elements) {
    const auto fail = [&](std::uint64_t entry, const std::string& problem) {
      throw InputError(path, str("PLY element \"", element.name, "\" entry ", entry, ": ", problem));
    };
    if (element.count > 0 && element.properties.empty())
      throw InputError(path, str("PLY element \"", element.name, "\" has entries but no properties"));
    const double min_bytes = min_entry_bytes(element, header.encoding);
    if (double(element.count) * min_bytes > double(cursor.remaining()) + 1)
      throw InputError(path,
                       str("PLY element \"", element.name, "\" claims ", element.count, " entries but only ",
                           cursor.remaining(), " bytes of data remain (truncated or corrupt)"));
    const bool is_vertex = element.name == "vertex";
    const bool is_face = read_faces && element.name == "face";
    // Where each property's values go: a vertex column index, the face index list, or nowhere.
    constexpr int skip = -1, face_indices = -2;
    std::vector<int> target(element.properties.size(), skip);
    if (is_vertex) {
      if (element.count > max_vertex_count)
        throw InputError(
            path, str("PLY has ", element.count, " vertices; at most ", max_vertex_count, " are supported"));
      out.vertex_count = element.count;
      for (std::size_t p = 0; p < element.properties.size(); ++p) {
        const Property& property = element.properties[p];
        if (property.is_list) continue;
        target[p] = int(out.vertex_columns.size());
        out.vertex_columns.push_back({property.name, property.type, std::vector<double>(element.count)});
      }
    }
    if (is_face) {
      for (std::size_t p = 0; p < element.properties.size(); ++p) {
        const Property& property = element.properties[p];
        if (property.is_list && (property.name == "vertex_indices" || property.name == "vertex_index") &&
            std::find(target.begin(), target.end(), face_indices) == target.end()) {
          if (!is_integer(property.type))
            throw InputError(path, "PLY face vertex_indices must have an integer type");
          target[p] = face_indices;
        }
      }
      if (std::find(target.begin(), target.end(), face_indices) == target.end())
        throw InputError(path, "PLY face element has no vertex_indices list");
      out.has_faces = true;
      out.triangles.reserve(element.count);
    }
    for (std::uint64_t entry = 0; entry < element.count; ++entry) {
      for (std::size_t p = 0; p < element.properties.size(); ++p) {
        const Property& property = element.properties[p];
        if (!property.is_list) {
          const auto value = cursor.next(property.type);
          if (!value) fail(entry, "file ends early (truncated)");
          if (target[p] >= 0) out.vertex_columns[target[p]].values[entry] = *value;
          continue;
        }
        const auto count = cursor.next(property.count_type);
        if (!count) fail(entry, "file ends early (truncated)");
        if (*count < 0) fail(entry, str("list \"", property.name, "\" has a negative length"));
        if (!cursor.can_hold(*count, property.type)) fail(entry, "file ends early (truncated list)");
        const auto n = std::size_t(*count);
        if (target[p] != face_indices) {
          for (std::size_t i = 0; i < n; ++i)
            if (!cursor.next(property.type)) fail(entry, "file ends early (truncated)");
          continue;
        }
        if (n < 3) fail(entry, str("a face has ", n, " vertices (at least 3 needed)"));
        list.resize(n);
        for (std::size_t i = 0; i < n; ++i) {
          const auto index = cursor.next(property.type);
          if (!index) fail(entry, "file ends early (truncated)");
          if (*index < 0 || *index >= double(header_vertex_count))
            fail(entry, str("vertex index ", *index, " out of range (", header_vertex_count, " vertices)"));
          list[i] = *index;
        }
        for (std::size_t i = 1; i + 1 < n; ++i)
          out.triangles.push_back(
              {std::uint32_t(list[0]), std::uint32_t(list[i]), std::uint32_t(list[i + 1])});
      }
    }
  }
}

// Serialises values into a growing buffer, flushed to the stream in large blocks.
class BodyWriter {
 public:
  BodyWriter(std::ofstream& out, PlyEncoding encoding) : out_(out), encoding_(encoding) {}
  void value(Type type, const void* data) {
    if (encoding_ == PlyEncoding::ascii) {
      if (!first_in_line_) buffer_.push_back(' ');
      first_in_line_ = false;
      char text[64];
      const auto end = format(type, data, text);
      buffer_.append(text, end);
    } else {
      const std::size_t size = size_of(type);
      unsigned char raw[8];
      std::memcpy(raw, data, size);
      if ((encoding_ == PlyEncoding::binary_big_endian) != (std::endian::native == std::endian::big))
        for (std::size_t i = 0; i < size / 2; ++i) std::swap(raw[i], raw[size - 1 - i]);
      buffer_.append(reinterpret_cast<const char*>(raw), size);
    }
  }
  void end_entry() {
    if (encoding_ == PlyEncoding::ascii) buffer_.push_back('\n');
    first_in_line_ = true;
    if (buffer_.size() > (1 << 20)) flush();
  }
  void flush() {
    out_.write(buffer_.data(), std::streamsize(buffer_.size()));
    buffer_.clear();
  }

 private:
  // Shortest text that reads back to the same bits.
  static char* format(Type type, const void* data, char* text) {
    char* last = text + 64;
    switch (type) {
      case Type::int8:
        return std::to_chars(text, last, int(load<std::int8_t>(data))).ptr;
      case Type::uint8:
        return std::to_chars(text, last, unsigned(load<std::uint8_t>(data))).ptr;
      case Type::int16:
        return std::to_chars(text, last, load<std::int16_t>(data)).ptr;
      case Type::uint16:
        return std::to_chars(text, last, load<std::uint16_t>(data)).ptr;
      case Type::int32:
        return std::to_chars(text, last, load<std::int32_t>(data)).ptr;
      case Type::uint32:
        return std::to_chars(text, last, load<std::uint32_t>(data)).ptr;
      case Type::float32:
        return std::to_chars(text, last, load<float>(data)).ptr;
      case Type::float64:
        return std::to_chars(text, last, load<double>(data)).ptr;
    }
    return text;
  }
  template <class T>
  static T load(const void* data) {
    T value;
    std::memcpy(&value, data, sizeof(T));
    return value;
  }
  std::ofstream& out_;
  PlyEncoding encoding_;
  std::string buffer_;
  bool first_in_line_ = true;
};

bool is_valid_name(std::string_view name) {
  if (name.empty()) return false;
  for (char c : name)
    if (c <= ' ' || c > '~') return false;
  return true;
}

}  // namespace

std::size_t size_of(Type type) {
  switch (type) {
    case Type::int8:
    case Type::uint8:
      return 1;
    case Type::int16:
    case Type::uint16:
      return 2;
    case Type::int32:
    case Type::uint32:
    case Type::float32:
      return 4;
    case Type::float64:
      return 8;
  }
  return 0;
}

const char* name_of(Type type) {
  switch (type) {
    case Type::int8:
      return "char";
    case Type::uint8:
      return "uchar";
    case Type::int16:
      return "short";
    case Type::uint16:
      return "ushort";
    case Type::int32:
      return "int";
    case Type::uint32:
      return "uint";
    case Type::float32:
      return "float";
    case Type::float64:
      return "double";
  }
  return "?";
}

std::uint8_t color_channel(const VertexColumn& column, double value) {
  switch (column.type) {
    case Type::float32:
    case Type::float64:
      if (std::isnan(value)) return 0;
      return std::uint8_t(std::lround(std::clamp(value, 0.0, 1.0) * 255.0));
    case Type::uint16:
      return std::uint8_t(std::lround(value / 257.0));
    default:
      return std::uint8_t(std::clamp(value, 0.0, 255.0));
  }
}

const VertexColumn* Contents::find(std::string_view name) const {
  for (const auto& column : vertex_columns)
    if (column.name == name) return &column;
  return nullptr;
}

Contents read(const fs::path& path, bool read_faces) {
  const std::string bytes = read_whole_file(path);
  const Header header = parse_header(bytes, path);
  Contents out;
  out.encoding = header.encoding;
  out.comments = header.comments;
  const std::string_view body = std::string_view(bytes).substr(header.data_offset);
  if (header.encoding == PlyEncoding::ascii) {
    AsciiCursor cursor(body);
    try {
      read_body(cursor, header, path, read_faces, out);
    } catch (const AsciiCursor::Malformed& m) {
      throw InputError(path,
                       str("PLY data has \"", m.word, "\" where a number of the declared type belongs"));
    }
  } else {
    BinaryCursor cursor(body, header.encoding == PlyEncoding::binary_big_endian);
    read_body(cursor, header, path, read_faces, out);
  }
  return out;
}

void require_finite_positions(const Contents& contents, const fs::path& path) {
  for (const auto& column : contents.vertex_columns) {
    if (column.name != "x" && column.name != "y" && column.name != "z" && column.name != "nx" &&
        column.name != "ny" && column.name != "nz")
      continue;
    for (std::size_t i = 0; i < column.values.size(); ++i)
      if (!std::isfinite(static_cast<float>(column.values[i])))
        throw InputError(path,
                         str("vertex ", i, " has a non-finite ", column.name, " (", column.values[i], ")"));
  }
}

void read_pg_comments(const Contents& contents, const fs::path& path,
                      std::initializer_list<std::string_view> accepted_formats, Provenance& provenance) {
  for (const std::string& comment : contents.comments) {
    const auto words = split_words(comment);
    if (words.empty()) continue;
    if (words[0] == "pg-format") {
      if (words.size() != 3) throw InputError(path, "malformed \"comment pg-format <name> <version>\"");
      if (std::find(accepted_formats.begin(), accepted_formats.end(), words[1]) == accepted_formats.end())
        throw InputError(path, str("pg-format is \"", words[1], "\", not one this reader accepts"));
      if (words[2] != "1")
        throw InputError(path,
                         str(words[1], " version ", words[2], " is not supported (this build reads 1)"));
    } else if (words[0] == "pg-provenance") {
      const std::string json = comment.substr(comment.find("pg-provenance") + 13);
      try {
        const auto parsed = nlohmann::json::parse(json);
        if (!parsed.is_object()) throw InputError(path, "pg-provenance comment is not a JSON object");
        provenance = provenance_from_json(parsed);
      } catch (const nlohmann::json::exception& e) {
        throw InputError(path, str("pg-provenance comment is not valid JSON: ", e.what()));
      }
    }
  }
}

void add_point_columns(WriteRequest& request, const std::vector<Eigen::Vector3f>& positions,
                       const std::vector<Eigen::Vector3f>& normals,
                       const std::vector<std::array<std::uint8_t, 3>>& colors) {
  static_assert(sizeof(Eigen::Vector3f) == 12 && sizeof(std::array<std::uint8_t, 3>) == 3);
  const auto add_three = [&](std::array<const char*, 3> names, Type type, const auto* data,
                             std::size_t stride) {
    for (int k = 0; k < 3; ++k)
      request.columns.push_back({names[k], type, data ? data + k : nullptr, stride});
  };
  if (positions.empty()) {
    add_three({"x", "y", "z"}, Type::float32, static_cast<const float*>(nullptr), 0);
    return;
  }
  add_three({"x", "y", "z"}, Type::float32, positions.front().data(), sizeof(Eigen::Vector3f));
  if (!normals.empty())
    add_three({"nx", "ny", "nz"}, Type::float32, normals.front().data(), sizeof(Eigen::Vector3f));
  if (!colors.empty()) add_three({"red", "green", "blue"}, Type::uint8, colors.front().data(), 3);
}

void write(const fs::path& path, const WriteRequest& request) {
  if (request.write_faces && request.vertex_count > std::size_t(std::numeric_limits<std::int32_t>::max()))
    throw OutputError(path, "too many vertices for PLY int face indices");
  std::string header = "ply\nformat ";
  header += request.encoding == PlyEncoding::ascii                  ? "ascii"
            : request.encoding == PlyEncoding::binary_little_endian ? "binary_little_endian"
                                                                    : "binary_big_endian";
  header += " 1.0\ncomment pg-format " + request.format_name + " 1\n";
  header += "comment pg-provenance " +
            to_json(request.provenance).dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
  header += str("element vertex ", request.vertex_count, "\n");
  for (const auto& column : request.columns) {
    if (!is_valid_name(column.name))
      throw OutputError(path, str("vertex property name \"", column.name, "\" cannot be written to PLY"));
    header += str("property ", name_of(column.type), " ", column.name, "\n");
  }
  if (request.write_faces)
    header += str("element face ", request.faces.size(), "\nproperty list uchar int vertex_indices\n");
  header += "end_header\n";

  write_atomically(path, [&](const fs::path& tmp) {
    std::ofstream out(tmp, std::ios::binary);
    if (!out) throw OutputError(tmp, "cannot open for writing");
    out.write(header.data(), std::streamsize(header.size()));
    BodyWriter body(out, request.encoding);
    for (std::size_t v = 0; v < request.vertex_count; ++v) {
      for (const auto& column : request.columns)
        body.value(column.type, static_cast<const char*>(column.data) + v * column.stride);
      body.end_entry();
    }
    if (request.write_faces) {
      const std::uint8_t three = 3;
      for (const auto& face : request.faces) {
        body.value(Type::uint8, &three);
        for (std::uint32_t index : face) {
          const auto i = std::int32_t(index);
          body.value(Type::int32, &i);
        }
        body.end_entry();
      }
    }
    body.flush();
    out.close();
    if (!out) throw OutputError(path, "write failed (disk full?)");
  });
}

}  // namespace pg::ply

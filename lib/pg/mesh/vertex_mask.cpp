#include "pg/mesh/vertex_mask.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdlib>

#include "pg/core/atomic_file.h"
#include "pg/core/error.h"
#include "pg/core/json_file.h"
#include "pg/core/log.h"

namespace fs = std::filesystem;

namespace pg {
namespace {

constexpr const char* format_name = "pg-vertex-mask";
constexpr int format_version = 1;

bool is_valid_weight(float w) {
  return w >= 0.0f && w <= 1.0f;
}  // false for NaN

bool is_valid_name(const std::string& name) {
  return !name.empty() && std::all_of(name.begin(), name.end(), [](unsigned char c) {
    return std::isalnum(c) || c == '_' || c == '-' || c == '.';
  });
}

bool is_hex64(const std::string& text) {
  return text.size() == 16 && std::all_of(text.begin(), text.end(), [](char c) {
           return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f');
         });
}

// The double nearest the shortest decimal that reads back as `value`, so the JSON shows "0.3"
// rather than "0.30000001192092896" and still reads back to the same float.
double json_number(float value) {
  char text[32];
  *std::to_chars(text, text + sizeof text - 1, value).ptr = '\0';
  return std::strtod(text, nullptr);
}

std::string describe_problem(const VertexMask& mask) {
  if (!is_valid_name(mask.name)) return "name \"" + mask.name + "\" must be letters, digits, '_', '-' or '.'";
  if (mask.weights.size() != mask.topology.vertex_count)
    return str("has ", mask.weights.size(), " weights for ", mask.topology.vertex_count, " vertices");
  for (std::size_t i = 0; i < mask.weights.size(); ++i)
    if (!is_valid_weight(mask.weights[i]))
      return str("weight ", i, " is ", mask.weights[i], ", not in [0, 1]");
  if (!is_hex64(mask.topology.faces_fnv1a64)) return "topology.faces_fnv1a64 is not 16 lowercase hex digits";
  return {};
}

TopologyId read_topology(const JsonReader& doc) {
  const JsonReader topology = doc.child("topology");
  TopologyId id;
  const long long vertex_count = topology.integer("vertex_count");
  const long long face_count = topology.integer("face_count");
  if (vertex_count < 0 || std::uint64_t(vertex_count) > max_vertex_count)
    topology.fail(str("vertex_count ", vertex_count, " is out of range (0..", max_vertex_count, ")"));
  if (face_count < 0) topology.fail("face_count is negative");
  id.vertex_count = std::uint64_t(vertex_count);
  id.face_count = std::uint64_t(face_count);
  id.faces_fnv1a64 = topology.string("faces_fnv1a64");
  if (!is_hex64(id.faces_fnv1a64)) topology.fail("faces_fnv1a64 is not 16 lowercase hex digits");
  return id;
}

const nlohmann::json& array_field(const JsonReader& doc, const char* key) {
  if (!doc.has(key)) doc.fail(str("missing \"", key, "\""));
  const auto& array = doc.node()[key];
  if (!array.is_array()) doc.fail(str("\"", key, "\" is not an array"));
  return array;
}

float read_weight(const JsonReader& doc, const nlohmann::json& value, std::size_t i) {
  if (!value.is_number()) doc.fail(str("weights[", i, "] is not a number"));
  const float w = float(value.get<double>());
  if (!is_valid_weight(w)) doc.fail(str("weights[", i, "] is ", value.dump(), ", not in [0, 1]"));
  return w;
}

}  // namespace

VertexMask read_vertex_mask(const fs::path& path) {
  const nlohmann::json json = read_json_file(path);
  check_format_header(json, path, format_name, format_version);
  const JsonReader doc(json, path, "");
  VertexMask mask;
  if (doc.has("provenance")) mask.provenance = provenance_from_json(doc.child("provenance").node());
  mask.name = doc.string("name");
  if (!is_valid_name(mask.name))
    doc.fail("name \"" + mask.name + "\" must be letters, digits, '_', '-' or '.'");
  mask.topology = read_topology(doc);
  const std::size_t n = mask.topology.vertex_count;
  const std::string encoding = doc.string("encoding");
  const auto& weights = array_field(doc, "weights");
  if (encoding == "dense") {
    if (weights.size() != n)
      doc.fail(str("dense mask has ", weights.size(), " weights for ", n, " vertices"));
    mask.weights.resize(n);
    for (std::size_t i = 0; i < n; ++i) mask.weights[i] = read_weight(doc, weights[i], i);
  } else if (encoding == "sparse") {
    const auto& indices = array_field(doc, "indices");
    if (indices.size() != weights.size())
      doc.fail(str("sparse mask has ", indices.size(), " indices but ", weights.size(), " weights"));
    if (indices.size() > n)
      doc.fail(str("sparse mask lists ", indices.size(), " entries for ", n, " vertices"));
    mask.weights.assign(n, 0.0f);
    std::vector<bool> seen(n, false);
    for (std::size_t i = 0; i < indices.size(); ++i) {
      if (!indices[i].is_number_integer()) doc.fail(str("indices[", i, "] is not an integer"));
      const long long index = indices[i].get<long long>();
      if (index < 0 || std::uint64_t(index) >= n)
        doc.fail(str("indices[", i, "] = ", index, " is out of range (", n, " vertices)"));
      if (seen[index]) doc.fail(str("indices[", i, "] = ", index, " appears twice"));
      seen[index] = true;
      mask.weights[index] = read_weight(doc, weights[i], i);
    }
  } else {
    doc.fail("encoding \"" + encoding + "\" is neither \"dense\" nor \"sparse\"");
  }
  return mask;
}

void write_vertex_mask(const fs::path& path, const VertexMask& mask, MaskEncoding encoding) {
  if (const std::string problem = describe_problem(mask); !problem.empty())
    throw Error(ExitCode::internal, str("vertex mask for ", path.string(), ": ", problem));
  const auto non_zero =
      std::size_t(std::count_if(mask.weights.begin(), mask.weights.end(), [](float w) { return w != 0; }));
  if (encoding == MaskEncoding::automatic)
    encoding = non_zero * 4 < mask.weights.size() ? MaskEncoding::sparse : MaskEncoding::dense;

  nlohmann::ordered_json doc;
  doc["format"] = format_name;
  doc["version"] = format_version;
  doc["provenance"] = nlohmann::ordered_json::parse(to_json(mask.provenance).dump());
  doc["name"] = mask.name;
  doc["topology"] = {{"vertex_count", mask.topology.vertex_count},
                     {"face_count", mask.topology.face_count},
                     {"faces_fnv1a64", mask.topology.faces_fnv1a64}};
  auto weights = nlohmann::ordered_json::array();
  if (encoding == MaskEncoding::dense) {
    doc["encoding"] = "dense";
    for (float w : mask.weights) weights.push_back(json_number(w));
  } else {
    doc["encoding"] = "sparse";
    auto indices = nlohmann::ordered_json::array();
    for (std::size_t i = 0; i < mask.weights.size(); ++i) {
      if (mask.weights[i] == 0) continue;
      indices.push_back(i);
      weights.push_back(json_number(mask.weights[i]));
    }
    doc["indices"] = std::move(indices);
  }
  doc["weights"] = std::move(weights);
  // ordered_json keeps format, version and provenance first (write_json_file would sort the keys).
  write_file_atomically(path, doc.dump(2) + "\n");
}

void check_fits(const VertexMask& mask, const Mesh& mesh, const fs::path& mask_file) {
  const TopologyId id = topology_id(mesh);
  if (mask.topology.vertex_count != id.vertex_count)
    throw InputError(mask_file,
                     str("mask \"", mask.name, "\" was made for a mesh with ", mask.topology.vertex_count,
                         " vertices, this mesh has ", id.vertex_count, " (remeshed?)"));
  if (mask.topology.face_count != id.face_count)
    throw InputError(mask_file,
                     str("mask \"", mask.name, "\" was made for a mesh with ", mask.topology.face_count,
                         " faces, this mesh has ", id.face_count, " (remeshed?)"));
  if (mask.topology.faces_fnv1a64 != id.faces_fnv1a64)
    throw InputError(mask_file,
                     str("mask \"", mask.name, "\" was made for a mesh with another face list (checksum ",
                         mask.topology.faces_fnv1a64, ", this mesh ", id.faces_fnv1a64,
                         "): the mesh was remeshed or its faces reordered"));
  if (mask.weights.size() != id.vertex_count)
    throw InputError(mask_file,
                     str("mask has ", mask.weights.size(), " weights for ", id.vertex_count, " vertices"));
}

VertexMask mask_from_property(const Mesh& mesh, const std::string& property) {
  const auto it = mesh.vertex_properties.find(property);
  if (it == mesh.vertex_properties.end() || it->second.size() != mesh.vertex_count())
    throw Error(ExitCode::bad_input, str("mesh has no vertex property \"", property, "\""));
  for (std::size_t i = 0; i < it->second.size(); ++i)
    if (!is_valid_weight(it->second[i]))
      throw Error(ExitCode::bad_input, str("vertex property \"", property, "\" holds ", it->second[i],
                                           " at vertex ", i, "; a mask needs weights in [0, 1]"));
  VertexMask mask;
  mask.name = property;
  mask.topology = topology_id(mesh);
  mask.weights = it->second;
  mask.provenance = Provenance::current();
  return mask;
}

void set_property_from_mask(Mesh& mesh, const VertexMask& mask) {
  if (mask.topology != topology_id(mesh))
    throw Error(ExitCode::bad_input, str("mask \"", mask.name, "\" was made for another mesh topology"));
  if (mask.weights.size() != mesh.vertex_count())
    throw Error(ExitCode::bad_input, str("mask \"", mask.name, "\" has ", mask.weights.size(),
                                         " weights for ", mesh.vertex_count(), " vertices"));
  mesh.vertex_properties[mask.name] = mask.weights;
}

}  // namespace pg

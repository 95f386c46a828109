#include "pg/core/json_file.h"

#include <cmath>
#include <fstream>
#include <sstream>

#include "pg/core/atomic_file.h"
#include "pg/core/error.h"

namespace fs = std::filesystem;

namespace pg {

nlohmann::json read_json_file(const fs::path& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) throw InputError(path, "no such file");
  if (fs::file_size(path, ec) > max_json_file_bytes) throw InputError(path, "file too large for a JSON file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "cannot open for reading");
  std::stringstream buffer;
  buffer << in.rdbuf();
  try {
    return nlohmann::json::parse(buffer.str());
  } catch (const nlohmann::json::exception& e) {  // parse errors, and numbers out of range (1e999)
    throw InputError(path, std::string("not valid JSON: ") + e.what());
  }
}

int check_format_header(const nlohmann::json& doc, const fs::path& path, const std::string& format,
                        int max_version) {
  if (!doc.is_object()) throw InputError(path, "top level is not a JSON object");
  auto f = doc.find("format");
  if (f == doc.end() || !f->is_string())
    throw InputError(path, "missing \"format\" (expected \"" + format + "\")");
  if (f->get<std::string>() != format)
    throw InputError(path, "format is \"" + f->get<std::string>() + "\", expected \"" + format + "\"");
  auto v = doc.find("version");
  if (v == doc.end() || !v->is_number_integer()) throw InputError(path, "missing integer \"version\"");
  long long version = v->get<long long>();
  if (version < 1 || version > max_version)
    throw InputError(path, format + " version " + std::to_string(version) +
                               " is not supported (this build reads 1.." + std::to_string(max_version) + ")");
  return int(version);
}

void write_json_file(const fs::path& path, const nlohmann::json& doc) {
  write_file_atomically(path, doc.dump(2) + "\n");
}

void write_json_file(const fs::path& path, const nlohmann::ordered_json& doc) {
  write_file_atomically(path, doc.dump(2) + "\n");
}

JsonReader::JsonReader(const nlohmann::json& node, fs::path file, std::string where)
    : node_(node), file_(std::move(file)), where_(std::move(where)) {
  if (!node_.is_object()) fail("expected an object");
}

void JsonReader::fail(const std::string& problem) const {
  throw InputError(file_, where_.empty() ? problem : where_ + ": " + problem);
}

bool JsonReader::has(const char* key) const {
  return node_.contains(key) && !node_[key].is_null();
}

const nlohmann::json& JsonReader::field(const char* key) const {
  auto it = node_.find(key);
  if (it == node_.end()) fail(std::string("missing \"") + key + "\"");
  return *it;
}

JsonReader JsonReader::child(const char* key) const {
  const auto& c = field(key);
  if (!c.is_object()) fail(std::string("\"") + key + "\" is not an object");
  return JsonReader(c, file_, where_.empty() ? key : where_ + "." + key);
}

double JsonReader::number(const char* key) const {
  const auto& c = field(key);
  if (!c.is_number()) fail(std::string("\"") + key + "\" is not a number");
  double value = c.get<double>();
  if (!std::isfinite(value)) fail(std::string("\"") + key + "\" is not finite");
  return value;
}

double JsonReader::number_or(const char* key, double fallback) const {
  return has(key) ? number(key) : fallback;
}

long long JsonReader::integer(const char* key) const {
  const auto& c = field(key);
  if (!c.is_number_integer()) fail(std::string("\"") + key + "\" is not an integer");
  return c.get<long long>();
}

std::string JsonReader::string(const char* key) const {
  const auto& c = field(key);
  if (!c.is_string()) fail(std::string("\"") + key + "\" is not a string");
  return c.get<std::string>();
}

std::string JsonReader::string_or(const char* key, const std::string& fallback) const {
  return has(key) ? string(key) : fallback;
}

bool JsonReader::boolean_or(const char* key, bool fallback) const {
  if (!has(key)) return fallback;
  if (!node_[key].is_boolean()) fail(std::string("\"") + key + "\" is not true/false");
  return node_[key].get<bool>();
}

std::vector<double> JsonReader::numbers(const char* key, std::size_t n) const {
  const auto& c = field(key);
  if (!c.is_array()) fail(std::string("\"") + key + "\" is not an array");
  if (n != 0 && c.size() != n)
    fail(std::string("\"") + key + "\" has " + std::to_string(c.size()) + " values, expected " +
         std::to_string(n));
  std::vector<double> out;
  out.reserve(c.size());
  for (const auto& e : c) {
    if (!e.is_number() || !std::isfinite(e.get<double>()))
      fail(std::string("\"") + key + "\" holds a value that is not a finite number");
    out.push_back(e.get<double>());
  }
  return out;
}

}  // namespace pg

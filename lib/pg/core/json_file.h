#pragma once
// Reading and writing the project's JSON files: every one starts with "format", "version" and
// "provenance" (formats/conventions.md). Readers reject with an InputError naming the file.
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

namespace pg {

// Largest JSON file a reader accepts; larger is refused before parsing.
inline constexpr std::uintmax_t max_json_file_bytes = 512ull << 20;

nlohmann::json read_json_file(const std::filesystem::path& path);

// Checks "format" equals `format` and "version" is an integer in [1, max_version]. Returns the version.
int check_format_header(const nlohmann::json& doc, const std::filesystem::path& path,
                        const std::string& format, int max_version);

// Serialises with 2-space indent and writes atomically. Use ordered_json to keep "format", "version"
// and "provenance" first, as the conventions ask.
void write_json_file(const std::filesystem::path& path, const nlohmann::json& doc);
void write_json_file(const std::filesystem::path& path, const nlohmann::ordered_json& doc);

// Typed field access that throws InputError("<path>: <where>: ...") instead of nlohmann's exceptions.
class JsonReader {
 public:
  JsonReader(const nlohmann::json& node, std::filesystem::path file, std::string where);
  const nlohmann::json& node() const { return node_; }
  bool has(const char* key) const;
  JsonReader child(const char* key) const;  // required object
  double number(const char* key) const;
  double number_or(const char* key, double fallback) const;
  long long integer(const char* key) const;
  std::string string(const char* key) const;
  std::string string_or(const char* key, const std::string& fallback) const;
  bool boolean_or(const char* key, bool fallback) const;
  // A required array of exactly `n` numbers (n = 0: any length).
  std::vector<double> numbers(const char* key, std::size_t n = 0) const;
  [[noreturn]] void fail(const std::string& problem) const;
  const std::filesystem::path& file() const { return file_; }
  const std::string& where() const { return where_; }

 private:
  const nlohmann::json& field(const char* key) const;
  const nlohmann::json& node_;
  std::filesystem::path file_;
  std::string where_;
};

}  // namespace pg

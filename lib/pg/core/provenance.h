#pragma once
// How a file was made. Every file pg writes carries one (formats/conventions.md).
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace pg {

struct Provenance {
  std::string tool = "libpg";
  std::string version;
  std::string command_line;
  std::string created_utc;  // ISO 8601
  std::vector<std::string> inputs;

  // The provenance of this process: the CLI frame fills tool, command line and inputs; library
  // callers (tests, benchmarks) get "libpg" and the library version.
  static Provenance current();
  static void set_current(Provenance p);
  // Adds an input file to the current provenance (the CLI frame does this for each input).
  static void add_current_input(const std::string& path);
};

nlohmann::json to_json(const Provenance& p);
Provenance provenance_from_json(const nlohmann::json& j);

std::string utc_now_iso8601();

}  // namespace pg

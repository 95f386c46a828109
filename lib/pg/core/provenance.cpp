#include "pg/core/provenance.h"

#include <algorithm>
#include <chrono>
#include <ctime>
#include <mutex>

#include "pg/build_info.h"

namespace pg {
namespace {
std::mutex g_mutex;
Provenance& current_storage() {
  static Provenance p = [] {
    Provenance q;
    q.version = build_info::version;
    return q;
  }();
  return p;
}
}  // namespace

Provenance Provenance::current() {
  std::lock_guard lock(g_mutex);
  Provenance p = current_storage();
  p.created_utc = utc_now_iso8601();
  return p;
}

void Provenance::set_current(Provenance p) {
  std::lock_guard lock(g_mutex);
  current_storage() = std::move(p);
}

void Provenance::add_current_input(const std::string& path) {
  std::lock_guard lock(g_mutex);
  std::vector<std::string>& inputs = current_storage().inputs;
  if (std::find(inputs.begin(), inputs.end(), path) == inputs.end()) inputs.push_back(path);
}

nlohmann::json to_json(const Provenance& p) {
  return {{"tool", p.tool},
          {"version", p.version},
          {"command_line", p.command_line},
          {"created_utc", p.created_utc},
          {"inputs", p.inputs}};
}

// Provenance is informational: a field of the wrong type (or a provenance that is no object) is
// skipped rather than failing the file, and never escapes as a JSON exception.
Provenance provenance_from_json(const nlohmann::json& j) {
  Provenance p;
  if (!j.is_object()) return p;
  const auto text = [&](const char* key) {
    const auto it = j.find(key);
    return it != j.end() && it->is_string() ? it->get<std::string>() : std::string();
  };
  p.tool = text("tool");
  p.version = text("version");
  p.command_line = text("command_line");
  p.created_utc = text("created_utc");
  if (j.contains("inputs") && j["inputs"].is_array())
    for (const auto& i : j["inputs"])
      if (i.is_string()) p.inputs.push_back(i.get<std::string>());
  return p;
}

std::string utc_now_iso8601() {
  std::time_t t = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buffer[32];
  std::strftime(buffer, sizeof buffer, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buffer;
}

}  // namespace pg

#include "pg/core/run_report.h"

#include <sys/resource.h>

#include <algorithm>

#include "pg/build_info.h"
#include "pg/core/hash.h"
#include "pg/core/json_file.h"
#include "pg/core/log.h"
#include "pg/core/provenance.h"

namespace fs = std::filesystem;

namespace pg {

RunReport& RunReport::global() {
  static RunReport report;
  return report;
}

void RunReport::set_tool(std::string tool, std::string command_line) {
  std::lock_guard lock(mutex_);
  tool_ = std::move(tool);
  command_line_ = std::move(command_line);
}

void RunReport::add_input(const fs::path& path) {
  std::lock_guard lock(mutex_);
  // A file read twice (one colour image for two depth maps) is one input.
  if (std::find(inputs_.begin(), inputs_.end(), path) == inputs_.end()) inputs_.push_back(path);
}

void RunReport::add_output(const fs::path& path) {
  std::lock_guard lock(mutex_);
  outputs_.push_back(path);
}

void RunReport::set_metric(const std::string& name, nlohmann::json value) {
  std::lock_guard lock(mutex_);
  metrics_[name] = std::move(value);
}

nlohmann::json RunReport::metrics() const {
  std::lock_guard lock(mutex_);
  return metrics_;
}

void RunReport::add_timing(const std::string& phase, double seconds) {
  std::lock_guard lock(mutex_);
  timings_.emplace_back(phase, seconds);
}

void RunReport::set_exit(int code, const std::string& message) {
  std::lock_guard lock(mutex_);
  exit_code_ = code;
  exit_message_ = message;
}

void RunReport::reset() {
  std::lock_guard lock(mutex_);
  inputs_.clear();
  outputs_.clear();
  metrics_ = nlohmann::json::object();
  timings_.clear();
  exit_code_ = 0;
  exit_message_.clear();
  start_ = std::chrono::steady_clock::now();
}

namespace {
nlohmann::json describe_file(const fs::path& path) {
  nlohmann::json j = {{"path", path.string()}};
  std::error_code ec;
  if (fs::is_regular_file(path, ec)) {
    j["bytes"] = fs::file_size(path, ec);
    try {
      j["sha256"] = sha256_file(path);
    } catch (const std::exception&) {
      j["sha256"] = nullptr;
    }
  } else {
    j["exists"] = fs::exists(path, ec);
  }
  return j;
}
}  // namespace

nlohmann::json RunReport::to_json() const {
  std::lock_guard lock(mutex_);
  nlohmann::json j;
  j["format"] = "pg-run-report";
  j["version"] = 1;
  Provenance p = Provenance::current();
  j["provenance"] = pg::to_json(p);
  j["tool"] = tool_;
  j["tool_version"] = build_info::version;
  j["command_line"] = command_line_;
  j["inputs"] = nlohmann::json::array();
  for (const auto& i : inputs_) j["inputs"].push_back(describe_file(i));
  j["outputs"] = nlohmann::json::array();
  for (const auto& o : outputs_) j["outputs"].push_back(describe_file(o));
  j["metrics"] = metrics_;
  j["timings"] = nlohmann::json::array();
  for (const auto& [phase, seconds] : timings_)
    j["timings"].push_back({{"phase", phase}, {"seconds", seconds}});
  j["wall_seconds"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  j["cpu_seconds"] = cpu_seconds();
  j["peak_memory_bytes"] = peak_memory_bytes();
  j["warnings"] = log::collected_warnings();
  j["exit_code"] = exit_code_;
  j["exit_message"] = exit_message_;
  return j;
}

void RunReport::write(const fs::path& path) const {
  write_json_file(path, to_json());
}

ScopedTimer::ScopedTimer(std::string phase)
    : phase_(std::move(phase)), start_(std::chrono::steady_clock::now()) {}
ScopedTimer::~ScopedTimer() {
  RunReport::global().add_timing(phase_, seconds());
}
double ScopedTimer::seconds() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

std::uint64_t peak_memory_bytes() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return std::uint64_t(usage.ru_maxrss) * 1024;  // Linux reports kilobytes
}

double cpu_seconds() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  auto tv = [](const timeval& t) { return double(t.tv_sec) + 1e-6 * double(t.tv_usec); };
  return tv(usage.ru_utime) + tv(usage.ru_stime);
}

}  // namespace pg

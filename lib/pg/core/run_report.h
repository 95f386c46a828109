#pragma once
// The run report (formats/run-report.md): what a tool read and wrote, its metrics, timings, peak
// memory and warnings. The CLI frame fills the common parts; stages add metrics and timings.
#include <chrono>
#include <filesystem>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace pg {

class RunReport {
 public:
  static RunReport& global();

  void set_tool(std::string tool, std::string command_line);
  void add_input(const std::filesystem::path& path);
  void add_output(const std::filesystem::path& path);
  void set_metric(const std::string& name, nlohmann::json value);
  void add_timing(const std::string& phase, double seconds);
  void set_exit(int code, const std::string& message);
  const std::vector<std::filesystem::path>& inputs() const { return inputs_; }
  const std::vector<std::filesystem::path>& outputs() const { return outputs_; }
  nlohmann::json metrics() const;

  // Builds the report document (hashes the inputs and outputs that exist).
  nlohmann::json to_json() const;
  void write(const std::filesystem::path& path) const;
  void reset();

 private:
  mutable std::mutex mutex_;
  std::string tool_, command_line_;
  std::vector<std::filesystem::path> inputs_, outputs_;
  nlohmann::json metrics_ = nlohmann::json::object();
  std::vector<std::pair<std::string, double>> timings_;
  int exit_code_ = 0;
  std::string exit_message_;
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

// Times a scope and records it in the global report: `ScopedTimer t("integrate");`
class ScopedTimer {
 public:
  explicit ScopedTimer(std::string phase);
  ~ScopedTimer();
  double seconds() const;

 private:
  std::string phase_;
  std::chrono::steady_clock::time_point start_;
};

// Peak resident memory of this process in bytes.
std::uint64_t peak_memory_bytes();
// User + system CPU time of this process in seconds.
double cpu_seconds();

}  // namespace pg

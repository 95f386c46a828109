#pragma once
// Progress on stderr, one line per update: "<prefix>: progress <task> 40% (4/10) eta 12s".
// On a terminal the line is redrawn with a carriage return; otherwise each update is a new line,
// at most one per `min_interval` (and always at 100%), so farm logs stay readable.
#include <atomic>
#include <chrono>
#include <cstdint>
#include <mutex>
#include <string>

namespace pg {

class Progress {
 public:
  Progress(std::string task, std::int64_t total);
  ~Progress();
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  // Thread-safe; `done` items more are complete.
  void advance(std::int64_t done = 1);
  void finish();

  // Global switches set by the CLI frame.
  static void set_enabled(bool enabled);
  static void set_min_interval(std::chrono::milliseconds interval);
  static void set_force_terminal(int mode);  // -1 autodetect, 0 never redraw, 1 always redraw

 private:
  void print(std::int64_t done, bool final);
  std::string task_;
  std::int64_t total_;
  std::atomic<std::int64_t> done_{0};
  std::chrono::steady_clock::time_point start_;
  std::chrono::steady_clock::time_point last_print_;
  std::mutex mutex_;
  bool finished_ = false;
  int last_percent_ = -1;
};

}  // namespace pg

#include "pg/core/progress.h"

#include <unistd.h>

#include <cstdio>

#include "pg/core/log.h"

namespace pg {
namespace {
std::atomic<bool> g_enabled{true};
std::atomic<long long> g_min_interval_ms{1000};
std::atomic<int> g_terminal_mode{-1};

bool redraw() {
  int mode = g_terminal_mode;
  if (mode >= 0) return mode == 1;
  return ::isatty(STDERR_FILENO) == 1;
}
}  // namespace

void Progress::set_enabled(bool enabled) {
  g_enabled = enabled;
}
void Progress::set_min_interval(std::chrono::milliseconds interval) {
  g_min_interval_ms = interval.count();
}
void Progress::set_force_terminal(int mode) {
  g_terminal_mode = mode;
}

Progress::Progress(std::string task, std::int64_t total)
    : task_(std::move(task)), total_(total > 0 ? total : 1), start_(std::chrono::steady_clock::now()) {
  last_print_ = start_ - std::chrono::hours(1);
}

Progress::~Progress() {
  finish();
}

void Progress::advance(std::int64_t done) {
  std::int64_t now_done = done_.fetch_add(done) + done;
  if (!g_enabled) return;
  auto now = std::chrono::steady_clock::now();
  std::unique_lock lock(mutex_, std::try_to_lock);
  if (!lock.owns_lock() || finished_) return;
  if (now - last_print_ < std::chrono::milliseconds(g_min_interval_ms.load()) && now_done < total_) return;
  print(now_done, false);
}

void Progress::finish() {
  std::lock_guard lock(mutex_);
  if (finished_) return;
  finished_ = true;
  if (!g_enabled) return;
  print(total_, true);
}

void Progress::print(std::int64_t done, bool final) {
  if (done > total_) done = total_;
  int percent = int(100 * done / total_);
  if (percent == last_percent_ && !final) return;
  if (final && last_percent_ == 100) return;
  last_percent_ = percent;
  last_print_ = std::chrono::steady_clock::now();
  double elapsed = std::chrono::duration<double>(last_print_ - start_).count();
  std::string eta = "?";
  if (done > 0) eta = std::to_string(int(elapsed * double(total_ - done) / double(done) + 0.5)) + "s";
  std::string line = str("progress ", task_, " ", percent, "% (", done, "/", total_, ") eta ", eta);
  if (redraw()) {
    std::fprintf(stderr, "\r%s%s", line.c_str(), percent == 100 ? "\n" : "");
  } else {
    log::write(log::Level::info, line);
  }
  std::fflush(stderr);
}

}  // namespace pg

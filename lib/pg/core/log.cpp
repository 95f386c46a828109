#include "pg/core/log.h"

#include <atomic>
#include <iostream>
#include <mutex>

#include "pg/core/error.h"

namespace pg::log {
namespace {
std::atomic<Level> g_level{Level::info};
std::mutex g_mutex;
std::string g_prefix = "pg";
std::vector<std::string> g_warnings;

const char* level_name(Level level) {
  switch (level) {
    case Level::error:
      return "error";
    case Level::warn:
      return "warning";
    case Level::info:
      return "info";
    case Level::debug:
      return "debug";
    case Level::trace:
      return "trace";
  }
  return "?";
}
}  // namespace

void set_level(Level level) {
  g_level = level;
}
Level level() {
  return g_level;
}

Level parse_level(std::string_view text) {
  if (text == "error") return Level::error;
  if (text == "warn" || text == "warning") return Level::warn;
  if (text == "info") return Level::info;
  if (text == "debug") return Level::debug;
  if (text == "trace") return Level::trace;
  throw UsageError("unknown log level '" + std::string(text) + "' (use error, warn, info, debug or trace)");
}

void set_prefix(std::string prefix) {
  std::lock_guard lock(g_mutex);
  g_prefix = std::move(prefix);
}

void write(Level level, std::string_view message) {
  std::lock_guard lock(g_mutex);
  if (level == Level::warn) g_warnings.emplace_back(message);
  if (level > g_level.load()) return;
  std::cerr << g_prefix << ": " << level_name(level) << ": " << message << '\n' << std::flush;
}

std::vector<std::string> collected_warnings() {
  std::lock_guard lock(g_mutex);
  return g_warnings;
}

}  // namespace pg::log

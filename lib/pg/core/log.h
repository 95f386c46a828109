#pragma once
// Minimal thread-safe logging to stderr: "<prefix>: <level>: message".
// GCC 12 has no <format>; pg::str(...) concatenates anything streamable.
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

namespace pg {

template <class... Args>
std::string str(const Args&... args) {
  std::ostringstream out;
  (out << ... << args);
  return out.str();
}

namespace log {

enum class Level { error = 0, warn = 1, info = 2, debug = 3, trace = 4 };

void set_level(Level level);
Level level();
// Parses "error|warn|info|debug|trace"; throws UsageError otherwise.
Level parse_level(std::string_view text);
// The prefix printed before every line (usually the tool name).
void set_prefix(std::string prefix);
void write(Level level, std::string_view message);
// Warnings are also collected so the run report can list them.
std::vector<std::string> collected_warnings();

template <class... Args>
void error(const Args&... args) {
  write(Level::error, str(args...));
}
template <class... Args>
void warn(const Args&... args) {
  write(Level::warn, str(args...));
}
template <class... Args>
void info(const Args&... args) {
  if (level() >= Level::info) write(Level::info, str(args...));
}
template <class... Args>
void debug(const Args&... args) {
  if (level() >= Level::debug) write(Level::debug, str(args...));
}

}  // namespace log
}  // namespace pg

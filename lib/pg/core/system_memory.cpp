#include "pg/core/system_memory.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace pg {

namespace {

namespace fs = std::filesystem;

std::optional<std::string> first_word(const fs::path& file) {
  std::ifstream in(file);
  std::string word;
  if (in >> word) return word;
  return std::nullopt;
}

// The value of `key` in a "key value" file such as memory.stat or /proc/meminfo (0 when absent).
std::uint64_t keyed_value(const fs::path& file, const std::string& key) {
  std::ifstream in(file);
  for (std::string line; std::getline(in, line);) {
    std::istringstream fields(line);
    std::string name;
    std::uint64_t value = 0;
    if (fields >> name >> value && name == key) return value;
  }
  return 0;
}

// What the memory cgroups holding this process have left: its own and every ancestor's limit count
// (v2's unified hierarchy, "0::/path" in /proc/self/cgroup, or v1's memory controller, "N:memory:/path").
// A container usually sees its own cgroup at the hierarchy's root, which the walk up reaches.
std::optional<std::uint64_t> cgroup_memory_left() {
  std::ifstream cgroups("/proc/self/cgroup");
  for (std::string line; std::getline(cgroups, line);) {
    const auto first = line.find(':'), second = line.find(':', first + 1);
    if (first == std::string::npos || second == std::string::npos) continue;
    const std::string controllers = line.substr(first + 1, second - first - 1);
    const bool v2 = line.compare(0, first, "0") == 0 && controllers.empty();
    if (!v2 && controllers != "memory") continue;
    const fs::path root = v2 ? "/sys/fs/cgroup" : "/sys/fs/cgroup/memory";
    std::optional<std::uint64_t> left;
    for (fs::path dir = root / fs::path(line.substr(second + 1)).relative_path();; dir = dir.parent_path()) {
      const auto limit = first_word(dir / (v2 ? "memory.max" : "memory.limit_in_bytes"));
      const auto usage = first_word(dir / (v2 ? "memory.current" : "memory.usage_in_bytes"));
      if (limit && usage) {
        std::uint64_t used = 0;
        std::istringstream(*usage) >> used;
        const std::string stat_key = v2 ? "inactive_file" : "total_inactive_file";
        if (const auto here =
                memory_left_under_limit(*limit, used, keyed_value(dir / "memory.stat", stat_key)))
          left = left ? std::min(*left, *here) : *here;
      }
      if (dir == root || !dir.has_relative_path()) break;
    }
    return left;
  }
  return std::nullopt;
}

}  // namespace

std::optional<std::uint64_t> memory_left_under_limit(const std::string& limit, std::uint64_t usage,
                                                     std::uint64_t inactive_file) {
  if (limit == "max") return std::nullopt;
  std::uint64_t bytes = 0;
  if (!(std::istringstream(limit) >> bytes) || bytes >= (std::uint64_t{1} << 62)) return std::nullopt;
  const std::uint64_t used = usage - std::min(usage, inactive_file);
  return bytes > used ? bytes - used : 0;
}

std::uint64_t available_memory_bytes() {
  std::uint64_t available = keyed_value("/proc/meminfo", "MemAvailable:") * 1024;  // "N kB"
  if (const auto left = cgroup_memory_left()) available = available ? std::min(available, *left) : *left;
  return available;
}

}  // namespace pg

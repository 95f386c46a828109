#include "pg/core/system_memory.h"

#include <fstream>
#include <sstream>
#include <string>

namespace pg {

std::uint64_t available_memory_bytes() {
  std::ifstream meminfo("/proc/meminfo");
  for (std::string line; std::getline(meminfo, line);) {
    if (line.rfind("MemAvailable:", 0) != 0) continue;
    std::istringstream fields(line.substr(13));
    std::uint64_t kib = 0;
    return fields >> kib ? kib * 1024 : 0;  // the kernel writes "MemAvailable: N kB"
  }
  return 0;
}

}  // namespace pg

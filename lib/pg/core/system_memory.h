#pragma once
// What the machine has to give: for sizing work to memory (how many large buffers may exist at once)
// when the user set no --max-memory budget.
#include <cstdint>
#include <optional>
#include <string>

namespace pg {

// Memory this process can have now without swapping or meeting its container's limit, in bytes: the
// smaller of Linux's MemAvailable and what the process's memory cgroup (v2 or v1) has left. 0 when
// unknown.
std::uint64_t available_memory_bytes();

// What a cgroup memory limit leaves: the limit less the usage, not counting the inactive file cache
// (the kernel reclaims it before it would fail an allocation). `limit` is the file's text: nullopt for
// "max" (v2) or a value of 2^62 or more (v1 writes unlimited as about 2^63).
std::optional<std::uint64_t> memory_left_under_limit(const std::string& limit, std::uint64_t usage,
                                                     std::uint64_t inactive_file);

}  // namespace pg

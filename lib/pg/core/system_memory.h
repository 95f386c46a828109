#pragma once
// What the machine has to give: for sizing work to memory (how many large buffers may exist at once)
// when the user set no --max-memory budget.
#include <cstdint>

namespace pg {

// Memory the system can hand out now without swapping (Linux MemAvailable), in bytes; 0 when unknown.
std::uint64_t available_memory_bytes();

}  // namespace pg

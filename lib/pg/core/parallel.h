#pragma once
// Thread control. Every parallel loop in pg partitions work so that results do not depend on the
// number of threads (reductions combine fixed-size chunks in a fixed order).
#include <cstdint>
#include <functional>

namespace pg {

// Limits TBB to `threads` workers for the rest of the process (0 = all cores).
void set_thread_count(int threads);
int thread_count();

// Runs body(begin, end) over [0, n) in chunks of `grain` items; chunk boundaries depend only on n and
// grain, never on the thread count, so per-chunk partial results can be combined deterministically.
void parallel_chunks(std::int64_t n, std::int64_t grain,
                     const std::function<void(std::int64_t begin, std::int64_t end)>& body);

}  // namespace pg

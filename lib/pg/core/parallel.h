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

// body(i) for every i in [0, n), at most `at_once` of them running at a time (each holds a large
// buffer, say); the other threads stay free for parallel loops inside body.
void parallel_for_bounded(int n, int at_once, const std::function<void(int)>& body);

}  // namespace pg

#include "pg/core/parallel.h"

#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_pipeline.h>
#include <tbb/partitioner.h>

#include <algorithm>
#include <memory>
#include <mutex>

namespace pg {
namespace {
std::mutex g_mutex;
std::unique_ptr<tbb::global_control> g_control;
int g_threads = 0;
}  // namespace

void set_thread_count(int threads) {
  std::lock_guard lock(g_mutex);
  g_control.reset();
  if (threads > 0)
    g_control = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, threads);
  g_threads = threads;
}

int thread_count() {
  std::lock_guard lock(g_mutex);
  return g_threads > 0 ? g_threads : tbb::info::default_concurrency();
}

void parallel_chunks(std::int64_t n, std::int64_t grain,
                     const std::function<void(std::int64_t begin, std::int64_t end)>& body) {
  if (n <= 0) return;
  if (grain < 1) grain = 1;
  std::int64_t chunks = (n + grain - 1) / grain;
  tbb::parallel_for(
      tbb::blocked_range<std::int64_t>(0, chunks, 1),
      [&](const tbb::blocked_range<std::int64_t>& r) {
        for (std::int64_t c = r.begin(); c != r.end(); ++c) body(c * grain, std::min(n, (c + 1) * grain));
      },
      tbb::simple_partitioner());
}

void parallel_for_bounded(int n, int at_once, const std::function<void(int)>& body) {
  int next = 0;
  tbb::parallel_pipeline(
      static_cast<std::size_t>(std::max(1, at_once)),
      tbb::make_filter<void, int>(tbb::filter_mode::serial_in_order, [&](tbb::flow_control& control) {
        if (next == n) control.stop();
        return next < n ? next++ : 0;
      }) & tbb::make_filter<int, void>(tbb::filter_mode::parallel, [&](int i) { body(i); }));
}

}  // namespace pg

// TBB shim behind core/mgs_parallel.h: one scheduler for the whole process, shared with
// OpenVDB. The thread limit is a tbb::global_control, which also bounds OpenVDB's loops.
#include "core/mgs_parallel.h"

#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <cstdlib>
#include <memory>
#include <mutex>

namespace {
std::unique_ptr<tbb::global_control> g_control;
std::once_flag g_env_once;
int g_threads = 0;

void apply_limit(int n) {
  g_control.reset();
  if (n > 0) g_control = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, (size_t)n);
  g_threads = n;
}

void init_from_env() {
  std::call_once(g_env_once, [] {
    if (g_threads > 0) return;  // set explicitly before first use
    if (const char *e = std::getenv("MGS_THREADS")) {
      int n = std::atoi(e);
      if (n > 0) apply_limit(n);
    }
  });
}
}  // namespace

extern "C" void mgs_parallel_for(size_t begin, size_t end, size_t grain, mgs_range_fn fn, void *ctx) {
  if (end <= begin) return;
  init_from_env();
  if (grain == 0) grain = 1;
  if (end - begin <= grain) { fn(ctx, begin, end); return; }
  tbb::parallel_for(tbb::blocked_range<size_t>(begin, end, grain),
                    [&](const tbb::blocked_range<size_t> &r) { fn(ctx, r.begin(), r.end()); });
}

extern "C" void mgs_parallel_set_threads(int n) {
  std::call_once(g_env_once, [] {});
  apply_limit(n > 0 ? n : 0);
}

extern "C" int mgs_parallel_max_threads(void) {
  init_from_env();
  return (int)tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism);
}

extern "C" int mgs_parallel_thread_index(void) {
  int i = tbb::this_task_arena::current_thread_index();
  return i < 0 ? 0 : i;
}

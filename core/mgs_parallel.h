/* The one parallel loop of the project, backed by TBB (the scheduler OpenVDB uses too,
 * so the two never oversubscribe the cores). Do not mix OpenMP or raw pthreads in. */
#ifndef MGS_PARALLEL_H
#define MGS_PARALLEL_H
#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

/* fn is called on disjoint sub-ranges [b, e) of [begin, end), possibly concurrently.
 * grain: the smallest range handed to one call (0 lets TBB choose). */
typedef void (*mgs_range_fn)(void *ctx, size_t b, size_t e);
void mgs_parallel_for(size_t begin, size_t end, size_t grain, mgs_range_fn fn, void *ctx);

/* Limit worker threads for the whole process (0 = all cores). Also read from the
 * environment variable MGS_THREADS at first use. */
void mgs_parallel_set_threads(int n);
int mgs_parallel_max_threads(void);
/* Index of the calling thread in [0, mgs_parallel_max_threads()), for per-thread scratch. */
int mgs_parallel_thread_index(void);

#ifdef __cplusplus
}
#endif
#endif

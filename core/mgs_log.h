/* Logging to stderr and a terminal progress bar.
 * The progress bar draws only when stdout is a terminal; otherwise it stays quiet and
 * (at most every 10 %) prints a plain line, so logs in CI stay readable. */
#ifndef MGS_LOG_H
#define MGS_LOG_H
#include <stddef.h>
#include <stdio.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef enum { MGS_LOG_DEBUG = 0, MGS_LOG_INFO, MGS_LOG_WARN, MGS_LOG_ERROR, MGS_LOG_QUIET } mgs_log_level;

void mgs_log_set_level(mgs_log_level level);
mgs_log_level mgs_log_get_level(void);
void mgs_log(mgs_log_level level, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
#define mgs_debug(...) mgs_log(MGS_LOG_DEBUG, __VA_ARGS__)
#define mgs_info(...)  mgs_log(MGS_LOG_INFO, __VA_ARGS__)
#define mgs_warn(...)  mgs_log(MGS_LOG_WARN, __VA_ARGS__)
#define mgs_errorf(...) mgs_log(MGS_LOG_ERROR, __VA_ARGS__)

typedef struct mgs_progress mgs_progress;
/* total: number of steps; label: shown before the bar. */
mgs_progress *mgs_progress_create(const char *label, size_t total);
/* done: steps completed so far; status: short text after the bar (may be NULL). */
void mgs_progress_update(mgs_progress *p, size_t done, const char *status);
void mgs_progress_destroy(mgs_progress *p); /* finishes the line */

/* Wall clock in seconds (monotonic). */
double mgs_now(void);
/* CPU time of this process (all its threads) in seconds: what a run costs on a machine
 * whose other load inflates wall times. */
double mgs_cpu_now(void);
/* Peak resident set size of this process in bytes (0 if unknown). */
size_t mgs_peak_rss(void);

#ifdef __cplusplus
}
#endif
#endif

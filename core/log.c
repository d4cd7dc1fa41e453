/* Logging and the progress bar. */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>
#include <sys/resource.h>
#include "core/mgs_log.h"

static mgs_log_level g_level = MGS_LOG_INFO;
static int g_level_init = 0;

static void init_level(void) {
  if (g_level_init) return;
  g_level_init = 1;
  const char *e = getenv("MGS_LOG");
  if (!e) return;
  if (!strcmp(e, "debug")) g_level = MGS_LOG_DEBUG;
  else if (!strcmp(e, "warn")) g_level = MGS_LOG_WARN;
  else if (!strcmp(e, "error")) g_level = MGS_LOG_ERROR;
  else if (!strcmp(e, "quiet")) g_level = MGS_LOG_QUIET;
}

void mgs_log_set_level(mgs_log_level level) { g_level_init = 1; g_level = level; }
mgs_log_level mgs_log_get_level(void) { init_level(); return g_level; }

void mgs_log(mgs_log_level level, const char *fmt, ...) {
  init_level();
  if (level < g_level) return;
  static const char *tags[] = {"debug: ", "", "warning: ", "error: "};
  fputs(tags[level < MGS_LOG_QUIET ? level : MGS_LOG_ERROR], stderr);
  va_list ap;
  va_start(ap, fmt);
  vfprintf(stderr, fmt, ap);
  va_end(ap);
  size_t n = strlen(fmt);
  if (n == 0 || fmt[n - 1] != '\n') fputc('\n', stderr);
}

double mgs_now(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

double mgs_cpu_now(void) {
  struct timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

size_t mgs_peak_rss(void) {
  struct rusage ru;
  if (getrusage(RUSAGE_SELF, &ru) != 0) return 0;
  return (size_t)ru.ru_maxrss * 1024u; /* Linux reports KiB */
}

struct mgs_progress {
  char label[64];
  size_t total, last_done;
  int tty, last_decile;
  double start, last_draw;
};

mgs_progress *mgs_progress_create(const char *label, size_t total) {
  mgs_progress *p = calloc(1, sizeof *p);
  if (!p) return NULL;
  snprintf(p->label, sizeof p->label, "%s", label ? label : "");
  p->total = total ? total : 1;
  p->tty = isatty(STDOUT_FILENO);
  p->start = p->last_draw = mgs_now();
  p->last_decile = -1;
  return p;
}

void mgs_progress_update(mgs_progress *p, size_t done, const char *status) {
  if (!p || mgs_log_get_level() > MGS_LOG_INFO) return;
  if (done > p->total) done = p->total;
  p->last_done = done;
  double now = mgs_now(), el = now - p->start;
  double frac = (double)done / (double)p->total;
  if (p->tty) {
    if (now - p->last_draw < 0.1 && done < p->total) return;
    p->last_draw = now;
    int width = 30, fill = (int)(frac * width);
    char bar[31];
    for (int i = 0; i < width; i++) bar[i] = i < fill ? '#' : '-';
    bar[width] = 0;
    double eta = done ? el * (double)(p->total - done) / (double)done : 0;
    printf("\r%s [%s] %zu/%zu %.0fs<%.0fs %s\033[K", p->label, bar, done, p->total, el, eta, status ? status : "");
    fflush(stdout);
  } else {
    /* Not a terminal: one plain line per 10 %, so CI logs stay short. */
    int decile = (int)(frac * 10.0);
    if (decile == p->last_decile) return;
    p->last_decile = decile;
    printf("%s %3d%% %zu/%zu %.1fs %s\n", p->label, decile * 10, done, p->total, el, status ? status : "");
    fflush(stdout);
  }
}

void mgs_progress_destroy(mgs_progress *p) {
  if (!p) return;
  if (p->tty && mgs_log_get_level() <= MGS_LOG_INFO) { printf("\n"); fflush(stdout); }
  free(p);
}

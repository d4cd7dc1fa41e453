/* Minimal test harness: each test program runs its cases and exits non-zero on any
 * failed check. A check failure prints file:line and the values involved. */
#ifndef MGS_TEST_H
#define MGS_TEST_H
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <stddef.h>
#include <stdarg.h>
#include <sys/wait.h>
#include "core/mgs_error.h"

/* 1 in a build under AddressSanitizer (GCC defines __SANITIZE_ADDRESS__, clang has the
 * feature test): the heaviest fast tests take a smaller input there, with the same checks */
#if defined(__SANITIZE_ADDRESS__)
#define MGS_TEST_SANITIZED 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define MGS_TEST_SANITIZED 1
#endif
#endif
#ifndef MGS_TEST_SANITIZED
#define MGS_TEST_SANITIZED 0
#endif

static int mgs_test_failures = 0;
static int mgs_test_checks = 0;

#define CHECK(cond) do { mgs_test_checks++; if (!(cond)) { mgs_test_failures++; \
  fprintf(stderr, "%s:%d: CHECK failed: %s\n", __FILE__, __LINE__, #cond); } } while (0)
#define CHECK_MSG(cond, ...) do { mgs_test_checks++; if (!(cond)) { mgs_test_failures++; \
  fprintf(stderr, "%s:%d: CHECK failed: %s: ", __FILE__, __LINE__, #cond); \
  fprintf(stderr, __VA_ARGS__); fputc('\n', stderr); } } while (0)
#define CHECK_NEAR(a, b, tol) do { double _a = (double)(a), _b = (double)(b), _t = (double)(tol); \
  mgs_test_checks++; if (!(fabs(_a - _b) <= _t) || _a != _a || _b != _b) { mgs_test_failures++; \
  fprintf(stderr, "%s:%d: CHECK_NEAR failed: %s = %.9g, %s = %.9g, tol %.3g\n", __FILE__, __LINE__, \
          #a, _a, #b, _b, _t); } } while (0)
/* A call returning mgs_status must succeed; prints the error message otherwise. */
static inline const char *mgs_test_errmsg(const void *err) {
  return err ? ((const mgs_error *)err)->msg : "?";
}
#define CHECK_OK(call, errp) do { mgs_test_checks++; mgs_status _s = (call); if (_s != MGS_OK) { \
  mgs_test_failures++; fprintf(stderr, "%s:%d: %s failed: %s\n", __FILE__, __LINE__, #call, \
  mgs_test_errmsg(errp)); } } while (0)

#define RUN(fn) do { int _before = mgs_test_failures; fn(); \
  fprintf(stderr, "%s %s\n", mgs_test_failures == _before ? "ok  " : "FAIL", #fn); } while (0)

static inline int mgs_test_finish(void) {
  fprintf(stderr, "%d checks, %d failed\n", mgs_test_checks, mgs_test_failures);
  if (mgs_test_checks == 0) { fprintf(stderr, "no checks ran\n"); return 1; }
  return mgs_test_failures ? 1 : 0;
}

/* Runs a shell command (printf-style), echoing it to stderr; its exit status, 128 when it
 * did not exit normally. For the tests that drive the CLI. */
static inline int mgs_test_sh(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
static inline int mgs_test_sh(const char *fmt, ...) {
  char cmd[8192];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(cmd, sizeof cmd, fmt, ap);
  va_end(ap);
  fprintf(stderr, "$ %s\n", cmd);
  int rc = system(cmd);
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : 128;
}

/* Does the file at `path` contain `needle`? (0 when it cannot be read) */
static inline int mgs_test_file_has(const char *path, const char *needle) {
  FILE *f = fopen(path, "rb");
  if (!f) return 0;
  size_t cap = 1 << 16, len = 0;
  char *b = malloc(cap + 1);
  size_t got;
  while (b && (got = fread(b + len, 1, cap - len, f)) > 0) {
    len += got;
    if (len == cap) { char *nb = realloc(b, 2 * cap + 1); if (!nb) break; b = nb; cap *= 2; }
  }
  fclose(f);
  if (!b) return 0;
  b[len] = 0;
  int found = strstr(b, needle) != NULL;
  free(b);
  return found;
}

/* A fresh scratch directory under the test's working directory (removed first). */
static inline const char *mgs_test_tmpdir(const char *name) {
  static char buf[256];
  snprintf(buf, sizeof buf, "tmp_%.200s", name);
  char cmd[600]; snprintf(cmd, sizeof cmd, "rm -rf '%s' && mkdir -p '%s'", buf, buf);
  if (system(cmd) != 0) { fprintf(stderr, "cannot make %s\n", buf); exit(2); }
  return buf;
}
#endif

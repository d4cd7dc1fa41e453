/* Shared by the fuzz targets: a private scratch directory and whole-file writes, so each
 * target fuzzes the readers through their file-path API exactly as users reach them. */
#ifndef MGS_FUZZ_UTIL_H
#define MGS_FUZZ_UTIL_H
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core/mgs_fs.h"

static char fuzz_dir_buf[256];
static inline void fuzz_cleanup(void) {
  if (fuzz_dir_buf[0]) mgs_remove_tree(fuzz_dir_buf, NULL);
}

static inline const char *fuzz_dir(void) {
  if (!fuzz_dir_buf[0]) {
    snprintf(fuzz_dir_buf, sizeof fuzz_dir_buf, "/tmp/mgs-fuzz-%ld-XXXXXX", (long)getpid());
    if (!mkdtemp(fuzz_dir_buf)) abort();
    atexit(fuzz_cleanup);
  }
  return fuzz_dir_buf;
}

static inline char *fuzz_path(const char *rel) {
  char *p = mgs_path_join(fuzz_dir(), rel);
  if (!p) abort();
  return p;
}

static inline void fuzz_write(const char *path, const uint8_t *data, size_t n) {
  FILE *f = fopen(path, "wb");
  if (!f) abort();
  if (n && fwrite(data, 1, n, f) != n) abort();
  fclose(f);
}
/* Reads `path` as Gaussians: success returns a model, failure returns none and names the
 * file (`name`, the path's last part); anything else aborts (a finding). */
#include "core/mgs_ply.h"
static inline void fuzz_check_gaussians(const char *path, const char *name) {
  mgs_error err;
  mgs_gaussians *g = NULL;
  if (mgs_ply_read_gaussians(path, &g, &err) == MGS_OK) {
    if (!g) abort();
    mgs_gaussians_destroy(g);
  } else if (g || !strstr(err.msg, name)) {
    abort();
  }
}

#endif

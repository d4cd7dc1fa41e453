/* File-system helpers: atomic writes and directories. */
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include "core/mgs_fs.h"

struct mgs_atomic_file {
  char *path, *tmp;
  FILE *fp;
};

char *mgs_strdup(const char *s) {
  if (!s) return NULL;
  size_t n = strlen(s) + 1;
  char *d = malloc(n);
  if (d) memcpy(d, s, n);
  return d;
}

char *mgs_temp_path_for(const char *path) {
  static unsigned counter = 0;
  size_t n = strlen(path) + 64;
  char *t = malloc(n);
  if (t) snprintf(t, n, "%s.tmp-%ld-%u", path, (long)getpid(), __atomic_fetch_add(&counter, 1, __ATOMIC_RELAXED));
  return t;
}

mgs_status mgs_atomic_open(const char *path, mgs_atomic_file **out, FILE **fp, mgs_error *err) {
  *out = NULL; *fp = NULL;
  mgs_atomic_file *af = calloc(1, sizeof *af);
  if (!af) return mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", path);
  af->path = mgs_strdup(path);
  af->tmp = mgs_temp_path_for(path);
  if (!af->path || !af->tmp) { mgs_atomic_abort(af); return mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", path); }
  af->fp = fopen(af->tmp, "wb");
  if (!af->fp) {
    int e = errno;
    mgs_atomic_abort(af);
    return mgs_error_set(err, MGS_ERR_IO, "%s: cannot write: %s", path, strerror(e));
  }
  *out = af; *fp = af->fp;
  return MGS_OK;
}

mgs_status mgs_atomic_commit(mgs_atomic_file *af, mgs_error *err) {
  mgs_status st = MGS_OK;
  int bad = ferror(af->fp) != 0;
  if (fflush(af->fp) != 0) bad = 1;
  if (!bad && fsync(fileno(af->fp)) != 0) bad = 1;
  int e = errno;
  if (fclose(af->fp) != 0) bad = 1;
  af->fp = NULL;
  if (bad) st = mgs_error_set(err, MGS_ERR_IO, "%s: write failed: %s", af->path, strerror(e));
  else if (rename(af->tmp, af->path) != 0)
    st = mgs_error_set(err, MGS_ERR_IO, "%s: cannot rename temporary file into place: %s", af->path, strerror(errno));
  if (st != MGS_OK) remove(af->tmp);
  free(af->path); free(af->tmp); free(af);
  return st;
}

void mgs_atomic_abort(mgs_atomic_file *af) {
  if (!af) return;
  if (af->fp) fclose(af->fp);
  if (af->tmp) remove(af->tmp);
  free(af->path); free(af->tmp); free(af);
}

mgs_status mgs_write_file_atomic(const char *path, const void *data, size_t size, mgs_error *err) {
  mgs_atomic_file *af; FILE *fp;
  mgs_status st = mgs_atomic_open(path, &af, &fp, err);
  if (st != MGS_OK) return st;
  if (size && fwrite(data, 1, size, fp) != size) {
    mgs_atomic_abort(af);
    return mgs_error_set(err, MGS_ERR_IO, "%s: write failed", path);
  }
  return mgs_atomic_commit(af, err);
}

mgs_status mgs_read_file(const char *path, char **data, size_t *size, mgs_error *err) {
  *data = NULL; if (size) *size = 0;
  FILE *fp = fopen(path, "rb");
  if (!fp) return mgs_error_set(err, MGS_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
  struct stat st;
  if (fstat(fileno(fp), &st) != 0 || !S_ISREG(st.st_mode)) {
    fclose(fp);
    return mgs_error_set(err, MGS_ERR_IO, "%s: not a regular file", path);
  }
  size_t n = (size_t)st.st_size;
  char *buf = malloc(n + 1);
  if (!buf) { fclose(fp); return mgs_error_set(err, MGS_ERR_NOMEM, "%s: cannot allocate %zu bytes", path, n); }
  if (n && fread(buf, 1, n, fp) != n) {
    free(buf); fclose(fp);
    return mgs_error_set(err, MGS_ERR_IO, "%s: read failed", path);
  }
  fclose(fp);
  buf[n] = 0;
  *data = buf;
  if (size) *size = n;
  return MGS_OK;
}

int mgs_path_exists(const char *path) { struct stat st; return stat(path, &st) == 0; }
int mgs_is_dir(const char *path) { struct stat st; return stat(path, &st) == 0 && S_ISDIR(st.st_mode); }

mgs_status mgs_mkdir_p(const char *dir, mgs_error *err) {
  char *p = mgs_strdup(dir);
  if (!p) return mgs_error_set(err, MGS_ERR_NOMEM, "out of memory");
  size_t n = strlen(p);
  for (size_t i = 1; i <= n; i++) {
    if (p[i] != '/' && p[i] != '\0') continue;
    char c = p[i];
    p[i] = '\0';
    if (mkdir(p, 0777) != 0 && errno != EEXIST) {
      int e = errno;
      mgs_status s = mgs_error_set(err, MGS_ERR_IO, "%s: cannot create directory: %s", p, strerror(e));
      free(p);
      return s;
    }
    if (!mgs_is_dir(p)) {
      mgs_status s = mgs_error_set(err, MGS_ERR_IO, "%s: exists and is not a directory", p);
      free(p);
      return s;
    }
    p[i] = c;
  }
  free(p);
  return MGS_OK;
}

mgs_status mgs_remove_tree(const char *path, mgs_error *err) {
  struct stat st;
  if (lstat(path, &st) != 0) return MGS_OK;
  if (S_ISDIR(st.st_mode)) {
    DIR *d = opendir(path);
    if (!d) return mgs_error_set(err, MGS_ERR_IO, "%s: cannot open directory: %s", path, strerror(errno));
    struct dirent *e;
    mgs_status s = MGS_OK;
    while (s == MGS_OK && (e = readdir(d))) {
      if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, "..")) continue;
      char *child = mgs_path_join(path, e->d_name);
      s = child ? mgs_remove_tree(child, err) : mgs_error_set(err, MGS_ERR_NOMEM, "out of memory");
      free(child);
    }
    closedir(d);
    if (s != MGS_OK) return s;
    if (rmdir(path) != 0) return mgs_error_set(err, MGS_ERR_IO, "%s: cannot remove: %s", path, strerror(errno));
  } else if (unlink(path) != 0) {
    return mgs_error_set(err, MGS_ERR_IO, "%s: cannot remove: %s", path, strerror(errno));
  }
  return MGS_OK;
}

char *mgs_path_join(const char *a, const char *b) {
  size_t na = strlen(a), nb = strlen(b);
  char *p = malloc(na + nb + 2);
  if (!p) return NULL;
  memcpy(p, a, na);
  size_t k = na;
  if (na && a[na - 1] != '/') p[k++] = '/';
  memcpy(p + k, b, nb + 1);
  return p;
}

char *mgs_path_dirname(const char *path) {
  const char *slash = strrchr(path, '/');
  if (!slash) return mgs_strdup(".");
  if (slash == path) return mgs_strdup("/");
  size_t n = (size_t)(slash - path);
  char *d = malloc(n + 1);
  if (d) { memcpy(d, path, n); d[n] = 0; }
  return d;
}

/* Header-against-size checks for mesh files, run before assimp sees them (mesh_check.h). */
#include <ctype.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "core/mesh_check.h"
#include "core/ply_format.h"

static mgs_status ply_noop_row(void *ctx, size_t row, const double *values, mgs_error *err) {
  (void)ctx; (void)row; (void)values; (void)err;
  return MGS_OK;
}

/* Walks every element of the body: a file that ends early or whose counts cannot fit is
 * refused with the walker's message (naming the element, the count and the bytes left). */
static mgs_status check_ply(const char *path, mgs_error *err) {
  ply_file pf;
  mgs_status st = ply_open(path, &pf, err);
  if (st != MGS_OK) return st;
  int last = -1;
  for (int i = 0; i < pf.n_elems; i++)
    if (pf.elems[i].n_props > 0 && pf.elems[i].count > 0) last = i;
  if (last >= 0) st = ply_read_element(&pf, last, ply_noop_row, NULL, err);
  ply_close(&pf);
  return st;
}

/* Reads the next unsigned integer of an OFF header, skipping blanks and # comments. */
static int off_next_count(FILE *f, unsigned long long *v) {
  int c;
  for (;;) {
    c = fgetc(f);
    if (c == '#') {
      while (c != EOF && c != '\n') c = fgetc(f);
    }
    if (c == EOF) return 0;
    if (!isspace(c)) break;
  }
  if (!isdigit(c)) return 0;
  unsigned long long x = 0;
  while (c != EOF && isdigit(c)) {
    if (x > 1000000000000000ULL) return 0;
    x = x * 10 + (unsigned long long)(c - '0');
    c = fgetc(f);
  }
  *v = x;
  return 1;
}

/* An OFF vertex line needs at least 6 bytes ("0 0 0\n"), a face at least 2 ("0\n"). */
static mgs_status check_off(const char *path, FILE *f, long long size, mgs_error *err) {
  char tok[32];
  if (fscanf(f, "%31s", tok) != 1) return MGS_OK;
  unsigned long long nv = 0, nf = 0;
  if (!off_next_count(f, &nv) || !off_next_count(f, &nf)) return MGS_OK; /* assimp's own message */
  const unsigned long long need = nv * 6ULL + nf * 2ULL;
  if (nv > (unsigned long long)size || nf > (unsigned long long)size || need > (unsigned long long)size)
    return mgs_error_set(err, MGS_ERR_FORMAT,
                         "%s: OFF header claims %llu vertices and %llu faces, more than a %lld-byte file can hold (truncated or corrupt)",
                         path, nv, nf, size);
  return MGS_OK;
}

/* Binary STL: 80-byte header, a uint32 triangle count, 50 bytes per triangle. Assimp takes
 * a file as binary only when the size matches exactly; a file that does not start with
 * "solid" cannot be ASCII, so a mismatch there is a truncated or padded binary file. */
static mgs_status check_stl(const char *path, FILE *f, long long size, mgs_error *err) {
  unsigned char h[84];
  size_t got = fread(h, 1, sizeof h, f);
  int ascii = got >= 5 && memcmp(h, "solid", 5) == 0;
  if (ascii) return MGS_OK;
  if (got < sizeof h)
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: binary STL shorter than its 84-byte header (%lld bytes)", path, size);
  unsigned long long n = (unsigned long long)h[80] | (unsigned long long)h[81] << 8 |
                         (unsigned long long)h[82] << 16 | (unsigned long long)h[83] << 24;
  if (84ULL + 50ULL * n != (unsigned long long)size)
    return mgs_error_set(err, MGS_ERR_FORMAT,
                         "%s: binary STL header claims %llu triangles (%llu bytes) but the file has %lld bytes (truncated or corrupt)",
                         path, n, 84ULL + 50ULL * n, size);
  return MGS_OK;
}

static int ext_is(const char *path, const char *e) {
  const char *s = strrchr(path, '/');
  const char *dot = strrchr(s ? s : path, '.');
  if (!dot || strlen(dot + 1) != strlen(e)) return 0;
  for (size_t i = 0; e[i]; i++)
    if (tolower((unsigned char)dot[1 + i]) != e[i]) return 0;
  return 1;
}

mgs_status mgs_mesh_precheck(const char *path, mgs_error *err) {
  struct stat st;
  if (stat(path, &st) != 0) return mgs_error_set(err, MGS_ERR_IO, "%s: %s", path, strerror(errno));
  FILE *f = fopen(path, "rb");
  if (!f) return mgs_error_set(err, MGS_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
  char head[8] = {0};
  size_t n = fread(head, 1, sizeof head - 1, f);
  rewind(f);
  /* Assimp chooses a reader by extension and by content; check by both. */
  const int is_ply = ext_is(path, "ply") || (n >= 4 && memcmp(head, "ply", 3) == 0 && (head[3] == '\n' || head[3] == '\r'));
  const char *off = strstr(head, "OFF");
  const int is_off = ext_is(path, "off") || (off && off - head <= 4);
  const int is_stl = ext_is(path, "stl");
  mgs_status s = MGS_OK;
  if (is_off) s = check_off(path, f, (long long)st.st_size, err);
  else if (is_stl) s = check_stl(path, f, (long long)st.st_size, err);
  fclose(f);
  if (s == MGS_OK && is_ply) s = check_ply(path, err);
  return s;
}

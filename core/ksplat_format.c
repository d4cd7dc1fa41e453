/* GaussianSplats3D's .ksplat -> a 3DGS model (core/ksplat_format.h). Decoded as
 * splat-transform's readKsplat decodes it (facts of the format): position = (q - range) *
 * block / 2 / range + the bucket's centre at levels 1-2; scale log(linear) (a zero, an
 * underflowed float16, becomes -10 as there); colour (byte / 255 - 0.5) / SH_C0; opacity
 * byte / 255 through the logit; SH stored channel by channel within each degree (degree 1:
 * R0 R1 R2 G0 ..., degree 2: R3..R7 G3..., degree 3: R8..R14 ...). */
#include "core/ksplat_format.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mgs_fs.h"

#define MAIN_HEADER 4096
#define SECTION_HEADER 1024
#define SH_C0 0.28209479177387814

int ksplat_is_path(const char *path) {
  const size_t n = strlen(path);
  return n > 7 && !strcmp(path + n - 7, ".ksplat");
}

static uint32_t u32(const uint8_t *p) { return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24; }
static uint16_t u16(const uint8_t *p) { return (uint16_t)(p[0] | p[1] << 8); }
static float f32(const uint8_t *p) {
  const uint32_t u = u32(p);
  float f;
  memcpy(&f, &u, 4);
  return f;
}
static double f16(const uint8_t *p) {
  const uint16_t h = u16(p);
  const int e = (h >> 10) & 31, m = h & 1023;
  const double v = e == 0 ? ldexp(m, -24) : e == 31 ? (m ? NAN : INFINITY) : ldexp(1024 + m, e - 25);
  return (h & 0x8000) ? -v : v;
}

/* Bytes of a record's parts at each compression level (as the format's table). */
static const int CENTER[3] = {12, 6, 6}, SCALE[3] = {12, 6, 6}, ROT[3] = {16, 8, 8}, SHB[3] = {4, 2, 1};
static const int SH_COUNT[4] = {0, 9, 24, 45};

mgs_status ksplat_read_gaussians(const char *path, mgs_gaussians **g, double **xyz64, mgs_error *err) {
  *g = NULL;
  *xyz64 = NULL;
  char *text = NULL;
  size_t size = 0;
  mgs_status st = mgs_read_file(path, &text, &size, err);
  uint8_t *b = (uint8_t *)text;
  if (st) return st;
  mgs_gaussians *m = NULL;
  double *xyz = NULL;
#define FAIL(...) do { st = mgs_error_set(err, MGS_ERR_FORMAT, __VA_ARGS__); goto done; } while (0)
  if (size < MAIN_HEADER) FAIL("%s: %zu bytes; a .ksplat header alone is %d", path, size, MAIN_HEADER);
  if (b[0] != 0 || b[1] < 1) FAIL("%s: .ksplat version %d.%d; this reader knows 0.1 and later 0.x", path, b[0], b[1]);
  const uint32_t sections = u32(b + 4), n = u32(b + 16);
  const int level = u16(b + 20);
  if (level > 2) FAIL("%s: compression level %d; the format has 0, 1 and 2", path, level);
  if (n == 0) FAIL("%s: the header counts 0 splats", path);
  if (sections == 0 || (uint64_t)sections * SECTION_HEADER > size - MAIN_HEADER)
    FAIL("%s: %u section headers do not fit the %zu-byte file", path, sections, size);
  double sh_lo = f32(b + 36), sh_hi = f32(b + 40);
  if (sh_lo == 0) sh_lo = -1.5; /* as the format's writers: 0 means the default bounds */
  if (sh_hi == 0) sh_hi = 1.5;
  if (!isfinite(sh_lo) || !isfinite(sh_hi)) FAIL("%s: SH bounds %g..%g are not finite", path, sh_lo, sh_hi);
  /* every section fits the file before anything is allocated for the splats it claims; the
     largest SH degree of any section decides the model's */
  int degree = 0;
  uint64_t total = 0, end = MAIN_HEADER + (uint64_t)sections * SECTION_HEADER;
  for (uint32_t s = 0; s < sections; s++) {
    const uint8_t *h = b + MAIN_HEADER + (size_t)s * SECTION_HEADER;
    const int d = u16(h + 40);
    if (d > 3) FAIL("%s: section %u has SH degree %d; at most 3 is read", path, s, d);
    const uint64_t per = (uint64_t)(CENTER[level] + SCALE[level] + ROT[level] + 4 + SH_COUNT[d] * SHB[level]);
    end += (uint64_t)u16(h + 20) * u32(h + 12) + 4ull * u32(h + 36) + per * u32(h + 4);
    if (u32(h) > u32(h + 4) || end > size)
      FAIL("%s: section %u (%u splats of %u) does not fit the %zu-byte file or its own counts", path, s, u32(h), u32(h + 4), size);
    if (u32(h) && d > degree) degree = d;
    total += u32(h);
  }
  if (total != n) FAIL("%s: the sections hold %llu splats, the header counts %u", path, (unsigned long long)total, n);
  m = mgs_gaussians_create(n, degree);
  xyz = malloc((size_t)n * 3 * sizeof(double));
  size_t first = 0;
  if (!m || !xyz || mgs_gaussians_append(m, n, &first, err) != MGS_OK) {
    st = mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory for %u splats", path, n);
    goto done;
  }
  uint64_t off = MAIN_HEADER + (uint64_t)sections * SECTION_HEADER;
  size_t k = 0; /* splats read so far */
  for (uint32_t s = 0; s < sections; s++) {
    const uint8_t *h = b + MAIN_HEADER + (size_t)s * SECTION_HEADER;
    const uint32_t count = u32(h), cap_splats = u32(h + 4), capacity = u32(h + 8), buckets = u32(h + 12);
    const double block = f32(h + 16);
    const uint32_t bucket_bytes = u16(h + 20), full = u32(h + 32), partial = u32(h + 36);
    uint32_t range = u32(h + 24);
    if (range == 0) range = level == 0 ? 1 : 32767;
    const int d = u16(h + 40), ncomp = SH_COUNT[d];
    const uint64_t per = (uint64_t)(CENTER[level] + SCALE[level] + ROT[level] + 4 + ncomp * SHB[level]);
    const uint64_t storage = (uint64_t)bucket_bytes * buckets + 4ull * partial;
    if (count > cap_splats || (uint64_t)full + partial > buckets || (level > 0 && bucket_bytes < 12 && buckets) ||
        off + storage + per * cap_splats > size)
      FAIL("%s: section %u (%u splats of %u, %u buckets) does not fit the file or its own counts", path, s, count, cap_splats, buckets);
    if (level > 0 && count && !(block > 0 && isfinite(block))) FAIL("%s: section %u: block size %g", path, s, block);
    const uint8_t *sizes = b + off, *centers = b + off + 4ull * partial, *rec0 = b + off + storage;
    const double unit = level > 0 ? block / 2.0 / range : 0;
    uint32_t pb = full;                         /* the partial bucket being read */
    uint64_t pb_base = (uint64_t)full * capacity; /* its first splat */
    for (uint32_t i = 0; i < count; i++, k++) {
      const uint8_t *r = rec0 + per * i;
      uint32_t bucket = 0;
      if (level > 0) {
        if ((uint64_t)i < (uint64_t)full * capacity) bucket = capacity ? i / capacity : 0;
        else {
          while (pb < full + partial && i >= pb_base + u32(sizes + 4ull * (pb - full))) pb_base += u32(sizes + 4ull * (pb++ - full));
          bucket = pb;
        }
        if (bucket >= buckets) FAIL("%s: section %u: splat %u falls outside its %u buckets", path, s, i, buckets);
      }
      for (int c = 0; c < 3; c++) {
        double x, sc;
        if (level == 0) {
          x = f32(r + 4 * c);
          sc = f32(r + 12 + 4 * c);
        } else {
          x = (u16(r + 2 * c) - (double)range) * unit + f32(centers + 12ull * bucket + 4 * (size_t)c);
          sc = f16(r + 6 + 2 * c);
        }
        if (!isfinite(x) || !isfinite(sc) || sc < 0)
          FAIL("%s: splat %zu: position %g or scale %g of axis %d is not a finite position and size", path, k, x, sc, c);
        xyz[3 * k + (size_t)c] = x;
        m->log_scale[3 * k + (size_t)c] = (float)(sc > 0 ? log(sc) : -10.0);
      }
      const uint8_t *q = r + CENTER[level] + SCALE[level];
      double rot[4], len = 0;
      for (int c = 0; c < 4; c++) {
        rot[c] = level == 0 ? f32(q + 4 * c) : f16(q + 2 * c);
        len += rot[c] * rot[c];
      }
      if (!(len > 0) || !isfinite(len)) FAIL("%s: splat %zu: rotation is zero or not finite", path, k);
      len = sqrt(len);
      for (int c = 0; c < 4; c++) m->rot[4 * k + (size_t)c] = (float)(rot[c] / len);
      const uint8_t *col = q + ROT[level];
      for (int c = 0; c < 3; c++) m->sh_dc[3 * k + (size_t)c] = (float)((col[c] / 255.0 - 0.5) / SH_C0);
      /* 8 bits cannot say 0 or 1: the ends stay half a quantum inside, the logit finite */
      const double a = fmin(fmax(col[3] / 255.0, 0.5 / 255.0), 1.0 - 0.5 / 255.0);
      m->opacity[k] = (float)log(a / (1.0 - a));
      float *rest = m->sh_rest + k * MGS_SH_REST_MAX;
      memset(rest, 0, sizeof(float) * MGS_SH_REST_MAX);
      const uint8_t *sh = col + 4;
      for (int j = 0; j < ncomp; j++) {
        const int ch = j < 9 ? j / 3 : j < 24 ? (j - 9) / 5 : (j - 24) / 7;
        const int co = j < 9 ? j % 3 : j < 24 ? (j - 9) % 5 + 3 : (j - 24) % 7 + 8;
        const double v = level == 0 ? f32(sh + 4 * j) : level == 1 ? f16(sh + 2 * j) : sh_lo + sh[j] / 255.0 * (sh_hi - sh_lo);
        if (!isfinite(v)) FAIL("%s: splat %zu: SH coefficient %d is not finite", path, k, j);
        rest[3 * co + ch] = (float)v;
      }
    }
    off += storage + per * cap_splats;
  }
#undef FAIL
  *g = m;
  *xyz64 = xyz;
  m = NULL;
  xyz = NULL;
done:
  free(b);
  free(xyz);
  mgs_gaussians_destroy(m);
  return st;
}

/* The antimatter15 `.splat` file -> a 3DGS model (core/splat_format.h). Decoded as the
 * format's writer (antimatter15/splat's convert script) encodes: rotation bytes (b - 128) /
 * 128, then normalised; scales log-ed; colour and opacity bytes / 255. */
#include "core/splat_format.h"
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define SPLAT_BYTES 32
#define SH_C0 0.28209479177387814

int splat_is_path(const char *path) {
  const size_t n = strlen(path);
  return n > 6 && !strcmp(path + n - 6, ".splat");
}

static float f32le(const unsigned char *p) {
  const uint32_t u = (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
  float f;
  memcpy(&f, &u, 4);
  return f;
}

mgs_status splat_read_gaussians(const char *path, mgs_gaussians **g, double **xyz64, mgs_error *err) {
  *g = NULL;
  *xyz64 = NULL;
  FILE *f = fopen(path, "rb");
  if (!f) return mgs_error_set(err, MGS_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
  long size = -1;
  if (fseek(f, 0, SEEK_END) == 0) size = ftell(f);
  if (size < 0 || fseek(f, 0, SEEK_SET) != 0) {
    fclose(f);
    return mgs_error_set(err, MGS_ERR_IO, "%s: cannot read its size", path);
  }
  if (size == 0 || size % SPLAT_BYTES) {
    fclose(f);
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: %ld bytes; a .splat file is a positive multiple of %d bytes (one splat each)",
                         path, size, SPLAT_BYTES);
  }
  const size_t n = (size_t)size / SPLAT_BYTES;
  mgs_status st = MGS_OK;
  unsigned char *buf = malloc((size_t)size);
  mgs_gaussians *m = mgs_gaussians_create(n, 0);
  double *xyz = malloc(n * 3 * sizeof(double));
  size_t first = 0;
  if (!buf || !m || !xyz || mgs_gaussians_append(m, n, &first, err) != MGS_OK) {
    st = mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory for %zu splats", path, n);
    goto done;
  }
  if (fread(buf, 1, (size_t)size, f) != (size_t)size) {
    st = mgs_error_set(err, MGS_ERR_IO, "%s: short read", path);
    goto done;
  }
  for (size_t i = 0; i < n; i++) {
    const unsigned char *p = buf + i * SPLAT_BYTES;
    for (int k = 0; k < 3; k++) {
      const float x = f32le(p + 4 * k), s = f32le(p + 12 + 4 * k);
      if (!isfinite(x)) {
        st = mgs_error_set(err, MGS_ERR_NUMERIC, "%s: splat %zu: position %d is not finite (%g)", path, i, k, (double)x);
        goto done;
      }
      if (!(s > 0) || !isfinite(s)) {
        st = mgs_error_set(err, MGS_ERR_NUMERIC, "%s: splat %zu: scale %d is %g; expected a positive finite size", path, i, k, (double)s);
        goto done;
      }
      xyz[3 * i + (size_t)k] = x;
      m->log_scale[3 * i + (size_t)k] = logf(s);
      m->sh_dc[3 * i + (size_t)k] = (float)((p[24 + k] / 255.0 - 0.5) / SH_C0);
    }
    /* 8 bits cannot say 0 or 1: the ends stay half a quantum inside, the logit finite */
    const double a = fmin(fmax(p[27] / 255.0, 0.5 / 255.0), 1.0 - 0.5 / 255.0);
    m->opacity[i] = (float)log(a / (1.0 - a));
    double q[4], len = 0;
    for (int k = 0; k < 4; k++) {
      q[k] = (p[28 + k] - 128.0) / 128.0;
      len += q[k] * q[k];
    }
    len = sqrt(len);
    for (int k = 0; k < 4; k++) m->rot[4 * i + (size_t)k] = (float)(len > 0 ? q[k] / len : k == 0);
    memset(m->sh_rest + i * MGS_SH_REST_MAX, 0, sizeof(float) * MGS_SH_REST_MAX);
  }
  *g = m;
  *xyz64 = xyz;
  m = NULL;
  xyz = NULL;
done:
  fclose(f);
  free(buf);
  free(xyz);
  mgs_gaussians_destroy(m);
  return st;
}

/* Which Gaussians reach a point: a few hundred query points (critical voxels' closest
 * points) against the whole model, once per analysis or after the model's count changed.
 * Points are binned in a uniform grid; each Gaussian visits the bins its bounding sphere
 * covers (very large Gaussians, more than 512 bins, are tested against every point), so
 * the cost is about N · (bins per Gaussian) · log P instead of N · P. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "train/morse_internal.h"
#include "core/mgs_math.h"

typedef struct { int64_t key; size_t pt; } bin_pt;
typedef struct { size_t pt, g; } hit;

static int cmp_bin(const void *a, const void *b) {
  const bin_pt *x = a, *y = b;
  if (x->key != y->key) return x->key < y->key ? -1 : 1;
  return x->pt < y->pt ? -1 : (x->pt > y->pt);
}
static int cmp_hit(const void *a, const void *b) {
  const hit *x = a, *y = b;
  if (x->pt != y->pt) return x->pt < y->pt ? -1 : 1;
  return x->g < y->g ? -1 : (x->g > y->g);
}
static int cmp_double(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return x < y ? -1 : (x > y);
}
static int64_t bin_key(int64_t i, int64_t j, int64_t k) {
  return ((i + (1 << 20)) << 42) | ((j + (1 << 20)) << 21) | (k + (1 << 20));
}

/* q = (p-μ)ᵀΣ⁻¹(p-μ) of Gaussian i */
static double mahalanobis(const mgs_gaussians *g, size_t i, const double p[3]) {
  float R[9];
  mgs_quat_to_mat3f(g->rot + 4 * i, R);
  double d[3] = {p[0] - g->mean[3 * i], p[1] - g->mean[3 * i + 1], p[2] - g->mean[3 * i + 2]}, q = 0;
  for (int k = 0; k < 3; k++) {
    double y = R[k] * d[0] + R[3 + k] * d[1] + R[6 + k] * d[2];
    double s = exp(g->log_scale[3 * i + k]);
    q += y * y / (s * s);
  }
  return q;
}

mgs_status morse_gather_build(const mgs_gaussians *g, const double *pts, size_t n, double k_sigma,
                              morse_gather *out, mgs_error *err) {
  memset(out, 0, sizeof *out);
  out->n = n;
  out->start = calloc(n + 1, sizeof(size_t));
  if (!out->start) return mgs_error_set(err, MGS_ERR_NOMEM, "morse: out of memory (gather)");
  if (n == 0 || g->n == 0) return MGS_OK;
  /* bin size: twice the median support radius, at least the points' spread / 256 */
  size_t ns = g->n < 4096 ? g->n : 4096;
  double *rad = malloc(ns * sizeof(double));
  if (!rad) return mgs_error_set(err, MGS_ERR_NOMEM, "morse: out of memory (gather)");
  for (size_t s = 0; s < ns; s++) {
    size_t i = s * g->n / ns;
    const float *l = g->log_scale + 3 * i;
    rad[s] = k_sigma * exp(fmax(l[0], fmax(l[1], l[2])));
  }
  qsort(rad, ns, sizeof(double), cmp_double);
  double cell = 2 * rad[ns / 2];
  free(rad);
  if (!(cell > 0) || !isfinite(cell)) cell = 1e-3;
  bin_pt *bp = malloc(n * sizeof *bp);
  size_t hcap = 1024, nh = 0;
  hit *h = malloc(hcap * sizeof *h);
  if (!bp || !h) { free(bp); free(h); return mgs_error_set(err, MGS_ERR_NOMEM, "morse: out of memory (gather)"); }
  for (size_t p = 0; p < n; p++) {
    bp[p].pt = p;
    bp[p].key = bin_key((int64_t)floor(pts[3 * p] / cell), (int64_t)floor(pts[3 * p + 1] / cell), (int64_t)floor(pts[3 * p + 2] / cell));
  }
  qsort(bp, n, sizeof *bp, cmp_bin);
  const double q_max = k_sigma * k_sigma;
  mgs_status st = MGS_OK;
  for (size_t i = 0; i < g->n && st == MGS_OK; i++) {
    const float *l = g->log_scale + 3 * i, *m = g->mean + 3 * i;
    double r = k_sigma * exp(fmax(l[0], fmax(l[1], l[2])));
    int64_t lo[3], hi[3];
    double cells = 1;
    for (int k = 0; k < 3; k++) {
      lo[k] = (int64_t)floor((m[k] - r) / cell);
      hi[k] = (int64_t)floor((m[k] + r) / cell);
      cells *= (double)(hi[k] - lo[k] + 1);
    }
    if (cells > 512 || cells > (double)n) { /* big Gaussian: every point */
      for (size_t p = 0; p < n && st == MGS_OK; p++) {
        if (mahalanobis(g, i, pts + 3 * p) > q_max) continue;
        if (nh == hcap) { hit *t = realloc(h, 2 * hcap * sizeof *h); if (!t) { st = MGS_ERR_NOMEM; break; } h = t; hcap *= 2; }
        h[nh].pt = p; h[nh++].g = i;
      }
      continue;
    }
    for (int64_t a = lo[0]; a <= hi[0]; a++)
      for (int64_t b = lo[1]; b <= hi[1]; b++)
        for (int64_t c = lo[2]; c <= hi[2]; c++) {
          int64_t key = bin_key(a, b, c);
          size_t L = 0, H = n; /* first bin entry with this key */
          while (L < H) { size_t M = (L + H) / 2; if (bp[M].key < key) L = M + 1; else H = M; }
          for (size_t e = L; e < n && bp[e].key == key; e++) {
            if (mahalanobis(g, i, pts + 3 * bp[e].pt) > q_max) continue;
            if (nh == hcap) { hit *t = realloc(h, 2 * hcap * sizeof *h); if (!t) { st = MGS_ERR_NOMEM; break; } h = t; hcap *= 2; }
            h[nh].pt = bp[e].pt; h[nh++].g = i;
          }
        }
  }
  free(bp);
  if (st == MGS_OK) {
    qsort(h, nh, sizeof *h, cmp_hit);
    out->idx = malloc((nh ? nh : 1) * sizeof(size_t));
    if (!out->idx) st = MGS_ERR_NOMEM;
  }
  if (st != MGS_OK) { free(h); morse_gather_free(out); return mgs_error_set(err, MGS_ERR_NOMEM, "morse: out of memory (gather)"); }
  for (size_t e = 0; e < nh; e++) { out->idx[e] = h[e].g; out->start[h[e].pt + 1]++; }
  for (size_t p = 0; p < n; p++) out->start[p + 1] += out->start[p];
  free(h);
  return MGS_OK;
}

void morse_gather_free(morse_gather *m) {
  free(m->start); free(m->idx);
  memset(m, 0, sizeof *m);
}

mgs_status morse_gather_rows(const mgs_gaussians *g, const size_t *idx, size_t k, mgs_gaussians *dst,
                             mgs_error *err) {
  if (dst->capacity < k) { mgs_status st = mgs_gaussians_reserve(dst, k, err); if (st) return st; }
  dst->n = k;
  for (int gr = 0; gr < MGS_PARAM_COUNT; gr++) {
    if (gr == MGS_PARAM_SH_REST) continue; /* the field does not read colour */
    size_t d = (size_t)mgs_param_dim((mgs_param_group)gr);
    const float *s = mgs_gaussians_group((mgs_gaussians *)g, (mgs_param_group)gr);
    float *o = mgs_gaussians_group(dst, (mgs_param_group)gr);
    for (size_t j = 0; j < k; j++) memcpy(o + j * d, s + idx[j] * d, d * sizeof(float));
  }
  return MGS_OK;
}

size_t morse_nearest_gaussian(const mgs_gaussians *g, const double p[3]) {
  size_t best = (size_t)-1;
  double bd = INFINITY;
  for (size_t i = 0; i < g->n; i++) {
    double dx = g->mean[3 * i] - p[0], dy = g->mean[3 * i + 1] - p[1], dz = g->mean[3 * i + 2] - p[2];
    double d = dx * dx + dy * dy + dz * dz;
    if (d < bd) { bd = d; best = i; }
  }
  return best;
}

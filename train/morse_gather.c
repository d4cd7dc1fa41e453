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
#include "core/mgs_parallel.h"

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

/* Gaussian i's rotation and σ per axis, set up once for all the points it is tested
   against (the same expressions as one test at a time: identical q). */
typedef struct { float R[9]; double s[3]; const float *m; } maha_prep;

static void maha_setup(const mgs_gaussians *g, size_t i, maha_prep *mp) {
  mgs_quat_to_mat3f(g->rot + 4 * i, mp->R);
  for (int k = 0; k < 3; k++) mp->s[k] = exp(g->log_scale[3 * i + k]);
  mp->m = g->mean + 3 * i;
}

/* q = (p-μ)ᵀΣ⁻¹(p-μ) */
static double mahalanobis(const maha_prep *mp, const double p[3]) {
  const float *R = mp->R;
  double d[3] = {p[0] - mp->m[0], p[1] - mp->m[1], p[2] - mp->m[2]}, q = 0;
  for (int k = 0; k < 3; k++) {
    double y = R[k] * d[0] + R[3 + k] * d[1] + R[6 + k] * d[2];
    q += y * y / (mp->s[k] * mp->s[k]);
  }
  return q;
}

/* The Gaussians are cut into GATHER_CHUNKS fixed ranges, each collecting its own hits in
   parallel; all hits are sorted by (point, Gaussian) afterwards, so the lists do not
   depend on the cut or the threads. */
#define GATHER_CHUNKS 64
typedef struct gather_job {
  const mgs_gaussians *g;
  const double *pts;
  size_t n;
  const bin_pt *bp;
  double cell, k_sigma;
  hit *h[GATHER_CHUNKS];
  size_t nh[GATHER_CHUNKS];
  int oom[GATHER_CHUNKS];
} gather_job;

static int push_hit(hit **h, size_t *nh, size_t *cap, size_t pt, size_t gi) {
  if (*nh == *cap) {
    size_t nc = *cap ? 2 * *cap : 256;
    hit *t = realloc(*h, nc * sizeof *t);
    if (!t) return 0;
    *h = t; *cap = nc;
  }
  (*h)[*nh].pt = pt; (*h)[(*nh)++].g = gi;
  return 1;
}

static void gather_chunk(void *vp, size_t cb, size_t ce) {
  gather_job *j = vp;
  const mgs_gaussians *g = j->g;
  const size_t n = j->n;
  const double cell = j->cell, k_sigma = j->k_sigma, q_max = k_sigma * k_sigma;
  for (size_t c = cb; c < ce; c++) {
    hit *h = NULL;
    size_t nh = 0, cap = 0;
    int ok = 1;
    for (size_t i = c * g->n / GATHER_CHUNKS; i < (c + 1) * g->n / GATHER_CHUNKS && ok; i++) {
      const float *l = g->log_scale + 3 * i, *m = g->mean + 3 * i;
      double r = k_sigma * exp(fmax(l[0], fmax(l[1], l[2])));
      int64_t lo[3], hi[3];
      double cells = 1;
      for (int k = 0; k < 3; k++) {
        lo[k] = (int64_t)floor((m[k] - r) / cell);
        hi[k] = (int64_t)floor((m[k] + r) / cell);
        cells *= (double)(hi[k] - lo[k] + 1);
      }
      maha_prep mp;
      int prepared = 0;
      if (cells > 512 || cells > (double)n) { /* big Gaussian: every point */
        maha_setup(g, i, &mp);
        for (size_t p = 0; p < n && ok; p++)
          if (mahalanobis(&mp, j->pts + 3 * p) <= q_max) ok = push_hit(&h, &nh, &cap, p, i);
        continue;
      }
      for (int64_t a = lo[0]; a <= hi[0] && ok; a++)
        for (int64_t b = lo[1]; b <= hi[1] && ok; b++)
          for (int64_t cc = lo[2]; cc <= hi[2] && ok; cc++) {
            int64_t key = bin_key(a, b, cc);
            size_t L = 0, H = n; /* first bin entry with this key */
            while (L < H) { size_t M = (L + H) / 2; if (j->bp[M].key < key) L = M + 1; else H = M; }
            for (size_t e = L; e < n && j->bp[e].key == key && ok; e++) {
              if (!prepared) { maha_setup(g, i, &mp); prepared = 1; }
              if (mahalanobis(&mp, j->pts + 3 * j->bp[e].pt) <= q_max) ok = push_hit(&h, &nh, &cap, j->bp[e].pt, i);
            }
          }
    }
    j->h[c] = h; j->nh[c] = nh; j->oom[c] = !ok;
  }
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
  gather_job *job = calloc(1, sizeof *job);
  if (!bp || !job) { free(bp); free(job); return mgs_error_set(err, MGS_ERR_NOMEM, "morse: out of memory (gather)"); }
  for (size_t p = 0; p < n; p++) {
    bp[p].pt = p;
    bp[p].key = bin_key((int64_t)floor(pts[3 * p] / cell), (int64_t)floor(pts[3 * p + 1] / cell), (int64_t)floor(pts[3 * p + 2] / cell));
  }
  qsort(bp, n, sizeof *bp, cmp_bin);
  job->g = g; job->pts = pts; job->n = n; job->bp = bp; job->cell = cell; job->k_sigma = k_sigma;
  mgs_parallel_for(0, GATHER_CHUNKS, 1, gather_chunk, job);
  free(bp);
  size_t nh = 0;
  int oom = 0;
  for (int c = 0; c < GATHER_CHUNKS; c++) { nh += job->nh[c]; oom |= job->oom[c]; }
  hit *h = oom ? NULL : malloc((nh ? nh : 1) * sizeof *h);
  if (h)
    for (size_t c = 0, w = 0; c < GATHER_CHUNKS; c++) {
      if (job->nh[c]) memcpy(h + w, job->h[c], job->nh[c] * sizeof *h);
      w += job->nh[c];
    }
  for (int c = 0; c < GATHER_CHUNKS; c++) free(job->h[c]);
  free(job);
  mgs_status st = h ? MGS_OK : MGS_ERR_NOMEM;
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

/* The normal-consistency loss term (train/mgs_term_normal.h). */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include "core/mgs_fs.h"
#include "core/mgs_log.h"
#include "core/mgs_parallel.h"
#include "train/gauss_local.h"
#include "train/mgs_term_normal.h"

void mgs_normal_options_default(mgs_normal_options *o) {
  o->gamma = 0.02;
  o->from_iter = 3000;
  o->until_iter = 0;
  o->every = 500;
  o->resolution = 128;
  o->tau = 0.5;
  o->half_width = 3;
  o->sharpness = 1.0;
}

mgs_status mgs_normal_options_check(const mgs_normal_options *o, mgs_error *err) {
  if (!(o->gamma > 0) || !(o->gamma <= 1e3))
    return mgs_error_set(err, MGS_ERR_ARG, "--normal-loss: weight %g outside (0, 1000]", o->gamma);
  if (o->from_iter < 1) return mgs_error_set(err, MGS_ERR_ARG, "normal loss: from-iteration %d must be >= 1", o->from_iter);
  if (o->every < 0) return mgs_error_set(err, MGS_ERR_ARG, "normal loss: rebuild interval %d must be >= 0", o->every);
  if (o->resolution < 8 || o->resolution > 4096)
    return mgs_error_set(err, MGS_ERR_ARG, "normal loss: resolution %d outside [8, 4096]", o->resolution);
  if (!(o->tau > 0) || !(o->tau < 1e3)) return mgs_error_set(err, MGS_ERR_ARG, "normal loss: tau %g outside (0, 1000)", o->tau);
  if (o->half_width < 1 || o->half_width > 64)
    return mgs_error_set(err, MGS_ERR_ARG, "normal loss: half-width %d outside [1, 64]", o->half_width);
  if (!(o->sharpness > 0) || o->sharpness > 64)
    return mgs_error_set(err, MGS_ERR_ARG, "normal loss: sharpness %g outside (0, 64]", o->sharpness);
  return MGS_OK;
}

/* ---------------------------------------------------------------- the loss */
/* Rows are cut into fixed chunks (not per thread), each summed in order, and the chunks'
   sums added in order: the value does not depend on the threads; each row's gradient is
   its own. */
#define NORMAL_CHUNK 2048
typedef struct normal_job {
  const mgs_gaussians *g;
  const float *T;
  double p, scale;
  mgs_gaussians *grad;
  double *sum;   /* per chunk */
  size_t *cnt;   /* per chunk */
} normal_job;

static void normal_rows(void *vp, size_t cb, size_t ce) {
  const normal_job *j = vp;
  const mgs_gaussians *g = j->g;
  mgs_gaussians *grad = j->grad;
  const double p = j->p, scale = j->scale;
  for (size_t c = cb; c < ce; c++) {
    double sum = 0;
    size_t cnt = 0, end = (c + 1) * NORMAL_CHUNK < g->n ? (c + 1) * NORMAL_CHUNK : g->n;
    for (size_t i = c * NORMAL_CHUNK; i < end; i++) {
      const float *t6 = j->T + 6 * i;
      const double tr = (double)t6[0] + t6[3] + t6[5];
      if (!(tr >= 0.05) || !isfinite(tr)) continue; /* outside the band: no direction */
      const double M[9] = {t6[0] / tr, t6[1] / tr, t6[2] / tr, t6[1] / tr, t6[3] / tr, t6[4] / tr, t6[2] / tr, t6[4] / tr, t6[5] / tr};
      mgs_gauss_local L;
      mgs_gauss_local_rotation(g, i, &L);
      /* weights w_k = softmax(−2p log s_k) (shifted by the max for exp's range) */
      double z[3], zmax = -INFINITY, w[3], ws = 0, cc[3], Mr[3][3], h = 0;
      for (int k = 0; k < 3; k++) { z[k] = -2.0 * p * (double)g->log_scale[3 * i + k]; zmax = fmax(zmax, z[k]); }
      for (int k = 0; k < 3; k++) { w[k] = exp(z[k] - zmax); ws += w[k]; }
      for (int k = 0; k < 3; k++) {
        w[k] /= ws;
        for (int a = 0; a < 3; a++) Mr[k][a] = M[3 * a] * L.R[k] + M[3 * a + 1] * L.R[3 + k] + M[3 * a + 2] * L.R[6 + k];
        cc[k] = L.R[k] * Mr[k][0] + L.R[3 + k] * Mr[k][1] + L.R[6 + k] * Mr[k][2]; /* r_kᵀ M r_k */
        h += w[k] * cc[k];
      }
      sum += 1.0 - h;
      cnt++;
      if (!grad) continue;
      /* ∂(1−h)/∂log s_j = 2p w_j (c_j − h); ∂(1−h)/∂R[a][k] = −2 w_k (M r_k)_a */
      for (int k = 0; k < 3; k++) grad->log_scale[3 * i + k] += (float)(scale * 2.0 * p * w[k] * (cc[k] - h));
      double dR[9], dq[4];
      for (int a = 0; a < 3; a++)
        for (int k = 0; k < 3; k++) dR[3 * a + k] = -2.0 * w[k] * Mr[k][a];
      mgs_gauss_local_dq(&L, dR, dq);
      for (int k = 0; k < 4; k++) grad->rot[4 * i + k] += (float)(scale * dq[k]);
    }
    j->sum[c] = sum;
    j->cnt[c] = cnt;
  }
}

mgs_status mgs_normal_loss(const mgs_gaussians *g, const float *T, double p, double weight, mgs_gaussians *grad,
                           double *value, size_t *used, mgs_error *err) {
  if (grad && grad->n != g->n)
    return mgs_error_set(err, MGS_ERR_ARG, "normal loss: gradient model has %zu rows, model %zu", grad->n, g->n);
  const size_t chunks = (g->n + NORMAL_CHUNK - 1) / NORMAL_CHUNK;
  double *sums = malloc((chunks + 1) * sizeof(double));
  size_t *cnts = malloc((chunks + 1) * sizeof(size_t));
  if (!sums || !cnts) { free(sums); free(cnts); return mgs_error_set(err, MGS_ERR_NOMEM, "normal loss: out of memory"); }
  normal_job job = {g, T, p, g->n ? weight / (double)g->n : 0, grad, sums, cnts};
  mgs_parallel_for(0, chunks, 1, normal_rows, &job);
  double sum = 0;
  size_t cnt = 0;
  for (size_t c = 0; c < chunks; c++) { sum += sums[c]; cnt += cnts[c]; }
  free(sums);
  free(cnts);
  if (value) *value = job.scale * sum;
  if (used) *used = cnt;
  return MGS_OK;
}

/* T at points xyz[m*3]: the central-difference gradients at the 8 voxel centres around
   each point (the stencil mgs_vdb_sample_gradient interpolates), blended with the
   trilinear weights; one batch read of the 4x4x4 voxel block per point. ijk/vals: scratch
   of m*64 entries. */
static void tensors_at(const mgs_vdb_grid *sdf, size_t m, const float *xyz, float *T, int32_t *ijk, float *vals) {
  double tr[3];
  mgs_vdb_grid_translation(sdf, tr);
  const double h = mgs_vdb_grid_voxel_size(sdf);
  for (size_t i = 0; i < m; i++) {
    int32_t b[3];
    for (int a = 0; a < 3; a++) b[a] = (int32_t)floor(((double)xyz[3 * i + a] - tr[a]) / h) - 1;
    for (int x = 0; x < 4; x++)
      for (int y = 0; y < 4; y++)
        for (int z = 0; z < 4; z++) {
          int32_t *o = ijk + 3 * (64 * i + 16 * x + 4 * y + z);
          o[0] = b[0] + x; o[1] = b[1] + y; o[2] = b[2] + z;
        }
  }
  mgs_vdb_values(sdf, m * 64, ijk, vals, NULL);
  for (size_t i = 0; i < m; i++) {
    const float *v = vals + 64 * i;
    double f[3];
    for (int a = 0; a < 3; a++) {
      double u = ((double)xyz[3 * i + a] - tr[a]) / h;
      f[a] = u - floor(u);
    }
    double t6[6] = {0};
    for (int c = 0; c < 8; c++) {
      const int cx = 1 + ((c >> 2) & 1), cy = 1 + ((c >> 1) & 1), cz = 1 + (c & 1);
      const double w = (cx == 2 ? f[0] : 1 - f[0]) * (cy == 2 ? f[1] : 1 - f[1]) * (cz == 2 ? f[2] : 1 - f[2]);
#define V(x, y, z) ((double)v[16 * (x) + 4 * (y) + (z)])
      const double gx = (V(cx + 1, cy, cz) - V(cx - 1, cy, cz)) / (2 * h);
      const double gy = (V(cx, cy + 1, cz) - V(cx, cy - 1, cz)) / (2 * h);
      const double gz = (V(cx, cy, cz + 1) - V(cx, cy, cz - 1)) / (2 * h);
#undef V
      t6[0] += w * gx * gx; t6[1] += w * gx * gy; t6[2] += w * gx * gz;
      t6[3] += w * gy * gy; t6[4] += w * gy * gz; t6[5] += w * gz * gz;
    }
    for (int k = 0; k < 6; k++) T[6 * i + k] = (float)t6[k];
  }
}

void mgs_normal_tensors(const mgs_vdb_grid *sdf, const mgs_gaussians *g, float *T) {
  int32_t *ijk = malloc(g->n * 64 * 3 * sizeof(int32_t) + 1);
  float *vals = malloc(g->n * 64 * sizeof(float) + 1);
  if (ijk && vals) tensors_at(sdf, g->n, g->mean, T, ijk, vals);
  else memset(T, 0, g->n * 6 * sizeof(float));
  free(ijk);
  free(vals);
}

/* ---------------------------------------------------------------- the term */
struct mgs_normal_term {
  mgs_normal_options o;
  mgs_vdb_grid *sdf;
  int sdf_iter;   /* iteration the grid was made at (-1: none) */
  int builds;     /* grids this term built itself */
  /* Tensors per Gaussian, cached: a row is recomputed when the grid changes or when the
     Gaussian's mean is more than a quarter voxel from where its tensor was taken (this
     also catches rows that densification or pruning shifted). */
  float *T, *Tmean;   /* n*6 tensors, n*3 means they were taken at */
  size_t cached_n;    /* rows valid in T (0 after a new grid) */
  size_t cap;
  size_t *rows;       /* scratch: rows to refresh */
  float *xyz, *Tnew;  /* scratch: their means and new tensors */
  int32_t *ijk;       /* scratch: 64 voxels per refreshed row */
  float *vals;
  size_t refreshed;   /* rows recomputed so far (for the notes' cost figures) */
  mgs_normal_sdf_source source; /* an analysis' grid (NULL: build our own) */
  void *source_user;
};

static unsigned normal_active(void *self, int it) {
  mgs_normal_term *t = self;
  if (it < t->o.from_iter || (t->o.until_iter > 0 && it > t->o.until_iter)) return 0;
  return MGS_TERM_MODEL;
}

/* The standalone analysis: α-field and SDF of the current model. */
static mgs_status build_sdf(mgs_normal_term *t, const mgs_gaussians *g, int it, mgs_error *err) {
  mgs_vdb_alpha_params ap;
  mgs_vdb_alpha_params_default(&ap);
  ap.resolution = t->o.resolution;
  ap.half_width = t->o.half_width;
  mgs_vdb_sdf_params sp;
  mgs_vdb_sdf_params_default(&sp);
  sp.tau = t->o.tau;
  sp.half_width = t->o.half_width;
  mgs_vdb_grid *alpha = NULL, *sdf = NULL;
  mgs_error e2;
  mgs_error_clear(&e2);
  mgs_status st = mgs_vdb_alpha_field(g, &ap, &alpha, NULL, &e2);
  if (st == MGS_OK) st = mgs_vdb_sdf_from_alpha(alpha, &sp, &sdf, &e2);
  mgs_vdb_grid_destroy(alpha);
  t->sdf_iter = it; /* tried here: the next try waits `every` iterations */
  if (st == MGS_ERR_NOMEM || st == MGS_ERR_ARG) return mgs_error_set(err, st, "normal loss: %s", e2.msg);
  if (st) {
    /* a model without a surface yet (nothing reaches τ): no term until the next try */
    mgs_warn("normal loss: no SDF at iteration %d (%s); the term waits %d iterations", it, e2.msg, t->o.every);
    mgs_vdb_grid_destroy(t->sdf);
    t->sdf = NULL;
    return MGS_OK;
  }
  mgs_vdb_grid_destroy(t->sdf);
  t->sdf = sdf;
  t->cached_n = 0;
  t->builds++;
  return MGS_OK;
}

static mgs_status normal_model_grad(void *self, mgs_term_step *s, mgs_error *err) {
  mgs_normal_term *t = self;
  const mgs_gaussians *g = s->model;
  s->value = 0;
  if (t->source) {
    int at = -1;
    const mgs_vdb_grid *sdf = t->source(t->source_user, &at);
    if (sdf && at != t->sdf_iter) {
      mgs_status st = mgs_term_normal_set_sdf(t, sdf, at, err);
      if (st) return st;
    }
  } else if (t->o.every > 0 && (t->sdf_iter < 0 || s->iteration - t->sdf_iter >= t->o.every)) {
    mgs_status st = build_sdf(t, g, s->iteration, err);
    if (st) return st;
  }
  if (!t->sdf || g->n == 0) return MGS_OK;
  if (g->n > t->cap) {
    size_t cap = g->n + g->n / 2;
    float *T = realloc(t->T, cap * 6 * sizeof(float));
    if (T) t->T = T;
    float *Tm = T ? realloc(t->Tmean, cap * 3 * sizeof(float)) : NULL;
    if (Tm) t->Tmean = Tm;
    size_t *rows = Tm ? realloc(t->rows, cap * sizeof(size_t)) : NULL;
    if (rows) t->rows = rows;
    float *xyz = rows ? realloc(t->xyz, cap * 3 * sizeof(float)) : NULL;
    if (xyz) t->xyz = xyz;
    float *Tn = xyz ? realloc(t->Tnew, cap * 6 * sizeof(float)) : NULL;
    if (Tn) t->Tnew = Tn;
    int32_t *ijk = Tn ? realloc(t->ijk, cap * 64 * 3 * sizeof(int32_t)) : NULL;
    if (ijk) t->ijk = ijk;
    float *vals = ijk ? realloc(t->vals, cap * 64 * sizeof(float)) : NULL;
    if (vals) t->vals = vals;
    if (!vals) return mgs_error_set(err, MGS_ERR_NOMEM, "normal loss: out of memory for %zu Gaussians", g->n);
    t->cap = cap;
  }
  const double h = mgs_vdb_grid_voxel_size(t->sdf), tol2 = 0.0625 * h * h;
  size_t m = 0;
  for (size_t i = 0; i < g->n; i++) {
    int stale = i >= t->cached_n;
    if (!stale) {
      double d2 = 0;
      for (int a = 0; a < 3; a++) { double d = (double)g->mean[3 * i + a] - t->Tmean[3 * i + a]; d2 += d * d; }
      stale = !(d2 <= tol2);
    }
    if (stale) {
      t->rows[m] = i;
      memcpy(t->xyz + 3 * m, g->mean + 3 * i, 3 * sizeof(float));
      m++;
    }
  }
  if (m) {
    tensors_at(t->sdf, m, t->xyz, t->Tnew, t->ijk, t->vals);
    for (size_t k = 0; k < m; k++) {
      memcpy(t->T + 6 * t->rows[k], t->Tnew + 6 * k, 6 * sizeof(float));
      memcpy(t->Tmean + 3 * t->rows[k], t->xyz + 3 * k, 3 * sizeof(float));
    }
    t->refreshed += m;
  }
  t->cached_n = g->n;
  return mgs_normal_loss(g, t->T, t->o.sharpness, t->o.gamma, s->grad, &s->value, NULL, err);
}

/* State: the grid's iteration, builds, the grid itself as bytes and the tensor cache. */
static mgs_status normal_save(void *self, FILE *f, mgs_error *err) {
  mgs_normal_term *t = self;
  int32_t hdr[3] = {t->sdf_iter, t->builds, t->sdf != NULL};
  if (fwrite(hdr, sizeof hdr, 1, f) != 1) return mgs_error_set(err, MGS_ERR_IO, "normal loss: checkpoint write failed");
  if (!t->sdf) return MGS_OK;
  char *data = NULL;
  size_t size = 0;
  mgs_status st = mgs_vdb_grid_to_bytes(t->sdf, &data, &size, err);
  if (st) return st;
  uint64_t n = size, cn = t->cached_n;
  if (fwrite(&n, sizeof n, 1, f) != 1 || fwrite(data, 1, size, f) != size) st = mgs_error_set(err, MGS_ERR_IO, "normal loss: checkpoint write failed");
  free(data);
  /* the tensor cache, so a resumed run samples exactly what an uninterrupted one would */
  if (st == MGS_OK && (fwrite(&cn, sizeof cn, 1, f) != 1 || fwrite(t->T, sizeof(float), 6 * cn, f) != 6 * cn ||
                       fwrite(t->Tmean, sizeof(float), 3 * cn, f) != 3 * cn))
    st = mgs_error_set(err, MGS_ERR_IO, "normal loss: checkpoint write failed");
  return st;
}

static mgs_status normal_load(void *self, FILE *f, mgs_error *err) {
  mgs_normal_term *t = self;
  int32_t hdr[3];
  if (fread(hdr, sizeof hdr, 1, f) != 1) return mgs_error_set(err, MGS_ERR_FORMAT, "normal loss: truncated checkpoint state");
  t->sdf_iter = hdr[0];
  t->builds = hdr[1];
  mgs_vdb_grid_destroy(t->sdf);
  t->sdf = NULL;
  t->cached_n = 0;
  if (!hdr[2]) return MGS_OK;
  uint64_t n;
  if (fread(&n, sizeof n, 1, f) != 1 || n > ((uint64_t)1 << 40))
    return mgs_error_set(err, MGS_ERR_FORMAT, "normal loss: truncated checkpoint state");
  char *data = malloc(n ? n : 1);
  if (!data) return mgs_error_set(err, MGS_ERR_NOMEM, "normal loss: out of memory reading the checkpoint");
  if (fread(data, 1, n, f) != n) { free(data); return mgs_error_set(err, MGS_ERR_FORMAT, "normal loss: truncated checkpoint state"); }
  mgs_status st = mgs_vdb_grid_from_bytes(data, n, NULL, &t->sdf, err);
  free(data);
  if (st) return st;
  uint64_t cn;
  if (fread(&cn, sizeof cn, 1, f) != 1 || cn > ((uint64_t)1 << 34))
    return mgs_error_set(err, MGS_ERR_FORMAT, "normal loss: truncated checkpoint state");
  if (cn > t->cap) {
    float *T = realloc(t->T, cn * 6 * sizeof(float));
    if (T) t->T = T;
    float *Tm = T ? realloc(t->Tmean, cn * 3 * sizeof(float)) : NULL;
    if (Tm) t->Tmean = Tm;
    if (!Tm) return mgs_error_set(err, MGS_ERR_NOMEM, "normal loss: out of memory reading the checkpoint");
    /* the other scratch arrays grow at the next step (cap stays, so they are reallocated) */
  }
  if (fread(t->T, sizeof(float), 6 * cn, f) != 6 * cn || fread(t->Tmean, sizeof(float), 3 * cn, f) != 3 * cn)
    return mgs_error_set(err, MGS_ERR_FORMAT, "normal loss: truncated checkpoint state");
  t->cached_n = cn;
  return MGS_OK;
}

static void normal_destroy(void *self) {
  mgs_normal_term *t = self;
  if (!t) return;
  mgs_vdb_grid_destroy(t->sdf);
  free(t->T);
  free(t->Tmean);
  free(t->rows);
  free(t->xyz);
  free(t->Tnew);
  free(t->ijk);
  free(t->vals);
  free(t);
}

static const mgs_term_ops normal_ops = {"normal", normal_active, NULL, normal_model_grad, normal_save, normal_load,
                                        normal_destroy, NULL};

mgs_status mgs_term_normal_create(const mgs_normal_options *o, mgs_term **out, mgs_normal_term **handle, mgs_error *err) {
  *out = NULL;
  if (handle) *handle = NULL;
  mgs_normal_options opt;
  if (o) opt = *o; else mgs_normal_options_default(&opt);
  mgs_status st = mgs_normal_options_check(&opt, err);
  if (st) return st;
  mgs_normal_term *t = calloc(1, sizeof *t);
  if (!t) return mgs_error_set(err, MGS_ERR_NOMEM, "normal loss: out of memory");
  t->o = opt;
  t->sdf_iter = -1;
  *out = mgs_term_create(&normal_ops, t);
  if (!*out) return mgs_error_set(err, MGS_ERR_NOMEM, "normal loss: out of memory");
  if (handle) *handle = t;
  return MGS_OK;
}

mgs_status mgs_term_normal_set_sdf(mgs_normal_term *t, const mgs_vdb_grid *sdf, int iteration, mgs_error *err) {
  if (!sdf || mgs_vdb_grid_class(sdf) != MGS_VDB_CLASS_LEVEL_SET)
    return mgs_error_set(err, MGS_ERR_ARG, "normal loss: the grid handed in is not a level set");
  mgs_vdb_grid *c = mgs_vdb_grid_copy(sdf);
  if (!c) return mgs_error_set(err, MGS_ERR_NOMEM, "normal loss: out of memory copying the SDF");
  mgs_vdb_grid_destroy(t->sdf);
  t->sdf = c;
  t->cached_n = 0;
  t->sdf_iter = iteration;
  return MGS_OK;
}

void mgs_term_normal_set_source(mgs_normal_term *t, mgs_normal_sdf_source fn, void *user) {
  t->source = fn;
  t->source_user = user;
}

const mgs_vdb_grid *mgs_term_normal_sdf(const mgs_normal_term *t, int *iteration, int *builds) {
  if (iteration) *iteration = t->sdf_iter;
  if (builds) *builds = t->builds;
  return t->sdf;
}

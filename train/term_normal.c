/* The normal-consistency loss term (train/mgs_term_normal.h). */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include "core/mgs_fs.h"
#include "core/mgs_log.h"
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
mgs_status mgs_normal_loss(const mgs_gaussians *g, const float *T, double p, double weight, mgs_gaussians *grad,
                           double *value, size_t *used, mgs_error *err) {
  if (grad && grad->n != g->n)
    return mgs_error_set(err, MGS_ERR_ARG, "normal loss: gradient model has %zu rows, model %zu", grad->n, g->n);
  double sum = 0;
  size_t cnt = 0;
  const double scale = g->n ? weight / (double)g->n : 0;
  for (size_t i = 0; i < g->n; i++) {
    const float *t6 = T + 6 * i;
    const double tr = (double)t6[0] + t6[3] + t6[5];
    if (!(tr >= 0.05) || !isfinite(tr)) continue; /* outside the band: no direction */
    const double M[9] = {t6[0] / tr, t6[1] / tr, t6[2] / tr, t6[1] / tr, t6[3] / tr, t6[4] / tr, t6[2] / tr, t6[4] / tr, t6[5] / tr};
    mgs_gauss_local L;
    mgs_gauss_local_get(g, i, &L);
    /* weights w_k = softmax(−2p log s_k) (shifted by the max for exp's range) */
    double z[3], zmax = -INFINITY, w[3], ws = 0, c[3], Mr[3][3], h = 0;
    for (int k = 0; k < 3; k++) { z[k] = -2.0 * p * (double)g->log_scale[3 * i + k]; zmax = fmax(zmax, z[k]); }
    for (int k = 0; k < 3; k++) { w[k] = exp(z[k] - zmax); ws += w[k]; }
    for (int k = 0; k < 3; k++) {
      w[k] /= ws;
      for (int a = 0; a < 3; a++) Mr[k][a] = M[3 * a] * L.R[k] + M[3 * a + 1] * L.R[3 + k] + M[3 * a + 2] * L.R[6 + k];
      c[k] = L.R[k] * Mr[k][0] + L.R[3 + k] * Mr[k][1] + L.R[6 + k] * Mr[k][2]; /* r_kᵀ M r_k */
      h += w[k] * c[k];
    }
    sum += 1.0 - h;
    cnt++;
    if (!grad) continue;
    /* ∂(1−h)/∂log s_j = 2p w_j (c_j − h); ∂(1−h)/∂R[a][k] = −2 w_k (M r_k)_a */
    for (int k = 0; k < 3; k++) grad->log_scale[3 * i + k] += (float)(scale * 2.0 * p * w[k] * (c[k] - h));
    double dR[9], dq[4];
    for (int a = 0; a < 3; a++)
      for (int k = 0; k < 3; k++) dR[3 * a + k] = -2.0 * w[k] * Mr[k][a];
    mgs_gauss_local_dq(&L, dR, dq);
    for (int k = 0; k < 4; k++) grad->rot[4 * i + k] += (float)(scale * dq[k]);
  }
  if (value) *value = scale * sum;
  if (used) *used = cnt;
  return MGS_OK;
}

/* T at the means: the gradients at the 8 voxel centres around each mean (there the
   grid's trilinear gradient is that voxel's own central difference), blended with the
   trilinear weights. pts/gr: scratch of n*8*3 floats. */
static void tensors(const mgs_vdb_grid *sdf, const mgs_gaussians *g, float *T, float *pts, float *gr) {
  double tr[3];
  mgs_vdb_grid_translation(sdf, tr);
  const double h = mgs_vdb_grid_voxel_size(sdf);
  double (*wts)[8] = malloc(sizeof(double[8]) * (g->n ? g->n : 1));
  if (!wts) { memset(T, 0, g->n * 6 * sizeof(float)); return; }
  for (size_t i = 0; i < g->n; i++) {
    double f[3], b[3];
    for (int a = 0; a < 3; a++) {
      double u = ((double)g->mean[3 * i + a] - tr[a]) / h;
      b[a] = floor(u);
      f[a] = u - b[a];
    }
    for (int c = 0; c < 8; c++) {
      double w = 1;
      for (int a = 0; a < 3; a++) {
        int bit = (c >> (2 - a)) & 1;
        pts[24 * i + 3 * c + a] = (float)((b[a] + bit) * h + tr[a]);
        w *= bit ? f[a] : 1 - f[a];
      }
      wts[i][c] = w;
    }
  }
  mgs_vdb_sample_gradient(sdf, g->n * 8, pts, gr, NULL);
  for (size_t i = 0; i < g->n; i++) {
    double t6[6] = {0};
    for (int c = 0; c < 8; c++) {
      const float *v = gr + 24 * i + 3 * c;
      const double w = wts[i][c];
      t6[0] += w * v[0] * v[0]; t6[1] += w * v[0] * v[1]; t6[2] += w * v[0] * v[2];
      t6[3] += w * v[1] * v[1]; t6[4] += w * v[1] * v[2]; t6[5] += w * v[2] * v[2];
    }
    for (int k = 0; k < 6; k++) T[6 * i + k] = (float)t6[k];
  }
  free(wts);
}

void mgs_normal_tensors(const mgs_vdb_grid *sdf, const mgs_gaussians *g, float *T) {
  float *pts = malloc(g->n * 24 * sizeof(float) + 1), *gr = malloc(g->n * 24 * sizeof(float) + 1);
  if (pts && gr) tensors(sdf, g, T, pts, gr);
  else memset(T, 0, g->n * 6 * sizeof(float));
  free(pts);
  free(gr);
}

/* ---------------------------------------------------------------- the term */
struct mgs_normal_term {
  mgs_normal_options o;
  mgs_vdb_grid *sdf;
  int sdf_iter;   /* iteration the grid was made at (-1: none) */
  int builds;     /* grids this term built itself */
  float *T;       /* scratch: the tensors at the means (n*6) */
  float *pts, *gr; /* scratch: the 8 voxel centres per mean and their gradients (n*24) */
  size_t cap;
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
  t->builds++;
  return MGS_OK;
}

static mgs_status normal_model_grad(void *self, mgs_term_step *s, mgs_error *err) {
  mgs_normal_term *t = self;
  const mgs_gaussians *g = s->model;
  s->value = 0;
  if (t->o.every > 0 && (t->sdf_iter < 0 || s->iteration - t->sdf_iter >= t->o.every)) {
    mgs_status st = build_sdf(t, g, s->iteration, err);
    if (st) return st;
  }
  if (!t->sdf || g->n == 0) return MGS_OK;
  if (g->n > t->cap) {
    size_t cap = g->n + g->n / 2;
    float *a = realloc(t->T, cap * 6 * sizeof(float));
    if (a) t->T = a;
    float *b = a ? realloc(t->pts, cap * 24 * sizeof(float)) : NULL;
    if (b) t->pts = b;
    float *c = b ? realloc(t->gr, cap * 24 * sizeof(float)) : NULL;
    if (c) t->gr = c;
    if (!a || !b || !c) return mgs_error_set(err, MGS_ERR_NOMEM, "normal loss: out of memory for %zu Gaussians", g->n);
    t->cap = cap;
  }
  tensors(t->sdf, g, t->T, t->pts, t->gr);
  return mgs_normal_loss(g, t->T, t->o.sharpness, t->o.gamma, s->grad, &s->value, NULL, err);
}

/* A unique temporary name (mkstemp's file; the caller removes it and `name`.vdb). */
static int temp_name(char *buf, size_t cap) {
  const char *dir = getenv("TMPDIR");
  snprintf(buf, cap, "%s/mgs_normal_XXXXXX", dir && *dir ? dir : "/tmp");
  int fd = mkstemp(buf);
  if (fd < 0) return -1;
  close(fd);
  return 0;
}

/* State: the grid's iteration, builds, and the grid itself as .vdb bytes (vdb/ writes
 * files only: through a temporary file). */
static mgs_status normal_save(void *self, FILE *f, mgs_error *err) {
  mgs_normal_term *t = self;
  int32_t hdr[3] = {t->sdf_iter, t->builds, t->sdf != NULL};
  if (fwrite(hdr, sizeof hdr, 1, f) != 1) return mgs_error_set(err, MGS_ERR_IO, "normal loss: checkpoint write failed");
  if (!t->sdf) return MGS_OK;
  char tmp[512], path[520];
  if (temp_name(tmp, sizeof tmp)) return mgs_error_set(err, MGS_ERR_IO, "normal loss: cannot create a temporary file for the checkpoint");
  snprintf(path, sizeof path, "%s.vdb", tmp);
  const mgs_vdb_grid *grids[1] = {t->sdf};
  char *data = NULL;
  size_t size = 0;
  mgs_status st = mgs_vdb_write(path, grids, 1, NULL, 0, NULL, err);
  if (st == MGS_OK) st = mgs_read_file(path, &data, &size, err);
  remove(path);
  remove(tmp);
  if (st) return st;
  uint64_t n = size;
  if (fwrite(&n, sizeof n, 1, f) != 1 || fwrite(data, 1, size, f) != size) st = mgs_error_set(err, MGS_ERR_IO, "normal loss: checkpoint write failed");
  free(data);
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
  if (!hdr[2]) return MGS_OK;
  uint64_t n;
  if (fread(&n, sizeof n, 1, f) != 1 || n > ((uint64_t)1 << 40))
    return mgs_error_set(err, MGS_ERR_FORMAT, "normal loss: truncated checkpoint state");
  char *data = malloc(n ? n : 1);
  if (!data) return mgs_error_set(err, MGS_ERR_NOMEM, "normal loss: out of memory reading the checkpoint");
  if (fread(data, 1, n, f) != n) { free(data); return mgs_error_set(err, MGS_ERR_FORMAT, "normal loss: truncated checkpoint state"); }
  char tmp[512], path[520];
  if (temp_name(tmp, sizeof tmp)) { free(data); return mgs_error_set(err, MGS_ERR_IO, "normal loss: cannot create a temporary file"); }
  snprintf(path, sizeof path, "%s.vdb", tmp);
  mgs_status st = mgs_write_file_atomic(path, data, n, err);
  free(data);
  if (st == MGS_OK) st = mgs_vdb_read_grid(path, NULL, &t->sdf, err);
  remove(path);
  remove(tmp);
  return st;
}

static void normal_destroy(void *self) {
  mgs_normal_term *t = self;
  if (!t) return;
  mgs_vdb_grid_destroy(t->sdf);
  free(t->T);
  free(t->pts);
  free(t->gr);
  free(t);
}

static const mgs_term_ops normal_ops = {"normal", normal_active, NULL, normal_model_grad, normal_save, normal_load,
                                        normal_destroy};

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
  t->sdf_iter = iteration;
  return MGS_OK;
}

const mgs_vdb_grid *mgs_term_normal_sdf(const mgs_normal_term *t, int *iteration, int *builds) {
  if (iteration) *iteration = t->sdf_iter;
  if (builds) *builds = t->builds;
  return t->sdf;
}

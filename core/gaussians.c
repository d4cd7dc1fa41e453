/* The Gaussian model: allocation, growth, compaction, selection, checks. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "core/mgs_gaussians.h"
#include "core/mgs_math.h"

static const int k_dims[MGS_PARAM_COUNT] = {3, 3, 4, 1, 3, MGS_SH_REST_MAX};
static const char *k_names[MGS_PARAM_COUNT] = {"mean", "log_scale", "rot", "opacity", "sh_dc", "sh_rest"};

int mgs_param_dim(mgs_param_group g) { return (g >= 0 && g < MGS_PARAM_COUNT) ? k_dims[g] : 0; }
const char *mgs_param_name(mgs_param_group g) { return (g >= 0 && g < MGS_PARAM_COUNT) ? k_names[g] : "?"; }

static float **group_slot(mgs_gaussians *g, mgs_param_group group) {
  switch (group) {
    case MGS_PARAM_MEAN: return &g->mean;
    case MGS_PARAM_LOG_SCALE: return &g->log_scale;
    case MGS_PARAM_ROT: return &g->rot;
    case MGS_PARAM_OPACITY: return &g->opacity;
    case MGS_PARAM_SH_DC: return &g->sh_dc;
    case MGS_PARAM_SH_REST: return &g->sh_rest;
    default: return NULL;
  }
}

float *mgs_gaussians_group(mgs_gaussians *g, mgs_param_group group) {
  float **s = group_slot(g, group);
  return s ? *s : NULL;
}

mgs_gaussians *mgs_gaussians_create(size_t capacity, int sh_degree) {
  mgs_gaussians *g = calloc(1, sizeof *g);
  if (!g) return NULL;
  g->sh_degree = sh_degree < 0 ? 0 : (sh_degree > 3 ? 3 : sh_degree);
  if (mgs_gaussians_reserve(g, capacity ? capacity : 16, NULL) != MGS_OK) {
    mgs_gaussians_destroy(g);
    return NULL;
  }
  return g;
}

void mgs_gaussians_destroy(mgs_gaussians *g) {
  if (!g) return;
  for (int k = 0; k < MGS_PARAM_COUNT; k++) free(*group_slot(g, (mgs_param_group)k));
  free(g);
}

mgs_status mgs_gaussians_reserve(mgs_gaussians *g, size_t capacity, mgs_error *err) {
  if (capacity <= g->capacity) return MGS_OK;
  for (int k = 0; k < MGS_PARAM_COUNT; k++) {
    float **s = group_slot(g, (mgs_param_group)k);
    float *p = realloc(*s, capacity * (size_t)k_dims[k] * sizeof(float));
    if (!p) return mgs_error_set(err, MGS_ERR_NOMEM, "cannot allocate %zu Gaussians", capacity);
    *s = p;
  }
  g->capacity = capacity;
  return MGS_OK;
}

mgs_status mgs_gaussians_append(mgs_gaussians *g, size_t count, size_t *first, mgs_error *err) {
  size_t need = g->n + count;
  if (need > g->capacity) {
    size_t cap = g->capacity * 3 / 2 + 16;
    if (cap < need) cap = need;
    mgs_status s = mgs_gaussians_reserve(g, cap, err);
    if (s != MGS_OK) return s;
  }
  for (int k = 0; k < MGS_PARAM_COUNT; k++)
    memset(*group_slot(g, (mgs_param_group)k) + g->n * (size_t)k_dims[k], 0, count * (size_t)k_dims[k] * sizeof(float));
  for (size_t i = g->n; i < need; i++) g->rot[4 * i] = 1.0f;
  if (first) *first = g->n;
  g->n = need;
  return MGS_OK;
}

size_t mgs_rows_compact(float *data, size_t n, int dim, const uint8_t *keep) {
  size_t w = 0;
  for (size_t i = 0; i < n; i++) {
    if (!keep[i]) continue;
    if (w != i) memmove(data + w * (size_t)dim, data + i * (size_t)dim, (size_t)dim * sizeof(float));
    w++;
  }
  return w;
}

size_t mgs_gaussians_compact(mgs_gaussians *g, const uint8_t *keep) {
  size_t n = g->n;
  for (int k = 0; k < MGS_PARAM_COUNT; k++) n = mgs_rows_compact(*group_slot(g, (mgs_param_group)k), g->n, k_dims[k], keep);
  g->n = n;
  return n;
}

mgs_gaussians *mgs_gaussians_select(const mgs_gaussians *src, const size_t *idx, size_t count) {
  mgs_gaussians *g = mgs_gaussians_create(count, src->sh_degree);
  if (!g) return NULL;
  mgs_gaussians *s = (mgs_gaussians *)src;
  for (int k = 0; k < MGS_PARAM_COUNT; k++) {
    const float *from = *group_slot(s, (mgs_param_group)k);
    float *to = *group_slot(g, (mgs_param_group)k);
    size_t d = (size_t)k_dims[k];
    for (size_t i = 0; i < count; i++) memcpy(to + i * d, from + idx[i] * d, d * sizeof(float));
  }
  g->n = count;
  for (int k = 0; k < 3; k++) g->origin[k] = src->origin[k];
  g->kind = src->kind;
  return g;
}

mgs_gaussians *mgs_gaussians_clone(const mgs_gaussians *src) {
  mgs_gaussians *g = mgs_gaussians_create(src->n, src->sh_degree);
  if (!g) return NULL;
  mgs_gaussians *s = (mgs_gaussians *)src;
  for (int k = 0; k < MGS_PARAM_COUNT; k++)
    memcpy(*group_slot(g, (mgs_param_group)k), *group_slot(s, (mgs_param_group)k), src->n * (size_t)k_dims[k] * sizeof(float));
  g->n = src->n;
  for (int k = 0; k < 3; k++) g->origin[k] = src->origin[k];
  g->kind = src->kind;
  return g;
}

mgs_status mgs_gaussians_check_finite(const mgs_gaussians *g, mgs_error *err) {
  mgs_gaussians *s = (mgs_gaussians *)g;
  for (int k = 0; k < MGS_PARAM_COUNT; k++) {
    const float *p = *group_slot(s, (mgs_param_group)k);
    size_t d = (size_t)k_dims[k];
    for (size_t i = 0; i < g->n * d; i++)
      if (!isfinite(p[i]))
        return mgs_error_set(err, MGS_ERR_NUMERIC, "non-finite value %g in parameter group '%s' at Gaussian %zu",
                             (double)p[i], k_names[k], i / d);
  }
  return MGS_OK;
}

float mgs_gaussian_alpha(const mgs_gaussians *g, size_t i) { return mgs_sigmoidf(g->opacity[i]); }

void mgs_gaussian_scale(const mgs_gaussians *g, size_t i, float s[3]) {
  for (int k = 0; k < 3; k++) s[k] = expf(g->log_scale[3 * i + k]);
}

void mgs_gaussian_covariance(const mgs_gaussians *g, size_t i, double cov[9]) {
  double q[4] = {g->rot[4*i], g->rot[4*i+1], g->rot[4*i+2], g->rot[4*i+3]}, R[9];
  mgs_quat_to_mat3d(q, R);
  double s2[3];
  for (int k = 0; k < 3; k++) { double s = exp((double)g->log_scale[3*i+k]); s2[k] = s * s; }
  for (int a = 0; a < 3; a++)
    for (int b = 0; b < 3; b++)
      cov[3*a+b] = R[3*a]*R[3*b]*s2[0] + R[3*a+1]*R[3*b+1]*s2[1] + R[3*a+2]*R[3*b+2]*s2[2];
}

static int cmp_float(const void *a, const void *b) {
  float x = *(const float *)a, y = *(const float *)b;
  return (x > y) - (x < y);
}

int mgs_points_bounds_robust(const float *xyz, size_t n, double lo[3], double hi[3]) {
  if (n == 0) return 0;
  for (int k = 0; k < 3; k++) lo[k] = hi[k] = xyz[k];
  for (size_t i = 1; i < n; i++)
    for (int k = 0; k < 3; k++) {
      double v = xyz[3 * i + k];
      if (v < lo[k]) lo[k] = v;
      if (v > hi[k]) hi[k] = v;
    }
  if (n < 200) return 1;
  size_t stride = n > 65536 ? n / 65536 : 1, m = (n + stride - 1) / stride;
  float *v = malloc(m * sizeof(float));
  if (!v) return 1; /* the true box: correct, only not robust */
  double qlo[3], qhi[3], ext = 0;
  for (int k = 0; k < 3; k++) {
    for (size_t j = 0; j < m; j++) v[j] = xyz[3 * (j * stride) + k];
    qsort(v, m, sizeof(float), cmp_float);
    qlo[k] = v[(size_t)floor(0.005 * (double)(m - 1))];
    qhi[k] = v[(size_t)ceil(0.995 * (double)(m - 1))];
    if (qhi[k] - qlo[k] > ext) ext = qhi[k] - qlo[k];
  }
  free(v);
  for (int k = 0; k < 3; k++) {
    lo[k] = fmax(lo[k], qlo[k] - 0.1 * ext);
    hi[k] = fmin(hi[k], qhi[k] + 0.1 * ext);
  }
  return 1;
}

int mgs_point_in_box(const float *p, const double lo[3], const double hi[3]) {
  return p[0] >= lo[0] && p[0] <= hi[0] && p[1] >= lo[1] && p[1] <= hi[1] && p[2] >= lo[2] && p[2] <= hi[2];
}

int mgs_gaussians_bounds(const mgs_gaussians *g, double lo[3], double hi[3]) {
  if (g->n == 0) return 0;
  for (int k = 0; k < 3; k++) lo[k] = hi[k] = g->mean[k];
  for (size_t i = 1; i < g->n; i++)
    for (int k = 0; k < 3; k++) {
      double v = g->mean[3*i+k];
      if (v < lo[k]) lo[k] = v;
      if (v > hi[k]) hi[k] = v;
    }
  return 1;
}

const char *mgs_model_kind_name(mgs_model_kind k) { return k == MGS_MODEL_2DGS ? "2dgs" : "3dgs"; }

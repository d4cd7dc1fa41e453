/* SuGaR's density and ideal SDF of a model (train/mgs_sugar.h), and the neighbour lists
 * they are summed over (k-d tree of train/knn_tree.c). */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "train/mgs_sugar.h"
#include "train/mgs_lpvi.h"
#include "train/gauss_local.h"
#include "train/sugar_internal.h"
#include "core/mgs_parallel.h"

int mgs_sugar_min_axis(const double s2[3]) {
  int a = 0;
  if (s2[1] < s2[a]) a = 1;
  if (s2[2] < s2[a]) a = 2;
  return a;
}

/* One neighbour's whitened shift: y = Rᵀ(p − μ), q = Σ y²/s². */
static double quad(const mgs_gauss_local *L, const double p[3], double d[3], double y[3]) {
  for (int b = 0; b < 3; b++) d[b] = p[b] - L->mu[b];
  double q = 0;
  for (int a = 0; a < 3; a++) {
    y[a] = L->R[a] * d[0] + L->R[3 + a] * d[1] + L->R[6 + a] * d[2];
    q += y[a] * y[a] / L->s2[a];
  }
  return q < 1e8 ? q : 1e8; /* the authors' clamp */
}

void mgs_sugar_field(const mgs_gaussians *g, const double p[3], const uint32_t *nb, int k, double factor,
                     mgs_sugar_value *v) {
  mgs_sugar_field_with(g, NULL, p, nb, k, factor, v);
}

void mgs_sugar_field_with(const mgs_gaussians *g, const mgs_sugar_locals *t, const double p[3], const uint32_t *nb,
                          int k, double factor, mgs_sugar_value *v) {
  memset(v, 0, sizeof *v);
  double beta = 0;
  for (int j = 0; j < k; j++) {
    mgs_gauss_local tmp;
    const mgs_gauss_local *L = mgs_sugar_local(g, t, nb[j], &tmp);
    double d[3], y[3];
    double e = factor * L->alpha * exp(-0.5 * quad(L, p, d, y));
    v->density += e;
    for (int a = 0; a < 3; a++) { /* ∂e/∂p = −e Σ_a (y_a/s_a²) R[:,a] */
      double c = -e * y[a] / L->s2[a];
      for (int b = 0; b < 3; b++) v->grad[b] += c * L->R[3 * b + a];
    }
    beta += sqrt(L->s2[mgs_sugar_min_axis(L->s2)]);
  }
  v->beta = k > 0 ? beta / k : 0;
  double dc = v->density > MGS_SUGAR_DMIN ? v->density : MGS_SUGAR_DMIN;
  v->sdf = dc >= MGS_SUGAR_DMAX ? 0 : v->beta * sqrt(-2 * log(dc));
}

void mgs_sugar_gaussian_normal(const mgs_gaussians *g, size_t i, double n[3]) {
  mgs_gauss_local L;
  mgs_gauss_local_get(g, i, &L);
  int a = mgs_sugar_min_axis(L.s2);
  for (int b = 0; b < 3; b++) n[b] = L.R[3 * b + a];
}

void mgs_sugar_sdf_rows(const mgs_gaussians *g, const mgs_sugar_locals *t, const double p[3], const uint32_t *nb,
                        int k, double factor, double w, double *rows) {
  memset(rows, 0, (size_t)k * MGS_SUGAR_ROW * sizeof *rows);
  mgs_gauss_local tmp[MGS_SUGAR_KMAX];
  const mgs_gauss_local *L[MGS_SUGAR_KMAX];
  double e[MGS_SUGAR_KMAX], dsum = 0, beta = 0;
  for (int j = 0; j < k; j++) {
    L[j] = mgs_sugar_local(g, t, nb[j], &tmp[j]);
    double dd[3], y[3];
    e[j] = factor * L[j]->alpha * exp(-0.5 * quad(L[j], p, dd, y));
    dsum += e[j];
    beta += sqrt(L[j]->s2[mgs_sugar_min_axis(L[j]->s2)]);
  }
  beta /= k;
  if (dsum >= MGS_SUGAR_DMAX) return; /* inside: f = 0, no gradient */
  double dc = dsum > MGS_SUGAR_DMIN ? dsum : MGS_SUGAR_DMIN;
  double root = sqrt(-2 * log(dc));
  /* ∂f/∂d (0 below the clamp) and ∂f/∂β */
  double gd = dsum > MGS_SUGAR_DMIN ? -beta / (dsum * root) : 0;
  double gb = root;
  for (int j = 0; j < k; j++) {
    double *r = rows + (size_t)j * MGS_SUGAR_ROW;
    double dd[3], y[3];
    quad(L[j], p, dd, y);
    double ge = w * gd; /* ∂(w f)/∂e_j */
    /* e = c α exp(−q/2): ∂e/∂logit = e (1 − α); ∂e/∂q = −e/2 */
    r[MGS_SUGAR_ROW_OPACITY] = ge * e[j] * (1 - L[j]->alpha);
    double gq = -0.5 * ge * e[j];
    double dR[9] = {0};
    for (int a = 0; a < 3; a++) {
      double ya = y[a] / L[j]->s2[a];
      for (int b = 0; b < 3; b++) {
        r[MGS_SUGAR_ROW_MEAN + b] += gq * -2 * ya * L[j]->R[3 * b + a]; /* ∂q/∂μ = −2 Σ ya R[:,a] */
        dR[3 * b + a] = gq * 2 * ya * dd[b];                               /* ∂q/∂R[b][a] */
      }
      if (!L[j]->ls_clamped[a]) r[MGS_SUGAR_ROW_SCALE + a] = gq * -2 * y[a] * ya; /* ∂q/∂log s_a */
    }
    /* β = mean of the smallest scales: ∂β/∂log s_min = s_min / k */
    int am = mgs_sugar_min_axis(L[j]->s2);
    if (!L[j]->ls_clamped[am]) r[MGS_SUGAR_ROW_SCALE + am] += w * gb * sqrt(L[j]->s2[am]) / k;
    double dq[4];
    mgs_gauss_local_dq(L[j], dR, dq);
    for (int c = 0; c < 4; c++) r[MGS_SUGAR_ROW_ROT + c] = dq[c];
  }
}

void mgs_sugar_scatter(mgs_gaussians *grad, uint32_t i, const double *r) {
  for (int c = 0; c < 3; c++) grad->mean[3 * (size_t)i + c] += (float)r[MGS_SUGAR_ROW_MEAN + c];
  for (int c = 0; c < 3; c++) grad->log_scale[3 * (size_t)i + c] += (float)r[MGS_SUGAR_ROW_SCALE + c];
  for (int c = 0; c < 4; c++) grad->rot[4 * (size_t)i + c] += (float)r[MGS_SUGAR_ROW_ROT + c];
  grad->opacity[i] += (float)r[MGS_SUGAR_ROW_OPACITY];
}

/* ---- neighbours ----------------------------------------------------------------------- */

typedef struct knn_job {
  const mgs_kdtree *tree;
  const float *mean;  /* queries from the model's means, or */
  const double *pts;  /* arbitrary points */
  int k;
  uint32_t *idx;
} knn_job;

static void knn_range(void *ctx, size_t b, size_t e) {
  knn_job *j = ctx;
  size_t id[MGS_SUGAR_KMAX];
  double d2[MGS_SUGAR_KMAX];
  for (size_t i = b; i < e; i++) {
    double q[3];
    for (int a = 0; a < 3; a++) q[a] = j->mean ? j->mean[3 * i + a] : j->pts[3 * i + a];
    size_t got = mgs_kdtree_knn(j->tree, q, (size_t)j->k, id, d2);
    for (int t = 0; t < j->k; t++) j->idx[i * (size_t)j->k + t] = (uint32_t)id[(size_t)t < got ? (size_t)t : got - 1];
    uint32_t *row = j->idx + i * (size_t)j->k;
    if (j->mean && row[0] != (uint32_t)i) { /* duplicate means: the Gaussian itself first */
      int at = j->k - 1;
      for (int t = 1; t < j->k; t++)
        if (row[t] == (uint32_t)i) { at = t; break; }
      for (int t = at; t > 0; t--) row[t] = row[t - 1];
      row[0] = (uint32_t)i;
    }
  }
}

mgs_status mgs_sugar_knn(const mgs_gaussians *g, int k, uint32_t **idx, int *k_used, mgs_error *err) {
  *idx = NULL;
  if (!g->n) return mgs_error_set(err, MGS_ERR_ARG, "sugar: no Gaussians to find neighbours among");
  if (k < 1 || k > MGS_SUGAR_KMAX) return mgs_error_set(err, MGS_ERR_ARG, "sugar: k = %d outside [1, %d]", k, MGS_SUGAR_KMAX);
  if ((size_t)k > g->n) k = (int)g->n;
  mgs_kdtree *t = mgs_kdtree_build(g->mean, g->n);
  *idx = malloc(g->n * (size_t)k * sizeof **idx);
  if (!t || !*idx) {
    mgs_kdtree_destroy(t);
    free(*idx);
    *idx = NULL;
    return mgs_error_set(err, MGS_ERR_NOMEM, "sugar: out of memory for the neighbours of %zu Gaussians", g->n);
  }
  knn_job j = {t, g->mean, NULL, k, *idx};
  mgs_parallel_for(0, g->n, 256, knn_range, &j);
  mgs_kdtree_destroy(t);
  *k_used = k;
  return MGS_OK;
}

mgs_status mgs_sugar_knn_points(const mgs_gaussians *g, const double *p, size_t m, int k, uint32_t *idx,
                                mgs_error *err) {
  if (k < 1 || k > MGS_SUGAR_KMAX || (size_t)k > g->n)
    return mgs_error_set(err, MGS_ERR_ARG, "sugar: k = %d outside [1, min(%d, %zu)]", k, MGS_SUGAR_KMAX, g->n);
  mgs_kdtree *t = mgs_kdtree_build(g->mean, g->n);
  if (!t) return mgs_error_set(err, MGS_ERR_NOMEM, "sugar: out of memory for a k-d tree");
  knn_job j = {t, NULL, p, k, idx};
  mgs_parallel_for(0, m, 256, knn_range, &j);
  mgs_kdtree_destroy(t);
  return MGS_OK;
}

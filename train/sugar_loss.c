/* The losses of SuGaR's coarse stage (train/mgs_sugar.h): SDF, normal, opacity entropy.
 * Samples are evaluated in parallel into per-sample gradient rows, then added into the
 * gradient model in one serial pass (neighbour lists overlap: no races, a fixed order). */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include "train/mgs_sugar.h"
#include "train/gauss_local.h"
#include "train/sugar_internal.h"
#include "core/mgs_parallel.h"

typedef struct loss_job {
  const mgs_gaussians *g;
  const uint32_t *knn;
  int k;
  const mgs_sugar_sample *s;
  double factor, sigma, w; /* w: the weight per sample (already / m) */
  double *rows;            /* m * rows_per * MGS_SUGAR_ROW, NULL: value only */
  int rows_per;
  double *values;          /* m */
  const double *weights;   /* normal loss: m*k given weights (NULL: computed) */
  double *weights_out;     /* normal loss: m*k weights written (NULL: not) */
  const mgs_sugar_locals *t; /* the Gaussians read, in their local frame (run() builds it) */
} loss_job;

static void sdf_range(void *ctx, size_t b, size_t e) {
  loss_job *j = ctx;
  for (size_t i = b; i < e; i++) {
    const uint32_t *nb = j->knn + (size_t)j->s[i].gauss * (size_t)j->k;
    mgs_sugar_value v;
    mgs_sugar_field_with(j->g, j->t, j->s[i].p, nb, j->k, j->factor, &v);
    double diff = v.sdf - j->s[i].target;
    j->values[i] = j->w * fabs(diff) / j->sigma;
    if (j->rows) {
      double sg = diff > 0 ? 1 : diff < 0 ? -1 : 0;
      mgs_sugar_sdf_rows(j->g, j->t, j->s[i].p, nb, j->k, j->factor, j->w * sg / j->sigma,
                         j->rows + i * (size_t)j->rows_per * MGS_SUGAR_ROW);
    }
  }
}

/* dL/dn of Gaussian L's normal (its shortest axis `a`) into a row's quaternion part. */
static void normal_to_row(const mgs_gauss_local *L, int a, const double dn[3], double *row) {
  double dR[9] = {0};
  for (int b = 0; b < 3; b++) dR[3 * b + a] = dn[b];
  double dq[4];
  mgs_gauss_local_dq(L, dR, dq);
  for (int c = 0; c < 4; c++) row[MGS_SUGAR_ROW_ROT + c] += dq[c];
}

static void normal_range(void *ctx, size_t b, size_t e) {
  loss_job *j = ctx;
  int k = j->k;
  for (size_t i = b; i < e; i++) {
    const mgs_sugar_sample *s = j->s + i;
    const uint32_t *nb = j->knn + (size_t)s->gauss * (size_t)k;
    mgs_gauss_local tg, tmp[MGS_SUGAR_KMAX];
    const mgs_gauss_local *Lg = mgs_sugar_local(j->g, j->t, s->gauss, &tg), *L[MGS_SUGAR_KMAX];
    int ag = mgs_sugar_min_axis(Lg->s2), an[MGS_SUGAR_KMAX];
    double ng[3], n[MGS_SUGAR_KMAX][3], w[MGS_SUGAR_KMAX], sum = 0;
    for (int c = 0; c < 3; c++) ng[c] = Lg->R[3 * c + ag];
    for (int t = 0; t < k; t++) {
      L[t] = mgs_sugar_local(j->g, j->t, nb[t], &tmp[t]);
      an[t] = mgs_sugar_min_axis(L[t]->s2);
      double d[3], q = 0, along = 0, dot = 0;
      for (int c = 0; c < 3; c++) {
        n[t][c] = L[t]->R[3 * c + an[t]];
        d[c] = s->p[c] - L[t]->mu[c];
        along += d[c] * n[t][c];
        dot += n[t][c] * ng[c];
      }
      for (int a = 0; a < 3; a++) {
        double y = L[t]->R[a] * d[0] + L[t]->R[3 + a] * d[1] + L[t]->R[6 + a] * d[2];
        q += y * y / L[t]->s2[a];
      }
      double smin2 = L[t]->s2[an[t]] > 1e-12 ? L[t]->s2[an[t]] : 1e-12;
      w[t] = j->factor * L[t]->alpha * exp(-0.5 * (q < 1e8 ? q : 1e8)) * fabs(along) / smin2;
      if (dot < 0) w[t] = -w[t]; /* the flip to n_g's side, folded into the weight */
      sum += fabs(w[t]);
    }
    sum = sum > 1e-6 ? sum : 1e-6;
    for (int t = 0; t < k; t++) {
      w[t] = j->weights ? j->weights[i * (size_t)k + (size_t)t] : w[t] / sum;
      if (j->weights_out) j->weights_out[i * (size_t)k + (size_t)t] = w[t];
    }
    double r[3];
    for (int c = 0; c < 3; c++) {
      r[c] = ng[c];
      for (int t = 0; t < k; t++) r[c] -= w[t] * n[t][c];
    }
    j->values[i] = j->w * (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
    if (!j->rows) continue;
    double *rows = j->rows + i * (size_t)j->rows_per * MGS_SUGAR_ROW;
    memset(rows, 0, (size_t)j->rows_per * MGS_SUGAR_ROW * sizeof *rows);
    for (int t = 0; t < k; t++) {
      double dn[3];
      for (int c = 0; c < 3; c++) dn[c] = -2 * j->w * w[t] * r[c];
      normal_to_row(L[t], an[t], dn, rows + (size_t)t * MGS_SUGAR_ROW);
    }
    double dn[3];
    for (int c = 0; c < 3; c++) dn[c] = 2 * j->w * r[c];
    normal_to_row(Lg, ag, dn, rows + (size_t)k * MGS_SUGAR_ROW);
  }
}

/* The samples' Gaussians and their neighbours, each in its local frame once. */
typedef struct locals_job {
  const mgs_gaussians *g;
  const uint32_t *idx;
  mgs_gauss_local *loc;
} locals_job;

static void locals_range(void *ctx, size_t b, size_t e) {
  locals_job *j = ctx;
  for (size_t u = b; u < e; u++) mgs_gauss_local_get(j->g, j->idx[u], &j->loc[u]);
}

/* Also checks that the neighbour lists name Gaussians of this model (the one walk over them). */
static mgs_status locals_build(const loss_job *j, size_t m, mgs_sugar_locals *t, mgs_error *err) {
  const size_t n = j->g->n;
  t->loc = NULL;
  t->slot = malloc((n ? n : 1) * sizeof *t->slot);
  uint32_t *idx = malloc(m * (size_t)(j->k + 1) * sizeof *idx);
  mgs_status st = MGS_OK;
  if (!t->slot || !idx) { st = mgs_error_set(err, MGS_ERR_NOMEM, "sugar: out of memory for %zu samples", m); goto done; }
  memset(t->slot, 0xff, n * sizeof *t->slot);
  size_t u = 0;
  for (size_t i = 0; i < m; i++) {
    const uint32_t *nb = j->knn + (size_t)j->s[i].gauss * (size_t)j->k;
    for (int r = 0; r <= j->k; r++) {
      uint32_t gi = r < j->k ? nb[r] : j->s[i].gauss;
      if (gi >= n) {
        st = mgs_error_set(err, MGS_ERR_ARG, "sugar: sample %zu's neighbour list names Gaussian %u of %zu", i, gi, n);
        goto done;
      }
      if (t->slot[gi] == UINT32_MAX) { t->slot[gi] = (uint32_t)u; idx[u++] = gi; }
    }
  }
  if (!(t->loc = malloc((u ? u : 1) * sizeof *t->loc))) {
    st = mgs_error_set(err, MGS_ERR_NOMEM, "sugar: out of memory for %zu samples", m);
    goto done;
  }
  locals_job lj = {j->g, idx, t->loc};
  mgs_parallel_for(0, u, 256, locals_range, &lj);
done:
  free(idx);
  if (st) { free(t->slot); t->slot = NULL; }
  return st;
}

/* Runs fn over the samples, sums the values, scatters the rows (the last row of a sample
 * block belongs to the sampled Gaussian itself when rows_per = k + 1). */
static mgs_status run(loss_job *j, size_t m, mgs_range_fn fn, mgs_gaussians *grad, double *value,
                      mgs_error *err) {
  *value = 0;
  if (!m) return MGS_OK;
  if (j->k < 1 || j->k > MGS_SUGAR_KMAX) return mgs_error_set(err, MGS_ERR_ARG, "sugar: k = %d outside [1, %d]", j->k, MGS_SUGAR_KMAX);
  for (size_t i = 0; i < m; i++)
    if (j->s[i].gauss >= j->g->n) return mgs_error_set(err, MGS_ERR_ARG, "sugar: sample %zu names Gaussian %u of %zu", i, j->s[i].gauss, j->g->n);
  if (grad && grad->n != j->g->n) return mgs_error_set(err, MGS_ERR_ARG, "sugar: gradient model holds %zu Gaussians, model %zu", grad->n, j->g->n);
  mgs_sugar_locals lt;
  mgs_status st = locals_build(j, m, &lt, err);
  if (st) return st;
  j->values = malloc(m * sizeof *j->values);
  j->rows = grad ? malloc(m * (size_t)j->rows_per * MGS_SUGAR_ROW * sizeof *j->rows) : NULL;
  if (!j->values || (grad && !j->rows)) {
    free(j->values);
    free(j->rows);
    free(lt.loc);
    free(lt.slot);
    return mgs_error_set(err, MGS_ERR_NOMEM, "sugar: out of memory for %zu samples", m);
  }
  j->t = &lt;
  mgs_parallel_for(0, m, 64, fn, j);
  j->t = NULL;
  free(lt.loc);
  free(lt.slot);
  for (size_t i = 0; i < m; i++) {
    *value += j->values[i];
    if (!grad) continue;
    const uint32_t *nb = j->knn + (size_t)j->s[i].gauss * (size_t)j->k;
    const double *rows = j->rows + i * (size_t)j->rows_per * MGS_SUGAR_ROW;
    for (int t = 0; t < j->rows_per; t++)
      mgs_sugar_scatter(grad, t < j->k ? nb[t] : j->s[i].gauss, rows + (size_t)t * MGS_SUGAR_ROW);
  }
  free(j->values);
  free(j->rows);
  return MGS_OK;
}

mgs_status mgs_sugar_sdf_loss(const mgs_gaussians *g, const uint32_t *knn, int k, const mgs_sugar_sample *s,
                              size_t m, double factor, double sigma, double w, mgs_gaussians *grad, double *value,
                              mgs_error *err) {
  if (!(sigma > 0)) return mgs_error_set(err, MGS_ERR_ARG, "sugar: the SDF loss needs σ > 0 (got %g)", sigma);
  loss_job j = {g, knn, k, s, factor, sigma, m ? w / (double)m : 0, NULL, k, NULL, NULL, NULL, NULL};
  return run(&j, m, sdf_range, grad, value, err);
}

mgs_status mgs_sugar_normal_loss(const mgs_gaussians *g, const uint32_t *knn, int k, const mgs_sugar_sample *s,
                                 size_t m, double factor, const double *weights, double *weights_out, double w,
                                 mgs_gaussians *grad, double *value, mgs_error *err) {
  loss_job j = {g, knn, k, s, factor, 1, m ? w / (double)m : 0, NULL, k + 1, NULL, weights, weights_out, NULL};
  return run(&j, m, normal_range, grad, value, err);
}

mgs_status mgs_sugar_entropy_loss(const mgs_gaussians *g, const int *radii, double w, mgs_gaussians *grad,
                                  double *value, mgs_error *err) {
  *value = 0;
  if (grad && grad->n != g->n) return mgs_error_set(err, MGS_ERR_ARG, "sugar: gradient model holds %zu Gaussians, model %zu", grad->n, g->n);
  size_t m = 0;
  for (size_t i = 0; i < g->n; i++) m += !radii || radii[i] > 0;
  if (!m) return MGS_OK;
  const double eps = 1e-10, wm = w / (double)m;
  for (size_t i = 0; i < g->n; i++) {
    if (radii && radii[i] <= 0) continue;
    double a = 1.0 / (1.0 + exp(-(double)g->opacity[i]));
    *value += wm * (-a * log(a + eps) - (1 - a) * log(1 - a + eps));
    if (grad) {
      double dh = -log(a + eps) - a / (a + eps) + log(1 - a + eps) + (1 - a) / (1 - a + eps);
      grad->opacity[i] += (float)(wm * dh * a * (1 - a));
    }
  }
  return MGS_OK;
}

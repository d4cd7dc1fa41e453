/* train/mgs_sugar.h: SuGaR's density and SDF against values computed independently (the
 * covariance from core/, inverted here), the normal of a flat Gaussian, ∇d against finite
 * differences, the neighbour lists against brute force, and finite-difference checks of
 * the SDF, normal and entropy losses (tiny and large scales, α near 0 and 1, equal
 * scales, a model 1e3 from its origin, overlapping Gaussians). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "core/mgs_core.h"
#include "core/mgs_rng.h"
#include "mgs_test.h"
#include "train/mgs_sugar.h"

static mgs_gaussians *model(size_t n) {
  mgs_gaussians *g = mgs_gaussians_create(n, 0);
  size_t first;
  if (!g || mgs_gaussians_append(g, n, &first, NULL)) exit(2);
  return g;
}

static void set(mgs_gaussians *g, size_t i, const double mu[3], const double s[3], const double q[4], double alpha) {
  for (int a = 0; a < 3; a++) g->mean[3 * i + a] = (float)mu[a];
  for (int a = 0; a < 3; a++) g->log_scale[3 * i + a] = (float)log(s[a]);
  for (int a = 0; a < 4; a++) g->rot[4 * i + a] = (float)q[a];
  g->opacity[i] = (float)log(alpha / (1 - alpha));
}

static void inv3(const double m[9], double r[9]) {
  double c0 = m[4] * m[8] - m[5] * m[7], c1 = m[5] * m[6] - m[3] * m[8], c2 = m[3] * m[7] - m[4] * m[6];
  double det = m[0] * c0 + m[1] * c1 + m[2] * c2;
  r[0] = c0 / det; r[1] = (m[2] * m[7] - m[1] * m[8]) / det; r[2] = (m[1] * m[5] - m[2] * m[4]) / det;
  r[3] = c1 / det; r[4] = (m[0] * m[8] - m[2] * m[6]) / det; r[5] = (m[2] * m[3] - m[0] * m[5]) / det;
  r[6] = c2 / det; r[7] = (m[1] * m[6] - m[0] * m[7]) / det; r[8] = (m[0] * m[4] - m[1] * m[3]) / det;
}

/* d(p) from the definition: c Σ α exp(−½ δᵀ Σ⁻¹ δ), Σ from core/. */
static double density_ref(const mgs_gaussians *g, const uint32_t *nb, int k, const double p[3], double c) {
  double d = 0;
  for (int j = 0; j < k; j++) {
    double cov[9], ic[9], dl[3];
    mgs_gaussian_covariance(g, nb[j], cov);
    inv3(cov, ic);
    for (int a = 0; a < 3; a++) dl[a] = p[a] - g->mean[3 * nb[j] + a];
    double q = 0;
    for (int a = 0; a < 3; a++)
      for (int b = 0; b < 3; b++) q += dl[a] * ic[3 * a + b] * dl[b];
    d += c * mgs_gaussian_alpha(g, nb[j]) * exp(-0.5 * q);
  }
  return d;
}

static void test_single(void) {
  mgs_gaussians *g = model(1);
  set(g, 0, (double[]){0, 0, 0}, (double[]){0.1, 0.1, 0.1}, (double[]){1, 0, 0, 0}, 0.8);
  uint32_t nb = 0;
  mgs_sugar_value v;
  mgs_sugar_field(g, (double[]){0.1, 0, 0}, &nb, 1, 1.0, &v);
  double d = 0.8 * exp(-0.5);
  CHECK_NEAR(v.density, d, 1e-6);
  CHECK_NEAR(v.beta, 0.1, 1e-7);
  CHECK_NEAR(v.sdf, 0.1 * sqrt(-2 * log(d)), 1e-6);
  /* at the centre with α = 0.8 < 1: f = β √(−2 ln 0.8) */
  mgs_sugar_field(g, (double[]){0, 0, 0}, &nb, 1, 1.0, &v);
  CHECK_NEAR(v.sdf, 0.1 * sqrt(-2 * log(0.8)), 1e-6);
  /* the density factor 1/16 of training */
  mgs_sugar_field(g, (double[]){0, 0.2, 0}, &nb, 1, 1.0 / 16, &v);
  CHECK_NEAR(v.density, 0.8 / 16 * exp(-2.0), 1e-8);
  /* far away: clamped at 1e-16, f = β √(2 · 36.84) */
  mgs_sugar_field(g, (double[]){100, 0, 0}, &nb, 1, 1.0, &v);
  CHECK_NEAR(v.sdf, 0.1 * sqrt(-2 * log(1e-16)), 1e-6);
  mgs_gaussians_destroy(g);
}

/* Two overlapping saturated Gaussians: d ≥ 1 is inside, f = 0. */
static void test_inside(void) {
  mgs_gaussians *g = model(2);
  set(g, 0, (double[]){0, 0, 0}, (double[]){0.1, 0.1, 0.1}, (double[]){1, 0, 0, 0}, 0.99);
  set(g, 1, (double[]){0.01, 0, 0}, (double[]){0.1, 0.1, 0.1}, (double[]){1, 0, 0, 0}, 0.99);
  uint32_t nb[2] = {0, 1};
  mgs_sugar_value v;
  mgs_sugar_field(g, (double[]){0.005, 0, 0}, nb, 2, 1.0, &v);
  CHECK(v.density > 1.9);
  CHECK(v.sdf == 0);
  mgs_gaussians_destroy(g);
}

/* A flat, rotated Gaussian: its normal, the field across and along its plane. */
static void test_flat(void) {
  mgs_gaussians *g = model(3);
  double h = sqrt(0.5);
  /* 90° about x: the local z axis (the shortest, 0.01) goes to world ±y */
  set(g, 0, (double[]){0.3, -0.2, 0.5}, (double[]){0.5, 0.4, 0.01}, (double[]){h, h, 0, 0}, 0.9);
  set(g, 1, (double[]){0.1, 0.2, 0.0}, (double[]){0.02, 0.3, 0.2}, (double[]){0.9, 0.1, -0.3, 0.2}, 0.6);
  set(g, 2, (double[]){-0.2, 0.1, 0.4}, (double[]){0.2, 0.05, 0.3}, (double[]){0.5, -0.5, 0.5, 0.5}, 0.3);
  double n[3];
  mgs_sugar_gaussian_normal(g, 0, n);
  CHECK_NEAR(fabs(n[1]), 1.0, 1e-6);
  CHECK_NEAR(fabs(n[0]) + fabs(n[2]), 0.0, 1e-6);
  uint32_t nb[3] = {0, 1, 2};
  mgs_sugar_value v;
  const double pts[4][3] = {{0.3, -0.19, 0.5}, {0.3, -0.2, 0.9}, {0.15, 0.1, 0.2}, {0.0, 0.0, 0.0}};
  for (int t = 0; t < 4; t++) {
    mgs_sugar_field(g, pts[t], nb, 3, 1.0, &v);
    double d = density_ref(g, nb, 3, pts[t], 1.0);
    CHECK_NEAR(v.density, d, 1e-6 * fmax(1, d));
    double beta = (0.01 + 0.02 + 0.05) / 3;
    CHECK_NEAR(v.beta, beta, 1e-6);
    CHECK_NEAR(v.sdf, d >= 1 ? 0 : beta * sqrt(-2 * log(fmax(d, 1e-16))), 1e-6);
    /* ∇d by central differences of the reference */
    for (int a = 0; a < 3; a++) {
      double pp[3] = {pts[t][0], pts[t][1], pts[t][2]}, pm[3] = {pts[t][0], pts[t][1], pts[t][2]};
      pp[a] += 1e-6;
      pm[a] -= 1e-6;
      double fd = (density_ref(g, nb, 3, pp, 1.0) - density_ref(g, nb, 3, pm, 1.0)) / 2e-6;
      CHECK_NEAR(v.grad[a], fd, 1e-4 * fmax(1, fabs(fd)));
    }
  }
  /* 0.01 across the flat one at α = 0.9 alone: d = 0.9 e^{−1/2} (one σ) */
  mgs_sugar_field(g, (double[]){0.3, -0.19, 0.5}, nb, 1, 1.0, &v);
  CHECK_NEAR(v.density, 0.9 * exp(-0.5), 1e-4);
  mgs_gaussians_destroy(g);
}

static mgs_gaussians *random_model(size_t n, uint64_t seed, double spread, double offset) {
  mgs_gaussians *g = model(n);
  mgs_rng r;
  mgs_rng_init(&r, seed, 0);
  for (size_t i = 0; i < n; i++) {
    double mu[3], s[3], q[4];
    for (int a = 0; a < 3; a++) mu[a] = offset + spread * (2 * mgs_rng_uniform(&r) - 1);
    for (int a = 0; a < 3; a++) s[a] = 0.05 + 0.2 * mgs_rng_uniform(&r);
    s[i % 3] *= 0.2; /* flat */
    for (int a = 0; a < 4; a++) q[a] = 2 * mgs_rng_uniform(&r) - 1;
    set(g, i, mu, s, q, 0.1 + 0.8 * mgs_rng_uniform(&r));
  }
  return g;
}

static void test_knn(void) {
  mgs_gaussians *g = random_model(200, 7, 1.0, 0);
  uint32_t *idx;
  int k;
  mgs_error err;
  CHECK_OK(mgs_sugar_knn(g, 16, &idx, &k, &err), &err);
  CHECK(k == 16);
  for (size_t i = 0; i < g->n; i++) {
    CHECK(idx[i * 16] == i);
    /* the 16th neighbour's distance is the 16th smallest (brute force) */
    double d2[200];
    for (size_t j = 0; j < g->n; j++) {
      double s = 0;
      for (int a = 0; a < 3; a++) s += pow((double)g->mean[3 * i + a] - g->mean[3 * j + a], 2);
      d2[j] = s;
    }
    double kth = 0;
    for (int t = 0; t < 16; t++) kth = fmax(kth, d2[idx[i * 16 + t]]);
    int closer = 0;
    for (size_t j = 0; j < g->n; j++) closer += d2[j] < kth;
    CHECK(closer <= 15);
  }
  free(idx);
  /* fewer Gaussians than k */
  mgs_gaussians *s = random_model(5, 3, 1.0, 0);
  CHECK_OK(mgs_sugar_knn(s, 16, &idx, &k, &err), &err);
  CHECK(k == 5);
  free(idx);
  mgs_gaussians_destroy(s);
  mgs_gaussians_destroy(g);
}

typedef enum { L_SDF, L_NORMAL, L_ENTROPY } which;

static double *frozen; /* the normal loss' weights at the unperturbed model */

static double eval(which w, const mgs_gaussians *g, const uint32_t *knn, int k, const mgs_sugar_sample *s, size_t m,
                   mgs_gaussians *grad) {
  double v = 0;
  mgs_error err;
  mgs_status st = w == L_SDF      ? mgs_sugar_sdf_loss(g, knn, k, s, m, 1.0 / 16, 0.3, 0.7, grad, &v, &err)
                  : w == L_NORMAL ? mgs_sugar_normal_loss(g, knn, k, s, m, 1.0 / 16, grad ? NULL : frozen,
                                                          grad ? frozen : NULL, 0.7, grad, &v, &err)
                                  : mgs_sugar_entropy_loss(g, NULL, 0.7, grad, &v, &err);
  if (st) { fprintf(stderr, "%s\n", err.msg); exit(3); }
  return v;
}

/* Central differences over every parameter of the listed groups; returns the worst error
 * relative to max(|analytic|, |fd|, scale). */
static double fd(which w, mgs_gaussians *g, const uint32_t *knn, int k, const mgs_sugar_sample *s, size_t m,
                 float h, const char *name) {
  mgs_gaussians *gr = model(g->n);
  for (int p = 0; p < MGS_PARAM_COUNT; p++)
    memset(mgs_gaussians_group(gr, (mgs_param_group)p), 0, g->n * (size_t)mgs_param_dim((mgs_param_group)p) * sizeof(float));
  eval(w, g, knn, k, s, m, gr);
  const mgs_param_group groups[4] = {MGS_PARAM_MEAN, MGS_PARAM_LOG_SCALE, MGS_PARAM_ROT, MGS_PARAM_OPACITY};
  double worst = 0, gmax = 0, nonzero = 0, smin = 0;
  for (size_t i = 0; i < g->n; i++) {
    float sc[3];
    mgs_gaussian_scale(g, i, sc);
    smin += fmin(sc[0], fmin(sc[1], sc[2])) / (double)g->n;
  }
  const float hmean = (float)(0.01 * smin); /* means move by a small part of the thinnest axis */
  for (int gi = 0; gi < 4; gi++) {
    int dim = mgs_param_dim(groups[gi]);
    float *D = mgs_gaussians_group(gr, groups[gi]);
    for (size_t i = 0; i < g->n * (size_t)dim; i++) gmax = fmax(gmax, fabs(D[i]));
  }
  for (int gi = 0; gi < 4; gi++) {
    int dim = mgs_param_dim(groups[gi]);
    float *P = mgs_gaussians_group(g, groups[gi]), *D = mgs_gaussians_group(gr, groups[gi]);
    for (size_t i = 0; i < g->n * (size_t)dim; i++) {
      const float p0 = P[i], hh = groups[gi] == MGS_PARAM_MEAN ? hmean : h;
      P[i] = p0 + hh;
      const double hp = (double)P[i] - p0, lp = eval(w, g, knn, k, s, m, NULL);
      P[i] = p0 - hh;
      const double hm = (double)P[i] - p0, lm = eval(w, g, knn, k, s, m, NULL);
      P[i] = p0;
      double f = (lp - lm) / (hp - hm);
      double e = fabs(f - D[i]) / fmax(fmax(fabs(f), fabs(D[i])), 1e-2 * gmax + 1e-12);
      if (e > worst) {
        worst = e;
        if (e > 2e-2) fprintf(stderr, "  %s %s[%zu]: analytic %.6g fd %.6g\n", name, mgs_param_name(groups[gi]), i, D[i], f);
      }
      nonzero += D[i] != 0;
    }
  }
  CHECK_MSG(nonzero > 0, "%s: no gradient at all", name);
  mgs_gaussians_destroy(gr);
  return worst;
}

/* Samples drawn near random Gaussians, targets around the field's own value. */
static mgs_sugar_sample *samples(const mgs_gaussians *g, const uint32_t *knn, int k, size_t m, uint64_t seed) {
  mgs_sugar_sample *s = calloc(m, sizeof *s);
  mgs_rng r;
  mgs_rng_init(&r, seed, 0);
  for (size_t i = 0; i < m; i++) {
    s[i].gauss = (uint32_t)(mgs_rng_uniform(&r) * (double)g->n) % (uint32_t)g->n;
    float sc[3];
    mgs_gaussian_scale(g, s[i].gauss, sc);
    for (int a = 0; a < 3; a++) s[i].p[a] = g->mean[3 * s[i].gauss + a] + 1.5 * sc[a] * (2 * mgs_rng_uniform(&r) - 1);
    mgs_sugar_value v;
    mgs_sugar_field(g, s[i].p, knn + (size_t)s[i].gauss * (size_t)k, k, 1.0 / 16, &v);
    s[i].target = v.sdf * (mgs_rng_uniform(&r) < 0.5 ? 0.5 : 1.5) + 0.01; /* away from |·|'s kink */
  }
  return s;
}

static void check_all(const char *label, mgs_gaussians *g, float h) {
  uint32_t *knn;
  int k;
  mgs_error err;
  CHECK_OK(mgs_sugar_knn(g, 8, &knn, &k, &err), &err);
  mgs_sugar_sample *s = samples(g, knn, k, 24, 11);
  frozen = malloc(24 * (size_t)k * sizeof *frozen);
  char name[96];
  snprintf(name, sizeof name, "%s sdf", label);
  double e = fd(L_SDF, g, knn, k, s, 24, h, name);
  CHECK_MSG(e < 2e-2, "%s: worst relative error %.3g", name, e);
  snprintf(name, sizeof name, "%s normal", label);
  e = fd(L_NORMAL, g, knn, k, s, 24, h, name);
  CHECK_MSG(e < 2e-2, "%s: worst relative error %.3g", name, e);
  snprintf(name, sizeof name, "%s entropy", label);
  e = fd(L_ENTROPY, g, knn, k, s, 24, h, name);
  CHECK_MSG(e < 2e-2, "%s: worst relative error %.3g", name, e);
  free(frozen);
  frozen = NULL;
  free(s);
  free(knn);
}

static void test_gradients(void) {
  mgs_gaussians *g = random_model(12, 5, 0.3, 0);
  check_all("random", g, 1e-3f);
  mgs_gaussians_destroy(g);
  /* tiny scales (1e-4 relative to a spread of 1e-3) */
  g = random_model(12, 6, 1e-3, 0);
  for (size_t i = 0; i < g->n * 3; i++) g->log_scale[i] += (float)log(1e-3);
  check_all("tiny", g, 1e-3f);
  mgs_gaussians_destroy(g);
  /* huge scales and spread */
  g = random_model(12, 8, 300, 0);
  for (size_t i = 0; i < g->n * 3; i++) g->log_scale[i] += (float)log(1e3);
  check_all("huge", g, 1e-3f);
  mgs_gaussians_destroy(g);
  /* α near 0 and 1 */
  g = random_model(12, 9, 0.3, 0);
  for (size_t i = 0; i < g->n; i++) g->opacity[i] = i % 2 ? 9.0f : -9.0f;
  check_all("alpha01", g, 1e-3f);
  mgs_gaussians_destroy(g);
  /* nearly equal scales (5 % apart: the shortest axis is a kink of min(), not differentiable
     at exact equality) */
  g = random_model(12, 10, 0.3, 0);
  for (size_t i = 0; i < g->n; i++) {
    g->log_scale[3 * i + 1] = g->log_scale[3 * i] + 0.05f;
    g->log_scale[3 * i + 2] = g->log_scale[3 * i] + 0.1f;
  }
  check_all("near-equal", g, 1e-3f);
  mgs_gaussians_destroy(g);
  g = random_model(12, 13, 0.3, 0);
  check_all("seed13", g, 1e-3f);
  mgs_gaussians_destroy(g);
  /* far from the model's origin: means at 1e3 in the local frame */
  g = random_model(12, 13, 0.3, 1e3);
  check_all("offset1e3", g, 1e-3f);
  mgs_gaussians_destroy(g);
}

/* The losses read each Gaussian's local frame from a table built once per evaluation; the
 * public mgs_sugar_field rebuilds it per call. Both are the same code on the same doubles, so
 * the SDF loss value must equal the sum of mgs_sugar_field's terms exactly (training with the
 * table gave a byte-identical model: docs/benchmarks.md, "SuGaR's term"). */
static void test_table_exact(void) {
  mgs_gaussians *g = random_model(40, 21, 0.3, 0);
  uint32_t *knn;
  int k;
  mgs_error err;
  CHECK_OK(mgs_sugar_knn(g, 8, &knn, &k, &err), &err);
  const size_t m = 64;
  mgs_sugar_sample *s = samples(g, knn, k, m, 5);
  double v = 0, direct = 0;
  const double w = 0.7, sigma = 0.3, wm = w / (double)m;
  CHECK_OK(mgs_sugar_sdf_loss(g, knn, k, s, m, 1.0 / 16, sigma, w, NULL, &v, &err), &err);
  for (size_t i = 0; i < m; i++) {
    mgs_sugar_value f;
    mgs_sugar_field(g, s[i].p, knn + (size_t)s[i].gauss * (size_t)k, k, 1.0 / 16, &f);
    direct += wm * fabs(f.sdf - s[i].target) / sigma;
  }
  CHECK_MSG(v == direct && v > 0, "table %.17g, rebuilt %.17g", v, direct);
  free(s);
  free(knn);
  mgs_gaussians_destroy(g);
}

/* Bad input: a sample naming a Gaussian out of range, a neighbour list naming one, σ = 0. */
static void test_errors(void) {
  mgs_gaussians *g = random_model(4, 1, 0.3, 0);
  uint32_t knn[16] = {0};
  mgs_sugar_sample s = {{0, 0, 0}, 9, 0};
  double v;
  mgs_error err;
  CHECK(mgs_sugar_sdf_loss(g, knn, 4, &s, 1, 1, 1, 1, NULL, &v, &err) == MGS_ERR_ARG);
  CHECK(strstr(err.msg, "Gaussian 9") != NULL);
  s.gauss = 0;
  knn[2] = 7;
  CHECK(mgs_sugar_normal_loss(g, knn, 4, &s, 1, 1, NULL, NULL, 1, NULL, &v, &err) == MGS_ERR_ARG);
  CHECK(strstr(err.msg, "neighbour list names Gaussian 7") != NULL);
  knn[2] = 0;
  CHECK(mgs_sugar_sdf_loss(g, knn, 4, &s, 1, 1, 0, 1, NULL, &v, &err) == MGS_ERR_ARG);
  mgs_gaussians_destroy(g);
}

int main(void) {
  test_single();
  test_inside();
  test_flat();
  test_knn();
  test_gradients();
  test_table_exact();
  test_errors();
  return mgs_test_finish();
}

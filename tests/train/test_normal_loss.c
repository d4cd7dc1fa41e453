/* train/mgs_term_normal.h: finite differences of the normal loss w.r.t. rotation (the
 * stored, un-normalized quaternion) and log-scale, including degenerate scale sets (two
 * equal smallest, all equal, extreme flatness); its definition for equal scales; its limit
 * toward the seed's hard shortest axis; the term on a model of flat Gaussians on a sphere
 * with its own SDF (aligned vs misaligned, descent lowers it), and its checkpoint state. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "core/mgs_core.h"
#include "mgs_test.h"
#include "train/mgs_term_normal.h"

static mgs_gaussians *model(size_t n) {
  mgs_gaussians *g = mgs_gaussians_create(n, 0);
  size_t first;
  if (!g || mgs_gaussians_append(g, n, &first, NULL)) exit(2);
  return g;
}

/* T = v vᵀ per Gaussian, plus (odd rows) a second, weaker direction u uᵀ. */
static void tensors_of(size_t n, const float *v, float *T) {
  for (size_t i = 0; i < n; i++) {
    const float *a = v + 3 * i, *b = v + 3 * ((i + 1) % n);
    const float e = i % 2 ? 0.3f : 0.0f;
    T[6 * i + 0] = a[0] * a[0] + e * b[0] * b[0]; T[6 * i + 1] = a[0] * a[1] + e * b[0] * b[1];
    T[6 * i + 2] = a[0] * a[2] + e * b[0] * b[2]; T[6 * i + 3] = a[1] * a[1] + e * b[1] * b[1];
    T[6 * i + 4] = a[1] * a[2] + e * b[1] * b[2]; T[6 * i + 5] = a[2] * a[2] + e * b[2] * b[2];
  }
}

static double loss(const mgs_gaussians *g, const float *gd, double p) {
  double v;
  mgs_normal_loss(g, gd, p, 1.0, NULL, &v, NULL, NULL);
  return v;
}

static double fd_check(mgs_gaussians *g, const float *gd, double p, const char *name) {
  mgs_gaussians *gr = model(g->n);
  memset(gr->rot, 0, 4 * g->n * sizeof(float));
  mgs_error err;
  double v;
  CHECK_OK(mgs_normal_loss(g, gd, p, 1.0, gr, &v, NULL, &err), &err);
  double worst = 0, gmax = 0;
  const mgs_param_group groups[2] = {MGS_PARAM_ROT, MGS_PARAM_LOG_SCALE};
  for (int gi = 0; gi < 2; gi++) {
    int dim = mgs_param_dim(groups[gi]);
    float *P = mgs_gaussians_group(g, groups[gi]), *D = mgs_gaussians_group(gr, groups[gi]);
    for (size_t i = 0; i < g->n * (size_t)dim; i++) {
      const float p0 = P[i];
      P[i] = p0 + 1e-4f;
      const double hp = (double)P[i] - p0, lp = loss(g, gd, p);
      P[i] = p0 - 1e-4f;
      const double hm = (double)P[i] - p0, lm = loss(g, gd, p);
      P[i] = p0;
      double fd = (lp - lm) / (hp - hm);
      double e = fabs(fd - D[i]) * (double)g->n; /* per Gaussian (the loss is a mean) */
      gmax = fmax(gmax, fabs(D[i]) * (double)g->n);
      worst = fmax(worst, e);
    }
  }
  fprintf(stderr, "  normal loss FD %-26s max abs error %.3g (max |grad| %.3g, per Gaussian)\n", name, worst, gmax);
  CHECK(gmax > 1e-3);
  mgs_gaussians_destroy(gr);
  return worst;
}

static void test_fd(void) {
  const size_t n = 40;
  mgs_gaussians *g = model(n);
  float *gd = malloc(n * 3 * sizeof(float));
  mgs_rng r;
  mgs_rng_init(&r, 3, 3);
  for (size_t i = 0; i < n; i++) {
    for (int k = 0; k < 4; k++) g->rot[4 * i + k] = (float)(1.5 * mgs_rng_normal(&r));
    for (int k = 0; k < 3; k++) g->log_scale[3 * i + k] = (float)(-3 + mgs_rng_normal(&r));
    double l = 0;
    for (int k = 0; k < 3; k++) { gd[3 * i + k] = (float)mgs_rng_normal(&r); l += gd[3 * i + k] * gd[3 * i + k]; }
    for (int k = 0; k < 3; k++) gd[3 * i + k] = (float)(gd[3 * i + k] / sqrt(l) * (0.8 + 0.4 * mgs_rng_uniform(&r)));
  }
  float *T = malloc(n * 6 * sizeof(float));
  tensors_of(n, gd, T);
  CHECK(fd_check(g, T, 1.0, "random") < 1e-5);
  CHECK(fd_check(g, T, 4.0, "random, sharpness 4") < 1e-5);
  /* degenerate scale sets */
  for (size_t i = 0; i < n; i++) {
    float *ls = g->log_scale + 3 * i;
    switch (i % 4) {
      case 0: ls[0] = ls[1] = -5.0f; ls[2] = -2.0f; break; /* two equal smallest */
      case 1: ls[0] = ls[1] = ls[2] = -3.0f; break;        /* isotropic */
      case 2: ls[2] = -12.0f; ls[0] = ls[1] = -1.0f; break; /* extremely flat */
      default: ls[1] = -4.0f; ls[0] = -4.0f + 1e-6f; ls[2] = 1.0f; break; /* nearly tied */
    }
  }
  CHECK(fd_check(g, T, 1.0, "degenerate scales") < 1e-5);
  /* far outside the band (tr T < 0.05): left out, no gradient */
  for (int k = 0; k < 6; k++) T[k] = 0.005f;
  mgs_gaussians *gr = model(n);
  memset(gr->rot, 0, 4 * n * sizeof(float));
  size_t used;
  double v;
  mgs_error err;
  CHECK_OK(mgs_normal_loss(g, T, 1.0, 1.0, gr, &v, &used, &err), &err);
  CHECK(used == n - 1);
  CHECK(gr->rot[0] == 0 && gr->log_scale[0] == 0);
  mgs_gaussians_destroy(gr);
  free(gd);
  free(T);
  mgs_gaussians_destroy(g);
}

/* The definition: h = Σ w_k (r_k·ĝ)², w ∝ s^(−2p). Two equal smallest scales: the mean of
 * the two axes' alignments (when the third is much larger); large p: the seed's hard axis. */
static void test_definition(void) {
  mgs_gaussians *g = model(1);
  g->rot[0] = 1; /* identity: axes = world axes */
  float gd[6] = {0.36f, 0.48f, 0, 0.64f, 0, 0}; /* (0.6, 0.8, 0) (0.6, 0.8, 0)ᵀ */
  g->log_scale[0] = g->log_scale[1] = -6.0f;
  g->log_scale[2] = 0.0f;
  double v = loss(g, gd, 1.0);
  double h = 0.5 * (0.36 + 0.64);
  CHECK_NEAR(v, 1 - h, 1e-4); /* third axis weight e^-12 */
  /* distinct scales, sharpness 16: the hard shortest axis (x) */
  g->log_scale[0] = -6.0f; g->log_scale[1] = -5.0f;
  CHECK_NEAR(loss(g, gd, 16.0), 1 - 0.36, 1e-6);
  /* p = 1 for a 10:10:1 Gaussian: within 2 % of the hard value */
  g->log_scale[0] = logf(0.1f); g->log_scale[1] = g->log_scale[2] = 0;
  float gx[6] = {1, 0, 0, 0, 0, 0};
  CHECK(loss(g, gx, 1.0) < 0.02);
  mgs_gaussians_destroy(g);
}

/* Flat Gaussians tangent to a sphere of radius 1 (normal = radial) on a shell dense enough
 * to make a surface; the term builds its own SDF. */
static mgs_gaussians *sphere_model(size_t n, int misalign) {
  mgs_gaussians *g = model(n);
  const double ga = MGS_PI * (3 - sqrt(5.0));
  for (size_t i = 0; i < n; i++) {
    double z = 1 - 2 * (i + 0.5) / (double)n, rr = sqrt(1 - z * z), ph = ga * (double)i;
    double nrm[3] = {rr * cos(ph), rr * sin(ph), z};
    for (int k = 0; k < 3; k++) g->mean[3 * i + k] = (float)nrm[k];
    /* rotation taking local z to the normal (or, misaligned, local x) */
    double t[3], b[3], a[3] = {fabs(nrm[0]) < 0.9 ? 1 : 0, fabs(nrm[0]) < 0.9 ? 0 : 1, 0};
    t[0] = a[1] * nrm[2] - a[2] * nrm[1]; t[1] = a[2] * nrm[0] - a[0] * nrm[2]; t[2] = a[0] * nrm[1] - a[1] * nrm[0];
    double tl = sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]);
    for (int k = 0; k < 3; k++) t[k] /= tl;
    b[0] = nrm[1] * t[2] - nrm[2] * t[1]; b[1] = nrm[2] * t[0] - nrm[0] * t[2]; b[2] = nrm[0] * t[1] - nrm[1] * t[0];
    double R[9];
    for (int k = 0; k < 3; k++) { R[3 * k] = t[k]; R[3 * k + 1] = b[k]; R[3 * k + 2] = nrm[k]; }
    double q[4];
    mgs_mat3_to_quatd(R, q);
    for (int k = 0; k < 4; k++) g->rot[4 * i + k] = (float)q[k];
    g->log_scale[3 * i + 0] = g->log_scale[3 * i + 1] = logf(0.12f);
    g->log_scale[3 * i + 2] = logf(0.01f);
    if (misalign) { g->log_scale[3 * i + 0] = logf(0.01f); g->log_scale[3 * i + 2] = logf(0.12f); }
    g->opacity[i] = 3.0f;
  }
  return g;
}

static double run_term(mgs_term *term, const mgs_gaussians *g, int it, mgs_gaussians *grad) {
  mgs_term_step s;
  memset(&s, 0, sizeof s);
  s.iteration = it;
  s.iterations = 10000;
  s.model = g;
  s.grad = grad;
  mgs_error err;
  CHECK(term->ops->active(term->self, it) == MGS_TERM_MODEL);
  CHECK_OK(term->ops->model_grad(term->self, &s, &err), &err);
  return s.value;
}

typedef struct { const mgs_vdb_grid *grid; int at, calls; } src_state;
static const mgs_vdb_grid *src_fn(void *user, int *iteration) {
  src_state *ss = user;
  ss->calls++;
  *iteration = ss->at;
  return ss->at > 0 ? ss->grid : NULL;
}

static void test_term_sphere(void) {
  mgs_normal_options o;
  mgs_normal_options_default(&o);
  o.from_iter = 1;
  o.every = 1000;
  o.resolution = 64;
  o.tau = 0.3;
  o.gamma = 1.0;
  mgs_term *term = NULL;
  mgs_normal_term *h = NULL;
  mgs_error err;
  CHECK_OK(mgs_term_normal_create(&o, &term, &h, &err), &err);
  if (!term) return;
  const size_t n = 1500;
  mgs_gaussians *good = sphere_model(n, 0), *bad = sphere_model(n, 1);
  mgs_gaussians *gr = model(n);
  double vg = run_term(term, good, 1, gr);
  int at, builds;
  CHECK(mgs_term_normal_sdf(h, &at, &builds) != NULL && at == 1 && builds == 1);
  {
    /* why tensors: at the means of a thin shell the interpolated ∇d nearly cancels */
    const mgs_vdb_grid *sdf = mgs_term_normal_sdf(h, NULL, NULL);
    float *gv = malloc(n * 3 * sizeof(float)), *T = malloc(n * 6 * sizeof(float));
    mgs_vdb_sample_gradient(sdf, n, good->mean, gv, NULL);
    mgs_normal_tensors(sdf, good, T);
    double mg = 0, mt = 0, align = 0;
    size_t weak = 0, used = 0;
    for (size_t i = 0; i < n; i++) {
      double l = sqrt(gv[3 * i] * gv[3 * i] + gv[3 * i + 1] * gv[3 * i + 1] + gv[3 * i + 2] * gv[3 * i + 2]);
      mg += l / (double)n;
      mt += (T[6 * i] + T[6 * i + 3] + T[6 * i + 5]) / (double)n;
      weak += l < 0.5;
      if (l > 0) align += fabs(gv[3 * i] * good->mean[3 * i] + gv[3 * i + 1] * good->mean[3 * i + 1] + gv[3 * i + 2] * good->mean[3 * i + 2]) / l / (double)n;
    }
    double v;
    mgs_normal_loss(good, T, 1.0, 1.0, NULL, &v, &used, NULL);
    fprintf(stderr, "  shell of flat Gaussians: mean |grad d(mu)| %.3f (%zu of %zu below 0.5; |cos| to radial %.3f), mean tr T %.3f, %zu in the tensor loss\n",
            mg, weak, n, align, mt, used);
    CHECK(used == n);
    free(gv);
    free(T);
  }
  double vb = run_term(term, bad, 2, gr); /* same grid (built from the good model) */
  CHECK(mgs_term_normal_sdf(h, &at, &builds) && builds == 1);
  fprintf(stderr, "  sphere: aligned %.4f, misaligned %.4f\n", vg, vb);
  CHECK(vg < 0.05);
  CHECK(vb > 0.8);
  /* plain gradient descent on rotation and scale lowers the misaligned loss */
  double v0 = vb;
  for (int step = 0; step < 30; step++) {
    memset(gr->rot, 0, 4 * n * sizeof(float));
    memset(gr->log_scale, 0, 3 * n * sizeof(float));
    run_term(term, bad, 3 + step, gr);
    for (size_t i = 0; i < 4 * n; i++) bad->rot[i] -= 0.05f * (float)n * gr->rot[i];
    for (size_t i = 0; i < 3 * n; i++) bad->log_scale[i] -= 0.05f * (float)n * gr->log_scale[i];
  }
  double v1 = run_term(term, bad, 40, gr);
  {
    double t0 = mgs_now();
    for (int k = 0; k < 10; k++) run_term(term, bad, 40, gr);
    double t1 = mgs_now();
    float *T = malloc(n * 6 * sizeof(float));
    mgs_normal_tensors(mgs_term_normal_sdf(h, NULL, NULL), bad, T);
    double t2 = mgs_now();
    free(T);
    fprintf(stderr, "  cost: %.1f us per Gaussian per cached call, %.1f us per Gaussian to refresh a tensor\n",
            1e6 * (t1 - t0) / 10 / (double)n, 1e6 * (t2 - t1) / (double)n);
  }
  fprintf(stderr, "  descent: %.4f -> %.4f\n", v0, v1);
  CHECK(v1 < 0.5 * v0);
  /* checkpoint state round trip: the same grid comes back */
  FILE *f = tmpfile();
  CHECK_OK(term->ops->save(term->self, f, &err), &err);
  rewind(f);
  mgs_term *t2 = NULL;
  mgs_normal_term *h2 = NULL;
  CHECK_OK(mgs_term_normal_create(&o, &t2, &h2, &err), &err);
  CHECK_OK(t2->ops->load(t2->self, f, &err), &err);
  fclose(f);
  int at2, b2;
  const mgs_vdb_grid *s1 = mgs_term_normal_sdf(h, &at, &builds), *s2 = mgs_term_normal_sdf(h2, &at2, &b2);
  CHECK(s2 && at2 == at && b2 == builds);
  if (s1 && s2) {
    CHECK(mgs_vdb_grid_active_voxel_count(s1) == mgs_vdb_grid_active_voxel_count(s2));
    float v1s[8], v2s[8], pts[24];
    for (int k = 0; k < 24; k++) pts[k] = (float)(0.9 * sin(1.3 * k));
    mgs_vdb_sample(s1, 8, pts, v1s);
    mgs_vdb_sample(s2, 8, pts, v2s);
    for (int k = 0; k < 8; k++) CHECK(v1s[k] == v2s[k]);
  }
  /* the tensor cache came along: both terms give the same value and gradient */
  {
    mgs_gaussians *g1 = model(n), *g2 = model(n);
    double a1 = run_term(term, bad, 41, g1), a2 = run_term(t2, bad, 41, g2);
    CHECK(a1 == a2);
    CHECK(memcmp(g1->rot, g2->rot, 4 * n * sizeof(float)) == 0);
    mgs_gaussians_destroy(g1);
    mgs_gaussians_destroy(g2);
  }
  /* a source (the Morse analysis' grid in training): the term copies each new grid in,
     builds none of its own, and gives the value of a term that built the same grid */
  {
    src_state ss = {mgs_term_normal_sdf(h, NULL, NULL), -1, 0};
    mgs_term *t4 = NULL;
    mgs_normal_term *h4 = NULL;
    mgs_normal_options o4 = o;
    o4.every = 1; /* would rebuild every iteration without the source */
    CHECK_OK(mgs_term_normal_create(&o4, &t4, &h4, &err), &err);
    if (t4) {
      mgs_term_normal_set_source(h4, src_fn, &ss);
      mgs_gaussians *g4 = model(n), *g1 = model(n);
      CHECK(run_term(t4, bad, 5, g4) == 0 && mgs_term_normal_sdf(h4, NULL, NULL) == NULL); /* none yet */
      ss.at = 3;
      double a4 = run_term(t4, bad, 6, g4), a1 = run_term(term, bad, 6, g1);
      run_term(t4, bad, 7, g4);
      int at4, b4;
      CHECK(mgs_term_normal_sdf(h4, &at4, &b4) != NULL && at4 == 3 && b4 == 0 && ss.calls == 3);
      CHECK(fabs(a4 - a1) < 1e-12);
      ss.at = 9; /* a newer analysis: taken at the next call */
      run_term(t4, bad, 9, g4);
      CHECK(mgs_term_normal_sdf(h4, &at4, &b4) != NULL && at4 == 9 && b4 == 0);
      mgs_gaussians_destroy(g4);
      mgs_gaussians_destroy(g1);
      mgs_term_destroy(t4);
    }
  }
  /* bad options: one line naming the flag */
  o.gamma = -1;
  mgs_term *t3 = NULL;
  CHECK(mgs_term_normal_create(&o, &t3, NULL, &err) == MGS_ERR_ARG && strstr(err.msg, "--normal-loss"));
  mgs_term_destroy(t2);
  mgs_term_destroy(term);
  mgs_gaussians_destroy(gr);
  mgs_gaussians_destroy(good);
  mgs_gaussians_destroy(bad);
}

int main(void) {
  RUN(test_fd);
  RUN(test_definition);
  RUN(test_term_sphere);
  return mgs_test_finish();
}

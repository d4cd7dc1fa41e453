/* L_topo alone on a small controlled scene (issue 14 acceptance): a cluster of random
 * Gaussians whose SDF has many short bars. One analysis fixes the pairing; plain
 * gradient steps on L_topo through the trainer's term interface (model_grad) then move
 * the Gaussians. `eliminate` must shorten the bars below ε_sig (the tracked total
 * persistence falls, and so does the one of a fresh analysis); the seed's `literal`
 * formula must lengthen them. Also: the term's re-evaluated bar ends equal the analysis'
 * values on the unchanged model, and its gradient matches central differences of its
 * own (fixed-pairing) loss along the gradient direction and, group by group, along
 * directions with the gradient's signs and random magnitudes (which also catch a group
 * dropped or scattered to the wrong Gaussians). */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <stdio.h>
#include <string.h>
#include "mgs_test.h"
#include "train/synth.h"
#include "train/mgs_morse.h"
#include "train/mgs_term.h"

static mgs_gaussians *scene(void) {
  mgs_gaussians *g = synth_model(60, 5);
  for (size_t i = 0; i < g->n; i++) g->opacity[i] = mgs_logitf(0.45f + 0.1f * (float)(i % 5) / 4.0f);
  return g;
}

static void options(mgs_morse_options *o, mgs_morse_topo kind) {
  mgs_morse_options_default(o);
  o->topo = kind;
  o->warmup = 1; o->every = 1000000; o->until = 1;
  o->resolution = 64;
  o->eps_sig = 0.05;
  o->beta = 1.0;
}

/* Fresh analysis: total persistence of the finite bars shorter than eps (world). */
static double fresh_short(mgs_gaussians *g, mgs_morse_topo kind, double eps_rel) {
  mgs_morse_options o;
  options(&o, kind);
  mgs_morse_ctx *c = NULL;
  mgs_error err;
  double s = 0;
  if (mgs_morse_ctx_create(&o, NULL, &c, &err) == MGS_OK && mgs_morse_analyze(c, g, 1, &err) == MGS_OK) {
    const mgs_morse_result *r = mgs_morse_ctx_result(c);
    for (size_t k = 0; k < r->n; k++) {
      const mgs_pair *p = &r->pairs[k].p;
      double pe = p->death - p->birth;
      if (isfinite(pe) && pe < eps_rel * r->diagonal && !p->truncated) s += pe;
    }
  } else CHECK_MSG(0, "%s", err.msg);
  mgs_morse_ctx_unref(c);
  return s;
}

static void zero(mgs_gaussians *gr, size_t n) {
  gr->n = n;
  for (int k = 0; k < MGS_PARAM_COUNT; k++)
    memset(mgs_gaussians_group(gr, (mgs_param_group)k), 0, n * (size_t)mgs_param_dim((mgs_param_group)k) * sizeof(float));
}

static void run(mgs_morse_topo kind) {
  mgs_gaussians *g = scene(), *gr = mgs_gaussians_create(g->n, g->sh_degree);
  mgs_morse_options o;
  options(&o, kind);
  mgs_morse_ctx *c = NULL;
  mgs_term *t = NULL;
  mgs_error err;
  CHECK_OK(mgs_morse_ctx_create(&o, NULL, &c, &err), &err);
  CHECK_OK(mgs_term_topo_create(c, 1, &t, &err), &err);
  double fresh0 = fresh_short(g, kind, o.eps_sig);
  mgs_term_step s;
  memset(&s, 0, sizeof s);
  s.model = g; s.grad = gr; s.iterations = 1000;
  double L0 = 0, P0 = 0, L = 0, P = 0;
  for (int it = 1; it <= 60; it++) {
    s.iteration = it;
    zero(gr, g->n);
    CHECK(t->ops->active(t->self, it) == MGS_TERM_MODEL);
    CHECK_OK(t->ops->model_grad(t->self, &s, &err), &err);
    if (it == 1) {
      CHECK_OK(mgs_term_topo_eval(c, g, &L0, &P0, &err), &err);
      const mgs_morse_result *r = mgs_morse_ctx_result(c);
      size_t ends = 0;
      for (size_t k = 0; k < r->n; k++) ends += (size_t)(r->pairs[k].has_cb + r->pairs[k].has_cd);
      fprintf(stderr, "%s: %zu pairs, %zu movable ends, loss %.4g, tracked short persistence %.4f, fresh %.4f\n",
              kind == MGS_MORSE_TOPO_LITERAL ? "literal" : "eliminate", r->n, ends, L0, P0, fresh0);
      CHECK(ends > 4);
      CHECK_NEAR(s.value, L0, 1e-9 * (1 + L0)); /* beta = 1 */
    }
    /* a normalized gradient step: at most 0.002 (world / log-scale / logit) per value */
    double mx = 0;
    for (int k = 0; k < MGS_PARAM_SH_DC; k++) {
      float *p = mgs_gaussians_group(gr, (mgs_param_group)k);
      for (size_t i = 0; i < g->n * (size_t)mgs_param_dim((mgs_param_group)k); i++) mx = fmax(mx, fabs(p[i]));
    }
    if (!(mx > 0)) break;
    for (int k = 0; k < MGS_PARAM_SH_DC; k++) {
      float *p = mgs_gaussians_group(g, (mgs_param_group)k), *d = mgs_gaussians_group(gr, (mgs_param_group)k);
      for (size_t i = 0; i < g->n * (size_t)mgs_param_dim((mgs_param_group)k); i++) p[i] -= (float)(0.002 / mx * d[i]);
    }
  }
  CHECK_OK(mgs_term_topo_eval(c, g, &L, &P, &err), &err);
  double fresh1 = fresh_short(g, kind, o.eps_sig);
  fprintf(stderr, "  after 60 steps: loss %.4g, tracked short persistence %.4f (was %.4f), fresh %.4f (was %.4f)\n", L, P, P0,
          fresh1, fresh0);
  CHECK(L < L0);
  if (kind == MGS_MORSE_TOPO_ELIMINATE) {
    CHECK(P < 0.8 * P0);       /* the short bars shorten */
    CHECK(fresh1 < fresh0);    /* and the true diagram agrees */
  } else {
    CHECK(P > 1.1 * P0);       /* the printed formula lengthens them */
  }
  mgs_term_destroy(t);
  mgs_morse_ctx_unref(c);
  mgs_gaussians_destroy(g);
  mgs_gaussians_destroy(gr);
}

static void eliminate(void) { run(MGS_MORSE_TOPO_ELIMINATE); }
static void literal(void) { run(MGS_MORSE_TOPO_LITERAL); }

/* The scene, one analysis of it (eliminate) and the term's gradient at its iteration. */
typedef struct grad_fixture {
  mgs_gaussians *g, *gr;
  mgs_morse_ctx *c;
  mgs_term *t;
} grad_fixture;

static grad_fixture term_gradient(void) {
  grad_fixture f = {scene(), NULL, NULL, NULL};
  f.gr = mgs_gaussians_create(f.g->n, f.g->sh_degree);
  mgs_morse_options o;
  options(&o, MGS_MORSE_TOPO_ELIMINATE);
  mgs_error err;
  CHECK_OK(mgs_morse_ctx_create(&o, NULL, &f.c, &err), &err);
  CHECK_OK(mgs_term_topo_create(f.c, 1, &f.t, &err), &err);
  mgs_term_step s;
  memset(&s, 0, sizeof s);
  s.model = f.g; s.grad = f.gr; s.iteration = 1; s.iterations = 10;
  zero(f.gr, f.g->n);
  CHECK_OK(f.t->ops->model_grad(f.t->self, &s, &err), &err);
  return f;
}

static void fixture_free(grad_fixture *f) {
  mgs_term_destroy(f->t);
  mgs_morse_ctx_unref(f->c);
  mgs_gaussians_destroy(f->g);
  mgs_gaussians_destroy(f->gr);
}

/* Central differences of the term's fixed-pairing loss along dir (per group; NULL: that
   group stays), step h. */
static double fd_along(const grad_fixture *f, double *const dir[MGS_PARAM_SH_DC], double h) {
  mgs_gaussians *gp = mgs_gaussians_clone(f->g), *gm = mgs_gaussians_clone(f->g);
  for (int k = 0; k < MGS_PARAM_SH_DC; k++) {
    if (!dir[k]) continue;
    float *a = mgs_gaussians_group(gp, (mgs_param_group)k), *b = mgs_gaussians_group(gm, (mgs_param_group)k);
    for (size_t i = 0; i < f->g->n * (size_t)mgs_param_dim((mgs_param_group)k); i++) {
      a[i] += (float)(h * dir[k][i]);
      b[i] -= (float)(h * dir[k][i]);
    }
  }
  double Lp = 0, Lm = 0, P;
  mgs_error err;
  CHECK_OK(mgs_term_topo_eval(f->c, gp, &Lp, &P, &err), &err);
  CHECK_OK(mgs_term_topo_eval(f->c, gm, &Lm, &P, &err), &err);
  mgs_gaussians_destroy(gp);
  mgs_gaussians_destroy(gm);
  return (Lp - Lm) / (2 * h);
}

/* The term's gradient against central differences of its fixed-pairing loss along the
 * gradient direction (the directional derivative), on the mean, scale and opacity groups
 * together (rotation: group_fd below). */
static void directional_fd(void) {
  grad_fixture f = term_gradient();
  double gg = 0, *dir[MGS_PARAM_SH_DC] = {NULL};
  for (int k = 0; k < MGS_PARAM_SH_DC; k++) {
    if (k == MGS_PARAM_ROT) continue;
    const size_t m = f.g->n * (size_t)mgs_param_dim((mgs_param_group)k);
    const float *d = mgs_gaussians_group(f.gr, (mgs_param_group)k);
    dir[k] = calloc(m, sizeof(double));
    for (size_t i = 0; i < m; i++) { dir[k][i] = d[i]; gg += (double)d[i] * d[i]; }
  }
  CHECK(gg > 0);
  double fd = fd_along(&f, dir, 1e-3 / sqrt(gg));
  fprintf(stderr, "directional derivative: analytic %.6g, central differences %.6g\n", gg, fd);
  CHECK(fabs(fd - gg) < 0.05 * gg);
  for (int k = 0; k < MGS_PARAM_SH_DC; k++) free(dir[k]);
  fixture_free(&f);
}

/* Per parameter group, the term's gradient against central differences of its fixed-pairing
 * loss along a direction that has the gradient's signs with random magnitudes: a group whose
 * gradient the term drops or scatters to the wrong rows gives a derivative the differences
 * do not see (the direction along the gradient itself cannot tell: it drops both sides). */
static void group_fd(void) {
  grad_fixture f = term_gradient();
  uint64_t rs = 12345;
  static const char *const names[] = {"mean", "log_scale", "rot", "opacity"};
  for (int k = 0; k < MGS_PARAM_SH_DC; k++) {
    const size_t m = f.g->n * (size_t)mgs_param_dim((mgs_param_group)k);
    const float *d = mgs_gaussians_group(f.gr, (mgs_param_group)k);
    double *dir[MGS_PARAM_SH_DC] = {NULL}, a = 0, dmax = 0;
    dir[k] = calloc(m, sizeof(double));
    for (size_t i = 0; i < m; i++) {
      rs = rs * 6364136223846793005ULL + 1442695040888963407ULL;
      double u = 0.5 + (double)(rs >> 11) / 9007199254740992.0;
      dir[k][i] = d[i] > 0 ? u : d[i] < 0 ? -u : 0;
      a += dir[k][i] * d[i];
      dmax = fmax(dmax, fabs(d[i]));
    }
    CHECK_MSG(a > 0, "the term gives group %s no gradient", names[k]);
    /* a step of at most 2e-4 per value (world units, log-scale, quaternion, logit) */
    double fd = fd_along(&f, dir, 2e-4);
    fprintf(stderr, "group %-9s: analytic %.6g, central differences %.6g (largest gradient %.3g)\n", names[k], a, fd, dmax);
    CHECK_MSG(fabs(fd - a) < 0.05 * a, "group %s: analytic %g, central differences %g", names[k], a, fd);
    free(dir[k]);
  }
  fixture_free(&f);
}

/* A strategy that replaces every Gaussian (Mini-Splatting's reinitialisations) makes the
 * analysis of the old model void: the term is off from the next iteration until the next
 * analysis, and stays so across a checkpoint; a run without replacement writes the same
 * checkpoint bytes as before the notice existed. */
static void replaced(void) {
  mgs_gaussians *g = scene(), *gr = mgs_gaussians_create(g->n, g->sh_degree);
  mgs_morse_options o;
  options(&o, MGS_MORSE_TOPO_ELIMINATE);
  o.warmup = 1; o.every = 10; o.until = 21; /* analyses at 1, 11, 21 */
  mgs_morse_ctx *c = NULL, *c2 = NULL;
  mgs_term *t = NULL, *t2 = NULL;
  mgs_error err;
  CHECK_OK(mgs_morse_ctx_create(&o, NULL, &c, &err), &err);
  CHECK_OK(mgs_term_topo_create(c, 1, &t, &err), &err);
  mgs_term_step s;
  memset(&s, 0, sizeof s);
  s.model = g; s.grad = gr; s.iterations = 100; s.iteration = 1;
  zero(gr, g->n);
  CHECK(t->ops->active(t->self, 1) == MGS_TERM_MODEL);
  CHECK_OK(t->ops->model_grad(t->self, &s, &err), &err);
  CHECK(t->ops->active(t->self, 2) == MGS_TERM_MODEL); /* the analysis of 1 guides 2..10 */
  /* the checkpoint without a replacement: the byte that says so is the plain owner flag */
  char *buf = NULL;
  size_t len = 0;
  FILE *f = open_memstream(&buf, &len);
  CHECK_OK(t->ops->save(t->self, f, &err), &err);
  fclose(f);
  CHECK(len > 0 && buf && (unsigned char)buf[0] == 1);
  free(buf);
  CHECK(t->ops->model_replaced != NULL);
  t->ops->model_replaced(t->self, 5);
  for (int it = 6; it <= 10; it++) CHECK_MSG(t->ops->active(t->self, it) == 0, "active at %d after the replacement at 5", it);
  CHECK(t->ops->active(t->self, 11) == MGS_TERM_MODEL); /* the next analysis */
  /* across a checkpoint: a fresh term loading the state is off too */
  f = open_memstream(&buf, &len);
  CHECK_OK(t->ops->save(t->self, f, &err), &err);
  fclose(f);
  CHECK(len > 5 && (unsigned char)buf[0] == (1 | 0x80));
  CHECK_OK(mgs_morse_ctx_create(&o, NULL, &c2, &err), &err);
  CHECK_OK(mgs_term_topo_create(c2, 1, &t2, &err), &err);
  f = fmemopen(buf, len, "rb");
  CHECK_OK(t2->ops->load(t2->self, f, &err), &err);
  fclose(f);
  free(buf);
  CHECK(t2->ops->active(t2->self, 7) == 0 && t2->ops->active(t2->self, 11) == MGS_TERM_MODEL);
  /* the analysis at 11 makes it guide again */
  s.iteration = 11;
  zero(gr, g->n);
  CHECK_OK(t->ops->model_grad(t->self, &s, &err), &err);
  CHECK(t->ops->active(t->self, 12) == MGS_TERM_MODEL);
  mgs_term_destroy(t);
  mgs_term_destroy(t2);
  mgs_morse_ctx_unref(c);
  mgs_morse_ctx_unref(c2);
  mgs_gaussians_destroy(g);
  mgs_gaussians_destroy(gr);
}

int main(void) {
  mgs_parallel_set_threads(1);
  RUN(replaced);
  RUN(directional_fd);
  RUN(group_fd);
  RUN(eliminate);
  RUN(literal);
  return mgs_test_finish();
}

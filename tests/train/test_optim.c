/* Adam (hand-computed steps, moments following compaction/append), the reference ADC
 * (clone / split / prune / opacity reset on hand-made inputs) and initialization (kNN
 * scales against brute force). */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "mgs_test.h"
#include "train/mgs_train.h"
#include "train/adam_internal.h"
#include "train/mgs_strategy.h"
#include "core/mgs_math.h"

static mgs_gaussians *model(size_t n) {
  mgs_gaussians *g = mgs_gaussians_create(n, 3);
  size_t first;
  mgs_gaussians_append(g, n, &first, NULL);
  return g;
}

/* every float of row i in every group = i + off */
static void tag_rows(float *const groups[MGS_PARAM_COUNT], size_t n, float off) {
  for (int k = 0; k < MGS_PARAM_COUNT; k++) {
    int d = mgs_param_dim((mgs_param_group)k);
    for (size_t i = 0; i < n; i++)
      for (int j = 0; j < d; j++) groups[k][i * d + j] = (float)i + off;
  }
}

static void test_adam_hand_values(void) {
  mgs_gaussians *g = model(2), *gr = model(2);
  mgs_adam *a = mgs_adam_create(2);
  a->lr[MGS_PARAM_OPACITY] = 0.1f;
  g->opacity[0] = 1.0f; g->opacity[1] = 1.0f;
  gr->opacity[0] = 0.5f; gr->opacity[1] = -2.0f;
  mgs_error err;
  /* first Adam step moves every parameter by lr against the gradient's sign */
  CHECK_OK(mgs_adam_step(a, g, gr, 1u << MGS_PARAM_OPACITY, &err), &err);
  CHECK_NEAR(g->opacity[0], 0.9, 1e-5);
  CHECK_NEAR(g->opacity[1], 1.1, 1e-5);
  /* same gradient again: m_hat = g, v_hat = g^2 -> again lr */
  CHECK_OK(mgs_adam_step(a, g, gr, 1u << MGS_PARAM_OPACITY, &err), &err);
  CHECK_NEAR(g->opacity[0], 0.8, 1e-5); /* float arithmetic */
  /* a third step with another gradient, by hand: m = .9 m + .1 g, v = .999 v + .001 g^2 */
  gr->opacity[0] = -1.0f;
  double m = 0.1 * 0.5, v = 0.001 * 0.25;
  m = 0.9 * m + 0.1 * 0.5; v = 0.999 * v + 0.001 * 0.25;
  m = 0.9 * m + 0.1 * -1.0; v = 0.999 * v + 0.001 * 1.0;
  double expect = 0.8 - 0.1 * (m / (1 - pow(0.9, 3))) / (sqrt(v / (1 - pow(0.999, 3))) + 1e-15);
  CHECK_OK(mgs_adam_step(a, g, gr, 1u << MGS_PARAM_OPACITY, &err), &err);
  CHECK_NEAR(g->opacity[0], expect, 1e-5);
  CHECK(a->t[MGS_PARAM_OPACITY] == 3);
  /* groups outside the mask are untouched and keep their step count */
  CHECK(a->t[MGS_PARAM_MEAN] == 0);
  CHECK(g->mean[0] == 0.0f);
  /* a gradient of exactly zero leaves a fresh parameter where it is */
  a->lr[MGS_PARAM_MEAN] = 1.0f;
  CHECK_OK(mgs_adam_step(a, g, gr, 1u << MGS_PARAM_MEAN, &err), &err);
  CHECK(g->mean[0] == 0.0f);
  mgs_adam_destroy(a); mgs_gaussians_destroy(g); mgs_gaussians_destroy(gr);
}

/* Before SH degree 3 only the active rest coefficients are stepped (the others have zero
 * moments and would not move anyway). */
static void test_adam_sh_rest_active(void) {
  mgs_gaussians *g = model(3), *gr = model(3);
  mgs_adam *a = mgs_adam_create(3);
  a->lr[MGS_PARAM_SH_REST] = 0.01f;
  a->sh_rest_active = 3; /* degree 1 */
  for (size_t i = 0; i < 3 * 45; i++) gr->sh_rest[i] = 1.0f;
  mgs_error err;
  CHECK_OK(mgs_adam_step(a, g, gr, 1u << MGS_PARAM_SH_REST, &err), &err);
  int ok = 1;
  for (size_t i = 0; i < 3; i++)
    for (int k = 0; k < 45; k++) ok &= k < 9 ? fabsf(g->sh_rest[45 * i + k] + 0.01f) < 1e-6f : g->sh_rest[45 * i + k] == 0.0f;
  CHECK(ok);
  mgs_adam_destroy(a); mgs_gaussians_destroy(g); mgs_gaussians_destroy(gr);
}

static void test_adam_nonfinite_names_group(void) {
  mgs_gaussians *g = model(3), *gr = model(3);
  mgs_adam *a = mgs_adam_create(3);
  for (int k = 0; k < MGS_PARAM_COUNT; k++) a->lr[k] = 0.01f;
  gr->log_scale[3 * 2 + 1] = NAN;
  mgs_error err;
  mgs_error_clear(&err);
  CHECK(mgs_adam_step(a, g, gr, 0x3f, &err) == MGS_ERR_NUMERIC);
  CHECK_MSG(strstr(err.msg, "log_scale") != NULL, "message: %s", err.msg);
  CHECK_MSG(strstr(err.msg, "Gaussian 2") != NULL, "message: %s", err.msg);
  mgs_adam_destroy(a); mgs_gaussians_destroy(g); mgs_gaussians_destroy(gr);
}

static void test_moments_follow_rows(void) {
  size_t n = 7;
  mgs_gaussians *g = model(n);
  mgs_adam *a = mgs_adam_create(n);
  float *pg[MGS_PARAM_COUNT];
  for (int k = 0; k < MGS_PARAM_COUNT; k++) pg[k] = mgs_gaussians_group(g, (mgs_param_group)k);
  tag_rows(pg, n, 0.0f);
  tag_rows(a->m, n, 0.25f);
  tag_rows(a->v, n, 0.5f);
  uint8_t keep[7] = {0, 1, 1, 0, 1, 0, 1};
  CHECK(mgs_model_compact(g, a, keep) == 4);
  CHECK(a->n == 4 && g->n == 4);
  size_t first = 0;
  mgs_error err;
  CHECK_OK(mgs_model_append(g, a, 100, &first, &err), &err); /* forces growth */
  CHECK(first == 4 && g->n == 104 && a->n == 104);
  int aligned = 1, fresh = 1;
  for (int k = 0; k < MGS_PARAM_COUNT; k++) {
    int d = mgs_param_dim((mgs_param_group)k);
    float *p = mgs_gaussians_group(g, (mgs_param_group)k);
    for (size_t i = 0; i < 4; i++)
      for (int j = 0; j < d; j++)
        aligned &= a->m[k][i * d + j] == p[i * d + j] + 0.25f && a->v[k][i * d + j] == p[i * d + j] + 0.5f &&
                   (p[i * d + j] == 1 || p[i * d + j] == 2 || p[i * d + j] == 4 || p[i * d + j] == 6);
    for (size_t i = 4; i < 104; i++)
      for (int j = 0; j < d; j++) fresh &= a->m[k][i * d + j] == 0 && a->v[k][i * d + j] == 0;
  }
  CHECK(aligned);
  CHECK(fresh);
  CHECK(g->rot[4 * 50] == 1.0f); /* appended Gaussians: identity rotation */
  mgs_adam_destroy(a); mgs_gaussians_destroy(g);
}

static void test_expon_lr(void) {
  CHECK_NEAR(mgs_expon_lr(0, 1.6e-4, 1.6e-6, 30000), 1.6e-4, 1e-12);
  CHECK_NEAR(mgs_expon_lr(30000, 1.6e-4, 1.6e-6, 30000), 1.6e-6, 1e-12);
  CHECK_NEAR(mgs_expon_lr(60000, 1.6e-4, 1.6e-6, 30000), 1.6e-6, 1e-12);
  CHECK_NEAR(mgs_expon_lr(15000, 1.6e-4, 1.6e-6, 30000), 1.6e-5, 1e-11); /* geometric mean */
}

/* Hand-made ADC input, extent 1, threshold 2e-4:
 * 0 big gradient, small scale -> cloned;  1 big gradient, large scale -> split in 2;
 * 2 small gradient -> untouched;  3 alpha 0.001 -> pruned;
 * 4 huge on screen (radius 30), 5 large in the world (0.2): pruned only with prune_big. */
static void test_adc_clone_split_prune(void) {
  mgs_adc_options o;
  mgs_adc_options_default(&o);
  for (int prune_big = 0; prune_big <= 1; prune_big++) {
    mgs_strategy *s = mgs_strategy_adc_create(&o);
    mgs_gaussians *g = model(6);
    mgs_adam *a = mgs_adam_create(6);
    float *pg[MGS_PARAM_COUNT];
    tag_rows(a->m, 6, 0.25f);
    (void)pg;
    float scales[6] = {0.001f, 0.05f, 0.001f, 0.001f, 0.001f, 0.2f};
    for (int i = 0; i < 6; i++) {
      for (int k = 0; k < 3; k++) { g->mean[3 * i + k] = (float)i; g->log_scale[3 * i + k] = logf(scales[i]); }
      g->log_scale[3 * 1 + 2] = logf(0.02f); /* anisotropic */
      g->opacity[i] = mgs_logitf(i == 3 ? 0.001f : 0.5f);
      g->sh_dc[3 * i] = 0.1f * (float)i;
    }
    mgs_adc_state *st = mgs_strategy_adc_state(s, 6);
    CHECK(st && st->n == 6);
    float acc[6] = {3e-3f, 3e-3f, 1e-4f, 1e-4f, 1e-4f, 1e-4f};
    for (int i = 0; i < 6; i++) { st->grad_accum[i] = acc[i]; st->count[i] = 10; st->max_radii[i] = i == 4 ? 30 : 5; }
    mgs_rng rng; mgs_rng_init(&rng, 9, 0);
    mgs_error err;
    CHECK_OK(mgs_adc_densify_and_prune(s, g, a, 1.0, prune_big, &rng, &err), &err);
    /* survivors in order, then the clone, then the two split samples */
    size_t expect_n = prune_big ? 5 : 7;
    CHECK_MSG(g->n == expect_n && a->n == expect_n, "n = %zu", g->n);
    if (g->n == expect_n) {
      size_t base = prune_big ? 1 : 3; /* rows before the clone: 0, 2 [, 4, 5] */
      CHECK(g->mean[0] == 0.0f && g->mean[3] == 2.0f);
      if (!prune_big) CHECK(g->mean[6] == 4.0f && g->mean[9] == 5.0f);
      size_t c = base + 1;
      CHECK(g->mean[3 * c] == 0.0f && g->log_scale[3 * c] == logf(0.001f) && g->sh_dc[3 * c] == 0.0f); /* clone of 0 */
      for (size_t k = c + 1; k < c + 3; k++) {
        CHECK_NEAR(g->log_scale[3 * k], logf(0.05f / 1.6f), 1e-6);
        CHECK_NEAR(g->log_scale[3 * k + 2], logf(0.02f / 1.6f), 1e-6);
        CHECK_NEAR(g->sh_dc[3 * k], 0.1f, 1e-7);
        CHECK_NEAR(mgs_sigmoidf(g->opacity[k]), 0.5, 1e-6);
        CHECK(fabsf(g->mean[3 * k] - 1.0f) < 0.3f && fabsf(g->mean[3 * k + 2] - 1.0f) < 0.12f);
        CHECK(g->mean[3 * k] != 1.0f); /* actually sampled */
      }
      /* moments follow: survivors keep their tags (row 0 -> 0.25, row 2 -> 2.25), new rows 0 */
      CHECK(a->m[MGS_PARAM_MEAN][0] == 0.25f && a->m[MGS_PARAM_MEAN][3] == 2.25f);
      if (!prune_big) CHECK(a->m[MGS_PARAM_OPACITY][2] == 4.25f && a->m[MGS_PARAM_OPACITY][3] == 5.25f);
      for (size_t k = c; k < c + 3; k++) CHECK(a->m[MGS_PARAM_SH_REST][45 * k] == 0.0f && a->v[MGS_PARAM_ROT][4 * k] == 0.0f);
    }
    st = mgs_strategy_adc_state(s, g->n);
    CHECK(st && st->n == g->n && st->count[0] == 0 && st->grad_accum[0] == 0.0f); /* reset */
    mgs_adam_destroy(a); mgs_gaussians_destroy(g); mgs_strategy_destroy(s);
  }
}

/* Split samples follow the parent's covariance R S^2 R^T. */
static void test_adc_split_distribution(void) {
  mgs_adc_options o;
  mgs_adc_options_default(&o);
  mgs_strategy *s = mgs_strategy_adc_create(&o);
  size_t n = 4000;
  mgs_gaussians *g = model(n);
  float q[4] = {0.9f, 0.3f, -0.2f, 0.25f}, sc[3] = {0.3f, 0.1f, 0.05f};
  for (size_t i = 0; i < n; i++) {
    memcpy(g->rot + 4 * i, q, sizeof q);
    for (int k = 0; k < 3; k++) g->log_scale[3 * i + k] = logf(sc[k]);
    g->opacity[i] = 0.0f;
  }
  mgs_adc_state *st = mgs_strategy_adc_state(s, n);
  for (size_t i = 0; i < n; i++) { st->grad_accum[i] = 1.0f; st->count[i] = 1; }
  mgs_rng rng; mgs_rng_init(&rng, 4, 0);
  mgs_error err;
  CHECK_OK(mgs_adc_densify_and_prune(s, g, NULL, 1.0, 0, &rng, &err), &err);
  CHECK(g->n == 2 * n);
  double C[9] = {0};
  for (size_t i = 0; i < g->n; i++)
    for (int r = 0; r < 3; r++)
      for (int c = 0; c < 3; c++) C[3 * r + c] += (double)g->mean[3 * i + r] * g->mean[3 * i + c] / (double)g->n;
  float R[9];
  mgs_quat_to_mat3f(q, R);
  double worst = 0;
  for (int r = 0; r < 3; r++)
    for (int c = 0; c < 3; c++) {
      double e = 0;
      for (int k = 0; k < 3; k++) e += R[3 * r + k] * sc[k] * sc[k] * R[3 * c + k];
      worst = fmax(worst, fabs(C[3 * r + c] - e));
    }
  CHECK_MSG(worst < 0.1 * 0.09, "covariance error %g", worst);
  mgs_gaussians_destroy(g); mgs_strategy_destroy(s);
}

static void test_adc_hooks_accumulate_and_reset(void) {
  mgs_adc_options o;
  mgs_adc_options_default(&o);
  mgs_strategy *s = mgs_strategy_adc_create(&o);
  mgs_gaussians *g = model(3), *gr = model(3);
  mgs_adam *a = mgs_adam_create(3);
  g->opacity[0] = mgs_logitf(0.5f); g->opacity[1] = mgs_logitf(0.001f); g->opacity[2] = mgs_logitf(0.02f);
  tag_rows(a->m, 3, 1.0f);
  float gm[3] = {1e-3f, 2e-3f, 5e-3f};
  int radii[3] = {4, 0, 9};
  mgs_rng rng; mgs_rng_init(&rng, 1, 0);
  mgs_strategy_step ss;
  memset(&ss, 0, sizeof ss);
  ss.model = g; ss.adam = a; ss.grad = gr; ss.grad_mean2d = gm; ss.radii = radii; ss.extent = 1; ss.rng = &rng;
  ss.width = ss.height = 64;
  mgs_error err;
  for (int it = 1; it <= 3; it++) {
    ss.iteration = it; ss.replaced_groups = 0;
    CHECK_OK(s->ops->post_backward(s->self, &ss, &err), &err);
    CHECK(ss.replaced_groups == 0);
    radii[0] = 4 + it;
  }
  mgs_adc_state *st = mgs_strategy_adc_state(s, 3);
  CHECK(st->count[0] == 3 && st->count[1] == 0 && st->count[2] == 3); /* visible only */
  CHECK_NEAR(st->grad_accum[0], 3e-3, 1e-9);
  CHECK(st->grad_accum[1] == 0.0f);
  CHECK(st->max_radii[0] == 6 && st->max_radii[2] == 9);
  /* iteration 600 densifies (nothing visible now): clone of 0, 1 (alpha 0.001) pruned,
     the count changes and every group is replaced */
  st->grad_accum[0] = 1.0f; st->count[0] = 1;
  st->grad_accum[2] = 0.0f; st->count[2] = 0;
  radii[0] = radii[1] = radii[2] = 0;
  ss.iteration = 600; ss.replaced_groups = 0;
  g->log_scale[0] = g->log_scale[1] = g->log_scale[2] = logf(0.001f);
  CHECK_OK(s->ops->post_backward(s->self, &ss, &err), &err);
  CHECK(ss.replaced_groups == (1u << MGS_PARAM_COUNT) - 1);
  CHECK(g->n == 3 && a->n == 3);
  CHECK_NEAR(mgs_sigmoidf(g->opacity[1]), 0.02, 1e-6);
  CHECK(g->log_scale[3 * 2] == logf(0.001f)); /* the clone, last */
  /* opacity reset at 3000 (no densification at 3000 or 6000 with an interval of 7):
     min(alpha, 0.01), opacity moments zeroed; like the reference, only before densify_until */
  o.densify_until = 10000;
  o.densify_every = 7;
  mgs_strategy *s2 = mgs_strategy_adc_create(&o);
  tag_rows(a->m, 3, 1.0f);
  ss.iteration = 3000; ss.replaced_groups = 0;
  CHECK_OK(s2->ops->post_backward(s2->self, &ss, &err), &err);
  CHECK(ss.replaced_groups == (1u << MGS_PARAM_OPACITY));
  CHECK_NEAR(mgs_sigmoidf(g->opacity[0]), 0.01, 1e-6);
  CHECK_NEAR(mgs_sigmoidf(g->opacity[1]), 0.01, 1e-6);
  CHECK(a->m[MGS_PARAM_OPACITY][0] == 0.0f && a->m[MGS_PARAM_MEAN][0] == 1.0f);
  g->opacity[1] = mgs_logitf(0.001f);
  ss.iteration = 6000;
  CHECK_OK(s2->ops->post_backward(s2->self, &ss, &err), &err);
  CHECK_NEAR(mgs_sigmoidf(g->opacity[1]), 0.001, 1e-7); /* below the cap: unchanged */
  g->opacity[1] = mgs_logitf(0.5f);
  ss.iteration = 12000;
  CHECK_OK(s2->ops->post_backward(s2->self, &ss, &err), &err);
  CHECK_NEAR(mgs_sigmoidf(g->opacity[1]), 0.5, 1e-6); /* after densify_until: no reset */
  mgs_strategy_destroy(s2);
  mgs_adam_destroy(a); mgs_gaussians_destroy(g); mgs_gaussians_destroy(gr); mgs_strategy_destroy(s);
}

/* A compressed schedule (densify every 10, reset every 300, reset_prune_wait 100): the
 * densifications within 100 iterations after a reset keep transparent Gaussians, the first
 * one after that prunes them; with the wait 0 (the reference) the first one prunes. */
static void test_adc_reset_prune_wait(void) {
  for (int wait = 0; wait <= 100; wait += 100) {
    mgs_adc_options o;
    mgs_adc_options_default(&o);
    o.densify_from = 50; o.densify_until = 1500; o.densify_every = 10; o.opacity_reset_every = 300;
    o.min_opacity = 0.05f; /* 2DGS' cull, above the reset's 0.01 */
    o.reset_prune_wait = wait;
    mgs_strategy *s = mgs_strategy_adc_create(&o);
    mgs_gaussians *g = model(2), *gr = model(2);
    mgs_adam *a = mgs_adam_create(2);
    g->opacity[0] = mgs_logitf(0.5f); g->opacity[1] = mgs_logitf(0.5f);
    for (int k = 0; k < 6; k++) g->log_scale[k] = logf(0.001f); /* not too big (pruned after a reset) */
    float gm[2] = {0, 0};
    int radii[2] = {1, 1};
    mgs_rng rng; mgs_rng_init(&rng, 1, 0);
    mgs_strategy_step ss;
    memset(&ss, 0, sizeof ss);
    ss.model = g; ss.adam = a; ss.grad = gr; ss.grad_mean2d = gm; ss.radii = radii; ss.extent = 1; ss.rng = &rng;
    ss.width = ss.height = 64;
    mgs_error err;
    ss.iteration = 300; /* densify (nothing), then the reset: both at 0.01 */
    CHECK_OK(s->ops->post_backward(s->self, &ss, &err), &err);
    CHECK_NEAR(mgs_sigmoidf(g->opacity[0]), 0.01, 1e-6);
    g->opacity[0] = mgs_logitf(0.06f); /* one recovered, one did not */
    for (int it = 310; it <= 400; it += 10) {
      ss.iteration = it;
      CHECK_OK(s->ops->post_backward(s->self, &ss, &err), &err);
      size_t want = wait == 0 || it >= 400 ? 1 : 2;
      CHECK_MSG(g->n == want, "wait %d, iteration %d: %zu Gaussians, want %zu", wait, it, g->n, want);
      if (g->n != want) break;
    }
    mgs_adam_destroy(a); mgs_gaussians_destroy(g); mgs_gaussians_destroy(gr); mgs_strategy_destroy(s);
  }
}

static void test_knn_and_init(void) {
  /* a 5x5x5 lattice of spacing 0.1: every point's 3 nearest are at 0.1 */
  size_t n = 125;
  float *xyz = malloc(n * 3 * sizeof(float)), *rgb = malloc(n * 3 * sizeof(float)), *d2 = malloc(n * sizeof(float));
  for (size_t i = 0; i < n; i++) {
    xyz[3 * i] = 0.1f * (float)(i % 5); xyz[3 * i + 1] = 0.1f * (float)((i / 5) % 5); xyz[3 * i + 2] = 0.1f * (float)(i / 25);
    rgb[3 * i] = 1.0f; rgb[3 * i + 1] = 0.5f; rgb[3 * i + 2] = 0.0f;
  }
  mgs_error err;
  CHECK_OK(mgs_knn3_mean_sq(xyz, n, d2, &err), &err);
  int ok = 1;
  for (size_t i = 0; i < n; i++) ok &= fabsf(d2[i] - 0.01f) < 1e-6f;
  CHECK(ok);
  mgs_gaussians *g = NULL;
  CHECK_OK(mgs_init_from_points(xyz, rgb, n, 3, &g, &err), &err);
  if (g) {
    CHECK(g->n == n);
    CHECK_NEAR(g->log_scale[3 * 7 + 1], log(0.1), 1e-5);
    CHECK_NEAR(mgs_sigmoidf(g->opacity[9]), 0.1, 1e-6);
    CHECK_NEAR(0.5 + MGS_SH_C0 * g->sh_dc[3 * 4], 1.0, 1e-6);
    CHECK_NEAR(0.5 + MGS_SH_C0 * g->sh_dc[3 * 4 + 2], 0.0, 1e-6);
    CHECK(g->rot[4 * 3] == 1.0f && g->rot[4 * 3 + 1] == 0.0f && g->sh_rest[45 * 3 + 7] == 0.0f);
    mgs_gaussians_destroy(g);
  }
  /* random clustered cloud with an outlier and duplicates against brute force */
  mgs_rng r; mgs_rng_init(&r, 2, 0);
  n = 2000;
  float *p = malloc(n * 3 * sizeof(float)), *out = malloc(n * sizeof(float));
  for (size_t i = 0; i < n; i++)
    for (int k = 0; k < 3; k++) p[3 * i + k] = (float)(mgs_rng_normal(&r) * (k == 2 ? 0.01 : 1.0) + (i % 2 ? 5 : 0));
  p[0] = 100.0f; p[1] = -50.0f;
  memcpy(p + 3 * 10, p + 3 * 11, 3 * sizeof(float));
  CHECK_OK(mgs_knn3_mean_sq(p, n, out, &err), &err);
  double worst = 0;
  for (size_t i = 0; i < n; i++) {
    double b[3] = {1e300, 1e300, 1e300};
    for (size_t j = 0; j < n; j++) {
      if (j == i) continue;
      double d = 0;
      for (int k = 0; k < 3; k++) d += ((double)p[3 * j + k] - p[3 * i + k]) * ((double)p[3 * j + k] - p[3 * i + k]);
      if (d < b[2]) { b[2] = d; if (b[2] < b[1]) { double t = b[1]; b[1] = b[2]; b[2] = t; } if (b[1] < b[0]) { double t = b[0]; b[0] = b[1]; b[1] = t; } }
    }
    double ref = (b[0] + b[1] + b[2]) / 3;
    worst = fmax(worst, fabs(out[i] - ref) / (ref + 1e-12));
  }
  CHECK_MSG(worst < 1e-4, "kNN relative error %g", worst);
  mgs_gaussians *gr = NULL;
  double lo[3] = {-1.3, -1.3, -1.3}, hi[3] = {1.3, 1.3, 1.3};
  CHECK_OK(mgs_init_random(1000, lo, hi, 3, &r, &gr, &err), &err);
  if (gr) {
    int inside = 1;
    for (size_t i = 0; i < 3 * gr->n; i++) inside &= fabsf(gr->mean[i]) <= 1.3f && gr->sh_dc[i] >= 0 && gr->sh_dc[i] < 1.0f / 255 + 1e-6f;
    CHECK(gr->n == 1000 && inside);
    mgs_gaussians_destroy(gr);
  }
  free(p); free(out); free(xyz); free(rgb); free(d2);
}

/* The step kernel (SIMD where the build has it) against the scalar formula written out
 * here, bit for bit: spans of every length 0..40 at every offset 0..8, moments and
 * gradients over many magnitudes, zero gradients, and the finiteness flag for an inf or
 * NaN gradient at each position (the SIMD body and the scalar tail both). */
static uint32_t bits_of(float f) { uint32_t u; memcpy(&u, &f, 4); return u; }
static void test_adam_span_matches_scalar(void) {
  enum { N = 64 };
  float P[N], M[N], V[N], G[N], P2[N], M2[N], V2[N];
  mgs_rng r;
  mgs_rng_init(&r, 5, 1);
  int mism = 0, flag_bad = 0, cases = 0;
  for (int len = 0; len <= 40; len++)
    for (int off = 0; off <= 8; off++)
      for (int poison = -1; poison < len; poison += len > 8 ? 5 : 1) {
        for (int i = 0; i < N; i++) {
          double sc = pow(10.0, 8.0 * mgs_rng_uniform(&r) - 6.0);
          P[i] = P2[i] = (float)(sc * (mgs_rng_uniform(&r) - 0.5));
          M[i] = M2[i] = (float)(1e-2 * sc * (mgs_rng_uniform(&r) - 0.5));
          V[i] = V2[i] = (float)(1e-4 * sc * sc * mgs_rng_uniform(&r));
          G[i] = i % 7 == 3 ? 0.0f : (float)(sc * (mgs_rng_uniform(&r) - 0.5));
        }
        if (poison >= 0) G[off + poison] = poison % 2 ? INFINITY : NAN;
        mgs_adam_group c;
        memset(&c, 0, sizeof c);
        c.p = P; c.m = M; c.v = V; c.g = G;
        c.b1 = 0.9f; c.b2 = 0.999f; c.step_size = 1.6e-4f * 3.1f; c.inv_sqrt_bc2 = 1.0f / sqrtf(1 - 0.999f * 0.999f);
        c.eps = 1e-15f;
        int bad = mgs_adam_span(&c, (size_t)off, (size_t)(off + len));
        const float b1 = c.b1, b2 = c.b2, ob1 = 1 - b1, ob2 = 1 - b2, ss = c.step_size, isb = c.inv_sqrt_bc2, eps = c.eps;
        int bad2 = 0;
        for (int i = off; i < off + len; i++) {
          float g = G[i];
          float m = b1 * M2[i] + ob1 * g;
          float v = b2 * V2[i] + ob2 * g * g;
          M2[i] = m; V2[i] = v;
          float p = P2[i] - ss * m / (sqrtf(v) * isb + eps);
          P2[i] = p;
          bad2 |= !isfinite(p) || !isfinite(g);
        }
        for (int i = 0; i < N; i++) /* outside the span untouched, inside equal bits (NaN as NaN) */
          if ((bits_of(P[i]) != bits_of(P2[i]) && !(isnan(P[i]) && isnan(P2[i]))) ||
              (bits_of(M[i]) != bits_of(M2[i]) && !(isnan(M[i]) && isnan(M2[i]))) ||
              (bits_of(V[i]) != bits_of(V2[i]) && !(isnan(V[i]) && isnan(V2[i]))))
            mism++;
        flag_bad += (bad != 0) != (bad2 != 0) || (bad2 != 0) != (poison >= 0);
        cases++;
      }
  CHECK_MSG(mism == 0, "%d floats differ from the scalar formula (%d spans)", mism, cases);
  CHECK_MSG(flag_bad == 0, "the finiteness flag is wrong in %d of %d spans", flag_bad, cases);
}

int main(void) {
  RUN(test_adam_hand_values);
  RUN(test_adam_sh_rest_active);
  RUN(test_adam_nonfinite_names_group);
  RUN(test_adam_span_matches_scalar);
  RUN(test_moments_follow_rows);
  RUN(test_expon_lr);
  RUN(test_adc_clone_split_prune);
  RUN(test_adc_split_distribution);
  RUN(test_adc_hooks_accumulate_and_reset);
  RUN(test_adc_reset_prune_wait);
  RUN(test_knn_and_init);
  return mgs_test_finish();
}

/* The backward fused with the Adam step (mgs_adam_step_backward) against the separate
 * passes (mgs_raster_backward into zeroed gradients, then mgs_adam_step): same model,
 * moments and 2D-mean gradient norms over two steps, with culled Gaussians (which only
 * move by momentum), a partly active SH degree, depth/alpha gradients; the same error
 * naming the group for a non-finite value; and the trainer (which fuses outside ADC's
 * densification steps) equal to a trainer that never fuses; an image term's depth gradient
 * carried by the trainer's backward equal to its own render and backward. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "mgs_test.h"
#include "synth.h"
#include "train/mgs_train.h"
#include "train/mgs_strategy.h"
#include "train/mgs_term.h"

/* max |a - b| / max(1, |a|) over a group's active floats */
static double rel_diff(const float *a, const float *b, size_t n) {
  double w = 0;
  for (size_t i = 0; i < n; i++) {
    double d = fabs((double)a[i] - (double)b[i]) / fmax(1.0, fabs((double)a[i]));
    if (!(d <= w)) w = d; /* NaN counts as a difference */
  }
  return w;
}

static mgs_gaussians *scene(size_t n, uint64_t seed, const mgs_camera *cam) {
  mgs_gaussians *g = synth_model(n, seed);
  mgs_rng r;
  mgs_rng_init(&r, seed, 5);
  for (size_t i = 0; i < n * MGS_SH_REST_MAX; i++) g->sh_rest[i] = (float)(0.2 * mgs_rng_normal(&r));
  /* every 13th Gaussian behind the camera: culled, no gradient */
  double c[3];
  mgs_camera_center(cam, c);
  for (size_t i = 0; i < n; i += 13)
    for (int k = 0; k < 3; k++) g->mean[3 * i + k] = (float)(2.0 * c[k]);
  return g;
}

/* Both Adams with the same nonzero moments and step counts, so culled Gaussians move. */
static void seed_adam(mgs_adam *a, size_t n, uint64_t seed) {
  mgs_rng r;
  mgs_rng_init(&r, seed, 9);
  for (int k = 0; k < MGS_PARAM_COUNT; k++) {
    size_t d = (size_t)mgs_param_dim((mgs_param_group)k);
    for (size_t i = 0; i < n * d; i++) {
      a->m[k][i] = (float)(1e-3 * mgs_rng_normal(&r));
      a->v[k][i] = (float)(1e-6 * mgs_rng_uniform(&r));
    }
    a->t[k] = 7;
    a->lr[k] = 1e-3f * (float)(k + 1);
  }
}

static void compare_fused(int sh_degree, int with_aux) {
  const int W = 96, H = 72;
  const size_t n = 3000;
  mgs_camera cam;
  synth_camera(&cam, W, H, 1, 8, 0.2);
  mgs_gaussians *ga = scene(n, 21, &cam), *gb = mgs_gaussians_clone(ga);
  mgs_gaussians *grad = mgs_gaussians_create(n, 3);
  size_t first;
  mgs_gaussians_append(grad, n, &first, NULL);
  mgs_adam *aa = mgs_adam_create(n), *ab = mgs_adam_create(n);
  seed_adam(aa, n, 4);
  seed_adam(ab, n, 4);
  aa->sh_rest_active = ab->sh_rest_active = (sh_degree + 1) * (sh_degree + 1) - 1;
  mgs_raster_settings rs;
  mgs_raster_settings_default(&rs);
  rs.sh_degree = sh_degree;
  rs.background[0] = 0.2f; rs.background[1] = 0.5f; rs.background[2] = 1.0f;
  mgs_raster *ra = mgs_raster_create(), *rb = mgs_raster_create();
  size_t np = (size_t)W * H;
  float *dl = malloc(3 * np * sizeof(float)), *dal = malloc(np * sizeof(float)), *dd = malloc(np * sizeof(float));
  float *gma = malloc(n * sizeof(float)), *gmb = malloc(n * sizeof(float));
  mgs_rng r;
  mgs_rng_init(&r, 77, 1);
  for (size_t i = 0; i < 3 * np; i++) dl[i] = (float)(mgs_rng_normal(&r) / (double)np);
  for (size_t i = 0; i < np; i++) { dal[i] = (float)(mgs_rng_normal(&r) / (double)np); dd[i] = (float)(0.1 * mgs_rng_normal(&r) / (double)np); }
  mgs_error err;
  int culled = 0;
  for (int step = 0; step < 2; step++) {
    mgs_raster_output oa, ob;
    CHECK_OK(mgs_raster_forward(ra, ga, &cam, &rs, &oa, &err), &err);
    CHECK_OK(mgs_raster_forward(rb, gb, &cam, &rs, &ob, &err), &err);
    for (size_t i = 0; i < n; i++) culled += oa.radii[i] == 0;
    for (int k = 0; k < MGS_PARAM_COUNT; k++)
      memset(mgs_gaussians_group(grad, (mgs_param_group)k), 0, n * (size_t)mgs_param_dim((mgs_param_group)k) * sizeof(float));
    CHECK_OK(mgs_raster_backward(ra, dl, with_aux ? dal : NULL, with_aux ? dd : NULL, grad, gma, &err), &err);
    CHECK_OK(mgs_adam_step(aa, ga, grad, (1u << MGS_PARAM_COUNT) - 1, &err), &err);
    CHECK_OK(mgs_adam_step_backward(ab, gb, rb, dl, with_aux ? dal : NULL, with_aux ? dd : NULL, gmb,
                                    (1u << MGS_PARAM_COUNT) - 1, &err), &err);
    CHECK_MSG(rel_diff(gma, gmb, n) <= 1e-6, "grad_mean2d differs by %g (step %d)", rel_diff(gma, gmb, n), step);
  }
  CHECK(culled >= 2 * (int)(n / 13));
  for (int k = 0; k < MGS_PARAM_COUNT; k++) {
    mgs_param_group pg = (mgs_param_group)k;
    size_t len = n * (size_t)mgs_param_dim(pg);
    double dp = rel_diff(mgs_gaussians_group(ga, pg), mgs_gaussians_group(gb, pg), len);
    double dm = rel_diff(aa->m[k], ab->m[k], len), dv = rel_diff(aa->v[k], ab->v[k], len);
    CHECK_MSG(dp <= 1e-6 && dm <= 1e-6 && dv <= 1e-6, "SH %d: group %s differs: param %g, m %g, v %g", sh_degree,
              mgs_param_name(pg), dp, dm, dv);
    CHECK(aa->t[k] == ab->t[k] && aa->t[k] == 9);
  }
  /* the step moved the model (a test that cannot fail would compare nothing) */
  mgs_gaussians *g0 = scene(n, 21, &cam);
  CHECK(rel_diff(g0->mean, ga->mean, 3 * n) > 1e-7 && (sh_degree == 0 || rel_diff(g0->sh_rest, ga->sh_rest, 45 * n) > 1e-7));
  /* culled Gaussians moved by momentum alone */
  CHECK(g0->opacity[13] != ga->opacity[13] && ga->opacity[13] == gb->opacity[13]);
  /* a second backward on the same forward is refused (the model changed under it) */
  mgs_error_clear(&err);
  CHECK(mgs_adam_step_backward(ab, gb, rb, dl, NULL, NULL, gmb, 0x3f, &err) == MGS_ERR_ARG);
  mgs_gaussians_destroy(g0);
  free(dl); free(dal); free(dd); free(gma); free(gmb);
  mgs_raster_destroy(ra); mgs_raster_destroy(rb);
  mgs_adam_destroy(aa); mgs_adam_destroy(ab);
  mgs_gaussians_destroy(ga); mgs_gaussians_destroy(gb); mgs_gaussians_destroy(grad);
}

static void test_fused_equals_separate(void) {
  compare_fused(3, 0);
  compare_fused(3, 1);
  compare_fused(1, 0);
  compare_fused(0, 1);
}

static void test_fused_nonfinite_names_group(void) {
  const int W = 64, H = 48;
  const size_t n = 500;
  mgs_camera cam;
  synth_camera(&cam, W, H, 0, 8, 0.0);
  for (int which = 0; which < 2; which++) {
    mgs_gaussians *ga = scene(n, 5, &cam), *gb = mgs_gaussians_clone(ga);
    /* non-finite parameters (culled, so non-finite after the step); the report names the
       first group in group order, then the first Gaussian */
    if (which == 0) ga->log_scale[3 * 300 + 1] = gb->log_scale[3 * 300 + 1] = NAN;
    ga->opacity[301] = gb->opacity[301] = INFINITY;
    ga->sh_rest[45 * 100 + 7] = gb->sh_rest[45 * 100 + 7] = NAN;
    mgs_gaussians *grad = mgs_gaussians_create(n, 3);
    size_t first;
    mgs_gaussians_append(grad, n, &first, NULL);
    mgs_adam *aa = mgs_adam_create(n), *ab = mgs_adam_create(n);
    for (int k = 0; k < MGS_PARAM_COUNT; k++) aa->lr[k] = ab->lr[k] = 0.01f;
    mgs_raster_settings rs;
    mgs_raster_settings_default(&rs);
    rs.sh_degree = 3;
    mgs_raster *ra = mgs_raster_create(), *rb = mgs_raster_create();
    float *dl = malloc(3 * (size_t)W * H * sizeof(float)), *gm = malloc(n * sizeof(float));
    for (size_t i = 0; i < 3 * (size_t)W * H; i++) dl[i] = 1.0f;
    mgs_raster_output o;
    mgs_error ea, eb;
    mgs_error_clear(&ea); mgs_error_clear(&eb);
    CHECK_OK(mgs_raster_forward(ra, ga, &cam, &rs, &o, &ea), &ea);
    CHECK_OK(mgs_raster_forward(rb, gb, &cam, &rs, &o, &eb), &eb);
    CHECK_OK(mgs_raster_backward(ra, dl, NULL, NULL, grad, gm, &ea), &ea);
    mgs_status sa = mgs_adam_step(aa, ga, grad, 0x3f, &ea);
    mgs_status sb = mgs_adam_step_backward(ab, gb, rb, dl, NULL, NULL, gm, 0x3f, &eb);
    CHECK(sa == MGS_ERR_NUMERIC && sb == MGS_ERR_NUMERIC);
    CHECK_MSG(strcmp(ea.msg, eb.msg) == 0, "separate: '%s', fused: '%s'", ea.msg, eb.msg);
    CHECK_MSG(strstr(eb.msg, which == 0 ? "'log_scale' (Gaussian 300)" : "'opacity' (Gaussian 301)") != NULL, "message: %s", eb.msg);
    free(dl); free(gm);
    mgs_raster_destroy(ra); mgs_raster_destroy(rb);
    mgs_adam_destroy(aa); mgs_adam_destroy(ab);
    mgs_gaussians_destroy(ga); mgs_gaussians_destroy(gb); mgs_gaussians_destroy(grad);
  }
}

/* ADC with its `fusable` hook removed: the trainer never fuses. */
static mgs_strategy_ops never_fused_ops;

static mgs_trainer *make_trainer(mgs_dataset *ds, const mgs_train_options *o, int fusable) {
  mgs_rng r;
  mgs_rng_init(&r, 8, 1);
  double lo[3] = {-1, -1, -1}, hi[3] = {1, 1, 1};
  mgs_gaussians *g = NULL;
  mgs_error err;
  if (mgs_init_random(400, lo, hi, 3, &r, &g, &err) != MGS_OK) { fprintf(stderr, "%s\n", err.msg); exit(2); }
  mgs_strategy *s = mgs_strategy_adc_create(&o->adc);
  if (!fusable) {
    never_fused_ops = *s->ops;
    never_fused_ops.fusable = NULL;
    s->ops = &never_fused_ops;
  }
  mgs_trainer *t = NULL;
  if (mgs_trainer_create(ds, o, g, s, &t, &err) != MGS_OK) { fprintf(stderr, "%s\n", err.msg); exit(2); }
  return t;
}

/* 60 iterations with ADC's densification, resets and SH steps inside them. */
static void short_run_options(mgs_train_options *o) {
  mgs_train_options_default(o);
  o->iterations = 60;
  o->sh_every = 10;
  o->adc.densify_from = 5;
  o->adc.densify_every = 10;
  o->adc.opacity_reset_every = 25;
  o->adc.densify_until = 45;
  o->seed = 3;
}

static void test_trainer_fused_equals_separate(void) {
  mgs_gaussians *gt = synth_model(150, 42);
  mgs_dataset *ds = synth_dataset(gt, 6, 1, 48, 40);
  mgs_train_options o;
  short_run_options(&o);
  mgs_trainer *a = make_trainer(ds, &o, 1), *b = make_trainer(ds, &o, 0);
  mgs_error err;
  CHECK_OK(mgs_trainer_run(a, &err), &err);
  CHECK_OK(mgs_trainer_run(b, &err), &err);
  const mgs_gaussians *ma = mgs_trainer_model(a), *mb = mgs_trainer_model(b);
  CHECK_MSG(ma->n == mb->n && ma->n != 400, "counts %zu vs %zu", ma->n, mb->n);
  if (ma->n == mb->n)
    for (int k = 0; k < MGS_PARAM_COUNT; k++) {
      mgs_param_group pg = (mgs_param_group)k;
      double d = rel_diff(mgs_gaussians_group((mgs_gaussians *)ma, pg), mgs_gaussians_group((mgs_gaussians *)mb, pg),
                          ma->n * (size_t)mgs_param_dim(pg));
      CHECK_MSG(d <= 1e-5, "group %s differs by %g", mgs_param_name(pg), d);
    }
  CHECK_NEAR(mgs_trainer_last_loss(a), mgs_trainer_last_loss(b), 1e-6);
  mgs_trainer_destroy(a); mgs_trainer_destroy(b);
  mgs_dataset_destroy(ds);
  mgs_gaussians_destroy(gt);
}

/* Two model terms that overlap on rows (so the order of the float sums differs between
   the two paths): a pull of the means toward the origin and of opacity and log-scales
   toward 0. */
typedef struct { double w; int calls; } pull_term;
static unsigned pull_active(void *self, int it) { (void)self; return it >= 3 ? MGS_TERM_MODEL : 0; }
static mgs_status pull_mean(void *self, mgs_term_step *s, mgs_error *err) {
  (void)err;
  pull_term *t = self;
  t->calls++;
  for (size_t i = 0; i < s->model->n; i++) {
    for (int k = 0; k < 3; k++) s->grad->mean[3 * i + k] += (float)(t->w * s->model->mean[3 * i + k]);
    s->grad->opacity[i] += (float)(t->w * s->model->opacity[i]);
  }
  return MGS_OK;
}
static mgs_status pull_shape(void *self, mgs_term_step *s, mgs_error *err) {
  (void)err;
  pull_term *t = self;
  t->calls++;
  for (size_t i = 0; i < s->model->n; i++) {
    for (int k = 0; k < 3; k++) s->grad->log_scale[3 * i + k] += (float)(t->w * s->model->log_scale[3 * i + k]);
    for (int k = 0; k < 4; k++) s->grad->rot[4 * i + k] += (float)(0.1 * t->w * s->model->rot[4 * i + k]);
    s->grad->opacity[i] += (float)(0.5 * t->w);
  }
  return MGS_OK;
}
static void pull_destroy(void *self) { (void)self; }
static const mgs_term_ops pull_mean_ops = {"pull-mean", pull_active, NULL, pull_mean, NULL, NULL, pull_destroy, NULL};
static const mgs_term_ops pull_shape_ops = {"pull-shape", pull_active, NULL, pull_shape, NULL, NULL, pull_destroy, NULL};

/* Model terms join the fused step (their gradients added in by the sink) where the
   strategy allows fusing: the result equals the trainer that never fuses (terms after a
   separate backward) up to float rounding, and the terms changed the model. */
static void test_trainer_terms_fused_equal_separate(void) {
  mgs_gaussians *gt = synth_model(150, 42);
  mgs_dataset *ds = synth_dataset(gt, 6, 1, 48, 40);
  mgs_train_options o;
  short_run_options(&o);
  pull_term pa[2] = {{0.05, 0}, {0.02, 0}}, pb[2] = {{0.05, 0}, {0.02, 0}};
  mgs_trainer *a = make_trainer(ds, &o, 1), *b = make_trainer(ds, &o, 0), *c = make_trainer(ds, &o, 1);
  mgs_error err;
  CHECK_OK(mgs_trainer_add_term(a, mgs_term_create(&pull_mean_ops, &pa[0]), &err), &err);
  CHECK_OK(mgs_trainer_add_term(a, mgs_term_create(&pull_shape_ops, &pa[1]), &err), &err);
  CHECK_OK(mgs_trainer_add_term(b, mgs_term_create(&pull_mean_ops, &pb[0]), &err), &err);
  CHECK_OK(mgs_trainer_add_term(b, mgs_term_create(&pull_shape_ops, &pb[1]), &err), &err);
  CHECK_OK(mgs_trainer_run(a, &err), &err);
  CHECK_OK(mgs_trainer_run(b, &err), &err);
  CHECK_OK(mgs_trainer_run(c, &err), &err);
  CHECK(pa[0].calls == pb[0].calls && pa[1].calls == pb[1].calls && pa[0].calls == 57);
  const mgs_gaussians *ma = mgs_trainer_model(a), *mb = mgs_trainer_model(b), *mc = mgs_trainer_model(c);
  CHECK_MSG(ma->n == mb->n, "counts %zu vs %zu", ma->n, mb->n);
  double moved = 0;
  if (ma->n == mb->n)
    for (int k = 0; k < MGS_PARAM_COUNT; k++) {
      mgs_param_group pg = (mgs_param_group)k;
      size_t len = ma->n * (size_t)mgs_param_dim(pg);
      double d = rel_diff(mgs_gaussians_group((mgs_gaussians *)ma, pg), mgs_gaussians_group((mgs_gaussians *)mb, pg), len);
      CHECK_MSG(d <= 1e-5, "group %s differs by %g", mgs_param_name(pg), d);
      if (ma->n == mc->n && k < MGS_PARAM_SH_DC)
        moved = fmax(moved, rel_diff(mgs_gaussians_group((mgs_gaussians *)ma, pg), mgs_gaussians_group((mgs_gaussians *)mc, pg), len));
    }
  CHECK_MSG(ma->n != mc->n || moved > 1e-3, "the terms did not change the model (%g)", moved);
  CHECK_NEAR(mgs_trainer_last_loss(a), mgs_trainer_last_loss(b), 1e-6);
  mgs_trainer_destroy(a); mgs_trainer_destroy(b); mgs_trainer_destroy(c);
  mgs_dataset_destroy(ds);
  mgs_gaussians_destroy(gt);
}

/* A depth loss sum_k w (depth_k - 2)^2 / 2 two ways: as an image term that adds dL/d(depth)
   of the iteration's render (MGS_TERM_DEPTH: the trainer's backward carries it), and as a
   model term that renders the view once more and runs its own backward (what GaussianPro's
   planar term did before). With densification off the trained models agree up to float
   rounding, on the fused and the separate paths, and differ from a run without the term. */
typedef struct { double w; int calls, image; mgs_raster *r; float *dd, *dc; size_t cap; } depth_term;
static unsigned depth_active(void *self, int it) {
  depth_term *t = self;
  return it >= 2 ? (t->image ? MGS_TERM_IMAGE | MGS_TERM_DEPTH : MGS_TERM_MODEL) : 0u;
}
static mgs_status depth_image(void *self, mgs_term_step *s, mgs_error *err) {
  (void)err;
  depth_term *t = self;
  t->calls++;
  if (!s->dl_ddepth) return mgs_error_set(err, MGS_ERR_ARG, "no depth gradient buffer");
  for (int k = 0; k < s->width * s->height; k++) s->dl_ddepth[k] += (float)(t->w * (s->depth[k] - 2.0f));
  s->dl_ddepth_used = 1;
  return MGS_OK;
}
static mgs_status depth_model(void *self, mgs_term_step *s, mgs_error *err) {
  depth_term *t = self;
  t->calls++;
  size_t np = (size_t)s->width * (size_t)s->height;
  if (np > t->cap) {
    free(t->dd); free(t->dc);
    t->dd = calloc(np, sizeof(float));
    t->dc = calloc(3 * np, sizeof(float));
    t->cap = np;
  }
  mgs_raster_settings rs;
  mgs_raster_settings_default(&rs);
  rs.sh_degree = 0;
  mgs_raster_output ro;
  mgs_status st = mgs_raster_forward(t->r, s->model, &s->view->cam, &rs, &ro, err);
  if (st) return st;
  for (size_t k = 0; k < np; k++) t->dd[k] = (float)(t->w * (ro.depth[k] - 2.0f));
  return mgs_raster_backward(t->r, t->dc, NULL, t->dd, s->grad, NULL, err);
}
static void depth_destroy(void *self) { (void)self; }
static const mgs_term_ops depth_image_ops = {"depth-image", depth_active, depth_image, NULL, NULL, NULL, depth_destroy, NULL};
static const mgs_term_ops depth_model_ops = {"depth-model", depth_active, NULL, depth_model, NULL, NULL, depth_destroy, NULL};

/* The never-fused ADC's post_backward, also keeping a copy of the full gradient of
   iteration g_snap_it (the trainer running now writes g_snap). */
static mgs_status (*adc_post)(void *, mgs_strategy_step *, mgs_error *);
static mgs_gaussians *g_snap;
static int g_snap_it;
static mgs_status snap_post(void *self, mgs_strategy_step *s, mgs_error *err) {
  if (s->iteration == g_snap_it && s->grad) {
    mgs_gaussians_destroy(g_snap);
    g_snap = mgs_gaussians_clone(s->grad);
  }
  return adc_post(self, s, err);
}

static void test_trainer_depth_term(void) {
  mgs_gaussians *gt = synth_model(150, 42);
  mgs_dataset *ds = synth_dataset(gt, 6, 1, 48, 40);
  mgs_train_options o;
  short_run_options(&o);
  o.iterations = 40;
  o.adc.densify_from = 1000; /* the image term's gradient also reaches the 2D-mean statistics */
  o.adc.opacity_reset_every = 0;
  depth_term ti = {0.5, 0, 1, NULL, NULL, NULL, 0}, tis = ti, tm = {0.5, 0, 0, mgs_raster_create(), NULL, NULL, 0};
  mgs_trainer *a = make_trainer(ds, &o, 1), *as = make_trainer(ds, &o, 0), *c = make_trainer(ds, &o, 1);
  mgs_error err;
  CHECK_OK(mgs_trainer_add_term(a, mgs_term_create(&depth_image_ops, &ti), &err), &err);
  CHECK_OK(mgs_trainer_add_term(as, mgs_term_create(&depth_image_ops, &tis), &err), &err);
  CHECK_OK(mgs_trainer_run(a, &err), &err);
  CHECK_OK(mgs_trainer_run(as, &err), &err);
  CHECK_OK(mgs_trainer_run(c, &err), &err);
  CHECK(ti.calls == tis.calls && ti.calls == 38);
  /* fused and separate backward carry the depth gradient alike (their results are equal
     without it, test_trainer_fused_equals_separate), and it changed the model */
  const mgs_gaussians *ma = mgs_trainer_model(a), *ms = mgs_trainer_model(as), *mc = mgs_trainer_model(c);
  CHECK_MSG(ma->n == ms->n && ma->n == mc->n, "counts %zu, %zu, %zu", ma->n, ms->n, mc->n);
  double moved = 0;
  if (ma->n == ms->n && ma->n == mc->n)
    for (int k = 0; k < MGS_PARAM_SH_DC; k++) {
      mgs_param_group pg = (mgs_param_group)k;
      size_t len = ma->n * (size_t)mgs_param_dim(pg);
      double d = rel_diff(mgs_gaussians_group((mgs_gaussians *)ma, pg), mgs_gaussians_group((mgs_gaussians *)ms, pg), len);
      CHECK_MSG(d <= 1e-5, "fused vs separate: group %s differs by %g", mgs_param_name(pg), d);
      moved = fmax(moved, rel_diff(mgs_gaussians_group((mgs_gaussians *)ma, pg), mgs_gaussians_group((mgs_gaussians *)mc, pg), len));
    }
  CHECK_MSG(moved > 1e-3, "the depth term did not change the model (%g)", moved);
  /* the gradient of iteration 2 (the term's first; the models are still equal) through the
     trainer's backward against the term's own render and backward: Adam would turn float
     rounding in near-zero components into whole steps, so gradients, not models (1e-4 of
     the largest: the rotations' sums cancel to ~4e-5 in float) */
  mgs_gaussians *grads[2] = {NULL, NULL};
  for (int w = 0; w < 2; w++) {
    depth_term tw = w ? tm : tis;
    tw.calls = 0;
    mgs_trainer *t = make_trainer(ds, &o, 0);
    adc_post = never_fused_ops.post_backward;
    never_fused_ops.post_backward = snap_post;
    CHECK_OK(mgs_trainer_add_term(t, mgs_term_create(w ? &depth_model_ops : &depth_image_ops, &tw), &err), &err);
    g_snap_it = 2;
    o.iterations = 3;
    CHECK_OK(mgs_trainer_run(t, &err), &err);
    grads[w] = g_snap;
    g_snap = NULL;
    mgs_trainer_destroy(t);
    if (w) { free(tw.dd); free(tw.dc); }
  }
  CHECK(grads[0] && grads[1] && grads[0]->n == grads[1]->n);
  if (grads[0] && grads[1] && grads[0]->n == grads[1]->n)
    for (int k = 0; k < MGS_PARAM_SH_DC; k++) {
      mgs_param_group pg = (mgs_param_group)k;
      const float *x = mgs_gaussians_group(grads[0], pg), *y = mgs_gaussians_group(grads[1], pg);
      size_t len = grads[0]->n * (size_t)mgs_param_dim(pg);
      double big = 0, diff = 0;
      for (size_t i = 0; i < len; i++) {
        big = fmax(big, fabs(x[i]));
        diff = fmax(diff, fabs((double)x[i] - y[i]));
      }
      CHECK_MSG(big > 0 && diff <= 1e-4 * big, "iteration 2: %s gradients differ by %g of %g", mgs_param_name(pg), diff, big);
    }
  mgs_gaussians_destroy(grads[0]); mgs_gaussians_destroy(grads[1]);
  mgs_trainer_destroy(a); mgs_trainer_destroy(as); mgs_trainer_destroy(c);
  mgs_raster_destroy(tm.r);
  mgs_dataset_destroy(ds);
  mgs_gaussians_destroy(gt);
}

int main(void) {
  RUN(test_fused_equals_separate);
  RUN(test_fused_nonfinite_names_group);
  RUN(test_trainer_fused_equals_separate);
  RUN(test_trainer_terms_fused_equal_separate);
  RUN(test_trainer_depth_term);
  return mgs_test_finish();
}

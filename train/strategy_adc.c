/* The reference 3DGS adaptive density control (Kerbl et al. 2023, gaussian_model.py):
 * accumulate the NDC 2D-mean gradient norm of visible Gaussians, and every
 * `densify_every` iterations between `densify_from` and `densify_until` clone small
 * Gaussians with a large mean gradient, split large ones into `split_n` samples with
 * scale / (0.8 N), prune transparent ones (and, after the first opacity reset, ones too
 * big on screen or in the world); reset opacities every `opacity_reset_every`.
 *
 * 2DGS models (kind MGS_MODEL_2DGS) as the authors': split samples lie in the surfel's
 * plane (0 sigma along the normal); the opacity cull of 0.05 is the option's value
 * (train/config.c).
 *
 * Deliberate difference: the reference zeroes max_radii2D in densification_postfix
 * *before* its screen-size test, so that test never fires there; here the test uses the
 * largest radius seen during the interval (the evident intent). Set max_screen_px = 0 to
 * get the reference's effective behaviour. */
#include <limits.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "train/mgs_strategy.h"
#include "core/mgs_math.h"

void mgs_adc_options_default(mgs_adc_options *o) {
  o->densify_from = 500;
  o->densify_until = 15000;
  o->densify_every = 100;
  o->opacity_reset_every = 3000;
  o->grad_threshold = 2e-4f;
  o->percent_dense = 0.01f;
  o->split_n = 2;
  o->min_opacity = 0.005f;
  o->max_screen_px = 20.0f;
  o->max_world_scale = 0.1f;
  o->white_background = 0;
  o->reset_prune_wait = 0;
}

typedef struct adc {
  mgs_adc_options o;
  mgs_adc_state st;
  size_t cap;
} adc;

static mgs_status adc_resize(adc *a, size_t n, mgs_error *err) {
  /* zeroed accumulators for n Gaussians */
  if (n > a->cap) {
    size_t cap = n > 2 * a->cap ? n : 2 * a->cap;
    float *g = realloc(a->st.grad_accum, cap * sizeof(float));
    if (g) a->st.grad_accum = g;
    int *c = g ? realloc(a->st.count, cap * sizeof(int)) : NULL;
    if (c) a->st.count = c;
    int *r = c ? realloc(a->st.max_radii, cap * sizeof(int)) : NULL;
    if (r) a->st.max_radii = r;
    if (!g || !c || !r) return mgs_error_set(err, MGS_ERR_NOMEM, "adc: cannot allocate accumulators for %zu Gaussians", n);
    a->cap = cap;
  }
  a->st.n = n;
  if (n) {
    memset(a->st.grad_accum, 0, n * sizeof(float));
    memset(a->st.count, 0, n * sizeof(int));
    memset(a->st.max_radii, 0, n * sizeof(int));
  }
  return MGS_OK;
}

static float max_scale(const mgs_gaussians *g, size_t i) {
  const float *l = g->log_scale + 3 * i;
  float m = l[0] > l[1] ? l[0] : l[1];
  m = m > l[2] ? m : l[2];
  return expf(m);
}

static void copy_row(mgs_gaussians *g, size_t dst, size_t src) {
  for (int k = 0; k < MGS_PARAM_COUNT; k++) {
    size_t d = (size_t)mgs_param_dim((mgs_param_group)k);
    float *p = mgs_gaussians_group(g, (mgs_param_group)k);
    memcpy(p + dst * d, p + src * d, d * sizeof(float));
  }
}

void mgs_adc_reset_opacity(mgs_gaussians *g, mgs_adam *a) {
  const float cap = mgs_logitf(0.01f);
  for (size_t i = 0; i < g->n; i++)
    if (g->opacity[i] > cap) g->opacity[i] = cap; /* min(alpha, 0.01) as a logit */
  if (a) mgs_adam_reset_group(a, MGS_PARAM_OPACITY);
}

/* Iterations from the last opacity reset before iteration `it` (a reset at a densification
 * iteration comes after that densification) to `it`; INT_MAX if none. */
static int since_reset(const mgs_adc_options *o, int it) {
  int d = INT_MAX;
  if (o->opacity_reset_every > 0 && it > o->opacity_reset_every)
    d = it % o->opacity_reset_every ? it % o->opacity_reset_every : o->opacity_reset_every;
  if (o->white_background && it > o->densify_from && it - o->densify_from < d) d = it - o->densify_from;
  return d;
}

/* force_split (n0 entries or NULL): also split these, whatever their gradient and size
 * (Mini-Splatting's blur split; a Gaussian may then be cloned and split, as there). */
static mgs_status densify_and_prune(adc *a, mgs_gaussians *g, mgs_adam *opt, double extent, int prune_big,
                                    int prune_transparent, const uint8_t *force_split, mgs_rng *rng, mgs_error *err) {
  const mgs_adc_options *o = &a->o;
  size_t n0 = g->n;
  if (a->st.n != n0) { mgs_status st = adc_resize(a, n0, err); if (st) return st; }
  uint8_t *sel = calloc(n0 ? n0 : 1, 1); /* 1 clone, 2 split */
  if (!sel) return mgs_error_set(err, MGS_ERR_NOMEM, "adc: out of memory");
  size_t n_clone = 0, n_split = 0;
  const float dense = (float)(o->percent_dense * extent);
  for (size_t i = 0; i < n0; i++) {
    float gm = a->st.count[i] ? a->st.grad_accum[i] / (float)a->st.count[i] : 0.0f;
    if (gm >= o->grad_threshold) sel[i] = max_scale(g, i) <= dense ? 1 : 2;
    if (force_split && force_split[i]) sel[i] |= 2;
    n_clone += sel[i] & 1;
    n_split += (sel[i] & 2) >> 1;
  }
  int N = o->split_n;
  size_t first = 0, add = n_clone + (size_t)N * n_split;
  mgs_status st = mgs_model_append(g, opt, add, &first, err);
  if (st) { free(sel); return st; }
  /* the reference appends the clones first, then the split samples */
  size_t w = first;
  for (size_t i = 0; i < n0; i++)
    if (sel[i] & 1) copy_row(g, w++, i);
  /* 2DGS surfels: samples at 0 sigma along the normal, the unused third scale kept */
  const int surfel = g->kind == MGS_MODEL_2DGS;
  for (size_t i = 0; i < n0; i++) {
    if (!(sel[i] & 2)) continue;
    float s[3], R[9];
    for (int k = 0; k < 3; k++) s[k] = expf(g->log_scale[3 * i + k]);
    if (surfel) s[2] = 0;
    mgs_quat_to_mat3f(g->rot + 4 * i, R);
    for (int c = 0; c < N; c++) {
      copy_row(g, w, i);
      float z[3];
      for (int k = 0; k < 3; k++) z[k] = (float)mgs_rng_normal(rng) * s[k];
      for (int r = 0; r < 3; r++)
        g->mean[3 * w + r] = g->mean[3 * i + r] + R[3 * r] * z[0] + R[3 * r + 1] * z[1] + R[3 * r + 2] * z[2];
      for (int k = 0; k < 3 - surfel; k++) g->log_scale[3 * w + k] = logf(s[k] / (0.8f * (float)N));
      w++;
    }
  }
  size_t n1 = g->n;
  uint8_t *keep = malloc(n1 ? n1 : 1);
  if (!keep) { free(sel); return mgs_error_set(err, MGS_ERR_NOMEM, "adc: out of memory"); }
  const float world_cap = (float)(o->max_world_scale * extent);
  for (size_t i = 0; i < n1; i++) {
    int drop = i < n0 && (sel[i] & 2); /* split originals */
    drop |= prune_transparent && mgs_sigmoidf(g->opacity[i]) < o->min_opacity;
    if (prune_big) {
      int rad = i < n0 ? a->st.max_radii[i] : 0;
      if (o->max_screen_px > 0 && (float)rad > o->max_screen_px) drop = 1;
      if (max_scale(g, i) > world_cap) drop = 1;
    }
    keep[i] = (uint8_t)!drop;
  }
  mgs_model_compact(g, opt, keep);
  free(keep);
  free(sel);
  return adc_resize(a, g->n, err);
}

static mgs_status adc_pre(void *self, mgs_strategy_step *s, mgs_error *err) {
  (void)self; (void)s; (void)err;
  return MGS_OK;
}

static mgs_status adc_post(void *self, mgs_strategy_step *s, mgs_error *err) {
  adc *a = self;
  const mgs_adc_options *o = &a->o;
  int it = s->iteration;
  mgs_gaussians *g = s->model;
  if (a->st.n != g->n) { mgs_status st = adc_resize(a, g->n, err); if (st) return st; }
  if (it >= o->densify_until) return MGS_OK;
  for (size_t i = 0; i < g->n; i++) {
    int r = s->radii[i];
    if (r <= 0) continue;
    if (r > a->st.max_radii[i]) a->st.max_radii[i] = r;
    a->st.grad_accum[i] += s->grad_mean2d[i];
    a->st.count[i]++;
  }
  if (it > o->densify_from && o->densify_every > 0 && it % o->densify_every == 0) {
    int prune_big = o->opacity_reset_every > 0 && it > o->opacity_reset_every;
    int prune_transparent = o->reset_prune_wait <= 0 || since_reset(o, it) >= o->reset_prune_wait;
    mgs_status st = densify_and_prune(a, g, s->adam, s->extent, prune_big, prune_transparent, NULL, s->rng, err);
    if (st) return st;
    s->replaced_groups = (1u << MGS_PARAM_COUNT) - 1;
  }
  if ((o->opacity_reset_every > 0 && it % o->opacity_reset_every == 0) ||
      (o->white_background && it == o->densify_from)) {
    mgs_adc_reset_opacity(g, s->adam);
    s->replaced_groups |= 1u << MGS_PARAM_OPACITY;
  }
  return MGS_OK;
}

/* Outside densification and opacity-reset iterations the hook only accumulates
 * grad_mean2d and radii (the same conditions as adc_post). */
static int adc_fusable(void *self, const mgs_strategy_step *s) {
  const mgs_adc_options *o = &((adc *)self)->o;
  int it = s->iteration;
  if (it >= o->densify_until) return 1;
  if (it > o->densify_from && o->densify_every > 0 && it % o->densify_every == 0) return 0;
  if ((o->opacity_reset_every > 0 && it % o->opacity_reset_every == 0) || (o->white_background && it == o->densify_from))
    return 0;
  return 1;
}

static mgs_status adc_save(void *self, FILE *f, mgs_error *err) {
  adc *a = self;
  uint64_t n = a->st.n;
  int ok = fwrite(&n, sizeof n, 1, f) == 1;
  if (n) {
    ok = ok && fwrite(a->st.grad_accum, sizeof(float), n, f) == n;
    ok = ok && fwrite(a->st.count, sizeof(int), n, f) == n;
    ok = ok && fwrite(a->st.max_radii, sizeof(int), n, f) == n;
  }
  return ok ? MGS_OK : mgs_error_set(err, MGS_ERR_IO, "adc: cannot write its state to the checkpoint");
}

static mgs_status adc_load(void *self, FILE *f, size_t n_gaussians, mgs_error *err) {
  adc *a = self;
  uint64_t n = 0;
  /* n = 0: written before the first step sized the accumulators (the run's initial
     checkpoint); the first step would zero them for every Gaussian, as this does */
  if (fread(&n, sizeof n, 1, f) != 1 || (n != n_gaussians && n != 0))
    return mgs_error_set(err, MGS_ERR_FORMAT, "adc state in the checkpoint does not match its %zu Gaussians", n_gaussians);
  mgs_status st = adc_resize(a, n_gaussians, err);
  if (st || n == 0) return st;
  if (n && (fread(a->st.grad_accum, sizeof(float), n, f) != n || fread(a->st.count, sizeof(int), n, f) != n ||
            fread(a->st.max_radii, sizeof(int), n, f) != n))
    return mgs_error_set(err, MGS_ERR_FORMAT, "checkpoint truncated in the adc state");
  return MGS_OK;
}

static void adc_destroy(void *self) {
  adc *a = self;
  if (!a) return;
  free(a->st.grad_accum); free(a->st.count); free(a->st.max_radii);
  free(a);
}

static const mgs_strategy_ops adc_ops = {"adc", adc_pre, adc_post, adc_save, adc_load, adc_destroy, adc_fusable, NULL};

mgs_strategy *mgs_strategy_adc_create(const mgs_adc_options *o) {
  mgs_strategy *s = calloc(1, sizeof *s);
  adc *a = calloc(1, sizeof *a);
  if (!s || !a) { free(s); free(a); return NULL; }
  if (o) a->o = *o; else mgs_adc_options_default(&a->o);
  s->ops = &adc_ops;
  s->self = a;
  return s;
}

void mgs_strategy_destroy(mgs_strategy *s) {
  if (!s) return;
  if (s->ops && s->ops->destroy) s->ops->destroy(s->self);
  free(s);
}

mgs_adc_state *mgs_strategy_adc_state(mgs_strategy *s, size_t n_gaussians) {
  if (!s || s->ops != &adc_ops) return NULL;
  adc *a = s->self;
  if (a->st.n != n_gaussians && adc_resize(a, n_gaussians, NULL) != MGS_OK) return NULL;
  return &a->st;
}

mgs_status mgs_adc_densify_and_prune(mgs_strategy *s, mgs_gaussians *g, mgs_adam *opt, double extent,
                                     int prune_big, mgs_rng *rng, mgs_error *err) {
  if (!s || s->ops != &adc_ops) return mgs_error_set(err, MGS_ERR_ARG, "not an adc strategy");
  return densify_and_prune(s->self, g, opt, extent, prune_big, 1, NULL, rng, err);
}

mgs_status mgs_adc_densify_and_prune_mask(mgs_strategy *s, mgs_gaussians *g, mgs_adam *opt, double extent,
                                          int prune_big, const uint8_t *force_split, mgs_rng *rng, mgs_error *err) {
  if (!s || s->ops != &adc_ops) return mgs_error_set(err, MGS_ERR_ARG, "not an adc strategy");
  return densify_and_prune(s->self, g, opt, extent, prune_big, 1, force_split, rng, err);
}

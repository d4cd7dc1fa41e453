/* The training loop of the reference 3DGS (train.py) on the CPU: views in a random order
 * per epoch, forward, (1-lambda) L1 + lambda (1 - SSIM), backward, the strategy's hooks,
 * Adam; the SH degree is raised every `sh_every` iterations. Any non-finite loss,
 * gradient or parameter stops training with a message naming the parameter group. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "train/trainer_internal.h"
#include "render/mgs_loss.h"
#include "core/mgs_log.h"

void mgs_train_options_default(mgs_train_options *o) {
  memset(o, 0, sizeof *o);
  o->iterations = 30000;
  o->sh_degree = 3;
  o->sh_every = 1000;
  o->lambda_dssim = 0.2f;
  o->lr_mean_init = 1.6e-4;
  o->lr_mean_final = 1.6e-6;
  o->lr_mean_max_steps = 30000;
  o->lr_log_scale = 5e-3f;
  o->lr_rot = 1e-3f;
  o->lr_opacity = 0.05f;
  o->lr_sh_dc = 2.5e-3f;
  /* the reference's feature_lr / 20 (0.000125 in double) rounded once, as the table's
     default; the float quotient 2.5e-3f / 20 is an ulp below it, and a resume (which reads
     the table's value from cfg_args) then stepped SH rest differently from the run it continued */
  o->lr_sh_rest = 1.25e-4f;
  o->seed = 0;
  o->checkpoint_every = 0;
  o->progress = 0;
  o->vis_rebin_every = 200;
  o->spatial_order = -1;
  o->prefetch = 8;
  mgs_adc_options_default(&o->adc);
}

static mgs_status grow_floats(float **p, size_t *cap, size_t need, mgs_error *err) {
  if (need <= *cap) return MGS_OK;
  float *q = realloc(*p, need * sizeof(float));
  if (!q) return mgs_error_set(err, MGS_ERR_NOMEM, "trainer: out of memory (%zu floats)", need);
  *p = q; *cap = need;
  return MGS_OK;
}

static void shuffle(mgs_trainer *t) {
  for (size_t i = 0; i < t->perm_len; i++) t->perm[i] = (uint32_t)i;
  for (size_t i = t->perm_len; i > 1; i--) {
    uint32_t j = mgs_rng_below(&t->rng, (uint32_t)i);
    uint32_t x = t->perm[i - 1]; t->perm[i - 1] = t->perm[j]; t->perm[j] = x;
  }
  t->perm_pos = 0;
  mgs_trainer_large_order_views(t); /* --view-order locality (train/trainer_large_scenes.c) */
}

mgs_status mgs_trainer_create(mgs_dataset *ds, const mgs_train_options *o, mgs_gaussians *init,
                              mgs_strategy *strategy, mgs_trainer **out, mgs_error *err) {
  *out = NULL;
  mgs_trainer *t = calloc(1, sizeof *t);
  if (!t) { mgs_gaussians_destroy(init); mgs_strategy_destroy(strategy); return mgs_error_set(err, MGS_ERR_NOMEM, "trainer: out of memory"); }
  t->o = *o;
  t->ds = ds;
  t->g = init;
  /* the model lives in the dataset's local frame; its .ply is written in world coordinates */
  if (init) for (int k = 0; k < 3; k++) init->origin[k] = ds->origin[k];
  t->strategy = strategy;
  mgs_status st = MGS_OK;
  if (!init || init->n == 0) st = mgs_error_set(err, MGS_ERR_ARG, "trainer: the initial model is empty");
  else if (ds->n_views[MGS_SPLIT_TRAIN] == 0) st = mgs_error_set(err, MGS_ERR_ARG, "%s: the dataset has no training views", ds->root);
  else if (o->iterations < 1) st = mgs_error_set(err, MGS_ERR_ARG, "trainer: iterations must be >= 1 (got %d)", o->iterations);
  else if (o->sh_degree < 0 || o->sh_degree > 3 || o->sh_degree > init->sh_degree)
    st = mgs_error_set(err, MGS_ERR_ARG, "trainer: SH degree %d not in 0..%d", o->sh_degree, init->sh_degree);
  if (st == MGS_OK) st = mgs_gaussians_check_finite(init, err);
  if (st != MGS_OK) { mgs_trainer_destroy(t); return st; }
  t->grad = mgs_gaussians_create(init->n, init->sh_degree);
  t->adam = mgs_adam_create(init->n);
  if (t->adam && o->sh_moments_bf16) (void)mgs_adam_set_sh_rest_bf16(t->adam, 1, err); /* packing frees, never fails */
  t->raster = mgs_raster_create();
  t->perm_len = ds->n_views[MGS_SPLIT_TRAIN];
  t->perm = malloc(t->perm_len * sizeof(uint32_t));
  if (!t->grad || !t->adam || !t->raster || !t->perm) {
    mgs_trainer_destroy(t);
    return mgs_error_set(err, MGS_ERR_NOMEM, "trainer: out of memory");
  }
  if ((st = mgs_trainer_large_init(t, err))) { mgs_trainer_destroy(t); return st; }
  double ext = ds->extent > 0 ? ds->extent : 1.0;
  t->adam->lr[MGS_PARAM_MEAN] = (float)(o->lr_mean_init * ext);
  t->adam->lr[MGS_PARAM_LOG_SCALE] = o->lr_log_scale;
  t->adam->lr[MGS_PARAM_ROT] = o->lr_rot;
  t->adam->lr[MGS_PARAM_OPACITY] = o->lr_opacity;
  t->adam->lr[MGS_PARAM_SH_DC] = o->lr_sh_dc;
  t->adam->lr[MGS_PARAM_SH_REST] = o->lr_sh_rest;
  mgs_raster_settings_default(&t->rs);
  memcpy(t->rs.background, ds->background, sizeof t->rs.background);
  mgs_rng_init(&t->rng, o->seed, 0x7261696eu);
  shuffle(t);
  /* with an image cache (train/trainer_large_scenes.c) images are decoded on demand instead */
  for (size_t i = 0; i < t->perm_len && st == MGS_OK && !o->image_cache_mb; i++) {
    mgs_view *v = &ds->views[MGS_SPLIT_TRAIN][i];
    if (!v->image) st = mgs_dataset_load_image(ds, v, err);
    if (st == MGS_OK && (v->image->channels != 3 || v->image->width != v->cam.width || v->image->height != v->cam.height))
      st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: image is %dx%dx%d, camera expects %dx%d RGB", v->image_path,
                         v->image->width, v->image->height, v->image->channels, v->cam.width, v->cam.height);
  }
  if (st != MGS_OK) { mgs_trainer_destroy(t); return st; }
  *out = t;
  return MGS_OK;
}

void mgs_trainer_destroy(mgs_trainer *t) {
  if (!t) return;
  mgs_gaussians_destroy(t->g);
  mgs_gaussians_destroy(t->grad);
  mgs_gaussians_destroy(t->tgrad);
  mgs_adam_destroy(t->adam);
  mgs_strategy_destroy(t->strategy);
  for (size_t i = 0; i < t->n_terms; i++) mgs_term_destroy(t->terms[i]);
  free(t->terms); free(t->term_values); free(t->term_s);
  mgs_raster_destroy(t->raster);
  mgs_trainer_large_destroy(t);
  mgs_progress_destroy(t->progress);
  free(t->perm); free(t->dl); free(t->dl_depth); free(t->gm2d);
  free(t);
}

mgs_status mgs_trainer_add_term(mgs_trainer *t, mgs_term *term, mgs_error *err) {
  if (!term) return mgs_error_set(err, MGS_ERR_ARG, "trainer: no loss term given");
  mgs_term **tt = realloc(t->terms, (t->n_terms + 1) * sizeof *tt);
  double *tv = tt ? realloc(t->term_values, (t->n_terms + 1) * sizeof *tv) : NULL;
  if (tt) t->terms = tt;
  if (tv) t->term_values = tv;
  double *tsec = tv ? realloc(t->term_s, (t->n_terms + 1) * sizeof *tsec) : NULL;
  if (tsec) t->term_s = tsec;
  if (!tt || !tv || !tsec) { mgs_term_destroy(term); return mgs_error_set(err, MGS_ERR_NOMEM, "trainer: out of memory"); }
  t->terms[t->n_terms] = term;
  t->term_s[t->n_terms] = 0;
  t->term_values[t->n_terms++] = 0;
  return MGS_OK;
}

size_t mgs_trainer_term_seconds(const mgs_trainer *t, double *out, size_t n_out) {
  size_t n = t->n_terms < n_out ? t->n_terms : n_out;
  if (n) memcpy(out, t->term_s, n * sizeof *out);
  return t->n_terms;
}

const char *mgs_trainer_term_name(const mgs_trainer *t, size_t k) {
  return k < t->n_terms ? t->terms[k]->ops->name : NULL;
}

size_t mgs_trainer_term_values(const mgs_trainer *t, double *out, size_t n_out) {
  size_t n = t->n_terms < n_out ? t->n_terms : n_out;
  if (n) memcpy(out, t->term_values, n * sizeof *out);
  return t->n_terms;
}

int mgs_trainer_iteration(const mgs_trainer *t) { return t->iteration; }
int mgs_trainer_model_iteration(const mgs_trainer *t) {
  return t->iteration >= t->o.iterations ? t->o.iterations : t->iteration + 1;
}
int mgs_trainer_active_sh(const mgs_trainer *t) { return t->active_sh; }
const mgs_gaussians *mgs_trainer_model(const mgs_trainer *t) { return t->g; }
mgs_gaussians *mgs_trainer_model_mut(mgs_trainer *t) { return t->g; }
size_t mgs_trainer_state_floats(const mgs_trainer *t) {
  (void)t;
  size_t n = 0;
  for (int k = 0; k < MGS_PARAM_COUNT; k++) n += (size_t)mgs_param_dim((mgs_param_group)k);
  return 3 * n;
}

/* pass 0: parameters, 1: first moments, 2: second moments */
static float *state_group(const mgs_trainer *t, int pass, int k) {
  return pass == 0 ? mgs_gaussians_group(t->g, (mgs_param_group)k) : pass == 1 ? t->adam->m[k] : t->adam->v[k];
}

void mgs_trainer_get_state(const mgs_trainer *t, size_t i, float *row) {
  for (int pass = 0; pass < 3; pass++)
    for (int k = 0; k < MGS_PARAM_COUNT; k++) {
      size_t d = (size_t)mgs_param_dim((mgs_param_group)k);
      const float *src = state_group(t, pass, k);
      if (src) memcpy(row, src + i * d, d * sizeof(float));
      else memset(row, 0, d * sizeof(float)); /* packed SH-rest moments: v is in m's words */
      row += d;
    }
}

void mgs_trainer_set_state(mgs_trainer *t, size_t i, const float *row) {
  for (int pass = 0; pass < 3; pass++)
    for (int k = 0; k < MGS_PARAM_COUNT; k++) {
      size_t d = (size_t)mgs_param_dim((mgs_param_group)k);
      float *dst = state_group(t, pass, k);
      if (dst) memcpy(dst + i * d, row, d * sizeof(float));
      row += d;
    }
}
double mgs_trainer_seconds(const mgs_trainer *t) { return t->seconds; }
double mgs_trainer_cpu_seconds(const mgs_trainer *t) { return t->cpu_seconds; }
double mgs_trainer_last_loss(const mgs_trainer *t) { return t->last_loss; }
double mgs_trainer_learning_rate(const mgs_trainer *t, mgs_param_group group) { return t->adam->lr[group]; }
void mgs_trainer_phase_seconds(const mgs_trainer *t, double out[MGS_TRAIN_PHASES]) {
  memcpy(out, t->phase_s, sizeof t->phase_s);
}

/* A gradient model with the model's count, zeroed. The Adam step zeroes the gradients it
 * consumes in the same pass; when nothing changed since (count, active SH degree), the
 * clearing pass is skipped. */
static mgs_status zero_grad(mgs_trainer *t, mgs_error *err) {
  size_t n = t->g->n;
  int clean = t->grad_clean && t->grad_clean_n == n && t->grad->n == n && t->grad_clean_sh == t->adam->sh_rest_active;
  t->grad_clean = 0;
  if (t->grad->capacity < n) {
    mgs_status st = mgs_gaussians_reserve(t->grad, n, err);
    if (st) return st;
  }
  t->grad->n = n;
  if (!clean) {
    for (int k = 0; k < MGS_PARAM_SH_REST; k++)
      memset(mgs_gaussians_group(t->grad, (mgs_param_group)k), 0, n * (size_t)mgs_param_dim((mgs_param_group)k) * sizeof(float));
    /* SH rest: only the coefficients of the active degree are read (by Adam) */
    size_t used = 3 * (size_t)t->adam->sh_rest_active;
    if (used == MGS_SH_REST_MAX) memset(t->grad->sh_rest, 0, n * MGS_SH_REST_MAX * sizeof(float));
    else if (used)
      for (size_t i = 0; i < n; i++) memset(t->grad->sh_rest + i * MGS_SH_REST_MAX, 0, used * sizeof(float));
  }
  return MGS_OK;
}

/* The model terms of this iteration into t->tgrad (cleared where the last fused step did
   not), before the backward: they read the model, never the rasterizer's gradients. */
static mgs_status terms_before_backward(mgs_trainer *t, mgs_term_step *ts, int it, mgs_error *err) {
  size_t n = t->g->n;
  if (!t->tgrad && !(t->tgrad = mgs_gaussians_create(n, t->g->sh_degree)))
    return mgs_error_set(err, MGS_ERR_NOMEM, "trainer: out of memory");
  if (t->tgrad->capacity < n) {
    mgs_status st = mgs_gaussians_reserve(t->tgrad, n, err);
    if (st) return st;
  }
  if (t->tgrad_clean_n != n || t->tgrad->n != n)
    for (int k = 0; k < MGS_PARAM_SH_DC; k++)
      memset(mgs_gaussians_group(t->tgrad, (mgs_param_group)k), 0, n * (size_t)mgs_param_dim((mgs_param_group)k) * sizeof(float));
  t->tgrad->n = n;
  ts->grad = t->tgrad;
  mgs_status st = MGS_OK;
  for (size_t k = 0; k < t->n_terms && st == MGS_OK; k++) {
    mgs_term *tm = t->terms[k];
    if (!tm->ops->model_grad || !(tm->ops->active(tm->self, it) & MGS_TERM_MODEL)) continue;
    ts->value = 0;
    double a = mgs_now();
    st = tm->ops->model_grad(tm->self, ts, err);
    t->term_s[k] += mgs_now() - a;
    t->term_values[k] += ts->value;
  }
  return st;
}

/* An Adam error (it names the group) as the reason training stopped. */
static mgs_status adam_stop(int it, mgs_error *err) {
  char msg[MGS_ERROR_MSG_MAX];
  snprintf(msg, sizeof msg, "%s", err ? err->msg : "non-finite value");
  return mgs_error_set(err, MGS_ERR_NUMERIC, "training stopped at iteration %d: %s", it, msg);
}

/* Names the parameter group holding a non-finite value, else describes `what`. */
static mgs_status numeric_stop(mgs_trainer *t, int it, const char *what, mgs_error *err) {
  mgs_error e2;
  mgs_error_clear(&e2);
  if (mgs_gaussians_check_finite(t->g, &e2) != MGS_OK)
    return mgs_error_set(err, MGS_ERR_NUMERIC, "training stopped at iteration %d: %s (%s)", it, what, e2.msg);
  return mgs_error_set(err, MGS_ERR_NUMERIC, "training stopped at iteration %d: %s", it, what);
}

mgs_status mgs_trainer_step(mgs_trainer *t, mgs_error *err) {
  const mgs_train_options *o = &t->o;
  int it = t->iteration + 1;
  double t0 = mgs_now(), c0 = mgs_cpu_now();
  double ext = t->ds->extent > 0 ? t->ds->extent : 1.0;
  int64_t lr_steps = o->lr_mean_max_steps > 0 ? o->lr_mean_max_steps : o->iterations;
  int lr_it = it, sh_max = o->sh_degree;
  if (t->strategy && t->strategy->ops->schedule) t->strategy->ops->schedule(t->strategy->self, it, &lr_it, &sh_max);
  t->adam->lr[MGS_PARAM_MEAN] = (float)mgs_expon_lr(lr_it, o->lr_mean_init * ext, o->lr_mean_final * ext, lr_steps);
  if (o->sh_every > 0 && it % o->sh_every == 0 && t->active_sh < sh_max) t->active_sh++;
  t->adam->sh_rest_active = (t->active_sh + 1) * (t->active_sh + 1) - 1;

  if (t->perm_pos >= t->perm_len) shuffle(t);
  size_t view_index = t->perm[t->perm_pos++];
  mgs_view *v = &t->ds->views[MGS_SPLIT_TRAIN][view_index];
  t->rs.sh_degree = t->active_sh;
  mgs_raster_output ro;
  t->raster_n = t->g->n;
  if (it < o->iterations && !o->freeze) { /* terms run in this iteration (step_opt below) */
    unsigned maps = 0;
    for (size_t k = 0; k < t->n_terms; k++)
      if (t->terms[k]->ops->active) maps |= t->terms[k]->ops->active(t->terms[k]->self, it) & MGS_TERM_MAPS;
    if (maps) mgs_raster_hint_maps(t->raster, MGS_MAP_DEPTH_MEDIAN | MGS_MAP_NORMAL | MGS_MAP_DISTORTION);
  }
  mgs_status st = mgs_trainer_large_forward(t, &v->cam, &ro, err);
  if (st) return st;
  double t1 = mgs_now();
  t->phase_s[MGS_PHASE_FORWARD] += t1 - t0;
  size_t np = (size_t)ro.width * (size_t)ro.height * 3;
  if ((st = grow_floats(&t->dl, &t->dl_cap, np, err))) return st;
  memset(t->dl, 0, np * sizeof(float));
  const float lam = o->lambda_dssim;
  const float *gt = NULL;
  if ((st = mgs_trainer_large_image(t, view_index, &gt, err))) return st;
  double l1 = mgs_loss_l1(ro.color, gt, ro.width, ro.height, 3, 1.0f - lam, t->dl);
  double ssim = mgs_ssim(ro.color, gt, ro.width, ro.height, 3, -lam, t->dl);
  double loss = (1.0 - lam) * l1 + lam * (1.0 - ssim);
  t->last_loss = loss;
  if (!isfinite(loss)) return numeric_stop(t, it, "the loss is not finite", err);
  double psnr = mgs_psnr(ro.color, gt, ro.width, ro.height, 3);
  t->ema_loss = it == 1 ? loss : 0.4 * loss + 0.6 * t->ema_loss;
  t->ema_psnr = it == 1 ? psnr : 0.4 * psnr + 0.6 * t->ema_psnr;

  if ((st = grow_floats(&t->gm2d, &t->gm_cap, t->g->n ? t->g->n : 1, err))) return st; /* cleared by the backward */
  mgs_strategy_step ss;
  memset(&ss, 0, sizeof ss);
  ss.iteration = it; ss.model = t->g; ss.adam = t->adam;
  ss.grad_mean2d = t->gm2d; ss.radii = ro.radii; ss.width = ro.width; ss.height = ro.height;
  ss.extent = ext; ss.rng = &t->rng;
  ss.raster = t->raster; ss.trainer = t;
  /* the reference does no optimizer step on the last iteration, and none on tensors the
     strategy replaced in this one; its last densification would change a model it never
     saves, so the last iteration runs neither (see mgs_trainer_run_to) */
  int step_opt = it < o->iterations && !o->freeze;
  int use_strategy = t->strategy && !o->freeze && it < o->iterations;
  const unsigned all = (1u << MGS_PARAM_COUNT) - 1;
  unsigned term_hooks = 0;
  mgs_term_step ts;
  memset(&ts, 0, sizeof ts);
  if (step_opt) {
    for (size_t k = 0; k < t->n_terms; k++) {
      t->term_values[k] = 0;
      if (t->terms[k]->ops->active) term_hooks |= t->terms[k]->ops->active(t->terms[k]->self, it);
    }
    ts.iteration = it; ts.iterations = o->iterations; ts.model = t->g; ts.view = v;
    ts.view_index = t->perm[t->perm_pos - 1]; ts.color = ro.color; ts.gt = gt;
    ts.alpha = ro.alpha; ts.depth = ro.depth; ts.radii = ro.radii;
    ts.width = ro.width; ts.height = ro.height; ts.active_sh = t->active_sh; ts.extent = ext;
    ts.rng = &t->rng; ts.dl_dcolor = t->dl; ts.raster = t->raster;
    if (term_hooks & MGS_TERM_DEPTH) {
      size_t npx = (size_t)ro.width * (size_t)ro.height;
      if ((st = grow_floats(&t->dl_depth, &t->dl_depth_cap, npx, err))) return st;
      memset(t->dl_depth, 0, npx * sizeof(float));
      ts.dl_ddepth = t->dl_depth;
    }
  }
  t->dl_depth_live = NULL;
  /* when the strategy's hook needs neither the gradients nor the unstepped model, the
     backward and the Adam step run fused (identical results); model terms then add their
     gradients before the backward into t->tgrad, which the fused step adds in (equal up to
     the order of the float sums; sparse Adam would skip the rows the view did not see, so
     it keeps the separate passes) */
  int model_terms = (term_hooks & MGS_TERM_MODEL) != 0;
  int fused = step_opt && (!model_terms || !o->sparse_adam) &&
              (!use_strategy || (t->strategy->ops->fusable && t->strategy->ops->fusable(t->strategy->self, &ss)));
  int terms_first = fused && model_terms;
  if (!fused && step_opt) {
    if ((st = zero_grad(t, err))) return st;
    ss.grad = t->grad;
  }
  double t2 = mgs_now();
  t->phase_s[MGS_PHASE_LOSS] += t2 - t1;
  if (term_hooks & MGS_TERM_IMAGE) {
    for (size_t k = 0; k < t->n_terms && st == MGS_OK; k++) {
      mgs_term *tm = t->terms[k];
      if (!tm->ops->image_grad || !(tm->ops->active(tm->self, it) & MGS_TERM_IMAGE)) continue;
      ts.value = 0;
      double a = mgs_now();
      st = tm->ops->image_grad(tm->self, &ts, err);
      t->term_s[k] += mgs_now() - a;
      t->term_values[k] += ts.value;
    }
    if (st) return st;
    if (ts.dl_ddepth_used) t->dl_depth_live = ts.dl_ddepth;
    double t2b = mgs_now();
    t->phase_s[MGS_PHASE_TERMS] += t2b - t2;
    t2 = t2b;
  }
  if (!step_opt && !use_strategy) { /* nothing reads a gradient in this iteration */
    t->iteration = it;
    t->seconds += mgs_now() - t0;
    t->cpu_seconds += mgs_cpu_now() - c0;
    return MGS_OK;
  }
  if (use_strategy && t->strategy->ops->pre_backward && (st = t->strategy->ops->pre_backward(t->strategy->self, &ss, err)))
    return st;
  if (terms_first) {
    if ((st = terms_before_backward(t, &ts, it, err))) return st;
    double t2b = mgs_now();
    t->phase_s[MGS_PHASE_TERMS] += t2b - t2;
    t2 = t2b;
    t->tgrad_clean_n = 0; /* until the fused step has cleared what the terms wrote */
    st = mgs_adam_step_backward_extra(t->adam, t->g, t->raster, t->dl, NULL, t->dl_depth_live, t->gm2d, all, t->tgrad, err);
    if (st == MGS_OK) t->tgrad_clean_n = t->g->n;
  } else if (fused) st = mgs_trainer_large_adam_fused(t, ro.radii, all, err);
  else st = mgs_raster_backward(t->raster, t->dl, NULL, t->dl_depth_live, t->grad, t->gm2d, err);
  if (st == MGS_ERR_NUMERIC) return adam_stop(it, err);
  if (st) return st;
  double t3 = mgs_now();
  t->phase_s[MGS_PHASE_BACKWARD] += t3 - t2;
  if ((term_hooks & MGS_TERM_MODEL) && !terms_first) {
    ts.grad = t->grad;
    for (size_t k = 0; k < t->n_terms && st == MGS_OK; k++) {
      mgs_term *tm = t->terms[k];
      if (!tm->ops->model_grad || !(tm->ops->active(tm->self, it) & MGS_TERM_MODEL)) continue;
      ts.value = 0;
      double a = mgs_now();
      st = tm->ops->model_grad(tm->self, &ts, err);
      t->term_s[k] += mgs_now() - a;
      t->term_values[k] += ts.value;
    }
    if (st) return st;
    double t3b = mgs_now();
    t->phase_s[MGS_PHASE_TERMS] += t3b - t3;
    t3 = t3b;
  }
  if (use_strategy && t->strategy->ops->post_backward && (st = t->strategy->ops->post_backward(t->strategy->self, &ss, err)))
    return st;
  if (ss.model_replaced)
    for (size_t k = 0; k < t->n_terms; k++)
      if (t->terms[k]->ops->model_replaced) t->terms[k]->ops->model_replaced(t->terms[k]->self, it);
  double t4 = mgs_now();
  t->phase_s[MGS_PHASE_STRATEGY] += t4 - t3;
  unsigned mask = all & ~ss.replaced_groups;
  if (step_opt && !fused && mask && t->g->n == t->grad->n) {
    int whole = mask == all;
    st = mgs_trainer_large_adam(t, ro.radii, mask, whole, err);
    if (st == MGS_OK && whole) {
      t->grad_clean = 1;
      t->grad_clean_n = t->g->n;
      t->grad_clean_sh = t->adam->sh_rest_active;
    }
    if (st == MGS_ERR_NUMERIC) return adam_stop(it, err);
    if (st) return st;
  }
  mgs_trainer_large_after_step(t, &ss, ro.radii, step_opt && (fused || mask));
  t->iteration = it;
  double t5 = mgs_now();
  t->phase_s[MGS_PHASE_ADAM] += t5 - t4;
  t->seconds += t5 - t0;
  t->cpu_seconds += mgs_cpu_now() - c0;
  return MGS_OK;
}

mgs_status mgs_trainer_run(mgs_trainer *t, mgs_error *err) {
  return mgs_trainer_run_until(t, t->o.iterations, err);
}

mgs_status mgs_trainer_run_to(mgs_trainer *t, int n, mgs_error *err) {
  return mgs_trainer_run_until(t, n >= t->o.iterations ? t->o.iterations : n - 1, err);
}

mgs_status mgs_trainer_run_until(mgs_trainer *t, int until, mgs_error *err) {
  const mgs_train_options *o = &t->o;
  if (until > o->iterations) until = o->iterations;
  if (o->progress && !t->progress) t->progress = mgs_progress_create("train", (size_t)o->iterations);
  mgs_progress *pb = t->progress;
  mgs_status st = MGS_OK;
  while (t->iteration < until) {
    if (o->stop && *o->stop) {
      st = MGS_ERR_INTERRUPTED;
      break;
    }
    if ((st = mgs_trainer_step(t, err))) break;
    if (o->after_step && (st = o->after_step(o->after_step_user, t, err))) break;
    if (o->checkpoint_every > 0 && o->checkpoint_path && t->iteration % o->checkpoint_every == 0 &&
        t->iteration < o->iterations && (st = mgs_trainer_save_checkpoint(t, o->checkpoint_path, err)))
      break;
    if (pb && (t->iteration % 10 == 0 || t->iteration == o->iterations)) {
      char status[128];
      snprintf(status, sizeof status, "loss %.4f  psnr %.2f  n %zu  sh %d", t->ema_loss, t->ema_psnr, t->g->n, t->active_sh);
      mgs_progress_update(pb, (size_t)t->iteration, status);
    }
  }
  if (pb && (st != MGS_OK || t->iteration >= o->iterations)) {
    mgs_progress_destroy(pb);
    t->progress = NULL;
  }
  if (st == MGS_ERR_INTERRUPTED) {
    if (o->checkpoint_path) {
      mgs_status s2 = mgs_trainer_save_checkpoint(t, o->checkpoint_path, err);
      if (s2) return s2;
    }
    return mgs_error_set(err, MGS_ERR_INTERRUPTED, "interrupted at iteration %d%s%s", t->iteration,
                         o->checkpoint_path ? "; checkpoint written to " : "", o->checkpoint_path ? o->checkpoint_path : "");
  }
  return st;
}


mgs_status mgs_trainer_evaluate(mgs_trainer *t, mgs_split split, size_t max_views, double *psnr,
                                double *ssim, mgs_error *err) {
  size_t nv = t->ds->n_views[split];
  *psnr = *ssim = 0;
  if (nv == 0) return mgs_error_set(err, MGS_ERR_ARG, "%s: no %s views to evaluate", t->ds->root, mgs_split_name(split));
  size_t use = max_views && max_views < nv ? max_views : nv;
  float *clamped = NULL;
  size_t cap = 0;
  double sp = 0, ss = 0;
  mgs_raster_settings rs = t->rs;
  rs.sh_degree = t->active_sh;
  for (size_t k = 0; k < use; k++) {
    mgs_view *v = &t->ds->views[split][k * nv / use];
    mgs_status st = v->image ? MGS_OK : mgs_dataset_load_image(t->ds, v, err);
    mgs_raster_output ro;
    if (st == MGS_OK) st = mgs_raster_forward(t->raster, t->g, &v->cam, &rs, &ro, err);
    size_t np = st == MGS_OK ? (size_t)ro.width * ro.height * 3 : 0;
    if (st == MGS_OK) st = grow_floats(&clamped, &cap, np, err);
    if (st != MGS_OK) { free(clamped); return st; }
    for (size_t i = 0; i < np; i++) clamped[i] = ro.color[i] < 0 ? 0 : (ro.color[i] > 1 ? 1 : ro.color[i]);
    sp += mgs_psnr(clamped, v->image->data, ro.width, ro.height, 3);
    ss += mgs_ssim(clamped, v->image->data, ro.width, ro.height, 3, 0, NULL);
  }
  free(clamped);
  *psnr = sp / (double)use;
  *ssim = ss / (double)use;
  return MGS_OK;
}

mgs_status mgs_trainer_edit_model(mgs_trainer *t, const uint8_t *keep, size_t add, size_t *first, mgs_error *err) {
  if (keep) mgs_model_compact(t->g, t->adam, keep);
  size_t f = t->g->n;
  if (add) {
    mgs_status st = mgs_model_append(t->g, t->adam, add, &f, err);
    if (st) return st;
  }
  if (first) *first = f;
  t->grad_clean = 0; /* the gradient rows no longer match the model's */
  mgs_trainer_large_invalidate(t);
  return MGS_OK;
}

const mgs_dataset *mgs_trainer_dataset(const mgs_trainer *t) { return t->ds; }
mgs_status mgs_trainer_train_image(mgs_trainer *t, size_t i, const float **rgb, mgs_error *err) {
  if (i >= t->ds->n_views[MGS_SPLIT_TRAIN])
    return mgs_error_set(err, MGS_ERR_ARG, "train view %zu of %zu", i, t->ds->n_views[MGS_SPLIT_TRAIN]);
  return mgs_trainer_large_image(t, i, rgb, err);
}

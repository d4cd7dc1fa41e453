/* SuGaR's density control (train/mgs_sugar.h): the reference ADC while it densifies (the
 * 3DGS model the coarse stage starts from), then nothing but one hard prune of the
 * Gaussians with α < prune_alpha at prune_at (coarse_sdf.py's prune_low_opacity_gaussians_at
 * = [9000], threshold 0.5). The ADC's own per-Gaussian state is resized by its hook when
 * the count changes, so the prune needs no bookkeeping beyond mgs_model_compact. */
#include <math.h>
#include <stdlib.h>
#include "core/mgs_log.h"
#include "train/mgs_sugar.h"

typedef struct sugar_strat {
  mgs_strategy *adc;
  int prune_at;
  double prune_alpha;
  size_t pruned;
} sugar_strat;

static mgs_status ss_pre(void *self, mgs_strategy_step *s, mgs_error *err) {
  mgs_strategy *a = ((sugar_strat *)self)->adc;
  return a->ops->pre_backward ? a->ops->pre_backward(a->self, s, err) : MGS_OK;
}

static mgs_status ss_post(void *self, mgs_strategy_step *s, mgs_error *err) {
  sugar_strat *t = self;
  mgs_strategy *a = t->adc;
  mgs_status st = a->ops->post_backward ? a->ops->post_backward(a->self, s, err) : MGS_OK;
  if (st || s->iteration != t->prune_at) return st;
  mgs_gaussians *g = s->model;
  uint8_t *keep = malloc(g->n ? g->n : 1);
  if (!keep) return mgs_error_set(err, MGS_ERR_NOMEM, "sugar: out of memory for the prune mask");
  const double logit = log(t->prune_alpha / (1 - t->prune_alpha)); /* α < a ⇔ logit < logit(a) */
  for (size_t i = 0; i < g->n; i++) keep[i] = !(g->opacity[i] < logit);
  size_t before = g->n;
  mgs_model_compact(g, s->adam, keep);
  t->pruned = before - g->n;
  free(keep);
  /* a model the coarse stage could not make opaque (a schedule compressed past its
     entropy phase, or too few iterations before it) loses nearly everything here */
  if (before > 0 && g->n * 100 < before)
    mgs_warn("sugar: the prune at iteration %d (alpha < %g) kept %zu of %zu Gaussians: the model will not "
             "represent the scene (too short a schedule before --sugar-prune-at?)", s->iteration, t->prune_alpha, g->n, before);
  return MGS_OK;
}

static int ss_fusable(void *self, const mgs_strategy_step *s) {
  sugar_strat *t = self;
  if (s->iteration == t->prune_at) return 0;
  return t->adc->ops->fusable ? t->adc->ops->fusable(t->adc->self, s) : 0;
}

static mgs_status ss_save(void *self, FILE *f, mgs_error *err) {
  mgs_strategy *a = ((sugar_strat *)self)->adc;
  return a->ops->save ? a->ops->save(a->self, f, err) : MGS_OK;
}

static mgs_status ss_load(void *self, FILE *f, size_t n, mgs_error *err) {
  mgs_strategy *a = ((sugar_strat *)self)->adc;
  return a->ops->load ? a->ops->load(a->self, f, n, err) : MGS_OK;
}

static void ss_destroy(void *self) {
  sugar_strat *t = self;
  if (!t) return;
  mgs_strategy_destroy(t->adc);
  free(t);
}

static const mgs_strategy_ops sugar_strat_ops = {"sugar", ss_pre, ss_post, ss_save, ss_load, ss_destroy, ss_fusable, NULL};

mgs_status mgs_strategy_sugar_create(const mgs_adc_options *a, const mgs_sugar_options *o, mgs_strategy **out,
                                     mgs_error *err) {
  *out = NULL;
  if (!(o->prune_alpha > 0 && o->prune_alpha < 1))
    return mgs_error_set(err, MGS_ERR_ARG, "sugar: the prune threshold must be in (0, 1) (got %g)", o->prune_alpha);
  sugar_strat *t = calloc(1, sizeof *t);
  mgs_strategy *s = calloc(1, sizeof *s);
  if (t) t->adc = mgs_strategy_adc_create(a);
  if (!t || !s || !t->adc) {
    if (t) mgs_strategy_destroy(t->adc);
    free(t);
    free(s);
    return mgs_error_set(err, MGS_ERR_NOMEM, "sugar: out of memory");
  }
  t->prune_at = o->prune_at;
  t->prune_alpha = o->prune_alpha;
  s->ops = &sugar_strat_ops;
  s->self = t;
  *out = s;
  return MGS_OK;
}

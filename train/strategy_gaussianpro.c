/* --strategy gaussianpro (train/mgs_gaussianpro.h): the reference ADC (owned) at every
 * iteration; at a propagation iteration, after it, one propagation step on the next
 * training view in turn (the authors take the iteration's random training view). New
 * Gaussians start with zero ADC statistics; the iteration then skips its Adam step (the
 * counts changed), as after any density change here. */
#include <stdlib.h>
#include <string.h>
#include "core/mgs_log.h"
#include "train/mgs_gaussianpro.h"
#include "train/mgs_strategy.h"

typedef struct gpro_strat {
  mgs_strategy *adc;
  mgs_gpro *pro;
  mgs_gpro_options o;
  size_t n_views;
  uint64_t next_view, steps, added;
} gpro_strat;

static int is_step(const gpro_strat *s, int it) {
  return s->n_views > 0 && it > s->o.from && it < s->o.until && it % s->o.every == 0;
}

static mgs_status gp_pre(void *self, mgs_strategy_step *s, mgs_error *err) {
  gpro_strat *m = self;
  return m->adc->ops->pre_backward ? m->adc->ops->pre_backward(m->adc->self, s, err) : MGS_OK;
}

static mgs_status gp_post(void *self, mgs_strategy_step *s, mgs_error *err) {
  gpro_strat *m = self;
  mgs_status st = m->adc->ops->post_backward(m->adc->self, s, err);
  if (st || !is_step(m, s->iteration)) return st;
  mgs_gaussians *g = s->model;
  size_t n0 = g->n;
  /* the ADC accumulators of the current Gaussians, carried past the append */
  mgs_adc_state *as = mgs_strategy_adc_state(m->adc, n0);
  float *acc = malloc((n0 + 1) * sizeof(float));
  int *cnt = malloc((n0 + 1) * sizeof(int)), *rad = malloc((n0 + 1) * sizeof(int));
  if (!as || !acc || !cnt || !rad) st = mgs_error_set(err, MGS_ERR_NOMEM, "gaussianpro: out of memory");
  if (st == MGS_OK) {
    memcpy(acc, as->grad_accum, n0 * sizeof(float));
    memcpy(cnt, as->count, n0 * sizeof(int));
    memcpy(rad, as->max_radii, n0 * sizeof(int));
  }
  mgs_gpro_report r;
  size_t view = (size_t)(m->next_view % m->n_views);
  double progress = m->o.until > m->o.from ? (double)(s->iteration - m->o.from) / (double)(m->o.until - m->o.from) : 1.0;
  if (st == MGS_OK) st = mgs_gpro_propagate(m->pro, g, s->adam, view, progress, &r, err);
  if (st == MGS_OK && r.added) {
    as = mgs_strategy_adc_state(m->adc, g->n); /* zeroed at the new count */
    if (!as) st = mgs_error_set(err, MGS_ERR_NOMEM, "gaussianpro: out of memory");
    else {
      memcpy(as->grad_accum, acc, n0 * sizeof(float));
      memcpy(as->count, cnt, n0 * sizeof(int));
      memcpy(as->max_radii, rad, n0 * sizeof(int));
    }
    s->replaced_groups = (1u << MGS_PARAM_COUNT) - 1; /* counts changed: no Adam step now */
  }
  free(acc); free(cnt); free(rad);
  if (st) return st;
  m->next_view++;
  m->steps++;
  m->added += r.added;
  mgs_info("gaussianpro @%d: view %zu against %zu neighbours: %zu consistent px, %zu disagree with the render, "
           "%zu Gaussians added (%zu in all), %.2f s", s->iteration, view, r.neighbors, r.consistent, r.accepted, r.added,
           g->n, r.seconds);
  return MGS_OK;
}

static int gp_fusable(void *self, const mgs_strategy_step *s) {
  gpro_strat *m = self;
  if (is_step(m, s->iteration)) return 0;
  return m->adc->ops->fusable ? m->adc->ops->fusable(m->adc->self, s) : 0;
}

static mgs_status gp_save(void *self, FILE *f, mgs_error *err) {
  gpro_strat *m = self;
  mgs_status st = m->adc->ops->save(m->adc->self, f, err);
  uint64_t v[3] = {m->next_view, m->steps, m->added};
  if (st == MGS_OK && fwrite(v, 8, 3, f) != 3) st = mgs_error_set(err, MGS_ERR_IO, "gaussianpro: cannot write its state");
  return st ? st : mgs_gpro_save(m->pro, f, err);
}

static mgs_status gp_load(void *self, FILE *f, size_t n, mgs_error *err) {
  gpro_strat *m = self;
  mgs_status st = m->adc->ops->load(m->adc->self, f, n, err);
  uint64_t v[3];
  if (st == MGS_OK && fread(v, 8, 3, f) != 3) st = mgs_error_set(err, MGS_ERR_FORMAT, "checkpoint truncated in the gaussianpro strategy state");
  if (st) return st;
  m->next_view = v[0];
  m->steps = v[1];
  m->added = v[2];
  return mgs_gpro_load(m->pro, f, err);
}

static void gp_destroy(void *self) {
  gpro_strat *m = self;
  if (!m) return;
  mgs_strategy_destroy(m->adc);
  mgs_gpro_destroy(m->pro);
  free(m);
}

static const mgs_strategy_ops gpro_ops = {"gaussianpro", gp_pre, gp_post, gp_save, gp_load, gp_destroy, gp_fusable, NULL};

mgs_status mgs_strategy_gaussianpro_create(const mgs_adc_options *adc, const mgs_gpro_options *o, const mgs_view *views,
                                           size_t n_views, double extent, mgs_strategy **out, mgs_error *err) {
  *out = NULL;
  mgs_strategy *s = calloc(1, sizeof *s);
  gpro_strat *m = calloc(1, sizeof *m);
  if (m) m->adc = mgs_strategy_adc_create(adc);
  if (!s || !m || !m->adc) {
    if (m) mgs_strategy_destroy(m->adc);
    free(s); free(m);
    return mgs_error_set(err, MGS_ERR_NOMEM, "gaussianpro strategy: out of memory");
  }
  mgs_status st = mgs_gpro_create(o, views, n_views, extent, &m->pro, err);
  if (st) { gp_destroy(m); free(s); return st; }
  m->o = *o;
  m->n_views = n_views;
  s->ops = &gpro_ops;
  s->self = m;
  *out = s;
  return MGS_OK;
}

const mgs_gpro *mgs_strategy_gaussianpro_pro(const mgs_strategy *s) {
  return s && s->ops == &gpro_ops ? ((const gpro_strat *)s->self)->pro : NULL;
}

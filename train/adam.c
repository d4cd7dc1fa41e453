/* Adam over the model's parameter groups, as torch.optim.Adam (non-amsgrad, no weight
 * decay) that the reference 3DGS uses, with moments that follow count changes. */
#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include "train/mgs_train.h"
#include "core/mgs_parallel.h"

mgs_adam *mgs_adam_create(size_t n) {
  mgs_adam *a = calloc(1, sizeof *a);
  if (!a) return NULL;
  a->beta1 = 0.9; a->beta2 = 0.999; a->eps = 1e-15;
  a->sh_rest_active = 15;
  size_t cap = n ? n : 1;
  for (int g = 0; g < MGS_PARAM_COUNT; g++) {
    size_t d = (size_t)mgs_param_dim((mgs_param_group)g);
    a->m[g] = calloc(cap * d, sizeof(float));
    a->v[g] = calloc(cap * d, sizeof(float));
    if (!a->m[g] || !a->v[g]) { mgs_adam_destroy(a); return NULL; }
  }
  a->n = n; a->capacity = cap;
  return a;
}

void mgs_adam_destroy(mgs_adam *a) {
  if (!a) return;
  for (int g = 0; g < MGS_PARAM_COUNT; g++) { free(a->m[g]); free(a->v[g]); }
  free(a);
}

mgs_status mgs_adam_append(mgs_adam *a, size_t count, mgs_error *err) {
  size_t need = a->n + count;
  if (need > a->capacity) {
    size_t cap = a->capacity * 2 > need ? a->capacity * 2 : need;
    for (int g = 0; g < MGS_PARAM_COUNT; g++) {
      size_t d = (size_t)mgs_param_dim((mgs_param_group)g);
      float *m = realloc(a->m[g], cap * d * sizeof(float));
      if (m) a->m[g] = m;
      float *v = m ? realloc(a->v[g], cap * d * sizeof(float)) : NULL;
      if (v) a->v[g] = v;
      if (!m || !v) return mgs_error_set(err, MGS_ERR_NOMEM, "adam: cannot grow moments to %zu Gaussians", cap);
    }
    a->capacity = cap;
  }
  for (int g = 0; g < MGS_PARAM_COUNT; g++) {
    size_t d = (size_t)mgs_param_dim((mgs_param_group)g);
    memset(a->m[g] + a->n * d, 0, count * d * sizeof(float));
    memset(a->v[g] + a->n * d, 0, count * d * sizeof(float));
  }
  a->n = need;
  return MGS_OK;
}

void mgs_adam_compact(mgs_adam *a, const uint8_t *keep) {
  size_t n = a->n;
  for (int g = 0; g < MGS_PARAM_COUNT; g++) {
    int d = mgs_param_dim((mgs_param_group)g);
    n = mgs_rows_compact(a->m[g], a->n, d, keep);
    mgs_rows_compact(a->v[g], a->n, d, keep);
  }
  a->n = n;
}

void mgs_adam_reset_group(mgs_adam *a, mgs_param_group group) {
  size_t d = (size_t)mgs_param_dim(group);
  memset(a->m[group], 0, a->n * d * sizeof(float));
  memset(a->v[group], 0, a->n * d * sizeof(float));
}

typedef struct {
  float *p, *m, *v;
  const float *g;
  float b1, b2, step_size, inv_sqrt_bc2, eps;
  size_t row, used; /* floats per row, of which the first `used` are updated */
  atomic_int bad;
} step_ctx;

static int step_span(step_ctx *c, size_t b, size_t e) {
  int bad = 0;
  for (size_t i = b; i < e; i++) {
    float g = c->g[i];
    float m = c->b1 * c->m[i] + (1 - c->b1) * g;
    float v = c->b2 * c->v[i] + (1 - c->b2) * g * g;
    c->m[i] = m; c->v[i] = v;
    float p = c->p[i] - c->step_size * m / (sqrtf(v) * c->inv_sqrt_bc2 + c->eps);
    c->p[i] = p;
    bad |= !isfinite(p) || !isfinite(g);
  }
  return bad;
}

static void step_range(void *vc, size_t b, size_t e) {
  step_ctx *c = vc;
  int bad = 0;
  if (c->used == c->row) bad = step_span(c, b, e);
  else /* b, e count rows */
    for (size_t r = b; r < e; r++) bad |= step_span(c, r * c->row, r * c->row + c->used);
  if (bad) atomic_store(&c->bad, 1);
}

mgs_status mgs_adam_step(mgs_adam *a, mgs_gaussians *model, const mgs_gaussians *grad,
                         unsigned group_mask, mgs_error *err) {
  if (a->n != model->n || grad->n != model->n)
    return mgs_error_set(err, MGS_ERR_ARG, "adam: %zu moments for %zu Gaussians (%zu gradients)", a->n, model->n, grad->n);
  for (int gi = 0; gi < MGS_PARAM_COUNT; gi++) {
    if (!(group_mask & (1u << gi))) continue;
    mgs_param_group grp = (mgs_param_group)gi;
    size_t d = (size_t)mgs_param_dim(grp);
    a->t[gi]++;
    double bc1 = 1.0 - pow(a->beta1, (double)a->t[gi]);
    double bc2 = 1.0 - pow(a->beta2, (double)a->t[gi]);
    step_ctx c;
    c.p = mgs_gaussians_group(model, grp);
    c.m = a->m[gi]; c.v = a->v[gi];
    c.g = mgs_gaussians_group((mgs_gaussians *)grad, grp);
    c.b1 = (float)a->beta1; c.b2 = (float)a->beta2;
    c.step_size = (float)(a->lr[gi] / bc1);
    c.inv_sqrt_bc2 = (float)(1.0 / sqrt(bc2));
    c.eps = (float)a->eps;
    atomic_init(&c.bad, 0);
    c.row = d;
    c.used = d;
    if (grp == MGS_PARAM_SH_REST && a->sh_rest_active >= 0 && a->sh_rest_active < 15) c.used = 3 * (size_t)a->sh_rest_active;
    size_t total = model->n * d;
    if (c.used == 0) continue;
    if (c.used == d) { if (total) mgs_parallel_for(0, total, 16384, step_range, &c); }
    else if (model->n) mgs_parallel_for(0, model->n, 1024, step_range, &c);
    if (atomic_load(&c.bad)) {
      for (size_t i = 0; i < total; i++) {
        if (i % d >= c.used) continue;
        if (!isfinite(c.g[i]))
          return mgs_error_set(err, MGS_ERR_NUMERIC, "non-finite gradient in parameter group '%s' (Gaussian %zu)",
                               mgs_param_name(grp), i / d);
        if (!isfinite(c.p[i]))
          return mgs_error_set(err, MGS_ERR_NUMERIC, "non-finite value in parameter group '%s' (Gaussian %zu) after the Adam step",
                               mgs_param_name(grp), i / d);
      }
    }
  }
  return MGS_OK;
}

double mgs_expon_lr(int64_t step, double lr_init, double lr_final, int64_t max_steps) {
  if (step < 0 || (lr_init == 0.0 && lr_final == 0.0)) return 0.0;
  double t = max_steps > 0 ? (double)step / (double)max_steps : 1.0;
  if (t > 1) t = 1;
  return exp(log(lr_init) * (1 - t) + log(lr_final) * t);
}

mgs_status mgs_model_append(mgs_gaussians *g, mgs_adam *a, size_t count, size_t *first, mgs_error *err) {
  mgs_status st = mgs_gaussians_append(g, count, first, err);
  if (st != MGS_OK) return st;
  if (a) {
    st = mgs_adam_append(a, count, err);
    if (st != MGS_OK) { g->n -= count; return st; }
  }
  return MGS_OK;
}

size_t mgs_model_compact(mgs_gaussians *g, mgs_adam *a, const uint8_t *keep) {
  if (a) mgs_adam_compact(a, keep);
  return mgs_gaussians_compact(g, keep);
}

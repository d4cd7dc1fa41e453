/* The rasterizer's backward and the Adam step in one pass: each block of Gaussians is
 * stepped as soon as its gradients are known (mgs_raster_backward_sink), so the gradient
 * arrays are never written, read back and cleared (at 100k Gaussians they are 24 MB, more
 * than the last-level cache holds next to the model and the moments). */
#include <math.h>
#include <stdatomic.h>
#include <stdint.h>
#include <string.h>
#include "train/mgs_train.h"
#include "train/adam_internal.h"

typedef struct fused_ctx {
  mgs_adam_group grp[MGS_PARAM_COUNT];
  int gid[MGS_PARAM_COUNT];
  int n_grp;
  /* per group: smallest (element << 1 | is_value) that was not finite, UINT64_MAX if none;
   * the report then names what a separate step's scan in element order finds first */
  _Atomic uint64_t first_bad[MGS_PARAM_COUNT];
  const int *radii;   /* sparse Adam: only rows with radii > 0 are stepped (NULL: all) */
  mgs_gaussians *extra; /* gradients of the model's loss terms, added in (NULL: none) */
} fused_ctx;

static void record_bad(fused_ctx *c, int k, uint64_t key) {
  uint64_t cur = atomic_load(&c->first_bad[k]);
  while (key < cur && !atomic_compare_exchange_weak(&c->first_bad[k], &cur, key)) {}
}

static void adam_sink(void *vctx, size_t first, size_t count, const mgs_gaussians *block) {
  fused_ctx *c = vctx;
  if (c->extra) /* the terms' rows join the block's (scratch) and are cleared for the next step */
    for (int gid = 0; gid < MGS_PARAM_SH_DC; gid++) {
      size_t d = (size_t)mgs_param_dim((mgs_param_group)gid);
      float *bg = mgs_gaussians_group((mgs_gaussians *)block, (mgs_param_group)gid);
      float *eg = mgs_gaussians_group(c->extra, (mgs_param_group)gid) + first * d;
      for (size_t i = 0; i < count * d; i++) { bg[i] += eg[i]; eg[i] = 0; }
    }
  for (int k = 0; k < c->n_grp; k++) {
    mgs_adam_group gp = c->grp[k];
    size_t row = gp.row, off = first * row;
    gp.p += off; gp.m += off;
    if (gp.v) gp.v += off; /* NULL for packed SH-rest moments */
    gp.elem0 = off;
    gp.g = mgs_gaussians_group((mgs_gaussians *)block, (mgs_param_group)c->gid[k]);
    int bad = 0;
    if (c->radii) { /* runs of visible rows */
      const int *rad = c->radii + first;
      for (size_t r = 0; r < count;) {
        if (rad[r] <= 0) { r++; continue; }
        size_t r1 = r + 1;
        while (r1 < count && rad[r1] > 0) r1++;
        if (gp.used == row) bad |= mgs_adam_span(&gp, r * row, r1 * row);
        else
          for (size_t q = r; q < r1; q++) bad |= mgs_adam_span(&gp, q * row, q * row + gp.used);
        r = r1;
      }
    } else if (gp.used == row) bad = mgs_adam_span(&gp, 0, count * row);
    else
      for (size_t r = 0; r < count; r++) bad |= mgs_adam_span(&gp, r * row, r * row + gp.used);
    if (!bad) continue;
    for (size_t i = 0; i < count * row; i++) {
      if (i % row >= gp.used || (c->radii && c->radii[first + i / row] <= 0)) continue;
      if (!isfinite(gp.g[i])) { record_bad(c, k, (uint64_t)(off + i) << 1); break; }
      if (!isfinite(gp.p[i])) { record_bad(c, k, (uint64_t)(off + i) << 1 | 1); break; }
    }
  }
}

static mgs_status step_backward(mgs_adam *a, mgs_gaussians *model, mgs_raster *r, const float *dL_dcolor,
                                const float *dL_dalpha, const float *dL_ddepth, float *grad_mean2d,
                                unsigned group_mask, const int *radii, mgs_gaussians *extra, mgs_error *err);

mgs_status mgs_adam_step_backward(mgs_adam *a, mgs_gaussians *model, mgs_raster *r, const float *dL_dcolor,
                                  const float *dL_dalpha, const float *dL_ddepth, float *grad_mean2d,
                                  unsigned group_mask, mgs_error *err) {
  return step_backward(a, model, r, dL_dcolor, dL_dalpha, dL_ddepth, grad_mean2d, group_mask, NULL, NULL, err);
}

mgs_status mgs_adam_step_backward_extra(mgs_adam *a, mgs_gaussians *model, mgs_raster *r, const float *dL_dcolor,
                                        const float *dL_dalpha, const float *dL_ddepth, float *grad_mean2d,
                                        unsigned group_mask, mgs_gaussians *extra, mgs_error *err) {
  if (!extra || extra->n != model->n)
    return mgs_error_set(err, MGS_ERR_ARG, "adam: extra gradients with %zu rows for %zu Gaussians", extra ? extra->n : 0,
                         model->n);
  return step_backward(a, model, r, dL_dcolor, dL_dalpha, dL_ddepth, grad_mean2d, group_mask, NULL, extra, err);
}

mgs_status mgs_adam_step_backward_sparse(mgs_adam *a, mgs_gaussians *model, mgs_raster *r, const float *dL_dcolor,
                                         const float *dL_dalpha, const float *dL_ddepth, float *grad_mean2d,
                                         unsigned group_mask, const int *radii, mgs_error *err) {
  if (!radii) return mgs_error_set(err, MGS_ERR_ARG, "adam: sparse step without radii");
  return step_backward(a, model, r, dL_dcolor, dL_dalpha, dL_ddepth, grad_mean2d, group_mask, radii, NULL, err);
}

static mgs_status step_backward(mgs_adam *a, mgs_gaussians *model, mgs_raster *r, const float *dL_dcolor,
                                const float *dL_dalpha, const float *dL_ddepth, float *grad_mean2d,
                                unsigned group_mask, const int *radii, mgs_gaussians *extra, mgs_error *err) {
  if (a->n != model->n)
    return mgs_error_set(err, MGS_ERR_ARG, "adam: %zu moments for %zu Gaussians", a->n, model->n);
  fused_ctx c;
  memset(&c, 0, sizeof c);
  for (int k = 0; k < MGS_PARAM_COUNT; k++) atomic_init(&c.first_bad[k], UINT64_MAX);
  c.radii = radii;
  c.extra = extra;
  /* the step counts advance only once the backward has accepted its arguments */
  mgs_adam probe = *a;
  c.n_grp = mgs_adam_prepare(&probe, model, NULL, group_mask, c.grp, c.gid);
  /* sparse: blocks without a visible Gaussian would be skipped row by row anyway */
  mgs_status st = radii ? mgs_raster_backward_sink_visible(r, model, dL_dcolor, dL_dalpha, dL_ddepth, grad_mean2d, adam_sink, &c, err)
                        : mgs_raster_backward_sink(r, model, dL_dcolor, dL_dalpha, dL_ddepth, grad_mean2d, adam_sink, &c, err);
  if (st != MGS_OK) return st;
  memcpy(a->t, probe.t, sizeof a->t);
  for (int k = 0; k < c.n_grp; k++) {
    uint64_t key = atomic_load(&c.first_bad[k]);
    if (key == UINT64_MAX) continue;
    return mgs_adam_report((mgs_param_group)c.gid[k], (size_t)(key >> 1) / c.grp[k].row, (int)(key & 1), err);
  }
  return MGS_OK;
}

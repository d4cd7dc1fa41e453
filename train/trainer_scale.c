/* The trainer's large-scene paths, kept out of trainer.c: the forward through the
 * spatial-tile visibility (render/mgs_visibility.h: identical images, cost follows the
 * view), the sparse Adam steps (train/adam_sparse.c: only what the view saw is stepped),
 * and keeping the tile bounds valid after each step (refit what changed; re-bin when the
 * strategy added, removed or replaced Gaussians, and every `vis_rebin_every` iterations
 * to tighten bounds grown by moving Gaussians). */
#include "train/trainer_internal.h"
#include "render/mgs_visibility.h"

mgs_status mgs_trainer_scale_init(mgs_trainer *t, mgs_error *err) {
  if (!t->o.visibility) return MGS_OK;
  if (!(t->o.vis_tile >= 0)) return mgs_error_set(err, MGS_ERR_ARG, "trainer: --vis-tile %g must be >= 0", t->o.vis_tile);
  t->vis = mgs_visibility_create(t->o.vis_tile);
  if (!t->vis) return mgs_error_set(err, MGS_ERR_NOMEM, "trainer: out of memory");
  return MGS_OK;
}

void mgs_trainer_scale_destroy(mgs_trainer *t) {
  mgs_visibility_destroy(t->vis);
  t->vis = NULL;
}

void mgs_trainer_scale_invalidate(mgs_trainer *t) {
  if (t->vis) mgs_visibility_invalidate(t->vis);
}

mgs_status mgs_trainer_scale_forward(mgs_trainer *t, const mgs_camera *cam, mgs_raster_output *ro, mgs_error *err) {
  if (!t->vis) return mgs_raster_forward(t->raster, t->g, cam, &t->rs, ro, err);
  const uint32_t *idx;
  size_t n_idx;
  mgs_status st = mgs_visibility_query(t->vis, t->g, cam, &t->rs, &idx, &n_idx, err);
  if (st != MGS_OK) return st;
  t->vis_listed += n_idx;
  return mgs_raster_forward_list(t->raster, t->g, cam, &t->rs, idx, n_idx, ro, err);
}

mgs_status mgs_trainer_scale_adam_fused(mgs_trainer *t, const int *radii, unsigned mask, mgs_error *err) {
  if (t->o.sparse_adam)
    return mgs_adam_step_backward_sparse(t->adam, t->g, t->raster, t->dl, NULL, NULL, t->gm2d, mask, radii, err);
  return mgs_adam_step_backward(t->adam, t->g, t->raster, t->dl, NULL, NULL, t->gm2d, mask, err);
}

mgs_status mgs_trainer_scale_adam(mgs_trainer *t, const int *radii, unsigned mask, int zero_grad, mgs_error *err) {
  /* after a count change radii no longer matches the model: step densely this once */
  if (t->o.sparse_adam && t->raster_n == t->g->n)
    return mgs_adam_step_sparse(t->adam, t->g, t->grad, mask, radii, zero_grad, err);
  return mgs_adam_step_zero(t->adam, t->g, t->grad, mask, zero_grad, err);
}

void mgs_trainer_scale_after_step(mgs_trainer *t, const mgs_strategy_step *ss, const int *radii, int stepped) {
  if (!t->vis) return;
  if (ss->replaced_groups || t->g->n != t->raster_n) { mgs_visibility_invalidate(t->vis); return; }
  if (t->o.vis_rebin_every > 0 && (t->iteration + 1) % t->o.vis_rebin_every == 0) {
    mgs_visibility_invalidate(t->vis);
    return;
  }
  if (!stepped) return;
  /* a sparse step changed only the rows the view saw; a dense one, every row */
  mgs_visibility_refit(t->vis, t->g, t->o.sparse_adam ? radii : NULL);
}

void mgs_trainer_visibility_stats(const mgs_trainer *t, double *listed_per_iter, size_t *tiles, double *tile_size) {
  mgs_visibility_stats st = {0};
  if (t->vis) mgs_visibility_get_stats(t->vis, &st);
  if (listed_per_iter) *listed_per_iter = t->iteration > 0 ? (double)t->vis_listed / t->iteration : 0;
  if (tiles) *tiles = st.tiles;
  if (tile_size) *tile_size = st.tile_size;
}

/* The trainer's large-scene paths, kept out of trainer.c: the forward through the
 * spatial-tile visibility (render/mgs_visibility.h: identical images, cost follows the
 * view), the sparse Adam steps (train/adam_sparse.c: only what the view saw is stepped),
 * and keeping the tile bounds valid after each step (refit what changed; re-bin when the
 * strategy added, removed or replaced Gaussians, and every `vis_rebin_every` iterations
 * to tighten bounds grown by moving Gaussians). */
#include "train/trainer_internal.h"
#include <stdlib.h>
#include "render/mgs_visibility.h"
#include "core/mgs_image_cache.h"
#include "train/mgs_partition.h"
#include <string.h>

static mgs_status cache_init(mgs_trainer *t, mgs_error *err) {
  if (!t->o.image_cache_mb) return MGS_OK;
  if (t->o.image_cache_mb > ((size_t)1 << 40) || t->o.prefetch < 0)
    return mgs_error_set(err, MGS_ERR_ARG, "trainer: --image-cache-mb %zu / prefetch %d out of range", t->o.image_cache_mb,
                         t->o.prefetch);
  return mgs_image_cache_create(t->ds, MGS_SPLIT_TRAIN, t->o.image_cache_mb << 20, t->o.prefetch > 0, &t->cache, err);
}

mgs_status mgs_trainer_large_image(mgs_trainer *t, size_t i, const float **gt, mgs_error *err) {
  mgs_view *v = &t->ds->views[MGS_SPLIT_TRAIN][i];
  if (!t->cache) { *gt = v->image->data; return MGS_OK; }
  size_t need = (size_t)v->cam.width * (size_t)v->cam.height * 3;
  if (need > t->gt_cap) {
    float *b = realloc(t->gt_buf, need * sizeof(float));
    if (!b) return mgs_error_set(err, MGS_ERR_NOMEM, "trainer: out of memory for an image");
    t->gt_buf = b;
    t->gt_cap = need;
  }
  mgs_status st = mgs_image_cache_get(t->cache, i, t->gt_buf, err);
  if (st != MGS_OK) return st;
  /* the views after this one in the epoch's order */
  if (t->o.prefetch > 0) {
    size_t k = t->perm_len - t->perm_pos < (size_t)t->o.prefetch ? t->perm_len - t->perm_pos : (size_t)t->o.prefetch;
    mgs_image_cache_prefetch(t->cache, t->perm + t->perm_pos, k);
  }
  *gt = t->gt_buf;
  return MGS_OK;
}

void mgs_trainer_image_cache_stats(const mgs_trainer *t, size_t *hits, size_t *misses, size_t *peak_bytes) {
  mgs_image_cache_stats st = {0};
  if (t->cache) mgs_image_cache_get_stats(t->cache, &st);
  if (hits) *hits = st.hits;
  if (misses) *misses = st.misses;
  if (peak_bytes) *peak_bytes = st.peak_bytes;
}

/* "Auto": a large scene is one where views see a small part of the model. The mean
 * share of the initial Gaussians in the tiles of up to 16 training views decides. */
static mgs_status resolve_auto(mgs_trainer *t, mgs_error *err) {
  if (t->o.visibility >= 0 && t->o.sparse_adam >= 0) return MGS_OK;
  if (t->g->n < 16) { /* a placeholder (resume) or a toy model: nothing to decide on */
    if (t->o.visibility < 0) t->o.visibility = 0;
    if (t->o.sparse_adam < 0) t->o.sparse_adam = 0;
    return MGS_OK;
  }
  mgs_visibility *v = mgs_visibility_create(t->o.vis_tile);
  if (!v) return mgs_error_set(err, MGS_ERR_NOMEM, "trainer: out of memory");
  mgs_raster_settings rs;
  mgs_raster_settings_default(&rs);
  size_t nv = t->ds->n_views[MGS_SPLIT_TRAIN], use = nv < 16 ? nv : 16;
  double share = 0;
  mgs_status st = MGS_OK;
  for (size_t k = 0; k < use && st == MGS_OK; k++) {
    const uint32_t *idx;
    size_t n_idx;
    st = mgs_visibility_query(v, t->g, &t->ds->views[MGS_SPLIT_TRAIN][k * nv / use].cam, &rs, &idx, &n_idx, err);
    share += (double)n_idx / (double)(t->g->n ? t->g->n : 1);
  }
  mgs_visibility_destroy(v);
  if (st != MGS_OK) return st;
  share /= (double)(use ? use : 1);
  int large = share < 0.5;
  if (t->o.visibility < 0) t->o.visibility = large;
  if (t->o.sparse_adam < 0) t->o.sparse_adam = large;
  mgs_info("views see %.0f%% of the initial Gaussians: %s scene; tile visibility %s, %s Adam", 100.0 * share,
           large ? "a large" : "not a large", t->o.visibility ? "on" : "off", t->o.sparse_adam ? "sparse" : "dense");
  return MGS_OK;
}

/* Lays the initial model out along the Morton curve of its tiles (before any optimizer
 * or strategy state exists, so nothing else needs permuting). Without it the Gaussians of
 * one view are scattered over the whole model's memory (point clouds come in no spatial
 * order): at 640k Gaussians every visible one then costs a cache and TLB miss per array. */
static mgs_status spatial_order(mgs_trainer *t, double tile, mgs_error *err) {
  mgs_gaussians *g = t->g;
  size_t n = g->n;
  uint32_t *perm = malloc((n ? n : 1) * sizeof *perm);
  float *tmp = malloc((n ? n : 1) * MGS_SH_REST_MAX * sizeof(float));
  mgs_status st = perm && tmp ? mgs_partition_morton_order(g->mean, n, tile, perm, err)
                              : mgs_error_set(err, MGS_ERR_NOMEM, "trainer: out of memory reordering %zu Gaussians", n);
  for (int k = 0; k < MGS_PARAM_COUNT && st == MGS_OK; k++) {
    size_t d = (size_t)mgs_param_dim((mgs_param_group)k);
    float *a = mgs_gaussians_group(g, (mgs_param_group)k);
    for (size_t j = 0; j < n; j++) memcpy(tmp + j * d, a + (size_t)perm[j] * d, d * sizeof(float));
    memcpy(a, tmp, n * d * sizeof(float));
  }
  free(perm);
  free(tmp);
  return st;
}

static mgs_status views_init(mgs_trainer *t, mgs_error *err) {
  if (!t->o.view_locality) return MGS_OK;
  size_t n = t->ds->n_views[MGS_SPLIT_TRAIN];
  float *c = malloc((n ? n : 1) * 3 * sizeof(float));
  t->view_chunk = malloc((n ? n : 1) * sizeof(uint32_t));
  t->view_scratch = malloc((n ? 2 * n : 2) * sizeof(uint32_t));
  if (!c || !t->view_chunk || !t->view_scratch) { free(c); return mgs_error_set(err, MGS_ERR_NOMEM, "trainer: out of memory"); }
  for (size_t v = 0; v < n; v++) {
    double cc[3];
    mgs_camera_center(&t->ds->views[MGS_SPLIT_TRAIN][v].cam, cc);
    for (int k = 0; k < 3; k++) c[3 * v + k] = (float)cc[k];
  }
  double tile = (t->ds->extent > 0 ? t->ds->extent : 1.0) / 8.0;
  size_t chunk = t->o.prefetch > 8 ? (size_t)t->o.prefetch : 8;
  mgs_status st = mgs_partition_view_chunks(c, n, tile, chunk, t->view_chunk, err);
  free(c);
  return st;
}

void mgs_trainer_large_order_views(mgs_trainer *t) {
  if (t->view_chunk) mgs_partition_order_by_chunks(t->view_chunk, t->perm_len, t->perm, t->view_scratch);
}

mgs_status mgs_trainer_large_init(mgs_trainer *t, mgs_error *err) {
  mgs_status st = cache_init(t, err);
  if (st == MGS_OK) st = views_init(t, err);
  if (st == MGS_OK) st = resolve_auto(t, err);
  if (st != MGS_OK || !t->o.visibility) return st;
  if (t->o.spatial_order < 0 ? 1 : t->o.spatial_order) {
    /* the visibility's tile side, from a binning of the initial model */
    mgs_visibility *probe = mgs_visibility_create(t->o.vis_tile);
    if (!probe) return mgs_error_set(err, MGS_ERR_NOMEM, "trainer: out of memory");
    st = mgs_visibility_rebin(probe, t->g, err);
    mgs_visibility_stats vs;
    mgs_visibility_get_stats(probe, &vs);
    mgs_visibility_destroy(probe);
    if (st == MGS_OK) st = spatial_order(t, vs.tile_size, err);
    if (st != MGS_OK) return st;
  }
  if (!(t->o.vis_tile >= 0)) return mgs_error_set(err, MGS_ERR_ARG, "trainer: --vis-tile %g must be >= 0", t->o.vis_tile);
  t->vis = mgs_visibility_create(t->o.vis_tile);
  if (!t->vis) return mgs_error_set(err, MGS_ERR_NOMEM, "trainer: out of memory");
  return MGS_OK;
}

void mgs_trainer_large_destroy(mgs_trainer *t) {
  mgs_visibility_destroy(t->vis);
  t->vis = NULL;
  mgs_image_cache_destroy(t->cache);
  t->cache = NULL;
  free(t->gt_buf);
  t->gt_buf = NULL;
  free(t->view_chunk);
  free(t->view_scratch);
  t->view_chunk = t->view_scratch = NULL;
}

void mgs_trainer_large_invalidate(mgs_trainer *t) {
  if (t->vis) mgs_visibility_invalidate(t->vis);
}

mgs_status mgs_trainer_large_forward(mgs_trainer *t, const mgs_camera *cam, mgs_raster_output *ro, mgs_error *err) {
  if (!t->vis) return mgs_raster_forward(t->raster, t->g, cam, &t->rs, ro, err);
  const uint32_t *idx;
  size_t n_idx;
  mgs_status st = mgs_visibility_query(t->vis, t->g, cam, &t->rs, &idx, &n_idx, err);
  if (st != MGS_OK) return st;
  t->vis_listed += n_idx;
  return mgs_raster_forward_list(t->raster, t->g, cam, &t->rs, idx, n_idx, ro, err);
}

mgs_status mgs_trainer_large_adam_fused(mgs_trainer *t, const int *radii, unsigned mask, mgs_error *err) {
  if (t->o.sparse_adam)
    return mgs_adam_step_backward_sparse(t->adam, t->g, t->raster, t->dl, NULL, t->dl_depth_live, t->gm2d, mask, radii, err);
  return mgs_adam_step_backward(t->adam, t->g, t->raster, t->dl, NULL, t->dl_depth_live, t->gm2d, mask, err);
}

mgs_status mgs_trainer_large_adam(mgs_trainer *t, const int *radii, unsigned mask, int zero_grad, mgs_error *err) {
  /* after a count change radii no longer matches the model: step densely this once */
  if (t->o.sparse_adam && t->raster_n == t->g->n)
    return mgs_adam_step_sparse(t->adam, t->g, t->grad, mask, radii, zero_grad, err);
  return mgs_adam_step_zero(t->adam, t->g, t->grad, mask, zero_grad, err);
}

void mgs_trainer_large_after_step(mgs_trainer *t, const mgs_strategy_step *ss, const int *radii, int stepped) {
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

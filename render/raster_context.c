/* The rasterizer context: buffers reused across calls (grown, never shrunk, so steady-
 * state training allocates nothing). */
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "render/raster_internal.h"

double mgs_raster_cpu_now(void) {
  struct timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

void mgs_raster_settings_default(mgs_raster_settings *s) {
  s->background[0] = s->background[1] = s->background[2] = 0;
  s->sh_degree = 0;
  s->scale_modifier = 1.0f;
  s->dilation = 0.3f;
  s->near_plane = 0.2f;
}

mgs_raster *mgs_raster_create(void) { return calloc(1, sizeof(mgs_raster)); }

static void free_all(mgs_raster *r) {
  free(r->splat); free(r->aux); free(r->radii); free(r->rect); free(r->count);
  free(r->vis_key); free(r->vis_idx); free(r->tmp_key); free(r->tmp_idx); free(r->gauss_off);
  free(r->isect_idx); free(r->isect_slot); free(r->isect_grad);
  free(r->tile_start); free(r->chunk_cnt); free(r->tile_evals); free(r->tile_visit);
  free(r->out_color); free(r->out_alpha); free(r->out_depth); free(r->final_T); free(r->n_contrib);
  free(r->map_gnormal); free(r->map_expected); free(r->map_median); free(r->map_normal); free(r->map_gnormal_grad);
  mgs_raster2d_free(r);
  mgs_raster_blend_free(r);
}

void mgs_raster_destroy(mgs_raster *r) {
  if (!r) return;
  free_all(r);
  free(r);
}

void mgs_raster_last_evals(const mgs_raster *r, double *forward, double *backward) {
  if (forward) *forward = r->evals_fwd;
  if (backward) *backward = r->evals_bwd;
}

void mgs_raster_last_profile(const mgs_raster *r, mgs_raster_profile *p) { *p = r->prof; }

/* Grows *p to hold n elements of size sz (contents not kept). */
static int grow(void **p, size_t n, size_t sz) {
  if (n == 0) n = 1;
  void *q = realloc(*p, n * sz);
  if (!q) return 0;
  *p = q;
  return 1;
}

mgs_status mgs_raster_reserve(mgs_raster *r, size_t n, size_t tiles, size_t pix, mgs_error *err) {
  if (n > r->cap_n) {
    size_t c = n + n / 4;
    if (!grow((void **)&r->splat, c, sizeof(mgs_splat)) || !grow((void **)&r->aux, c, sizeof(mgs_proj_aux)) ||
        !grow((void **)&r->radii, c, sizeof(int)) || !grow((void **)&r->rect, c, 4 * sizeof(uint16_t)) ||
        !grow((void **)&r->count, c, sizeof(uint32_t)) || !grow((void **)&r->vis_key, c, sizeof(uint32_t)) ||
        !grow((void **)&r->vis_idx, c, sizeof(uint32_t)) || !grow((void **)&r->tmp_key, c, sizeof(uint32_t)) ||
        !grow((void **)&r->tmp_idx, c, sizeof(uint32_t)) || !grow((void **)&r->gauss_off, c, sizeof(uint32_t)))
      return mgs_error_set(err, MGS_ERR_NOMEM, "render/raster_context.c: out of memory for %zu Gaussians", n);
    r->cap_n = c;
  }
  if (tiles > r->cap_tiles) {
    if (!grow((void **)&r->tile_start, tiles + 1, sizeof(uint32_t)) || !grow((void **)&r->tile_evals, tiles, sizeof(uint32_t)) ||
        !grow((void **)&r->tile_visit, 2 * tiles, sizeof(uint32_t)))
      return mgs_error_set(err, MGS_ERR_NOMEM, "render/raster_context.c: out of memory for %zu tiles", tiles);
    r->cap_tiles = tiles;
  }
  if (pix > r->cap_pix) {
    if (!grow((void **)&r->out_color, 3 * pix, sizeof(float)) || !grow((void **)&r->out_alpha, pix, sizeof(float)) ||
        !grow((void **)&r->out_depth, pix, sizeof(float)) || !grow((void **)&r->final_T, pix, sizeof(float)) ||
        !grow((void **)&r->n_contrib, pix, sizeof(int32_t)))
      return mgs_error_set(err, MGS_ERR_NOMEM, "render/raster_context.c: out of memory for %zu pixels", pix);
    r->cap_pix = pix;
  }
  return MGS_OK;
}

mgs_status mgs_raster_reserve_isect(mgs_raster *r, size_t n_isect, mgs_error *err) {
  if (n_isect > UINT32_MAX - 1)
    return mgs_error_set(err, MGS_ERR_NOMEM, "render/raster_context.c: %zu tile intersections exceed the 2^32 limit", n_isect);
  if (n_isect > r->cap_isect) {
    size_t c = n_isect + n_isect / 4;
    if (c > UINT32_MAX - 1) c = n_isect;
    /* the backward's per-intersection gradient slots are allocated here too, so the
     * first backward does not allocate */
    free(r->isect_grad);
    r->isect_grad = aligned_alloc(64, c * GS_STRIDE * sizeof(float));
    if (!grow((void **)&r->isect_idx, c, sizeof(uint32_t)) || !grow((void **)&r->isect_slot, c, sizeof(uint32_t)) ||
        !r->isect_grad)
      return mgs_error_set(err, MGS_ERR_NOMEM, "render/raster_context.c: out of memory for %zu tile intersections", n_isect);
    r->cap_isect = c;
  }
  return MGS_OK;
}

mgs_status mgs_raster_reserve_maps(mgs_raster *r, size_t n, size_t pix, mgs_error *err) {
  if (n > r->cap_map_n) {
    if (!grow((void **)&r->map_gnormal, n, 3 * sizeof(float)))
      return mgs_error_set(err, MGS_ERR_NOMEM, "render/raster_context.c: out of memory for %zu normals", n);
    r->cap_map_n = n;
  }
  if (pix > r->cap_map_pix) {
    if (!grow((void **)&r->map_expected, pix, sizeof(float)) || !grow((void **)&r->map_median, pix, sizeof(float)) ||
        !grow((void **)&r->map_normal, 3 * pix, sizeof(float)) || !grow((void **)&r->map_gnormal_grad, 3 * pix, sizeof(float)))
      return mgs_error_set(err, MGS_ERR_NOMEM, "render/raster_context.c: out of memory for %zu pixels of maps", pix);
    r->cap_map_pix = pix;
  }
  return MGS_OK;
}

/* Blending statistics of the last forward (mgs_raster_blend_stats, render/mgs_raster.h):
 * one more pass over the forward's depth-sorted tile lists with its alpha rules (same
 * power, exp and clamp, 1/255 skip, T < 1e-4 stop), as raster_maps.c does, so that a
 * forward not followed by this call costs nothing more. Per pixel the first Gaussian (in
 * depth order) with the largest weight alpha*T, as fatPeter/mini-splatting's rasterizer
 * (`weight_max < alpha*T`); per intersection the sum of its weights over the tile, summed
 * per Gaussian through the forward's gradient-slot order (deterministic, no atomics).
 * A surfel forward's pass is the 2DGS compositing's (raster_2dgs_tiles.c); the sums and
 * counts here are shared. */
#include <stdlib.h>
#include <string.h>
#include "core/mgs_parallel.h"
#include "render/raster_kernel.h"

struct mgs_raster_blend_buf {
  size_t cap_pix, cap_isect, cap_n;
  int32_t *max_index;
  float *final_T, *slot_w, *importance;
  uint32_t *area_max;
};

void mgs_raster_blend_free(mgs_raster *r) {
  struct mgs_raster_blend_buf *b = r->blend;
  if (!b) return;
  free(b->max_index); free(b->final_T); free(b->slot_w); free(b->importance); free(b->area_max);
  free(b);
  r->blend = NULL;
}

static int grow(void **p, size_t *cap, size_t n, size_t elem) {
  if (n <= *cap) return 1;
  void *q = realloc(*p, (n ? n : 1) * elem);
  if (!q) return 0;
  *p = q;
  return 1;
}

static mgs_status reserve(mgs_raster *r, size_t pix, size_t nis, size_t n, mgs_error *err) {
  if (!r->blend && !(r->blend = calloc(1, sizeof *r->blend)))
    return mgs_error_set(err, MGS_ERR_NOMEM, "render/raster_blend.c: out of memory");
  struct mgs_raster_blend_buf *b = r->blend;
  size_t c = b->cap_pix;
  if (!grow((void **)&b->max_index, &c, pix, sizeof(int32_t)) || !grow((void **)&b->final_T, &c, pix, sizeof(float)))
    return mgs_error_set(err, MGS_ERR_NOMEM, "render/raster_blend.c: out of memory for %zu pixels", pix);
  if (pix > b->cap_pix) b->cap_pix = pix;
  c = b->cap_isect;
  if (!grow((void **)&b->slot_w, &c, nis, sizeof(float)))
    return mgs_error_set(err, MGS_ERR_NOMEM, "render/raster_blend.c: out of memory for %zu intersections", nis);
  if (nis > b->cap_isect) b->cap_isect = nis;
  c = b->cap_n;
  if (!grow((void **)&b->importance, &c, n, sizeof(float)) || !grow((void **)&b->area_max, &c, n, sizeof(uint32_t)))
    return mgs_error_set(err, MGS_ERR_NOMEM, "render/raster_blend.c: out of memory for %zu Gaussians", n);
  if (n > b->cap_n) b->cap_n = n;
  return MGS_OK;
}

static void blend_tile(mgs_raster *r, size_t tile) {
  struct mgs_raster_blend_buf *b = r->blend;
  const int W = r->width, H = r->height;
  int tx = (int)(tile % (size_t)r->tiles_x), ty = (int)(tile / (size_t)r->tiles_x);
  int x0 = tx * MGS_TILE_SIZE, y0 = ty * MGS_TILE_SIZE;
  int nrows = H - y0 < MGS_TILE_SIZE ? H - y0 : MGS_TILE_SIZE;
  int ncols = W - x0 < MGS_TILE_SIZE ? W - x0 : MGS_TILE_SIZE;
  v16f T[MGS_TILE_SIZE], WMAX[MGS_TILE_SIZE];
  v16i DONE[MGS_TILE_SIZE], IMAX[MGS_TILE_SIZE];
  v16f xs;
  v16i outside;
  for (int i = 0; i < 16; i++) { xs[i] = (float)(x0 + i) + 0.5f; outside[i] = i < ncols ? 0 : -1; }
  int rowdone[MGS_TILE_SIZE];
  for (int y = 0; y < MGS_TILE_SIZE; y++) {
    T[y] = v16f_set1(1.0f);
    WMAX[y] = v16f_set1(0.0f);
    IMAX[y] = v16i_set1(-1);
    DONE[y] = outside;
    rowdone[y] = 0;
  }
  const v16f zero = v16f_set1(0.0f);
  uint32_t start = r->tile_start[tile], end = r->tile_start[tile + 1];
  uint32_t j = start;
  for (; j < end; j++) {
    uint32_t gi = r->isect_idx[j];
    const mgs_splat *sp = &r->splat[gi];
    int lo, hi;
    mgs_row_range(sp, y0, nrows, &lo, &hi);
    v16f dx = xs - v16f_set1(sp->u), wsum = zero;
    const v16i gidx = v16i_set1((int32_t)gi);
    for (int y = lo; y <= hi; y++) {
      if (rowdone[y]) continue;
      v16i m;
      v16f alpha, testT = mgs_row_step(sp, dx, (float)(y0 + y) + 0.5f - sp->v, T[y], &DONE[y], &rowdone[y], &m, &alpha);
      mgs_blend_stat_step(m, alpha, testT, gidx, &T[y], &WMAX[y], &IMAX[y], &wsum);
    }
    float s = 0;
    for (int l = 0; l < 16; l++) s += wsum[l];
    b->slot_w[r->isect_slot[j]] = s;
    if (((j - start) & 31) == 31 && mgs_blend_tile_done(DONE, nrows)) { j++; break; }
  }
  for (; j < end; j++) b->slot_w[r->isect_slot[j]] = 0; /* after the tile's early stop */
  mgs_blend_tile_store(T, IMAX, x0, y0, nrows, ncols, W, b->final_T, b->max_index);
}

static void blend_range(void *ctx, size_t b, size_t e) {
  for (size_t t = b; t < e; t++) blend_tile(ctx, t);
}

static void importance_range(void *ctx, size_t b, size_t e) {
  mgs_raster *r = ctx;
  for (size_t i = b; i < e; i++) {
    float s = 0;
    const float *w = r->blend->slot_w + r->gauss_off[i];
    for (uint32_t k = 0; k < r->count[i]; k++) s += w[k];
    r->blend->importance[i] = s;
  }
}

mgs_status mgs_raster_blend_stats(mgs_raster *r, mgs_raster_blend *out, mgs_error *err) {
  if (!r || !out) return mgs_error_set(err, MGS_ERR_ARG, "render/raster_blend.c: NULL argument");
  if (!r->have_forward) return mgs_error_set(err, MGS_ERR_ARG, "render/raster_blend.c: no forward pass on this context");
  size_t npix = (size_t)r->width * r->height;
  mgs_status st = reserve(r, npix, r->n_isect, r->n, err);
  if (st) return st;
  struct mgs_raster_blend_buf *b = r->blend;
  if (r->surfel) mgs_raster2d_blend_tiles(r, b->max_index, b->final_T, b->slot_w); /* raster_2dgs_tiles.c */
  else mgs_parallel_for(0, (size_t)r->tiles_x * r->tiles_y, 1, blend_range, r);
  mgs_parallel_for(0, r->n, 4096, importance_range, r);
  if (r->n) memset(b->area_max, 0, r->n * sizeof(uint32_t));
  for (size_t p = 0; p < npix; p++)
    if (b->max_index[p] >= 0) b->area_max[b->max_index[p]]++;
  memset(out, 0, sizeof *out);
  out->width = r->width;
  out->height = r->height;
  out->n = r->n;
  out->max_index = b->max_index;
  out->final_T = b->final_T;
  out->area_max = b->area_max;
  out->importance = b->importance;
  return MGS_OK;
}

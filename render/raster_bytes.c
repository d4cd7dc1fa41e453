/* Byte accounting of the tile rasterizer (render/mgs_raster.h, mgs_raster_last_bytes):
 * what each phase's loops read and write, element size times how many elements they
 * touch, following raster_project.c, raster_bin.c, raster_forward.c and
 * raster_backward.c. Change this file with them. */
#include <math.h>
#include <string.h>
#include "render/raster_internal.h"

#define F4 4.0 /* float, int32, uint32 */

static double sh_rest_floats(int deg) { return 3.0 * ((deg + 1) * (deg + 1) - 1); }

void mgs_raster_bytes_of(const mgs_raster_counts *c, mgs_raster_bytes *b) {
  memset(b, 0, sizeof *b);
  const double n = (double)c->n, nf = (double)c->n_front, ns = (double)c->n_shaded, nb = (double)c->n_binned;
  const double ni = (double)c->n_isect, nt = (double)c->n_tiles, np = (double)c->n_pix;
  const double rest = sh_rest_floats(c->sh_degree) * F4;
  /* projection: mean, rotation and opacity logit of every Gaussian (the culling tests),
   * scales of those in front, SH of those shaded; radius and tile count of every one, the
   * splat and the backward's aux of the shaded, the tile rectangle of the binned */
  b->project[0] = n * (3 + 4 + 1) * F4 + nf * 3 * F4 + ns * (3 * F4 + rest);
  b->project[1] = n * 2 * F4 + ns * (double)(sizeof(mgs_splat) + sizeof(mgs_proj_aux)) + nb * 4 * sizeof(uint16_t);
  /* binning: two sweeps of the tile counts (count, fill: the depth of the binned, their
   * slot offset, key and index); the radix sort's histogram sweep of every digit and a
   * key+index scatter for each non-trivial one; the per-chunk tile counters (cleared,
   * incremented per intersection, prefix-summed); the scatter's per-Gaussian reads and
   * per-intersection index and slot writes */
  const double nc = (double)c->bin_chunks;
  b->bin[0] = 2 * n * F4 + nb * F4;
  b->bin[1] = nb * 3 * F4;
  if (c->n_binned > 1) {
    b->bin[0] += 4 * nb * F4 + c->sort_passes * nb * 2 * F4;
    b->bin[1] += c->sort_passes * nb * 2 * F4;
  }
  b->bin[0] += nb * (F4 + 8) + ni * F4 + nc * nt * F4 + nb * (F4 + 8 + F4) + ni * F4;
  b->bin[1] += nc * nt * F4 + ni * F4 + nc * nt * F4 + (nt + 1) * F4 + ni * (F4 + F4 + F4);
  /* forward tiles: each tile's list bounds, the index and splat of every intersection
   * visited, colour (3), alpha, depth, final T and contributor count of every pixel */
  b->render[0] = nt * 2 * F4 + (double)c->fwd_visit * (F4 + (double)sizeof(mgs_splat));
  b->render[1] = np * (3 + 1 + 1 + 1 + 1) * F4;
  if (c->bwd_kind == 0) return;
  /* backward tiles: list bounds; per pixel of a tile with a list its output gradients,
   * final T, contributor count; every intersection's slot index and its 64-byte gradient
   * slot (zeros behind the last contributor), and the index and splat of the evaluated */
  b->tiles[0] = nt * 2 * F4 + (double)c->n_pix_listed * (3 + (c->bwd_alpha ? 1 : 0) + (c->bwd_depth ? 1 : 0) + 2) * F4 + ni * F4 +
                (double)c->bwd_visit * (F4 + (double)sizeof(mgs_splat));
  b->tiles[1] = ni * GS_STRIDE * F4;
  /* per Gaussian: tile count of every one, slot offset and slots of the binned; for those
   * with a nonzero sum the forward's aux and splat, scales, rotation, SH rest (the colour
   * backward), and the gradients added into (arrays: read and written; a sink's block: in
   * L1, not counted); the 2D-mean gradient norm cleared for all, written for them */
  const double nl = (double)c->n_live;
  b->reduce[0] = n * F4 + nb * F4 + ni * GS_STRIDE * F4 +
                 nl * ((double)(sizeof(mgs_proj_aux) + sizeof(mgs_splat)) + (3 + 4) * F4 + rest);
  b->reduce[1] = 0;
  if (c->bwd_visible_only) b->reduce[0] += n * F4; /* radii of the blocks scanned */
  if (c->bwd_kind == 1) {
    double g = (3 + 1 + 3 + 4 + 3) * F4 + rest;
    b->reduce[0] += nl * g;
    b->reduce[1] += nl * g;
  }
  if (c->bwd_mean2d) b->reduce[1] += n * F4 + nl * F4;
}

void mgs_raster_last_bytes(const mgs_raster *r, mgs_raster_counts *cout, mgs_raster_bytes *bout) {
  mgs_raster_counts c;
  memset(&c, 0, sizeof c);
  if (r->have_forward || r->bwd_kind == 2) c.bwd_kind = r->bwd_kind; /* a sink backward clears have_forward */
  if (!r->g || r->surfel || (!r->have_forward && r->bwd_kind != 2)) {
    if (cout) *cout = c;
    if (bout) memset(bout, 0, sizeof *bout);
    return;
  }
  const mgs_gaussians *g = r->g;
  const double *V = r->cam.w2c;
  c.n = r->n;
  c.sh_degree = r->s.sh_degree;
  c.sort_passes = r->sort_passes;
  c.bin_chunks = r->bin_chunks;
  c.n_isect = r->n_isect;
  c.n_tiles = (size_t)r->tiles_x * r->tiles_y;
  c.n_pix = (size_t)r->width * r->height;
  for (size_t i = 0; i < r->n; i++) {
    /* the projection's first test, in its arithmetic (raster_project.c) */
    double m[3] = {g->mean[3 * i], g->mean[3 * i + 1], g->mean[3 * i + 2]}, td[3];
    for (int k = 0; k < 3; k++) td[k] = V[4 * k] * m[0] + V[4 * k + 1] * m[1] + V[4 * k + 2] * m[2] + V[4 * k + 3];
    const float *q = g->rot + 4 * i;
    c.n_front += td[2] > r->s.near_plane && isfinite(td[0]) && isfinite(td[1]) && isfinite(td[2]) &&
                 isfinite(q[0] + q[1] + q[2] + q[3]) && isfinite(g->opacity[i]);
    c.n_shaded += r->radii[i] > 0;
    c.n_binned += r->count[i] > 0;
  }
  for (size_t t = 0; t < c.n_tiles; t++) c.fwd_visit += r->tile_visit[2 * t];
  if (c.bwd_kind) {
    c.bwd_alpha = r->bwd_alpha; c.bwd_depth = r->bwd_depth; c.bwd_mean2d = r->bwd_mean2d;
    c.bwd_visible_only = r->bwd_visible_only;
    size_t pix_listed = 0;
    for (size_t t = 0; t < c.n_tiles; t++) {
      c.bwd_visit += r->tile_visit[2 * t + 1];
      if (r->tile_start[t + 1] > r->tile_start[t]) {
        int tx = (int)(t % (size_t)r->tiles_x), ty = (int)(t / (size_t)r->tiles_x);
        int w = r->width - tx * MGS_TILE_SIZE, h = r->height - ty * MGS_TILE_SIZE;
        pix_listed += (size_t)(w < MGS_TILE_SIZE ? w : MGS_TILE_SIZE) * (size_t)(h < MGS_TILE_SIZE ? h : MGS_TILE_SIZE);
      }
    }
    c.n_pix_listed = pix_listed;
    for (size_t i = 0; i < r->n; i++) { /* the per-Gaussian pass's test (raster_backward.c) */
      uint32_t cnt = r->count[i];
      if (!cnt) continue;
      float acc[GS_STRIDE] = {0};
      const float *s = r->isect_grad + (size_t)r->gauss_off[i] * GS_STRIDE;
      for (uint32_t k = 0; k < cnt; k++)
        for (int j = 0; j < GS_STRIDE; j++) acc[j] += s[(size_t)k * GS_STRIDE + j];
      int live = 0;
      for (int j = 0; j < GS_STRIDE; j++) live |= acc[j] != 0.0f;
      c.n_live += live;
    }
  }
  if (cout) *cout = c;
  if (bout) mgs_raster_bytes_of(&c, bout);
}

/* Tile binning. The visible Gaussians are sorted once by depth (parallel LSD radix sort,
 * 8-bit digits on the float bits of the positive depth, stable), then scattered into
 * per-tile lists in that order by a stable parallel counting sort, so each tile's list is
 * depth-ordered: the same (tile, depth) order as the reference's 64-bit key sort, ties
 * broken by Gaussian index as there. */
#include <stdlib.h>
#include <string.h>
#include "core/mgs_parallel.h"
#include "render/raster_internal.h"

#define BIN_CHUNKS 16

typedef struct bin_ctx {
  mgs_raster *r;
  size_t m;                 /* items being chunked */
  size_t nc;                /* chunks */
  uint32_t hist[BIN_CHUNKS][256];
  uint32_t nvis_chunk[BIN_CHUNKS];
  uint64_t slots_chunk[BIN_CHUNKS];
  int shift;
  const uint32_t *kin, *vin;
  uint32_t *kout, *vout;
} bin_ctx;

static void chunk_bounds(const bin_ctx *c, size_t k, size_t *b, size_t *e) {
  *b = c->m * k / c->nc;
  *e = c->m * (k + 1) / c->nc;
}

/* 1. visible Gaussians in index order */
static void vis_count(void *ctx, size_t kb, size_t ke) {
  bin_ctx *c = ctx;
  for (size_t k = kb; k < ke; k++) {
    size_t b, e; chunk_bounds(c, k, &b, &e);
    uint32_t n = 0;
    uint64_t sl = 0;
    for (size_t i = b; i < e; i++) { n += c->r->count[i] > 0; sl += c->r->count[i]; }
    c->nvis_chunk[k] = n;
    c->slots_chunk[k] = sl;
  }
}
static void vis_fill(void *ctx, size_t kb, size_t ke) {
  bin_ctx *c = ctx;
  mgs_raster *r = c->r;
  for (size_t k = kb; k < ke; k++) {
    size_t b, e; chunk_bounds(c, k, &b, &e);
    uint32_t o = c->nvis_chunk[k];
    uint32_t so = (uint32_t)c->slots_chunk[k];
    for (size_t i = b; i < e; i++)
      if (r->count[i] > 0) {
        r->gauss_off[i] = so;
        so += r->count[i];
        float z = r->splat[i].z;
        uint32_t bits; memcpy(&bits, &z, 4); /* z > 0: bit order = value order */
        r->vis_key[o] = bits;
        r->vis_idx[o] = (uint32_t)i;
        o++;
      }
  }
}

/* 2. radix sort passes */
static void radix_hist(void *ctx, size_t kb, size_t ke) {
  bin_ctx *c = ctx;
  for (size_t k = kb; k < ke; k++) {
    size_t b, e; chunk_bounds(c, k, &b, &e);
    uint32_t *h = c->hist[k];
    memset(h, 0, 256 * sizeof(uint32_t));
    for (size_t i = b; i < e; i++) h[(c->kin[i] >> c->shift) & 255]++;
  }
}
static void radix_scatter(void *ctx, size_t kb, size_t ke) {
  bin_ctx *c = ctx;
  for (size_t k = kb; k < ke; k++) {
    size_t b, e; chunk_bounds(c, k, &b, &e);
    uint32_t *h = c->hist[k]; /* now holds output offsets */
    for (size_t i = b; i < e; i++) {
      uint32_t key = c->kin[i];
      uint32_t o = h[(key >> c->shift) & 255]++;
      c->kout[o] = key;
      c->vout[o] = c->vin[i];
    }
  }
}

static void radix_sort(bin_ctx *c) {
  mgs_raster *r = c->r;
  c->kin = r->vis_key; c->vin = r->vis_idx; c->kout = r->tmp_key; c->vout = r->tmp_idx;
  for (int shift = 0; shift < 32; shift += 8) {
    c->shift = shift;
    mgs_parallel_for(0, c->nc, 1, radix_hist, c);
    /* a digit shared by all keys needs no pass */
    int trivial = 0;
    for (int d = 0; d < 256 && !trivial; d++) {
      size_t s = 0;
      for (size_t k = 0; k < c->nc; k++) s += c->hist[k][d];
      if (s == c->m) trivial = 1;
    }
    if (trivial) continue;
    r->sort_passes++;
    uint32_t o = 0;
    for (int d = 0; d < 256; d++)
      for (size_t k = 0; k < c->nc; k++) { uint32_t t = c->hist[k][d]; c->hist[k][d] = o; o += t; }
    mgs_parallel_for(0, c->nc, 1, radix_scatter, c);
    const uint32_t *tk = c->kin, *tv = c->vin;
    c->kin = c->kout; c->vin = c->vout;
    c->kout = (uint32_t *)tk; c->vout = (uint32_t *)tv;
  }
  if (c->kin != r->vis_key) { /* result in the scratch arrays: swap buffers */
    uint32_t *t = r->vis_key; r->vis_key = r->tmp_key; r->tmp_key = t;
    t = r->vis_idx; r->vis_idx = r->tmp_idx; r->tmp_idx = t;
  }
}

/* 4. per-(chunk, tile) counts and stable scatter */
static void tile_count(void *ctx, size_t kb, size_t ke) {
  bin_ctx *c = ctx;
  mgs_raster *r = c->r;
  size_t nt = (size_t)r->tiles_x * r->tiles_y;
  for (size_t k = kb; k < ke; k++) {
    size_t b, e; chunk_bounds(c, k, &b, &e);
    uint32_t *cnt = r->chunk_cnt + k * nt;
    memset(cnt, 0, nt * sizeof(uint32_t));
    for (size_t j = b; j < e; j++) {
      /* depth order is random in memory: fetch ahead */
      if (j + 16 < e) __builtin_prefetch(r->rect + 4 * (size_t)r->vis_idx[j + 16]);
      const uint16_t *rc = r->rect + 4 * (size_t)r->vis_idx[j];
      for (int ty = rc[1]; ty < rc[3]; ty++)
        for (int tx = rc[0]; tx < rc[2]; tx++) cnt[(size_t)ty * r->tiles_x + tx]++;
    }
  }
}
static void tile_scatter(void *ctx, size_t kb, size_t ke) {
  bin_ctx *c = ctx;
  mgs_raster *r = c->r;
  size_t nt = (size_t)r->tiles_x * r->tiles_y;
  for (size_t k = kb; k < ke; k++) {
    size_t b, e; chunk_bounds(c, k, &b, &e);
    uint32_t *off = r->chunk_cnt + k * nt;
    for (size_t j = b; j < e; j++) {
      if (j + 16 < e) { /* depth order is random in memory: fetch ahead */
        uint32_t ga = r->vis_idx[j + 16];
        __builtin_prefetch(r->rect + 4 * (size_t)ga);
        __builtin_prefetch(&r->gauss_off[ga]);
      }
      uint32_t gi = r->vis_idx[j];
      const uint16_t *rc = r->rect + 4 * (size_t)gi;
      uint32_t s = r->gauss_off[gi];
      for (int ty = rc[1]; ty < rc[3]; ty++)
        for (int tx = rc[0]; tx < rc[2]; tx++) {
          uint32_t pos = off[(size_t)ty * r->tiles_x + tx]++;
          r->isect_idx[pos] = gi;
          r->isect_slot[pos] = s++;
        }
    }
  }
}

mgs_status mgs_raster_bin(mgs_raster *r, mgs_error *err) {
  bin_ctx c;
  c.r = r;
  r->sort_passes = 0;
  size_t nt = (size_t)r->tiles_x * r->tiles_y;
  /* 1 */
  c.m = r->n;
  c.nc = r->n < 65536 ? 1 : BIN_CHUNKS;
  mgs_parallel_for(0, c.nc, 1, vis_count, &c);
  uint32_t o = 0;
  uint64_t tot = 0;
  for (size_t k = 0; k < c.nc; k++) {
    uint32_t t = c.nvis_chunk[k]; c.nvis_chunk[k] = o; o += t;
    uint64_t ts = c.slots_chunk[k]; c.slots_chunk[k] = tot; tot += ts;
  }
  /* slots are numbered in Gaussian index order (the backward's per-Gaussian pass then
   * walks the model arrays sequentially) */
  mgs_status st = mgs_raster_reserve_isect(r, (size_t)tot, err);
  if (st != MGS_OK) return st;
  mgs_parallel_for(0, c.nc, 1, vis_fill, &c);
  size_t nv = o;
  r->n_visible = nv;
  /* 2 */
  c.m = nv;
  c.nc = nv < 32768 ? 1 : BIN_CHUNKS;
  if (nv > 1) radix_sort(&c);
  r->n_isect = (size_t)tot;
  /* 4 */
  c.nc = (tot < 65536 || nt > (1u << 20)) ? 1 : BIN_CHUNKS; /* per-chunk tile counters: keep them small */
  if (c.nc * nt > r->cap_chunk_cnt) {
    size_t want = c.nc * nt;
    void *q = realloc(r->chunk_cnt, want * sizeof(uint32_t));
    if (!q) return mgs_error_set(err, MGS_ERR_NOMEM, "render/raster_bin.c: out of memory for %zu tiles", nt);
    r->chunk_cnt = q;
    r->cap_chunk_cnt = want;
  }
  r->bin_chunks = (int)c.nc;
  mgs_parallel_for(0, c.nc, 1, tile_count, &c);
  uint32_t pos = 0;
  for (size_t t = 0; t < nt; t++) {
    r->tile_start[t] = pos;
    for (size_t k = 0; k < c.nc; k++) {
      uint32_t *cc = r->chunk_cnt + k * nt + t;
      uint32_t n = *cc; *cc = pos; pos += n;
    }
  }
  r->tile_start[nt] = pos;
  mgs_parallel_for(0, c.nc, 1, tile_scatter, &c);
  return MGS_OK;
}

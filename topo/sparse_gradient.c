/* The gradient path of the narrow band: per chunk of leaves (in parallel), the critical
 * cells of the lower stars of the leaf voxels (topo/gradient_lowerstar.c; T: of -f, dual
 * cells) and the -w x-run ends each leaf owns, in one pass; and the block-wise skip of -w
 * tiles for the Morse boundary walk.
 *
 * Why: only critical cells enter the sort and the pairing, so the enumeration emits nothing
 * else; a regular voxel (acyclic lower link) is recognised without pairing its lower star. */
#include <stdlib.h>
#include <string.h>
#include "core/mgs_parallel.h"
#include "topo/sparse_internal.h"

/* Gradient path (V): per chunk of leaves, the critical cells of the lower stars of the leaf
 * voxels strictly inside (lo, top) and the -w x-run ends owned by the leaf, in one pass. */
#define GCHUNK 8
typedef struct grad_ctx {
  const prep *p;
  const cub_field *f;
  cub_cells *out;   /* per chunk */
  size_t *band;     /* per chunk: band cells (lower-star cells + -w run ends) */
  int *failed;      /* per chunk: out of memory */
} grad_ctx;

static int push_cell(cub_cells *l, uint64_t key, float v) {
  if (l->n == l->cap) {
    size_t cap = l->cap ? l->cap * 2 : 1024;
    cub_cell *nc = realloc(l->c, cap * sizeof *nc);
    if (!nc) return 0;
    l->c = nc;
    l->cap = cap;
  }
  l->c[l->n].key = key;
  l->c[l->n].v = v;
  l->n++;
  return 1;
}

/* One leaf's critical cells (its window w loaded) appended to out; its band cell count. */
static size_t leaf_cells(const prep *p, const cub_field *f, size_t b, const float *w, cub_cells *out, int *failed) {
  const float lo = f->lo, top = f->top;
  const int cons = f->construction, dual = cons == MGS_TOPO_T; /* T: cells 2v + 1 + d */
  const int32_t *o = p->s->origin + 3 * b;
  size_t band = 0;
  for (int x = 0; x < 8; x++)
    for (int y = 0; y < 8; y++)
      for (int z = 0; z < 8; z++) {
        float fv = win(w, x, y, z);
        if (!(fv > lo && fv < top)) continue;
        float nb[27];
        for (int i = 0; i < 3; i++)
          for (int j = 0; j < 3; j++)
            memcpy(nb + i * 9 + j * 3, &w[((x + i + 1) * WY + (y + j)) * WZ + z], 3 * sizeof *nb);
        if (dual)
          for (int i = 0; i < 27; i++) nb[i] = -nb[i];
        size_t nl;
        if (!cub_lower_star_count(nb, &nl)) { band += nl; continue; } /* regular vertex */
        cub_ls ls;
        cub_lower_star(nb, &ls);
        band += ls.n;
        cub_cell cc[27];
        size_t k = cub_ls_critical(&ls, o[0] + x, o[1] + y, o[2] + z, dual, fv, cc);
        for (size_t i = 0; i < k; i++)
          if (!push_cell(out, cc[i].key, cc[i].v)) *failed = 1;
      }
  uint32_t mask = cub_sparse_leaf_neighbours(p, b);
  for (int i = -1; i <= 8; i++)
    for (int j = -1; j <= 8; j++)
      for (int k = -1; k <= 8; k++) {
        if (!dual && win(w, i, j, k) != lo) continue; /* a V -w cell has its anchor voxel at -w */
        if ((i <= 0 || i >= 7 || j <= 0 || j >= 7 || k <= 0 || k >= 7) && !cub_sparse_owns(mask, i, j, k)) continue;
        for (int ey = 0; ey <= 1; ey++)
          for (int ez = 0; ez <= 1; ez++) {
            /* run ends have even x: V a = 2i, T a = 2i + 2 */
            int32_t a = 2 * i + 2 * dual, bb = 2 * j + dual + ey, c = 2 * k + dual + ez;
            if (wcell(cons, w, a, bb, c) != lo || wcell(cons, w, a - 1, bb, c) == lo) continue;
            band++;
            if (!push_cell(out, cub_key(a + 2 * o[0], bb + 2 * o[1], c + 2 * o[2]), lo)) *failed = 1;
          }
      }
  return band;
}

static void enum_gradient(void *vctx, size_t c0, size_t c1) {
  grad_ctx *g = vctx;
  const prep *p = g->p;
  float w[WX * WY * WZ];
  for (size_t ch = c0; ch < c1; ch++) {
    size_t band = 0;
    size_t l1 = (ch + 1) * GCHUNK < p->nleaf ? (ch + 1) * GCHUNK : p->nleaf;
    for (size_t li = ch * GCHUNK; li < l1 && !g->failed[ch]; li++) {
      cub_sparse_load_window(p, p->leaves[li], w);
      band += leaf_cells(p, g->f, p->leaves[li], w, &g->out[ch], &g->failed[ch]);
    }
    g->band[ch] = band;
  }
}

/* -w tiles: a whole block column of -w cells is skipped at once by the x-run walk. */
static int32_t sparse_lo_skip(const void *ctx, int32_t a, int32_t b, int32_t c) {
  const prep *p = ctx;
  /* V: the cell's voxels have x = a/2; T (even a): x = a/2 - 1 and a/2, and one -w voxel
   * makes a T cell -w, so the block of x = a/2 suffices */
  int cons = p->construction;
  int32_t x = a >> 1, ys[2], zs[2];
  int ny = cub_axis_voxels(cons, b, ys), nz = cub_axis_voxels(cons, c, zs);
  for (int j = 0; j < ny; j++)
    for (int k = 0; k < nz; k++) {
      uint32_t bl = cub_map_get(&p->s->map, block_key(x >> 3, ys[j] >> 3, zs[k] >> 3));
      if (bl == UINT32_MAX || p->leaf_slot[bl] != SIZE_MAX || p->cval[bl] != p->lo) return a;
    }
  return 2 * (x & ~7);
}

/* The chunks' cells (total in all) into one list, in chunk order; 0 when out of memory. */
static int concat_chunks(const cub_cells *chunks, size_t nch, size_t total, cub_cells *cells) {
  cells->c = malloc((total ? total : 1) * sizeof *cells->c);
  cells->cap = total ? total : 1;
  if (!cells->c) return 0;
  for (size_t i = 0; i < nch; i++) {
    if (chunks[i].n) memcpy(cells->c + cells->n, chunks[i].c, chunks[i].n * sizeof *cells->c);
    cells->n += chunks[i].n;
  }
  return 1;
}

mgs_status cub_sparse_gradient_cells(const prep *p, cub_field *f, cub_cells *cells, size_t *band, mgs_error *err) {
  *band = 0;
  f->lo_skip = sparse_lo_skip;
  cub_lower_star_tables();
  size_t nch = (p->nleaf + GCHUNK - 1) / GCHUNK;
  grad_ctx g = {p, f, calloc(nch + 1, sizeof(cub_cells)), calloc(nch + 1, sizeof(size_t)), calloc(nch + 1, sizeof(int))};
  size_t total = 0;
  int failed = !g.out || !g.band || !g.failed;
  if (!failed) {
    mgs_parallel_for(0, nch, 1, enum_gradient, &g);
    for (size_t i = 0; i < nch; i++) { total += g.out[i].n; *band += g.band[i]; failed |= g.failed[i]; }
  }
  if (!failed) failed = !concat_chunks(g.out, nch, total, cells);
  if (g.out)
    for (size_t i = 0; i < nch; i++) free(g.out[i].c);
  free(g.out); free(g.band); free(g.failed);
  if (failed) return mgs_error_set(err, MGS_ERR_NOMEM, "persistence: out of memory (critical cells)");
  return MGS_OK;
}

/* ---------------------------------------------------------------- leaf cache */
/* The last call's leaves, sorted by block key: each leaf's window hash, band count and
   critical cells (a range of one pool). */
struct mgs_topo_cache {
  int valid, construction;
  float lo, top;
  size_t n;
  uint64_t *key, *hash;
  size_t *band, *off, *cnt;
  cub_cell *cells;
};

static void cache_clear(mgs_topo_cache *c) {
  free(c->key); free(c->hash); free(c->band); free(c->off); free(c->cnt); free(c->cells);
  memset(c, 0, sizeof *c);
}

mgs_topo_cache *mgs_topo_cache_create(void) { return calloc(1, sizeof(mgs_topo_cache)); }
void mgs_topo_cache_destroy(mgs_topo_cache *c) {
  if (!c) return;
  cache_clear(c);
  free(c);
}

/* the window's bits and the neighbour mask (equal windows: equal cells; a hash collision
   between two different windows of one leaf position is left to 2^-64) */
static uint64_t window_hash(const float *w, uint32_t mask) {
  uint64_t h = 0x9e3779b97f4a7c15ull ^ mask;
  for (size_t i = 0; i < (size_t)WX * WY * WZ; i++) {
    uint32_t x;
    memcpy(&x, w + i, 4);
    h = (h ^ x) * 0xff51afd7ed558ccdull;
    h ^= h >> 32;
  }
  return h;
}

static size_t cache_find(const mgs_topo_cache *c, uint64_t key) {
  size_t lo = 0, hi = c->n;
  while (lo < hi) {
    size_t mid = (lo + hi) / 2;
    if (c->key[mid] < key) lo = mid + 1;
    else hi = mid;
  }
  return lo < c->n && c->key[lo] == key ? lo : SIZE_MAX;
}

typedef struct cgrad_ctx {
  grad_ctx g;
  const mgs_topo_cache *old; /* NULL: nothing reusable */
  uint64_t *lkey, *lhash;    /* per leaf */
  size_t *lband, *lstart, *lcnt;
  uint8_t *lreused;
} cgrad_ctx;

static void enum_gradient_cached(void *vctx, size_t c0, size_t c1) {
  cgrad_ctx *cg = vctx;
  grad_ctx *g = &cg->g;
  const prep *p = g->p;
  const mgs_topo_cache *old = cg->old;
  float w[WX * WY * WZ];
  for (size_t ch = c0; ch < c1; ch++) {
    size_t band = 0;
    cub_cells *out = &g->out[ch];
    size_t l1 = (ch + 1) * GCHUNK < p->nleaf ? (ch + 1) * GCHUNK : p->nleaf;
    for (size_t li = ch * GCHUNK; li < l1 && !g->failed[ch]; li++) {
      size_t b = p->leaves[li];
      const int32_t *o = p->s->origin + 3 * b;
      cub_sparse_load_window(p, b, w);
      uint64_t key = block_key(o[0] >> 3, o[1] >> 3, o[2] >> 3), h = window_hash(w, cub_sparse_leaf_neighbours(p, b));
      cg->lkey[li] = key;
      cg->lhash[li] = h;
      cg->lstart[li] = out->n;
      size_t at = old ? cache_find(old, key) : SIZE_MAX, lb;
      if (at != SIZE_MAX && old->hash[at] == h) {
        for (size_t i = 0; i < old->cnt[at] && !g->failed[ch]; i++)
          if (!push_cell(out, old->cells[old->off[at] + i].key, old->cells[old->off[at] + i].v)) g->failed[ch] = 1;
        lb = old->band[at];
        cg->lreused[li] = 1;
      } else {
        lb = leaf_cells(p, g->f, b, w, out, &g->failed[ch]);
        cg->lreused[li] = 0;
      }
      cg->lband[li] = lb;
      cg->lcnt[li] = out->n - cg->lstart[li];
      band += lb;
    }
    g->band[ch] = band;
  }
}

typedef struct keyed_leaf { uint64_t key; size_t li; } keyed_leaf;
static int cmp_leaf_key(const void *a, const void *b) {
  uint64_t x = ((const keyed_leaf *)a)->key, y = ((const keyed_leaf *)b)->key;
  return x < y ? -1 : (x > y);
}

mgs_status cub_sparse_gradient_cells_cached(const prep *p, cub_field *f, mgs_topo_cache *cache, cub_cells *cells, size_t *band,
                                            size_t *reused, mgs_error *err) {
  *band = 0;
  *reused = 0;
  f->lo_skip = sparse_lo_skip;
  cub_lower_star_tables();
  const size_t nch = (p->nleaf + GCHUNK - 1) / GCHUNK, nl = p->nleaf ? p->nleaf : 1;
  cgrad_ctx cg = {{p, f, calloc(nch + 1, sizeof(cub_cells)), calloc(nch + 1, sizeof(size_t)), calloc(nch + 1, sizeof(int))},
                  cache->valid && cache->lo == f->lo && cache->top == f->top && cache->construction == f->construction ? cache : NULL,
                  malloc(nl * sizeof(uint64_t)), malloc(nl * sizeof(uint64_t)), malloc(nl * sizeof(size_t)),
                  malloc(nl * sizeof(size_t)), malloc(nl * sizeof(size_t)), malloc(nl)};
  grad_ctx *g = &cg.g;
  size_t total = 0;
  keyed_leaf *order = malloc(nl * sizeof *order);
  mgs_topo_cache next = {0};
  int failed = !g->out || !g->band || !g->failed || !cg.lkey || !cg.lhash || !cg.lband || !cg.lstart || !cg.lcnt || !cg.lreused ||
               !order;
  if (!failed) {
    mgs_parallel_for(0, nch, 1, enum_gradient_cached, &cg);
    for (size_t i = 0; i < nch; i++) { total += g->out[i].n; *band += g->band[i]; failed |= g->failed[i]; }
  }
  if (!failed) failed = !concat_chunks(g->out, nch, total, cells);
  if (!failed) {
    /* this call's leaves become the cache: sorted by key, cells in that order */
    next.key = malloc(nl * sizeof(uint64_t)); next.hash = malloc(nl * sizeof(uint64_t));
    next.band = malloc(nl * sizeof(size_t)); next.off = malloc(nl * sizeof(size_t)); next.cnt = malloc(nl * sizeof(size_t));
    next.cells = malloc((total ? total : 1) * sizeof(cub_cell));
    failed = !next.key || !next.hash || !next.band || !next.off || !next.cnt || !next.cells;
  }
  if (!failed) {
    for (size_t li = 0; li < p->nleaf; li++) order[li].key = cg.lkey[li], order[li].li = li, *reused += cg.lreused[li];
    qsort(order, p->nleaf, sizeof *order, cmp_leaf_key);
    size_t at = 0;
    for (size_t j = 0; j < p->nleaf; j++) {
      size_t li = order[j].li;
      next.key[j] = cg.lkey[li]; next.hash[j] = cg.lhash[li]; next.band[j] = cg.lband[li];
      next.off[j] = at; next.cnt[j] = cg.lcnt[li];
      if (cg.lcnt[li]) memcpy(next.cells + at, g->out[li / GCHUNK].c + cg.lstart[li], cg.lcnt[li] * sizeof(cub_cell));
      at += cg.lcnt[li];
    }
    next.n = p->nleaf;
    next.valid = 1;
    next.lo = f->lo; next.top = f->top; next.construction = f->construction;
    cache_clear(cache);
    *cache = next;
  } else {
    cache_clear(&next);
    cache_clear(cache); /* a failed call leaves nothing stale behind */
  }
  if (g->out)
    for (size_t i = 0; i < nch; i++) free(g->out[i].c);
  free(g->out); free(g->band); free(g->failed);
  free(cg.lkey); free(cg.lhash); free(cg.lband); free(cg.lstart); free(cg.lcnt); free(cg.lreused); free(order);
  if (failed) return mgs_error_set(err, MGS_ERR_NOMEM, "persistence: out of memory (critical cells)");
  return MGS_OK;
}

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

static void enum_gradient(void *vctx, size_t c0, size_t c1) {
  grad_ctx *g = vctx;
  const prep *p = g->p;
  const float lo = g->f->lo, top = g->f->top;
  const int cons = g->f->construction, dual = cons == MGS_TOPO_T; /* T: cells 2v + 1 + d */
  float w[WX * WY * WZ];
  for (size_t ch = c0; ch < c1; ch++) {
    cub_cells *out = &g->out[ch];
    size_t band = 0;
    size_t l1 = (ch + 1) * GCHUNK < p->nleaf ? (ch + 1) * GCHUNK : p->nleaf;
    for (size_t li = ch * GCHUNK; li < l1 && !g->failed[ch]; li++) {
      size_t b = p->leaves[li];
      const int32_t *o = p->s->origin + 3 * b;
      cub_sparse_load_window(p, b, w);
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
              if (!push_cell(out, cc[i].key, cc[i].v)) g->failed[ch] = 1;
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
                if (!push_cell(out, cub_key(a + 2 * o[0], bb + 2 * o[1], c + 2 * o[2]), lo)) g->failed[ch] = 1;
              }
          }
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
  if (!failed) {
    cells->c = malloc((total ? total : 1) * sizeof *cells->c);
    cells->cap = total ? total : 1;
    failed = !cells->c;
  }
  if (!failed) {
    for (size_t i = 0; i < nch; i++) {
      if (g.out[i].n) memcpy(cells->c + cells->n, g.out[i].c, g.out[i].n * sizeof *cells->c);
      cells->n += g.out[i].n;
    }
  }
  if (g.out)
    for (size_t i = 0; i < nch; i++) free(g.out[i].c);
  free(g.out); free(g.band); free(g.failed);
  if (failed) return mgs_error_set(err, MGS_ERR_NOMEM, "persistence: out of memory (critical cells)");
  return MGS_OK;
}

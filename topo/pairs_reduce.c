/* Dimensions 1 and 2: boundary-matrix reduction (standard column algorithm, columns in
 * filtration order) over the reduced complex. Dimension 2 goes through the dual union-find
 * (topo/pairs_dual.c) by default; its twist reduction here is the reference path
 * (opts.d2_reduction) and the fallback. Dimension 1 uses clearing (2-cells born in a
 * dimension-2 pair, however found, are never reduced) and compression (edges that kill a
 * component are dropped as rows: Bauer-Kerber-Reininghaus, "Clear and Compress"). Most
 * columns are apparent pairs and stop at their first pivot. */
#include <stdlib.h>
#include <string.h>
#include "topo/cubical_internal.h"

typedef struct col_store {
  uint32_t *pool; size_t n, cap;   /* concatenated stored columns */
  size_t *start; uint32_t *len;    /* per stored column */
  size_t ncols, colcap;
} col_store;

static int store_col(col_store *s, const uint32_t *c, uint32_t len, uint32_t *id) {
  if (s->n + len > s->cap) {
    size_t cap = s->cap ? s->cap * 2 : 1 << 16;
    while (cap < s->n + len) cap *= 2;
    uint32_t *np = realloc(s->pool, cap * sizeof *np);
    if (!np) return 0;
    s->pool = np; s->cap = cap;
  }
  if (s->ncols == s->colcap) {
    size_t cap = s->colcap ? s->colcap * 2 : 1 << 12;
    size_t *ns = realloc(s->start, cap * sizeof *ns);
    if (!ns) return 0;
    s->start = ns;
    uint32_t *nl = realloc(s->len, cap * sizeof *nl);
    if (!nl) return 0;
    s->len = nl; s->colcap = cap;
  }
  memcpy(s->pool + s->n, c, len * sizeof *c);
  s->start[s->ncols] = s->n;
  s->len[s->ncols] = len;
  s->n += len;
  *id = (uint32_t)s->ncols++;
  return 1;
}

/* dst = a xor b (both ascending); returns the length. */
static size_t sym_diff(const uint32_t *a, size_t na, const uint32_t *b, size_t nb, uint32_t *dst) {
  size_t i = 0, j = 0, n = 0;
  while (i < na && j < nb) {
    if (a[i] < b[j]) dst[n++] = a[i++];
    else if (a[i] > b[j]) dst[n++] = b[j++];
    else { i++; j++; }
  }
  while (i < na) dst[n++] = a[i++];
  while (j < nb) dst[n++] = b[j++];
  return n;
}

/* Reduces every column of dimension `dim` (skipping those flagged skip_col), dropping rows
 * flagged drop_row; pivot rows get mark_row. Zero columns are reported via zero_dim. */
#define SELF 0x80000000u

static mgs_status reduce(const cub_complex *cx, int dim, uint8_t *flags, uint8_t skip_col,
                         uint8_t drop_row, uint8_t mark_row, int zero_dim, cub_pairs *out,
                         mgs_error *err) {
  mgs_status st = MGS_OK;
  uint32_t *piv = malloc(cx->n * sizeof *piv);
  col_store s = {0};
  size_t wcap = 64, obcap = 64;
  uint32_t *w = malloc(wcap * sizeof *w), *t = malloc(wcap * sizeof *t), *ob = malloc(obcap * sizeof *ob);
  if (!piv || !w || !t || !ob) { st = mgs_error_set(err, MGS_ERR_NOMEM, "persistence: out of memory (reduction)"); goto done; }
  memset(piv, 0xff, cx->n * sizeof *piv);
  if (cx->n >= SELF) { st = mgs_error_set(err, MGS_ERR_NOMEM, "persistence: %zu cells exceed the 2^31 limit", cx->n); goto done; }
  for (size_t r = 0; r < cx->n; r++) {
    if ((flags[r] & skip_col) || cub_key_dim(cx->cells[r].key) != dim) continue;
    uint32_t sc[6];
    const uint32_t *bd;
    int nb = cub_boundary(cx, (uint32_t)r, sc, &bd, err);
    if (nb < 0) { st = err ? err->code : MGS_ERR_FORMAT; goto done; }
    size_t n = 0;
    int xored = 0;
    if ((size_t)nb > wcap) {
      while (wcap < (size_t)nb) wcap *= 2;
      uint32_t *nw = realloc(w, wcap * sizeof *w), *nt = nw ? realloc(t, wcap * sizeof *t) : NULL;
      if (nw) w = nw;
      if (!nw || !nt) { st = mgs_error_set(err, MGS_ERR_NOMEM, "persistence: out of memory (column)"); goto done; }
      t = nt;
    }
    for (int i = 0; i < nb; i++)
      if (!(flags[bd[i]] & drop_row)) w[n++] = bd[i];
    while (n > 0) {
      uint32_t low = w[n - 1];
      uint32_t id = piv[low];
      if (id == UINT32_MAX) {
        /* a column that met no earlier pivot is its own boundary: remember its rank only
         * (SELF bit) and recompute it if it is ever needed; store reduced ones */
        if (!xored) id = SELF | (uint32_t)r;
        else if (!store_col(&s, w, (uint32_t)n, &id)) { st = mgs_error_set(err, MGS_ERR_NOMEM, "persistence: out of memory (columns)"); goto done; }
        piv[low] = id;
        flags[low] |= mark_row;
        if ((st = cub_pairs_push(out, (uint32_t)(dim - 1), low, (uint32_t)r, err)) != MGS_OK) goto done;
        break;
      }
      xored = 1;
      const uint32_t *other;
      uint32_t olen;
      if (id & SELF) {
        int k = cub_boundary(cx, id & ~SELF, sc, &bd, err);
        if (k < 0) { st = err ? err->code : MGS_ERR_FORMAT; goto done; }
        if ((size_t)k > obcap) {
          uint32_t *no = realloc(ob, (size_t)k * 2 * sizeof *ob);
          if (!no) { st = mgs_error_set(err, MGS_ERR_NOMEM, "persistence: out of memory (column)"); goto done; }
          ob = no;
          obcap = (size_t)k * 2;
        }
        olen = 0;
        for (int i = 0; i < k; i++)
          if (!(flags[bd[i]] & drop_row)) ob[olen++] = bd[i];
        other = ob;
      } else {
        other = s.pool + s.start[id];
        olen = s.len[id];
      }
      size_t need = n + olen;
      if (need > wcap) {
        while (wcap < need) wcap *= 2;
        uint32_t *nw = realloc(w, wcap * sizeof *w), *nt = nw ? realloc(t, wcap * sizeof *t) : NULL;
        if (nw) w = nw;
        if (!nw || !nt) { st = mgs_error_set(err, MGS_ERR_NOMEM, "persistence: out of memory (column)"); goto done; }
        t = nt;
      }
      n = sym_diff(w, n, other, olen, t);
      uint32_t *x = w; w = t; t = x;
    }
    if (n == 0 && zero_dim >= 0)
      if ((st = cub_pairs_push(out, (uint32_t)zero_dim, (uint32_t)r, UINT32_MAX, err)) != MGS_OK) goto done;
  }
done:
  free(piv); free(w); free(t); free(ob);
  free(s.pool); free(s.start); free(s.len);
  return st;
}

mgs_status cub_pairs_d2(const cub_complex *cx, uint8_t *flags, cub_pairs *out, mgs_error *err) {
  /* a zero 3-column would be an H3 class: impossible in R^3, so not reported */
  return reduce(cx, 3, flags, 0, 0, CUB_CLEARED, -1, out, err);
}

mgs_status cub_pairs_d1(const cub_complex *cx, uint8_t *flags, cub_pairs *out, mgs_error *err) {
  /* zero 2-columns that are not D2 births are essential voids */
  mgs_status st = reduce(cx, 2, flags, CUB_CLEARED, CUB_NEG, CUB_PAIRED_ROW, 2, out, err);
  if (st != MGS_OK) return st;
  for (size_t r = 0; r < cx->n; r++)
    if (!(flags[r] & (CUB_NEG | CUB_PAIRED_ROW)) && cub_key_dim(cx->cells[r].key) == 1)
      if ((st = cub_pairs_push(out, 1, (uint32_t)r, UINT32_MAX, err)) != MGS_OK) return st;
  return MGS_OK;
}

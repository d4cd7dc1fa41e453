/* Dimension 2 by union-find on the dual (the (2,3) step of TTK's discrete Morse sandwich,
 * Guillou-Vidal-Tierny 2023), instead of reducing the 3-cell columns.
 *
 * Why it is exact: the reduced (Morse) complex K lives in the cubical grid of R^3, so a
 * 2-cell has at most two cofaces there; in the Morse complex its coboundary is the set of
 * ends of its (at most two) ascending V-paths, mod 2: critical 3-cells (maxima), or the
 * outside (cells of value >= top, or beyond the box) when a path leaves K. Give the outside
 * one extra node, entered before every 3-cell and never killed. Then every 2-cell joins at
 * most two nodes, the anti-transposed boundary matrix is a graph's incidence matrix, and its
 * reduction is Kruskal's union-find with the elder rule: sweeping 2-cells by decreasing rank,
 * a 2-cell that joins two components is born in a pair with the younger component's
 * oldest 3-cell (its highest rank); one that joins a component to itself is not paired here.
 * Pairs equal the twist reduction's (persistence pairs are invariant under anti-transposition;
 * the outside column, the sum of all 3-columns, enters last and pairs with nothing). Merging
 * all of the outside into one node only hides 2-cells that separate two outside regions
 * (essential voids of K): they stay unpaired here and D1 finds them as zero columns, as
 * before. The coboundaries are the transpose of the 3-cells' Morse boundaries, already
 * computed, so no path is walked twice. If a 2-cell ever has more than two cofaces (not a
 * subcomplex of R^3: cannot happen), the caller falls back to the reduction. */
#include <stdlib.h>
#include <string.h>
#include "topo/cubical_internal.h"

#define NONE UINT32_MAX

static uint32_t find(uint32_t *parent, uint32_t x) {
  while (parent[x] != x) {
    parent[x] = parent[parent[x]];
    x = parent[x];
  }
  return x;
}

mgs_status cub_pairs_d2_dual(const cub_complex *cx, uint8_t *flags, cub_pairs *out, int *done,
                             mgs_error *err) {
  *done = 0;
  const size_t n = cx->n;
  const uint32_t out_node = (uint32_t)n; /* the outside: older than every 3-cell */
  if (n >= NONE - 1) return MGS_OK;      /* no room for the outside node: reduce instead */
  if (!cx->n_dim[3]) { *done = 1; return MGS_OK; } /* no maxima (smooth SDF bands): no pairs */
  /* One array per role, shared by disjoint rank sets: at a 2-cell rank, up[] and up2[] hold
   * its coboundary (NONE = empty), 3-cell ranks above it; at a 3-cell rank, up[] is the
   * union-find parent (itself until the sweep has passed it) and up2[] the 2-cell that kills
   * it, a rank below. So the sweeps below tell the roles apart without reading the keys. */
  uint32_t *up = malloc((n + 1) * sizeof *up), *up2 = malloc((n + 1) * sizeof *up2);
  mgs_status st = MGS_OK;
  if (!up || !up2) { st = mgs_error_set(err, MGS_ERR_NOMEM, "persistence: out of memory (dual union-find)"); goto fail; }
  memset(up, 0xff, (n + 1) * sizeof *up);
  memset(up2, 0xff, (n + 1) * sizeof *up2);
  up[out_node] = out_node;
  /* transpose the 3-cell boundaries (each already Z/2-reduced: a 3-cell appears once) */
  for (size_t r = 0; r < n; r++) {
    if (cub_key_dim(cx->cells[r].key) != 3) continue;
    up[r] = (uint32_t)r;
    uint32_t sc[6];
    const uint32_t *bd;
    int nb = cub_boundary(cx, (uint32_t)r, sc, &bd, err);
    if (nb < 0) { st = err ? err->code : MGS_ERR_FORMAT; goto fail; }
    for (int i = 0; i < nb; i++) {
      uint32_t s = bd[i];
      if (up[s] == NONE) up[s] = (uint32_t)r;
      else if (up2[s] == NONE) up2[s] = (uint32_t)r;
      else goto fallback; /* a third coface: not embedded in R^3 */
    }
  }
  /* 2-cells by decreasing rank: Kruskal on the dual graph, elder rule. Merges and path
   * compression only touch ranks above the current one, so a 3-cell still has up == itself. */
  for (size_t i = n; i-- > 0;) {
    if (up[i] == NONE || up[i] == i) continue; /* no coface / a 3-cell */
    uint32_t a = find(up, up[i]), b = find(up, up2[i] == NONE ? out_node : up2[i]);
    if (a == b) continue; /* joins a region to itself: negative, or an essential void (D1) */
    uint32_t young = a < b ? a : b, old = a < b ? b : a; /* a root is its oldest (highest) rank */
    up[young] = old;
    up2[young] = (uint32_t)i;
    flags[i] |= CUB_CLEARED;
  }
  /* push by increasing death rank: the order of the twist reduction (equal diagrams) */
  for (size_t r = 0; r < n && st == MGS_OK; r++)
    if (up2[r] < r) st = cub_pairs_push(out, 2, up2[r], (uint32_t)r, err); /* a killed 3-cell */
  if (st == MGS_OK) *done = 1;
  free(up);
  free(up2);
  return st;
fallback:
  free(up);
  free(up2);
  return MGS_OK;
fail:
  free(up);
  free(up2);
  return st;
}

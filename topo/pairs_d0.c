/* Dimension 0: union-find over the vertices and edges of the reduced complex in filtration
 * order (elder rule: the component with the younger oldest vertex dies at the edge). */
#include <stdlib.h>
#include "topo/cubical_internal.h"

static uint32_t find(uint32_t *parent, uint32_t x) {
  while (parent[x] != x) {
    parent[x] = parent[parent[x]];
    x = parent[x];
  }
  return x;
}

mgs_status cub_pairs_d0(const cub_complex *cx, uint8_t *flags, cub_pairs *out, mgs_error *err) {
  /* parent indexed by rank; only vertex ranks are used. A root's rank is its oldest vertex
   * because we always hang the younger root below the older one. */
  uint32_t *parent = malloc(cx->n * sizeof *parent);
  if (!parent) return mgs_error_set(err, MGS_ERR_NOMEM, "persistence: out of memory (union-find)");
  for (size_t i = 0; i < cx->n; i++) parent[i] = (uint32_t)i;
  mgs_status st = MGS_OK;
  for (size_t r = 0; r < cx->n; r++) {
    if (cub_key_dim(cx->cells[r].key) != 1) continue;
    uint32_t sc[6];
    const uint32_t *bd;
    int nb = cub_boundary(cx, (uint32_t)r, sc, &bd, err);
    if (nb < 0) { st = err ? err->code : MGS_ERR_FORMAT; break; }
    if (nb != 2) continue; /* a loop edge after collapse: positive */
    uint32_t u = find(parent, bd[0]), v = find(parent, bd[1]);
    if (u == v) continue; /* positive edge: creates a 1-cycle */
    uint32_t young = u > v ? u : v, old = u > v ? v : u;
    parent[young] = old;
    flags[r] |= CUB_NEG;
    flags[young] |= CUB_PAIRED_ROW;
    if ((st = cub_pairs_push(out, 0, young, (uint32_t)r, err)) != MGS_OK) break;
  }
  if (st == MGS_OK)
    for (size_t r = 0; r < cx->n; r++)
      if (parent[r] == r && cub_key_dim(cx->cells[r].key) == 0)
        if ((st = cub_pairs_push(out, 0, (uint32_t)r, UINT32_MAX, err)) != MGS_OK) break;
  free(parent);
  return st;
}

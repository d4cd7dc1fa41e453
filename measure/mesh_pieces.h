/* Connected pieces (triangles sharing vertices) and Euler characteristic V - E + F of a
 * triangle mesh, for the geometry reports (the "76 pieces, chi = -247" of the
 * alpha-surface vs a single genus-2 surface, chi = -2). Internal to measure/. */
#ifndef MGS_MESH_PIECES_H
#define MGS_MESH_PIECES_H
#include <stdint.h>
#include <stdlib.h>
#include "core/mgs_mesh.h"

static uint32_t mp_find(uint32_t *p, uint32_t x) {
  while (p[x] != x) x = p[x] = p[p[x]];
  return x;
}

static int mp_cmp_u64(const void *a, const void *b) {
  uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
  return x < y ? -1 : x > y;
}

/* Returns the number of pieces (0 on allocation failure); *chi the Euler characteristic. */
static inline size_t mgs_mesh_pieces(const mgs_mesh *m, long *chi) {
  uint32_t *p = malloc((m->nv ? m->nv : 1) * sizeof(uint32_t));
  uint64_t *e = malloc((m->nt ? 3 * m->nt : 1) * sizeof(uint64_t));
  unsigned char *used = calloc(m->nv ? m->nv : 1, 1);
  size_t pieces = 0;
  if (p && e && used) {
    for (size_t i = 0; i < m->nv; i++) p[i] = (uint32_t)i;
    for (size_t t = 0; t < m->nt; t++)
      for (int k = 0; k < 3; k++) {
        uint32_t a = m->t[3 * t + k], b = m->t[3 * t + (k + 1) % 3];
        used[a] = 1;
        uint32_t ra = mp_find(p, a), rb = mp_find(p, b);
        if (ra != rb) p[ra] = rb;
        e[3 * t + k] = a < b ? ((uint64_t)a << 32) | b : ((uint64_t)b << 32) | a;
      }
    size_t nv = 0;
    for (size_t i = 0; i < m->nv; i++) {
      nv += used[i];
      pieces += used[i] && mp_find(p, (uint32_t)i) == i;
    }
    qsort(e, 3 * m->nt, sizeof(uint64_t), mp_cmp_u64);
    size_t ne = 0;
    for (size_t i = 0; i < 3 * m->nt; i++) ne += i == 0 || e[i] != e[i - 1];
    if (chi) *chi = (long)nv - (long)ne + (long)m->nt;
  }
  free(p); free(e); free(used);
  return pieces;
}
#endif

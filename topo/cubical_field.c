/* Cells of the cubical complex over a clamped field: values, the voxel setting a value,
 * the key->rank map and the boundary in the reduced complex (with the -w collapse). */
#include <stdlib.h>
#include <string.h>
#include "topo/cubical_internal.h"

float cub_cell_value(const cub_field *f, int32_t a, int32_t b, int32_t c) {
  int32_t xs[2], ys[2], zs[2];
  int nx = cub_axis_voxels(f->construction, a, xs), ny = cub_axis_voxels(f->construction, b, ys),
      nz = cub_axis_voxels(f->construction, c, zs);
  if (f->construction == MGS_TOPO_V) {
    float m = -INFINITY;
    for (int i = 0; i < nx; i++)
      for (int j = 0; j < ny; j++)
        for (int k = 0; k < nz; k++) {
          float v = f->voxel(f->ctx, xs[i], ys[j], zs[k]);
          if (v > m) m = v;
        }
    return m;
  }
  float m = INFINITY;
  for (int i = 0; i < nx; i++)
    for (int j = 0; j < ny; j++)
      for (int k = 0; k < nz; k++) {
        float v = f->voxel(f->ctx, xs[i], ys[j], zs[k]);
        if (v < m) m = v;
      }
  return m;
}

void cub_cell_voxel(const cub_field *f, int32_t a, int32_t b, int32_t c, int32_t vox[3]) {
  int32_t xs[2], ys[2], zs[2];
  int nx = cub_axis_voxels(f->construction, a, xs), ny = cub_axis_voxels(f->construction, b, ys),
      nz = cub_axis_voxels(f->construction, c, zs);
  int first = 1;
  float best = 0;
  for (int i = 0; i < nx; i++)
    for (int j = 0; j < ny; j++)
      for (int k = 0; k < nz; k++) {
        float v = f->voxel(f->ctx, xs[i], ys[j], zs[k]);
        /* V: the max vertex, later index wins ties (the lower-star owner); T: the min voxel */
        int better = first || (f->construction == MGS_TOPO_V ? v >= best : v < best);
        if (better && isfinite(v)) { best = v; vox[0] = xs[i]; vox[1] = ys[j]; vox[2] = zs[k]; first = 0; }
      }
  if (first) { vox[0] = xs[0]; vox[1] = ys[0]; vox[2] = zs[0]; }
}

mgs_status cub_cells_push(cub_cells *l, uint64_t key, float v, mgs_error *err) {
  if (l->n == l->cap) {
    size_t cap = l->cap ? l->cap * 2 : 4096;
    cub_cell *nc = realloc(l->c, cap * sizeof *nc);
    if (!nc) return mgs_error_set(err, MGS_ERR_NOMEM, "persistence: out of memory (%zu cells)", cap);
    l->c = nc;
    l->cap = cap;
  }
  l->c[l->n].key = key;
  l->c[l->n].v = v;
  l->n++;
  return MGS_OK;
}

void cub_cells_free(cub_cells *l) {
  free(l->c);
  memset(l, 0, sizeof *l);
}

mgs_status cub_map_init(cub_map *m, size_t n, mgs_error *err) {
  size_t cap = 16;
  while (cap < n + n / 2) cap <<= 1; /* load factor <= 2/3 */
  m->slots = malloc(cap * sizeof *m->slots);
  if (!m->slots) {
    cub_map_free(m);
    return mgs_error_set(err, MGS_ERR_NOMEM, "persistence: out of memory (cell map of %zu)", cap);
  }
  memset(m->slots, 0xff, cap * sizeof *m->slots);
  m->mask = cap - 1;
  return MGS_OK;
}

void cub_map_free(cub_map *m) {
  free(m->slots);
  memset(m, 0, sizeof *m);
}

void cub_map_put(cub_map *m, uint64_t key, uint32_t val) {
  size_t i = cub_hash(key) & m->mask;
  while (m->slots[i].key != CUB_KEY_NONE && m->slots[i].key != key) i = (i + 1) & m->mask;
  m->slots[i].key = key;
  m->slots[i].val = val;
}

mgs_status cub_pairs_push(cub_pairs *l, uint32_t dim, uint32_t b, uint32_t d, mgs_error *err) {
  if (l->n == l->cap) {
    size_t cap = l->cap ? l->cap * 2 : 1024;
    cub_pair *np = realloc(l->p, cap * sizeof *np);
    if (!np) return mgs_error_set(err, MGS_ERR_NOMEM, "persistence: out of memory (%zu pairs)", cap);
    l->p = np;
    l->cap = cap;
  }
  l->p[l->n].dim = dim;
  l->p[l->n].birth = b;
  l->p[l->n].death = d;
  l->n++;
  return MGS_OK;
}

/* A face not in the reduced complex: a -w cell. Odd-x ones are matched with their right
 * x-face (contribute nothing); even-x ones are matched with their left x-coface, so the
 * gradient flow slides them left along x to the start of their run, which is kept. */
static uint32_t resolve_face(const cub_complex *cx, int32_t a, int32_t b, int32_t c, mgs_error *err,
                             int *skip) {
  const cub_field *f = cx->f;
  *skip = 0;
  float v = cub_cell_value(f, a, b, c);
  if (v != f->lo) {
    mgs_error_set(err, MGS_ERR_FORMAT, "persistence: cell (%d,%d,%d) of value %g is missing from the "
                  "band (broken narrow band?)", a, b, c, (double)v);
    return UINT32_MAX;
  }
  if (a & 1) { *skip = 1; return UINT32_MAX; }
  a = cub_lo_run_start(f, a, b, c);
  uint32_t r = cub_rank_get(cx, cub_key(a, b, c));
  if (r == UINT32_MAX)
    mgs_error_set(err, MGS_ERR_FORMAT, "persistence: interior region reaches voxel x=%d (cell %d,%d,%d) "
                  "without a band around it (broken narrow band)", a / 2, a, b, c);
  return r;
}

int32_t cub_lo_run_start(const cub_field *f, int32_t a, int32_t b, int32_t c) {
  for (;;) {
    if (f->lo_skip) a = f->lo_skip(f->ctx, a, b, c);
    if (cub_cell_value(f, a - 1, b, c) != f->lo) return a;
    a -= 2;
  }
}

int cub_boundary(const cub_complex *cx, uint32_t rank, uint32_t out[6], const uint32_t **outp,
                 mgs_error *err) {
  if (cx->bstart) {
    *outp = cx->bpool + cx->bstart[rank];
    return (int)(cx->bstart[rank + 1] - cx->bstart[rank]);
  }
  *outp = out;
  int32_t p[3];
  cub_unkey(cx->cells[rank].key, &p[0], &p[1], &p[2]);
  int n = 0;
  for (int ax = 0; ax < 3; ax++) {
    if (!(p[ax] & 1)) continue;
    for (int s = -1; s <= 1; s += 2) {
      int32_t q[3] = {p[0], p[1], p[2]};
      q[ax] += s;
      uint32_t r = cub_rank_get(cx, cub_key(q[0], q[1], q[2]));
      if (r == UINT32_MAX) {
        int skip;
        r = resolve_face(cx, q[0], q[1], q[2], err, &skip);
        if (skip) continue;
        if (r == UINT32_MAX) return -1;
      }
      out[n++] = r;
    }
  }
  /* sort ascending (n <= 6) and cancel equal pairs (Z/2) */
  for (int i = 1; i < n; i++) {
    uint32_t x = out[i];
    int j = i - 1;
    while (j >= 0 && out[j] > x) { out[j + 1] = out[j]; j--; }
    out[j + 1] = x;
  }
  int m = 0;
  for (int i = 0; i < n;) {
    if (i + 1 < n && out[i] == out[i + 1]) { i += 2; continue; }
    out[m++] = out[i++];
  }
  return m;
}

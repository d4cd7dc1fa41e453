/* Morton-curve partition of tiles into cost-balanced contiguous runs (see
 * train/mgs_partition.h). */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "core/mgs_camera.h"
#include "core/mgs_dataset.h"
#include "train/mgs_partition.h"

#define BITS 21
#define HALF (1 << (BITS - 1))

/* spreads the low 21 bits of x to every third bit */
static uint64_t spread3(uint64_t x) {
  x &= 0x1fffff;
  x = (x | x << 32) & 0x1f00000000ffffULL;
  x = (x | x << 16) & 0x1f0000ff0000ffULL;
  x = (x | x << 8) & 0x100f00f00f00f00fULL;
  x = (x | x << 4) & 0x10c30c30c30c30c3ULL;
  x = (x | x << 2) & 0x1249249249249249ULL;
  return x;
}

/* Tile coordinates counted from t0 (a tile index per axis): the scene's tiles sit centred
   in a power-of-two range of each axis, so the curve's cells are the scene's halves,
   quarters, ... and an axis with few tiles (a city's height) only splits at the finest
   levels. Counted from 0, the top-level cells met at the origin and the first split of a
   scene around it was a plane through the origin (a city on z = 0 was cut along its
   ground: every surface point on a block boundary; bench mpi found it). */
static uint64_t curve_pos(const float p[3], double inv, const double t0[3]) {
  uint64_t c[3];
  for (int k = 0; k < 3; k++) {
    double t = floor((double)p[k] * inv) - t0[k];
    if (!(t >= -HALF)) t = -HALF; /* NaN too */
    if (t > HALF - 1) t = HALF - 1;
    c[k] = (uint64_t)((int64_t)t + HALF);
  }
  return spread3(c[0]) | spread3(c[1]) << 1 | spread3(c[2]) << 2;
}

void mgs_partition_destroy(mgs_partition *p) {
  if (!p) return;
  free(p->split); free(p->lo); free(p->hi); free(p->count); free(p->cost);
  free(p);
}

typedef struct { uint64_t key; double w; } weighted_key;

static int cmp_weighted(const void *a, const void *b) {
  const weighted_key *x = a, *y = b;
  return x->key < y->key ? -1 : (x->key > y->key);
}

mgs_status mgs_partition_build(const float *xyz, size_t n, int ranks, double tile, mgs_partition **out, mgs_error *err) {
  return mgs_partition_build_weighted(xyz, NULL, n, ranks, tile, out, err);
}

mgs_status mgs_partition_build_weighted(const float *xyz, const double *cost, size_t n, int ranks, double tile,
                                        mgs_partition **out, mgs_error *err) {
  *out = NULL;
  if (ranks < 1 || ranks > 1 << 20) return mgs_error_set(err, MGS_ERR_ARG, "partition: %d ranks", ranks);
  double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  size_t nf = 0;
  for (size_t i = 0; i < n; i++) {
    const float *p = xyz + 3 * i;
    if (!isfinite(p[0]) || !isfinite(p[1]) || !isfinite(p[2])) continue;
    nf++;
    for (int k = 0; k < 3; k++) { lo[k] = fmin(lo[k], p[k]); hi[k] = fmax(hi[k], p[k]); }
  }
  if (!nf) return mgs_error_set(err, MGS_ERR_ARG, "partition: no finite point among %zu", n);
  if (!(tile > 0)) {
    double ext = 0, vol = 1;
    for (int k = 0; k < 3; k++) ext = fmax(ext, hi[k] - lo[k]);
    for (int k = 0; k < 3; k++) vol *= fmax(hi[k] - lo[k], 1e-3 * fmax(ext, 1e-9));
    tile = cbrt(vol * 256.0 / (double)nf);
    if (!(tile > 1e-9) || !isfinite(tile)) tile = 1.0;
  }
  if (cost)
    for (size_t i = 0; i < n; i++)
      if (!(cost[i] >= 0) || !isfinite(cost[i])) return mgs_error_set(err, MGS_ERR_ARG, "partition: cost %g of point %zu", cost[i], i);
  mgs_partition *p = calloc(1, sizeof *p);
  weighted_key *keys = malloc((nf ? nf : 1) * sizeof *keys);
  if (p) {
    p->split = calloc((size_t)ranks + 1, sizeof *p->split);
    p->lo = calloc((size_t)ranks, sizeof *p->lo);
    p->hi = calloc((size_t)ranks, sizeof *p->hi);
    p->count = calloc((size_t)ranks, sizeof *p->count);
    p->cost = calloc((size_t)ranks, sizeof *p->cost);
  }
  if (!p || !keys || !p->split || !p->lo || !p->hi || !p->count || !p->cost) {
    free(keys);
    mgs_partition_destroy(p);
    return mgs_error_set(err, MGS_ERR_NOMEM, "partition: out of memory for %zu points", n);
  }
  p->ranks = ranks;
  p->tile = tile;
  double inv = 1.0 / tile;
  for (int k = 0; k < 3; k++) {
    double a = floor(lo[k] * inv), nt = floor(hi[k] * inv) - a + 1, pow2 = 1;
    while (pow2 < nt && pow2 < HALF) pow2 *= 2;
    p->t0[k] = a - floor(0.5 * (pow2 - nt));
  }
  size_t m = 0;
  double total = 0;
  for (size_t i = 0; i < n; i++) {
    const float *q = xyz + 3 * i;
    if (!isfinite(q[0]) || !isfinite(q[1]) || !isfinite(q[2])) continue;
    keys[m].key = curve_pos(q, inv, p->t0);
    keys[m].w = cost ? cost[i] : 1.0;
    total += keys[m++].w;
  }
  qsort(keys, m, sizeof *keys, cmp_weighted);
  /* cut where the running cost reaches r/ranks of the total, moved to the next tile
     boundary (a tile is never split); no cost at all: by count */
  if (!(total > 0)) {
    for (size_t j = 0; j < m; j++) keys[j].w = 1.0;
    total = (double)m;
  }
  p->split[0] = 0;
  size_t j = 0;
  double run = 0;
  for (int r = 1; r < ranks; r++) {
    double target = total * (double)r / (double)ranks;
    while (j < m && run + keys[j].w <= target) run += keys[j++].w;
    while (j > 0 && j < m && keys[j].key == keys[j - 1].key) run += keys[j++].w;
    uint64_t s = j < m ? keys[j].key : UINT64_MAX;
    p->split[r] = s > p->split[r - 1] ? s : p->split[r - 1];
  }
  p->split[ranks] = UINT64_MAX;
  free(keys);
  for (int r = 0; r < ranks; r++)
    for (int k = 0; k < 3; k++) { p->lo[r][k] = INFINITY; p->hi[r][k] = -INFINITY; }
  for (size_t i = 0; i < n; i++) {
    const float *q = xyz + 3 * i;
    if (!isfinite(q[0]) || !isfinite(q[1]) || !isfinite(q[2])) continue;
    int r = mgs_partition_owner(p, q);
    p->count[r]++;
    p->cost[r] += cost ? cost[i] : 1.0;
    /* the box of the owner's tiles, not just its points */
    for (int k = 0; k < 3; k++) {
      double t0 = floor((double)q[k] * inv) * tile;
      p->lo[r][k] = fmin(p->lo[r][k], t0);
      p->hi[r][k] = fmax(p->hi[r][k], t0 + tile);
    }
  }
  *out = p;
  return MGS_OK;
}

int mgs_partition_owner(const mgs_partition *p, const float xyz[3]) {
  if (!isfinite(xyz[0]) || !isfinite(xyz[1]) || !isfinite(xyz[2])) return 0;
  uint64_t key = curve_pos(xyz, 1.0 / p->tile, p->t0);
  /* the last r with split[r] <= key */
  int lo = 0, hi = p->ranks - 1;
  while (lo < hi) {
    int mid = (lo + hi + 1) / 2;
    if (p->split[mid] <= key) lo = mid;
    else hi = mid - 1;
  }
  return lo;
}

typedef struct { uint64_t key; uint32_t idx; } keyed;

static int cmp_keyed(const void *a, const void *b) {
  const keyed *x = a, *y = b;
  if (x->key != y->key) return x->key < y->key ? -1 : 1;
  return x->idx < y->idx ? -1 : (x->idx > y->idx);
}

mgs_status mgs_partition_morton_order(const float *xyz, size_t n, double tile, uint32_t *perm, mgs_error *err) {
  if (n > UINT32_MAX) return mgs_error_set(err, MGS_ERR_ARG, "partition: %zu points exceed the 2^32 limit", n);
  if (!(tile > 0) || !isfinite(tile)) return mgs_error_set(err, MGS_ERR_ARG, "partition: tile side %g", tile);
  keyed *k = malloc((n ? n : 1) * sizeof *k);
  if (!k) return mgs_error_set(err, MGS_ERR_NOMEM, "partition: out of memory for %zu points", n);
  double inv = 1.0 / tile, t0[3] = {0, 0, 0};
  for (size_t i = 0; i < n; i++) { k[i].key = curve_pos(xyz + 3 * i, inv, t0); k[i].idx = (uint32_t)i; }
  qsort(k, n, sizeof *k, cmp_keyed);
  for (size_t i = 0; i < n; i++) perm[i] = k[i].idx;
  free(k);
  return MGS_OK;
}

mgs_status mgs_partition_view_chunks(const float *centers, size_t n, double tile, size_t chunk, uint32_t *chunk_of,
                                     mgs_error *err) {
  if (chunk < 1) return mgs_error_set(err, MGS_ERR_ARG, "partition: view chunk of %zu", chunk);
  uint32_t *perm = malloc((n ? n : 1) * sizeof *perm);
  if (!perm) return mgs_error_set(err, MGS_ERR_NOMEM, "partition: out of memory for %zu views", n);
  mgs_status st = mgs_partition_morton_order(centers, n, tile, perm, err);
  if (st == MGS_OK)
    for (size_t j = 0; j < n; j++) chunk_of[perm[j]] = (uint32_t)(j / chunk);
  free(perm);
  return st;
}

void mgs_partition_order_by_chunks(const uint32_t *chunk_of, size_t n, uint32_t *perm, uint32_t *scratch) {
  /* chunks in the order of their first view in perm; views of a chunk in perm's order */
  size_t n_chunks = 0;
  for (size_t j = 0; j < n; j++) if (chunk_of[j] + 1 > n_chunks) n_chunks = chunk_of[j] + 1;
  /* scratch: n_chunks rank slots then n output slots (2n is enough: n_chunks <= n) */
  uint32_t *rank = scratch, *out = scratch + n;
  for (size_t c = 0; c < n_chunks; c++) rank[c] = UINT32_MAX;
  uint32_t next = 0;
  for (size_t j = 0; j < n; j++) {
    uint32_t c = chunk_of[perm[j]];
    if (rank[c] == UINT32_MAX) rank[c] = next++;
  }
  /* counting sort by chunk rank, stable */
  uint32_t *start = malloc((n_chunks + 1) * sizeof *start);
  if (!start) return; /* keep perm as it is: an order hint only */
  memset(start, 0, (n_chunks + 1) * sizeof *start);
  for (size_t j = 0; j < n; j++) start[rank[chunk_of[perm[j]]] + 1]++;
  for (size_t c = 0; c < n_chunks; c++) start[c + 1] += start[c];
  for (size_t j = 0; j < n; j++) out[start[rank[chunk_of[perm[j]]]]++] = perm[j];
  memcpy(perm, out, n * sizeof *perm);
  free(start);
}

mgs_status mgs_partition_pixel_costs(const float *xyz, size_t n, const mgs_camera *cams, size_t n_cams, double *cost,
                                     mgs_error *err) {
  uint8_t *seen = malloc(n ? n : 1);
  double *pix = calloc(n ? n : 1, sizeof *pix);
  if (!seen || !pix) { free(seen); free(pix); return mgs_error_set(err, MGS_ERR_NOMEM, "partition: out of memory for %zu points", n); }
  double P = 0;
  for (size_t v = 0; v < n_cams; v++) {
    const mgs_camera *c = &cams[v];
    size_t k = 0;
    for (size_t i = 0; i < n; i++) {
      const double q[3] = {xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]};
      double u, w, z;
      seen[i] = (uint8_t)(isfinite(q[0]) && isfinite(q[1]) && isfinite(q[2]) && mgs_camera_project(c, q, &u, &w, &z) &&
                          u >= 0 && w >= 0 && u < c->width && w < c->height);
      k += seen[i];
    }
    if (!k) continue;
    /* the view's pixels shared among the points it sees */
    double share = (double)c->width * (double)c->height / (double)k;
    for (size_t i = 0; i < n; i++)
      if (seen[i]) pix[i] += share;
    P += (double)c->width * (double)c->height;
  }
  size_t nf = 0;
  for (size_t i = 0; i < n; i++) nf += isfinite(xyz[3 * i]) && isfinite(xyz[3 * i + 1]) && isfinite(xyz[3 * i + 2]);
  for (size_t i = 0; i < n; i++) cost[i] = (nf ? 1.0 / (double)nf : 0) + (P > 0 ? pix[i] / P : 0);
  free(seen); free(pix);
  return MGS_OK;
}

mgs_status mgs_partition_for_dataset(const mgs_dataset *ds, int ranks, int by_pixels, mgs_partition **out, mgs_error *err) {
  *out = NULL;
  if (!ds->init_points || !ds->init_points->n)
    return mgs_error_set(err, MGS_ERR_ARG, "partition: the dataset has no initial points (points3d.ply / SfM points)");
  const mgs_point_cloud *pc = ds->init_points;
  if (!by_pixels || ranks == 1) return mgs_partition_build(pc->xyz, pc->n, ranks, 0, out, err);
  size_t nv = ds->n_views[MGS_SPLIT_TRAIN];
  double *cost = malloc(pc->n * sizeof *cost);
  mgs_camera *cams = malloc((nv ? nv : 1) * sizeof *cams);
  mgs_status st = MGS_OK;
  if (!cost || !cams) st = mgs_error_set(err, MGS_ERR_NOMEM, "partition: out of memory for %zu points", pc->n);
  for (size_t v = 0; v < nv && !st; v++) cams[v] = ds->views[MGS_SPLIT_TRAIN][v].cam;
  if (!st) st = mgs_partition_pixel_costs(pc->xyz, pc->n, cams, nv, cost, err);
  if (!st) st = mgs_partition_build_weighted(pc->xyz, cost, pc->n, ranks, 0, out, err);
  free(cost); free(cams);
  return st;
}

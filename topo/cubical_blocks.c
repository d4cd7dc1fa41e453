/* The sparse input of the persistence engine: 8³ leaf blocks keyed by block coordinate,
 * constant tiles (stored per 8³ block, so their cost is per block, never per voxel) and a
 * background. The narrow-band path builds only the cells near leaves: the cells whose
 * anchor voxel lies within one voxel of a leaf, each claimed by exactly one leaf; constant
 * regions contribute no cells of their own (+w is never built; -w collapses along x to the
 * run ends next to the band, see topo/persistence.c). With the discrete gradient (default)
 * each leaf emits only the critical cells of the lower stars of its voxels plus the -w run
 * ends it owns (topo/sparse_gradient.c), and the Morse boundary walk skips -w tiles block by
 * block. Shared internals: topo/sparse_internal.h. */
#include <stdlib.h>
#include <string.h>
#include "core/mgs_log.h"
#include "core/mgs_parallel.h"
#include "topo/sparse_internal.h"

mgs_status mgs_topo_sparse_create(float background, mgs_topo_sparse **out, mgs_error *err) {
  if (!out) return mgs_error_set(err, MGS_ERR_ARG, "sparse field: null argument");
  if (!isfinite(background)) return mgs_error_set(err, MGS_ERR_NUMERIC, "sparse field: non-finite background");
  mgs_topo_sparse *s = calloc(1, sizeof *s);
  if (!s) return mgs_error_set(err, MGS_ERR_NOMEM, "sparse field: out of memory");
  s->background = background;
  if (cub_map_init(&s->map, 512, err) != MGS_OK) { free(s); return MGS_ERR_NOMEM; }
  s->map_cap = 512;
  *out = s;
  return MGS_OK;
}

void mgs_topo_sparse_destroy(mgs_topo_sparse *s) {
  if (!s) return;
  free(s->origin); free(s->type); free(s->cval); free(s->leaf_at); free(s->vals);
  cub_map_free(&s->map);
  free(s);
}

size_t mgs_topo_sparse_leaf_count(const mgs_topo_sparse *s) { return s ? s->nleaves : 0; }

static mgs_status grow(mgs_topo_sparse *s, mgs_error *err) {
  if (s->n == s->cap) {
    size_t cap = s->cap ? s->cap * 2 : 1024;
    int32_t *o = realloc(s->origin, cap * 3 * sizeof *o);
    if (o) s->origin = o;
    uint8_t *t = o ? realloc(s->type, cap) : NULL;
    if (t) s->type = t;
    float *c = t ? realloc(s->cval, cap * sizeof *c) : NULL;
    if (c) s->cval = c;
    size_t *l = c ? realloc(s->leaf_at, cap * sizeof *l) : NULL;
    if (!l) return mgs_error_set(err, MGS_ERR_NOMEM, "sparse field: out of memory (%zu blocks)", cap);
    s->leaf_at = l;
    s->cap = cap;
  }
  if (2 * (s->n + 1) > s->map_cap) { /* keep the block map at most half full */
    cub_map m;
    if (cub_map_init(&m, s->map_cap * 2, err) != MGS_OK) return MGS_ERR_NOMEM;
    for (size_t i = 0; i < s->n; i++)
      cub_map_put(&m, block_key(s->origin[3 * i] >> 3, s->origin[3 * i + 1] >> 3, s->origin[3 * i + 2] >> 3), (uint32_t)i);
    cub_map_free(&s->map);
    s->map = m;
    s->map_cap *= 2;
  }
  return MGS_OK;
}

static mgs_status add_block(mgs_topo_sparse *s, int32_t bx, int32_t by, int32_t bz, int type,
                            float cval, const float *vals, mgs_error *err) {
  if (bx < -65000 || bx > 65000 || by < -65000 || by > 65000 || bz < -65000 || bz > 65000) /* keys: 21 bits */
    return mgs_error_set(err, MGS_ERR_UNSUPPORTED, "sparse field: block (%d,%d,%d) beyond the +-520000 voxel range", bx, by, bz);
  uint64_t key = block_key(bx, by, bz);
  if (cub_map_get(&s->map, key) != UINT32_MAX)
    return mgs_error_set(err, MGS_ERR_ARG, "sparse field: block at voxel (%d,%d,%d) added twice", bx * 8, by * 8, bz * 8);
  mgs_status st = grow(s, err);
  if (st != MGS_OK) return st;
  size_t i = s->n++;
  s->origin[3 * i] = bx * 8; s->origin[3 * i + 1] = by * 8; s->origin[3 * i + 2] = bz * 8;
  s->type[i] = (uint8_t)type;
  s->cval[i] = cval;
  s->leaf_at[i] = 0;
  if (type == BLK_LEAF) {
    if (s->nvals + 512 > s->capvals) {
      size_t cap = s->capvals ? s->capvals * 2 : 512 * 256;
      float *nv = realloc(s->vals, cap * sizeof *nv);
      if (!nv) { s->n--; return mgs_error_set(err, MGS_ERR_NOMEM, "sparse field: out of memory (leaf values)"); }
      s->vals = nv; s->capvals = cap;
    }
    s->leaf_at[i] = s->nvals;
    memcpy(s->vals + s->nvals, vals, 512 * sizeof *vals);
    s->nvals += 512;
    s->nleaves++;
  }
  cub_map_put(&s->map, key, (uint32_t)i);
  return MGS_OK;
}

mgs_status mgs_topo_sparse_add_leaf(mgs_topo_sparse *s, const int32_t origin[3], const float values[512],
                                    mgs_error *err) {
  if (!s || !origin || !values) return mgs_error_set(err, MGS_ERR_ARG, "sparse field: null argument");
  if ((origin[0] & 7) || (origin[1] & 7) || (origin[2] & 7))
    return mgs_error_set(err, MGS_ERR_ARG, "sparse field: leaf origin (%d,%d,%d) is not a multiple of 8", origin[0], origin[1], origin[2]);
  for (int i = 0; i < 512; i++)
    if (!isfinite(values[i]))
      return mgs_error_set(err, MGS_ERR_NUMERIC, "sparse field: non-finite value in the leaf at (%d,%d,%d)", origin[0], origin[1], origin[2]);
  return add_block(s, origin[0] >> 3, origin[1] >> 3, origin[2] >> 3, BLK_LEAF, 0, values, err);
}

mgs_status mgs_topo_sparse_add_tile(mgs_topo_sparse *s, const int32_t origin[3], int32_t dim, float value,
                                    mgs_error *err) {
  if (!s || !origin) return mgs_error_set(err, MGS_ERR_ARG, "sparse field: null argument");
  if (dim < 8 || (dim & 7) || (origin[0] & 7) || (origin[1] & 7) || (origin[2] & 7))
    return mgs_error_set(err, MGS_ERR_ARG, "sparse field: tile at (%d,%d,%d) of size %d is not on the 8-voxel grid", origin[0], origin[1], origin[2], dim);
  if (!isfinite(value)) return mgs_error_set(err, MGS_ERR_NUMERIC, "sparse field: non-finite tile value at (%d,%d,%d)", origin[0], origin[1], origin[2]);
  if (value == s->background) return MGS_OK; /* same as no tile */
  if (dim > 512)
    return mgs_error_set(err, MGS_ERR_UNSUPPORTED, "sparse field: tile of %d^3 voxels with a non-background value (at most 512^3)", dim);
  s->ntiles_in++;
  int32_t nb = dim / 8;
  for (int32_t i = 0; i < nb; i++)
    for (int32_t j = 0; j < nb; j++)
      for (int32_t k = 0; k < nb; k++) {
        mgs_status st = add_block(s, (origin[0] >> 3) + i, (origin[1] >> 3) + j, (origin[2] >> 3) + k, BLK_TILE, value, NULL, err);
        if (st != MGS_OK) return st;
      }
  return MGS_OK;
}

mgs_status mgs_topo_sparse_from_dense(const float *values, int nx, int ny, int nz, float w,
                                      mgs_topo_sparse **out, mgs_error *err) {
  if (!values || !out || nx < 1 || ny < 1 || nz < 1 || !(w > 0))
    return mgs_error_set(err, MGS_ERR_ARG, "sparse field: bad dense input");
  mgs_status st = mgs_topo_sparse_create(w, out, err);
  if (st != MGS_OK) return st;
  float blk[512];
  for (int bx = 0; bx < (nx + 7) / 8; bx++)
    for (int by = 0; by < (ny + 7) / 8; by++)
      for (int bz = 0; bz < (nz + 7) / 8; bz++) {
        int constant = 1;
        for (int i = 0; i < 8; i++)
          for (int j = 0; j < 8; j++)
            for (int k = 0; k < 8; k++) {
              int x = bx * 8 + i, y = by * 8 + j, z = bz * 8 + k;
              float v = (x < nx && y < ny && z < nz) ? values[((size_t)x * ny + y) * nz + z] : w;
              v = v < -w ? -w : (v > w ? w : v);
              blk[(i << 6) | (j << 3) | k] = v;
              if (v != blk[0]) constant = 0;
            }
        int32_t o[3] = {bx * 8, by * 8, bz * 8};
        st = constant ? mgs_topo_sparse_add_tile(*out, o, 8, blk[0], err) : mgs_topo_sparse_add_leaf(*out, o, blk, err);
        if (st != MGS_OK) { mgs_topo_sparse_destroy(*out); *out = NULL; return st; }
      }
  return MGS_OK;
}

float cub_sparse_voxel(const void *ctx, int32_t x, int32_t y, int32_t z) {
  const prep *p = ctx;
  uint32_t b = cub_map_get(&p->s->map, block_key(x >> 3, y >> 3, z >> 3));
  if (b == UINT32_MAX) return p->top;
  if (p->leaf_slot[b] == SIZE_MAX) return p->cval[b];
  return p->vals[p->leaf_slot[b] * 512 + (size_t)(((x & 7) << 6) | ((y & 7) << 3) | (z & 7))];
}

/* Which of the 27 neighbour offsets (dx,dy,dz in -1..1; bit (dx+1)*9+(dy+1)*3+dz+1) hold a leaf. */
uint32_t cub_sparse_leaf_neighbours(const prep *p, size_t b) {
  const int32_t *o = p->s->origin + 3 * b;
  uint32_t mask = 0;
  for (int dx = -1; dx <= 1; dx++)
    for (int dy = -1; dy <= 1; dy++)
      for (int dz = -1; dz <= 1; dz++) {
        uint32_t nb = cub_map_get(&p->s->map, block_key((o[0] >> 3) + dx, (o[1] >> 3) + dy, (o[2] >> 3) + dz));
        if (nb != UINT32_MAX && p->leaf_slot[nb] != SIZE_MAX) mask |= 1u << ((dx + 1) * 9 + (dy + 1) * 3 + dz + 1);
      }
  return mask;
}

/* Neighbour offsets along one axis whose extended range [-1, 8] also holds relative coord i. */
static inline int cand(int i, int d[2]) {
  d[0] = 0;
  if (i <= 0) { d[1] = -1; return 2; }
  if (i >= 7) { d[1] = 1; return 2; }
  return 1;
}

/* A cell anchored at relative voxel (i,j,k) belongs to this leaf unless a lexicographically
 * smaller neighbour leaf also covers it. */
int cub_sparse_owns(uint32_t mask, int i, int j, int k) {
  int dx[2], dy[2], dz[2];
  int nx = cand(i, dx), ny = cand(j, dy), nz = cand(k, dz);
  for (int a = 0; a < nx; a++)
    for (int b = 0; b < ny; b++)
      for (int c = 0; c < nz; c++) {
        int x = dx[a], y = dy[b], z = dz[c];
        int neg = x < 0 || (x == 0 && (y < 0 || (y == 0 && z < 0)));
        if (neg && (mask >> ((x + 1) * 9 + (y + 1) * 3 + z + 1) & 1u)) return 0;
      }
  return 1;
}

/* The window from the 27 neighbour blocks (one block lookup each, not one per voxel). */
void cub_sparse_load_window(const prep *p, size_t b, float *w) {
  const int32_t *o = p->s->origin + 3 * b;
  const float *vals[27];
  float cval[27];
  for (int d = 0; d < 27; d++) {
    uint32_t nb = cub_map_get(&p->s->map, block_key((o[0] >> 3) + d / 9 - 1, (o[1] >> 3) + d / 3 % 3 - 1, (o[2] >> 3) + d % 3 - 1));
    vals[d] = NULL;
    if (nb == UINT32_MAX) cval[d] = p->top;
    else if (p->leaf_slot[nb] == SIZE_MAX) cval[d] = p->cval[nb];
    else vals[d] = p->vals + p->leaf_slot[nb] * 512;
  }
  for (int x = -2; x <= 9; x++) {
    int bx = x < 0 ? 0 : (x < 8 ? 1 : 2), lx = x & 7;
    for (int y = -1; y <= 9; y++) {
      int by = y < 0 ? 0 : (y < 8 ? 1 : 2), ly = y & 7;
      float *row = w + ((x + 2) * WY + (y + 1)) * WZ;
      for (int z = -1; z <= 9; z++) {
        int bz = z < 0 ? 0 : (z < 8 ? 1 : 2), d = bx * 9 + by * 3 + bz;
        row[z + 1] = vals[d] ? vals[d][(lx << 6) | (ly << 3) | (z & 7)] : cval[d];
      }
    }
  }
}

/* Two passes over the leaves (count, then fill at per-leaf offsets): one exact array. */
typedef struct enum_ctx {
  const prep *p;
  const cub_field *f;
  size_t *count;    /* per leaf (count pass) */
  const size_t *offset; /* per leaf (fill pass) */
  cub_cell *dst;    /* NULL in the count pass */
} enum_ctx;

static void enum_leaves(void *vctx, size_t b0, size_t b1) {
  enum_ctx *e = vctx;
  const prep *p = e->p;
  float w[WX * WY * WZ];
  int cons = e->f->construction;
  for (size_t li = b0; li < b1; li++) {
    size_t kept = 0;
    cub_cell *out = e->dst ? e->dst + e->offset[li] : NULL;
    size_t b = p->leaves[li];
    const int32_t *o = p->s->origin + 3 * b;
    cub_sparse_load_window(p, b, w);
    uint32_t mask = cub_sparse_leaf_neighbours(p, b);
    int base = cons == MGS_TOPO_V ? 0 : 1; /* doubled coordinate of anchor u: 2u + base */
    for (int i = -1; i <= 8; i++)
      for (int j = -1; j <= 8; j++)
        for (int k = -1; k <= 8; k++) {
          if ((i <= 0 || i >= 7 || j <= 0 || j >= 7 || k <= 0 || k >= 7) && !cub_sparse_owns(mask, i, j, k)) continue;
          for (int ex = 0; ex <= 1; ex++)
            for (int ey = 0; ey <= 1; ey++)
              for (int ez = 0; ez <= 1; ez++) {
                int32_t a = 2 * i + base + ex, bb = 2 * j + base + ey, c = 2 * k + base + ez;
                float v = wcell(cons, w, a, bb, c);
                if (!(v < e->f->top)) continue;
                if (!(v > e->f->lo)) {
                  if (a & 1) continue;
                  if (wcell(cons, w, a - 1, bb, c) == e->f->lo) continue;
                }
                if (out) {
                  out[kept].key = cub_key(a + 2 * o[0], bb + 2 * o[1], c + 2 * o[2]);
                  out[kept].v = v;
                }
                kept++;
              }
        }
    if (!e->dst) e->count[li] = kept;
  }
}

mgs_status mgs_topo_persistence_sparse_stats(const mgs_topo_sparse *s, const mgs_topo_opts *opts_in,
                                             double w_limit, mgs_diagram **out,
                                             mgs_topo_stats *stats_out, mgs_error *err) {
  double t0 = mgs_now();
  mgs_topo_opts opts;
  if (opts_in) opts = *opts_in; else mgs_topo_opts_default(&opts);
  if (!s || !out) return mgs_error_set(err, MGS_ERR_ARG, "persistence: null argument");
  *out = NULL;
  mgs_status st = mgs_topo_check_opts(&opts, err);
  if (st != MGS_OK) return st;
  prep p;
  memset(&p, 0, sizeof p);
  p.s = s;
  p.sign = opts.filtration == MGS_TOPO_SUPERLEVEL ? -1.0f : 1.0f;
  float bg = p.sign * s->background;
  double w = opts.half_width < w_limit ? opts.half_width : w_limit;
  if (bg > 0 && bg < w) w = bg; /* the band holds no values beyond its background */
  p.lo = (float)-w;
  p.top = (bg < (float)w ? bg : (float)w) + 0.0f; /* -0 -> +0 */
  if (!(p.top > p.lo))
    return mgs_error_set(err, MGS_ERR_UNSUPPORTED, "persistence: the background (%g) must be the largest value of the "
                         "filtration (use the superlevel filtration for fog volumes)", (double)s->background);
  mgs_topo_stats stats;
  memset(&stats, 0, sizeof stats);
  stats.effective_w = w;
  cub_field f = {cub_sparse_voxel, &p, p.lo, p.top, (int)opts.construction, NULL};
  cub_cells cells = {0};
  size_t *counts = NULL;
  p.leaf_slot = malloc((s->n + 1) * sizeof *p.leaf_slot);
  p.cval = malloc((s->n + 1) * sizeof *p.cval);
  p.leaves = malloc((s->n + 1) * sizeof *p.leaves);
  if (!p.leaf_slot || !p.cval || !p.leaves) { st = mgs_error_set(err, MGS_ERR_NOMEM, "persistence: out of memory"); goto done; }
  /* classify blocks; expand tiles strictly inside (lo, top) */
  size_t nslots = 0;
  int32_t lo3[3] = {INT32_MAX, INT32_MAX, INT32_MAX}, hi3[3] = {INT32_MIN, INT32_MIN, INT32_MIN};
  for (size_t b = 0; b < s->n; b++) {
    float c = s->type[b] == BLK_TILE ? clampf(&p, s->cval[b]) : 0;
    p.cval[b] = c;
    int leafy = s->type[b] == BLK_LEAF || (c > p.lo && c < p.top);
    p.leaf_slot[b] = leafy ? nslots++ : SIZE_MAX;
    if (leafy) p.leaves[p.nleaf++] = b;
    for (int k = 0; k < 3; k++) {
      if (s->origin[3 * b + k] < lo3[k]) lo3[k] = s->origin[3 * b + k];
      if (s->origin[3 * b + k] + 8 > hi3[k]) hi3[k] = s->origin[3 * b + k] + 8;
    }
  }
  p.vals = malloc((nslots ? nslots : 1) * 512 * sizeof *p.vals);
  if (!p.vals) { st = mgs_error_set(err, MGS_ERR_NOMEM, "persistence: out of memory (%zu leaves)", nslots); goto done; }
  for (size_t b = 0; b < s->n; b++) {
    if (p.leaf_slot[b] == SIZE_MAX) continue;
    float *dst = p.vals + p.leaf_slot[b] * 512;
    if (s->type[b] == BLK_LEAF) {
      const float *src = s->vals + s->leaf_at[b];
      for (int i = 0; i < 512; i++) dst[i] = clampf(&p, src[i]);
    } else {
      for (int i = 0; i < 512; i++) dst[i] = p.cval[b];
    }
  }
  /* an interior (bottom) block touching the background with no band between would hide
   * cells from the band enumeration: refuse it */
  for (size_t b = 0; b < s->n; b++) {
    if (p.leaf_slot[b] != SIZE_MAX || p.cval[b] != p.lo) continue;
    const int32_t *o = s->origin + 3 * b;
    for (int d = 0; d < 27; d++) {
      int dx = d / 9 - 1, dy = d / 3 % 3 - 1, dz = d % 3 - 1;
      uint32_t nb = cub_map_get(&s->map, block_key((o[0] >> 3) + dx, (o[1] >> 3) + dy, (o[2] >> 3) + dz));
      if (nb == UINT32_MAX || (p.leaf_slot[nb] == SIZE_MAX && p.cval[nb] == p.top)) {
        st = mgs_error_set(err, MGS_ERR_FORMAT, "persistence: broken narrow band: the interior block at voxel (%d,%d,%d) "
                           "touches the background with no band voxels between", o[0], o[1], o[2]);
        goto done;
      }
    }
  }
  stats.leaves = s->nleaves;
  stats.tiles = s->n - s->nleaves;
  stats.active_voxels = nslots * 512;
  if (s->n) {
    int ext = opts.construction == MGS_TOPO_V ? -1 : 1;
    stats.cells_total = 1;
    for (int k = 0; k < 3; k++) stats.cells_total *= (size_t)(2 * (hi3[k] - lo3[k]) + ext);
  }
  int gradient = !opts.full_reduction;
  size_t band = 0;
  p.construction = (int)opts.construction;
  if (gradient) {
    if (opts.cache) st = cub_sparse_gradient_cells_cached(&p, &f, opts.cache, &cells, &band, &stats.leaves_reused, err);
    else st = cub_sparse_gradient_cells(&p, &f, &cells, &band, err);
    if (st != MGS_OK) goto done;
    goto enumerated;
  }
  counts = malloc((p.nleaf + 1) * sizeof *counts);
  if (!counts) { st = mgs_error_set(err, MGS_ERR_NOMEM, "persistence: out of memory"); goto done; }
  enum_ctx ec = {&p, &f, counts, counts, NULL};
  mgs_parallel_for(0, p.nleaf, 16, enum_leaves, &ec);
  size_t total = 0;
  for (size_t li = 0; li < p.nleaf; li++) { size_t c = counts[li]; counts[li] = total; total += c; }
  cells.c = malloc((total ? total : 1) * sizeof *cells.c);
  if (!cells.c) { st = mgs_error_set(err, MGS_ERR_NOMEM, "persistence: out of memory (%zu cells)", total); goto done; }
  cells.cap = total ? total : 1;
  cells.n = total;
  ec.dst = cells.c;
  mgs_parallel_for(0, p.nleaf, 16, enum_leaves, &ec);
enumerated:
  stats.seconds_build = mgs_now() - t0;
  stats.peak_bytes = nslots * 512 * sizeof(float) + s->n * 24;
  {
    double vs = opts.voxel_size;
    cub_run run = {&f, &opts, vs, {opts.origin[0], opts.origin[1], opts.origin[2]}, 0, gradient, band};
    st = cub_persistence(&run, &cells, out, &stats, err);
  }
done:
  cub_cells_free(&cells);
  free(counts);
  free(p.leaf_slot); free(p.cval); free(p.leaves); free(p.vals);
  stats.seconds = mgs_now() - t0;
  if (*out) (*out)->seconds = stats.seconds;
  if (stats_out) *stats_out = stats;
  return st;
}

mgs_status mgs_topo_persistence_sparse(const mgs_topo_sparse *s, const mgs_topo_opts *opts,
                                       mgs_diagram **out, mgs_topo_stats *stats, mgs_error *err) {
  return mgs_topo_persistence_sparse_stats(s, opts, INFINITY, out, stats, err);
}

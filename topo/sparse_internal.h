/* Internal to the sparse (narrow-band) path of the persistence engine: the sparse input, its
 * prepared (clamped) view, the leaf windows and the cell ownership rule shared by the
 * full-reduction enumeration (topo/cubical_blocks.c) and the gradient enumeration
 * (topo/sparse_gradient.c). Not a public header. */
#ifndef MGS_SPARSE_INTERNAL_H
#define MGS_SPARSE_INTERNAL_H
#include <stdint.h>
#include "topo/cubical_internal.h"

enum { BLK_LEAF = 0, BLK_TILE = 1 };

struct mgs_topo_sparse {
  float background;
  size_t n, cap;
  int32_t *origin;   /* 3 per block */
  uint8_t *type;
  float *cval;       /* tile value */
  size_t *leaf_at;   /* leaf: offset of its 512 values in vals */
  float *vals;
  size_t nvals, capvals;
  size_t nleaves, ntiles_in;
  cub_map map;       /* block key -> block index (rebuilt when it fills) */
  size_t map_cap;
};

static inline uint64_t block_key(int32_t bx, int32_t by, int32_t bz) { return cub_key(bx, by, bz); }

/* ---------------------------------------------------------------- prepared view */
/* Clamped, sign-applied blocks. Tiles whose clamped value lies strictly between the bottom
 * and the top are expanded into leaves (they hold cells of their own). */
typedef struct prep {
  const mgs_topo_sparse *s;
  float lo, top, sign;
  float *vals;       /* 512 per block that acts as a leaf, else NULL */
  size_t *leaf_slot; /* block -> slot in vals (SIZE_MAX for constant blocks) */
  float *cval;       /* clamped constant per block */
  size_t nleaf;
  size_t *leaves;    /* block indices acting as leaves */
  int construction;
} prep;

static inline float clampf(const prep *p, float v) {
  v *= p->sign;
  return (v < p->lo ? p->lo : (v > p->top ? p->top : v)) + 0.0f;
}

/* The clamped value of voxel (x,y,z) (cub_field accessor; hash lookup of its block). */
float cub_sparse_voxel(const void *ctx, int32_t x, int32_t y, int32_t z);

/* Local window of a leaf: x in [-2, 9], y, z in [-1, 9] relative to its origin. */
#define WX 12
#define WY 11
#define WZ 11
static inline float win(const float *w, int x, int y, int z) { return w[((x + 2) * WY + (y + 1)) * WZ + (z + 1)]; }

/* value of the cell with doubled coordinates (a,b,c) relative to the leaf origin */
static inline float wcell(int cons, const float *w, int32_t a, int32_t b, int32_t c) {
  int32_t xs[2], ys[2], zs[2];
  int nx = cub_axis_voxels(cons, a, xs), ny = cub_axis_voxels(cons, b, ys), nz = cub_axis_voxels(cons, c, zs);
  float m = win(w, xs[0], ys[0], zs[0]);
  for (int i = 0; i < nx; i++)
    for (int j = 0; j < ny; j++)
      for (int k = 0; k < nz; k++) {
        float v = win(w, xs[i], ys[j], zs[k]);
        if (cons == MGS_TOPO_V ? v > m : v < m) m = v;
      }
  return m;
}

/* Which of the 27 neighbour blocks of block b hold a leaf (bit (dx+1)*9+(dy+1)*3+dz+1). */
uint32_t cub_sparse_leaf_neighbours(const prep *p, size_t b);
/* Whether the leaf with neighbour mask `mask` owns the cells anchored at relative voxel (i,j,k). */
int cub_sparse_owns(uint32_t mask, int i, int j, int k);
/* The WX*WY*WZ window of leaf b (block lookups, not voxel lookups). */
void cub_sparse_load_window(const prep *p, size_t b, float *w);
/* Gradient path: the critical cells of every leaf (lower stars of its voxels, -w run ends it
 * owns) into *cells, the band cell count into *band; sets f->lo_skip. */
mgs_status cub_sparse_gradient_cells(const prep *p, cub_field *f, cub_cells *cells, size_t *band, mgs_error *err);
/* The same through a cache of the last call's leaves (mgs_topo_cache), which it then holds
 * this call's; *reused: leaves taken from it. */
mgs_status cub_sparse_gradient_cells_cached(const prep *p, cub_field *f, mgs_topo_cache *cache, cub_cells *cells, size_t *band,
                                            size_t *reused, mgs_error *err);
#endif

/* Internal to the persistence engine (topo/ *.c): the clamped field accessor, cell keys in
 * the doubled grid, the reduced cell list and the pairing stages. Not a public header. */
#ifndef MGS_CUBICAL_INTERNAL_H
#define MGS_CUBICAL_INTERNAL_H
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include "core/mgs_error.h"
#include "topo/mgs_persistence.h"

/* Cells live in the doubled grid: coordinate a is even for a vertex position and odd for an
 * edge extent along that axis. V: voxel x <-> a = 2x. T: voxel x <-> a = 2x + 1.
 * Key = x-major packing of the three doubled coordinates (21 bits each, offset 2^20), so
 * comparing keys compares (a, b, c) lexicographically. */
#define CUB_OFF (1 << 20)
#define CUB_KEY_NONE UINT64_MAX
static inline uint64_t cub_key(int32_t a, int32_t b, int32_t c) {
  return ((uint64_t)(uint32_t)(a + CUB_OFF) << 42) | ((uint64_t)(uint32_t)(b + CUB_OFF) << 21) |
         (uint64_t)(uint32_t)(c + CUB_OFF);
}
static inline void cub_unkey(uint64_t k, int32_t *a, int32_t *b, int32_t *c) {
  *a = (int32_t)((k >> 42) & 0x1fffff) - CUB_OFF;
  *b = (int32_t)((k >> 21) & 0x1fffff) - CUB_OFF;
  *c = (int32_t)(k & 0x1fffff) - CUB_OFF;
}
static inline int cub_dim(int32_t a, int32_t b, int32_t c) { return (a & 1) + (b & 1) + (c & 1); }
static inline int cub_key_dim(uint64_t k) {
  int32_t a, b, c;
  cub_unkey(k, &a, &b, &c);
  return cub_dim(a, b, c);
}

/* The clamped field seen by the engine: voxel(x,y,z) returns the clamped (and, for
 * superlevel filtrations, negated) value, or +INFINITY where there is no voxel. */
typedef struct cub_field {
  float (*voxel)(const void *ctx, int32_t x, int32_t y, int32_t z);
  const void *ctx;
  float lo;   /* bottom clamp: cells of exactly this value are collapsed along x */
  float top;  /* cells with value >= top are not built (they enter last, all at once) */
  int construction; /* MGS_TOPO_V / MGS_TOPO_T */
  /* optional: given an even-x cell (a,b,c) of value lo, a smaller even a' such that every
   * cell (a'' ,b,c), a' <= a'' <= a, has value lo (e.g. the left edge of a -w tile); NULL:
   * walk voxel by voxel */
  int32_t (*lo_skip)(const void *ctx, int32_t a, int32_t b, int32_t c);
} cub_field;

/* A cell's filtration value (V: max of vertices; T: min of adjacent voxels). */
float cub_cell_value(const cub_field *f, int32_t a, int32_t b, int32_t c);
/* Whether cell (a,b,c) of value v belongs to the reduced complex. */
static inline int cub_keep(const cub_field *f, float v, int32_t a, int32_t b, int32_t c) {
  if (!(v < f->top)) return 0;
  if (v > f->lo) return 1;
  /* v == lo: keep only the left end of each x-run of lo cells (even a, left coface not lo) */
  return !(a & 1) && cub_cell_value(f, a - 1, b, c) != f->lo;
}
/* Left end of the x-run of lo cells holding the even-x lo cell (a,b,c): its a coordinate. */
int32_t cub_lo_run_start(const cub_field *f, int32_t a, int32_t b, int32_t c);
/* The voxel whose value sets the cell's value (V: max (value, index) vertex; T: min adjacent). */
void cub_cell_voxel(const cub_field *f, int32_t a, int32_t b, int32_t c, int32_t vox[3]);

/* ---------------------------------------------------------------- discrete gradient
 * ProcessLowerStars on one vertex (topo/gradient_lowerstar.c; T: on -f, read dually). Star
 * cells of vertex v are indexed ci = (dx+1)*9 + (dy+1)*3 + dz+1 (cell 2v + d in the doubled
 * grid; 13 = v). */
enum { CUB_LS_OUT = 0, CUB_LS_FREE = 1, CUB_LS_CRIT = 2, CUB_LS_PAIR = 3 };
typedef struct cub_ls {
  uint8_t state[27];   /* CUB_LS_OUT: not in the lower star */
  int8_t partner[27];  /* CUB_LS_PAIR: the star index of the other cell */
  uint8_t time[27];    /* classification order inside the lower star */
  uint8_t n;           /* cells in the lower star */
} cub_ls;
void cub_lower_star_tables(void); /* once, before any cub_lower_star call */
/* nb: the 27 clamped values around v (missing voxels +INFINITY), nb[13] = f(v). */
void cub_lower_star(const float nb[27], cub_ls *ls);
int cub_ls_dim(int ci);
/* Cheap pre-check: *ncells = |L(v)|; returns 0 when L(v) has no critical cell (a regular
 * vertex: its lower link is acyclic), 1 when cub_lower_star must run to find them. */
int cub_lower_star_count(const float nb[27], size_t *ncells);

/* Growable array of (key, value) cells: 12 bytes a cell (the dimension is in the key). */
typedef struct __attribute__((packed, aligned(4))) cub_cell { uint64_t key; float v; } cub_cell;
typedef struct cub_cells { cub_cell *c; size_t n, cap; } cub_cells;
mgs_status cub_cells_push(cub_cells *l, uint64_t key, float v, mgs_error *err);
/* The critical cells of L(v) (vertex (x,y,z) of value v) into out (may be NULL); the count.
 * base 0: V (cell 2v + d); base 1: T, the dual cells 2v + 1 + d. */
size_t cub_ls_critical(const cub_ls *ls, int32_t x, int32_t y, int32_t z, int base, float v, cub_cell *out);
void cub_cells_free(cub_cells *l);

/* Open-addressing map key -> rank (key and value side by side: one cache line per probe). */
typedef struct cub_slot { uint64_t key; uint32_t val; uint32_t pad; } cub_slot;
typedef struct cub_map { cub_slot *slots; size_t mask; } cub_map;
mgs_status cub_map_init(cub_map *m, size_t n, mgs_error *err);
void cub_map_free(cub_map *m);
void cub_map_put(cub_map *m, uint64_t key, uint32_t val);
static inline uint64_t cub_hash(uint64_t k) {
  k ^= k >> 33; k *= 0xff51afd7ed558ccdULL; k ^= k >> 33; k *= 0xc4ceb9fe1a85ec53ULL; k ^= k >> 33;
  return k;
}
static inline uint32_t cub_map_get(const cub_map *m, uint64_t key) {
  size_t i = cub_hash(key) & m->mask;
  for (;;) {
    if (m->slots[i].key == key) return m->slots[i].val;
    if (m->slots[i].key == CUB_KEY_NONE) return UINT32_MAX;
    i = (i + 1) & m->mask;
  }
}

/* The reduced complex sorted by (value, dim, key), with its boundary oracle. The key ->
 * rank index stores ranks only (4 bytes a slot) and checks keys against the sorted cells. */
typedef struct cub_complex {
  const cub_field *f;
  cub_cell *cells;   /* sorted; rank = index */
  size_t n;
  uint32_t *slot;    /* open addressing, UINT32_MAX = empty */
  size_t mask;
  size_t n_dim[4];
  /* Morse complex (gradient path): boundaries by rank as CSR, NULL for the plain complex */
  uint64_t *bstart;
  uint32_t *bpool;
} cub_complex;

static inline uint32_t cub_rank_get(const cub_complex *cx, uint64_t key) {
  size_t i = cub_hash(key) & cx->mask;
  for (;;) {
    uint32_t r = cx->slot[i];
    if (r == UINT32_MAX || cx->cells[r].key == key) return r;
    i = (i + 1) & cx->mask;
  }
}

/* Boundary of cell `rank` in the reduced (Morse) complex, as ascending ranks with Z/2
 * cancellation: *out points at scratch (plain complex, <= 6 entries) or at the stored Morse
 * boundary. Returns the count or -1 with err set (inconsistent band). */
int cub_boundary(const cub_complex *cx, uint32_t rank, uint32_t scratch[6], const uint32_t **out,
                 mgs_error *err);
/* Morse boundaries of every cell of cx (its cells are the critical cells of the gradient),
 * by V-path traversal in parallel (topo/morse_boundary.c): fills bstart/bpool. */
mgs_status cub_morse_boundaries(cub_complex *cx, mgs_error *err);

/* Pair records: dim, birth rank, death rank (UINT32_MAX for essential). */
typedef struct cub_pair { uint32_t dim, birth, death; } cub_pair;
typedef struct cub_pairs { cub_pair *p; size_t n, cap; } cub_pairs;
mgs_status cub_pairs_push(cub_pairs *l, uint32_t dim, uint32_t b, uint32_t d, mgs_error *err);

/* Stage flags per rank. */
enum { CUB_NEG = 1, CUB_CLEARED = 2, CUB_PAIRED_ROW = 4 };

/* Dimension 0: union-find over vertices and edges in rank order. Marks negative edges. */
mgs_status cub_pairs_d0(const cub_complex *cx, uint8_t *flags, cub_pairs *out, mgs_error *err);
/* Dimension 2: reduction of the 3-cell columns (twist). Marks cleared 2-cells. */
mgs_status cub_pairs_d2(const cub_complex *cx, uint8_t *flags, cub_pairs *out, mgs_error *err);
/* Dimension 2 by union-find on the dual graph (critical 3-cells + one outside node, joined by
 * the coboundaries of the 2-cells, topo/pairs_dual.c): same pairs and flags as cub_pairs_d2.
 * *done = 0 (nothing changed) when a 2-cell has more than two cofaces: reduce instead. */
mgs_status cub_pairs_d2_dual(const cub_complex *cx, uint8_t *flags, cub_pairs *out, int *done, mgs_error *err);
/* Dimension 1: reduction of the 2-cell columns with clearing (D2 births skipped) and
 * compression (negative edges dropped), then essentials of every dimension. */
mgs_status cub_pairs_d1(const cub_complex *cx, uint8_t *flags, cub_pairs *out, mgs_error *err);

/* Runs the whole pipeline on an unsorted cell list (consumed) and fills the diagram. */
typedef struct cub_run {
  const cub_field *f;
  const mgs_topo_opts *opts;
  double voxel_size, origin[3];
  int negate_output; /* unused: values are reported in filtration units */
  int gradient;      /* cells are the critical cells of the gradient: Morse boundaries */
  size_t band_cells; /* gradient path: cells below top in the band (what the plain path builds) */
} cub_run;
mgs_status cub_persistence(const cub_run *run, cub_cells *cells, mgs_diagram **out,
                           mgs_topo_stats *stats, mgs_error *err);

mgs_status mgs_topo_check_opts(const mgs_topo_opts *o, mgs_error *err);
/* The sparse path with the band's own half-width w_limit (VDB background; INFINITY: none). */
mgs_status mgs_topo_persistence_sparse_stats(const mgs_topo_sparse *s, const mgs_topo_opts *opts,
                                             double w_limit, mgs_diagram **out,
                                             mgs_topo_stats *stats, mgs_error *err);

/* Voxel coordinates spanned by doubled coordinate a along one axis (1 or 2 of them). V: even
 * a is a voxel, odd a the edge between two; T: odd a is a voxel's extent, even a the wall
 * between voxels a/2-1 and a/2. */
static inline int cub_axis_voxels(int construction, int32_t a, int32_t v[2]) {
  if (construction == MGS_TOPO_V) {
    if (!(a & 1)) { v[0] = a >> 1; return 1; }
    v[0] = (a - 1) >> 1; v[1] = (a + 1) >> 1; return 2;
  }
  if (a & 1) { v[0] = (a - 1) >> 1; return 1; }
  v[0] = (a >> 1) - 1; v[1] = a >> 1; return 2;
}
#endif

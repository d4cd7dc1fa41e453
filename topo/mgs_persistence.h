/* The persistence engine: persistence diagrams (dimensions 0, 1, 2, Z/2) of a scalar field
 * on a 3D cubical complex, dense or over a sparse narrow band (VDB leaves + constant tiles).
 * This header owns the options, the entry points and the sparse block input; the output
 * type is mgs_diagram (topo/mgs_diagram.h).
 *
 * Filtration. Values are (optionally negated for superlevel sets, then) clamped to
 * [-w, w]. Construction V (default): voxels are vertices, a cell's value is the max of its
 * vertices (lower star, Robins-Wood-Sheppard; as PHAT on the explicit V complex,
 * CubicalRipser V). Construction T: voxels are 3-cells, a cell's value is the min of its
 * cofaces (GUDHI's CubicalComplex(top_dimensional_cells), CubicalRipser T). Ties are
 * ordered by (value, dimension, cell index), cell index x-major over the doubled grid.
 *
 * Result = the diagram of the clamped field on the dense box that holds it: every pair of
 * positive persistence (> min_persistence), plus the essential classes (one H0 class for a
 * box). Two reductions keep the cost with the band, both exact (see topo/persistence.c):
 *   - cells at the top value (+w, the background) are never built: a class still alive
 *     below +w dies at +w in the box; it is reported with death = +w and truncated = 1;
 *   - cells at the bottom value (-w, interior tiles) are collapsed by an x-directed
 *     acyclic matching in closed form: only the left ends of x-runs of -w cells are kept.
 * Pairs whose death is +w or whose birth is -w were set by the clamp: truncated = 1.
 * Discrete gradient first: ProcessLowerStars (Robins-Wood-Sheppard) per voxel, per leaf in
 * parallel (topo/gradient_lowerstar.c; T through duality, the lower stars of -f), pairs cells
 * of equal value; only the critical cells (1-3 % of the band cells on SDF bands) are sorted,
 * and their boundaries are those of the Morse complex (V-path traversal in parallel,
 * topo/morse_boundary.c). The diagram equals the full reduction's exactly (values, cells
 * and voxels on generic fields); opts.full_reduction = 1 keeps that reference path.
 * Pairing: union-find for dimension 0, union-find on the dual (critical 3-cells + the
 * outside, joined by the 2-cells' coboundaries) for dimension 2 (topo/pairs_dual.c; the twist
 * reduction of the 3-cell columns with opts.d2_reduction = 1), reduction with clearing (the
 * D2 births) + compression for dimension 1 (topo/pairs_*.c).
 * Memory about 19-26 bytes per active voxel at 128^3-1024^3 (bench/RESULTS-topo.md).
 * Coordinates: |voxel index| < 2^19; at most 2^31 cells.
 *
 * Dense layout: values[(x*ny + y)*nz + z] (same as the VDB leaf order (x<<6)|(y<<3)|z),
 * voxel (x,y,z) at world origin + voxel_size * (x,y,z). */
#ifndef MGS_PERSISTENCE_H
#define MGS_PERSISTENCE_H
#include <stddef.h>
#include <stdint.h>
#include "core/mgs_error.h"
#include "topo/mgs_diagram.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct mgs_vdb_grid mgs_vdb_grid;

typedef enum mgs_topo_construction {
  MGS_TOPO_V = 0, /* voxels = vertices, lower star (default) */
  MGS_TOPO_T = 1  /* voxels = 3-cells, a cell's value = min of its cofaces */
} mgs_topo_construction;

typedef enum mgs_topo_filtration {
  MGS_TOPO_SUBLEVEL = 0,  /* SDF: sublevel sets {f <= t} */
  MGS_TOPO_SUPERLEVEL = 1 /* fog density: superlevel sets {f >= t}, computed as sublevel of -f;
                             births/deaths are reported in -f units (birth <= death) */
} mgs_topo_filtration;

/* The gradient path's per-leaf work kept between calls (incremental analyses of a field
 * that changed in a few places): the critical cells a leaf gives depend only on its window
 * (its values and its neighbours' next to it), which of its neighbours are leaves, the
 * clamp and the construction; a leaf whose window hashes as in the last call takes its
 * cells from the cache. The sort and the pairing, which are global, run whole. The diagram
 * equals an uncached call's (tests/topo/test_topo_cache). */
typedef struct mgs_topo_cache mgs_topo_cache;
mgs_topo_cache *mgs_topo_cache_create(void);
void mgs_topo_cache_destroy(mgs_topo_cache *c);

typedef struct mgs_topo_opts {
  mgs_topo_construction construction;
  mgs_topo_filtration filtration;
  double half_width;      /* clamp w: values clamped to [-w, w]; INFINITY = no clamp.
                             VDB path: w is also limited to the grid's |background| */
  double min_persistence; /* report pairs with death - birth > this (0: all positive) */
  double voxel_size;      /* world = origin + voxel_size * ijk (dense path; VDB: grid's) */
  double origin[3];
  int full_reduction;     /* 1: skip the discrete gradient and reduce every band cell (the
                             reference path, for tests and benchmarks); 0 (default): gradient */
  int d2_reduction;       /* 1: dimension-2 pairs by twist reduction of the 3-cell columns (the
                             previous path, for tests); 0 (default): union-find on the dual */
  mgs_topo_cache *cache;  /* sparse gradient path: reuse unchanged leaves' cells (NULL: none) */
} mgs_topo_opts;

void mgs_topo_opts_default(mgs_topo_opts *o); /* V, sublevel, w = inf, 0, 1, (0,0,0) */

/* The band's clamp to [-w, w] keeps a bar exact only when both of its ends lie strictly
 * inside. A bar alive at level t (birth <= t < death) with persistence p has both ends in
 * [t - p, t + p], so every such bar with p <= max_persistence is exact when
 * w > |t| + max_persistence. Returns that half-width in voxels: the smallest integer above
 * (|t| + max_persistence) / voxel_size, at least 1; -1 for non-finite or non-positive input.
 * Whoever thresholds persistence (the trainer's ε_sig and ε_p, `--min-persistence`) builds
 * the SDF with at least this band (`morsegs vdb --band`) rather than a fixed 3 voxels. */
int mgs_topo_band_for_threshold(double max_persistence, double level, double voxel_size);

typedef struct mgs_topo_stats {
  size_t active_voxels;   /* voxels the engine looked at (dense: all; sparse: leaf voxels) */
  size_t leaves, tiles;   /* sparse input blocks */
  size_t leaves_reused;   /* leaves whose critical cells came from opts.cache */
  size_t cells_total;     /* cells of the full complex on the bounding box (implicit) */
  size_t band_cells;      /* cells of the band below the top value (+w), -w cells collapsed
                             along x: what the full-reduction path sorts and reduces */
  size_t cells_built;     /* cells the sort and the pairing stages touch: the critical cells
                             of the discrete gradient, or band_cells (full_reduction) */
  size_t critical_cells;  /* critical cells of the discrete gradient (= cells_built) */
  double reduction_ratio; /* 1 - critical_cells / band_cells (0 without a gradient) */
  size_t persistent_cells; /* cells in positive-persistence pairs or essential classes (what an
                              optimal gradient would leave) */
  size_t pairs_d[3];      /* reported pairs per dimension (incl. essential) */
  size_t truncated;       /* reported pairs set by the clamp */
  int d2_union_find;      /* 1: dimension 2 was paired by the dual union-find (0: reduction) */
  double effective_w;     /* clamp actually used */
  double seconds_build;   /* input, cell enumeration and the gradient */
  double seconds_morse;   /* Morse boundaries (V-path traversal) */
  double seconds_pairs, seconds;
  size_t peak_bytes;      /* engine's own largest allocation footprint (estimate) */
} mgs_topo_stats;

/* Dense field, nx*ny*nz finite values. opts NULL = defaults. The diagram's n_cells,
 * n_critical, n_active_voxels and seconds are filled too. */
mgs_status mgs_topo_persistence_dense(const float *values, int nx, int ny, int nz,
                                      const mgs_topo_opts *opts, mgs_diagram **out,
                                      mgs_error *err);
/* Same, with the full statistics (stats may be NULL). */
mgs_status mgs_topo_persistence_dense_stats(const float *values, int nx, int ny, int nz,
                                            const mgs_topo_opts *opts, mgs_diagram **out,
                                            mgs_topo_stats *stats, mgs_error *err);

/* ---------------------------------------------------------------- sparse input
 * 8³ leaf blocks (values in OpenVDB order (x<<6)|(y<<3)|z, origin a multiple of 8) plus
 * constant tiles (any multiple-of-8 cube) and a background value for everything else.
 * Values are copied. Used by the VDB path, the benchmark and tests. */
typedef struct mgs_topo_sparse mgs_topo_sparse;
mgs_status mgs_topo_sparse_create(float background, mgs_topo_sparse **out, mgs_error *err);
void mgs_topo_sparse_destroy(mgs_topo_sparse *s);
mgs_status mgs_topo_sparse_add_leaf(mgs_topo_sparse *s, const int32_t origin[3],
                                    const float values[512], mgs_error *err);
mgs_status mgs_topo_sparse_add_tile(mgs_topo_sparse *s, const int32_t origin[3], int32_t dim,
                                    float value, mgs_error *err);
size_t mgs_topo_sparse_leaf_count(const mgs_topo_sparse *s);
/* Test/bench helper: blocks of a dense field (layout as above, voxel (0,0,0) at index 0)
 * whose clamped values are all equal become tiles, the others leaves; background = +w. */
mgs_status mgs_topo_sparse_from_dense(const float *values, int nx, int ny, int nz, float w,
                                      mgs_topo_sparse **out, mgs_error *err);

/* The band's top value is the (sign-applied) background: +w for a level set (w limited to the
 * background), 0 for a fog volume with the superlevel filtration (values above the top are
 * clamped to it). It must exceed -w. Tiles strictly between -w and the top are expanded to
 * voxels (they cost per voxel); -w tiles and the background cost per block. */
mgs_status mgs_topo_persistence_sparse(const mgs_topo_sparse *s, const mgs_topo_opts *opts,
                                       mgs_diagram **out, mgs_topo_stats *stats,
                                       mgs_error *err);

/* A VDB grid's narrow band (leaves + inactive tiles; background outside). Level sets use the
 * sublevel filtration and w = min(opts->half_width, background); voxel size and origin come
 * from the grid. Errors: non-finite values, a band that lets interior (-w) voxels touch the
 * background (+w) directly ("broken narrow band"). */
mgs_status mgs_topo_persistence_vdb(const mgs_vdb_grid *g, const mgs_topo_opts *opts,
                                    mgs_diagram **out, mgs_error *err);
mgs_status mgs_topo_persistence_vdb_stats(const mgs_vdb_grid *g, const mgs_topo_opts *opts,
                                          mgs_diagram **out, mgs_topo_stats *stats,
                                          mgs_error *err);

#ifdef __cplusplus
}
#endif
#endif

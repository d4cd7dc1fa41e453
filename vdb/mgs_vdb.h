/* vdb/: sparse OpenVDB grids behind a C API (C++17 shims in vdb/ *.cpp files; no C++ type here).
 * This module owns
 *   the grid handle ............ mgs_vdb_grid: one float grid (level set, fog or other),
 *                                uniform voxel size h + translation t:
 *                                world(ijk) = ijk * h + t   (ijk = voxel centre)
 *   the α-field ................ A(x) = Σ αᵢ exp(−½(x−μᵢ)ᵀΣᵢ⁻¹(x−μᵢ)) (alpha_field.cpp)
 *   the SDF .................... narrow-band level set of {A = τ}, negative inside (sdf.cpp)
 *   the C grid view ............ leaves / tiles / values / sampling / change detection
 *                                without copying the tree (grid_view.cpp)
 *   .vdb files ................. read / write with file metadata, atomic (vdb_io.cpp)
 *   critical points ............ PointDataGrid "critical" (points.cpp)
 *   mesh extraction ............ zero level set -> mgs_mesh (mesh_extract.cpp)
 *   TSDF fusion ................ depth maps -> sparse TSDF + weights -> valid level set of its
 *                                zero crossing (tsdf.cpp, vdb/mgs_vdb_tsdf.h)
 *
 * Threading: builders run in parallel through TBB (the scheduler mgs_parallel_for uses).
 * Read-only calls on one grid (views, values, sampling) may run concurrently; any call
 * that modifies a grid invalidates leaf views and tile lists taken from it.
 *
 * Choices (measured; see bench/RESULTS-vdb.md):
 *   - Gaussians thinner than a voxel: each covariance is low-pass filtered with the voxel's
 *     own footprint, Σ' = Σ + (h/2)² I (like 3DGS's 0.3-pixel dilation), so no Gaussian
 *     falls between voxel centres. Default MGS_VDB_SMALL_PEAK keeps αᵢ (conservative
 *     footprint): a sub-voxel Gaussian, or a sheet of flat ones (a trained surface), stays
 *     in {A = τ} as a voxel-thick blob/shell. MGS_VDB_SMALL_MASS scales the amplitude by
 *     sqrt(det Σ / det Σ') so each Gaussian's integral is preserved: right for density,
 *     but a sheet thinner than a voxel then drops below τ and leaves the level set
 *     (measured: 1M flat Gaussians on a torus at 256³ keep 0.4 % of the surface).
 *   - Gaussians whose largest std-dev exceeds the scene diagonal are capped to it (warned).
 *   - density grid = the α-field clamped to [0,1] (it is the field the splats define;
 *     sdfToFogVolume would only be a ramp of the level set).
 *   - SDF method: see mgs_vdb_sdf_method.
 */
#ifndef MGS_VDB_H
#define MGS_VDB_H
#include <stddef.h>
#include <stdint.h>
#include "core/mgs_error.h"
#include "core/mgs_gaussians.h"
#include "core/mgs_mesh.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ---------------------------------------------------------------- grid handle */
typedef struct mgs_vdb_grid mgs_vdb_grid;

typedef enum mgs_vdb_class {
  MGS_VDB_CLASS_UNKNOWN = 0,
  MGS_VDB_CLASS_LEVEL_SET, /* signed distance, background = +half-width (world units) */
  MGS_VDB_CLASS_FOG        /* fog volume, background 0, values in [0,1] */
} mgs_vdb_class;

/* An empty grid. translation may be NULL (0,0,0). voxel_size > 0. */
mgs_status mgs_vdb_grid_create(const char *name, mgs_vdb_class cls, double voxel_size,
                               const double translation[3], float background,
                               mgs_vdb_grid **out, mgs_error *err);
void mgs_vdb_grid_destroy(mgs_vdb_grid *g);
mgs_vdb_grid *mgs_vdb_grid_copy(const mgs_vdb_grid *g); /* deep copy, NULL on failure */

const char *mgs_vdb_grid_name(const mgs_vdb_grid *g);
void mgs_vdb_grid_set_name(mgs_vdb_grid *g, const char *name);
mgs_vdb_class mgs_vdb_grid_class(const mgs_vdb_grid *g);
void mgs_vdb_grid_set_class(mgs_vdb_grid *g, mgs_vdb_class cls);
double mgs_vdb_grid_voxel_size(const mgs_vdb_grid *g);
void mgs_vdb_grid_translation(const mgs_vdb_grid *g, double t[3]);
/* Adds offset (world units, double) to the transform's translation; the voxels stay. Grids
 * are built in a model's local float frame; this puts them at the model's origin
 * (g->origin, core/mgs_origin.h) so a .vdb is in world coordinates. NULL or 0: no-op. */
void mgs_vdb_grid_translate(mgs_vdb_grid *g, const double offset[3]);
float mgs_vdb_grid_background(const mgs_vdb_grid *g);
size_t mgs_vdb_grid_active_voxel_count(const mgs_vdb_grid *g);
size_t mgs_vdb_grid_leaf_count(const mgs_vdb_grid *g);
size_t mgs_vdb_grid_memory_bytes(const mgs_vdb_grid *g); /* tree memory (OpenVDB's count) */
/* Index bounding box of the active voxels and tiles, inclusive. Returns 0 when empty. */
int mgs_vdb_grid_active_bbox(const mgs_vdb_grid *g, int32_t lo[3], int32_t hi[3]);

/* Writes: set a voxel's value and active state (serial; for tests and small edits). */
void mgs_vdb_set_value(mgs_vdb_grid *g, const int32_t ijk[3], float value, int active);
/* A grid from a dense block: values[(i*ny + j)*nz + k] is voxel origin + (i,j,k).
 * LEVEL_SET: voxels with |v| < background are active, others become inactive ±background
 * (sign kept) and are pruned into tiles. FOG: voxels with v > 0 are active.
 * Other classes: voxels differing from background are active. */
mgs_status mgs_vdb_grid_from_dense(const char *name, mgs_vdb_class cls, double voxel_size,
                                   const double translation[3], float background,
                                   const int32_t origin[3], const int32_t dims[3],
                                   const float *values, mgs_vdb_grid **out, mgs_error *err);

/* ---------------------------------------------------------------- α-field */
typedef enum mgs_vdb_small_mode {
  MGS_VDB_SMALL_MASS = 0, /* Σ += (h/2)² I, amplitude · sqrt(det Σ/det Σ') (mass-preserving) */
  MGS_VDB_SMALL_PEAK = 1, /* Σ += (h/2)² I, amplitude kept (conservative footprint; default) */
  MGS_VDB_SMALL_NONE = 2  /* no filter (exact point samples; sub-voxel Gaussians may vanish) */
} mgs_vdb_small_mode;

typedef struct mgs_vdb_alpha_params {
  int resolution;          /* voxels along the diagonal of the means' bounding box (256) */
  double voxel_size;       /* > 0: absolute voxel size, overrides resolution (0) */
  double k_sigma;          /* each Gaussian visits the voxels of its kσ ellipsoid box (3) */
  mgs_vdb_small_mode small;
  double memory_budget;    /* bytes; 0 = 60 % of physical memory. Builds estimated above
                              it are refused with MGS_ERR_NOMEM stating the estimate */
  int half_width;          /* SDF band the grid will be used for, voxels (3): widens the
                              padding and the memory estimate */
} mgs_vdb_alpha_params;

void mgs_vdb_alpha_params_default(mgs_vdb_alpha_params *p);

/* Report of a build (any pointer argument taking it may be NULL). */
typedef struct mgs_vdb_build_info {
  double voxel_size;
  double scene_lo[3], scene_hi[3];  /* bounding box of the means */
  size_t gaussians_used, gaussians_capped;
  size_t active_voxels, leaves;
  double dense_voxels;              /* voxels of the dense box that holds the same field */
  double estimated_bytes;           /* the estimate checked against the budget */
  double seconds;
  size_t leaves_reused;             /* copied from a cache (mgs_vdb_alpha_field_cached) */
} mgs_vdb_build_info;

/* Rejects (MGS_ERR_NUMERIC / MGS_ERR_FORMAT, naming `source` and the Gaussian index) NaN/Inf
 * means, log-scales (zero scale = -inf), rotations (and zero quaternions), opacity logits,
 * and an empty model (MGS_ERR_FORMAT). */
mgs_status mgs_vdb_check_gaussians(const mgs_gaussians *g, const char *source, mgs_error *err);

/* A 2DGS model's surfels (core/mgs_gaussians.h) have no thickness: the α-field builders
 * give them a third standard deviation of half the voxel size (this value), so that a
 * surfel is a disc one voxel thick. */
double mgs_vdb_surfel_thickness(const mgs_gaussians *g, const mgs_vdb_alpha_params *p);

/* The α-field as a FOG-class grid named "alpha" (values not clamped: A may exceed 1).
 * Active voxels = the union of the kσ ellipsoids; inactive = 0. */
mgs_status mgs_vdb_alpha_field(const mgs_gaussians *g, const mgs_vdb_alpha_params *p,
                               mgs_vdb_grid **out, mgs_vdb_build_info *info, mgs_error *err);
/* Same from raw arrays: mean[n*3], cov[n*6] = (xx, xy, xz, yy, yz, zz), alpha[n]. */
mgs_status mgs_vdb_alpha_field_cov(size_t n, const float *mean, const float *cov,
                                   const float *alpha, const mgs_vdb_alpha_params *p,
                                   mgs_vdb_grid **out, mgs_vdb_build_info *info, mgs_error *err);
/* Incremental builds: a cache of the last build's leaves. A leaf whose Gaussians (their
 * prepared parameters, in index order) are those of the cached build, at the same voxel
 * size, lattice (the grid translation: the means' box centre snapped to 64 voxels) and support, is
 * copied; the others are computed. The result is bit-identical to mgs_vdb_alpha_field's
 * (tested). Give an absolute voxel_size so that moving Gaussians do not change it. */
typedef struct mgs_vdb_alpha_cache mgs_vdb_alpha_cache;
mgs_vdb_alpha_cache *mgs_vdb_alpha_cache_create(void);
void mgs_vdb_alpha_cache_destroy(mgs_vdb_alpha_cache *c);
mgs_status mgs_vdb_alpha_field_cached(const mgs_gaussians *g, const mgs_vdb_alpha_params *p, mgs_vdb_alpha_cache *cache,
                                      mgs_vdb_grid **out, mgs_vdb_build_info *info, mgs_error *err);
/* The voxel size p would give for these means (resolution over the bbox diagonal). */
double mgs_vdb_voxel_size_for(size_t n, const float *mean, const mgs_vdb_alpha_params *p);

/* ---------------------------------------------------------------- SDF and fog */
typedef enum mgs_vdb_sdf_method {
  /* volumeToMesh(A, τ) then meshToLevelSet: distances to the polygonized surface (max band
   * error 0.076 voxel on a 4-voxel sphere, 0.18 on a 2-voxel-curvature ellipsoid), ~4x the
   * CPU of CLOSEST; its flood-fill sign calls a hollow shell's cavity inside. */
  MGS_VDB_SDF_MESH = 0,
  /* tools::fogToSdf (fast sweeping) on the α-field dilated by the band: first order
   * (0.44 voxel on the same sphere), cheapest. */
  MGS_VDB_SDF_SWEEP = 1,
  /* Default. Closest points on {A = τ} (Chopp's iteration on the triquadratic interpolant)
   * at the voxels next to the interface, carried ring by ring through the band and refined,
   * then relaxed until neighbours' distances differ by at most their spacing, and grown
   * where a band voxel lies nearer than w − 1 to a surface part no seed sees (a valid
   * narrow band on trained models too: tests/vdb/test_vdb_band):
   * 0.016 / 0.041 voxel on the sphere / ellipsoid (tests/vdb/test_vdb_field),
   * bench/RESULTS-vdb.md for the cost. */
  MGS_VDB_SDF_CLOSEST = 2
} mgs_vdb_sdf_method;

typedef struct mgs_vdb_sdf_params {
  double tau;            /* iso value of the surface {A = τ} (0.5) */
  int half_width;        /* narrow band half-width in voxels (3) */
  mgs_vdb_sdf_method method;
  /* MESH only: 0 = volumeToMesh's quads as they are; 1 = vertices moved onto {A = τ}
   * (Newton on the triquadratic interpolant); 2 = 1 + every quad split into 4 triangles
   * around its projected centre (most accurate, ~2.5x the meshToLevelSet work). */
  int mesh_refine;
} mgs_vdb_sdf_params;

void mgs_vdb_sdf_params_default(mgs_vdb_sdf_params *p);

/* LEVEL_SET grid named "sdf": negative inside {A > τ}, world-space distances, active band of
 * half-width w voxels, background w·h, interior filled with inactive -w·h tiles. */
mgs_status mgs_vdb_sdf_from_alpha(const mgs_vdb_grid *alpha, const mgs_vdb_sdf_params *p,
                                  mgs_vdb_grid **out, mgs_error *err);

/* Incremental SDF (CLOSEST and SWEEP; MESH and empty fields are built whole): the cache
 * keeps the last build's α-field (shared, so it must not be changed afterwards) and band.
 * On the same lattice, τ and band, the leaves where the new α-field differs from the cached
 * one, grown by the distance over which an SDF value depends on α (2w + 10 voxels), are
 * computed again from a crop of the field with the same margin once more; every other leaf
 * is copied. The grid equals mgs_vdb_sdf_from_alpha's voxel for voxel
 * (tests/vdb/test_vdb_sdf_cache). When the region to redo is over half the grid, the whole
 * is built (whole = 1). */
typedef struct mgs_vdb_sdf_cache mgs_vdb_sdf_cache;
typedef struct mgs_vdb_sdf_update_info {
  int whole;                 /* built from scratch */
  size_t leaves_changed;     /* α leaves that differ from the cached field */
  size_t leaves_recomputed;  /* band leaves computed again */
  size_t leaves_total;       /* band leaves of the previous build */
} mgs_vdb_sdf_update_info;
mgs_vdb_sdf_cache *mgs_vdb_sdf_cache_create(void);
void mgs_vdb_sdf_cache_destroy(mgs_vdb_sdf_cache *c);
mgs_status mgs_vdb_sdf_from_alpha_cached(const mgs_vdb_grid *alpha, const mgs_vdb_sdf_params *p, mgs_vdb_sdf_cache *cache,
                                         mgs_vdb_grid **out, mgs_vdb_sdf_update_info *info, mgs_error *err);
/* FOG grid named "density": the α-field clamped to [0,1]. */
mgs_status mgs_vdb_density_from_alpha(const mgs_vdb_grid *alpha, mgs_vdb_grid **out,
                                      mgs_error *err);

/* ---------------------------------------------------------------- C grid view */
/* One leaf (8³ voxels) of the tree, pointing into the grid's own memory. */
typedef struct mgs_vdb_leaf_view {
  int32_t origin[3];             /* index coordinates of voxel (0,0,0) of the leaf */
  const float *values;           /* 512 values, OpenVDB order: offset (x<<6)|(y<<3)|z */
  const uint64_t *active_mask;   /* 8 words; bit (offset & 63) of word (offset >> 6) */
} mgs_vdb_leaf_view;

#define MGS_VDB_LEAF_DIM 8
#define MGS_VDB_LEAF_VOXELS 512
static inline int mgs_vdb_leaf_offset(int x, int y, int z) { return ((x & 7) << 6) | ((y & 7) << 3) | (z & 7); }
static inline int mgs_vdb_leaf_is_active(const mgs_vdb_leaf_view *l, int offset) {
  return (int)((l->active_mask[offset >> 6] >> (offset & 63)) & 1u);
}

size_t mgs_vdb_leaf_count(const mgs_vdb_grid *g);
/* Fills out[0 .. min(cap, count)) in the tree's (deterministic) order; returns the count.
 * The views stay valid until the grid is modified or destroyed. */
size_t mgs_vdb_leaf_views(const mgs_vdb_grid *g, mgs_vdb_leaf_view *out, size_t cap);

/* A constant region stored above the leaf level (internal nodes or root). */
typedef struct mgs_vdb_tile {
  int32_t origin[3];  /* index coordinates of its lowest corner */
  int32_t dim;        /* edge length in voxels: 8 (lower internal), 128 (upper), 4096 (root) */
  float value;
  int32_t active;     /* 0/1 */
} mgs_vdb_tile;

enum { MGS_VDB_TILES_ACTIVE = 1, MGS_VDB_TILES_INACTIVE = 2, MGS_VDB_TILES_ALL = 3 };
/* Tiles of the selected kinds at all levels. For INACTIVE, tiles whose value equals the
 * background are left out unless `keep_background` (so a level set's interior (-w) tiles
 * come back, the far outside does not). Same fill/count convention as leaf views. */
size_t mgs_vdb_tiles(const mgs_vdb_grid *g, int which, int keep_background,
                     mgs_vdb_tile *out, size_t cap);

/* Random access: value at ijk (background/tile value if not a voxel), *active (may be NULL). */
float mgs_vdb_value(const mgs_vdb_grid *g, const int32_t ijk[3], int *active);
/* Batch: n coordinates ijk[n*3] -> values[n], active[n] (may be NULL). Parallel. */
void mgs_vdb_values(const mgs_vdb_grid *g, size_t n, const int32_t *ijk, float *values,
                    uint8_t *active);

/* world = ijk * h + t, and back (continuous index coordinates). */
void mgs_vdb_index_to_world(const mgs_vdb_grid *g, const double ijk[3], double xyz[3]);
void mgs_vdb_world_to_index(const mgs_vdb_grid *g, const double xyz[3], double ijk[3]);

/* Trilinear samples at world points xyz[n*3] -> values[n]. Parallel. */
void mgs_vdb_sample(const mgs_vdb_grid *g, size_t n, const float *xyz, float *values);
/* World-space gradient at world points: central differences at the 8 surrounding voxels,
 * interpolated trilinearly -> grad[n*3]; values[n] (may be NULL) as mgs_vdb_sample. */
void mgs_vdb_sample_gradient(const mgs_vdb_grid *g, size_t n, const float *xyz, float *grad,
                             float *values);

/* Per-leaf change detection between two grids with the same transform. */
typedef enum { MGS_VDB_LEAF_CHANGED = 0, MGS_VDB_LEAF_ADDED = 1, MGS_VDB_LEAF_REMOVED = 2 } mgs_vdb_change_kind;
typedef struct mgs_vdb_leaf_change {
  int32_t origin[3];
  int32_t kind;        /* mgs_vdb_change_kind: ADDED = only in `after`, REMOVED = only in `before` */
  float max_diff;      /* CHANGED: max |after - before| over the leaf; else 0 */
} mgs_vdb_leaf_change;
/* Leaves whose values differ by more than tol anywhere, or whose active masks differ;
 * leaves present in one grid only. *out is malloc'd (free()), sorted by origin (x, y, z).
 * Fails (MGS_ERR_ARG) when the transforms differ. */
mgs_status mgs_vdb_leaf_changes(const mgs_vdb_grid *before, const mgs_vdb_grid *after,
                                float tol, mgs_vdb_leaf_change **out, size_t *n,
                                mgs_error *err);

/* ---------------------------------------------------------------- critical points */
typedef struct mgs_vdb_points mgs_vdb_points;
/* PointDataGrid named "critical": positions xyz[n*3] (world), attributes index (int32:
 * 0,1,2), birth, death, persistence (float; death may be +inf for essential classes).
 * voxel_size: the point grid's voxel size (e.g. the SDF's). */
mgs_status mgs_vdb_points_create_critical(size_t n, const float *xyz, const int32_t *index,
                                          const float *birth, const float *death,
                                          const float *persistence, double voxel_size,
                                          mgs_vdb_points **out, mgs_error *err);
void mgs_vdb_points_destroy(mgs_vdb_points *p);
/* Moves the point grid's transform by offset (double): positions given relative to a local
 * origin (float) land at origin + position in the file (see mgs_vdb_grid_translate). */
void mgs_vdb_points_translate(mgs_vdb_points *p, const double offset[3]);
size_t mgs_vdb_points_count(const mgs_vdb_points *p);
/* Reads such a point grid back (name NULL = "critical"); arrays malloc'd (free()), in the
 * grid's spatial order (not the order written). Errors name a missing attribute. */
mgs_status mgs_vdb_read_critical(const char *path, const char *name, size_t *n, float **xyz,
                                 int32_t **index, float **birth, float **death,
                                 float **persistence, mgs_error *err);

/* ---------------------------------------------------------------- .vdb files */
typedef struct mgs_vdb_file_meta {
  char tool[64];      /* "morsegs" */
  char version[32];   /* "0.1.0" */
  double tau;         /* iso value (NaN if not applicable) */
  double voxel_size;
  char source[1024];  /* input file */
} mgs_vdb_file_meta;
void mgs_vdb_file_meta_default(mgs_vdb_file_meta *m); /* tool, version set; tau NaN */

/* Writes grids (and optional point grids) into one .vdb, atomically (temp + rename).
 * Overwrites `path` (callers check --force). meta may be NULL. */
mgs_status mgs_vdb_write(const char *path, const mgs_vdb_grid *const *grids, size_t ngrids,
                         const mgs_vdb_points *const *points, size_t npoints,
                         const mgs_vdb_file_meta *meta, mgs_error *err);
/* Reads one float grid. name NULL: the first level set, else the first float grid.
 * Clear errors for: missing file, not a .vdb, no grid of that name, non-float grid,
 * truncated or corrupt data, an unusable transform. Every .vdb read validates the header
 * against the file size and parses in a forked child under a memory cap (vdb_read.hpp):
 * a hostile file is an error, never a crash or an unbounded allocation. */
mgs_status mgs_vdb_read_grid(const char *path, const char *name, mgs_vdb_grid **out,
                             mgs_error *err);
/* A grid as bytes (OpenVDB's stream format; free() them) and back (name NULL: the first
 * float grid; bytes of a whole .vdb file are read too): for checkpoints (vdb/grid_bytes.cpp). */
mgs_status mgs_vdb_grid_to_bytes(const mgs_vdb_grid *g, char **bytes, size_t *len, mgs_error *err);
mgs_status mgs_vdb_grid_from_bytes(const char *bytes, size_t len, const char *name, mgs_vdb_grid **out,
                                   mgs_error *err);
/* File metadata written by mgs_vdb_write (fields left default when absent). */
mgs_status mgs_vdb_read_meta(const char *path, mgs_vdb_file_meta *meta, mgs_error *err);

/* ---------------------------------------------------------------- reference builders */
/* OpenVDB's own tools::ParticlesToLevelSet on spheres (world positions xyz[n*3], radii
 * radius[n]) at the given voxel size and band: the peer `morsegs bench vdb` compares with.
 * *ignored (may be NULL): spheres OpenVDB skipped as smaller than its 1.5-voxel minimum. */
mgs_status mgs_vdb_particles_to_level_set(size_t n, const float *xyz, const float *radius,
                                          double voxel_size, int half_width, mgs_vdb_grid **out,
                                          size_t *ignored, mgs_error *err);

/* ---------------------------------------------------------------- mesh extraction */
/* Surface {grid = iso} (iso 0 for a level set) via volumeToMesh with adaptivity in [0,1],
 * quads split into triangles, oriented outward (counter-clockwise seen from outside). */
mgs_status mgs_vdb_extract_mesh(const mgs_vdb_grid *g, double iso, double adaptivity,
                                mgs_mesh **out, mgs_error *err);

#ifdef __cplusplus
}
#endif
#endif

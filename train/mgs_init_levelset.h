/* MorseGS's level-set initialization (seed 000 §3.4, SPEC §5.2 item 6), `--init levelset`:
 *
 *   1. normals of the input points (SfM, or a scene maker's noisy surface samples) by
 *      local PCA over their k nearest neighbours (smallest eigenvector);
 *   2. consistent orientation by Hoppe et al. 1992: propagation along a minimum spanning
 *      tree of the kNN graph with edge cost 1 − |nᵢ·nⱼ| (flip a child that disagrees with
 *      its parent), each tree's root oriented away from the points' centroid; afterwards
 *      the whole set is flipped if most normals point toward the centroid (closed objects
 *      get outward normals);
 *   3. a coarse signed distance field: at each voxel of a grid of `resolution` voxels along
 *      the points' diagonal, the Gaussian-weighted mean of the tangent-plane distances
 *      nⱼ·(x − pⱼ) of the points within the band (a smoothed Hoppe distance); voxels no
 *      point reaches get ±band by a flood fill from the grid's border (outside) — stored
 *      as a sparse level set (vdb/);
 *   4. level sets d = kδ, k = −levels..levels, extracted as meshes (vdb/ volumeToMesh);
 *   5. `count` points sampled on them in proportion to area (render/'s area-uniform
 *      sampler), each a Gaussian flat in the tangent plane: shortest axis along the level
 *      set's normal, tangent std-dev the reference's sqrt(mean squared 3-NN distance) of
 *      the samples, normal std-dev `flatness` times that, opacity `opacity` (0.1 as the reference),
 *      colour (SH DC) from the nearest input point. */
#ifndef MGS_INIT_LEVELSET_H
#define MGS_INIT_LEVELSET_H
#include <stddef.h>
#include <stdint.h>
#include "core/mgs_error.h"
#include "core/mgs_gaussians.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct mgs_levelset_options {
  size_t count;       /* Gaussians to create (0 = as many as input points, at least 10000) */
  int resolution;     /* voxels along the points' bounding-box diagonal (128) */
  int knn;            /* neighbours for PCA normals and orientation (32: the scene maker's 1 % noise
                         needs ~30, measured in tests/train/test_init_coverage.c) */
  int levels;         /* level sets at kδ, k = −levels..levels (1: three sheets) */
  double delta;       /* spacing δ in voxels (1.0) */
  double flatness;    /* normal std-dev / tangent std-dev (0.1) */
  double opacity;     /* initial α (0.1, the reference's; see docs/notes/morse-grad.md: flat
                         Gaussians at 0.1 leave {A = 0.5} patchy at the start) */
  uint64_t seed;      /* sampling seed */
} mgs_levelset_options;
void mgs_levelset_options_default(mgs_levelset_options *o);

/* What the initialization did (may be NULL). */
typedef struct mgs_levelset_info {
  double voxel_size, delta, band;
  size_t flipped;        /* normals flipped by the orientation */
  double area[16];       /* area of each level set, k = −levels..levels (first 16) */
  size_t per_level[16];  /* Gaussians placed on each */
  double seconds;
  size_t outliers;       /* input points outside the robust box (mgs_points_bounds_robust), left out */
} mgs_levelset_info;

/* Input points xyz[n*3], colours rgb[n*3] in [0,1] (may be NULL: grey). Fails with a
 * clear message on fewer than 16 points, non-finite input, or a field without surface. */
mgs_status mgs_init_levelset(const float *xyz, const float *rgb, size_t n, int sh_degree,
                             const mgs_levelset_options *o, mgs_gaussians **out,
                             mgs_levelset_info *info, mgs_error *err);
/* The normals alone (step 1–2): normals[n*3], unit, consistently oriented. */
mgs_status mgs_point_normals(const float *xyz, size_t n, int knn, float *normals, size_t *flipped,
                             mgs_error *err);

/* ---- surface points for datasets without a point file (train/init_hull.c) ----------
 * The real NeRF-synthetic folders ship transforms_*.json and RGBA images, no points. Where
 * the training images have alpha: the visual hull of their silhouettes (alpha >= 0.5),
 * carved on a coarse grid over the cameras' sphere, then on a fine grid over what survived;
 * a voxel stays when at least min_views (and min_seen of the views) see it and at most miss_fraction of those put it
 * outside their silhouette. Points sit on the hull's boundary: each boundary face of the
 * fine grid, its crossing refined along the segment in every view's alpha (bilinear, so
 * sub-voxel), colour the cosine-weighted mean of the views that see it unoccluded by the
 * hull. Where the images have no alpha (COLMAP / nerfstudio without masks): the centres of
 * the Gaussians that a short warm-up of the baseline from the random init made opaque
 * (docs/notes/morse.md, "Level-set init without a point file", says why). Images not
 * loaded (image cache) are read one view at a time and released; the dataset is left as
 * it was. Only train views are used. */
typedef struct mgs_view_points_options {
  int resolution;        /* fine-grid voxels along the longest side of the hull's box (128) */
  int coarse;            /* coarse-grid voxels along the side of the cameras' box (64) */
  int min_views;         /* views that must see a voxel to keep it (3, or all if fewer) ... */
  double min_seen;       /* ... and at least this share of the train views (0.5: voxels at the
                            cameras' edge of view, seen by a few, are not the object) */
  double miss_fraction;  /* share of those views whose silhouette may exclude it (0.02) */
  size_t max_points;     /* points returned (10000, the scenes' points3d.ply count) */
  int warmup_iterations; /* without alpha: baseline iterations from the random init (500) */
  size_t warmup_points;  /* without alpha: random Gaussians of the warm-up (100000) */
  double warmup_opacity; /* without alpha: opacity a warm-up Gaussian needs to count (0.5) */
  size_t image_cache_mb; /* without alpha: the trainer's image cache (0: images loaded) */
  uint64_t seed;
} mgs_view_points_options;
void mgs_view_points_options_default(mgs_view_points_options *o);

typedef struct mgs_view_points_info {
  int from_alpha;        /* 1 visual hull, 0 warm-up */
  size_t views;          /* train views used */
  size_t hull_voxels;    /* fine voxels kept */
  size_t boundary_faces; /* before subsampling to max_points */
  double voxel_size;     /* fine voxel */
  double seconds;
} mgs_view_points_info;

/* Surface points of ds's object from its train views: xyz[n*3], rgb[n*3] in [0,1]
 * (malloc'd, the caller frees). Fails with a message when no voxel survives the carving
 * or the warm-up leaves fewer than 16 opaque Gaussians. info may be NULL. */
struct mgs_dataset;
mgs_status mgs_init_points_from_views(struct mgs_dataset *ds, const mgs_view_points_options *o, float **xyz,
                                      float **rgb, size_t *n, mgs_view_points_info *info, mgs_error *err);
/* The same into ds->init_points when ds has none (as if the folder had a point file, so
 * every consumer of initial points sees them); logs what it did. No-op when ds has points. */
mgs_status mgs_init_dataset_points(struct mgs_dataset *ds, const mgs_view_points_options *o, mgs_error *err);

#ifdef __cplusplus
}
#endif
#endif

/* The Gaussian model as a structure of arrays: one contiguous array per parameter group
 * (the layout optimizers and SIMD loops want), never an array of per-Gaussian structs.
 *
 * Parameters are stored in the reference 3DGS's *activation-free* form:
 *   mean      [n*3]  position relative to `origin` (float32 in a local frame; the
 *                    world position is origin + mean, added in double: core/mgs_origin.h)
 *   log_scale [n*3]  log of the standard deviations along the local axes
 *   rot       [n*4]  quaternion (w, x, y, z), not necessarily normalized
 *   opacity   [n]    logit of α
 *   sh_dc     [n*3]  degree-0 SH coefficient per RGB channel
 *   sh_rest   [n*45] degrees 1..3: [i][k][c], k = 0..14 the coefficient, c the channel
 *                    (the reference's features_rest layout; the .ply stores it
 *                    channel-major, the PLY module converts)
 * sh_rest always holds 15 coefficients per channel; `sh_degree` says how many are in
 * use ((sh_degree+1)^2 - 1), the rest are zero.
 *
 * Every operation that changes the count works on all groups at once through a
 * generic group table, so the optimizer's moment arrays (same groups, same shapes) can be
 * kept in step with the same keep-mask / append calls (see mgs_rows_*). */
#ifndef MGS_GAUSSIANS_H
#define MGS_GAUSSIANS_H
#include <stddef.h>
#include <stdint.h>
#include "core/mgs_error.h"

#ifdef __cplusplus
extern "C" {
#endif

#define MGS_SH_REST_MAX 45
#define MGS_SH_COEFFS_MAX 16

typedef enum mgs_param_group {
  MGS_PARAM_MEAN = 0,
  MGS_PARAM_LOG_SCALE,
  MGS_PARAM_ROT,
  MGS_PARAM_OPACITY,
  MGS_PARAM_SH_DC,
  MGS_PARAM_SH_REST,
  MGS_PARAM_COUNT
} mgs_param_group;

/* What the rows are: 3D Gaussians, or 2DGS surfels (hbb1/2d-gaussian-splatting: a disc
 * spanned by the first two local axes with standard deviations exp(log_scale[0..1]); the
 * normal is the third axis of R; log_scale[2] is not a parameter of the model: renderers
 * ignore it, the rasterizer's gradient for it is 0 and the .ply has no scale_2). */
typedef enum mgs_model_kind { MGS_MODEL_3DGS = 0, MGS_MODEL_2DGS = 1 } mgs_model_kind;
const char *mgs_model_kind_name(mgs_model_kind k); /* "3dgs", "2dgs" */
/* What a surfel's unused log_scale[2] holds when read or initialized (a flat disc to any
 * code that treats it as a 3D Gaussian; code that needs a thickness sets its own). */
#define MGS_SURFEL_LOG_SCALE2 (-13.815511f) /* log(1e-6) */

typedef struct mgs_gaussians {
  size_t n;        /* Gaussians in use */
  size_t capacity; /* rows allocated in every group */
  int sh_degree;   /* 0..3: SH degree stored / active */
  float *mean, *log_scale, *rot, *opacity, *sh_dc, *sh_rest;
  double origin[3]; /* world position of mean (0,0,0); (0,0,0) unless the scene is far
                       from the world origin. Kept by select/clone; written by the .ply */
  mgs_model_kind kind; /* MGS_MODEL_3DGS (0, what create gives) unless set; kept by
                          select/clone */
} mgs_gaussians;

/* Floats per Gaussian in each group: 3, 3, 4, 1, 3, 45. */
int mgs_param_dim(mgs_param_group g);
const char *mgs_param_name(mgs_param_group g); /* "mean", "log_scale", ... */
float *mgs_gaussians_group(mgs_gaussians *g, mgs_param_group group);

mgs_gaussians *mgs_gaussians_create(size_t capacity, int sh_degree);
void mgs_gaussians_destroy(mgs_gaussians *g);
mgs_status mgs_gaussians_reserve(mgs_gaussians *g, size_t capacity, mgs_error *err);
/* Appends `count` zero-initialized Gaussians (rot = identity); returns the first new index
 * in *first. */
mgs_status mgs_gaussians_append(mgs_gaussians *g, size_t count, size_t *first, mgs_error *err);
/* Keeps rows with keep[i] != 0, in order; returns the new count. */
size_t mgs_gaussians_compact(mgs_gaussians *g, const uint8_t *keep);
/* New model holding rows idx[0..count) of src (for exports, subsets, tests). */
mgs_gaussians *mgs_gaussians_select(const mgs_gaussians *src, const size_t *idx, size_t count);
mgs_gaussians *mgs_gaussians_clone(const mgs_gaussians *src);
/* MGS_ERR_NUMERIC naming the first parameter group and index holding NaN/Inf. */
mgs_status mgs_gaussians_check_finite(const mgs_gaussians *g, mgs_error *err);

/* Activated values for one Gaussian. */
float mgs_gaussian_alpha(const mgs_gaussians *g, size_t i);         /* sigmoid(opacity) */
void mgs_gaussian_scale(const mgs_gaussians *g, size_t i, float s[3]); /* exp(log_scale) */
/* World covariance Σ = R S S Rᵀ (row-major 3x3, double for stability). */
void mgs_gaussian_covariance(const mgs_gaussians *g, size_t i, double cov[9]);
/* Axis-aligned bounding box of all means. Returns 0 for an empty model. */
int mgs_gaussians_bounds(const mgs_gaussians *g, double lo[3], double hi[3]);
/* A box that far outliers do not stretch (real SfM clouds hold two-view points 10x the
 * object's size away): per axis the 0.5 % and 99.5 % quantiles (of at most 65536 evenly
 * strided points), widened by 10 % of the largest quantile extent, clipped to the true
 * min/max — a compact cloud keeps its full box. Fewer than 200 points: the true box.
 * Returns 0 for n = 0. */
int mgs_points_bounds_robust(const float *xyz, size_t n, double lo[3], double hi[3]);
/* 1 when p lies in [lo, hi] on every axis. */
int mgs_point_in_box(const float *p, const double lo[3], const double hi[3]);

/* Generic row operations on an array of `dim` floats per row (used for Adam moments). */
size_t mgs_rows_compact(float *data, size_t n, int dim, const uint8_t *keep);

/* SH degree-0 constant of the reference: colour = 0.5 + C0 * sh_dc. */
#define MGS_SH_C0 0.28209479177387814f

#ifdef __cplusplus
}
#endif
#endif

/* Mini-Splatting and Mini-Splatting-D (Fang & Wang 2024; fatPeter/mini-splatting,
 * ms/train.py and ms_d/train.py): a density-control strategy (train/mgs_strategy.h).
 *
 *   blur split ........ during densification, Gaussians that had the largest blending
 *                       weight alpha*T in more than H*W/5000 pixels of some view since the
 *                       last densification are split (OR-ed with ADC's gradient test)
 *   reinitialisation .. at multiples of `reinit_every` below `densify_until`: every train
 *                       view rendered; per pixel the point of its ray closest (in the
 *                       Gaussian's own metric) to its max-weight Gaussian; pixels sampled
 *                       with probability proportional to 1 - T_final; all Gaussians
 *                       replaced by these points (the reference init: 3-NN scale, opacity
 *                       0.1, ground-truth colour), Adam and the ADC statistics reset
 *   simplification .... (not -D) at `simplify1`: importance = sum over train views of each
 *                       Gaussian's blending weight (0 if never a max-weight Gaussian);
 *                       N*f*(share with importance > 0) sampled without replacement with
 *                       probability proportional to importance; the rest removed;
 *                       at `simplify2`: Gaussians below 1 % of the cumulative importance
 *                       (sorted ascending) removed
 *   at simplify1 ...... (both) every kept Gaussian re-initialised at its mean with its DC
 *                       colour (3-NN scale, opacity 0.1, identity rotation, no higher SH),
 *                       Adam reset; the SH degree is held at 0 until then and the position
 *                       learning rate restarts at step `lr_restart` there
 * On a 2DGS model (surfels) the statistics are the surfel rasterizer's, the ray point is on
 * the max-weight surfel's plane (mgs_minisplat_ray_points) and every replacement is 2DGS's
 * init from points (random rotations in [0,1)^4, two 3-NN disc scales).
 * No opacity reset (ADC's reset period only gates the screen/world size pruning).
 * The milestones are those of the config after --schedule-scale (train/config.c). */
#ifndef MGS_MINISPLAT_H
#define MGS_MINISPLAT_H
#include <stddef.h>
#include <stdint.h>
#include "train/mgs_strategy.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct mgs_minisplat_options {
  int dense;                 /* 1: Mini-Splatting-D (blur split and reinitialisation only) */
  mgs_adc_options adc;       /* densification from/until/every, thresholds; no reset */
  int reinit_every;          /* 5000 */
  int simplify1, simplify2;  /* 15000 (-D: densify_until), 20000 */
  int lr_restart;            /* 5000 */
  double blur_share;         /* 1/5000 of the view's pixels */
  double blur_min_px;        /* 8: floor of that threshold in pixels (under ~70² it is below one pixel: every visible Gaussian would split) */
  double simplify_fraction;  /* 0.5 (authors: 0.3 for large scenes) */
  double prune_share;        /* 0.01 of the cumulative importance at simplify2 */
  size_t depth_points;       /* points of a reinitialisation; 0 = the model's count then */
  size_t max_gaussians;      /* 4.5M: no densification above (authors' num_max; not -D) */
} mgs_minisplat_options;
void mgs_minisplat_options_default(mgs_minisplat_options *o);

mgs_status mgs_strategy_minisplat_create(const mgs_minisplat_options *o, mgs_strategy **out, mgs_error *err);

/* ---- the rules, for tests and tools ---- */

/* Per pixel of one rendered view (r: a forward of model g at cam, then its blend
 * statistics): the point of the pixel ray closest to its max-weight Gaussian in that
 * Gaussian's metric |S^-1 R^T (x - mu)| (xyz: 3 floats per pixel, NaN where no Gaussian
 * or behind the camera). A 2DGS model's surfel has no such metric (its third scale is ~0):
 * the ray's intersection with the surfel's plane, the point the 2DGS rasterizer evaluates,
 * where it lies on the splat (alpha >= 1/255 there); else, where the rasterizer's
 * screen-space filter gave the weight, the ray's point at the centre's camera depth (the
 * rasterizer's depth there). */
mgs_status mgs_minisplat_ray_points(mgs_raster *r, const mgs_gaussians *g, const mgs_camera *cam, float *xyz,
                                    mgs_error *err);
/* k distinct indices out of n drawn without replacement with probability proportional to
 * w (w >= 0; Efraimidis-Spirakis keys); out gets min(k, #(w > 0)) indices, in increasing
 * order; returns that count. */
size_t mgs_minisplat_weighted_sample(const double *w, size_t n, size_t k, mgs_rng *rng, uint32_t *out);
/* keep[i] = 0 for the Gaussians whose importance lies in the lowest `share` of the
 * cumulative importance (the authors' init_cdf_mask). */
void mgs_minisplat_cdf_keep(const double *imp, size_t n, double share, uint8_t *keep);
/* Global rule of the first simplification: how many survive (N f nonzero/N). */
size_t mgs_minisplat_simplify_count(size_t n, size_t nonzero, double fraction);

#ifdef __cplusplus
}
#endif
#endif

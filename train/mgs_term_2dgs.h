/* The 2DGS losses (hbb1/2d-gaussian-splatting train.py) as loss terms (train/mgs_term.h),
 * on the maps the 2DGS rasterizer composites (render/mgs_raster.h), their gradients added
 * through mgs_raster_map_grads before the backward:
 *
 *   depth distortion   lambda_dist * mean over pixels of sum_i sum_j<i w_i w_j (m_i - m_j)^2
 *                      from iteration dist_from (3000);
 *   normal consistency lambda_normal * mean over pixels of (1 - <N, alpha Nd>) from
 *                      normal_from (7000): N = sum_i w_i n_i (the rendered normal, not
 *                      renormalized), Nd = the unit normal of the median depth's surface
 *                      (the authors' depth_ratio 1, their object setting: cross product of
 *                      the central differences of the back-projected points), alpha
 *                      detached as theirs. Deliberate difference: Nd is 0 (no gradient)
 *                      where a pixel or one of its 4 neighbours has no median depth (alpha
 *                      < 0.5, render/mgs_render_maps.h), where theirs differences the
 *                      depth of whatever contributed last.
 * Both need a 2DGS forward of the iteration (mgs_term_step.raster). */
#ifndef MGS_TERM_2DGS_H
#define MGS_TERM_2DGS_H
#include "core/mgs_error.h"
#include "train/mgs_term.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct mgs_2dgs_term_options {
  double lambda_dist;   /* 0: the authors' default; 1000 their DTU runs */
  double lambda_normal; /* 0.05 */
  int dist_from;        /* 3000 */
  int normal_from;      /* 7000 */
  int alpha_weight;     /* 1: N_d scaled by the (detached) alpha, the authors'; 0: not scaled
                           (the loss is then differentiable everywhere it is defined: the
                           finite-difference test uses it) */
} mgs_2dgs_term_options;

void mgs_2dgs_term_options_default(mgs_2dgs_term_options *o);
/* One term holding both losses (either weight may be 0); *out NULL when both are 0. */
mgs_status mgs_term_2dgs_create(const mgs_2dgs_term_options *o, mgs_term **out, mgs_error *err);

#ifdef __cplusplus
}
#endif
#endif

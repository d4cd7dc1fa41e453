/* GaussianPro's progressive propagation (Cheng et al. 2024, kcheng1021/GaussianPro):
 *
 *   mgs_gpro_* ........................ one propagation step on one training view: render
 *                                       its depth and normals, patch-match them against
 *                                       overlapping views (render/mgs_patchmatch.h), keep
 *                                       pixels >= 2 neighbours' propagated depths agree
 *                                       with, add a Gaussian at every `stride`-th such
 *                                       pixel where the render's depth disagrees
 *   mgs_strategy_gaussianpro_create ... the reference ADC plus that step every `every`
 *                                       iterations in (from, until), views in turn
 *   mgs_term_planar_create ............ the planar loss against the checked
 *                                       propagated normals (the authors') and depths
 *
 * The propagated depth of every view matched so far is kept (as the authors cache it on
 * the camera) and reused as a neighbour's depth in the consistency check; it is part of
 * the strategy's checkpoint state. */
#ifndef MGS_GAUSSIANPRO_H
#define MGS_GAUSSIANPRO_H
#include <stdint.h>
#include <stdio.h>
#include "core/mgs_error.h"
#include "core/mgs_dataset.h"
#include "core/mgs_gaussians.h"
#include "render/mgs_raster.h"
#include "train/mgs_train.h"
#include "train/mgs_term.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct mgs_gpro_options {
  int from, until, every;   /* propagation at iterations from < it < until, it % every == 0
                               (authors' demo: 1000, 6000, 50) */
  int patch_size;           /* NCC window side (authors' --patch_size 20) */
  int pm_iterations;        /* checkerboard sweeps (authors 6) */
  int neighbors;            /* views matched against (authors 4) */
  int stride;               /* a Gaussian at every stride-th accepted pixel in x and y (8) */
  double error_max, error_min; /* relative depth error (propagated vs rendered) above which a
                               pixel disagrees, falling linearly from max to min over the
                               window (authors' demo: 1.0 to 0.8) */
  int min_pixels;           /* no Gaussians from a view with fewer accepted pixels (100) */
  double depth_min, depth_max; /* depth range of plane hypotheses (0: from the extent) */
  uint64_t seed;
} mgs_gpro_options;

void mgs_gpro_options_default(mgs_gpro_options *o);

typedef struct mgs_gpro mgs_gpro;

/* views: the training views (borrowed; their images loaded before a step uses them);
 * extent: the scene radius (sets the depth range when the options leave it 0). */
mgs_status mgs_gpro_create(const mgs_gpro_options *o, const mgs_view *views, size_t n_views, double extent,
                           mgs_gpro **out, mgs_error *err);
void mgs_gpro_destroy(mgs_gpro *p);

typedef struct mgs_gpro_report {
  size_t view, neighbors;  /* the reference view and how many views it was matched against */
  size_t consistent;       /* pixels whose propagated depth >= 2 neighbours agree with */
  size_t accepted;         /* ... and where the render's depth disagrees */
  size_t added;            /* Gaussians appended */
  double seconds;
} mgs_gpro_report;

/* One propagation step on view `view` (the disagreement threshold at `progress` in [0, 1]
 * of the window). New Gaussians go through mgs_model_append (a may be NULL: no
 * optimizer); their rows are the last r->added of g. */
mgs_status mgs_gpro_propagate(mgs_gpro *p, mgs_gaussians *g, mgs_adam *a, size_t view, double progress,
                              mgs_gpro_report *r, mgs_error *err);
/* The propagated depth kept for a view (its camera's size, 0 = none), NULL if none yet;
 * the checked one only when the view was matched as the reference (then 0 where fewer
 * than 2 neighbours agree): what the planar loss compares the render with. */
const float *mgs_gpro_cached_depth(const mgs_gpro *p, size_t view);
const float *mgs_gpro_checked_depth(const mgs_gpro *p, size_t view);
/* The propagated normal of a view matched as the reference (world, unit, facing its
 * camera, 3 per pixel; the zero vector where fewer than 2 neighbours agree or the image's
 * alpha marks background: the authors' -10), NULL if none. */
const float *mgs_gpro_checked_normal(const mgs_gpro *p, size_t view);

mgs_status mgs_gpro_save(const mgs_gpro *p, FILE *f, mgs_error *err);
mgs_status mgs_gpro_load(mgs_gpro *p, FILE *f, mgs_error *err);

/* The planar loss (train/term_planar.c), an image term from iteration from + 1 on the
 * views with a checked propagation of `pro` (borrowed: the strategy's), read from the
 * iteration's render and carried by its backward: weight_normal x
 * mean (1 - cos(rendered normal, propagated normal)) + weight_l1 x mean |N/|N| - n|_1 in
 * the camera frame + weight x mean |sum w z - depth|. */
mgs_status mgs_term_planar_create(const mgs_gpro *pro, double weight, double weight_normal, double weight_l1, int from,
                                  mgs_term **out, mgs_error *err);
typedef struct mgs_planar_target {
  const float *depth;  /* propagated depth per pixel, 0 = none (NULL: none) */
  const float *normal; /* propagated unit normal, world, 3 per pixel, zero = none (NULL: none) */
  double w_depth, w_normal;
  double w_l1;         /* the authors' L1 of the normals (camera frame); 0 = off */
} mgs_planar_target;
/* Its value for one view rendered with r: w_depth x mean |sum w z - depth| over depth > 0
 * plus w_normal x mean (1 - N.n/|N|) over the nonzero normals (N the rendered normal map;
 * 1 where it is 0) plus w_l1 x mean sum_j |R N/|N| - R n|_j over them (R world -> camera;
 * N/|N| = 0 where N = 0, as F.normalize); the gradient added into grad (NULL: value only). The buffers are the
 * caller's scratch (grown as needed, *cap floats of depth). */
mgs_status mgs_planar_loss(mgs_raster *r, const mgs_gaussians *g, const mgs_camera *cam, const mgs_planar_target *t,
                           float **dl_ddepth, float **dl_dcolor, size_t *cap, mgs_gaussians *grad, double *value,
                           mgs_error *err);
/* The same value from the last forward on r (its depth `depth`, its normal map): with
 * want_grad, the depth half ADDED into dl_ddepth (*depth_used set to 1 when it has one)
 * and the normal halves into r's normal-map gradient (mgs_raster_map_grads), for r's next
 * backward to carry; mgs_planar_loss is a forward, this and a backward. */
mgs_status mgs_planar_loss_add(mgs_raster *r, const mgs_camera *cam, const mgs_planar_target *t, const float *depth,
                               float *dl_ddepth, int *depth_used, int want_grad, double *value, mgs_error *err);

/* The ADC of `adc` plus propagation (views borrowed from the dataset's training split). */
mgs_status mgs_strategy_gaussianpro_create(const mgs_adc_options *adc, const mgs_gpro_options *o, const mgs_view *views,
                                           size_t n_views, double extent, struct mgs_strategy **out, mgs_error *err);
/* The propagation of a gaussianpro strategy (NULL for another strategy). */
const mgs_gpro *mgs_strategy_gaussianpro_pro(const struct mgs_strategy *s);

#ifdef __cplusplus
}
#endif
#endif

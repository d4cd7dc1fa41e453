/* Loss terms beside the photometric loss: the one way a regularizer (MorseGS's topological
 * and normal losses, Topology-GS's PersLoss, ...) plugs into the trainer, as density
 * control plugs in through train/mgs_strategy.h. A term adds its weighted value and its
 * gradient at one of two places of an iteration:
 *
 *   image_grad  after the photometric loss, before the backward: adds dL/dcolor of the
 *               rendered image (the rasterizer's backward carries it to the Gaussians);
 *   model_grad  before the strategy's post hook and Adam: adds dL/dθ into the gradient
 *               model directly (losses defined on the Gaussians or on fields built from
 *               them). It only ADDS to s->grad's mean, log-scale, rotation and opacity rows
 *               and reads nothing of it: where the backward and Adam run fused, s->grad
 *               holds only the model terms' gradients and the fused step adds them to the
 *               rasterizer's (train/adam_backward.c); elsewhere (densification steps,
 *               sparse Adam) it is the full gradient after the backward.
 *
 * Terms see the model before this iteration's density control and Adam step.
 * Their state (schedules, cached analyses) goes into checkpoints through save/load. */
#ifndef MGS_TERM_H
#define MGS_TERM_H
#include <stdio.h>
#include "core/mgs_error.h"
#include "core/mgs_gaussians.h"
#include "core/mgs_dataset.h"
#include "core/mgs_rng.h"

#ifdef __cplusplus
extern "C" {
#endif

/* What a term sees of one iteration. */
typedef struct mgs_term_step {
  int iteration;                /* 1-based, as the reference */
  int iterations;               /* the run's total */
  const mgs_gaussians *model;
  const mgs_view *view;         /* the training view of this iteration (camera, GT image) */
  size_t view_index;            /* its index among the training views */
  const float *color;           /* rendered image, width x height x 3, row-major */
  const float *gt;              /* ground truth, same layout */
  const float *alpha;           /* the render's 1 - T, width x height */
  const float *depth;           /* the render's sum_i w_i z_i (not divided by alpha) */
  const int *radii;             /* per Gaussian screen radius in px, 0 when culled */
  int width, height;
  int active_sh;
  double extent;                /* scene radius (the reference's cameras_extent) */
  mgs_rng *rng;
  float *dl_dcolor;             /* image_grad adds here */
  float *dl_ddepth;             /* image_grad adds dL/d(depth) here (width x height, zeroed);
                                   non-NULL only in iterations where a term's active() has
                                   MGS_TERM_DEPTH */
  int dl_ddepth_used;           /* out: set by a term that added to dl_ddepth (the backward
                                   then reads it) */
  struct mgs_raster *raster;    /* the rasterizer context of this iteration's forward (its
                                   maps and, for 2DGS, map gradients: render/mgs_raster.h) */
  mgs_gaussians *grad;          /* model_grad adds here (the model's n and SH degree) */
  double value;                 /* out: the term's weighted loss value this iteration */
} mgs_term_step;

typedef struct mgs_term_ops {
  const char *name;             /* also the checkpoint's key for its state (< 32 chars) */
  /* Which hooks run in this iteration: MGS_TERM_IMAGE | MGS_TERM_MODEL bits (0: none);
     with MGS_TERM_MAPS the image hook reads the geometry maps (mgs_raster_maps), and the
     trainer asks the forward for them ahead (mgs_raster_hint_maps); with MGS_TERM_DEPTH
     it may add a gradient of the rendered depth (s->dl_ddepth), carried by the same
     backward as the colour's. A function of the iteration (and of model_replaced notices,
     which come after the terms of their iteration): the trainer calls it before the forward
     and again after. */
  unsigned (*active)(void *self, int iteration);
  mgs_status (*image_grad)(void *self, mgs_term_step *s, mgs_error *err);
  mgs_status (*model_grad)(void *self, mgs_term_step *s, mgs_error *err);
  mgs_status (*save)(void *self, FILE *f, mgs_error *err);           /* may be NULL */
  mgs_status (*load)(void *self, FILE *f, mgs_error *err);           /* may be NULL */
  void (*destroy)(void *self);
  /* May be NULL: the strategy replaced every Gaussian by new ones at `iteration` (after this
     iteration's terms ran); state derived from the old model is to be dropped. */
  void (*model_replaced)(void *self, int iteration);
} mgs_term_ops;

enum { MGS_TERM_IMAGE = 1u, MGS_TERM_MODEL = 2u, MGS_TERM_MAPS = 4u, MGS_TERM_DEPTH = 8u };

typedef struct mgs_term {
  const mgs_term_ops *ops;
  void *self;
} mgs_term;

/* Wraps ops + self in a heap term (NULL on allocation failure, self then destroyed). */
mgs_term *mgs_term_create(const mgs_term_ops *ops, void *self);
void mgs_term_destroy(mgs_term *t);

#ifdef __cplusplus
}
#endif
#endif

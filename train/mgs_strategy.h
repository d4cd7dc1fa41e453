/* Density-control strategies: the hooks the trainer calls around the backward pass, as
 * gsplat's Strategy. A strategy may add or remove Gaussians only through
 * mgs_model_append / mgs_model_compact (train/mgs_train.h), which keep Adam's moments in
 * step, and must keep its own per-Gaussian state aligned itself.
 *
 * The reference ADC (train/strategy_adc.c) is the first; MorseGS plugs in here later. */
#ifndef MGS_STRATEGY_H
#define MGS_STRATEGY_H
#include <stdio.h>
#include "core/mgs_error.h"
#include "core/mgs_gaussians.h"
#include "core/mgs_rng.h"
#include "train/mgs_train.h"

#ifdef __cplusplus
extern "C" {
#endif

/* What the hooks see of one iteration. */
typedef struct mgs_strategy_step {
  int iteration;             /* 1-based, as the reference */
  mgs_gaussians *model;
  mgs_adam *adam;
  const mgs_gaussians *grad; /* gradients of this iteration (model's n); NULL when the
                                trainer runs backward and Adam fused (see `fusable`) */
  const float *grad_mean2d;  /* n: |dL/dmean2d| in NDC units, 0 when culled */
  const int *radii;          /* n: screen radius px, 0 when culled */
  int width, height;
  double extent;             /* scene radius (the reference's cameras_extent) */
  mgs_rng *rng;
  /* out: groups whose tensors the hook replaced (1 << group); the trainer skips Adam for
   * them this iteration, as torch does for a fresh parameter without a gradient. */
  unsigned replaced_groups;
  /* out: every Gaussian was replaced by new ones (Mini-Splatting's reinitialisations): the
   * trainer tells the loss terms (mgs_term_ops.model_replaced), so that none goes on using an
   * analysis of a model that no longer exists. */
  int model_replaced;
  /* For strategies that render (Mini-Splatting): the context of this iteration's forward
   * (untouched since it in pre_backward) and the trainer (its train views and images). */
  mgs_raster *raster;
  struct mgs_trainer *trainer;
} mgs_strategy_step;

typedef struct mgs_strategy_ops {
  const char *name;
  mgs_status (*pre_backward)(void *self, mgs_strategy_step *s, mgs_error *err);
  mgs_status (*post_backward)(void *self, mgs_strategy_step *s, mgs_error *err);
  /* Checkpoint: the strategy's state as an opaque blob. */
  mgs_status (*save)(void *self, FILE *f, mgs_error *err);
  mgs_status (*load)(void *self, FILE *f, size_t n_gaussians, mgs_error *err);
  void (*destroy)(void *self);
  /* Optional: nonzero when post_backward of this iteration (s->iteration; s->grad NULL)
   * reads only grad_mean2d and radii, neither the gradients nor the parameters, and
   * replaces no group. The trainer then runs the backward and Adam fused, before the hook
   * (which sees the stepped model). NULL: never. */
  int (*fusable)(void *self, const mgs_strategy_step *s);
  /* Optional: at the start of `iteration`, the step of the position-lr schedule (*lr_step,
   * preset to the iteration) and the highest SH degree the trainer may raise to (*sh_max,
   * preset to the model's). NULL: the reference's schedule. */
  void (*schedule)(void *self, int iteration, int *lr_step, int *sh_max);
} mgs_strategy_ops;

typedef struct mgs_strategy {
  const mgs_strategy_ops *ops;
  void *self;
} mgs_strategy;

void mgs_strategy_destroy(mgs_strategy *s);

/* The reference adaptive density control. */
mgs_strategy *mgs_strategy_adc_create(const mgs_adc_options *o);

/* The ADC accumulators (for tests and tools); resized to n_gaussians (zeroed) when they
 * hold another count. NULL if s is not ADC. */
typedef struct mgs_adc_state {
  size_t n;
  float *grad_accum;
  int *count;
  int *max_radii;
} mgs_adc_state;
mgs_adc_state *mgs_strategy_adc_state(mgs_strategy *s, size_t n_gaussians);
/* Runs the densify-and-prune of one interval on the current accumulators (what
 * post_backward does at a densification step); `prune_big` enables the screen/world
 * size pruning (the reference enables it after the first opacity reset). */
mgs_status mgs_adc_densify_and_prune(mgs_strategy *s, mgs_gaussians *g, mgs_adam *a, double extent,
                                     int prune_big, mgs_rng *rng, mgs_error *err);
/* The same, also splitting every Gaussian with force_split[i] != 0 (g->n entries). */
mgs_status mgs_adc_densify_and_prune_mask(mgs_strategy *s, mgs_gaussians *g, mgs_adam *a, double extent,
                                          int prune_big, const uint8_t *force_split, mgs_rng *rng, mgs_error *err);
/* Opacity reset: opacity = min(alpha, 0.01) as a logit; zeroes the opacity moments. */
void mgs_adc_reset_opacity(mgs_gaussians *g, mgs_adam *a);

#ifdef __cplusplus
}
#endif
#endif

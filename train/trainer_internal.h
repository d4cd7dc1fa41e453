/* The trainer's state, shared by trainer.c and checkpoint.c only. */
#ifndef MGS_TRAINER_INTERNAL_H
#define MGS_TRAINER_INTERNAL_H
#include "train/mgs_train.h"
#include "train/mgs_strategy.h"
#include "train/mgs_term.h"
#include "render/mgs_raster.h"
#include "core/mgs_log.h"

struct mgs_trainer {
  mgs_train_options o;
  mgs_dataset *ds;              /* borrowed */
  mgs_gaussians *g, *grad;
  mgs_adam *adam;
  mgs_strategy *strategy;       /* owned, may be NULL */
  mgs_term **terms;             /* owned loss terms, in the order added */
  double *term_values;          /* each term's last weighted value */
  double *term_s;               /* each term's wall seconds, summed over the run */
  size_t n_terms;
  mgs_raster *raster;
  mgs_raster_settings rs;
  int iteration;                /* completed */
  int active_sh;
  mgs_rng rng;
  uint32_t *perm;               /* order of the train views in this epoch */
  size_t perm_len, perm_pos;
  float *dl;                    /* dL/dcolor */
  size_t dl_cap;
  float *dl_depth;              /* dL/d(depth) from image terms (MGS_TERM_DEPTH), or NULL */
  size_t dl_depth_cap;
  const float *dl_depth_live;   /* dl_depth when a term wrote it this iteration, else NULL */
  float *gm2d;                  /* per-Gaussian NDC 2D-mean gradient norm */
  int grad_clean;               /* the last Adam step zeroed the gradients it read ... */
  size_t grad_clean_n;          /* ... of this many Gaussians ... */
  int grad_clean_sh;            /* ... with this many active SH-rest coefficients */
  size_t gm_cap;
  mgs_gaussians *tgrad;         /* model terms' gradients when they join the fused step */
  size_t tgrad_clean_n;         /* rows of tgrad known zero (the fused step clears what it reads) */
  double seconds;               /* training wall time */
  double cpu_seconds;           /* training CPU time of the process (NAN: resumed from a checkpoint without it) */
  double ema_loss, ema_psnr;    /* the reference's 0.4/0.6 moving average */
  double last_loss;
  double phase_s[MGS_TRAIN_PHASES]; /* seconds per phase, see mgs_trainer_phase_seconds */
  struct mgs_progress *progress; /* drawn across run_until calls */
  /* large scenes (train/trainer_large_scenes.c) */
  struct mgs_visibility *vis;   /* NULL unless o.visibility */
  size_t raster_n;              /* model count at this iteration's forward */
  size_t vis_listed;            /* Gaussians projected, summed over iterations */
  struct mgs_image_cache *cache; /* NULL unless o.image_cache_mb */
  float *gt_buf;                /* the current view's image from the cache */
  size_t gt_cap;
  uint32_t *view_chunk;         /* o.view_locality: chunk of each train view, and scratch */
  uint32_t *view_scratch;
};

/* train/trainer_large_scenes.c: the large-scene paths (visibility, sparse Adam) */
mgs_status mgs_trainer_large_init(mgs_trainer *t, mgs_error *err);
void mgs_trainer_large_destroy(mgs_trainer *t);
void mgs_trainer_large_invalidate(mgs_trainer *t); /* the model was replaced (checkpoint) */
mgs_status mgs_trainer_large_forward(mgs_trainer *t, const mgs_camera *cam, mgs_raster_output *ro, mgs_error *err);
mgs_status mgs_trainer_large_adam_fused(mgs_trainer *t, const int *radii, unsigned mask, mgs_error *err);
mgs_status mgs_trainer_large_adam(mgs_trainer *t, const int *radii, unsigned mask, int zero_grad, mgs_error *err);
/* The ground truth of train view i: the dataset's float image, or the cache's (then the
 * next views are handed to its prefetch thread). */
mgs_status mgs_trainer_large_image(mgs_trainer *t, size_t i, const float **gt, mgs_error *err);
/* After each epoch's shuffle: views of one spatial chunk made consecutive (no-op unless
 * o.view_locality). */
void mgs_trainer_large_order_views(mgs_trainer *t);
void mgs_trainer_large_after_step(mgs_trainer *t, const mgs_strategy_step *ss, const int *radii, int stepped);
#endif

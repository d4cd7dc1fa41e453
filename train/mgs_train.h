/* The training layer (train/): it owns
 *   Adam over the model's parameter groups ........ mgs_adam_* (train/adam.c; fused with
 *                                                   the backward: train/adam_backward.c)
 *   count changes that keep Adam in step .......... mgs_model_append / mgs_model_compact
 *   initial Gaussians (points or random) .......... mgs_init_* (train/init.c)
 *   the trainer loop, checkpoints, Ctrl-C ......... mgs_trainer_* (train/trainer.c,
 *                                                   train/checkpoint.c)
 *   the run folder (cameras.json, cfg_args) ....... mgs_run_* (train/run_io.c,
 *                                                   one trainer per folder: run_lock.c)
 * Density-control strategies plug in through train/mgs_strategy.h.
 *
 * Steps are counted as the reference 3DGS does: iteration 1 is the first, learning rates
 * and the SH degree are updated at the start of an iteration, the optimizer steps after
 * the strategy's post-backward hook, and the last iteration does no optimizer step. */
#ifndef MGS_TRAIN_H
#define MGS_TRAIN_H
#include <signal.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include "core/mgs_error.h"
#include "core/mgs_gaussians.h"
#include "core/mgs_dataset.h"
#include "core/mgs_rng.h"
#include "render/mgs_raster.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ---- Adam ------------------------------------------------------------------------ */

/* First and second moments with the same groups and shapes as the model; one step count
 * per group (a group skipped on a step keeps its count, as torch's per-parameter state). */
typedef struct mgs_adam {
  size_t n, capacity;
  float *m[MGS_PARAM_COUNT], *v[MGS_PARAM_COUNT];
  float lr[MGS_PARAM_COUNT];
  int64_t t[MGS_PARAM_COUNT];
  double beta1, beta2, eps;
  /* SH rest coefficients per channel in use (0..15, default 15): the others never had a
   * gradient, so their moments are zero and Adam would leave them unchanged; skipping
   * them is exact and saves most of the memory traffic before the SH degree is 3. */
  int sh_rest_active;
  /* SH-rest moments stored as bfloat16 (set with mgs_adam_set_sh_rest_bf16): m[SH_REST]
   * then holds one 32-bit word per coefficient, m in the low and v in the high 16 bits,
   * rounded stochastically (a hash of the element and the step: unbiased, so v's 0.999
   * decay is not lost to rounding; deterministic); v[SH_REST] is NULL (freed). Moves 16 instead
   * of 24 bytes per SH-rest float a step (45 of the 59 floats a Gaussian). Row operations
   * (append, compact, copies, checkpoints) carry the words unchanged. Not the reference:
   * off by default (bench train measures its effect on quality). */
  int sh_rest_bf16;
} mgs_adam;

/* Moments for n Gaussians, zero; beta = (0.9, 0.999), eps = 1e-15, lr all zero. */
mgs_adam *mgs_adam_create(size_t n);
void mgs_adam_destroy(mgs_adam *a);
/* Adds `count` rows of zero moments at the end. */
mgs_status mgs_adam_append(mgs_adam *a, size_t count, mgs_error *err);
/* Keeps rows with keep[i] != 0, in order (the same mask as mgs_gaussians_compact). */
void mgs_adam_compact(mgs_adam *a, const uint8_t *keep);
/* Switches the SH-rest moments to (on != 0) or from bfloat16 storage, converting the
 * moments held (round to nearest); packing frees v[SH_REST] (NULL while packed),
 * unpacking allocates it again (MGS_ERR_NOMEM if it cannot; nothing changed then). */
mgs_status mgs_adam_set_sh_rest_bf16(mgs_adam *a, int on, mgs_error *err);
/* Zeroes one group's moments (what the reference does when it replaces a tensor). */
void mgs_adam_reset_group(mgs_adam *a, mgs_param_group group);
/* One Adam step on every group whose bit is set in group_mask (1 << group).
 * grad has the model's n and shapes. Returns MGS_ERR_NUMERIC naming the group and the
 * Gaussian when a gradient or an updated value is not finite. */
mgs_status mgs_adam_step(mgs_adam *a, mgs_gaussians *model, const mgs_gaussians *grad,
                         unsigned group_mask, mgs_error *err);
/* The same, and with zero_grad != 0 the gradient values it consumed are set to zero in the
 * same pass (the active part of each selected group; the next backward can then add into
 * it without a separate clearing pass). Gradients of a group holding a non-finite value
 * may be left as they were. */
mgs_status mgs_adam_step_zero(mgs_adam *a, mgs_gaussians *model, mgs_gaussians *grad,
                              unsigned group_mask, int zero_grad, mgs_error *err);
/* The rasterizer's backward (of the last forward on r, which rendered `model`) and this
 * Adam step in one pass, without gradient arrays: identical to mgs_raster_backward into
 * zeroed gradients followed by mgs_adam_step (no gradient is ever 24 MB of memory
 * traffic). grad_mean2d as mgs_raster_backward. Another backward on r needs a new forward. */
mgs_status mgs_adam_step_backward(mgs_adam *a, mgs_gaussians *model, mgs_raster *r, const float *dL_dcolor,
                                  const float *dL_dalpha, const float *dL_ddepth, float *grad_mean2d,
                                  unsigned group_mask, mgs_error *err);
/* The same with `extra` (model->n rows; its mean, log-scale, rotation and opacity groups)
 * added to the rasterizer's gradients before the step: loss terms on the Gaussians,
 * computed before the backward, join the fused step. Those groups of extra are set to
 * zero as they are read (the next step's terms add into a clean array). Equal to the
 * separate passes up to the order of the float sums: raster + (term1 + term2) here,
 * (raster + term1) + term2 there (tests/train/test_fused.c). */
mgs_status mgs_adam_step_backward_extra(mgs_adam *a, mgs_gaussians *model, mgs_raster *r, const float *dL_dcolor,
                                        const float *dL_dalpha, const float *dL_ddepth, float *grad_mean2d,
                                        unsigned group_mask, mgs_gaussians *extra, mgs_error *err);
/* Sparse Adam (train/adam_sparse.c), a deliberate difference from the reference, which
 * steps every Gaussian: only rows with radii[i] > 0 (the Gaussians the last view saw) are
 * stepped; the others keep parameters and moments unchanged. Otherwise as
 * mgs_adam_step_zero / mgs_adam_step_backward. */
mgs_status mgs_adam_step_sparse(mgs_adam *a, mgs_gaussians *model, mgs_gaussians *grad, unsigned group_mask,
                                const int *radii, int zero_grad, mgs_error *err);
mgs_status mgs_adam_step_backward_sparse(mgs_adam *a, mgs_gaussians *model, mgs_raster *r, const float *dL_dcolor,
                                         const float *dL_dalpha, const float *dL_ddepth, float *grad_mean2d,
                                         unsigned group_mask, const int *radii, mgs_error *err);
/* Bytes one Adam step reads and writes, counted from the layout (train/adam.c): for every
 * stepped row (rows: model->n for a dense step, the rows with radii > 0 for a sparse one)
 * and every active float of each group in group_mask, the parameter and its two moments
 * read and written (24 bytes); the gradient read from gradient arrays when grad_arrays
 * (and written back as 0 with zero_grad), not counted when it comes from a fused
 * backward's 64-Gaussian block, which stays in L1. */
void mgs_adam_bytes(const mgs_adam *a, size_t rows, unsigned group_mask, int grad_arrays, int zero_grad,
                    double *read, double *written);
/* The reference's get_expon_lr_func (lr_delay_steps = 0): log-linear from lr_init at
 * step 0 to lr_final at max_steps, constant after. */
double mgs_expon_lr(int64_t step, double lr_init, double lr_final, int64_t max_steps);

/* Count changes that keep the optimizer in step: append `count` Gaussians (zero
 * parameters, identity rotation, zero moments) / keep rows where keep[i] != 0. */
mgs_status mgs_model_append(mgs_gaussians *g, mgs_adam *a, size_t count, size_t *first,
                            mgs_error *err);
size_t mgs_model_compact(mgs_gaussians *g, mgs_adam *a, const uint8_t *keep);

/* ---- initialization ---------------------------------------------------------------- */

/* The reference's create_from_pcd: one Gaussian per point, isotropic scale = sqrt of the
 * mean squared distance to the 3 nearest neighbours (min 1e-7), opacity 0.1, SH DC from
 * the colour, higher SH zero, identity rotation. */
mgs_status mgs_init_from_points(const float *xyz, const float *rgb, size_t n, int sh_degree,
                                mgs_gaussians **out, mgs_error *err);
/* Makes an initial model 2DGS surfels as the authors' create_from_pcd does (the same
 * centres, colours, opacity 0.1 and sqrt(mean squared 3-NN distance) scales on the two
 * disc axes; rotations uniform random in [0,1)^4, unnormalized, from `seed`'s own stream;
 * log_scale[2] = MGS_SURFEL_LOG_SCALE2). */
void mgs_init_to_surfels(mgs_gaussians *g, uint64_t seed);
/* Mean squared distance of each point to its 3 nearest other points (uniform grid). */
mgs_status mgs_knn3_mean_sq(const float *xyz, size_t n, float *out, mgs_error *err);
/* Random init of the reference for NeRF-synthetic: `count` points uniform in the cube
 * [lo, hi]^3, colour SH2RGB(u/255), u uniform in [0,1). */
mgs_status mgs_init_random(size_t count, const double lo[3], const double hi[3], int sh_degree,
                           mgs_rng *rng, mgs_gaussians **out, mgs_error *err);
/* The random init for a dataset without initial points: the reference's cube of half-size
 * 1.3 for NeRF-synthetic, centred where the training cameras look (mgs_dataset_look_at,
 * snapped to 1/64 of the extent: exactly the reference's cube at (0,0,0) for a centred
 * folder, the same cube moved for a moved one); for other formats (scale unknown) a cube
 * of half-size extent/1.1 * 0.5 around the cameras' centre. All in the dataset's local
 * frame (its origin). `seed` is the run's seed (its own stream). */
mgs_status mgs_init_random_for_dataset(const mgs_dataset *ds, size_t count, int sh_degree, uint64_t seed,
                                       mgs_gaussians **out, mgs_error *err);

/* ---- trainer ----------------------------------------------------------------------- */

typedef struct mgs_adc_options {
  int densify_from;        /* 500 */
  int densify_until;       /* 15000 */
  int densify_every;       /* 100 */
  int opacity_reset_every; /* 3000 */
  float grad_threshold;    /* 2e-4, on the mean NDC 2D-mean gradient norm */
  float percent_dense;     /* 0.01: clone if max scale <= this * extent, else split */
  int split_n;             /* 2 */
  float min_opacity;       /* 0.005 */
  float max_screen_px;     /* 20: pruned after the first opacity reset */
  float max_world_scale;   /* 0.1 * extent, pruned after the first opacity reset */
  int white_background;    /* the reference also resets opacity at densify_from then */
  int reset_prune_wait;    /* 0 (the reference): transparent Gaussians pruned at every densification;
                              N: not within N iterations after an opacity reset (a compressed
                              schedule's reset leaves the unscaled learning rate fewer steps than
                              the reference's 100 to lift opacities over the prune threshold) */
} mgs_adc_options;
void mgs_adc_options_default(mgs_adc_options *o);

struct mgs_trainer; /* for the hook below; the typedef follows */
typedef struct mgs_train_options {
  int iterations;            /* 30000 */
  int sh_degree;             /* max SH degree, 3 */
  int sh_every;              /* raise the active degree every N iterations, 1000 */
  float lambda_dssim;        /* 0.2 */
  double lr_mean_init, lr_mean_final; /* 1.6e-4, 1.6e-6, times the scene extent */
  int lr_mean_max_steps;     /* 30000: the decay's length, whatever `iterations` is (the
                                reference's position_lr_max_steps); 0 = `iterations` */
  float lr_log_scale, lr_rot, lr_opacity, lr_sh_dc, lr_sh_rest;
  uint64_t seed;
  int checkpoint_every;      /* 0 = never (besides Ctrl-C) */
  const char *checkpoint_path; /* where periodic / interrupt checkpoints go (may be NULL) */
  volatile sig_atomic_t *stop; /* set asynchronously (SIGINT): stop after this iteration */
  int freeze;                /* 1: never update parameters (calibration of tests) */
  int progress;              /* 1: draw the progress bar */
  mgs_adc_options adc;
  /* large scenes (train/trainer_large_scenes.c); all off by default */
  int visibility;            /* 1: project only the spatial tiles a view can see (same images);
                                -1 auto: on when views see under half the initial model */
  double vis_tile;           /* tile side in world units, 0 = automatic */
  int vis_rebin_every;       /* re-bin the tiles every N iterations (200; 0 = only on count changes) */
  int spatial_order;         /* with visibility: lay the initial Gaussians out along a Morton
                                curve of tiles (memory locality; the model's order changes,
                                not its content). -1 = yes (default), 0 = keep the input order */
  int sparse_adam;           /* 1: step only the Gaussians the view saw (differs from the
                                reference); -1 auto: as the visibility's auto decision */
  int sh_moments_bf16;       /* SH-rest Adam moments as bfloat16 (mgs_adam.sh_rest_bf16) */
  size_t image_cache_mb;     /* > 0: train images streamed through an 8-bit cache of this many
                                MiB with a prefetch thread (core/mgs_image_cache.h); 0: all
                                images loaded as floats up front */
  int prefetch;              /* views decoded ahead by the cache's thread (8; 0 = no thread) */
  int view_locality;         /* 1: each epoch visits spatial chunks of views (camera centres
                                along a Morton curve, max(8, prefetch) a chunk) one after
                                another, chunks and views within them in random order */
  /* Called after every whole iteration, before that iteration's periodic checkpoint (so a
   * checkpoint holds what the hook made of the model): distributed training keeps its ghost
   * copies here. A nonzero status ends the run. NULL: none. */
  mgs_status (*after_step)(void *user, struct mgs_trainer *t, mgs_error *err);
  void *after_step_user;
} mgs_train_options;
void mgs_train_options_default(mgs_train_options *o);

typedef struct mgs_trainer mgs_trainer;
struct mgs_strategy;
struct mgs_term;

/* Takes ownership of `init` (the initial model) and `strategy` (may be NULL: no density
 * control). The dataset is borrowed and must have its train images loaded.
 *
 * Save points. The reference saves, evaluates and reports "iteration N" after iteration
 * N's backward and before its densification, opacity reset and optimizer step: the model
 * it writes is the one iteration N-1 left. This trainer decides that once, here:
 * mgs_trainer_run_to(t, N) stops at that point (iterations 1..N-1 complete), and
 * mgs_trainer_model_iteration() names the current model as the reference would. The last
 * iteration has neither optimizer step nor density control (as the reference, whose final
 * densification would only change a model it never saves), so after a whole run the model
 * is the reference's final one. Periodic checkpoints are taken after a whole iteration,
 * which is where --resume continues exactly. */
mgs_status mgs_trainer_create(mgs_dataset *ds, const mgs_train_options *o, mgs_gaussians *init,
                              struct mgs_strategy *strategy, mgs_trainer **out, mgs_error *err);
void mgs_trainer_destroy(mgs_trainer *t);
/* Adds a loss term (train/mgs_term.h); the trainer owns it (destroyed on failure too).
 * Terms run in the order added; their state is part of checkpoints. */
mgs_status mgs_trainer_add_term(mgs_trainer *t, struct mgs_term *term, mgs_error *err);
/* The last iteration's weighted value of each term (in the order added); n_out <= count. */
size_t mgs_trainer_term_values(const mgs_trainer *t, double *out, size_t n_out);
/* Each term's wall seconds summed over this process's iterations (analyses a term
 * triggers included); n_out <= count. */
size_t mgs_trainer_term_seconds(const mgs_trainer *t, double *out, size_t n_out);
/* The k-th term's name (its ops' name), NULL past the last. */
const char *mgs_trainer_term_name(const mgs_trainer *t, size_t k);
/* One iteration. MGS_ERR_NUMERIC stops training: the message names the parameter group. */
mgs_status mgs_trainer_step(mgs_trainer *t, mgs_error *err);
/* Steps until `iterations`, drawing progress, writing periodic checkpoints, checking the
 * stop flag (then writes a checkpoint and returns MGS_ERR_INTERRUPTED). */
mgs_status mgs_trainer_run(mgs_trainer *t, mgs_error *err);
/* The same, stopping after iteration `until` is complete. */
mgs_status mgs_trainer_run_until(mgs_trainer *t, int until, mgs_error *err);
/* Runs to the save point of iteration n (see above; n = iterations runs the whole run). */
mgs_status mgs_trainer_run_to(mgs_trainer *t, int n, mgs_error *err);
int mgs_trainer_iteration(const mgs_trainer *t);  /* iterations completed */
/* The iteration the reference would name the current model by: iterations completed + 1,
 * or the total once the last iteration ran. */
int mgs_trainer_model_iteration(const mgs_trainer *t);
int mgs_trainer_active_sh(const mgs_trainer *t);
const mgs_gaussians *mgs_trainer_model(const mgs_trainer *t);
mgs_gaussians *mgs_trainer_model_mut(mgs_trainer *t); /* tests inject values */
/* Changes the set of Gaussians outside a strategy's hooks (distributed training's hand-off
 * between blocks): rows with keep[i] == 0 are removed (keep NULL: none), then `add` rows
 * are appended at *first with zero Adam moments, for the caller to fill through
 * mgs_trainer_model_mut. Tiles and strategy state follow the new count. */
mgs_status mgs_trainer_edit_model(mgs_trainer *t, const uint8_t *keep, size_t add, size_t *first, mgs_error *err);
/* One Gaussian's whole training state as a row of floats: its parameters, then Adam's
 * first and second moments, group by group (mgs_trainer_state_floats() floats). A Gaussian
 * that moves between distributed blocks takes its state along this way; step counts and
 * learning rates stay with the trainer. */
size_t mgs_trainer_state_floats(const mgs_trainer *t);
void mgs_trainer_get_state(const mgs_trainer *t, size_t i, float *row);
void mgs_trainer_set_state(mgs_trainer *t, size_t i, const float *row);
double mgs_trainer_seconds(const mgs_trainer *t);  /* training wall time so far */
/* Training CPU time so far (the process' threads, over the training steps only); NAN after
 * a resume from a checkpoint older than version 4. */
double mgs_trainer_cpu_seconds(const mgs_trainer *t);
double mgs_trainer_last_loss(const mgs_trainer *t);
/* The learning rate the last iteration used for a parameter group. */
double mgs_trainer_learning_rate(const mgs_trainer *t, mgs_param_group group);
/* Wall seconds spent so far in each phase (Adam is counted in the backward on iterations
 * where the two run fused; terms = the loss terms of train/mgs_term.h). */
typedef enum { MGS_PHASE_FORWARD, MGS_PHASE_LOSS, MGS_PHASE_BACKWARD, MGS_PHASE_STRATEGY, MGS_PHASE_ADAM,
               MGS_PHASE_TERMS, MGS_TRAIN_PHASES } mgs_train_phase;
void mgs_trainer_phase_seconds(const mgs_trainer *t, double out[MGS_TRAIN_PHASES]);
/* Image-cache figures (zeros without a cache): hits, misses, peak resident bytes. */
void mgs_trainer_image_cache_stats(const mgs_trainer *t, size_t *hits, size_t *misses, size_t *peak_bytes);
/* Visibility figures: Gaussians projected per iteration (mean so far), occupied tiles,
 * tile side (0s when visibility is off). */
void mgs_trainer_visibility_stats(const mgs_trainer *t, double *listed_per_iter, size_t *tiles, double *tile_size);
/* The dataset, and the ground truth of train view i (h*w*3 floats, valid until the next
 * call or iteration): for strategies that render every train view (Mini-Splatting). */
const mgs_dataset *mgs_trainer_dataset(const mgs_trainer *t);
mgs_status mgs_trainer_train_image(mgs_trainer *t, size_t i, const float **rgb, mgs_error *err);
/* Mean PSNR and SSIM over a split's views (images loaded on demand). */
mgs_status mgs_trainer_evaluate(mgs_trainer *t, mgs_split split, size_t max_views,
                                double *psnr, double *ssim, mgs_error *err);

/* Binary checkpoint (versioned header, checksum, atomic): model, Adam moments and step
 * counts, strategy state, iteration, active SH degree, RNG and view order. Loading
 * replaces the trainer's state; it must have been made with the same dataset. */
mgs_status mgs_trainer_save_checkpoint(const mgs_trainer *t, const char *path, mgs_error *err);
mgs_status mgs_trainer_load_checkpoint(mgs_trainer *t, const char *path, mgs_error *err);

/* ---- run folder -------------------------------------------------------------------- */

/* RUN/cameras.json in the reference layout (test then train views: id, img_name, width,
 * height, position (world: the dataset's origin added in double), rotation
 * (camera-to-world), fy, fx). */
mgs_status mgs_run_write_cameras(const char *run_dir, const mgs_dataset *ds, mgs_error *err);
/* RUN/point_cloud/iteration_N/point_cloud.ply (world coordinates: g->origin added, see
 * mgs_ply_write_gaussians) */
mgs_status mgs_run_write_ply(const char *run_dir, int iteration, const mgs_gaussians *g, mgs_error *err);
/* Appends "iteration,train_seconds,gaussians,train_cpu_seconds" to RUN/saves.csv (header
 * first when new): the training wall and CPU time at each saved model, which survives a kill and a --resume (file
 * times of the .ply files do not). Rewritten whole through a temp file, so a kill never
 * leaves a half line. */
mgs_status mgs_run_record_save(const char *run_dir, int iteration, double train_seconds, size_t gaussians,
                               double train_cpu_seconds, mgs_error *err);
/* Training seconds recorded for `iteration` in RUN/saves.csv (its last line for that
 * iteration), or NaN when there is none. */
double mgs_run_saved_seconds(const char *run_dir, int iteration);
/* Largest N with RUN/point_cloud/iteration_N/point_cloud.ply, or -1. */
int mgs_run_latest_iteration(const char *run_dir);
/* One trainer per run folder (train/run_lock.c): creates RUN if needed and takes an
 * exclusive lock on RUN/.morsegs-train.lock; fails with a message naming RUN (and the
 * holder's pid) when another trainer holds it. The kernel releases it if the process dies;
 * release removes the file. While held, temp files left by killed trainers are removed. */
typedef struct mgs_run_lock mgs_run_lock;
mgs_status mgs_run_lock_acquire(const char *run_dir, mgs_run_lock **out, mgs_error *err);
void mgs_run_lock_release(mgs_run_lock *l); /* NULL is fine */

/* Opens a run for render/eval: reads cfg_args (source_path, downscale, background,
 * test_every), loads the dataset (images only if load_images) and the .ply of
 * `iteration` (-1: the latest), its means made relative to the dataset's origin (which
 * must equal cfg_args' scene_origin when recorded). */
mgs_status mgs_run_open(const char *run_dir, int iteration, int load_images, mgs_dataset **ds,
                        mgs_gaussians **g, int *iteration_out, mgs_error *err);

/* A run folder for a model trained elsewhere, so that eval/render/vdb treat it as one of
 * ours: `model_path` (a folder in the reference's output layout: its latest iteration; or a file
 * in any format mgs_ply_read_gaussians reads: the reference .ply, 2DGS,
 * SuperSplat's compressed .ply, .splat, .spz, SOG, .ksplat) becomes out_dir/point_cloud/iteration_0/
 * point_cloud.ply, with the dataset's cameras.json and a cfg_args naming the dataset (its
 * absolute path), the background (white_background: 1 white, 0 black, -1 the dataset's
 * default), the image downscale the model was trained at (>= 1: the reference's
 * --resolution), a COLMAP dataset's image folder (NULL: images; the reference's -i), the scene
 * origin and `imported_from`. The model must be in the dataset's world
 * frame. out_dir must not exist or be empty (nothing is overwritten). */
mgs_status mgs_run_import(const char *model_path, const char *dataset_dir, int white_background, int downscale,
                          const char *images, const char *out_dir, mgs_error *err);

/* The settings record RUN/cfg_args: Python Namespace(...) syntax as the reference (so
 * its viewers find source_path), one key=value per setting. */
typedef struct mgs_settings {
  size_t n;
  char **key, **value;
  int *quoted;
} mgs_settings;
void mgs_settings_init(mgs_settings *s);
void mgs_settings_free(mgs_settings *s);
void mgs_settings_set(mgs_settings *s, const char *key, const char *value, int quoted);
void mgs_settings_setf(mgs_settings *s, const char *key, double value);
void mgs_settings_seti(mgs_settings *s, const char *key, long long value);
const char *mgs_settings_get(const mgs_settings *s, const char *key);
mgs_status mgs_settings_write(const char *path, const mgs_settings *s, mgs_error *err);
mgs_status mgs_settings_read(const char *path, mgs_settings *s, mgs_error *err);
/* scene_origin='x y z': the dataset's origin (core/mgs_origin.h) in the settings record. */
void mgs_run_record_origin(mgs_settings *s, const mgs_dataset *ds);

#ifdef __cplusplus
}
#endif
#endif

/* The option table of `morsegs train` (train/mgs_config.h): every training setting once.
 * Defaults are written as a user would type them and go through the command line's parser;
 * cfg_args keys of the reference 3DGS are kept where it has the setting. */
#include <float.h>
#include <stddef.h>
#include <string.h>
#include "train/mgs_config.h"

#define F(field) offsetof(mgs_train_config, field), sizeof(((mgs_train_config *)0)->field)
#define BIG 1e9
#define REC MGS_OPT_RECORDED
#define CHG (MGS_OPT_RECORDED | MGS_OPT_CHANGEABLE)
#define MPI MGS_OPT_MPI
#define OPT MGS_OPT_OPTIONAL
#define NOT_DIST "the distributed trainer has no global analysis or loss of this kind yet (docs/notes/scale.md)"
#define NOT_DIST_MS "Mini-Splatting renders every training view for its global reinitialisation and simplification"
#define NOT_DIST_INIT "each rank initialises its block from the dataset's points"

static const mgs_option TABLE[] = {
  /* ---- run control ---- */
  {"output", NULL, MGS_OPT_STRING, F(output), "", 0, 0, NULL, NULL, MGS_GROUP_RUN, MPI,
   "-o, --output RUN: the run folder (point_cloud/iteration_N/point_cloud.ply, cameras.json, cfg_args)", NULL},
  {"resume", NULL, MGS_OPT_BOOL, F(resume), "0", 0, 1, NULL, "1", MGS_GROUP_RUN, MPI,
   "continue RUN from its checkpoint with its recorded settings (a flag contradicting them is refused)", NULL},
  {"force", NULL, MGS_OPT_BOOL, F(force), "0", 0, 1, NULL, "1", MGS_GROUP_RUN, MPI,
   "reuse a non-empty RUN (its previous outputs are removed)", NULL},
  {"checkpoint-every", "checkpoint_every", MGS_OPT_INT, F(checkpoint_every), "1000", 0, BIG, NULL, NULL, MGS_GROUP_RUN,
   CHG | MPI, "periodic checkpoint RUN/checkpoint.mgsckpt every N iterations (0 = off)", NULL},
  {"save-at", NULL, MGS_OPT_STRING, F(save_at), "7000", 0, 0, NULL, NULL, MGS_GROUP_RUN, 0,
   "extra .ply saves at these iterations (comma-separated)", "ranks save only the merged final model"},
  {"threads", NULL, MGS_OPT_INT, F(threads), "0", 0, 4096, NULL, NULL, MGS_GROUP_RUN, MPI,
   "worker threads (0 = all cores; with --mpi per process)", NULL},
  {"quiet", NULL, MGS_OPT_BOOL, F(quiet), "0", 0, 1, NULL, "1", MGS_GROUP_RUN, MPI, "no progress bar", NULL},
  {"mpi", NULL, MGS_OPT_BOOL, F(mpi), "0", 0, 1, NULL, "1", MGS_GROUP_RUN, MPI,
   "under mpirun -np K: K spatial blocks trained and merged (-np 1 = the serial trainer)", NULL},
  {"help", NULL, MGS_OPT_BOOL, F(help), "0", 0, 1, NULL, "1", MGS_GROUP_RUN, MPI, "-h, --help: this text", NULL},

  /* ---- 3DGS baseline (the reference's defaults) ---- */
  {"iters", "iterations", MGS_OPT_INT, F(iters), "30000", 1, BIG, NULL, NULL, MGS_GROUP_BASELINE, CHG | MPI,
   "iterations (--resume may extend a run)", NULL},
  {"downscale", "downscale", MGS_OPT_INT, F(downscale), "1", 1, 1024, NULL, NULL, MGS_GROUP_BASELINE, REC | MPI,
   "train on images resized to round(w/N) x round(h/N), bicubic (the reference's -r N; no width cap then)", NULL},
  {"max-width", "max_width", MGS_OPT_INT, F(max_width), "1600", 0, BIG, NULL, NULL, MGS_GROUP_BASELINE, REC | MPI,
   "without --downscale, images wider than W are resized to W (the reference's cap; 0 = full size)", NULL},
  {"images", "images", MGS_OPT_STRING, F(images), "images", 0, 0, NULL, NULL, MGS_GROUP_BASELINE, REC | MPI,
   "COLMAP/nerfstudio: the image folder in DATA (the reference's -i; images_4 of Mip-NeRF 360 or ns-process-data: cameras scaled to its images)", NULL},
  {"sh-degree", "sh_degree", MGS_OPT_INT, F(sh_degree), "3", 0, 3, NULL, NULL, MGS_GROUP_BASELINE, REC | MPI,
   "max SH degree", NULL},
  {"sh-every", "sh_increase_every", MGS_OPT_INT, F(sh_every), "1000", 1, BIG, NULL, NULL, MGS_GROUP_BASELINE, REC | MPI,
   "raise the active SH degree every N iterations", NULL},
  {"background", "background", MGS_OPT_ENUM, F(background), "auto", 0, 0, "auto|white|black", NULL,
   MGS_GROUP_BASELINE, REC | MPI,
   "auto: white for NeRF-synthetic, black for COLMAP and nerfstudio (the reference's use); --white, --black", NULL},
  {"test-every", "test_every", MGS_OPT_INT, F(test_every), "8", 0, BIG, NULL, NULL, MGS_GROUP_BASELINE, REC | MPI,
   "COLMAP/nerfstudio: every Nth view is a test view (the reference's --eval; 0 = every view trains, as without it)", NULL},
  {"seed", "seed", MGS_OPT_U64, F(seed), "0", 0, 0, NULL, NULL, MGS_GROUP_BASELINE, REC | MPI,
   "random seed (rank K of --mpi uses S + K)", NULL},
  {"strategy", "strategy", MGS_OPT_ENUM, F(strategy), "adc", 0, 0, "adc|morse|none|mini-splatting|mini-splatting-d|sugar|gaussianpro", NULL, MGS_GROUP_BASELINE, REC | MPI,
   "density control: adc (the reference's), morse (MorseGS, below), none, mini-splatting(-d) (Fang & Wang 2024), "
   "sugar (SuGaR's coarse stage, below), gaussianpro (ADC plus GaussianPro's propagation, --gpro-*)", NULL},
  {"init", "init", MGS_OPT_ENUM, F(init), "sfm", 0, 0, "sfm|random|levelset|lpvi", NULL, MGS_GROUP_BASELINE, REC | MPI,
   "initial Gaussians: dataset points (random when it has none), random, MorseGS level sets, LPVI (Topology-GS)", NULL},
  {"random-points", "random_points", MGS_OPT_INT, F(random_points), "100000", 1, BIG, NULL, NULL, MGS_GROUP_BASELINE,
   REC, "Gaussians of the random init", NOT_DIST_INIT},
  {"densify-from", "densify_from_iter", MGS_OPT_INT, F(densify_from), "500", 0, BIG, NULL, NULL, MGS_GROUP_BASELINE,
   REC | MPI, "first densification", NULL},
  {"densify-until", "densify_until_iter", MGS_OPT_INT, F(densify_until), "15000", 0, BIG, NULL, NULL,
   MGS_GROUP_BASELINE, REC | MPI, "last densification (with --mpi: the hand-off to ghosts)", NULL},
  {"densify-every", "densification_interval", MGS_OPT_INT, F(densify_every), "100", 1, BIG, NULL, NULL,
   MGS_GROUP_BASELINE, REC | MPI, "iterations between densifications", NULL},
  {"opacity-reset-every", "opacity_reset_interval", MGS_OPT_INT, F(opacity_reset_every), "3000", 0, BIG, NULL, NULL,
   MGS_GROUP_BASELINE, REC | MPI, "opacity reset period (0 = never)", NULL},
  {"grad-threshold", "densify_grad_threshold", MGS_OPT_DOUBLE, F(grad_threshold), "0.0002", 1e-12, 1e3, NULL, NULL,
   MGS_GROUP_BASELINE, REC | MPI, "view-space gradient threshold of ADC", NULL},
  {"percent-dense", "percent_dense", MGS_OPT_DOUBLE, F(percent_dense), "0.01", 0, 1, NULL, NULL, MGS_GROUP_BASELINE,
   REC | MPI, "clone if the largest scale <= this x extent, else split", NULL},
  {"min-opacity", "min_opacity", MGS_OPT_DOUBLE, F(min_opacity), "0.005", 0, 1, NULL, NULL, MGS_GROUP_BASELINE,
   REC | MPI, "prune below this opacity", NULL},
  {"max-screen-size", "max_screen_size", MGS_OPT_DOUBLE, F(max_screen_size), "20", 0, BIG, NULL, NULL,
   MGS_GROUP_BASELINE, REC | MPI, "prune Gaussians larger than this many pixels (after the first reset)", NULL},
  {"lambda-dssim", "lambda_dssim", MGS_OPT_DOUBLE, F(lambda_dssim), "0.2", 0, 1, NULL, NULL, MGS_GROUP_BASELINE,
   REC | MPI, "weight of D-SSIM in the loss", NULL},
  {"position-lr-init", "position_lr_init", MGS_OPT_DOUBLE, F(position_lr_init), "0.00016", 0, 1, NULL, NULL,
   MGS_GROUP_BASELINE, REC | MPI, "position learning rate at the start (x extent)", NULL},
  {"position-lr-final", "position_lr_final", MGS_OPT_DOUBLE, F(position_lr_final), "1.6e-06", 0, 1, NULL, NULL,
   MGS_GROUP_BASELINE, REC | MPI, "... at the end of the decay", NULL},
  {"position-lr-max-steps", "position_lr_max_steps", MGS_OPT_INT, F(position_lr_max_steps), "30000", 0, BIG, NULL,
   NULL, MGS_GROUP_BASELINE, REC | MPI, "length of the decay (the reference's, whatever --iters is; 0 = --iters)", NULL},
  {"feature-lr", "feature_lr", MGS_OPT_DOUBLE, F(feature_lr), "0.0025", 0, 10, NULL, NULL, MGS_GROUP_BASELINE, REC | MPI,
   "SH DC learning rate", NULL},
  {"feature-rest-lr", "feature_rest_lr", MGS_OPT_DOUBLE, F(feature_rest_lr), "0.000125", 0, 10, NULL, NULL,
   MGS_GROUP_BASELINE, REC | MPI, "higher SH learning rate", NULL},
  {"opacity-lr", "opacity_lr", MGS_OPT_DOUBLE, F(opacity_lr), "0.05", 0, 10, NULL, NULL, MGS_GROUP_BASELINE, REC | MPI,
   "opacity learning rate", NULL},
  {"scaling-lr", "scaling_lr", MGS_OPT_DOUBLE, F(scaling_lr), "0.005", 0, 10, NULL, NULL, MGS_GROUP_BASELINE, REC | MPI,
   "log-scale learning rate", NULL},
  {"rotation-lr", "rotation_lr", MGS_OPT_DOUBLE, F(rotation_lr), "0.001", 0, 10, NULL, NULL, MGS_GROUP_BASELINE,
   REC | MPI, "rotation learning rate", NULL},
  {"schedule-scale", "schedule_scale", MGS_OPT_DOUBLE, F(schedule_scale), "1", 1e-4, 100, NULL, NULL, MGS_GROUP_BASELINE,
   REC | MPI, "multiplies every iteration milestone (densify, resets, SH steps, lr decay, MorseGS W/K, PersLoss, "
   "Mini-Splatting): 0.25 = the reference schedule compressed into --iters 7500", NULL},
  {"simplify-fraction", "simplify_fraction", MGS_OPT_DOUBLE, F(simplify_fraction), "0.5", 1e-3, 1, NULL, NULL,
   MGS_GROUP_BASELINE, REC, "mini-splatting: share of Gaussians its first simplification samples (0.3: large scenes)",
   NOT_DIST_MS},
  {"ms-depth-points", "ms_depth_points", MGS_OPT_INT, F(ms_depth_points), "0", 0, BIG, NULL, NULL, MGS_GROUP_BASELINE,
   REC, "mini-splatting: points of a depth reinitialisation (authors: 3.5M; 0 = the model's count then)", NOT_DIST_MS},
  {"ms-blur-min-px", "ms_blur_min_px", MGS_OPT_DOUBLE, F(ms_blur_min_px), "8", 0, 1e6, NULL, NULL, MGS_GROUP_BASELINE,
   REC, "mini-splatting: floor in pixels of the blur-split threshold H*W/5000 (which is under a pixel below ~70x70)",
   NOT_DIST_MS},
  {"freeze", "freeze", MGS_OPT_BOOL, F(freeze), "0", 0, 1, NULL, "1", MGS_GROUP_BASELINE, REC,
   "diagnostic: never update the parameters (test calibration)", "a diagnostic of the serial trainer"},

  /* ---- 2DGS (hbb1/2d-gaussian-splatting; docs/notes/2dgs.md) ---- */
  {"model", "model", MGS_OPT_ENUM, F(model), "3dgs", 0, 0, "3dgs|2dgs", NULL, MGS_GROUP_BASELINE, REC,
   "splat model: 3dgs, or 2dgs (surfels with the authors' init, rasterizer, densification and losses)", NOT_DIST},
  {"lambda-dist", "lambda_dist", MGS_OPT_DOUBLE, F(lambda_dist), "-1", -1, 1e9, NULL, NULL, MGS_GROUP_BASELINE, REC,
   "2DGS depth distortion weight from iteration 3000 (-1 = auto: 1000, the authors' object (DTU) setting, for "
   "NeRF-synthetic; 0, their default, for COLMAP and nerfstudio)", NOT_DIST},
  {"lambda-normal", "lambda_normal", MGS_OPT_DOUBLE, F(lambda_normal), "0.05", 0, 1e9, NULL, NULL, MGS_GROUP_BASELINE,
   REC, "2DGS normal consistency weight from iteration 7000 (median depth's normals)", NOT_DIST},

  /* ---- large scenes (docs/notes/scale.md) ---- */
  {"visibility", "visibility", MGS_OPT_ENUM, F(visibility), "auto", 0, 0, "auto|on|off", NULL, MGS_GROUP_SCALE,
   REC | MPI, "project only the spatial tiles a view can see (auto: on when views see under half the model)", NULL},
  {"vis-tile", "vis_tile", MGS_OPT_DOUBLE, F(vis_tile), "0", 0, 1e30, NULL, NULL, MGS_GROUP_SCALE, REC | MPI,
   "tile side in world units (0 = automatic, ~256 Gaussians a tile)", NULL},
  {"adam", "adam", MGS_OPT_ENUM, F(adam), "auto", 0, 0, "auto|sparse|dense", NULL, MGS_GROUP_SCALE, REC | MPI,
   "sparse: step only the Gaussians the view saw (differs from the reference); auto: sparse when visibility is "
   "auto-on; --sparse-adam, --dense-adam", NULL},
  {"sh-moments-bf16", "sh_moments_bf16", MGS_OPT_BOOL, F(sh_moments_bf16), "0", 0, 1, NULL, "1", MGS_GROUP_SCALE,
   REC | MPI, "store the SH-rest Adam moments as bfloat16, stochastically rounded (a third less memory traffic a "
   "step, 180 bytes a Gaussian less memory; not the reference; docs/notes/iteration-bytes.md)", NULL},
  {"image-cache-mb", "image_cache_mb", MGS_OPT_INT, F(image_cache_mb), "0", 0, BIG, NULL, NULL, MGS_GROUP_SCALE,
   REC | MPI, "stream train images through an 8-bit cache of N MiB with a prefetch thread (0 = all as floats)", NULL},
  {"view-order", "view_order", MGS_OPT_ENUM, F(view_locality), "random", 0, 0, "random|locality", NULL,
   MGS_GROUP_SCALE, REC | MPI, "locality: each epoch visits spatial chunks of views in turn", NULL},

  /* ---- distributed ---- */
  {"ghost-margin", "ghost_margin", MGS_OPT_DOUBLE, F(ghost_margin), "1", 0, 1e6, NULL, NULL, MGS_GROUP_DIST,
   REC | MPI | MGS_OPT_MPI_ONLY, "ghosts within this many tiles of a block", NULL},
  {"mpi-timeout", NULL, MGS_OPT_DOUBLE, F(mpi_timeout), "-1", -1, 1e9, NULL, NULL, MGS_GROUP_DIST,
   MPI | MGS_OPT_MPI_ONLY, "seconds rank 0 waits for the other blocks after its own (-1: 600 + 2x its training)", NULL},
  {"vdb-resolution", NULL, MGS_OPT_INT, F(vdb_resolution), "0", 0, 100000, NULL, NULL, MGS_GROUP_DIST,
   MPI | MGS_OPT_MPI_ONLY, "the merged point_cloud.vdb at this resolution, built by blocks (0 = none)", NULL},
  {"exchange-every", "exchange_every", MGS_OPT_INT, F(exchange_every), "100", 0, BIG, NULL, NULL, MGS_GROUP_DIST,
   REC | MPI | MGS_OPT_MPI_ONLY, "ghosts refreshed by their owners every K steps after the hand-off", NULL},
  {"migrate-every", "migrate_every", MGS_OPT_INT, F(migrate_every), "100", 0, BIG, NULL, NULL, MGS_GROUP_DIST,
   REC | MPI | MGS_OPT_MPI_ONLY, "Gaussians that left their block move to its owner every M steps (0 = never)", NULL},
  {"ghosts", "ghosts", MGS_OPT_ENUM, F(ghosts_average), "owner", 0, 0, "owner|average", NULL, MGS_GROUP_DIST,
   REC | MPI | MGS_OPT_MPI_ONLY, "read-only copies, or copies that train and are averaged with their owner", NULL},
  {"independent", "independent", MGS_OPT_BOOL, F(independent), "0", 0, 1, NULL, "1", MGS_GROUP_DIST,
   REC | MPI | MGS_OPT_MPI_ONLY, "no hand-off: blocks independent to the end", NULL},
  {"split-by", "split_by", MGS_OPT_ENUM, F(split_pixels), "points", 0, 0, "points|pixels", NULL, MGS_GROUP_DIST,
   REC | MPI | MGS_OPT_MPI_ONLY, "blocks of equal points, or of equal points + pixels that see them", NULL},

  /* ---- MorseGS (lengths are fractions of the bounding-box diagonal) ---- */
  {"preset", "preset", MGS_OPT_ENUM, F(preset), "none", 0, 0,
   "none|baseline|morse-d|morse-r|morse-i|morse-full|topology-gs|sugar", NULL, MGS_GROUP_MORSE, REC | MPI,
   "a row of settings: morse-d (--strategy morse), morse-r (--topo-loss), morse-i (--init levelset), morse-full "
   "(all + --normal-loss 0.01), topology-gs (--init lpvi --pers-loss), sugar (--strategy sugar --iters 15000 "
   "--densify-until 7000)", NULL},
  {"literal", "literal", MGS_OPT_BOOL, F(literal), "0", 0, 1, NULL, "1", MGS_GROUP_MORSE, REC,
   "every MorseGS rule in the seed's printed form (spawn, prune, L_topo)", NOT_DIST},
  {"spawn", "morse_spawn", MGS_OPT_ENUM, F(spawn), "auto", 0, 0, "auto|gaps|literal|none", NULL, MGS_GROUP_MORSE, REC,
   "Morse spawning (auto: gaps under --strategy morse)", NOT_DIST},
  {"prune", "morse_prune", MGS_OPT_ENUM, F(prune), "auto", 0, 0, "auto|floaters|literal|none", NULL, MGS_GROUP_MORSE,
   REC, "Morse pruning (auto: floaters under --strategy morse)", NOT_DIST},
  {"topo-loss", "topo_loss", MGS_OPT_ENUM, F(topo_loss), "none", 0, 0, "none|eliminate|literal", "eliminate",
   MGS_GROUP_MORSE, REC | OPT, "persistence regularization L_topo (--topo-loss alone: eliminate)", NOT_DIST},
  {"beta", "topo_beta", MGS_OPT_DOUBLE, F(beta), "0.003", 0, 100, NULL, NULL, MGS_GROUP_MORSE, REC,
   "weight of L_topo in units of eps-sig squared", NOT_DIST},
  {"eps-p", "eps_p", MGS_OPT_DOUBLE, F(eps_p), "0.01", 1e-6, 0.5, NULL, NULL, MGS_GROUP_MORSE, REC,
   "densification threshold of the literal rules", NOT_DIST},
  {"eps-sig", "eps_sig", MGS_OPT_DOUBLE, F(eps_sig), "0.02", 1e-6, 0.5, NULL, NULL, MGS_GROUP_MORSE, REC,
   "L_topo cutoff", NOT_DIST},
  {"topo-dims", "topo_dims", MGS_OPT_DIMS, F(topo_dims), "0,1,2", 0, 0, NULL, NULL, MGS_GROUP_MORSE, REC,
   "dimensions in L_topo", NOT_DIST},
  {"min-bar", "min_bar", MGS_OPT_DOUBLE, F(min_bar), "0.5", 0, 16, NULL, NULL, MGS_GROUP_MORSE, REC,
   "bars shorter than V voxels stay out of L_topo", NOT_DIST},
  {"morse-every", "morse_every", MGS_OPT_INT, F(morse_every), "500", 1, 1e6, NULL, NULL, MGS_GROUP_MORSE, REC,
   "K: iterations between analyses", NOT_DIST},
  {"morse-warmup", "morse_warmup", MGS_OPT_INT, F(morse_warmup), "3000", 1, 1e7, NULL, NULL, MGS_GROUP_MORSE, REC,
   "W: first analysis", NOT_DIST},
  {"morse-until", "morse_until", MGS_OPT_INT, F(morse_until), "15000", 1, 1e7, NULL, NULL, MGS_GROUP_MORSE, REC,
   "last analysis (under --strategy morse at most --densify-until)", NOT_DIST},
  {"morse-resolution", "morse_resolution", MGS_OPT_INT, F(morse_resolution), "256", 16, 2048, NULL, NULL,
   MGS_GROUP_MORSE, REC, "R: voxels along the diagonal", NOT_DIST},
  {"morse-tau", "morse_tau", MGS_OPT_DOUBLE, F(morse_tau), "0.5", 1e-3, 0.999, NULL, NULL, MGS_GROUP_MORSE, REC,
   "the surface {A = tau}", NOT_DIST},
  {"morse-sdf", "morse_sdf", MGS_OPT_ENUM, F(morse_sdf), "closest", 0, 0, "mesh|sweep|closest", NULL, MGS_GROUP_MORSE,
   REC, "SDF construction of the analyses", NOT_DIST},
  {"gap-max", "gap_max", MGS_OPT_DOUBLE, F(gap_max), "0.05", 1e-6, 0.5, NULL, NULL, MGS_GROUP_MORSE, REC,
   "gaps: largest hole radius filled", NOT_DIST},
  {"min-cameras", "min_cameras", MGS_OPT_INT, F(min_cameras), "3", 0, 1e6, NULL, NULL, MGS_GROUP_MORSE, REC,
   "floaters: Gaussians fewer cameras see are pruned (0 = off)", NOT_DIST},
  {"floater-volume", "floater_volume", MGS_OPT_DOUBLE, F(floater_volume), "0.01", 0, 0.999, NULL, NULL,
   MGS_GROUP_MORSE, REC, "floaters: components below this share of the largest's volume", NOT_DIST},
  {"floater-mass", "floater_mass", MGS_OPT_DOUBLE, F(floater_mass), "0.01", 0, 0.999, NULL, NULL, MGS_GROUP_MORSE, REC,
   "... or of its opacity mass", NOT_DIST},
  {"max-spawn", "max_spawn", MGS_OPT_INT, F(max_spawn), "1000", 0, 1e8, NULL, NULL, MGS_GROUP_MORSE, REC,
   "Gaussians spawned per analysis at most", NOT_DIST},
  {"morse-incremental", "morse_incremental", MGS_OPT_BOOL, F(morse_incremental), "0", 0, 1, NULL, "1",
   MGS_GROUP_MORSE, REC, "keep the lattice, redo only the alpha leaves, SDF band and critical cells that changed",
   NOT_DIST},
  {"normal-loss", "normal_loss", MGS_OPT_DOUBLE, F(normal_loss), "0", 0, 1000, NULL, "0.02", MGS_GROUP_MORSE, REC | OPT,
   "MorseGS normal consistency loss with weight G (alone: 0.02; 0 = off), from iteration 3000 (half a shorter run)",
   NOT_DIST},

  /* ---- Topology-GS ---- */
  {"lpvi-faithful", "lpvi_faithful", MGS_OPT_BOOL, F(lpvi_faithful), "0", 0, 1, NULL, "1", MGS_GROUP_TOPOGS, REC,
   "the authors' LPVI (default: corrected, docs/notes/topogs.md)", NOT_DIST},
  {"lpvi-tau", "lpvi_tau", MGS_OPT_DOUBLE, F(lpvi_tau), "0.25", 0, 1e6, NULL, NULL, MGS_GROUP_TOPOGS, REC,
   "LPVI acceptance threshold", NOT_DIST},
  {"lpvi-max-edge", "lpvi_max_edge", MGS_OPT_DOUBLE, F(lpvi_max_edge), "2", 1e-12, 1e6, NULL, NULL, MGS_GROUP_TOPOGS,
   REC, "LPVI longest edge (corrected: scaled by extent / 4.4342)", NOT_DIST},
  {"pers-loss", "pers_loss", MGS_OPT_DOUBLE, F(pers_loss), "0", 0, 1e6, NULL, "10", MGS_GROUP_TOPOGS, REC | OPT,
   "PersLoss with weight W (alone: 10; 0 = off)", NOT_DIST},
  {"pers-loss-form", "pers_loss_form", MGS_OPT_ENUM, F(pers_loss_form), "topk", 0, 0, "topk|betti", NULL,
   MGS_GROUP_TOPOGS, REC, "top-k bar lengths (authors' code) or seed 001's Betti-weighted form", NOT_DIST},
  {"pers-loss-downsample", "pers_loss_downsample", MGS_OPT_DOUBLE, F(pers_loss_downsample), "0.09", 1e-6, 1, NULL,
   NULL, MGS_GROUP_TOPOGS, REC, "image downsampling factor", NOT_DIST},
  {"pers-loss-k", "pers_loss_k", MGS_OPT_INT3, F(pers_loss_k), "10,20,50", 0, 1e8, NULL, NULL, MGS_GROUP_TOPOGS, REC,
   "K0,K1,K2: bars per dimension", NOT_DIST},
  {"pers-loss-schedule", "pers_loss_schedule", MGS_OPT_INT3, F(pers_loss_schedule), "1500,15000,200", 0, 1e8, NULL,
   NULL, MGS_GROUP_TOPOGS, REC, "FROM,UNTIL,EVERY", NOT_DIST},

  /* ---- SuGaR's coarse stage (--strategy sugar; docs/notes/sugar.md) ---- */
  {"sugar-from", "sugar_from", MGS_OPT_INT, F(sugar_from), "7000", 0, BIG, NULL, NULL, MGS_GROUP_SUGAR, REC,
   "the 3DGS model the stage starts from: opacity entropy after this iteration", NOT_DIST},
  {"sugar-prune-at", "sugar_prune_at", MGS_OPT_INT, F(sugar_prune_at), "9000", 0, BIG, NULL, NULL, MGS_GROUP_SUGAR,
   REC, "prune alpha < --sugar-prune-alpha here; entropy until, SDF and normal losses after", NOT_DIST},
  {"sugar-prune-alpha", "sugar_prune_alpha", MGS_OPT_DOUBLE, F(sugar_prune_alpha), "0.5", 1e-6, 0.999999, NULL, NULL,
   MGS_GROUP_SUGAR, REC, "opacity below which the prune removes a Gaussian", NOT_DIST},
  {"sugar-entropy", "sugar_entropy", MGS_OPT_DOUBLE, F(sugar_entropy), "0.1", 0, 1e6, NULL, NULL, MGS_GROUP_SUGAR, REC,
   "weight of the opacity entropy", NOT_DIST},
  {"sugar-sdf", "sugar_sdf", MGS_OPT_DOUBLE, F(sugar_sdf), "0.2", 0, 1e6, NULL, NULL, MGS_GROUP_SUGAR, REC,
   "weight of the SDF loss (the authors' estimation_factor)", NOT_DIST},
  {"sugar-normal", "sugar_normal", MGS_OPT_DOUBLE, F(sugar_normal), "0.2", 0, 1e6, NULL, NULL, MGS_GROUP_SUGAR, REC,
   "weight of the normal loss (normal_factor)", NOT_DIST},
  {"sugar-samples", "sugar_samples", MGS_OPT_INT, F(sugar_samples), "20000", 1, 1e8, NULL, NULL, MGS_GROUP_SUGAR, REC,
   "SDF samples per iteration (the authors 1000000; fewer on the CPU)", NOT_DIST},
  {"sugar-knn-every", "sugar_knn_every", MGS_OPT_INT, F(sugar_knn_every), "500", 1, BIG, NULL, NULL,
   MGS_GROUP_SUGAR, REC, "16 nearest neighbours refreshed every N iterations", NOT_DIST},
  /* ---- GaussianPro (--strategy gaussianpro; the authors' demo values) ---- */
  {"gpro-schedule", "gpro_schedule", MGS_OPT_INT3, F(gpro_schedule), "1000,6000,50", 1, 1e8, NULL, NULL,
   MGS_GROUP_BASELINE, REC, "GaussianPro: FROM,UNTIL,EVERY of the propagation steps (one view each)", NOT_DIST},
  {"gpro-patch", "gpro_patch", MGS_OPT_INT, F(gpro_patch), "20", 3, 62, NULL, NULL, MGS_GROUP_BASELINE, REC,
   "GaussianPro: patch-match window side in px", NOT_DIST},
  {"gpro-pm-iters", "gpro_pm_iters", MGS_OPT_INT, F(gpro_pm_iters), "6", 0, 100, NULL, NULL, MGS_GROUP_BASELINE, REC,
   "GaussianPro: checkerboard propagation sweeps", NOT_DIST},
  {"gpro-neighbors", "gpro_neighbors", MGS_OPT_INT, F(gpro_neighbors), "4", 2, 32, NULL, NULL, MGS_GROUP_BASELINE,
   REC, "GaussianPro: views a view is matched against (chosen by overlap)", NOT_DIST},
  {"gpro-error-max", "gpro_error_max", MGS_OPT_DOUBLE, F(gpro_error_max), "1.0", 0, 1e6, NULL, NULL,
   MGS_GROUP_BASELINE, REC, "GaussianPro: relative depth error for new Gaussians at FROM ...", NOT_DIST},
  {"gpro-error-min", "gpro_error_min", MGS_OPT_DOUBLE, F(gpro_error_min), "0.8", 0, 1e6, NULL, NULL,
   MGS_GROUP_BASELINE, REC, "... falling linearly to this at UNTIL", NOT_DIST},
  {"gpro-planar", "gpro_planar", MGS_OPT_DOUBLE, F(gpro_planar), "0.001", 0, 1e6, NULL, NULL, MGS_GROUP_BASELINE, REC,
   "GaussianPro: weight of the planar loss on depth after FROM (0 = off; docs/notes/gaussianpro.md)", NOT_DIST},
  {"gpro-planar-normal", "gpro_planar_normal", MGS_OPT_DOUBLE, F(gpro_planar_normal), "0.001", 0, 1e6, NULL, NULL,
   MGS_GROUP_BASELINE, REC, "GaussianPro: weight of the planar loss 1 - cos(rendered, propagated normal) (0 = off)", NOT_DIST},
  {"gpro-planar-l1", "gpro_planar_l1", MGS_OPT_DOUBLE, F(gpro_planar_l1), "0.001", 0, 1e6, NULL, NULL,
   MGS_GROUP_BASELINE, REC, "GaussianPro: weight of the planar loss' L1 of the camera-frame normals (0 = off)", NOT_DIST},
};

const mgs_option *mgs_config_options(size_t *count) {
  *count = sizeof TABLE / sizeof TABLE[0];
  return TABLE;
}

const mgs_option *mgs_config_find(const char *name) {
  for (size_t i = 0; i < sizeof TABLE / sizeof TABLE[0]; i++)
    if (!strcmp(TABLE[i].name, name)) return &TABLE[i];
  return NULL;
}

/* One configuration for every way to train (train/config*.c): it owns
 *   the option table ................ every training setting once: flag, cfg_args key, type,
 *                                     default, range, group, flags, help (train/config_table.h)
 *   parsing ......................... argv of `morsegs train` (serial, --mpi, the demo's and
 *                                     the experiment's --train-arg), with one-line errors
 *   presets ......................... rows of values over the table (morse-*, topology-gs)
 *   the record ...................... cfg_args (every result-changing setting) and resume
 *                                     (restores each recorded setting; a typed flag that
 *                                     contradicts the record is refused, naming both values)
 *   --help .......................... grouped by section, from the table
 *   the options of each layer ....... mgs_train_options, mgs_morse_options, LPVI, PersLoss,
 *                                     normal loss, dataset options, built from a config
 *
 * A config is a plain value (copyable); nothing here is global. FFmpeg's AVOption and the
 * reference 3DGS's ParamGroup are the models: defaults are written as a user would type
 * them and go through the same parser as the command line. */
#ifndef MGS_CONFIG_H
#define MGS_CONFIG_H
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include "core/mgs_error.h"
#include "core/mgs_dataset.h"
#include "train/mgs_train.h"
#include "train/mgs_morse.h"
#include "train/mgs_lpvi.h"
#include "train/mgs_persloss.h"
#include "train/mgs_term_normal.h"
#include "train/mgs_term_2dgs.h"
#include "train/mgs_minisplat.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Enumerations the table names (values in the order of the names in config_table.h). */
typedef enum { MGS_BG_AUTO, MGS_BG_WHITE, MGS_BG_BLACK } mgs_cfg_background;
typedef enum { MGS_STRAT_ADC, MGS_STRAT_MORSE, MGS_STRAT_NONE, MGS_STRAT_MINISPLAT, MGS_STRAT_MINISPLAT_D, MGS_STRAT_SUGAR,
               MGS_STRAT_GAUSSIANPRO } mgs_cfg_strategy;
typedef enum { MGS_INIT_SFM, MGS_INIT_RANDOM, MGS_INIT_LEVELSET, MGS_INIT_LPVI } mgs_cfg_init;
typedef enum { MGS_AUTO_OFF_ON_AUTO, MGS_AUTO_OFF_ON_ON, MGS_AUTO_OFF_ON_OFF } mgs_cfg_tristate; /* auto|on|off */
typedef enum { MGS_ADAM_AUTO, MGS_ADAM_SPARSE, MGS_ADAM_DENSE } mgs_cfg_adam;
typedef enum { MGS_PRESET_NONE, MGS_PRESET_BASELINE, MGS_PRESET_MORSE_D, MGS_PRESET_MORSE_R, MGS_PRESET_MORSE_I,
               MGS_PRESET_MORSE_FULL, MGS_PRESET_TOPOLOGY_GS, MGS_PRESET_SUGAR } mgs_cfg_preset;
/* spawn/prune: auto = the MorseGS rule under --strategy morse (its literal form with
 * --literal), none otherwise */
typedef enum { MGS_SPAWN_AUTO, MGS_SPAWN_GAPS, MGS_SPAWN_LITERAL, MGS_SPAWN_NONE } mgs_cfg_spawn;
typedef enum { MGS_PRUNE_AUTO, MGS_PRUNE_FLOATERS, MGS_PRUNE_LITERAL, MGS_PRUNE_NONE } mgs_cfg_prune;
typedef enum { MGS_TOPO_NONE, MGS_TOPO_ELIMINATE, MGS_TOPO_LITERAL } mgs_cfg_topo;

#define MGS_CFG_PATH 4096

/* Every training setting (fields named as their flags). */
typedef struct mgs_train_config {
  /* run control: how, where, how often (not part of the result) */
  char output[MGS_CFG_PATH];
  int resume, force, threads, quiet, checkpoint_every, mpi, help;
  char save_at[256];
  /* 3DGS baseline */
  int iters, downscale, max_width, sh_degree, sh_every, background, test_every;
  char images[256];
  uint64_t seed;
  int strategy, init, random_points;
  int densify_from, densify_until, densify_every, opacity_reset_every;
  double grad_threshold, percent_dense, min_opacity, max_screen_size, lambda_dssim;
  double position_lr_init, position_lr_final;
  int position_lr_max_steps;
  double feature_lr, feature_rest_lr, opacity_lr, scaling_lr, rotation_lr;
  int freeze;
  double schedule_scale, simplify_fraction; /* every milestone x s; Mini-Splatting */
  int ms_depth_points;
  double ms_blur_min_px;
  /* large scenes */
  int visibility;
  double vis_tile;
  int adam, image_cache_mb, view_locality;
  int sh_moments_bf16;
  /* distributed (--mpi) */
  double ghost_margin, mpi_timeout;
  int vdb_resolution, exchange_every, migrate_every, ghosts_average, independent, split_pixels;
  /* MorseGS */
  int preset, literal, spawn, prune, topo_loss;
  double beta, eps_p, eps_sig;
  int topo_dims;
  double min_bar;
  int morse_every, morse_warmup, morse_until, morse_resolution;
  double morse_tau;
  int morse_sdf;
  double gap_max;
  int min_cameras;
  double floater_volume, floater_mass;
  int max_spawn, morse_incremental;
  double normal_loss;
  /* 2DGS */
  int model;
  double lambda_dist, lambda_normal;
  /* Topology-GS */
  int lpvi_faithful;
  double lpvi_tau, lpvi_max_edge, pers_loss;
  int pers_loss_form;
  double pers_loss_downsample;
  int pers_loss_k[3], pers_loss_schedule[3];
  /* SuGaR (--strategy sugar) */
  int sugar_from, sugar_prune_at, sugar_samples, sugar_knn_every;
  double sugar_prune_alpha, sugar_entropy, sugar_sdf, sugar_normal;
  /* GaussianPro (--strategy gaussianpro) */
  int gpro_schedule[3], gpro_patch, gpro_pm_iters, gpro_neighbors;
  double gpro_error_max, gpro_error_min, gpro_planar;
  double gpro_planar_normal;
  double gpro_planar_l1;
  /* where each option's value came from (mgs_cfg_source, by option index) */
  unsigned char source[128];
} mgs_train_config;

typedef enum { MGS_CFG_DEFAULT, MGS_CFG_PRESET, MGS_CFG_RECORD, MGS_CFG_TYPED } mgs_cfg_source;

/* Option groups: the sections of --help. */
typedef enum { MGS_GROUP_RUN, MGS_GROUP_BASELINE, MGS_GROUP_SCALE, MGS_GROUP_DIST, MGS_GROUP_MORSE, MGS_GROUP_TOPOGS,
               MGS_GROUP_SUGAR, MGS_GROUP_COUNT } mgs_opt_group;

typedef enum { MGS_OPT_INT, MGS_OPT_U64, MGS_OPT_DOUBLE, MGS_OPT_BOOL, MGS_OPT_ENUM, MGS_OPT_STRING, MGS_OPT_INT3,
               MGS_OPT_DIMS } mgs_opt_type;

enum {
  MGS_OPT_RECORDED = 1u,   /* changes the result: written to cfg_args, restored by --resume */
  MGS_OPT_CHANGEABLE = 2u, /* recorded, and --resume may change it (--iters extends a run) */
  MGS_OPT_OPTIONAL = 4u,   /* the value may be left out (--normal-loss, --topo-loss, --pers-loss) */
  MGS_OPT_MPI = 8u,        /* honoured by --mpi on more than one process */
  MGS_OPT_MPI_ONLY = 16u   /* read only by --mpi */
};

typedef struct mgs_option {
  const char *name;          /* the flag without "--" */
  const char *key;           /* cfg_args key (NULL: not recorded) */
  mgs_opt_type type;
  size_t offset, size;       /* the field in mgs_train_config */
  const char *def;           /* default, as typed */
  double min, max;           /* range (numbers) */
  const char *names;         /* ENUM: "a|b|c" in the enum's order */
  const char *implicit;      /* OPTIONAL and BOOL: the value when none is given */
  mgs_opt_group group;
  unsigned flags;
  const char *help;
  const char *mpi_reason;    /* not MGS_OPT_MPI: why --mpi on several processes refuses it */
} mgs_option;

/* The table (train/config_table.h), in --help order. */
const mgs_option *mgs_config_options(size_t *count);
/* The option named `name` (flag without "--"), or NULL. */
const mgs_option *mgs_config_find(const char *name);

/* Every option at its default. */
void mgs_config_defaults(mgs_train_config *c);
/* Sets one option from text as typed (range checked). MGS_ERR_ARG names the flag. */
mgs_status mgs_config_set(mgs_train_config *c, const char *name, const char *value, mgs_cfg_source src,
                          mgs_error *err);
/* The option's value as text (what cfg_args holds). */
void mgs_config_format(const mgs_train_config *c, const mgs_option *o, char *buf, size_t cap);

/* `morsegs train DATA -o RUN [options]` (argv[0] is the command): defaults, then the
 * preset's row, then what was typed. *data gets the positional DATA (NULL if none).
 * With --resume (and -o RUN holding a cfg_args), the record is restored before the typed
 * values are checked against it. */
mgs_status mgs_config_parse(mgs_train_config *c, int argc, char **argv, const char **data, mgs_error *err);
/* Restores every recorded setting from a run's record (a parsed cfg_args); a typed value
 * that differs from the record is refused unless the option is CHANGEABLE. */
mgs_status mgs_config_restore(mgs_train_config *c, const mgs_settings *record, const char *record_path,
                              mgs_error *err);
/* Cross-option checks before anything is written (ranges are checked by mgs_config_set):
 * MorseGS settings nobody reads, the analysis' memory budget, --resume with --force.
 * `ranks` > 1: every option set away from its default must be honoured by --mpi. */
mgs_status mgs_config_validate(const mgs_train_config *c, int ranks, mgs_error *err);
/* Every recorded option into s (cfg_args). */
void mgs_config_record(const mgs_train_config *c, mgs_settings *s);
/* --help, grouped by section. */
void mgs_config_usage(FILE *f);

/* The options of each layer, from a config. */
void mgs_config_train_options(const mgs_train_config *c, mgs_train_options *o);
void mgs_config_dataset_options(const mgs_train_config *c, mgs_dataset_options *o);
/* MorseGS: spawn/prune/topo resolved (auto, --literal); returns 1 if anything reads them
 * (--strategy morse or L_topo). */
int mgs_config_morse_options(const mgs_train_config *c, mgs_morse_options *o);
void mgs_config_lpvi_options(const mgs_train_config *c, mgs_lpvi_options *o);
/* PersLoss; returns 1 if it is on. */
int mgs_config_persloss_options(const mgs_train_config *c, mgs_persloss_options *o);
/* The 2DGS losses (train/mgs_term_2dgs.h) of a --model 2dgs run on dataset format
 * `format` (lambda-dist auto resolved); returns 1 for a 2DGS run. */
int mgs_config_2dgs_options(const mgs_train_config *c, int format, mgs_2dgs_term_options *o);
/* The normal loss; returns 1 if it is on (its start moved to half a run shorter than twice it). */
int mgs_config_normal_options(const mgs_train_config *c, mgs_normal_options *o);
/* GaussianPro's propagation; returns 1 if it is on (--strategy gaussianpro). */
struct mgs_gpro_options;
int mgs_config_gpro_options(const mgs_train_config *c, struct mgs_gpro_options *o);
/* Mini-Splatting (-D); returns 1 if --strategy is one of them. */
int mgs_config_minisplat_options(const mgs_train_config *c, mgs_minisplat_options *o);
/* --schedule-scale applied: a copy of c with every iteration milestone times the scale
 * (rounded, periods at least 1, 0 = off kept); every layer's options above are built
 * from it, so no strategy or term scales anything itself. */
void mgs_config_scheduled(const mgs_train_config *c, mgs_train_config *out);
/* A reference milestone (Mini-Splatting's 5000, the normal loss' 3000) under the scale. */
int mgs_config_scale_iteration(const mgs_train_config *c, int iteration);
/* SuGaR's coarse stage; returns 1 if it is on (--strategy sugar). */
struct mgs_sugar_options;
int mgs_config_sugar_options(const mgs_train_config *c, struct mgs_sugar_options *o);
/* Names of enum values (for messages and records). */
const char *mgs_config_enum_name(const mgs_train_config *c, const char *option);

/* ---- a trainer made from a config (train/setup.c) ---- */
struct mgs_morse_ctx;
typedef struct mgs_train_setup {
  mgs_trainer *trainer;
  struct mgs_morse_ctx *morse; /* the analysis shared by the strategy and L_topo (NULL: none) */
  char init_used[16];          /* sfm, random (sfm without points), levelset, lpvi */
} mgs_train_setup;
/* The initial model (`c->init`; a one-Gaussian placeholder when `for_resume`, replaced by
 * the checkpoint), the strategy, the Morse analysis (its rows to RUN/morse_analysis.csv
 * when run_dir is given) and every loss term the config asks for, on dataset ds (borrowed)
 * with trainer options o. On failure nothing is left to destroy. */
mgs_status mgs_train_setup_create(const mgs_train_config *c, mgs_dataset *ds, const mgs_train_options *o,
                                  const char *run_dir, int for_resume, mgs_train_setup *out, mgs_error *err);
void mgs_train_setup_destroy(mgs_train_setup *s);

#ifdef __cplusplus
}
#endif
#endif

/* morsegs train DATA -o RUN: the 3DGS baseline trainer (reference defaults), writing the
 * reference run layout. Never writes into the dataset folder; refuses a non-empty RUN
 * unless --force or --resume; Ctrl-C writes a checkpoint and the current .ply. */
#include <getopt.h>
#include <limits.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <dirent.h>
#include <cjson/cJSON.h>
#include "apps/mgs_cli.h"
#include "apps/mgs_train_topogs.h"
#include "core/mgs_core.h"
#include "train/mgs_train.h"
#include "train/mgs_strategy.h"
#include "train/mgs_init_levelset.h"
#include "train/mgs_term_normal.h"

/* ---- MorseGS normal loss and level-set init (issue 14; train/mgs_term_normal.h,
 * train/mgs_init_levelset.h): parsed here, used in mgs_cmd_train_run. ---- */
static double g_normal_loss = 0; /* γ of --normal-loss (0: off) */
static int morse_grad_parse_normal(const char *arg) {
  g_normal_loss = 0.02; /* the default γ (seed range 0.01-0.05) */
  if (arg) {
    char *end;
    double v = strtod(arg, &end);
    if (!*arg || *end || !(v > 0) || v > 1000) {
      fprintf(stderr, "morsegs train: --normal-loss needs a weight in (0, 1000] (got '%s')\n", arg);
      return 0;
    }
    g_normal_loss = v;
  }
  return 1;
}
/* ---- end of the normal-loss / level-set block ---- */
#include "apps/train_morse_flags.h" /* MorseGS flags (kept apart) */

/* The normal loss reads the Morse analysis' SDF when one runs (none before the first). */
static const mgs_vdb_grid *morse_sdf_source(void *user, int *iteration) {
  const mgs_morse_ctx *c = user;
  const mgs_morse_result *r = mgs_morse_ctx_result(c);
  *iteration = r ? r->iteration : -1;
  return r && r->iteration > 0 ? mgs_morse_ctx_sdf(c) : NULL;
}

static volatile sig_atomic_t g_stop = 0;
/* Topology-GS flags (apps/train_topogs_flags.c): parsed before the option table */
static mgs_topogs_flags g_topogs;
static void on_sigint(int sig) { (void)sig; g_stop = 1; }

static void usage(FILE *f) {
  fprintf(f,
    "usage: morsegs train DATA -o RUN [options]\n"
    "  DATA: NeRF-synthetic (transforms_train.json), nerfstudio (transforms.json) or COLMAP folder\n"
    "  -o, --output RUN        run folder (point_cloud/iteration_N/point_cloud.ply, cameras.json, cfg_args)\n"
    "      --iters N           iterations (30000)\n"
    "      --downscale N       train on images resized to round(w/N) x round(h/N), bicubic (the\n"
    "                          reference's -r N); without it, images wider than --max-width are\n"
    "                          resized to that width (the reference's 1600 px cap)\n"
    "      --max-width W       the cap (1600; 0 = train at full size)\n"
    "      --sh-degree N       max SH degree 0..3 (3), raised every 1000 iterations\n"
    "      --white | --black   background (white for NeRF-synthetic, black for COLMAP and nerfstudio,\n"
    "                          as the reference's defaults and its -w for the synthetic scenes)\n"
    "      --test-every N      COLMAP/nerfstudio: every Nth view is a test view (8)\n"
    "      --seed S            random seed (0)\n"
    "      --strategy adc      density control: adc (reference), morse (below) or none\n"
    "      --init sfm|random|levelset|lpvi  initial Gaussians: dataset points (falls back to random),\n"
    "                          random, MorseGS level sets of the dataset points' distance field (flat,\n"
    "                          tangent), or LPVI over the dataset points (Topology-GS, below)\n"
    "      --normal-loss[=G]   MorseGS normal consistency loss, weight G (0.02), from iteration 3000\n"
    "                          (half the run if shorter than 6000), SDF rebuilt from the model every\n"
    "                          500 iterations (resolution 128 of the diagonal, tau 0.5)\n"
    "      --random-points N   Gaussians of the random init (100000)\n"
    "      --densify-from N    (500)   --densify-until N (15000)   --densify-every N (100)\n"
    "      --position-lr-max-steps N  length of the position learning-rate decay (30000, the\n"
    "                          reference's, whatever --iters is; 0 = --iters)\n"
    "      --opacity-reset-every N (3000)   --grad-threshold G (2e-4)\n"
    "      --checkpoint-every N   periodic checkpoint RUN/checkpoint.mgsckpt (1000; 0 = off)\n"
    "      --save-at LIST      extra .ply saves at these iterations (7000)\n"
    "      --resume            continue RUN from its checkpoint\n"
    "      --force             reuse a non-empty RUN (its previous outputs are removed)\n"
    "      --threads N         worker threads (all cores)\n"
    "      --freeze            diagnostic: never update the parameters (test calibration)\n"
    "  large scenes (docs/notes-scale.md):\n"
    "      --visibility auto|on|off  project only the spatial tiles a view can see (same images;\n"
    "                          auto: on when views see under half of the initial Gaussians)\n"
    "      --vis-tile S        tile side in world units (auto: ~256 Gaussians a tile)\n"
    "      --sparse-adam | --dense-adam  step only the Gaussians the view saw (differs from the\n"
    "                          reference, which steps all; default: sparse when visibility is auto-on)\n"
    "      --image-cache-mb N  stream train images through an 8-bit cache of N MiB with a prefetch\n"
    "                          thread (0 = all images in memory as floats, the default)\n"
    "      --view-order random|locality  locality: each epoch visits spatial chunks of views in turn\n"
    "                          (random chunk order, random within a chunk; default random as the reference)\n"
    "      --mpi               under mpirun -np K: K spatial blocks trained and merged (-np 1 = serial)\n"
    "                          (with --mpi: --ghost-margin TILES (1), --mpi-timeout S: how long rank 0 waits\n"
    "                          for the other blocks after its own (600 + 2x its training time);\n"
    "                          --checkpoint-every, --resume and --force per rank: RUN/ranks/rank_K.mgsckpt;\n"
    "                          --vdb-resolution R: the merged point_cloud.vdb, built by blocks;\n"
    "                          --densify-until N: hand-off there, then read-only ghosts refreshed every\n"
    "                          --exchange-every K steps (100); --migrate-every M (100): Gaussians that left\n"
    "                          their block move to its owner with their Adam state; --ghosts owner|average:\n"
    "                          read-only copies (default), or copies that train and are averaged with their\n"
    "                          owner at each exchange; --independent: no hand-off;\n"
    "                          --split-by points|pixels: blocks of equal points (default) or of equal\n"
    "                          points + pixels that see them)\n"
    "      --quiet             no progress bar\n"
    "%s",
    train_morse_flags_usage);
  mgs_topogs_usage(f);
}

enum {
  O_ITERS = 1000, O_DOWNSCALE, O_SH, O_WHITE, O_BLACK, O_TEST_EVERY, O_SEED, O_STRATEGY, O_INIT,
  O_RANDOM_POINTS, O_DFROM, O_DUNTIL, O_DEVERY, O_RESET, O_GTHR, O_CKPT, O_SAVE_AT, O_RESUME, O_FORCE,
  O_THREADS, O_FREEZE, O_QUIET, O_TOPO, O_PERS, O_NORMAL, O_MAXW, O_LRSTEPS,
  O_VIS, O_VIS_TILE, O_SPARSE, O_DENSE, O_CACHE, O_VIEW_ORDER, O_HELP
};

static int parse_int(const char *s, const char *name, int lo, int *out) {
  char *end;
  long v = strtol(s, &end, 10);
  if (*s == 0 || *end || v < lo || v > INT_MAX) {
    fprintf(stderr, "morsegs train: %s needs an integer >= %d (got '%s')\n", name, lo, s);
    return 0;
  }
  *out = (int)v;
  return 1;
}

/* Non-empty directory? */
static int dir_has_entries(const char *dir) {
  DIR *d = opendir(dir);
  if (!d) return 0;
  struct dirent *e;
  int any = 0;
  while ((e = readdir(d)))
    if (strcmp(e->d_name, ".") && strcmp(e->d_name, "..")) { any = 1; break; }
  closedir(d);
  return any;
}

/* Is `inner` (existing or about to be created) inside `outer`? Compares real paths of
 * the deepest existing ancestor. */
static int path_inside(const char *inner, const char *outer) {
  char ro[PATH_MAX], ri[PATH_MAX];
  if (!realpath(outer, ro)) return 0;
  char *probe = mgs_strdup(inner);
  if (!probe) return 0;
  int inside = 0;
  for (;;) {
    if (realpath(probe, ri)) {
      size_t lo = strlen(ro);
      inside = !strncmp(ri, ro, lo) && (ri[lo] == 0 || ri[lo] == '/');
      break;
    }
    char *slash = strrchr(probe, '/');
    if (!slash) { inside = realpath(".", ri) && !strncmp(ri, ro, strlen(ro)) && (ri[strlen(ro)] == 0 || ri[strlen(ro)] == '/'); break; }
    if (slash == probe) { slash[1] = 0; continue; }
    *slash = 0;
  }
  free(probe);
  return inside;
}

static mgs_morse_ctx *g_morse; /* the run's Morse context, for the stats (NULL: none) */

static mgs_status write_stats(const char *run, const mgs_trainer *t, mgs_error *err) {
  cJSON *o = cJSON_CreateObject();
  if (g_morse) { /* MorseGS: analysis cost against the training wall time */
    cJSON_AddNumberToObject(o, "morse_analyses", (double)mgs_morse_ctx_analyses(g_morse));
    cJSON_AddNumberToObject(o, "morse_analysis_seconds", mgs_morse_ctx_seconds(g_morse));
    double ph[MGS_TRAIN_PHASES];
    mgs_trainer_phase_seconds(t, ph);
    cJSON_AddNumberToObject(o, "loss_term_seconds", ph[5]); /* every model term (L_topo, normal, PersLoss), including the Morse analyses L_topo triggers */
  }
  cJSON_AddNumberToObject(o, "iterations", mgs_trainer_iteration(t));
  cJSON_AddNumberToObject(o, "train_seconds", mgs_trainer_seconds(t));
  cJSON_AddNumberToObject(o, "gaussians", (double)mgs_trainer_model(t)->n);
  cJSON_AddNumberToObject(o, "final_loss", mgs_trainer_last_loss(t));
  cJSON_AddNumberToObject(o, "peak_rss_mb", (double)mgs_peak_rss() / (1024.0 * 1024.0));
  char *text = cJSON_Print(o);
  cJSON_Delete(o);
  char *path = mgs_path_join(run, "train_stats.json");
  mgs_status st = text && path ? mgs_write_file_atomic(path, text, strlen(text), err)
                               : mgs_error_set(err, MGS_ERR_NOMEM, "out of memory");
  free(text); free(path);
  return st;
}

/* Removes what an earlier run wrote (with --force), never anything else. */
static mgs_status clear_run(const char *run, mgs_error *err) {
  static const char *dirs[] = {"point_cloud", "eval", "renders"};
  static const char *files[] = {"checkpoint.mgsckpt", "cameras.json", "cfg_args", "results.json", "train_stats.json",
                                "morse_analysis.csv"};
  for (size_t i = 0; i < sizeof dirs / sizeof *dirs; i++) {
    char *p = mgs_path_join(run, dirs[i]);
    mgs_status st = p && mgs_is_dir(p) ? mgs_remove_tree(p, err) : MGS_OK;
    free(p);
    if (st) return st;
  }
  for (size_t i = 0; i < sizeof files / sizeof *files; i++) {
    char *p = mgs_path_join(run, files[i]);
    if (p) remove(p);
    free(p);
  }
  return MGS_OK;
}

static int mgs_cmd_train_run(const char *data, const char *run, mgs_train_options *op, const char *strategy,
                             const char *init, const char *save_at, int downscale, int max_width, int white,
                             int test_every, int resume, int force, int threads, int quiet, int random_points,
                             unsigned long long seed, train_morse_flags *mf);

static int mgs_cmd_train_parse(int argc, char **argv, train_morse_flags *mf);
int mgs_cmd_train(int argc, char **argv) {
  /* Topology-GS flags first (they take `--preset topology-gs` and pass the other presets
     on), then the MorseGS ones; both leave argv before getopt */
  mgs_topogs_flags_init(&g_topogs);
  if (mgs_topogs_flags_extract(&argc, argv, &g_topogs)) return 2;
  train_morse_flags mf; /* apps/train_morse_flags.c */
  if (!train_morse_flags_take(&argc, &argv, &mf)) { train_morse_flags_free(&mf); return 2; }
  int rc = mgs_cmd_train_parse(argc, argv, &mf);
  train_morse_flags_free(&mf);
  return rc;
}

static int mgs_cmd_train_parse(int argc, char **argv, train_morse_flags *mf) {
  static const struct option opts[] = {
    {"output", required_argument, 0, 'o'}, {"iters", required_argument, 0, O_ITERS},
    {"downscale", required_argument, 0, O_DOWNSCALE}, {"sh-degree", required_argument, 0, O_SH},
    {"white", no_argument, 0, O_WHITE}, {"black", no_argument, 0, O_BLACK},
    {"test-every", required_argument, 0, O_TEST_EVERY}, {"seed", required_argument, 0, O_SEED},
    {"strategy", required_argument, 0, O_STRATEGY}, {"init", required_argument, 0, O_INIT},
    {"random-points", required_argument, 0, O_RANDOM_POINTS},
    {"densify-from", required_argument, 0, O_DFROM}, {"densify-until", required_argument, 0, O_DUNTIL},
    {"densify-every", required_argument, 0, O_DEVERY}, {"opacity-reset-every", required_argument, 0, O_RESET},
    {"grad-threshold", required_argument, 0, O_GTHR}, {"checkpoint-every", required_argument, 0, O_CKPT},
    {"save-at", required_argument, 0, O_SAVE_AT}, {"resume", no_argument, 0, O_RESUME},
    {"force", no_argument, 0, O_FORCE}, {"threads", required_argument, 0, O_THREADS},
    {"freeze", no_argument, 0, O_FREEZE}, {"quiet", no_argument, 0, O_QUIET},
    {"topo-loss", optional_argument, 0, O_TOPO}, {"pers-loss", optional_argument, 0, O_PERS},
    {"normal-loss", optional_argument, 0, O_NORMAL}, {"max-width", required_argument, 0, O_MAXW},
    {"position-lr-max-steps", required_argument, 0, O_LRSTEPS}, {"help", no_argument, 0, O_HELP},
    {"visibility", required_argument, 0, O_VIS}, {"vis-tile", required_argument, 0, O_VIS_TILE},
    {"sparse-adam", no_argument, 0, O_SPARSE}, {"dense-adam", no_argument, 0, O_DENSE},
    {"image-cache-mb", required_argument, 0, O_CACHE}, {"view-order", required_argument, 0, O_VIEW_ORDER}, {0, 0, 0, 0}};
  mgs_train_options o;
  mgs_train_options_default(&o);
  o.visibility = -1; /* auto */
  o.sparse_adam = -1;
  o.checkpoint_every = 1000;
  const char *run = NULL, *strategy = "adc", *init = "sfm", *save_at = "7000";
  int downscale = 1, max_width = 1600, white = -1, test_every = 8, resume = 0, force = 0, threads = 0, quiet = 0, random_points = 100000;
  unsigned long long seed = 0;
  int c;
  unsigned char given[O_HELP + 1] = {0}; /* flags typed on this command line */
  optind = 1;
  while ((c = getopt_long(argc, argv, "o:h", opts, NULL)) != -1) {
    if (c >= O_ITERS && c <= O_HELP) given[c] = 1;
    switch (c) {
      case 'o': run = optarg; break;
      case O_ITERS: if (!parse_int(optarg, "--iters", 1, &o.iterations)) return 2; break;
      case O_DOWNSCALE: if (!parse_int(optarg, "--downscale", 1, &downscale)) return 2; break;
      case O_SH: if (!parse_int(optarg, "--sh-degree", 0, &o.sh_degree) || o.sh_degree > 3) { fprintf(stderr, "morsegs train: --sh-degree must be 0..3\n"); return 2; } break;
      case O_MAXW: if (!parse_int(optarg, "--max-width", 0, &max_width)) return 2; break;
      case O_LRSTEPS: if (!parse_int(optarg, "--position-lr-max-steps", 0, &o.lr_mean_max_steps)) return 2; break;
      case O_WHITE: white = 1; break;
      case O_BLACK: white = 0; break;
      case O_TEST_EVERY: if (!parse_int(optarg, "--test-every", 1, &test_every)) return 2; break;
      case O_SEED: {
        char *end;
        seed = strtoull(optarg, &end, 10);
        if (!*optarg || *end) { fprintf(stderr, "morsegs train: --seed needs a non-negative integer (got '%s')\n", optarg); return 2; }
        break;
      }
      case O_STRATEGY: strategy = optarg; break;
      case O_INIT: init = optarg; break;
      case O_RANDOM_POINTS: if (!parse_int(optarg, "--random-points", 1, &random_points)) return 2; break;
      case O_DFROM: if (!parse_int(optarg, "--densify-from", 0, &o.adc.densify_from)) return 2; break;
      case O_DUNTIL: if (!parse_int(optarg, "--densify-until", 0, &o.adc.densify_until)) return 2; break;
      case O_DEVERY: if (!parse_int(optarg, "--densify-every", 1, &o.adc.densify_every)) return 2; break;
      case O_RESET: if (!parse_int(optarg, "--opacity-reset-every", 0, &o.adc.opacity_reset_every)) return 2; break;
      case O_GTHR: {
        char *end;
        double v = strtod(optarg, &end);
        if (!*optarg || *end || !(v > 0)) { fprintf(stderr, "morsegs train: --grad-threshold needs a positive number (got '%s')\n", optarg); return 2; }
        o.adc.grad_threshold = (float)v;
        break;
      }
      case O_CKPT: if (!parse_int(optarg, "--checkpoint-every", 0, &o.checkpoint_every)) return 2; break;
      case O_SAVE_AT: save_at = optarg; break;
      case O_RESUME: resume = 1; break;
      case O_FORCE: force = 1; break;
      case O_THREADS: if (!parse_int(optarg, "--threads", 1, &threads)) return 2; break;
      case O_FREEZE: o.freeze = 1; break;
      case O_QUIET: quiet = 1; break;
      case O_TOPO: fprintf(stderr, "morsegs train: --topo-loss is not available yet (MorseGS persistence loss comes in a later issue)\n"); return 2;
      case O_PERS: fprintf(stderr, "morsegs train: --pers-loss is not available yet (Topology-GS PersLoss comes in a later issue)\n"); return 2;
      case O_NORMAL: { /* "--normal-loss=G", "--normal-loss G" or a bare "--normal-loss" */
        const char *a = optarg;
        char *e = NULL;
        if (!a && optind < argc && argv[optind][0] && (strtod(argv[optind], &e), e && !*e)) a = argv[optind++];
        if (!morse_grad_parse_normal(a)) return 2;
        break;
      }
      case O_VIS:
        if (!strcmp(optarg, "auto")) o.visibility = -1;
        else if (!strcmp(optarg, "on")) o.visibility = 1;
        else if (!strcmp(optarg, "off")) o.visibility = 0;
        else { fprintf(stderr, "morsegs train: --visibility must be auto, on or off (got '%s')\n", optarg); return 2; }
        break;
      case O_VIS_TILE: {
        char *end;
        o.vis_tile = strtod(optarg, &end);
        if (!*optarg || *end || !(o.vis_tile > 0) || !isfinite(o.vis_tile)) { fprintf(stderr, "morsegs train: --vis-tile needs a positive number (got '%s')\n", optarg); return 2; }
        break;
      }
      case O_VIEW_ORDER:
        if (!strcmp(optarg, "random")) o.view_locality = 0;
        else if (!strcmp(optarg, "locality")) o.view_locality = 1;
        else { fprintf(stderr, "morsegs train: --view-order must be random or locality (got '%s')\n", optarg); return 2; }
        break;
      case O_SPARSE: o.sparse_adam = 1; break;
      case O_DENSE: o.sparse_adam = 0; break;
      case O_CACHE: {
        int mb;
        if (!parse_int(optarg, "--image-cache-mb", 0, &mb)) return 2;
        o.image_cache_mb = (size_t)mb;
        break;
      }
      case 'h': case O_HELP: usage(stdout); return 0;
      default: usage(stderr); return 2;
    }
  }
  if (optind != argc - 1 || !run) {
    fprintf(stderr, "morsegs train: %s\n", !run ? "-o RUN is required" : "exactly one DATA folder is expected");
    usage(stderr);
    return 2;
  }
  const char *data = argv[optind];
  /* --resume: settings not typed again come from the run's record */
  mgs_settings prev;
  mgs_settings_init(&prev);
  if (resume && run) {
    char *cfg = mgs_path_join(run, "cfg_args");
    if (cfg && mgs_path_exists(cfg) && mgs_settings_read(cfg, &prev, NULL) == MGS_OK) {
      const char *v;
#define RESTORE_INT(flag, key, dst) if (!given[flag] && (v = mgs_settings_get(&prev, key))) dst = atoi(v)
      RESTORE_INT(O_ITERS, "iterations", o.iterations);
      RESTORE_INT(O_DOWNSCALE, "downscale", downscale);
      RESTORE_INT(O_MAXW, "max_width", max_width);
      RESTORE_INT(O_LRSTEPS, "position_lr_max_steps", o.lr_mean_max_steps);
      RESTORE_INT(O_SH, "sh_degree", o.sh_degree);
      RESTORE_INT(O_TEST_EVERY, "test_every", test_every);
      RESTORE_INT(O_RANDOM_POINTS, "random_points", random_points);
      RESTORE_INT(O_DFROM, "densify_from_iter", o.adc.densify_from);
      RESTORE_INT(O_DUNTIL, "densify_until_iter", o.adc.densify_until);
      RESTORE_INT(O_DEVERY, "densification_interval", o.adc.densify_every);
      RESTORE_INT(O_RESET, "opacity_reset_interval", o.adc.opacity_reset_every);
      RESTORE_INT(O_CKPT, "checkpoint_every", o.checkpoint_every);
#undef RESTORE_INT
      if (!given[O_SEED] && (v = mgs_settings_get(&prev, "seed"))) seed = strtoull(v, NULL, 10);
      if (!given[O_GTHR] && (v = mgs_settings_get(&prev, "densify_grad_threshold"))) o.adc.grad_threshold = (float)atof(v);
      if (!given[O_WHITE] && !given[O_BLACK] && (v = mgs_settings_get(&prev, "white_background"))) white = !strcmp(v, "True");
      if (!given[O_STRATEGY] && (v = mgs_settings_get(&prev, "strategy"))) strategy = v;
      if (!given[O_FREEZE] && (v = mgs_settings_get(&prev, "freeze"))) o.freeze = !strcmp(v, "True");
      if (!given[O_INIT] && (v = mgs_settings_get(&prev, "init"))) init = v; /* for the record only */
      mgs_topogs_flags_restore(&g_topogs, &prev);
      if (!given[O_NORMAL] && (v = mgs_settings_get(&prev, "normal_loss"))) g_normal_loss = atof(v);
    }
    free(cfg);
  }
  init = mgs_topogs_init(&g_topogs, init, given[O_INIT]);
  if (given[O_DOWNSCALE] && !given[O_MAXW]) max_width = 0; /* a resolution given: no cap, as the reference */
  int rc = mgs_cmd_train_run(data, run, &o, strategy, init, save_at, downscale, max_width, white, test_every, resume, force,
                             threads, quiet, random_points, seed, mf);
  mgs_settings_free(&prev);
  return rc;
}

static int mgs_cmd_train_run(const char *data, const char *run, mgs_train_options *op, const char *strategy,
                             const char *init, const char *save_at, int downscale, int max_width, int white,
                             int test_every, int resume, int force, int threads, int quiet, int random_points,
                             unsigned long long seed, train_morse_flags *mf) {
  mgs_train_options o = *op;
  if (strcmp(strategy, "adc") && strcmp(strategy, "none") && strcmp(strategy, "morse")) { fprintf(stderr, "morsegs train: unknown --strategy '%s' (adc, morse, none)\n", strategy); return 2; }
  /* MorseGS: ranges and the grid budget, before anything is written */
  if (!train_morse_flags_check(mf, strategy, o.iterations)) return 2;
  int use_morse = !strcmp(strategy, "morse") || mf->o.topo != MGS_MORSE_TOPO_NONE;
  if (strcmp(init, "sfm") && strcmp(init, "random") && strcmp(init, "lpvi") && strcmp(init, "levelset")) { fprintf(stderr, "morsegs train: unknown --init '%s' (sfm, random, levelset, lpvi)\n", init); return 2; }
  int saves[64], n_saves = 0;
  for (const char *p = save_at; *p && n_saves < 64;) {
    char *end;
    long v = strtol(p, &end, 10);
    if (end == p || v < 1) { fprintf(stderr, "morsegs train: --save-at needs a comma-separated list of iterations (got '%s')\n", save_at); return 2; }
    if (v < o.iterations) saves[n_saves++] = (int)v; /* the final save is always written */
    p = *end == ',' ? end + 1 : end;
    if (*end && *end != ',') { fprintf(stderr, "morsegs train: bad --save-at list '%s'\n", save_at); return 2; }
  }
  if (threads) mgs_parallel_set_threads(threads);
  o.seed = seed;
  o.progress = !quiet;
  o.stop = &g_stop;

  mgs_error err;
  mgs_error_clear(&err);
  if (!mgs_is_dir(data)) { fprintf(stderr, "morsegs train: %s: dataset folder not found\n", data); return 1; }
  if (path_inside(run, data)) {
    fprintf(stderr, "morsegs train: %s: the run folder is inside the dataset folder %s; choose another -o (the dataset is never written to)\n", run, data);
    return 2;
  }
  if (mgs_is_dir(run) && dir_has_entries(run) && !force && !resume) {
    fprintf(stderr, "morsegs train: %s: run folder exists and is not empty (use --force to replace it or --resume to continue)\n", run);
    return 1;
  }
  if (mgs_path_exists(run) && !mgs_is_dir(run)) { fprintf(stderr, "morsegs train: %s: exists and is not a folder\n", run); return 1; }
  char *ckpt = mgs_path_join(run, "checkpoint.mgsckpt");
  if (resume && !mgs_path_exists(ckpt)) {
    fprintf(stderr, "morsegs train: %s: no checkpoint to resume from\n", ckpt);
    free(ckpt);
    return 1;
  }
  o.checkpoint_path = ckpt;

  mgs_dataset_options dopt;
  mgs_dataset_options_default(&dopt);
  dopt.downscale = downscale;
  dopt.max_width = max_width;
  dopt.white_background = white; /* -1: by format */
  dopt.load_images = o.image_cache_mb == 0; /* the cache decodes on demand */
  dopt.test_every = test_every;
  mgs_dataset *ds = NULL;
  int rc = 1;
  mgs_trainer *t = NULL;
  mgs_run_lock *lock = NULL;
  mgs_morse_ctx *mctx = NULL; /* MorseGS analysis context (NULL: not used) */
  mgs_status st = mgs_dataset_load(data, &dopt, &ds, &err);
  if (st) goto done;
  white = ds->white_background;
  /* the reference's extra opacity reset at densify_from comes with its white background */
  o.adc.white_background = white;
  /* the lock before --force clears anything: a second trainer on RUN is refused */
  if ((st = mgs_run_lock_acquire(run, &lock, &err))) goto done;
  if (!resume && force && (st = clear_run(run, &err))) goto done;

  mgs_gaussians *g0 = NULL;
  const char *init_used = init;
  if (resume) {
    g0 = mgs_gaussians_create(1, o.sh_degree); /* replaced by the checkpoint */
    size_t first;
    if (!g0 || (st = mgs_gaussians_append(g0, 1, &first, &err))) { mgs_gaussians_destroy(g0); if (!st) st = MGS_ERR_NOMEM; goto done; }
  } else if (!strcmp(init, "lpvi")) {
    st = mgs_topogs_init_model(&g_topogs, ds, o.sh_degree, seed, random_points, &g0, &err);
  } else if (!strcmp(init, "levelset")) { /* MorseGS level-set init (train/mgs_init_levelset.h) */
    if (!ds->init_points || ds->init_points->n == 0) {
      st = mgs_error_set(&err, MGS_ERR_ARG, "--init levelset: %s has no initial points (COLMAP points3D, points3d.ply)", data);
    } else {
      mgs_levelset_options lo;
      mgs_levelset_options_default(&lo);
      lo.seed = seed;
      mgs_levelset_info li;
      st = mgs_init_levelset(ds->init_points->xyz, ds->init_points->rgb, ds->init_points->n, o.sh_degree, &lo, &g0, &li, &err);
      if (!st) mgs_info("level-set init: %zu Gaussians from %zu points (%zu far outliers left out; voxel %.4g, delta %.4g, %.2f s)", g0->n, ds->init_points->n, li.outliers, li.voxel_size, li.delta, li.seconds);
    }
  } else if (!strcmp(init, "sfm") && ds->init_points && ds->init_points->n > 0) {
    st = mgs_init_from_points(ds->init_points->xyz, ds->init_points->rgb, ds->init_points->n, o.sh_degree, &g0, &err);
  } else {
    init_used = "random";
    if (!strcmp(init, "sfm")) mgs_info("%s: no initial points; random init with %d Gaussians", data, random_points);
    st = mgs_init_random_for_dataset(ds, (size_t)random_points, o.sh_degree, seed, &g0, &err);
  }
  if (st) goto done;
  mgs_strategy *strat = NULL;
  if (!strcmp(strategy, "adc")) strat = mgs_strategy_adc_create(&o.adc);
  /* ---- MorseGS: one analysis context shared by the strategy and the L_topo term */
  if (use_morse) {
    mf->o.until = mf->o.until > o.adc.densify_until && !strcmp(strategy, "morse") ? o.adc.densify_until : mf->o.until;
    if ((st = mgs_morse_ctx_create(&mf->o, ds, &mctx, &err))) { mgs_gaussians_destroy(g0); goto done; }
    if (!strcmp(strategy, "morse") && (st = mgs_strategy_morse_create(&o.adc, mctx, &strat, &err))) { mgs_gaussians_destroy(g0); goto done; }
    char *csv = mgs_path_join(run, "morse_analysis.csv");
    mgs_morse_ctx_set_csv(mctx, csv);
    free(csv);
    g_morse = mctx;
  }
  if ((st = mgs_trainer_create(ds, &o, g0, strat, &t, &err))) goto done;
  if (mctx && mf->o.topo != MGS_MORSE_TOPO_NONE) {
    mgs_term *topo = NULL;
    if ((st = mgs_term_topo_create(mctx, strcmp(strategy, "morse") != 0, &topo, &err))) goto done;
    if ((st = mgs_trainer_add_term(t, topo, &err))) goto done;
  }
  if ((st = mgs_topogs_add_terms(&g_topogs, t, &err))) goto done;
  if (g_normal_loss > 0) { /* MorseGS normal loss (train/mgs_term_normal.h) */
    mgs_normal_options no;
    mgs_normal_options_default(&no);
    no.gamma = g_normal_loss;
    if (o.iterations < 2 * no.from_iter) no.from_iter = o.iterations / 2 > 0 ? o.iterations / 2 : 1; /* short runs: the second half */
    mgs_term *nt = NULL;
    mgs_normal_term *nh = NULL;
    if ((st = mgs_term_normal_create(&no, &nt, &nh, &err)) || (st = mgs_trainer_add_term(t, nt, &err))) goto done;
    if (mctx) mgs_term_normal_set_source(nh, morse_sdf_source, mctx); /* ∇d of the last Morse analysis */
  }
  if (resume) {
    if ((st = mgs_trainer_load_checkpoint(t, ckpt, &err))) goto done;
    mgs_info("resuming %s at iteration %d with %zu Gaussians", run, mgs_trainer_iteration(t), mgs_trainer_model(t)->n);
  }
  /* a checkpoint before anything else of the run is written: from here on a run killed
     at any moment can --resume */
  if (!resume && o.checkpoint_every > 0 && (st = mgs_trainer_save_checkpoint(t, ckpt, &err))) goto done;

  /* settings record and cameras before training (a crash still leaves them) */
  {
    char abs_data[PATH_MAX];
    if (!realpath(data, abs_data)) snprintf(abs_data, sizeof abs_data, "%s", data);
    mgs_settings s;
    mgs_settings_init(&s);
    mgs_settings_seti(&s, "sh_degree", o.sh_degree);
    mgs_settings_set(&s, "source_path", abs_data, 1);
    mgs_settings_set(&s, "model_path", run, 1);
    mgs_settings_set(&s, "images", "images", 1);
    mgs_settings_seti(&s, "resolution", downscale > 1 ? downscale : -1);
    mgs_settings_seti(&s, "max_width", max_width);
    mgs_settings_set(&s, "white_background", white ? "True" : "False", 0);
    mgs_settings_set(&s, "data_device", "cpu", 1);
    mgs_settings_set(&s, "eval", "True", 0);
    mgs_settings_seti(&s, "downscale", downscale);
    mgs_settings_seti(&s, "test_every", test_every);
    mgs_settings_seti(&s, "iterations", o.iterations);
    mgs_settings_seti(&s, "seed", (long long)seed);
    mgs_settings_set(&s, "strategy", strategy, 1);
    mgs_settings_set(&s, "init", init_used, 1);
    mgs_settings_setf(&s, "normal_loss", g_normal_loss);
    mgs_settings_seti(&s, "random_points", random_points);
    mgs_settings_setf(&s, "lambda_dssim", o.lambda_dssim);
    mgs_settings_setf(&s, "position_lr_init", o.lr_mean_init);
    mgs_settings_setf(&s, "position_lr_final", o.lr_mean_final);
    mgs_settings_seti(&s, "position_lr_max_steps", o.lr_mean_max_steps > 0 ? o.lr_mean_max_steps : o.iterations);
    mgs_settings_setf(&s, "feature_lr", o.lr_sh_dc);
    mgs_settings_setf(&s, "feature_rest_lr", o.lr_sh_rest);
    mgs_settings_setf(&s, "opacity_lr", o.lr_opacity);
    mgs_settings_setf(&s, "scaling_lr", o.lr_log_scale);
    mgs_settings_setf(&s, "rotation_lr", o.lr_rot);
    mgs_settings_seti(&s, "sh_increase_every", o.sh_every);
    mgs_settings_seti(&s, "densify_from_iter", o.adc.densify_from);
    mgs_settings_seti(&s, "densify_until_iter", o.adc.densify_until);
    mgs_settings_seti(&s, "densification_interval", o.adc.densify_every);
    mgs_settings_seti(&s, "opacity_reset_interval", o.adc.opacity_reset_every);
    mgs_settings_setf(&s, "densify_grad_threshold", o.adc.grad_threshold);
    mgs_settings_setf(&s, "percent_dense", o.adc.percent_dense);
    mgs_settings_setf(&s, "min_opacity", o.adc.min_opacity);
    mgs_settings_setf(&s, "max_screen_size", o.adc.max_screen_px);
    mgs_settings_seti(&s, "checkpoint_every", o.checkpoint_every);
    mgs_settings_seti(&s, "threads", mgs_parallel_max_threads());
    mgs_settings_set(&s, "freeze", o.freeze ? "True" : "False", 0);
    mgs_topogs_flags_record(&g_topogs, !strcmp(init_used, "lpvi"), &s);
    train_morse_flags_record(mf, strategy, &s); /* MorseGS settings */
    mgs_run_record_origin(&s, ds); /* scene_origin: the frame the model trained in */
    char *cfg = mgs_path_join(run, "cfg_args");
    st = mgs_settings_write(cfg, &s, &err);
    free(cfg);
    mgs_settings_free(&s);
    if (st) goto done;
    if ((st = mgs_run_write_cameras(run, ds, &err))) goto done;
  }

  struct sigaction sa, old;
  memset(&sa, 0, sizeof sa);
  sa.sa_handler = on_sigint;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, &old);
  mgs_info("training %s: %zu train views, %zu Gaussians, %d iterations", data, ds->n_views[MGS_SPLIT_TRAIN],
           mgs_trainer_model(t)->n, o.iterations);
  /* each save is the model the reference writes at that iteration (mgs_trainer_run_to) */
  for (int i = 0; i <= n_saves && st == MGS_OK; i++) {
    int at = i < n_saves ? saves[i] : o.iterations;
    if (at < mgs_trainer_model_iteration(t) && i < n_saves) continue;
    st = mgs_trainer_run_to(t, at, &err);
    if (st == MGS_OK && i < n_saves) st = mgs_run_write_ply(run, at, mgs_trainer_model(t), &err);
  }
  sigaction(SIGINT, &old, NULL);
  if (st == MGS_ERR_INTERRUPTED) {
    mgs_error e2;
    mgs_status s2 = mgs_run_write_ply(run, mgs_trainer_model_iteration(t), mgs_trainer_model(t), &e2);
    fprintf(stderr, "morsegs train: %s; %s\n", err.msg, s2 == MGS_OK ? "current model written" : e2.msg);
    write_stats(run, t, &e2);
    if (mctx) mgs_morse_ctx_flush_csv(mctx, &e2);
    rc = 130;
    goto done;
  }
  if (st) goto done;
  if ((st = mgs_run_write_ply(run, mgs_trainer_iteration(t), mgs_trainer_model(t), &err))) goto done;
  if ((st = write_stats(run, t, &err))) goto done;
  if (mctx) {
    if ((st = mgs_morse_ctx_flush_csv(mctx, &err))) goto done;
    mgs_info("Morse analyses: %zu, %.1f s (%.1f %% of the training wall time)", mgs_morse_ctx_analyses(mctx),
             mgs_morse_ctx_seconds(mctx), 100.0 * mgs_morse_ctx_seconds(mctx) / (mgs_trainer_seconds(t) > 0 ? mgs_trainer_seconds(t) : 1));
  }
  /* a final checkpoint lets --resume extend the run with a larger --iters */
  if (o.checkpoint_every > 0 && (st = mgs_trainer_save_checkpoint(t, ckpt, &err))) goto done;
  printf("trained %d iterations in %.1f s: %zu Gaussians -> %s/point_cloud/iteration_%d/point_cloud.ply\n",
         mgs_trainer_iteration(t), mgs_trainer_seconds(t), mgs_trainer_model(t)->n, run, mgs_trainer_iteration(t));
  rc = 0;
done:
  if (rc == 1) mgs_cli_fail("train", &err);
  mgs_trainer_destroy(t);
  g_morse = NULL;
  mgs_morse_ctx_unref(mctx);
  mgs_dataset_destroy(ds);
  mgs_run_lock_release(lock);
  free(ckpt);
  return rc;
}

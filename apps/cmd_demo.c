/* `morsegs demo`: the embedded default, run end to end. A list of stages over one
 * context; each prints what it wrote: the built-in genus-2 scene as a small dataset, a
 * brief 3DGS baseline training run on it, evaluation (PSNR/SSIM, Chamfer/F-score/floaters
 * against the ground-truth mesh), the .vdb export (density + sdf + surface mesh),
 * persistence of the SDF (diagram, barcode, critical points); then the same four stages
 * for `--preset morse-full` at the same seed and iterations (DIR/run-morse), and a report
 * that puts the two side by side, DIR/REPORT.md (apps/cmd_demo_report.c) and the page to
 * open, DIR/REPORT.html with the pictures (apps/cmd_demo_html.c).
 * The later stages run the subcommands in-process with the arguments a user would type,
 * so the demo exercises exactly what the CLI does. */
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "apps/cmd_demo.h"
#include "apps/mgs_cli.h"
#include "assets/mgs_assets.h"
#include "core/mgs_fs.h"
#include "core/mgs_log.h"
#include "render/mgs_scene.h"

/* Runs a subcommand in-process, as `morsegs ARGS...` would. */
static int run_cmd(int (*fn)(int, char **), const char *const *args) {
  char *argv[32];
  int argc = 0;
  while (args[argc] && argc < 31) { argv[argc] = (char *)args[argc]; argc++; }
  argv[argc] = NULL;
  printf("  $ morsegs");
  for (int i = 0; i < argc; i++) printf(" %s", argv[i]);
  printf("\n");
  fflush(stdout);
  optind = 0; /* glibc: full getopt re-initialization for the next parser */
  return fn(argc, argv);
}

typedef struct demo_stage {
  const char *name;
  const char *what;
  int (*run)(demo_ctx *ctx, demo_run *r); /* 0 ok, else the exit code */
  int run_index;                          /* which run the stage works on (-1: none) */
} demo_stage;

static int stage_scene(demo_ctx *ctx, demo_run *r) {
  (void)r;
  ctx->scene_dir = mgs_path_join(ctx->out_dir, "scene");
  if (!ctx->scene_dir) return 1;
  char *record = mgs_path_join(ctx->scene_dir, "scene.json");
  int exists = record && mgs_path_exists(record);
  free(record);
  if (exists && !ctx->force) {
    printf("  %s: kept the existing dataset (pass --force to rebuild it)\n", ctx->scene_dir);
    return 0;
  }
  mgs_error err;
  mgs_error_clear(&err);
  mgs_mesh *mesh = NULL;
  if (mgs_assets_builtin("genus2", &mesh, &err) != MGS_OK) return mgs_cli_fail("demo", &err);
  mgs_scene_options o;
  mgs_scene_options_default(&o);
  o.n_train = 40;
  o.n_test = 8;
  o.width = o.height = 128;
  o.specular = 1;
  o.mesh_name = "builtin:genus2";
  o.force = ctx->force;
  o.quiet = ctx->quiet;
  mgs_scene_stats st;
  mgs_status s = mgs_scene_render_dataset_stats(mesh, &o, ctx->scene_dir, &st, &err);
  mgs_mesh_destroy(mesh);
  if (s != MGS_OK) return mgs_cli_fail("demo", &err);
  printf("  %s/\n"
         "    train/r_0..r_%d.png, test/r_0..r_%d.png   RGBA %dx%d, Embree, 4x4 antialiasing\n"
         "    transforms_train.json, transforms_test.json  NeRF-synthetic cameras\n"
         "    gt_mesh.ply      the double torus, %zu triangles, normalized to [-1,1]^3\n"
         "    points3d.ply     10000 noisy surface points (SfM stand-in)\n"
         "    scene.json       settings and normalization\n"
         "    (%.1f s)\n",
         ctx->scene_dir, o.n_train - 1, o.n_test - 1, o.width, o.height, st.triangles, st.total_seconds);
  return 0;
}

/* Trains run r: the baseline exactly as before (DIR/run), morse-full with the same
 * seed (the trainer's default, for both) and iterations plus its preset and the scaled
 * analysis schedule. */
static int stage_train(demo_ctx *ctx, demo_run *r) {
  char sub[96];
  snprintf(sub, sizeof sub, "point_cloud/iteration_%d/point_cloud.ply", ctx->iters);
  r->run_dir = mgs_path_join(ctx->out_dir, r->subdir);
  r->ply_path = r->run_dir ? mgs_path_join(r->run_dir, sub) : NULL;
  if (!r->run_dir || !r->ply_path) return 1;
  if (mgs_path_exists(r->ply_path) && !ctx->force) {
    printf("  %s: kept the existing trained model (pass --force to retrain)\n", r->ply_path);
    return 0;
  }
  char iters[32], warmup[32], every[32];
  snprintf(iters, sizeof iters, "%d", ctx->iters);
  snprintf(warmup, sizeof warmup, "%d", ctx->morse_warmup);
  snprintf(every, sizeof every, "%d", ctx->morse_every);
  const char *args[20];
  int n = 0;
  args[n++] = "train"; args[n++] = ctx->scene_dir; args[n++] = "-o"; args[n++] = r->run_dir;
  args[n++] = "--iters"; args[n++] = iters; args[n++] = "--force";
  if (r->preset) {
    args[n++] = "--preset"; args[n++] = r->preset;
    args[n++] = "--morse-warmup"; args[n++] = warmup;
    args[n++] = "--morse-every"; args[n++] = every;
    /* half the default analysis resolution: the demo stays at about a minute (256 doubles
       the morse-full run on this scene; README) */
    args[n++] = "--morse-resolution"; args[n++] = "128";
  }
  if (ctx->quiet) args[n++] = "--quiet";
  args[n] = NULL;
  return run_cmd(mgs_cmd_train, args);
}

static int stage_eval(demo_ctx *ctx, demo_run *r) {
  (void)ctx;
  const char *args[] = {"eval", r->run_dir, NULL};
  return run_cmd(mgs_cmd_eval, args);
}

static int stage_vdb(demo_ctx *ctx, demo_run *r) {
  (void)ctx;
  r->vdb_path = mgs_path_join(r->run_dir, "scene.vdb");
  char *mesh = mgs_path_join(r->run_dir, "surface.ply");
  if (!r->vdb_path || !mesh) { free(mesh); return 1; }
  const char *args[] = {"vdb", r->ply_path, "-o", r->vdb_path, "--mesh", mesh, "--force", NULL};
  int rc = run_cmd(mgs_cmd_vdb, args);
  free(mesh);
  return rc;
}

static int stage_persistence(demo_ctx *ctx, demo_run *r) {
  (void)ctx;
  r->pers_dir = mgs_path_join(r->run_dir, "persistence");
  if (!r->pers_dir) return 1;
  const char *args[] = {"persistence", r->vdb_path, "--grid", "sdf", "-o", r->pers_dir, "--force", NULL};
  return run_cmd(mgs_cmd_persistence, args);
}

static int stage_report(demo_ctx *ctx, demo_run *r) {
  (void)r;
  return demo_report(ctx);
}

static const demo_stage stages[] = {
    {"scene", "built-in genus-2 scene -> NeRF-synthetic dataset", stage_scene, -1},
    {"train", "3DGS baseline training (brief)", stage_train, DEMO_BASE},
    {"eval", "PSNR/SSIM on test views, Chamfer/F-score/floaters vs the GT mesh", stage_eval, DEMO_BASE},
    {"vdb", "trained .ply -> .vdb (density fog + sdf level set) and surface mesh", stage_vdb, DEMO_BASE},
    {"persist", "persistence diagram of the SDF, plots, critical points", stage_persistence, DEMO_BASE},
    {"train-morse", "MorseGS training, --preset morse-full, same seed and iterations", stage_train, DEMO_MORSE},
    {"eval-morse", "the same evaluation of the morse-full model", stage_eval, DEMO_MORSE},
    {"vdb-morse", "the same .vdb export of the morse-full model", stage_vdb, DEMO_MORSE},
    {"persist-morse", "the same persistence of its SDF", stage_persistence, DEMO_MORSE},
    {"report", "DIR/REPORT.md and REPORT.html: baseline and morse-full side by side", stage_report, -1},
};
enum { N_STAGES = sizeof stages / sizeof stages[0] };

static void demo_usage(FILE *f) {
  fprintf(f, "usage: morsegs demo [-o DIR] [--iters N] [--baseline-only] [--force] [-q]\n"
             "Runs the bundled demo end to end into DIR (demo-out):\n");
  for (size_t i = 0; i < N_STAGES; i++) fprintf(f, "  %2zu. %-13s %s\n", i + 1, stages[i].name, stages[i].what);
  fprintf(f, "options:\n  -o, --output DIR  output folder (demo-out)\n  --force           rebuild outputs that exist\n"
             "  --iters N         training iterations of both runs (2000); the morse-full run's analysis\n"
             "                    starts at N/4 and repeats every N/8 iterations (--morse-warmup/--morse-every),\n"
             "                    at --morse-resolution 128 (the default 256 doubles its time)\n"
             "  --baseline-only   skip the morse-full run (the *-morse stages): under half the time\n"
             "  -q, --quiet       no progress output\n  -h, --help        this text\n");
}

int mgs_cmd_demo(int argc, char **argv) {
  enum { O_BASE_ONLY = 1000 };
  static const struct option longopts[] = {{"output", required_argument, 0, 'o'}, {"force", no_argument, 0, 'f'},
                                           {"quiet", no_argument, 0, 'q'}, {"help", no_argument, 0, 'h'},
                                           {"iters", required_argument, 0, 'i'},
                                           {"baseline-only", no_argument, 0, O_BASE_ONLY}, {0, 0, 0, 0}};
  demo_ctx ctx;
  memset(&ctx, 0, sizeof ctx);
  ctx.out_dir = "demo-out";
  ctx.iters = 2000;
  ctx.runs[DEMO_BASE] = (demo_run){"baseline", "run", NULL, NULL, NULL, NULL, NULL};
  ctx.runs[DEMO_MORSE] = (demo_run){"morse-full", "run-morse", "morse-full", NULL, NULL, NULL, NULL};
  optind = 1;
  opterr = 0;
  int c;
  while ((c = getopt_long(argc, argv, "o:qh", longopts, NULL)) != -1) {
    switch (c) {
    case 'o': ctx.out_dir = optarg; break;
    case 'f': ctx.force = 1; break;
    case 'q': ctx.quiet = 1; break;
    case O_BASE_ONLY: ctx.baseline_only = 1; break;
    case 'i': {
      char *end;
      long v = strtol(optarg, &end, 10);
      if (!*optarg || *end || v < 1 || v > 1000000) { fprintf(stderr, "morsegs demo: --iters needs an integer in 1..1000000\n"); return 2; }
      ctx.iters = (int)v;
      break;
    }
    case 'h': demo_usage(stdout); return 0;
    default: fprintf(stderr, "morsegs demo: bad option %s\n", argv[optind - 1]); demo_usage(stderr); return 2;
    }
  }
  if (optind < argc) { fprintf(stderr, "morsegs demo: unexpected argument '%s'\n", argv[optind]); return 2; }
  ctx.n_runs = ctx.baseline_only ? 1 : 2;
  /* The preset's W = 3000, K = 500 belong to a 30000-iteration schedule and never fire in
   * a 2000-iteration demo. Scaled: the analysis starts where ADC starts densifying in the
   * default demo (500 of 2000, a quarter of the run) and repeats every eighth, so a
   * default demo gets six analyses (500, 750, ..., 1750) while ADC is still active. */
  ctx.morse_warmup = ctx.iters / 4 > 0 ? ctx.iters / 4 : 1;
  ctx.morse_every = ctx.iters / 8 > 0 ? ctx.iters / 8 : 1;
  mgs_error err;
  mgs_error_clear(&err);
  if (mgs_mkdir_p(ctx.out_dir, &err) != MGS_OK) return mgs_cli_fail("demo", &err);
  double t0 = mgs_now();
  int rc = 0, n = 0;
  for (size_t i = 0; i < N_STAGES; i++) n += !(ctx.baseline_only && stages[i].run_index == DEMO_MORSE);
  for (size_t i = 0, k = 0; i < N_STAGES && rc == 0; i++) {
    if (ctx.baseline_only && stages[i].run_index == DEMO_MORSE) continue;
    printf("[%zu/%d] %s: %s\n", ++k, n, stages[i].name, stages[i].what);
    fflush(stdout);
    double ts = mgs_now();
    rc = stages[i].run(&ctx, stages[i].run_index >= 0 ? &ctx.runs[stages[i].run_index] : NULL);
    if (ctx.n_stages_done < 16) {
      ctx.stage_name[ctx.n_stages_done] = stages[i].name;
      ctx.stage_seconds[ctx.n_stages_done++] = mgs_now() - ts;
    }
  }
  if (rc == 0) printf("demo done in %.1f s; outputs in %s/\nopen %s/REPORT.html\n", mgs_now() - t0, ctx.out_dir, ctx.out_dir);
  free(ctx.scene_dir);
  for (int r = 0; r < DEMO_RUNS; r++) {
    free(ctx.runs[r].run_dir);
    free(ctx.runs[r].ply_path);
    free(ctx.runs[r].vdb_path);
    free(ctx.runs[r].pers_dir);
  }
  return rc;
}

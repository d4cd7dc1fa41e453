/* `morsegs demo`: the embedded default, run end to end as far as the system goes. It is
 * a list of stages over one context; each stage prints what it wrote. At this stage of
 * the project: build the built-in genus-2 scene as a small dataset in DIR/scene. Later
 * stages (train, export .ply/.vdb, persistence plots, report) are appended to `stages`. */
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "apps/mgs_cli.h"
#include "assets/mgs_assets.h"
#include "core/mgs_fs.h"
#include "core/mgs_log.h"
#include "render/mgs_scene.h"

typedef struct demo_ctx {
  const char *out_dir;   /* -o (demo-out) */
  int force;             /* rebuild what exists */
  int quiet;
  char *scene_dir;       /* DIR/scene: the dataset the later stages train on */
} demo_ctx;

typedef struct demo_stage {
  const char *name;
  const char *what;
  int (*run)(demo_ctx *ctx); /* 0 ok, else the exit code */
} demo_stage;

static int stage_scene(demo_ctx *ctx) {
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

static const demo_stage stages[] = {
    {"scene", "built-in genus-2 scene -> NeRF-synthetic dataset", stage_scene},
};

static void demo_usage(FILE *f) {
  fprintf(f, "usage: morsegs demo [-o DIR] [--force] [-q]\n"
             "Runs the bundled demo end to end into DIR (demo-out):\n");
  for (size_t i = 0; i < sizeof stages / sizeof stages[0]; i++) fprintf(f, "  %zu. %-8s %s\n", i + 1, stages[i].name, stages[i].what);
  fprintf(f, "options:\n  -o, --output DIR  output folder (demo-out)\n  --force           rebuild outputs that exist\n"
             "  -q, --quiet       no progress output\n  -h, --help        this text\n");
}

int mgs_cmd_demo(int argc, char **argv) {
  static const struct option longopts[] = {{"output", required_argument, 0, 'o'}, {"force", no_argument, 0, 'f'},
                                           {"quiet", no_argument, 0, 'q'}, {"help", no_argument, 0, 'h'}, {0, 0, 0, 0}};
  demo_ctx ctx = {"demo-out", 0, 0, NULL};
  optind = 1;
  opterr = 0;
  int c;
  while ((c = getopt_long(argc, argv, "o:qh", longopts, NULL)) != -1) {
    switch (c) {
    case 'o': ctx.out_dir = optarg; break;
    case 'f': ctx.force = 1; break;
    case 'q': ctx.quiet = 1; break;
    case 'h': demo_usage(stdout); return 0;
    default: fprintf(stderr, "morsegs demo: bad option %s\n", argv[optind - 1]); demo_usage(stderr); return 2;
    }
  }
  if (optind < argc) { fprintf(stderr, "morsegs demo: unexpected argument '%s'\n", argv[optind]); return 2; }
  mgs_error err;
  mgs_error_clear(&err);
  if (mgs_mkdir_p(ctx.out_dir, &err) != MGS_OK) return mgs_cli_fail("demo", &err);
  double t0 = mgs_now();
  int rc = 0;
  size_t n = sizeof stages / sizeof stages[0];
  for (size_t i = 0; i < n && rc == 0; i++) {
    printf("[%zu/%zu] %s: %s\n", i + 1, n, stages[i].name, stages[i].what);
    fflush(stdout);
    rc = stages[i].run(&ctx);
  }
  if (rc == 0) printf("demo done in %.1f s; outputs in %s/\n", mgs_now() - t0, ctx.out_dir);
  free(ctx.scene_dir);
  return rc;
}

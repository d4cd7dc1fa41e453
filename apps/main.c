/* morsegs: dispatch to the subcommand named by argv[1]. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "apps/mgs_cli.h"
#include "core/mgs_log.h"
#include "core/mgs_parallel.h"

typedef struct { const char *name; int (*fn)(int, char **); const char *help; } command;

static const command commands[] = {
  {"demo", mgs_cmd_demo, "build the bundled scene, train it briefly, export and report"},
  {"report", mgs_cmd_report, "REPORT.md and REPORT.html (the page to open) of one or two trained runs"},
  {"scene", mgs_cmd_scene, "render a NeRF-synthetic dataset of a mesh with Embree"},
  {"train", mgs_cmd_train, "train a 3DGS model on a dataset"},
  {"render", mgs_cmd_render, "render the views of a trained run"},
  {"eval", mgs_cmd_eval, "PSNR/SSIM (and geometry metrics) of a trained run"},
  {"vdb", mgs_cmd_vdb, "3DGS .ply -> .vdb with density (fog) and sdf (level set) grids"},
  {"persistence", mgs_cmd_persistence, "persistence diagram of a .vdb level set or fog volume"},
  {"bench", mgs_cmd_bench, "benchmarks: run time against error"},
  {"experiment", mgs_cmd_experiment, "every dataset x variant x seed: H1-H4 verdicts, run time against error"},
};

static void usage(FILE *f) {
  fprintf(f, "usage: morsegs COMMAND [options]   (morsegs COMMAND --help for details)\n\ncommands:\n");
  for (size_t i = 0; i < sizeof commands / sizeof commands[0]; i++)
    fprintf(f, "  %-12s %s\n", commands[i].name, commands[i].help);
  fprintf(f, "\nenvironment: MGS_THREADS=N limits worker threads.\n");
}

int mgs_cli_fail(const char *cmd, const mgs_error *err) {
  fprintf(stderr, "morsegs %s: %s\n", cmd, err && err->msg[0] ? err->msg : "failed");
  return 1;
}

int mgs_cli_mask_carve(const char *cmd, const char *arg, int *px) {
  char *end;
  long v = strtol(arg, &end, 10);
  if (!strcmp(arg, "off")) v = -1, end = (char *)arg + 3;
  if (!*arg || *end || v < -1 || v > 64) {
    fprintf(stderr, "morsegs %s: --mask-carve '%s': expected a margin in pixels 0..64, or off\n", cmd, arg);
    return 0;
  }
  *px = (int)v;
  return 1;
}

int main(int argc, char **argv) {
  if (argc < 2) { usage(stderr); return 2; }
  if (!strcmp(argv[1], "-h") || !strcmp(argv[1], "--help") || !strcmp(argv[1], "help")) { usage(stdout); return 0; }
  if (!strcmp(argv[1], "--version")) { printf("morsegs 0.1.0\n"); return 0; }
  for (size_t i = 0; i < sizeof commands / sizeof commands[0]; i++)
    if (!strcmp(argv[1], commands[i].name)) return commands[i].fn(argc - 1, argv + 1);
  fprintf(stderr, "morsegs: unknown command '%s'\n", argv[1]);
  usage(stderr);
  return 2;
}

/* `morsegs report RUN [RUN2] -o DIR`: the demo's report (REPORT.md and REPORT.html, with
 * apps/cmd_demo_report.c and apps/cmd_demo_html.c) of runs made elsewhere: one column per
 * run, every figure read from what `morsegs train/eval/vdb/persistence` wrote into RUN
 * (persistence read from RUN/persistence, as the demo writes it). The page links RUN's
 * images by their path relative to DIR, so DIR and the runs are moved together. */
#include <getopt.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "apps/cmd_demo.h"
#include "apps/mgs_cli.h"
#include "core/mgs_fs.h"

/* `to` relative to the directory `from` (both existing): "../a/b". Caller frees. */
static char *relative_path(const char *from, const char *to) {
  char a[PATH_MAX], b[PATH_MAX];
  if (!realpath(from, a) || !realpath(to, b)) return NULL;
  size_t common = 0, i = 0;
  for (; a[i] && a[i] == b[i]; i++)
    if (a[i] == '/') common = i;
  if (!a[i] && (b[i] == '/' || !b[i])) common = i; /* from is a prefix of to */
  else if (!b[i] && a[i] == '/') common = i;       /* to is a prefix of from */
  size_t ups = 0;
  for (const char *p = a + common; *p; p++) ups += *p == '/';
  const char *rest = b + common;
  while (*rest == '/') rest++;
  size_t len = ups * 3 + strlen(rest) + 2;
  char *out = malloc(len), *o = out;
  if (!out) return NULL;
  for (size_t k = 0; k < ups; k++) memcpy(o, "../", 3), o += 3;
  snprintf(o, len - (size_t)(o - out), "%s", rest);
  size_t n = strlen(out);
  if (n == 0) snprintf(out, len, ".");
  else if (out[n - 1] == '/') out[n - 1] = 0;
  return out;
}

static void usage(FILE *f) {
  fprintf(f, "usage: morsegs report RUN [RUN2] -o DIR\n"
             "Writes DIR/REPORT.md and DIR/REPORT.html (the page to open) for one or two trained runs:\n"
             "figures from RUN/results.json (morsegs eval), train_stats.json, cfg_args, morse_analysis.csv,\n"
             "persistence/diagram.json; pictures from RUN/eval/*.png, RUN/persistence/{diagram,barcode}.png and\n"
             "RUN/surface.ply (rendered with Embree into DIR/surface_views/).\n"
             "options:\n  -o, --output DIR  output folder (required)\n  -h, --help        this text\n");
}

int mgs_cmd_report(int argc, char **argv) {
  static const struct option longopts[] = {{"output", required_argument, 0, 'o'}, {"help", no_argument, 0, 'h'}, {0, 0, 0, 0}};
  const char *out = NULL;
  optind = 1;
  opterr = 0;
  int c;
  while ((c = getopt_long(argc, argv, "o:h", longopts, NULL)) != -1) {
    if (c == 'o') out = optarg;
    else if (c == 'h') { usage(stdout); return 0; }
    else { fprintf(stderr, "morsegs report: bad option %s\n", argv[optind - 1]); usage(stderr); return 2; }
  }
  int n = argc - optind;
  if (!out || n < 1 || n > DEMO_RUNS) { fprintf(stderr, "morsegs report: need -o DIR and 1..%d runs\n", DEMO_RUNS); usage(stderr); return 2; }
  mgs_error err;
  mgs_error_clear(&err);
  for (int i = 0; i < n; i++)
    if (!mgs_is_dir(argv[optind + i])) { fprintf(stderr, "morsegs report: %s: not a run folder\n", argv[optind + i]); return 1; }
  if (mgs_mkdir_p(out, &err) != MGS_OK) return mgs_cli_fail("report", &err);
  demo_ctx ctx;
  memset(&ctx, 0, sizeof ctx);
  ctx.out_dir = out;
  ctx.report_only = 1;
  ctx.n_runs = n;
  char *rel[DEMO_RUNS] = {0};
  int rc = 0;
  for (int i = 0; i < n && rc == 0; i++) {
    demo_run *r = &ctx.runs[i];
    r->run_dir = strdup(argv[optind + i]);
    r->pers_dir = mgs_path_join(argv[optind + i], "persistence");
    rel[i] = relative_path(out, argv[optind + i]);
    if (!r->run_dir || !r->pers_dir || !rel[i]) { fprintf(stderr, "morsegs report: %s: cannot resolve\n", argv[optind + i]); rc = 1; }
    r->subdir = rel[i];
    r->label = rel[i]; /* the column heading: the run as seen from DIR */
  }
  if (rc == 0) rc = demo_report(&ctx);
  if (rc == 0) printf("open %s/REPORT.html\n", out);
  for (int i = 0; i < n; i++) {
    free(ctx.runs[i].run_dir);
    free(ctx.runs[i].pers_dir);
    free(rel[i]);
  }
  return rc;
}

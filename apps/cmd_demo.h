/* `morsegs demo`, shared between apps/cmd_demo.c (the stages, which run the subcommands
 * in-process) and apps/cmd_demo_report.c (DIR/REPORT.md and the stdout summary, read back
 * from the files the stages wrote, so no figure in the report is typed by the demo) and
 * apps/cmd_demo_html.c (DIR/REPORT.html, the page to open). */
#ifndef MGS_CMD_DEMO_H
#define MGS_CMD_DEMO_H

/* One training run of the demo and the files its later stages write. */
typedef struct demo_run {
  const char *label;  /* column heading: "baseline", "morse-full" */
  const char *subdir; /* DIR/<subdir>: "run" (kept for existing users), "run-morse"; for
                         `morsegs report`, the run's path relative to DIR (links of the page) */
  const char *preset; /* --preset of `morsegs train`; NULL = the plain baseline command */
  char *run_dir;      /* DIR/<subdir> */
  char *ply_path;     /* the trained model */
  char *vdb_path;     /* DIR/<subdir>/scene.vdb */
  char *pers_dir;     /* DIR/<subdir>/persistence */
} demo_run;

enum { DEMO_BASE = 0, DEMO_MORSE = 1, DEMO_RUNS = 2 };

typedef struct demo_ctx {
  const char *out_dir; /* -o (demo-out) */
  int force;           /* rebuild what exists */
  int quiet;
  int iters;           /* training iterations, equal for both runs */
  int baseline_only;   /* --baseline-only: the old fast path, no morse-full run */
  int report_only;     /* `morsegs report RUN...`: runs made elsewhere, no demo text */
  int morse_warmup;    /* W and K of the morse-full run, scaled to iters (cmd_demo.c) */
  int morse_every;
  char *scene_dir;     /* DIR/scene: the dataset both runs train on */
  demo_run runs[DEMO_RUNS];
  int n_runs;          /* 1 with --baseline-only, else 2 */
  /* wall time of each stage so far, for the report */
  const char *stage_name[16];
  double stage_seconds[16];
  int n_stages_done;
} demo_ctx;

/* Writes DIR/REPORT.md (atomically) and prints it, then DIR/REPORT.html; 0 on success,
 * else the exit code. */
int demo_report(const demo_ctx *ctx);

/* The figures of one run the HTML page draws (NAN: not written). */
typedef struct demo_html_figs {
  double psnr, train_s;
} demo_html_figs;
/* Writes DIR/REPORT.html (apps/cmd_demo_html.c): the table of `md` (REPORT.md's text),
 * PSNR against wall time, and per run the eval images, persistence plots and pictures of
 * RUN/surface.ply (rendered into DIR/surface_views/runK_view_N.png). 0 on success, else the exit code. */
int demo_report_html(const demo_ctx *ctx, const char *md, const demo_html_figs figs[DEMO_RUNS]);

#endif

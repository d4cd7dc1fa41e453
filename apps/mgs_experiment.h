/* `morsegs experiment` (apps/cmd_experiment*.c), private to apps/. What a run records is
 * measure/mgs_measure.h's, the statistics are stats/mgs_stats.h's; here:
 *   cmd_experiment.c ........ command line, plan, one child process per train/eval, resume
 *   cmd_experiment_report.c . RESULTS.md / RESULTS.json / CSV, H1–H4 verdicts, and
 *                             re-analysis of earlier results (--report-from)
 *   cmd_experiment_plot.c ... line plots (cairo, PNG + SVG)
 *   cmd_experiment_plan.c ... what a run costs before it has run (--plan). */
#ifndef MGS_EXPERIMENT_H
#define MGS_EXPERIMENT_H
#include <stddef.h>
#include "core/mgs_error.h"
#include "measure/mgs_measure.h"

/* ---- the report ---- */
typedef struct exp_variant_status {
  char name[EXP_NAME];
  char status[16];             /* "available", "not available", "failed", "pending" */
  char reason[1024];
  char base[EXP_NAME];         /* the variant its changes are measured against ("" = baseline) */
} exp_variant_status;

typedef struct exp_report_in {
  const char *dir, *command_line;
  int iters, seeds;
  const char *knob_desc;       /* description of the knobs swept */
  size_t n_datasets;
  const char *const *dataset_names;
  const exp_truth *truths;
  size_t n_variants;
  const exp_variant_status *variants;
  size_t n_runs;               /* finished runs */
  const exp_run *runs;
  size_t planned_runs;
  double load_start;           /* 1-minute load average when the experiment started */
  const char *source_note;     /* a line under the command (re-analysis: where the runs came from); may be NULL */
  const char *previous_results; /* an earlier RESULTS.json whose verdicts are compared; may be NULL */
} exp_report_in;

/* The statistics are stats/mgs_stats.h's; this writes them (and the runs) out. */
mgs_status exp_report_write(const exp_report_in *in, mgs_error *err);
/* Re-analysis without training: FROM/curves.csv (every evaluation point of every run, as
 * exp_report_write wrote it) and FROM/RESULTS.json (settings, variants, ground truth as
 * recorded) -> the report in OUT, its verdicts compared with FROM's. variants: comma list
 * of the variants kept (NULL = all; baseline is always kept). */
mgs_status exp_report_from_results(const char *from, const char *out, const char *variants, mgs_error *err);

/* ---- plots ---- */
typedef struct exp_series {
  const char *name;
  size_t n;
  const double *x, *y;
} exp_series;
/* Writes base.png and base.svg (atomically). logy: logarithmic y axis. */
mgs_status exp_plot_lines(const char *base, const char *title, const char *xlabel, const char *ylabel,
                          const exp_series *s, size_t ns, int logy, mgs_error *err);

/* ---- the plan's cost ---- */
/* CPU time per iteration of a variant (its `morsegs train` arguments, NULL-terminated)
 * against 3DGS's, as measured by `morsegs bench train --method`. */
double exp_variant_cost_factor(const char *const *args);
/* Seconds one run of the variant takes on one core: training `iters` iterations on views
 * of `pixels` pixels, and n_evals evaluation points; a prior for plans with no finished run. */
double exp_run_cost_prior(const char *const *args, int iters, double pixels, int n_evals);

#endif

/* `morsegs experiment` (apps/cmd_experiment*.c), private to apps/: the records one run
 * leaves (RUN/result.json), the per-dataset ground truth, and the three parts
 *   cmd_experiment.c ........ command line, plan, one child process per train/eval, resume
 *   cmd_experiment_measure.c  what each evaluation point records (eval's figures, floater
 *                             mass, Betti numbers, bottleneck distance to the GT diagram)
 *   cmd_experiment_report.c . RESULTS.md / RESULTS.json / CSV, H1–H4 verdicts (statistics:
 *                             stats/mgs_stats.h), and re-analysis of earlier results
 *   cmd_experiment_plot.c ... line plots (cairo, PNG + SVG). */
#ifndef MGS_EXPERIMENT_H
#define MGS_EXPERIMENT_H
#include <stddef.h>
#include "core/mgs_error.h"
#include "topo/mgs_diagram.h"

#define EXP_MAX_POINTS 32
#define EXP_NAME 128

/* Stated measurement constants (written into RESULTS.md and RESULTS.json). */
#define EXP_TOPO_RES 256            /* default: GT and model SDF voxel = GT bbox diagonal / this */
#define EXP_PERS_REL 0.02           /* persistence threshold = this x GT bbox diagonal */
#define EXP_VISIBLE_DIST_REL 0.02   /* viewer-visible floaters: centre farther than this x GT diagonal */
#define EXP_SURFACE_TAU 0.5         /* the model surface {A = tau} (as morsegs eval) */

/* One evaluation point of one run. NAN = not measured (no GT mesh, no surface). */
typedef struct exp_point {
  int iteration;
  double wall_seconds;         /* training wall time up to this iteration */
  double psnr, ssim, gaussians;                     /* morsegs eval */
  double chamfer, fscore, floaters, floaters_fraction; /* morsegs eval --mesh (H2: floaters) */
  double floater_mass, floater_mass_fraction;       /* viewer-visible: Σα beyond the distance */
  int betti[3], betti_persistent[3];                /* model SDF at level 0; -1 = unknown */
  double bottleneck;                                /* to the GT diagram; INFINITY if unmatched */
  double measure_seconds;                           /* what the harness spent on this point */
} exp_point;

typedef struct exp_run {
  char dataset[EXP_NAME], variant[EXP_NAME];
  int seed;
  double factor;               /* densification knob multiplier (1 = the variant's default) */
  int iters;
  double train_seconds, analysis_seconds; /* analysis: NAN when the run does not report one */
  int n_points;
  exp_point pt[EXP_MAX_POINTS];
} exp_run;

/* Ground truth of one dataset: the GT mesh's SDF diagram and its Betti numbers. */
typedef struct exp_truth {
  char mesh[4096];             /* "" when the dataset has none */
  int res;                     /* voxels along the GT diagonal (--topo-res) */
  double diag, voxel, pers_threshold, visible_dist, half_width;
  int band;                    /* voxels */
  int betti[3], betti_persistent[3];
  mgs_diagram *diagram;        /* NULL when there is no mesh */
  void *mesh_distance;         /* mgs_mesh_distance* (floater distances) */
} exp_truth;

mgs_status exp_truth_build(const char *mesh_path, int res, const char *save_dir, exp_truth *t, mgs_error *err);
void exp_truth_free(exp_truth *t);

/* Reads RUN/results.json (written by `morsegs eval RUN --iteration N`) into p. */
mgs_status exp_read_eval(const char *run_dir, int iteration, exp_point *p, mgs_error *err);
/* Floater mass, Betti numbers and bottleneck distance of the model saved at p->iteration. */
mgs_status exp_measure_topology(const char *ply, const exp_truth *t, exp_point *p, mgs_error *err);
/* Betti numbers at level 0 of a sublevel diagram: all classes, and those with persistence > thr. */
void exp_betti_at_zero(const mgs_diagram *d, double thr, int all[3], int persistent[3]);

/* RUN/result.json (atomic) and back. */
mgs_status exp_run_write(const char *path, const exp_run *r, mgs_error *err);
mgs_status exp_run_read(const char *path, exp_run *r, mgs_error *err);

/* ---- the report ---- */
typedef struct exp_variant_status {
  char name[EXP_NAME];
  char status[16];             /* "available", "not available", "failed", "pending" */
  char reason[1024];
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

#endif

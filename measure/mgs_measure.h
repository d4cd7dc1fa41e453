/* What `morsegs experiment` records at each evaluation point of a run, as a library so it
 * can be tested without the command (measure/experiment_measure.c): the figures of
 * `morsegs eval` read back, the viewer-visible floater mass, the Betti numbers and the
 * bottleneck distance of the model's α-surface against the ground-truth mesh, and the
 * run record RUN/result.json. The statistics over runs are stats/mgs_stats.h's; the report
 * is the command's (apps/). Names keep the command's exp_ prefix. */
#ifndef MGS_MEASURE_H
#define MGS_MEASURE_H
#include <stddef.h>
#include "core/mgs_error.h"
#include "topo/mgs_diagram.h"

#ifdef __cplusplus
extern "C" {
#endif

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
  double chamfer, fscore, floaters, floaters_fraction; /* morsegs eval --mesh: the α-surface (H2: floaters) */
  double chamfer_fused, fscore_fused;               /* the depth-fused surface (geometry.fused) */
  double chamfer_mesh, fscore_mesh;                 /* SuGaR's mesh (geometry.sugar; final point of SuGaR runs) */
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
  double run_seconds;          /* wall time of training, evaluations and measures (NAN in older records) */
  double train_cpu_seconds;    /* CPU time of the training steps (NAN in older records) */
  double eval_cpu_seconds;     /* CPU time of the evaluation points: eval, vdb and measures (NAN in older records) */
  char evaluator[24];          /* the evaluating binary's fingerprint (hex; "" in older records): --reevaluate */
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
  mgs_diagram *diagram;        /* NULL when there is no mesh (or the truth was read back from a report) */
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

#ifdef __cplusplus
}
#endif
#endif

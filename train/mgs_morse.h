/* MorseGS inside training (SPEC §5.2 items 4-5, §6; seed 000 Alg. 1, §3.3, §6.2). This
 * header owns
 *   the Morse context ........ mgs_morse_ctx: options, the schedule and the latest
 *                              analysis, shared (borrowed) by the strategy and the terms
 *                              (train/morse_analysis.c)
 *   the analysis ............. model -> α-field -> SDF -> narrow-band persistence with
 *                              critical cells (+ closest points, solid components, camera
 *                              counts when a component reads them), timed per stage
 *   MorseGS-D ................ mgs_strategy_morse_create (train/strategy_morse.c): spawn /
 *                              prune from the analysis, ADC for the rest and during warm-up
 *   MorseGS-R ................ mgs_term_topo_create (train/term_topo.c): L_topo on the pairs
 *                              of the last analysis, re-evaluated every iteration
 *
 * Analyses run at iteration W, W+K, W+2K, ... up to `until`, on the model as the terms see
 * it (before that iteration's density control). Whoever asks first in an iteration (the
 * topological term's model_grad, else the strategy's post_backward) runs it; the other
 * reads the same result. Hyperparameters that are lengths (ε_p, ε_sig, floater volume) are
 * fractions of the diagonal of the model's means' bounding box at the analysis (seed §6.2),
 * voxel size = diagonal / r.
 *
 * The context's state (the last analysis' pairs, closest points, counters, CSV rows since
 * the last checkpoint are not kept) is serialized by whoever owns it in a checkpoint: the
 * strategy if there is one, else the term (mgs_morse_ctx_save/_load). */
#ifndef MGS_MORSE_H
#define MGS_MORSE_H
#include <stdio.h>
#include "core/mgs_error.h"
#include "core/mgs_gaussians.h"
#include "core/mgs_dataset.h"
#include "topo/mgs_diagram.h"
#include "vdb/mgs_vdb.h"

#ifdef __cplusplus
extern "C" {
#endif

struct mgs_strategy;
struct mgs_term;
struct mgs_adc_options;

typedef enum { MGS_MORSE_SPAWN_NONE = 0, MGS_MORSE_SPAWN_LITERAL, MGS_MORSE_SPAWN_GAPS } mgs_morse_spawn;
typedef enum { MGS_MORSE_PRUNE_NONE = 0, MGS_MORSE_PRUNE_LITERAL, MGS_MORSE_PRUNE_FLOATERS } mgs_morse_prune;
typedef enum { MGS_MORSE_TOPO_NONE = 0, MGS_MORSE_TOPO_ELIMINATE, MGS_MORSE_TOPO_LITERAL } mgs_morse_topo;

typedef struct mgs_morse_options {
  int every;              /* K: iterations between analyses (500; seed 500-1000) */
  int warmup;             /* W: first analysis (3000; seed 3000-5000); ADC alone before */
  int until;              /* last iteration with an analysis (15000, ADC's densify_until;
                             L_topo keeps applying the last pairing after it) */
  int resolution;         /* r: voxels along the diagonal (256; seed 128-256) */
  double tau;             /* the surface {A = τ} (0.5) */
  double eps_p;           /* ε_p / diagonal: densification threshold (0.01; 0.01-0.05) */
  double eps_sig;         /* ε_sig / diagonal: L_topo cutoff (0.02; 0.02-0.10) */
  double min_alpha;       /* Gaussians below this α are left out of the field (1/255:
                             what the rasterizer never draws) */
  mgs_vdb_sdf_method sdf_method; /* SWEEP for now: CLOSEST breaks on trained models (issue 14) */
  double memory_budget;   /* bytes for the grids (0 = the vdb default, 60 % of RAM) */
  /* MorseGS-D */
  mgs_morse_spawn spawn;
  mgs_morse_prune prune;
  int max_spawn;          /* per analysis (1000) */
  double gap_max;         /* gaps: largest hole radius filled / diagonal (0.05) */
  double floater_volume;  /* floaters: component volume below this fraction of the
                             largest's (0.01) ... */
  double floater_mass;    /* ... or opacity mass below this fraction of the largest's (0.01) */
  int min_cameras;        /* floaters: Gaussians whose mean fewer than m training cameras see
                             are pruned (3; 0 = off) */
  /* MorseGS-R */
  mgs_morse_topo topo;
  double beta;            /* weight of L_topo in units of ε_sig² (0.003, chosen by the sweep in docs/notes/morse.md; seed 0.001-0.01) */
  unsigned dims;          /* dimensions in the loss, bit k = H_k (0x7) */
  double min_bar;         /* bars shorter than this many voxels stay out of the loss (0.5:
                             below the SDF's accuracy they are discretization noise) */
  /* Large scenes: 1 keeps the voxel size while the analysed box's diagonal stays within
     10 % of the one it was set from, and builds the α-field incrementally (leaves whose
     Gaussians did not change since the last analysis are copied, bit-identical to a
     full build: vdb's alpha cache) and the SDF band only around the α leaves that changed
     (vdb's SDF cache, also bit-identical), and the persistence reuses the critical cells
     of band leaves that did not change (topo's leaf cache); its sort and pairing run whole.
     0 (default): every analysis from scratch at diagonal / resolution. */
  int incremental;
} mgs_morse_options;

void mgs_morse_options_default(mgs_morse_options *o);
/* The largest length threshold the enabled components use (world units for a diagonal);
 * the band half-width follows it (mgs_topo_band_for_threshold). */
double mgs_morse_eps_in_use(const mgs_morse_options *o, double diagonal);
/* Range checks (what `morsegs train` reports before training): MGS_ERR_ARG naming the
 * flag (`--morse-every` etc., as apps/train_morse_flags.c spells them) and the range. */
mgs_status mgs_morse_options_check(const mgs_morse_options *o, int iterations, mgs_error *err);
/* The analysis grids' memory: a band of 2w+1 voxels around a surface of about 6 r² voxels
 * (a cube's faces; trained surfaces are larger, so 4x that), ~40 bytes per band voxel for
 * the α-field, the SDF and the persistence engine together. MGS_ERR_ARG when that exceeds
 * 60 % of this machine's memory, naming --morse-resolution. */
mgs_status mgs_morse_grid_budget_check(const mgs_morse_options *o, mgs_error *err);

/* One pair of the last analysis, with what the strategy and the term read. */
typedef struct mgs_morse_pair {
  mgs_pair p;             /* dimension, values, cells, world positions, truncated */
  double cb[3], cd[3];    /* closest points on {A = τ} of the birth / death voxels (world) */
  double gb, gd;          /* |∇A| there at the analysis (exact Gaussian sum) */
  double ab, ad;          /* A there at the analysis (exact Gaussian sum); the term
                             re-evaluates an end as value - (A_now(c) - A)/|∇A| */
  int has_cb, has_cd;     /* 1 when the closest point was found (Newton converged) */
} mgs_morse_pair;

typedef struct mgs_morse_result {
  int iteration;          /* 0: no analysis yet */
  double diagonal, voxel_size, half_width; /* half_width in world units */
  size_t gaussians_used;  /* after the transparency skip */
  size_t n;               /* pairs (all dimensions, incl. essential) */
  mgs_morse_pair *pairs;
  int betti0[3];          /* classes alive at level 0 (birth <= 0 < death) */
  int betti_eps[3];       /* ... of those, persistence > the largest threshold in use */
  double seconds[6];      /* alpha, sdf, persistence, closest points, components, total */
  size_t active_voxels;
  size_t leaves, leaves_reused; /* the α-field's 8³ leaves; copied from the last analysis */
  size_t sdf_leaves, sdf_leaves_reused; /* the SDF band's leaves; copied from the last analysis (incremental) */
  size_t pers_leaves, pers_leaves_reused; /* the persistence's leaves; their critical cells reused (incremental) */
} mgs_morse_result;

typedef struct mgs_morse_ctx mgs_morse_ctx;

/* ds (borrowed; may be NULL: no camera counts) must outlive the context. Refcount 1. */
mgs_status mgs_morse_ctx_create(const mgs_morse_options *o, const mgs_dataset *ds,
                                mgs_morse_ctx **out, mgs_error *err);
mgs_morse_ctx *mgs_morse_ctx_ref(mgs_morse_ctx *c);
void mgs_morse_ctx_unref(mgs_morse_ctx *c);
const mgs_morse_options *mgs_morse_ctx_options(const mgs_morse_ctx *c);
/* Is `iteration` an analysis iteration? */
int mgs_morse_is_analysis_iteration(const mgs_morse_ctx *c, int iteration);
/* Runs the analysis of `iteration` on g unless it already ran for it (then MGS_OK at once).
 * *ran (may be NULL) = 1 if this call ran it. A failed analysis is logged as a warning and
 * leaves an empty result (nothing acts on it until the next one); training goes on. */
mgs_status mgs_morse_ctx_update(mgs_morse_ctx *c, const mgs_gaussians *g, int iteration,
                                int *ran, mgs_error *err);
/* The same, now, whatever the schedule (tools and tests). */
mgs_status mgs_morse_analyze(mgs_morse_ctx *c, const mgs_gaussians *g, int iteration, mgs_error *err);
const mgs_morse_result *mgs_morse_ctx_result(const mgs_morse_ctx *c);
/* The last analysis' grids, valid until the next analysis — the SDF for sampling
 * (mgs_vdb_sample / _gradient; checkpointed, so the same after --resume) and the α-field
 * (NULL after a resume). */
const mgs_vdb_grid *mgs_morse_ctx_sdf(const mgs_morse_ctx *c);
const mgs_vdb_grid *mgs_morse_ctx_alpha(const mgs_morse_ctx *c);
/* Per-Gaussian camera counts of the last analysis (index into the analysed model; NULL
 * when not computed). */
const int *mgs_morse_ctx_camera_counts(const mgs_morse_ctx *c, size_t *n);

/* Components record their per-analysis numbers here; a row is written per analysis. */
void mgs_morse_ctx_note_spawn(mgs_morse_ctx *c, size_t spawned, size_t pruned);
void mgs_morse_ctx_note_topo(mgs_morse_ctx *c, double value);
/* RUN/morse_analysis.csv: appends the rows completed since the last flush (header first
 * when the file is new). path NULL: rows are kept in memory only. */
void mgs_morse_ctx_set_csv(mgs_morse_ctx *c, const char *path);
mgs_status mgs_morse_ctx_flush_csv(mgs_morse_ctx *c, mgs_error *err);
/* Total analysis seconds so far (for the share of wall time). */
double mgs_morse_ctx_seconds(const mgs_morse_ctx *c);
size_t mgs_morse_ctx_analyses(const mgs_morse_ctx *c);

/* Checkpoint: the last result (pairs, closest points), its SDF grid and the counters. */
mgs_status mgs_morse_ctx_save(const mgs_morse_ctx *c, FILE *f, mgs_error *err);
mgs_status mgs_morse_ctx_load(mgs_morse_ctx *c, FILE *f, mgs_error *err);

/* Closest point on {A = τ} from x on the α grid (trilinear): Newton steps along ∇A, or,
 * where ∇A vanishes (critical cells far from the surface: a blob's core, a gap's middle),
 * from the nearest grid sample across τ. Returns 1 when a point within max_travel of x
 * was found (|A - τ| < 1e-4 τ), c and |∇A(c)| then set. */
int mgs_morse_grid_closest_point(const mgs_vdb_grid *alpha, double tau, const double x[3],
                            double max_travel, double c[3], double *grad_norm);

/* ---- MorseGS-D: the strategy. ADC (adc options) runs alone before W and after `until`,
 * and as the fallback at every densification iteration; at analysis iterations the
 * spawn/prune rules run first. Takes a reference on ctx. */
mgs_status mgs_strategy_morse_create(const struct mgs_adc_options *adc, mgs_morse_ctx *ctx,
                                     struct mgs_strategy **out, mgs_error *err);

/* Spawn / prune on one analysis, without a trainer (tests, tools). Appends through
 * mgs_model_append when adam is given, else mgs_gaussians_append. */
struct mgs_adam;
mgs_status mgs_morse_spawn_apply(mgs_morse_ctx *ctx, mgs_gaussians *g, struct mgs_adam *adam,
                                 size_t *spawned, mgs_error *err);
/* keep[n] (caller's, g->n entries) is cleared for the Gaussians the prune rule drops;
 * returns their count in *pruned. */
mgs_status mgs_morse_prune_select(mgs_morse_ctx *ctx, const mgs_gaussians *g, uint8_t *keep,
                                  size_t *pruned, mgs_error *err);

/* ---- MorseGS-R: the topological loss term. Takes a reference on ctx; if owns_state, its
 * checkpoint blob carries the context (no morse strategy in the run). */
mgs_status mgs_term_topo_create(mgs_morse_ctx *ctx, int owns_state, struct mgs_term **out,
                                mgs_error *err);
/* The loss on the current model with the last analysis' pairing (value, no gradient):
 * what the term minimizes, for tests. Also its current total persistence of the bars in
 * the loss (their re-evaluated lengths). */
mgs_status mgs_term_topo_eval(mgs_morse_ctx *ctx, const mgs_gaussians *g, double *loss,
                              double *short_persistence, mgs_error *err);

#ifdef __cplusplus
}
#endif
#endif

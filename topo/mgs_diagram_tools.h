/* Tools over persistence diagrams (topo/mgs_diagram.h): distances between diagrams,
 * queries (top-k, Betti numbers at a level, total persistence, filters) and file I/O
 * (GUDHI-style text, JSON with cell positions). Plots live in topo/mgs_diagram_plot.h.
 *
 * Conventions shared by every function here:
 *  - `dim` selects one homology dimension (0, 1, 2); MGS_DIM_ALL means every dimension
 *    (distances then combine per-dimension values: max for bottleneck, (Σ W_p^p)^(1/p)
 *    for Wasserstein — points are only ever matched within their own dimension).
 *  - A pair with an infinite end is *essential*. Essential pairs are matched only among
 *    themselves, by their finite coordinate (sorted order, optimal in 1D); when the two
 *    diagrams have different numbers of essential classes (per dimension and kind:
 *    death = +inf or death = -inf) the distance is INFINITY.
 *  - The ground metric between finite points is L_q (`internal_p` = q; INFINITY gives L∞,
 *    the default of GUDHI, persim and hera); a point's distance to the diagonal is the
 *    L_q distance to its orthogonal projection: |death − birth| / 2 · 2^(1/q). */
#ifndef MGS_DIAGRAM_TOOLS_H
#define MGS_DIAGRAM_TOOLS_H
#include <stddef.h>
#include "topo/mgs_diagram.h"

#ifdef __cplusplus
extern "C" {
#endif

#define MGS_DIM_ALL (-1)

/* ---------------------------------------------------------------- distances */

/* Exact bottleneck distance (L∞ ground metric, as gudhi.bottleneck_distance with e=0):
 * the smallest r such that a perfect matching of the diagrams augmented with the diagonal
 * projections of the other diagram exists using only edges of length ≤ r, found by binary
 * search over the candidate edge lengths (or, for n·m > 4e6 candidates, by bisection over
 * the bit patterns of doubles, which lands on the same exact value) with Hopcroft–Karp
 * matching at each step. */
mgs_status mgs_diagram_bottleneck(const mgs_diagram *a, const mgs_diagram *b, int dim,
                                  double *out, mgs_error *err);

/* Order-p Wasserstein distance with L_q ground metric (q = internal_p, ≥ 1 or INFINITY),
 * p ≥ 1; p = INFINITY gives the bottleneck distance. Exact (Hungarian algorithm on the
 * (n+m)×(n+m) augmented cost matrix) while n+m ≤ MGS_WASSERSTEIN_EXACT_MAX per dimension.
 * Beyond that limit the smallest-persistence points of both diagrams are matched to the
 * diagonal until the rest fits; the result is then approximate and *error_bound (if
 * non-NULL) receives a rigorous bound on |result − exact| (by the triangle inequality:
 * the Wasserstein distances of each diagram to its truncation); it is 0 when exact.
 * Cost: O((n+m)^3) time and 8(n+m)^2 bytes; n+m = 2000 takes ~5 s of one core. */
#define MGS_WASSERSTEIN_EXACT_MAX 2000
mgs_status mgs_diagram_wasserstein(const mgs_diagram *a, const mgs_diagram *b, int dim,
                                   double p, double internal_p, double *out,
                                   double *error_bound, mgs_error *err);

/* Same distances on bare point arrays (births[i], deaths[i]) of one dimension; used by
 * the functions above and by tests. force_bisect=1 selects the bit-bisection search. */
double mgs_bottleneck_points(const double *ba, const double *da, size_t na,
                             const double *bb, const double *db, size_t nb, int force_bisect);
double mgs_wasserstein_points(const double *ba, const double *da, size_t na,
                              const double *bb, const double *db, size_t nb,
                              double p, double internal_p, double *error_bound);
/* Same with another exact-size limit (tests of the approximation on small inputs). */
double mgs_wasserstein_points_limit(const double *ba, const double *da, size_t na,
                                    const double *bb, const double *db, size_t nb,
                                    double p, double internal_p, size_t exact_max,
                                    double *error_bound);

/* ---------------------------------------------------------------- queries */

/* Indices (into d->pairs) of the k most persistent pairs of dimension `dim`, most
 * persistent first (essential classes count as infinitely persistent; ties by birth).
 * idx must hold k entries; returns how many were written (≤ k). */
size_t mgs_diagram_top_k(const mgs_diagram *d, int dim, size_t k, size_t *idx);

/* Betti numbers at level t: the number of classes with birth ≤ t < death, per
 * dimension 0..2 (for a superlevel diagram stored negated-back, pass the negated level
 * and a negated diagram, or use mgs_diagram_betti_superlevel). */
void mgs_diagram_betti(const mgs_diagram *d, double t, int betti[3]);
/* The same, counting only classes whose persistence exceeds min_persistence (the Betti
 * numbers "above ε": voxel-scale noise left out). */
void mgs_diagram_betti_persistent(const mgs_diagram *d, double t, double min_persistence, int betti[3]);
/* Superlevel form: classes with death < t ≤ birth (births above deaths). */
void mgs_diagram_betti_superlevel(const mgs_diagram *d, double t, int betti[3]);

/* Σ persistence^q over finite pairs of `dim` whose persistence is < threshold
 * (threshold = INFINITY: all finite pairs). Persistence is |death − birth|. */
double mgs_diagram_total_persistence(const mgs_diagram *d, int dim, double q, double threshold);

/* A pair filter: every bound is inclusive; unset bounds are ±INFINITY after init. */
typedef struct mgs_diagram_filter {
  int dim;                         /* MGS_DIM_ALL or 0..2 */
  double min_persistence, max_persistence; /* on |death − birth| (essential = INFINITY) */
  double birth_min, birth_max;
  double death_min, death_max;
  int include_essential;           /* 1 (default) keeps essential pairs that pass */
  int use_box;                     /* 1: the chosen end's world position must lie in box */
  int box_end;                     /* 0: birth cell position, 1: death cell position */
  double box_min[3], box_max[3];
} mgs_diagram_filter;

void mgs_diagram_filter_init(mgs_diagram_filter *f);
int mgs_diagram_filter_accepts(const mgs_diagram_filter *f, const mgs_pair *p);
/* Indices of the accepted pairs; *idx is malloc'ed (NULL when none), caller frees. */
mgs_status mgs_diagram_select(const mgs_diagram *d, const mgs_diagram_filter *f,
                              size_t **idx, size_t *n, mgs_error *err);
/* A new diagram holding the accepted pairs (statistics copied). */
mgs_diagram *mgs_diagram_filtered(const mgs_diagram *d, const mgs_diagram_filter *f,
                                  mgs_error *err);
/* Pairs per dimension (0..2) and truncated-bar count. */
void mgs_diagram_counts(const mgs_diagram *d, size_t per_dim[3], size_t *essential,
                        size_t *truncated);

/* ---------------------------------------------------------------- files */

/* GUDHI text layout: one line per pair "dim birth death", death "inf" for essential
 * classes; '#' lines are comments. Written atomically. The reader accepts the same
 * (blank lines and comments skipped, "inf"/"-inf" accepted) and rejects anything else
 * with a message naming the file and line. Cells/positions are not stored in text. */
mgs_status mgs_diagram_write_text(const char *path, const mgs_diagram *d, mgs_error *err);
mgs_status mgs_diagram_read_text(const char *path, mgs_diagram **out, mgs_error *err);

/* JSON: {"format":"morsegs-diagram","version":1,"meta":{...},"stats":{...},
 *  "pairs":[{"dim","birth","death","persistence","truncated",
 *            "birth_cell":{"voxel":[i,j,k],"pos":[x,y,z],"cell":id},
 *            "death_cell":{...} (omitted for essential pairs)}]}
 * Infinite values are written as the strings "inf" / "-inf" (JSON has no infinity).
 * meta_json (may be NULL) must be a JSON object text; it is stored under "meta".
 * Doubles are printed with round-trip precision, so write → read reproduces the diagram. */
mgs_status mgs_diagram_write_json(const char *path, const mgs_diagram *d,
                                  const char *meta_json, mgs_error *err);
mgs_status mgs_diagram_read_json(const char *path, mgs_diagram **out, mgs_error *err);

#ifdef __cplusplus
}
#endif
#endif

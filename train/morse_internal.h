/* The Morse context's insides, shared by morse_analysis.c, morse_gather.c,
 * strategy_morse.c and term_topo.c only. */
#ifndef MGS_MORSE_INTERNAL_H
#define MGS_MORSE_INTERNAL_H
#include "train/mgs_morse.h"
#include <math.h>
#include "topo/mgs_topo_select.h"

typedef struct morse_row {
  int iteration;
  double seconds[6];
  int betti0[3], betti_eps[3];
  size_t pairs, spawned, pruned;
  double topo;
  size_t leaves, leaves_reused;
} morse_row;

struct mgs_morse_ctx {
  int refs;
  mgs_morse_options o;
  const mgs_dataset *ds;
  mgs_morse_result r;
  /* valid in the analysis iteration only (not checkpointed) */
  mgs_vdb_grid *alpha, *sdf;
  mgs_gaussians *sub;          /* the analysed Gaussians (α >= min_alpha) */
  size_t *sub_map;             /* sub index -> model index */
  mgs_topo_components *comp;   /* floaters: components of {d <= 0} */
  int *cam_count;              /* per model Gaussian */
  size_t cam_n;
  /* incremental analyses (o.incremental) */
  struct mgs_vdb_alpha_cache *acache;
  struct mgs_vdb_sdf_cache *scache;
  struct mgs_topo_cache *tcache;
  double h_fixed, diag_fixed;  /* voxel size kept, and the diagonal it was set from */
  /* bookkeeping */
  size_t analyses;
  double seconds_total;
  morse_row *rows;
  size_t n_rows, rows_flushed;
  char *csv_path;
};

#define morse_eps_in_use mgs_morse_eps_in_use

/* Is a pair (values at the analysis) in L_topo's set? Finite, of a selected dimension,
 * shorter than ε_sig, and not shorter than min_bar voxels: a bar below the SDF's own
 * accuracy (sweep: 0.44 voxel on a sphere) is discretization noise, not a feature, and
 * most pairs of a trained model are such (they would dominate the term's cost). */
static inline int morse_in_loss(const mgs_morse_options *o, const mgs_pair *p, double eps_sig, double h) {
  double pe = p->death - p->birth;
  return p->dim >= 0 && p->dim <= 2 && isfinite(p->death) && ((o->dims >> p->dim) & 1u) && pe < eps_sig && pe >= o->min_bar * h;
}

/* Candidate lists: for each of n points, the Gaussians of g (ascending index) whose
 * ellipsoid of `k_sigma` standard deviations contains the point. CSR: start[n+1], idx. */
typedef struct morse_gather {
  size_t n;
  size_t *start, *idx;
} morse_gather;
mgs_status morse_gather_build(const mgs_gaussians *g, const double *pts, size_t n, double k_sigma,
                              morse_gather *out, mgs_error *err);
void morse_gather_free(morse_gather *m);
/* Copies rows idx[0..k) of g into dst (reserved as needed, n = k). */
mgs_status morse_gather_rows(const mgs_gaussians *g, const size_t *idx, size_t k, mgs_gaussians *dst,
                             mgs_error *err);
/* Index of the Gaussian whose mean is nearest to p (brute force), or (size_t)-1. */
size_t morse_nearest_gaussian(const mgs_gaussians *g, const double p[3]);
#endif

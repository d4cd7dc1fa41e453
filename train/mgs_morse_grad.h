/* The α-field of the model at single points, and the derivative of the SDF of {A = τ}
 * with respect to the Gaussian parameters (MorseGS's persistence loss, SPEC §5.2 item 5).
 * This module owns
 *   the point evaluation ........ A(x), ∇A(x) exactly as vdb/alpha_field.cpp rasterizes it
 *                                 (same covariance, low-pass filter, kσ cutoff, opacity)
 *   the spatial index ........... mgs_morse_index: which Gaussians' kσ support reaches x
 *   the closest point ........... Newton along ∇A onto {A = τ}, then Chopp's tangential
 *                                 iteration to the closest point of a voxel centre
 *   the SDF derivative .......... ∂d/∂θ at a voxel whose closest point on {A = τ} is c:
 *                                 ∂d/∂θ = −(∂A(c)/∂θ) / |∇A(c)|   (implicit function
 *                                 theorem; same formula inside (d < 0) and outside)
 *
 * The field. A(x) = Σ αᵢ exp(−½ (x−μᵢ)ᵀ Σ'ᵢ⁻¹ (x−μᵢ)) over the Gaussians with
 * (x−μᵢ)ᵀ Σ'ᵢ⁻¹ (x−μᵢ) ≤ k², αᵢ = sigmoid(opacity logit), Σᵢ = R(q/|q|) S² Rᵀ with
 * S = diag(exp(log_scale)) (log-scales clamped at 300 and a zero quaternion read as the
 * identity, as vdb/), Σ'ᵢ = Σᵢ + f·I with f = the grid's low-pass variance (h/2)² for
 * MGS_VDB_SMALL_PEAK (the default of the SDF builder), 0 for MGS_VDB_SMALL_NONE.
 * MGS_VDB_SMALL_MASS (amplitude depending on Σ) is refused (MGS_ERR_UNSUPPORTED). Not
 * reproduced: vdb/'s cap of std-devs larger than the scene diagonal (such Gaussians are
 * already warned about there) — their derivatives here are those of the uncapped field.
 * Everything is computed in double from the model's floats.
 *
 * Parameters θ and what reaches them (accumulated into a gradient model with the model's n
 * and layout, as the rasterizer's backward): opacity logit, mean, log_scale, rot (the
 * stored, un-normalized quaternion: chained through q/|q| exactly as render/'s backward).
 * The kσ cutoff makes A jump by αᵢ e^{−k²/2} where a support boundary crosses x; that
 * jump is not differentiated (zero measure; the derivative is the one-sided interior one).
 * Where {A = τ} itself runs along such a jump (A steps over τ there; 4 % of the first-ring
 * band voxels of a 10-Gaussian cluster at k = 3, tests/train/test_morse_grad.c) no point
 * has A = τ and the surface moves with the support boundary, which the formula does not
 * describe: mgs_morse_closest_point refuses those voxels (MGS_ERR_NUMERIC) and callers
 * should skip them (or build the grid with a larger k_sigma: the jump is e^{−k²/2}).
 *
 * A flat gradient. Where |∇A(c)| is tiny the surface is not a smooth manifold at c (a
 * saddle or extremum of A touching τ) and the quotient explodes. The denominator is
 * floored at  g_floor = 1e-3 · τ / σ_c,  σ_c the smallest largest-std-dev (filtered) among
 * the Gaussians reaching c: a single Gaussian of amplitude τ has |∇A| ≈ 0.6 τ/σ at 1σ, so
 * the floor is 600× below any regular surface point, and the gradient stays bounded by
 * 1000 σ_c |∂A/∂θ| / τ. Such calls report floored = 1 (mgs_morse_point). No contributing
 * Gaussian at c (A(c) = 0): nothing is added, contributors = 0.
 *
 * Threading: the index is read-only after creation; evaluations may run concurrently,
 * but two calls must not accumulate into the same gradient model at the same time. */
#ifndef MGS_MORSE_GRAD_H
#define MGS_MORSE_GRAD_H
#include <stddef.h>
#include "core/mgs_error.h"
#include "core/mgs_gaussians.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct mgs_morse_field_params {
  double k_sigma;     /* support cutoff, as mgs_vdb_alpha_params.k_sigma (3) */
  double filter_var;  /* f added to every covariance: (h/2)² for the PEAK filter of a grid
                         of voxel size h (mgs_morse_filter_var), 0 = the exact field (0) */
} mgs_morse_field_params;
void mgs_morse_field_params_default(mgs_morse_field_params *p);
/* (h/2)² for MGS_VDB_SMALL_PEAK, 0 for NONE (small_mode as mgs_vdb_small_mode). Returns
 * -1 for MASS (unsupported). */
double mgs_morse_filter_var(double voxel_size, int small_mode);

/* What one point evaluation found. */
typedef struct mgs_morse_point {
  double alpha;         /* A(c) */
  double grad[3];       /* ∇A(c) */
  double grad_norm;     /* |∇A(c)| (the unfloored value) */
  int contributors;     /* Gaussians whose support reaches c */
  int floored;          /* 1: |∇A| was below g_floor and the floor was used */
} mgs_morse_point;

/* A spatial index over the Gaussians' kσ boxes (uniform hash grid, cell ≈ the typical
 * support size; Gaussians spanning many cells sit in a global list). Built once per
 * analysis (O(n log n)); each box is indexed enlarged by 25 % of its half-extent per side,
 * so the index stays exact while the Gaussians move or grow by less than that. Between
 * analyses call mgs_morse_index_update after optimizer steps: O(n) check, rebuild only when
 * the count changed or a support left its indexed box. */
typedef struct mgs_morse_index mgs_morse_index;
mgs_status mgs_morse_index_create(const mgs_gaussians *g, const mgs_morse_field_params *p,
                                  mgs_morse_index **out, mgs_error *err);
void mgs_morse_index_destroy(mgs_morse_index *ix);
size_t mgs_morse_index_count(const mgs_morse_index *ix); /* the model's n it was built for */
/* Keeps *ix exact for the current g (same parameters): rebuilds it (replacing *ix) when g's
 * count differs or a support box escaped its padded box; *rebuilt (may be NULL) says so. */
mgs_status mgs_morse_index_update(mgs_morse_index **ix, const mgs_gaussians *g, int *rebuilt,
                                  mgs_error *err);

/* A(x) and ∇A(x) (grad may be NULL). ix may be NULL: brute-force scan over g (p NULL =
 * defaults). With an index, p is the index's. */
mgs_status mgs_morse_alpha_at(const mgs_gaussians *g, const mgs_morse_index *ix,
                              const mgs_morse_field_params *p, const double x[3], double *alpha,
                              double grad[3], mgs_error *err);

/* Projection of x onto {A = τ}: damped Newton steps along ∇A (not the closest point
 * where the surface curves; cheaper). MGS_ERR_NUMERIC in a flat region. */
mgs_status mgs_morse_project(const mgs_gaussians *g, const mgs_morse_index *ix,
                             const mgs_morse_field_params *p, const double x[3], float tau,
                             double c[3], mgs_error *err);
/* Closest point c of x on {A = τ}: Newton steps along ∇A from x onto the surface (the
 * projection), then Chopp's iteration (tangential move toward x, re-projection) until the
 * tangential residual vanishes, polished by Newton on the optimality conditions
 * (x − c ∥ ∇A(c), A(c) = τ) to ~1e-12 relative. *d_out (may be NULL): the signed distance of x, −|x−c| where
 * A(x) > τ. Fails with MGS_ERR_NUMERIC when the iteration reaches a flat region
 * (|∇A| ~ 0, A far from τ) or does not converge in 100 steps. */
mgs_status mgs_morse_closest_point(const mgs_gaussians *g, const mgs_morse_index *ix,
                                   const mgs_morse_field_params *p, const double x[3], float tau,
                                   double c[3], double *d_out, mgs_error *err);

/* Accumulates weight · ∂d/∂θ into grad (the model's n, same layout; grad may be NULL when
 * weight is 0: the value only; groups other than
 * mean, log_scale, rot and opacity untouched), d the SDF at a voxel whose closest point
 * on {A = τ} is c. *alpha_out (may be NULL) = A(c). Brute-force over all Gaussians, the
 * exact field (filter_var 0, k_sigma 3): for a grid built with a low-pass filter use the
 * index variant with the grid's parameters. */
mgs_status mgs_morse_sdf_point_grad(const mgs_gaussians *g, const double c[3], float tau,
                                    double weight, mgs_gaussians *grad, double *alpha_out,
                                    mgs_error *err);
/* The same derivative in one pass, for callers that learn the weight only after the
 * value: writes ∂A(c)/∂θ into unit (g's n rows; mean, log_scale, rot and opacity of EVERY
 * row overwritten, 0 where the support does not reach c) and *den_out = the normal length
 * the derivative divides by (|∇A(c)|, or its floor as above). weight · ∂d/∂θ is then
 * (−weight / den) · unit: what mgs_morse_sdf_point_grad adds, up to one float rounding. */
mgs_status mgs_morse_sdf_point_unit_grad(const mgs_gaussians *g, const double c[3], float tau, mgs_gaussians *unit,
                                         mgs_morse_point *pt, double *den_out, mgs_error *err);
/* The same through an index built from g (MGS_ERR_ARG if its count differs); *pt (may be
 * NULL) receives A, ∇A, the contributor count and the floor flag. */
mgs_status mgs_morse_sdf_point_grad_ix(const mgs_gaussians *g, const mgs_morse_index *ix,
                                       const double c[3], float tau, double weight,
                                       mgs_gaussians *grad, mgs_morse_point *pt, mgs_error *err);

#ifdef __cplusplus
}
#endif
#endif

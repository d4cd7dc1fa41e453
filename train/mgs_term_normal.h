/* MorseGS's normal-consistency loss (seed 000 §3.5, SPEC §5.2 item 7) as a loss term
 * (train/mgs_term.h):
 *
 *   L = γ / N · Σᵢ (1 − hᵢ),   hᵢ = Σₖ wᵢₖ rᵢₖᵀ Tᵢ rᵢₖ / tr Tᵢ,   wᵢₖ = sᵢₖ^(−2p) / Σⱼ sᵢⱼ^(−2p)
 *
 * rᵢₖ the local axes of Gaussian i (columns of R(q/|q|)), sᵢₖ its scales, N the model's
 * count, and Tᵢ the structure tensor of ∇d at μᵢ: the trilinear blend of ∇d∇dᵀ at the 8
 * voxels around μᵢ (each voxel's central difference), from an SDF grid held fixed between
 * analyses. Where ∇d is smooth, T = ∇d∇dᵀ and hᵢ = Σₖ wᵢₖ (rᵢₖ·∇d/|∇d|)², the seed's
 * |nᵢ·∇d|² with a soft shortest axis (below). Why the tensor: the Gaussians of a trained
 * surface sit in the middle of a thin shell {A > τ}, i.e. on the medial sheet of the SDF,
 * where ∇d flips sign across a voxel and the interpolated gradient cancels to ~0 (measured
 * in tests/train/test_normal_loss.c: on a shell of 1500 flat Gaussians at r = 64, the
 * interpolated |∇d(μ)| averages 0.28 and is below 0.5 at every mean);
 * ∇d∇dᵀ does not flip, so the direction survives (the loss only needs it up to sign).
 *
 * The soft shortest axis: nᵢ is replaced by a weighting of the three axes by their inverse
 * variance (p = 1: Σₖ wₖ rₖrₖᵀ = Σ⁻¹ / tr Σ⁻¹). For a flat Gaussian (scales 10:10:1)
 * w_short = 0.98, so it is the seed's term within 2 %; it is smooth where the argmin is not
 * (the seed's form has no gradient w.r.t. scale and jumps when two scales cross), and for
 * two equal smallest scales it is defined as the mean of the two axes' alignments. Its
 * scale gradient flattens Gaussians across ∇d. The 1/N makes γ independent of the model
 * size (the seed writes Σᵢ; γ_seed = γ/N).
 *
 * Gradients: rotation (through q/|q|) and log-scale. Not the mean: the field is fixed
 * between analyses and its sampling position is not differentiated (that would be the
 * SDF's third derivatives through T, noise at voxel scale). Gaussians where tr T < 0.05
 * (outside the narrow band, where the grid is constant) are left out of the sum.
 *
 * The SDF: handed in by an analysis (mgs_term_normal_set_sdf, e.g. the Morse strategy's,
 * every K iterations), or, when the term runs alone, built by the term itself from the
 * model every `every` iterations through vdb/ (α-field at resolution r of the means'
 * diagonal, SDF of {A = τ}). Its grid is part of the checkpointed state. */
#ifndef MGS_TERM_NORMAL_H
#define MGS_TERM_NORMAL_H
#include "core/mgs_error.h"
#include "core/mgs_gaussians.h"
#include "train/mgs_term.h"
#include "vdb/mgs_vdb.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct mgs_normal_options {
  double gamma;       /* weight γ (0.02; seed range 0.01–0.05) */
  int from_iter;      /* first iteration the term runs (3000: the seed's warm-up W) */
  int until_iter;     /* last iteration (0 = to the end) */
  int every;          /* standalone: rebuild the SDF from the model every K iterations when no
                         newer grid was handed in (500; 0 = only grids handed in) */
  int resolution;     /* standalone SDF: voxels along the means' bounding-box diagonal (128) */
  double tau;         /* standalone SDF: iso value of {A = τ} (0.5) */
  int half_width;     /* standalone SDF: band half-width in voxels (3) */
  double sharpness;   /* p of the axis weights (1; larger approaches the hard argmin) */
} mgs_normal_options;
void mgs_normal_options_default(mgs_normal_options *o);
/* One-line MGS_ERR_ARG naming the option and its range. */
mgs_status mgs_normal_options_check(const mgs_normal_options *o, mgs_error *err);

/* The loss alone: T[n*6] = the tensor Tᵢ at each mean (xx, xy, xz, yy, yz, zz; rows with
 * tr T < 0.05 are skipped). *value = weight/N Σ (1 − hᵢ); grad (may be NULL) += ∂value/∂θ
 * (rot, log_scale). *used (may be NULL) = Gaussians in the sum. */
mgs_status mgs_normal_loss(const mgs_gaussians *g, const float *T, double sharpness, double weight,
                           mgs_gaussians *grad, double *value, size_t *used, mgs_error *err);
/* Tᵢ from an SDF grid at the means (n*6 floats). */
void mgs_normal_tensors(const mgs_vdb_grid *sdf, const mgs_gaussians *g, float *T);

typedef struct mgs_normal_term mgs_normal_term;
/* A term for mgs_trainer_add_term; *handle (may be NULL) stays valid while the term lives
 * (the trainer owns the term). */
mgs_status mgs_term_normal_create(const mgs_normal_options *o, mgs_term **out, mgs_normal_term **handle,
                                  mgs_error *err);
/* Hands the term the SDF of an analysis made at `iteration` (deep-copied; LEVEL_SET grid). */
mgs_status mgs_term_normal_set_sdf(mgs_normal_term *t, const mgs_vdb_grid *sdf, int iteration, mgs_error *err);
/* Where the term takes its SDF from when an analysis runs beside it (MorseGS-Full: the
 * Morse analysis' grid, issue 14 item 5): called every iteration the term runs; a grid
 * made at another iteration than the one in use is copied in. With a source the term
 * builds no grid of its own. fn returns NULL while there is none. */
typedef const mgs_vdb_grid *(*mgs_normal_sdf_source)(void *user, int *iteration);
void mgs_term_normal_set_source(mgs_normal_term *t, mgs_normal_sdf_source fn, void *user);
/* The grid in use (NULL before the first), the iteration it was made at, builds made. */
const mgs_vdb_grid *mgs_term_normal_sdf(const mgs_normal_term *t, int *iteration, int *builds);

#ifdef __cplusplus
}
#endif
#endif

/* SuGaR (Guédon & Lepetit 2024; Anttwo/SuGaR, the coarse stage `-r sdf` and its mesh):
 * this header owns
 *   the density and ideal SDF of a model .... mgs_sugar_field (train/sugar_field.c)
 *   the losses of the coarse stage .......... mgs_sugar_*_loss (train/sugar_loss.c)
 *   the loss term of `--preset sugar` ....... mgs_term_sugar_create (train/term_sugar.c)
 *   the strategy (ADC, then one prune) ...... mgs_strategy_sugar_create (train/strategy_sugar.c)
 *   the mesh ................................ mgs_sugar_mesh (train/sugar_mesh.c, Poisson:
 *                                             train/mgs_poisson.h)
 *
 * The field, as sugar_model.py's get_field_values (beta_mode 'average'): at a point p,
 * over the k (16) Gaussians nearest to the Gaussian the point belongs to (training) or to
 * the point (meshing),
 *   d(p) = c Σⱼ αⱼ exp(−½ (p−μⱼ)ᵀ Σⱼ⁻¹ (p−μⱼ))        c: density factor (1/16 in training,
 *                                                        1 for the mesh, as the authors)
 *   f(p) = β √(−2 ln d),  β = mean over the k of the smallest scale (the flat Gaussian's
 *                            standard deviation across its plane)
 * f is unsigned (the authors' value; its sign is the side of the surface, which the loss
 * takes from the view: it compares f with |rendered depth − sample depth|). d ≥ 1 counts
 * as inside the surface: f = 0 and no gradient (the authors divide d by its detached value
 * there). d is clamped below at 1e-16 (the authors' opacity_min_clamp): f ≤ 8.6 β.
 * The normal of a Gaussian is its shortest axis (get_smallest_axis); the normal of the
 * field is −∇d/|∇d| (the mesh's normals, compute_level_surface_points_from_camera_fast).
 *
 * Points and means are in the model's local frame (mgs_gaussians.origin). */
#ifndef MGS_SUGAR_H
#define MGS_SUGAR_H
#include <stddef.h>
#include <stdint.h>
#include "core/mgs_error.h"
#include "core/mgs_gaussians.h"
#include "core/mgs_dataset.h"
#include "core/mgs_mesh.h"
#include "train/mgs_strategy.h"
#include "train/mgs_term.h"

#ifdef __cplusplus
extern "C" {
#endif

#define MGS_SUGAR_KNN 16

/* ---- the field ------------------------------------------------------------------------ */

typedef struct mgs_sugar_value {
  double density; /* d(p) */
  double sdf;     /* f(p) >= 0 */
  double beta;    /* β */
  double grad[3]; /* ∇ₚd */
} mgs_sugar_value;

/* The field at p from the Gaussians nb[0..k). */
void mgs_sugar_field(const mgs_gaussians *g, const double p[3], const uint32_t *nb, int k, double factor,
                     mgs_sugar_value *v);
/* Shortest axis of Gaussian i (unit, world = local orientation). */
void mgs_sugar_gaussian_normal(const mgs_gaussians *g, size_t i, double n[3]);
/* The k nearest means of every Gaussian, itself first: *idx malloc'd (n * *k_used,
 * k_used = min(k, n)). */
mgs_status mgs_sugar_knn(const mgs_gaussians *g, int k, uint32_t **idx, int *k_used, mgs_error *err);
/* The k nearest means of each of m points p[3m] (idx: m*k, k <= g->n). */
mgs_status mgs_sugar_knn_points(const mgs_gaussians *g, const double *p, size_t m, int k, uint32_t *idx,
                                mgs_error *err);

/* ---- the losses of the coarse stage (each: value out, grad += ∂value/∂θ; grad may be
 *      NULL) ------------------------------------------------------------------------------ */

/* A sample near the surface: a point drawn in Gaussian `gauss` and |D − z|, the distance
 * along the view's axis between the rendered depth at its pixel and its own depth (the
 * authors' SDF estimate). */
typedef struct mgs_sugar_sample {
  double p[3];
  uint32_t gauss;
  double target;
} mgs_sugar_sample;

/* The SDF loss: w / (m σ) Σᵢ |f(pᵢ) − targetᵢ|, f over knn[gauss*k ..] (σ: the authors'
 * extent/10). Gradient through f: means, scales, rotations, opacities of the neighbours
 * (the samples and targets are held fixed: see train/term_sugar.c). */
mgs_status mgs_sugar_sdf_loss(const mgs_gaussians *g, const uint32_t *knn, int k, const mgs_sugar_sample *s,
                              size_t m, double factor, double sigma, double w, mgs_gaussians *grad, double *value,
                              mgs_error *err);
/* The normal loss ("sdf_better_normal"): per sample, the neighbours' normals nⱼ, flipped
 * to the sampled Gaussian's n_g, weighted by wⱼ ∝ c αⱼ exp(−½ qⱼ(p)) |(p−μⱼ)·nⱼ| / sminⱼ²
 * (normalized by max(Σ, 1e-6)): w/m Σᵢ |n_g − Σⱼ wⱼ nⱼ|². The weights are constants of
 * the loss (the authors detach them): the gradient goes through the normals only
 * (rotations). weights (m*k, the flip's sign included; NULL: computed) replaces them,
 * weights_out (NULL: not) receives those used — the finite-difference check's handle. */
mgs_status mgs_sugar_normal_loss(const mgs_gaussians *g, const uint32_t *knn, int k, const mgs_sugar_sample *s,
                                 size_t m, double factor, const double *weights, double *weights_out, double w,
                                 mgs_gaussians *grad, double *value, mgs_error *err);
/* The opacity entropy: w · mean over Gaussians with radii[i] > 0 (all when radii is NULL)
 * of −α ln(α + 1e-10) − (1 − α) ln(1 − α + 1e-10). */
mgs_status mgs_sugar_entropy_loss(const mgs_gaussians *g, const int *radii, double w, mgs_gaussians *grad,
                                  double *value, mgs_error *err);

/* ---- the coarse stage in the trainer --------------------------------------------------- */

typedef struct mgs_sugar_options {
  int from_iter;        /* 7000: the 3DGS model the stage starts from; entropy after it */
  int prune_at;         /* 9000: α < prune_alpha pruned; entropy until it, SDF losses after */
  double prune_alpha;   /* 0.5 */
  double entropy;       /* 0.1 */
  double sdf_weight;    /* 0.2 (the authors' estimation_factor) */
  double normal_weight; /* 0.2 (normal_factor) */
  int samples;          /* samples per iteration (the authors 1M; default 20000: CPU) */
  int knn_every;        /* neighbours refreshed every N iterations (500) */
  double density_factor; /* c in training (1/16) */
  double sample_scale;  /* samples μ + R (this · s ⊙ ε) (1.5) */
  double close_sigmas;  /* Gaussians within this many σ of the rendered depth sampled (2) */
} mgs_sugar_options;
void mgs_sugar_options_default(mgs_sugar_options *o);
/* The term: entropy (from_iter, prune_at), SDF and normal losses after prune_at. */
mgs_status mgs_term_sugar_create(const mgs_sugar_options *o, mgs_term **out, mgs_error *err);
/* ADC (options a) as the reference until a->densify_until, and one prune of α <
 * prune_alpha at o->prune_at. */
mgs_status mgs_strategy_sugar_create(const mgs_adc_options *a, const mgs_sugar_options *o, mgs_strategy **out,
                                     mgs_error *err);

/* ---- the mesh (sugar_extractors/coarse_mesh.py) ---------------------------------------- */

typedef struct mgs_sugar_mesh_options {
  double level;          /* 0.3: the density level crossed along the rays */
  int points_per_view;   /* crossing points kept per training view (0: all pixels) */
  int range_points;      /* samples along a ray around the rendered depth (21) */
  double range_sigmas;   /* ± this many σ of the hit Gaussian along the ray (3) */
  double prune_alpha;    /* Gaussians with α below this are left out first (0.5) */
  double trim_quantile;  /* vertices of the lowest this quantile of point density removed
                            (0.1) */
  size_t max_triangles;  /* decimation target (200000; 0 = none) */
  uint64_t seed;
} mgs_sugar_mesh_options;
void mgs_sugar_mesh_options_default(mgs_sugar_mesh_options *o);
typedef struct mgs_sugar_mesh_stats {
  size_t points, poisson_vertices, poisson_triangles, trimmed_vertices, triangles;
} mgs_sugar_mesh_stats;
/* Level crossings of d (factor 1) along the rays of `views` (their rendered median depth),
 * with normals −∇d; then Poisson reconstruction, trimming and decimation
 * (train/mgs_poisson.h). `views`: cameras in the model's local frame (as a dataset's;
 * cameras.json minus the origin). *out: the mesh in world coordinates (origin added). */
mgs_status mgs_sugar_mesh(const mgs_gaussians *g, const mgs_camera *views, size_t n_views,
                          const mgs_sugar_mesh_options *o, mgs_mesh **out, mgs_sugar_mesh_stats *stats,
                          mgs_error *err);
/* A run's SuGaR mesh beside its other exports (train/sugar_export.c): the model of
 * `iteration` (-1: the latest) at the run's training cameras -> RUN/mesh/sugar.ply, and
 * its signed distance as an OpenVDB level set RUN/mesh/sugar.vdb (grid `sdf`, meshToLevelSet
 * of vdb/mgs_vdb_mesh_sdf.h; voxel = the mesh's bounding-box diagonal / resolution, band
 * ±3 voxels). Existing outputs are refused unless `force`. */
typedef struct mgs_sugar_export_report {
  int iteration;
  size_t views;
  mgs_sugar_mesh_stats mesh;
  double voxel_size;
  size_t active_voxels;
  double seconds;
  char ply[4096], vdb[4096];
} mgs_sugar_export_report;
mgs_status mgs_sugar_export_run(const char *run_dir, int iteration, const mgs_sugar_mesh_options *o, int resolution,
                                int force, mgs_sugar_export_report *rep, mgs_error *err);
/* The crossings alone (points/normals malloc'd, 3 * *n each, local frame). */
mgs_status mgs_sugar_level_points(const mgs_gaussians *g, const mgs_camera *views, size_t n_views,
                                  const mgs_sugar_mesh_options *o, double **points, double **normals, size_t *n,
                                  mgs_error *err);

#ifdef __cplusplus
}
#endif
#endif

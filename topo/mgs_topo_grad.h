/* The gradient hook of the persistence regularizer (SPEC §5.2 item 5, §6): topological
 * losses on a diagram with their gradients w.r.t. each pair's birth and death, and the
 * map of those gradients to the field (Brüel-Gabrielsson et al. 2020): a bar end's value
 * IS the field value at one voxel (mgs_pair_end.voxel), so dL/d(field at that voxel) +=
 * dL/d(end). Everything downstream (SDF → α-field → Gaussians) is the caller's chain rule.
 *
 * Clamp: the engine filters the field clamped to [−w, w]; an end whose value is at the
 * clamp (|value| ≥ w) was set by the clamp, whose derivative is 0 there, so it contributes
 * nothing (pass clamp_w = INFINITY to map every end). Essential deaths (infinite) never
 * receive gradient. */
#ifndef MGS_TOPO_GRAD_H
#define MGS_TOPO_GRAD_H
#include <stddef.h>
#include <stdint.h>
#include "topo/mgs_diagram.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum mgs_topo_loss_kind {
  /* default: Σ over finite pairs with p < ε_sig of p² (p = death − birth): its gradient
   * shortens the short bars, i.e. drives low-persistence features to zero persistence */
  MGS_TOPO_LOSS_ELIMINATE = 0,
  /* the seed's formula as printed: Σ max(0, ε_sig − p)², whose gradient LENGTHENS short
   * bars (largest for the shortest); provided to measure what it does */
  MGS_TOPO_LOSS_LITERAL = 1
} mgs_topo_loss_kind;

/* Loss value over the pairs whose dimension bit is set in dim_mask (bit k = dimension k;
 * 0x7 = all); essential pairs are skipped. dL_dbirth / dL_ddeath (length d->n, may be
 * NULL) are OVERWRITTEN with the gradient (0 for pairs outside the loss). The eliminate
 * loss is discontinuous at p = ε_sig (the term drops from ε² to 0): the gradient is the
 * one-sided derivative of the branch the pair is on. */
double mgs_topo_loss(const mgs_diagram *d, mgs_topo_loss_kind kind, double eps_sig,
                     unsigned dim_mask, double *dL_dbirth, double *dL_ddeath);

/* A sparse per-voxel gradient: one entry per distinct voxel, sorted by (x, y, z). */
typedef struct mgs_voxel_grad {
  int32_t ijk[3];
  double grad;
} mgs_voxel_grad;

/* Accumulates dL/d(field) per voxel from per-pair gradients (either array may be NULL =
 * zero). Entries with exactly zero total are dropped. *out is malloc'ed (free()). */
mgs_status mgs_topo_grad_to_voxels(const mgs_diagram *d, const double *dL_dbirth,
                                   const double *dL_ddeath, double clamp_w,
                                   mgs_voxel_grad **out, size_t *n_out, mgs_error *err);

/* Same, accumulated (+=) into a dense array of dims[0]*dims[1]*dims[2] doubles laid out as
 * the engine's dense input, grad[(x*ny + y)*nz + z] for voxel origin + (x,y,z). A voxel
 * outside the box is an error (MGS_ERR_ARG naming the pair). */
mgs_status mgs_topo_grad_to_dense(const mgs_diagram *d, const double *dL_dbirth,
                                  const double *dL_ddeath, double clamp_w,
                                  const int32_t origin[3], const int32_t dims[3],
                                  double *grad, mgs_error *err);

#ifdef __cplusplus
}
#endif
#endif

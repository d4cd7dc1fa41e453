/* Sparse Adam (as gsplat's SparseAdam / Taming 3DGS): a step updates only the Gaussians
 * the view saw (screen radius > 0); the others keep their parameters and moments as they
 * were, instead of decaying their moments and drifting on momentum as torch.optim.Adam in
 * the reference does. Each group's bias correction still uses its global step count. The
 * cost of a step then follows what the view sees, not the size of the scene. This file
 * is the separate step (gradients in arrays); the step fused with the backward is
 * mgs_adam_step_backward_sparse (train/adam_backward.c). */
#include <math.h>
#include <stdatomic.h>
#include <string.h>
#include "train/mgs_train.h"
#include "train/adam_internal.h"
#include "core/mgs_parallel.h"

typedef struct sparse_ctx {
  mgs_adam_group grp[MGS_PARAM_COUNT];
  int n_grp;
  const int *radii;
  int zero_grad;
  atomic_int bad; /* bit k: group k had a non-finite value */
} sparse_ctx;

static void sparse_rows(void *vc, size_t b, size_t e) {
  sparse_ctx *c = vc;
  int bad = 0;
  for (size_t i = b; i < e; i++) {
    if (c->radii[i] <= 0) continue;
    for (int k = 0; k < c->n_grp; k++) {
      const mgs_adam_group *gp = &c->grp[k];
      size_t o = i * gp->row;
      int rb = mgs_adam_span(gp, o, o + gp->used);
      if (rb) bad |= 1 << k;
      else if (c->zero_grad) memset(gp->g + o, 0, gp->used * sizeof(float));
    }
  }
  if (bad) atomic_fetch_or(&c->bad, bad);
}

mgs_status mgs_adam_step_sparse(mgs_adam *a, mgs_gaussians *model, mgs_gaussians *grad, unsigned group_mask,
                                const int *radii, int zero_grad, mgs_error *err) {
  if (!radii) return mgs_error_set(err, MGS_ERR_ARG, "adam: sparse step without radii");
  if (a->n != model->n || grad->n != model->n)
    return mgs_error_set(err, MGS_ERR_ARG, "adam: %zu moments for %zu Gaussians (%zu gradients)", a->n, model->n, grad->n);
  sparse_ctx c;
  memset(&c, 0, sizeof c);
  c.radii = radii;
  c.zero_grad = zero_grad;
  atomic_init(&c.bad, 0);
  int gid[MGS_PARAM_COUNT];
  c.n_grp = mgs_adam_prepare(a, model, grad, group_mask, c.grp, gid);
  if (c.n_grp) mgs_parallel_for(0, model->n, 2048, sparse_rows, &c);
  int bad = atomic_load(&c.bad);
  for (int k = 0; k < c.n_grp && bad; k++) {
    if (!(bad & (1 << k))) continue;
    const mgs_adam_group *gp = &c.grp[k];
    for (size_t i = 0; i < model->n; i++) {
      if (radii[i] <= 0) continue;
      for (size_t j = 0; j < gp->used; j++) {
        if (!isfinite(gp->g[i * gp->row + j])) return mgs_adam_report((mgs_param_group)gid[k], i, 0, err);
        if (!isfinite(gp->p[i * gp->row + j])) return mgs_adam_report((mgs_param_group)gid[k], i, 1, err);
      }
    }
  }
  return MGS_OK;
}

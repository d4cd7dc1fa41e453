/* Adam's per-group step kernel, shared by the separate step (train/adam.c) and the step
 * fused into the backward (train/adam_backward.c). Internal to train/. */
#ifndef MGS_ADAM_INTERNAL_H
#define MGS_ADAM_INTERNAL_H
#include "train/mgs_train.h"

typedef struct mgs_adam_group {
  float *p, *m, *v, *g;
  float b1, b2, step_size, inv_sqrt_bc2, eps;
  size_t row, used;   /* floats per row, of which the first `used` are updated */
  size_t n_elem;      /* elements (used == row) or rows (partial); mgs_adam_step_zero only */
  size_t unit0;       /* first unit of this group in the global numbering; ditto */
  size_t per_unit;    /* elements or rows per unit; ditto */
  int packed;         /* m holds bfloat16 (m, v) words (mgs_adam.sh_rest_bf16), v unused */
  uint32_t seed;      /* packed: this step's rounding seed */
  size_t elem0;       /* packed: element index of p[0] in the group (the rounding hash's) */
} mgs_adam_group;

/* One step's constants for every group of group_mask that has something to update
 * (advances their step counts; grad may be NULL: g left NULL). Fills grp[0..k) and
 * gid[0..k) (the group of each), returns k. */
int mgs_adam_prepare(mgs_adam *a, mgs_gaussians *model, mgs_gaussians *grad, unsigned group_mask,
                     mgs_adam_group grp[MGS_PARAM_COUNT], int gid[MGS_PARAM_COUNT]);
/* Steps elements [b, e) of c's arrays; nonzero when a gradient or a result is not finite. */
int mgs_adam_span(const mgs_adam_group *c, size_t b, size_t e);
/* MGS_ERR_NUMERIC naming the group and the Gaussian: its gradient (value = 0) or its
 * updated value (value = 1) is not finite. */
mgs_status mgs_adam_report(mgs_param_group group, size_t gaussian, int value, mgs_error *err);
#endif

/* One Gaussian of the model in its local frame, in double: the pieces the α-field's point
 * derivatives (train/morse_grad.c) and the normal loss (train/term_normal.c) share, and
 * the chain from ∂/∂R to the stored (un-normalized) quaternion as render/'s backward
 * does it. Internal to train/. */
#ifndef MGS_TRAIN_GAUSS_LOCAL_H
#define MGS_TRAIN_GAUSS_LOCAL_H
#include <math.h>
#include "core/mgs_gaussians.h"
#include "core/mgs_math.h"

typedef struct mgs_gauss_local {
  double mu[3];
  double qhat[4], qnorm;  /* normalized quaternion and |q| (identity, |q| = 0 for a zero q) */
  double R[9];            /* row-major; column k = local axis k in world space */
  double s2[3];           /* exp(2 log_scale), log_scale clamped at 300 as vdb/ */
  int ls_clamped[3];      /* 1: log_scale > 300 (derivative 0) */
  double alpha;           /* sigmoid(logit) */
} mgs_gauss_local;

/* The rotation part alone (qnorm, qhat, R): for readers that need no mean, scale or
   opacity (the normal loss). */
static inline void mgs_gauss_local_rotation(const mgs_gaussians *g, size_t i, mgs_gauss_local *o) {
  const float *q = g->rot + 4 * i;
  double n = sqrt((double)q[0] * q[0] + (double)q[1] * q[1] + (double)q[2] * q[2] + (double)q[3] * q[3]);
  o->qnorm = n;
  if (n > 0)
    for (int k = 0; k < 4; k++) o->qhat[k] = q[k] / n;
  else {
    o->qhat[0] = 1;
    o->qhat[1] = o->qhat[2] = o->qhat[3] = 0;
  }
  mgs_quat_to_mat3d(o->qhat, o->R);
}

static inline void mgs_gauss_local_get(const mgs_gaussians *g, size_t i, mgs_gauss_local *o) {
  for (int k = 0; k < 3; k++) o->mu[k] = g->mean[3 * i + k];
  mgs_gauss_local_rotation(g, i, o);
  for (int k = 0; k < 3; k++) {
    double ls = g->log_scale[3 * i + k];
    o->ls_clamped[k] = ls > 300.0;
    double s = exp(ls > 300.0 ? 300.0 : ls);
    o->s2[k] = s * s;
  }
  o->alpha = 1.0 / (1.0 + exp(-(double)g->opacity[i]));
}

/* ∂L/∂q (stored quaternion) from ∂L/∂R (row-major, R = R(q/|q|)): the derivative of
 * build_rotation, then the projection of the normalization (q̂ (q̂·g) removed, / |q|).
 * A zero quaternion (identity by convention) gets no gradient. */
static inline void mgs_gauss_local_dq(const mgs_gauss_local *o, const double dR[9], double dq[4]) {
  if (!(o->qnorm > 0)) {
    dq[0] = dq[1] = dq[2] = dq[3] = 0;
    return;
  }
  const double w = o->qhat[0], x = o->qhat[1], y = o->qhat[2], z = o->qhat[3];
  double gq[4];
  gq[0] = 2 * (-z * dR[1] + y * dR[2] + z * dR[3] - x * dR[5] - y * dR[6] + x * dR[7]);
  gq[1] = 2 * (y * dR[1] + z * dR[2] + y * dR[3] - 2 * x * dR[4] - w * dR[5] + z * dR[6] + w * dR[7] - 2 * x * dR[8]);
  gq[2] = 2 * (-2 * y * dR[0] + x * dR[1] + w * dR[2] + x * dR[3] + z * dR[5] - w * dR[6] + z * dR[7] - 2 * y * dR[8]);
  gq[3] = 2 * (-2 * z * dR[0] - w * dR[1] + x * dR[2] + w * dR[3] - 2 * z * dR[4] + y * dR[5] + x * dR[6] + y * dR[7]);
  const double qd = w * gq[0] + x * gq[1] + y * gq[2] + z * gq[3];
  for (int k = 0; k < 4; k++) dq[k] = (gq[k] - o->qhat[k] * qd) / o->qnorm;
}
#endif

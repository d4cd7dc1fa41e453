/* TEMPORARY stand-in for the morse-grad branch's mgs_morse_sdf_point_grad (delete at merge;
 * see train/mgs_morse_grad.h). Exact Gaussian sum at c over the Gaussians whose 3σ
 * ellipsoid holds c (brute force over the model); gradients w.r.t. mean, log-scale and
 * opacity logit; rotation gets none here (the real one does). */
#include <math.h>
#include "train/mgs_morse_grad.h"
#include "core/mgs_math.h"

mgs_status mgs_morse_sdf_point_grad(const mgs_gaussians *g, const double c[3], float tau, double weight,
                                    mgs_gaussians *grad, double *alpha_out, mgs_error *err) {
  (void)tau;
  double A = 0, gA[3] = {0, 0, 0};
  /* two passes: the field and its gradient first (|∇A| divides every term) */
  for (int pass = 0; pass < 2; pass++) {
    double inv = 0;
    if (pass == 1) {
      double gn = sqrt(gA[0] * gA[0] + gA[1] * gA[1] + gA[2] * gA[2]);
      if (weight == 0 || !grad) break;
      if (!(gn > 1e-12)) break; /* flat field: no defined normal, no gradient */
      inv = -weight / gn;
    }
    for (size_t i = 0; i < g->n; i++) {
      float R[9];
      mgs_quat_to_mat3f(g->rot + 4 * i, R); /* normalizes */
      double dx[3] = {c[0] - g->mean[3 * i], c[1] - g->mean[3 * i + 1], c[2] - g->mean[3 * i + 2]};
      double y[3], s2[3], q = 0;
      for (int k = 0; k < 3; k++) {
        y[k] = R[k] * dx[0] + R[3 + k] * dx[1] + R[6 + k] * dx[2]; /* Rᵀ dx */
        double s = exp(g->log_scale[3 * i + k]);
        s2[k] = s * s;
        q += y[k] * y[k] / s2[k];
      }
      if (q > 9.0) continue;
      double a = mgs_sigmoidf(g->opacity[i]), e = exp(-0.5 * q), ae = a * e;
      double u[3] = {y[0] / s2[0], y[1] / s2[1], y[2] / s2[2]}, w[3]; /* Σ⁻¹dx in local, then world */
      for (int r = 0; r < 3; r++) w[r] = R[3 * r] * u[0] + R[3 * r + 1] * u[1] + R[3 * r + 2] * u[2];
      if (pass == 0) {
        A += ae;
        for (int k = 0; k < 3; k++) gA[k] -= ae * w[k];
        continue;
      }
      for (int k = 0; k < 3; k++) {
        grad->mean[3 * i + k] += (float)(inv * ae * w[k]);
        grad->log_scale[3 * i + k] += (float)(inv * ae * y[k] * y[k] / s2[k]);
      }
      grad->opacity[i] += (float)(inv * (1 - a) * ae);
    }
  }
  if (alpha_out) *alpha_out = A;
  if (!isfinite(A)) return mgs_error_set(err, MGS_ERR_NUMERIC, "sdf point gradient: α not finite at (%g, %g, %g)", c[0], c[1], c[2]);
  return MGS_OK;
}

/* PLACEHOLDER of the interface agreed with the morse-grad branch (which owns this header
 * and its implementation): at merge, take that branch's version of this file and delete
 * train/morse_grad_tmp.c. Only the one declaration the topological term calls is here. */
#ifndef MGS_MORSE_GRAD_H
#define MGS_MORSE_GRAD_H
#include "core/mgs_error.h"
#include "core/mgs_gaussians.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Accumulates weight * dd/dθ into grad, d the SDF at a voxel whose closest point on
 * {A = τ} is c: dd/dθ = -(dA(c)/dθ) / |∇A(c)| (negative inside), using only the Gaussians
 * whose support reaches c. *alpha_out (may be NULL) = A(c). weight 0: value only. */
mgs_status mgs_morse_sdf_point_grad(const mgs_gaussians *g, const double c[3], float tau, double weight,
                                    mgs_gaussians *grad, double *alpha_out, mgs_error *err);

#ifdef __cplusplus
}
#endif
#endif

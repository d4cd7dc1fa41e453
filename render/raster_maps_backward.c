/* The 3DGS normal map's backward (render/mgs_raster.h, mgs_raster_map_grads). The map is
 * N = sum_i w_i n_i with n_i = s_i R(q_i) e_k(i): the unit axis of Gaussian i's smallest
 * scale, s_i = +-1 turning it towards the camera (render/raster_maps.c). Its gradient
 * reaches the Gaussians two ways:
 *  - through the blending weights w_i = alpha_i T_i, as one more colour channel (no
 *    background term: the map has none): the tile backward adds n_i . dL/dN to each
 *    Gaussian's value seen through the pixel (raster_backward.c), from where the alpha
 *    chain carries it to opacity, screen mean (means) and conic (scales, rotation, means);
 *  - through n_i itself, to the quaternion only (here): the axis index k(i) and the sign
 *    s_i are piecewise constant in the log-scales and the mean, so n_i has no derivative
 *    w.r.t. them where it has one at all; where two smallest scales are equal or the axis
 *    is edge-on to the camera the map jumps and no derivative exists (the gradient is the
 *    one of the side the forward took, as the authors' argmin and sign in autograd). */
#include <string.h>
#include "core/mgs_math.h"
#include "render/raster_internal.h"

void mgs_raster_normal_rot_grad(const mgs_raster *r, size_t i, const float gn[3], float *dq) {
  const float *n = r->map_gnormal + 3 * i, *ls = r->g->log_scale + 3 * i, *q = r->g->rot + 4 * i;
  int k = ls[0] <= ls[1] ? (ls[0] <= ls[2] ? 0 : 2) : (ls[1] <= ls[2] ? 1 : 2);
  /* the sign the forward applied: n = s R e_k, so s = n . (R e_k) */
  float qn2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3];
  if (!(qn2 > 0) || (n[0] == 0 && n[1] == 0 && n[2] == 0)) return; /* identity for a zero quaternion; culled */
  float R[9];
  mgs_quat_to_mat3f(q, R);
  float s = n[0] * R[k] + n[1] * R[3 + k] + n[2] * R[6 + k] < 0 ? -1.0f : 1.0f;
  /* dL/dR (row-major) is s gn in column k, 0 elsewhere; then through the quaternion's
   * rotation matrix and its normalization (as raster_project.c's backward) */
  float dR[9] = {0};
  for (int a = 0; a < 3; a++) dR[3 * a + k] = s * gn[a];
  float iqn = 1.0f / sqrtf(qn2);
  float w = q[0] * iqn, x = q[1] * iqn, y = q[2] * iqn, z = q[3] * iqn;
  float gq[4];
  gq[0] = 2.0f * (-z * dR[1] + y * dR[2] + z * dR[3] - x * dR[5] - y * dR[6] + x * dR[7]);
  gq[1] = 2.0f * (y * dR[1] + z * dR[2] + y * dR[3] - 2.0f * x * dR[4] - w * dR[5] + z * dR[6] + w * dR[7] - 2.0f * x * dR[8]);
  gq[2] = 2.0f * (-2.0f * y * dR[0] + x * dR[1] + w * dR[2] + x * dR[3] + z * dR[5] - w * dR[6] + z * dR[7] - 2.0f * y * dR[8]);
  gq[3] = 2.0f * (-2.0f * z * dR[0] - w * dR[1] + x * dR[2] + w * dR[3] - 2.0f * z * dR[4] + y * dR[5] + x * dR[6] + y * dR[7]);
  float qd = w * gq[0] + x * gq[1] + y * gq[2] + z * gq[3];
  const float qv[4] = {w, x, y, z};
  for (int c = 0; c < 4; c++) dq[c] += (gq[c] - qv[c] * qd) * iqn;
}

mgs_status mgs_raster3d_map_grads(mgs_raster *r, mgs_raster_map_grad *out, mgs_error *err) {
  size_t npix = (size_t)r->width * r->height;
  mgs_status st = mgs_raster_reserve_maps(r, r->n, npix, err);
  if (st != MGS_OK) return st;
  mgs_raster_gauss_normals(r); /* the backward reads the forward's n_i */
  if (!r->map_grad_live) {
    memset(r->map_gnormal_grad, 0, 3 * npix * sizeof(float));
    r->map_grad_live = 1;
  }
  out->depth_median = NULL;
  out->normal = r->map_gnormal_grad;
  out->distortion = NULL;
  return MGS_OK;
}

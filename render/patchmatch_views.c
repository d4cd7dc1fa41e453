/* Which views a reference view is matched against, and whether their depth maps agree
 * with it (render/mgs_patchmatch.h). GaussianPro takes neighbours by frame order (+-1,
 * +-2, ... or a pair file); NeRF-synthetic and COLMAP views are unordered, so neighbours
 * here are chosen by overlap with a baseline-angle weight, as MVSNet's view selection
 * (itself after COLMAP's): a view scores for each reference point it sees, most for a
 * triangulation angle near 5 degrees. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "render/mgs_patchmatch.h"

static void pix_to_world(const mgs_camera *c, double u, double v, double z, double X[3]) {
  double xc = (u - c->cx) / c->fx * z, yc = (v - c->cy) / c->fy * z;
  for (int i = 0; i < 3; i++) X[i] = c->c2w[4 * i] * xc + c->c2w[4 * i + 1] * yc + c->c2w[4 * i + 2] * z + c->c2w[4 * i + 3];
}

/* Projection without the near-plane test (depth returned; <= 0 behind). */
static void world_to_pix(const mgs_camera *c, const double X[3], double *u, double *v, double *z) {
  double p[3];
  for (int i = 0; i < 3; i++) p[i] = c->w2c[4 * i] * X[0] + c->w2c[4 * i + 1] * X[1] + c->w2c[4 * i + 2] * X[2] + c->w2c[4 * i + 3];
  *z = p[2];
  *u = c->fx * p[0] / p[2] + c->cx;
  *v = c->fy * p[1] / p[2] + c->cy;
}

static double angle_weight(double theta_deg) {
  const double t0 = 5.0, s1 = 1.0, s2 = 10.0;
  double s = theta_deg <= t0 ? s1 : s2;
  return exp(-(theta_deg - t0) * (theta_deg - t0) / (2 * s * s));
}

size_t mgs_pm_select_neighbors(const mgs_camera *cams, size_t n, size_t ref, const float *ref_depth, int stride,
                               size_t k, size_t *out) {
  if (!cams || ref >= n || !ref_depth || k == 0 || n < 2) return 0;
  if (stride < 1) stride = 1;
  const mgs_camera *rc = &cams[ref];
  double *score = calloc(n, sizeof *score);
  if (!score) return 0;
  double cr[3] = {rc->c2w[3], rc->c2w[7], rc->c2w[11]};
  for (int y = stride / 2; y < rc->height; y += stride)
    for (int x = stride / 2; x < rc->width; x += stride) {
      float z = ref_depth[(size_t)y * (size_t)rc->width + (size_t)x];
      if (!(z > 0) || !isfinite(z)) continue;
      double X[3];
      pix_to_world(rc, x + 0.5, y + 0.5, z, X);
      double a[3] = {cr[0] - X[0], cr[1] - X[1], cr[2] - X[2]};
      double la = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
      for (size_t j = 0; j < n; j++) {
        if (j == ref) continue;
        const mgs_camera *c = &cams[j];
        double u, v, zs;
        world_to_pix(c, X, &u, &v, &zs);
        if (!(zs > 0) || u < 0 || v < 0 || u >= c->width || v >= c->height) continue;
        double b[3] = {c->c2w[3] - X[0], c->c2w[7] - X[1], c->c2w[11] - X[2]};
        double lb = sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2]);
        double cs = (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]) / (la * lb);
        cs = cs > 1 ? 1 : cs < -1 ? -1 : cs;
        score[j] += angle_weight(acos(cs) * 180.0 / M_PI);
      }
    }
  size_t m = 0;
  while (m < k) {
    size_t best = n;
    for (size_t j = 0; j < n; j++)
      if (j != ref && score[j] > 1e-6 && (best == n || score[j] > score[best])) best = j;
    if (best == n) break;
    out[m++] = best;
    score[best] = 0;
  }
  free(score);
  return m;
}

void mgs_pm_geometric_consistency(const mgs_camera *ref, const float *ref_depth, const mgs_camera *const *src,
                                  const float *const *src_depth, int n_src, float max_px, float max_rel,
                                  uint8_t *count) {
  const int W = ref->width, H = ref->height;
  for (int y = 0; y < H; y++)
    for (int x = 0; x < W; x++) {
      size_t p = (size_t)y * (size_t)W + (size_t)x;
      count[p] = 0;
      float z = ref_depth[p];
      if (!(z > 0) || !isfinite(z)) continue;
      double X[3];
      pix_to_world(ref, x + 0.5, y + 0.5, z, X);
      for (int j = 0; j < n_src; j++) {
        const mgs_camera *c = src[j];
        double u, v, zs;
        world_to_pix(c, X, &u, &v, &zs);
        if (!(zs > 0) || !(u >= 0 && v >= 0 && u < c->width && v < c->height)) continue;
        /* nearest source pixel: bilinear would blend across depth edges */
        int xs = (int)u, ys = (int)v;
        float d2 = src_depth[j][(size_t)ys * (size_t)c->width + (size_t)xs];
        if (!(d2 > 0) || !isfinite(d2)) continue;
        double Y[3], ub, vb, zb;
        pix_to_world(c, u, v, d2, Y);
        world_to_pix(ref, Y, &ub, &vb, &zb);
        double du = ub - (x + 0.5), dv = vb - (y + 0.5);
        if (sqrt(du * du + dv * dv) < max_px && fabs(zb - z) / z < max_rel && count[p] < 255) count[p]++;
      }
    }
}

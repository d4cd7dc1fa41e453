/* Controlled fields made of flat Gaussians (surface elements as a trained model has them):
 * a closed sphere shell with one missing cap, a plate with a through-hole, an open thin
 * tube, and a shell with a floater at a given distance. Header-only (static functions). */
#ifndef MGS_TEST_FLAT_FIELDS_H
#define MGS_TEST_FLAT_FIELDS_H
#include <math.h>
#include <stdlib.h>
#include "core/mgs_core.h"
#include "core/mgs_math.h"

/* Appends a flat Gaussian at p with normal n, tangent std st, normal std sn, opacity a. */
static inline void flat_add(mgs_gaussians *g, const double p[3], const double n_in[3], double st, double sn, double a,
                            float grey) {
  size_t i;
  if (mgs_gaussians_append(g, 1, &i, NULL) != MGS_OK) exit(2);
  double n[3] = {n_in[0], n_in[1], n_in[2]}, t[3], b[3], R[9], q[4];
  mgs_normalize3d(n);
  double e[3] = {fabs(n[0]) < 0.9 ? 1 : 0, fabs(n[0]) < 0.9 ? 0 : 1, 0};
  mgs_cross3d(n, e, t); mgs_normalize3d(t);
  mgs_cross3d(n, t, b);
  for (int r = 0; r < 3; r++) { R[3 * r] = t[r]; R[3 * r + 1] = b[r]; R[3 * r + 2] = n[r]; }
  mgs_mat3_to_quatd(R, q);
  for (int k = 0; k < 3; k++) {
    g->mean[3 * i + k] = (float)p[k];
    g->sh_dc[3 * i + k] = (grey - 0.5f) / MGS_SH_C0;
  }
  for (int k = 0; k < 4; k++) g->rot[4 * i + k] = (float)q[k];
  g->log_scale[3 * i] = g->log_scale[3 * i + 1] = (float)log(st);
  g->log_scale[3 * i + 2] = (float)log(sn);
  g->opacity[i] = mgs_logitf((float)a);
}

/* Sphere of radius R (centre c) sampled with spacing s; the cap within geodesic radius
 * `hole` of +z is left out (hole 0: closed). */
static inline void flat_sphere(mgs_gaussians *g, const double c[3], double R, double s, double hole) {
  size_t n = (size_t)(4 * MGS_PI * R * R / (s * s));
  for (size_t k = 0; k < n; k++) {
    double z = 1 - (2.0 * k + 1) / (double)n, r = sqrt(1 - z * z), ph = k * 2.399963229728653;
    double d[3] = {r * cos(ph), r * sin(ph), z};
    if (hole > 0 && R * acos(fmin(1.0, z)) < hole) continue;
    double p[3] = {c[0] + R * d[0], c[1] + R * d[1], c[2] + R * d[2]};
    flat_add(g, p, d, 0.8 * s, 0.1 * s, 0.9, 0.6f);
  }
}

/* Square plate |x|,|y| <= L/2 in z = 0 with a round hole of radius `hole` at the origin. */
static inline void flat_plate(mgs_gaussians *g, double L, double s, double hole) {
  int m = (int)(L / s);
  double nz[3] = {0, 0, 1};
  for (int i = 0; i <= m; i++)
    for (int j = 0; j <= m; j++) {
      double p[3] = {-L / 2 + i * s, -L / 2 + j * s, 0};
      if (sqrt(p[0] * p[0] + p[1] * p[1]) < hole) continue;
      flat_add(g, p, nz, 0.8 * s, 0.1 * s, 0.9, 0.4f);
    }
}

/* Open tube of radius r along z, length L. */
static inline void flat_tube(mgs_gaussians *g, double r, double L, double s) {
  int nu = (int)(2 * MGS_PI * r / s) + 1, nz = (int)(L / s);
  for (int i = 0; i < nu; i++)
    for (int j = 0; j <= nz; j++) {
      double u = 2 * MGS_PI * i / nu, n[3] = {cos(u), sin(u), 0};
      double p[3] = {r * n[0], r * n[1], -L / 2 + j * s};
      flat_add(g, p, n, 0.8 * s, 0.1 * s, 0.9, 0.5f);
    }
}
#endif

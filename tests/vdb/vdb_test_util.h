/* Shared helpers of the vdb tests: small Gaussian scenes and ray/zero-crossing search. */
#ifndef VDB_TEST_UTIL_H
#define VDB_TEST_UTIL_H
#include <math.h>
#include "core/mgs_gaussians.h"
#include "vdb/mgs_vdb.h"

/* Appends a Gaussian with std-devs s, rotation q (w,x,y,z), opacity alpha. */
static inline void vt_add(mgs_gaussians *g, double x, double y, double z, const double s[3], const double q[4],
                          double alpha) {
  size_t i = 0;
  mgs_gaussians_append(g, 1, &i, NULL);
  g->mean[3 * i] = (float)x; g->mean[3 * i + 1] = (float)y; g->mean[3 * i + 2] = (float)z;
  for (int k = 0; k < 3; k++) g->log_scale[3 * i + k] = (float)log(s[k]);
  for (int k = 0; k < 4; k++) g->rot[4 * i + k] = (float)q[k];
  g->opacity[i] = (float)log(alpha / (1 - alpha));
}

/* Zero crossing of the trilinearly sampled SDF along origin + t·dir, t in [t0, t1],
 * where the sign changes once (bisection). Returns NAN if there is no sign change. */
static inline double vt_ray_zero(const mgs_vdb_grid *sdf, const double o[3], const double d[3], double t0, double t1) {
  float p[3], v0, v1;
  for (int k = 0; k < 3; k++) p[k] = (float)(o[k] + t0 * d[k]);
  mgs_vdb_sample(sdf, 1, p, &v0);
  for (int k = 0; k < 3; k++) p[k] = (float)(o[k] + t1 * d[k]);
  mgs_vdb_sample(sdf, 1, p, &v1);
  if ((v0 < 0) == (v1 < 0)) return NAN;
  for (int it = 0; it < 60; it++) {
    double tm = 0.5 * (t0 + t1);
    float vm;
    for (int k = 0; k < 3; k++) p[k] = (float)(o[k] + tm * d[k]);
    mgs_vdb_sample(sdf, 1, p, &vm);
    if ((vm < 0) == (v0 < 0)) { t0 = tm; v0 = vm; } else { t1 = tm; }
  }
  return 0.5 * (t0 + t1);
}
#endif

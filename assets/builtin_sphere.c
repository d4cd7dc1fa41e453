/* Builtin "sphere": a bumpy blob, genus 0. A sphere of radius 0.8 with smooth bumps of
 * amplitude well below the radius, so it stays star-shaped (one part, no handles). */
#include <math.h>
#include "assets/assets_internal.h"

static double blob(const double p[3], const void *ctx) {
  (void)ctx;
  double r = sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
  double bumps = 0.06 * sin(4.0 * p[0] + 1.0) * sin(5.0 * p[1] + 0.3) * sin(3.0 * p[2] + 0.5) +
                 0.04 * sin(7.0 * p[2] + 2.0 * p[0]);
  return r - (0.8 + bumps) + 0.12 * p[2] * p[2] * (p[2] > 0 ? 1.0 : 0.0); /* flatter top */
}

mgs_status mgs_builtin_sphere(int detail, mgs_mesh **out, mgs_error *err) {
  int res = 56 * detail;
  double lo[3] = {-1.1, -1.1, -1.1}, hi[3] = {1.1, 1.1, 1.1};
  int n[3] = {res, res, res};
  return mgs_assets_polygonize(blob, NULL, lo, hi, n, "sphere", out, err);
}

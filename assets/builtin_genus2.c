/* Builtin "genus2": a double torus. Two solid tori side by side whose tubes overlap in
 * one contractible lens near the origin, fused with a smooth minimum: a handlebody of
 * genus 2 (Euler characteristic V - E + F = -2). */
#include <math.h>
#include "assets/assets_internal.h"

static double torus(const double p[3], double cx, double R, double r) {
  double x = p[0] - cx, q = sqrt(x * x + p[1] * p[1]) - R;
  return sqrt(q * q + p[2] * p[2]) - r;
}

/* Polynomial smooth minimum (blend width k). */
static double smin(double a, double b, double k) {
  double h = 0.5 + 0.5 * (b - a) / k;
  h = h < 0 ? 0 : (h > 1 ? 1 : h);
  return b + (a - b) * h - k * h * (1 - h);
}

static double double_torus(const double p[3], const void *ctx) {
  (void)ctx;
  double a = torus(p, -0.55, 0.5, 0.17), b = torus(p, 0.55, 0.5, 0.17);
  /* A gentle ripple on the tubes so the shape is not a surface of revolution. */
  double ripple = 0.012 * sin(9.0 * p[0]) * cos(7.0 * p[1]);
  return smin(a, b, 0.08) + ripple;
}

mgs_status mgs_builtin_genus2(int detail, mgs_mesh **out, mgs_error *err) {
  double lo[3] = {-1.3, -0.8, -0.32}, hi[3] = {1.3, 0.8, 0.32};
  double h = 2.6 / (112.0 * detail); /* detail 1: just over 100k triangles */
  int n[3];
  for (int a = 0; a < 3; a++) n[a] = (int)ceil((hi[a] - lo[a]) / h);
  return mgs_assets_polygonize(double_torus, NULL, lo, hi, n, "genus2", out, err);
}

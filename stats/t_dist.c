/* Student's t through the regularized incomplete beta function: I_x(a, b) by its continued
 * fraction (modified Lentz), evaluated on the side where it converges fast (x < (a+1)/(a+b+2),
 * else the symmetry I_x(a, b) = 1 − I_{1−x}(b, a)). The two-sided p of t with ν dof is
 * I_{ν/(ν+t²)}(ν/2, 1/2) — no cancellation in the tail; the quantile inverts it by bisection
 * (monotone, so it cannot miss; 200 halvings are far below double precision). */
#include <math.h>
#include "stats/mgs_stats.h"

static double beta_continued_fraction(double a, double b, double x) {
  const double tiny = 1e-300, eps = 1e-15;
  double qab = a + b, qap = a + 1, qam = a - 1, c = 1, d = 1 - qab * x / qap;
  if (fabs(d) < tiny) d = tiny;
  d = 1 / d;
  double h = d;
  for (int m = 1; m <= 1000; m++) {
    int m2 = 2 * m;
    double aa = m * (b - m) * x / ((qam + m2) * (a + m2));
    d = 1 + aa * d; if (fabs(d) < tiny) d = tiny;
    c = 1 + aa / c; if (fabs(c) < tiny) c = tiny;
    d = 1 / d;
    h *= d * c;
    aa = -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2));
    d = 1 + aa * d; if (fabs(d) < tiny) d = tiny;
    c = 1 + aa / c; if (fabs(c) < tiny) c = tiny;
    d = 1 / d;
    double del = d * c;
    h *= del;
    if (fabs(del - 1) < eps) break;
  }
  return h;
}

double mgs_stats_betainc(double a, double b, double x) {
  if (!(a > 0) || !(b > 0) || !(x >= 0) || !(x <= 1) || !isfinite(a) || !isfinite(b)) return NAN;
  if (x == 0) return 0;
  if (x == 1) return 1;
  double ln_front = lgamma(a + b) - lgamma(a) - lgamma(b) + a * log(x) + b * log1p(-x);
  double front = exp(ln_front);
  if (x < (a + 1) / (a + b + 2)) return front * beta_continued_fraction(a, b, x) / a;
  return 1 - front * beta_continued_fraction(b, a, 1 - x) / b;
}

double mgs_stats_t_p_two_sided(double t, double dof) {
  if (isnan(t) || !(dof > 0)) return NAN;
  if (isinf(t)) return 0;
  return mgs_stats_betainc(0.5 * dof, 0.5, dof / (dof + t * t));
}

double mgs_stats_t_cdf(double t, double dof) {
  double tail = 0.5 * mgs_stats_t_p_two_sided(t, dof);
  return t > 0 ? 1 - tail : tail;
}

double mgs_stats_t_quantile(double q, double dof) {
  if (!(q > 0) || !(q < 1) || !(dof > 0)) return NAN;
  if (q == 0.5) return 0;
  if (q < 0.5) return -mgs_stats_t_quantile(1 - q, dof);
  const double want = 2 * (1 - q); /* two-sided p at the answer; p falls as t grows */
  double lo = 0, hi = 1;
  while (mgs_stats_t_p_two_sided(hi, dof) > want) {
    lo = hi;
    hi *= 2;
    if (hi > 1e300) return INFINITY;
  }
  for (int k = 0; k < 200 && hi - lo > 1e-13 * hi; k++) {
    double mid = 0.5 * (lo + hi);
    if (mgs_stats_t_p_two_sided(mid, dof) > want) lo = mid; else hi = mid;
  }
  return 0.5 * (lo + hi);
}

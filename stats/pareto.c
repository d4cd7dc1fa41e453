/* The Pareto front of a density-knob sweep (H3): fewer Gaussians and higher PSNR are both
 * better, so a method's best trade-offs are its non-dominated points. Along the front PSNR
 * and count rise together by construction, so "the base's count at this PSNR" is a
 * well-defined monotone interpolation (log-count linear in PSNR); outside the front's PSNR
 * range there is no answer, and the caller must say so. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "stats/mgs_stats.h"

static int cmp_psnr_desc_count_asc(const void *a, const void *b) {
  const mgs_stats_point *x = a, *y = b;
  if (x->psnr != y->psnr) return (x->psnr < y->psnr) - (x->psnr > y->psnr);
  return (x->count > y->count) - (x->count < y->count);
}

size_t mgs_stats_pareto_front(const mgs_stats_point *pts, size_t n, mgs_stats_point *front) {
  size_t m = 0;
  for (size_t i = 0; i < n; i++)
    if (isfinite(pts[i].psnr) && isfinite(pts[i].count) && pts[i].count > 0) front[m++] = pts[i];
  /* best PSNR first: a point survives when it needs fewer Gaussians than every point with
     at least its PSNR (those are all before it) */
  qsort(front, m, sizeof *front, cmp_psnr_desc_count_asc);
  size_t k = 0;
  double best = INFINITY;
  for (size_t i = 0; i < m; i++)
    if (front[i].count < best) { best = front[i].count; front[k++] = front[i]; }
  for (size_t i = 0; i < k / 2; i++) { mgs_stats_point t = front[i]; front[i] = front[k - 1 - i]; front[k - 1 - i] = t; }
  return k;
}

mgs_stats_front_at mgs_stats_front_count_at(const mgs_stats_point *front, size_t n, double psnr, double *count) {
  *count = NAN;
  if (n == 0 || !isfinite(psnr)) return MGS_STATS_FRONT_NONE;
  if (psnr < front[0].psnr) return MGS_STATS_FRONT_BELOW;
  if (psnr > front[n - 1].psnr) return MGS_STATS_FRONT_ABOVE;
  for (size_t i = 0; i + 1 < n; i++)
    if (psnr <= front[i + 1].psnr) {
      double t = (psnr - front[i].psnr) / (front[i + 1].psnr - front[i].psnr); /* PSNR strictly rises */
      *count = exp((1 - t) * log(front[i].count) + t * log(front[i + 1].count));
      return MGS_STATS_FRONT_INSIDE;
    }
  *count = front[n - 1].count; /* n == 1 and psnr equal to its one point */
  return MGS_STATS_FRONT_INSIDE;
}

int mgs_stats_front_dominates(const mgs_stats_point *front, size_t n, mgs_stats_point p) {
  for (size_t i = 0; i < n; i++)
    if (front[i].count <= p.count && front[i].psnr >= p.psnr && (front[i].count < p.count || front[i].psnr > p.psnr)) return 1;
  return 0;
}

void mgs_stats_front_changes(const mgs_stats_point *front, size_t nf, const mgs_stats_point *v, size_t n,
                             double *change, mgs_stats_front_tally *tally) {
  memset(tally, 0, sizeof *tally);
  for (size_t i = 0; i < n; i++) {
    change[i] = NAN;
    if (!isfinite(v[i].psnr) || !isfinite(v[i].count) || !(v[i].count > 0)) { tally->invalid++; continue; }
    if (mgs_stats_front_dominates(front, nf, v[i])) tally->dominated++;
    double c;
    switch (mgs_stats_front_count_at(front, nf, v[i].psnr, &c)) {
      case MGS_STATS_FRONT_INSIDE: tally->inside++; change[i] = log(v[i].count / c); break;
      case MGS_STATS_FRONT_ABOVE: tally->above++; break;
      default: tally->below++; break;
    }
  }
}

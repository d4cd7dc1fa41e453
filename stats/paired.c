/* Paired changes, their intervals, verdict words and Holm's correction.
 *
 * The interval is the t-interval of the mean change over seeds, n−1 dof: the seeds are
 * the pairs (same seed, scene and schedule for a method and its base), the change is on a
 * log scale so ±x are symmetric (a mean of ratios is not: +582 % against −100 %). The
 * bootstrap (percentile, resampling the changes) is reported beside it, never instead: at 3
 * to 5 seeds it has 10 to 126 distinct resamples and is too narrow.
 *
 * Holm within a family: the k-th smallest of m p-values is tested at α/(m−k+1), and testing
 * stops at the first that fails. A corrected verdict is then read from the interval at the
 * level that cell was tested at, 1 − α/(m−k+1): wider than 95 %, and it excludes 0 exactly
 * when Holm rejects that cell's null (its raw p < α/(m−k+1)); a cell Holm stopped before
 * is "no" whatever its own interval says. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "core/mgs_rng.h"
#include "stats/mgs_stats.h"

double mgs_stats_change(double variant, double base, mgs_stats_scale scale) {
  if (!isfinite(variant) || !isfinite(base)) return NAN;
  if (scale == MGS_STATS_DIFFERENCE) return variant - base;
  if (!(variant > 0) || !(base > 0)) return NAN;
  return log(variant / base);
}

static int cmp_double(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return (x > y) - (x < y);
}

mgs_status mgs_stats_interval_of(const double *change, size_t n, double level, int boot_samples,
                                 mgs_stats_interval *out, mgs_error *err) {
  memset(out, 0, sizeof *out);
  out->level = level;
  out->mean = out->sd = out->lo = out->hi = out->t = out->p = out->boot_lo = out->boot_hi = NAN;
  if (!(level > 0 && level < 1)) return mgs_error_set(err, MGS_ERR_ARG, "stats: confidence level must be in (0, 1) (got %g)", level);
  double *x = malloc((n ? n : 1) * sizeof *x);
  if (!x) return mgs_error_set(err, MGS_ERR_NOMEM, "stats: out of memory (%zu changes)", n);
  size_t m = 0;
  for (size_t i = 0; i < n; i++) {
    if (isfinite(change[i])) x[m++] = change[i];
    else out->skipped++;
  }
  out->n = (int)m;
  if (m == 0) { free(x); return MGS_OK; }
  double s = 0;
  for (size_t i = 0; i < m; i++) s += x[i];
  out->mean = s / (double)m;
  if (m < 2) { free(x); return MGS_OK; }
  double ss = 0;
  for (size_t i = 0; i < m; i++) ss += (x[i] - out->mean) * (x[i] - out->mean);
  out->sd = sqrt(ss / (double)(m - 1));
  mgs_stats_interval_at(out, level, &out->lo, &out->hi);
  double se = out->sd / sqrt((double)m);
  if (se > 0) {
    out->t = out->mean / se;
    out->p = mgs_stats_t_p_two_sided(out->t, (double)(m - 1));
  } else { /* every seed changed by exactly the same amount */
    out->t = out->mean == 0 ? 0 : copysign(INFINITY, out->mean);
    out->p = out->mean == 0 ? 1 : 0;
  }
  if (boot_samples > 0) {
    double *means = malloc((size_t)boot_samples * sizeof *means);
    if (!means) { free(x); return mgs_error_set(err, MGS_ERR_NOMEM, "stats: out of memory (bootstrap)"); }
    mgs_rng rng;
    mgs_rng_init(&rng, 0x5eedb007u, (uint64_t)m); /* fixed: the report is reproducible */
    for (int b = 0; b < boot_samples; b++) {
      double t = 0;
      for (size_t i = 0; i < m; i++) t += x[mgs_rng_below(&rng, (uint32_t)m)];
      means[b] = t / (double)m;
    }
    qsort(means, (size_t)boot_samples, sizeof *means, cmp_double);
    double a = 0.5 * (1 - level);
    size_t ilo = (size_t)floor(a * (boot_samples - 1)), ihi = (size_t)ceil((1 - a) * (boot_samples - 1));
    out->boot_lo = means[ilo];
    out->boot_hi = means[ihi];
    free(means);
  }
  free(x);
  return MGS_OK;
}

void mgs_stats_interval_at(const mgs_stats_interval *iv, double level, double *lo, double *hi) {
  *lo = *hi = NAN;
  if (iv->n < 2 || !isfinite(iv->sd) || !(level > 0 && level < 1)) return;
  double half = mgs_stats_t_quantile(0.5 * (1 + level), (double)(iv->n - 1)) * iv->sd / sqrt((double)iv->n);
  if (iv->sd == 0) half = 0; /* not inf·0 */
  *lo = iv->mean - half;
  *hi = iv->mean + half;
}

mgs_stats_verdict mgs_stats_verdict_of(double lo, double hi, int direction, double target) {
  if (isnan(lo) || isnan(hi) || isnan(target) || direction == 0) return MGS_STATS_NA;
  /* flip so that "better" is positive */
  double glo = direction > 0 ? lo : -hi, ghi = direction > 0 ? hi : -lo, gt = direction > 0 ? target : -target;
  if (glo > 0) return glo >= gt ? MGS_STATS_YES : MGS_STATS_PARTLY;
  if (ghi < 0) return MGS_STATS_WORSE;
  return MGS_STATS_NO;
}

const char *mgs_stats_verdict_name(mgs_stats_verdict v) {
  switch (v) {
    case MGS_STATS_NO: return "no";
    case MGS_STATS_PARTLY: return "partly";
    case MGS_STATS_YES: return "yes";
    case MGS_STATS_WORSE: return "worse";
    default: return "n/a";
  }
}

typedef struct ranked { double p; size_t i; } ranked;
static int cmp_ranked(const void *a, const void *b) {
  const ranked *x = a, *y = b;
  if (x->p != y->p) return (x->p > y->p) - (x->p < y->p);
  return (x->i > y->i) - (x->i < y->i); /* stable: ties keep their order */
}

mgs_status mgs_stats_holm(const double *p, size_t n, double alpha, double *adjusted, double *level_out, mgs_error *err) {
  if (!(alpha > 0 && alpha < 1)) return mgs_error_set(err, MGS_ERR_ARG, "stats: Holm's alpha must be in (0, 1) (got %g)", alpha);
  ranked *r = malloc((n ? n : 1) * sizeof *r);
  if (!r) return mgs_error_set(err, MGS_ERR_NOMEM, "stats: out of memory (Holm, %zu p-values)", n);
  size_t m = 0;
  for (size_t i = 0; i < n; i++) {
    adjusted[i] = NAN;
    if (level_out) level_out[i] = NAN;
    if (isfinite(p[i]) && p[i] >= 0 && p[i] <= 1) { r[m].p = p[i]; r[m].i = i; m++; }
  }
  qsort(r, m, sizeof *r, cmp_ranked);
  double running = 0;
  for (size_t k = 0; k < m; k++) {
    double a = fmin(1.0, (double)(m - k) * r[k].p);
    running = fmax(running, a); /* step-down: an adjusted p never falls below an earlier one */
    adjusted[r[k].i] = running;
    if (level_out) level_out[r[k].i] = 1 - alpha / (double)(m - k);
  }
  free(r);
  return MGS_OK;
}

mgs_stats_verdict mgs_stats_verdict_holm(const mgs_stats_interval *iv, double adjusted_p, double alpha, double holm_level,
                                         int direction, double target) {
  if (iv->n < 2 || isnan(adjusted_p)) return MGS_STATS_NA;
  if (!(adjusted_p < alpha)) return MGS_STATS_NO;
  double lo, hi;
  mgs_stats_interval_at(iv, holm_level, &lo, &hi);
  return mgs_stats_verdict_of(lo, hi, direction, target);
}

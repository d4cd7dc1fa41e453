/* The statistics of `morsegs experiment` (SPEC §7, DESIGN-NOTES "Statistics that hold up"),
 * a library of their own so they can be tested without training. This header owns
 *   distributions ..... Student's t (CDF, two-sided p, quantile) through the regularized
 *                       incomplete beta function
 *   paired changes .... per-seed change of a method against its base on a log scale
 *                       (log-ratio for counts and distances, difference for dB), its mean,
 *                       t-interval (n−1 dof), paired t-test p and a percentile bootstrap
 *   verdicts .......... the word a hypothesis gets from an interval and a target
 *   Holm .............. step-down adjusted p-values within one family of cells, and the
 *                       per-cell level Holm tests at (the corrected verdict's interval)
 *   Pareto front ...... the non-dominated (count, PSNR) points of a method's density-knob
 *                       sweep and its count at a given PSNR (H3 "at equal PSNR")
 * Depends on core only (errors, the seeded RNG of the bootstrap). Everything here is pure:
 * no files, no globals. Non-finite inputs are skipped and counted, never silently used. */
#ifndef MGS_STATS_H
#define MGS_STATS_H
#include <stddef.h>
#include "core/mgs_error.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ---------------------------------------------------------------- distributions */
/* I_x(a, b), a, b > 0, x in [0, 1]; NAN outside. */
double mgs_stats_betainc(double a, double b, double x);
/* P(T <= t) for Student's t with dof > 0 degrees of freedom. */
double mgs_stats_t_cdf(double t, double dof);
/* Two-sided p-value P(|T| >= |t|). */
double mgs_stats_t_p_two_sided(double t, double dof);
/* The q-quantile of Student's t (q in (0, 1)), to ~1e-10 relative; NAN for bad input. */
double mgs_stats_t_quantile(double q, double dof);

/* ---------------------------------------------------------------- paired changes */
typedef enum mgs_stats_scale {
  MGS_STATS_LOG_RATIO = 0,  /* change = log(variant / base); both must be > 0 */
  MGS_STATS_DIFFERENCE = 1  /* change = variant − base (dB, SSIM) */
} mgs_stats_scale;

typedef struct mgs_stats_interval {
  int n;                 /* changes used */
  int skipped;           /* non-finite inputs (or <= 0 on the log scale), left out */
  double level;          /* confidence level of [lo, hi] (0.95) */
  double mean, sd;       /* of the changes; sd NAN when n < 2 */
  double lo, hi;         /* t-interval mean ± t_{(1+level)/2, n−1}·sd/√n; NAN when n < 2 */
  double t, p;           /* paired t statistic and its two-sided p; NAN when n < 2 */
  double boot_lo, boot_hi; /* percentile bootstrap of the mean, same level; NAN when n < 2 */
} mgs_stats_interval;

/* Change of one pair on the given scale; NAN when it is not defined (non-finite input, or
 * a value <= 0 on the log scale). */
double mgs_stats_change(double variant, double base, mgs_stats_scale scale);

/* The interval of n changes (non-finite ones skipped and counted). boot_samples resamples
 * for the bootstrap (0 = none; seeded, so reproducible). */
mgs_status mgs_stats_interval_of(const double *change, size_t n, double level, int boot_samples,
                                 mgs_stats_interval *out, mgs_error *err);
/* [lo, hi] of the same changes at another level (Holm's per-cell level); NAN when n < 2. */
void mgs_stats_interval_at(const mgs_stats_interval *iv, double level, double *lo, double *hi);

/* ---------------------------------------------------------------- verdicts */
typedef enum mgs_stats_verdict {
  MGS_STATS_NA = 0,   /* no interval (fewer than 2 changes) */
  MGS_STATS_NO,       /* the interval contains 0 */
  MGS_STATS_PARTLY,   /* beyond 0 in the right direction, not wholly beyond the target */
  MGS_STATS_YES,      /* wholly beyond the target */
  MGS_STATS_WORSE     /* beyond 0 in the wrong direction */
} mgs_stats_verdict;

/* direction −1: lower is better (target <= 0, e.g. log 0.7 for −30 %), +1: higher is
 * better (target >= 0). NAN ends give MGS_STATS_NA. */
mgs_stats_verdict mgs_stats_verdict_of(double lo, double hi, int direction, double target);
const char *mgs_stats_verdict_name(mgs_stats_verdict v);

/* ---------------------------------------------------------------- Holm */
/* Holm-adjusted p-values of one family: adjusted[i] = max over k <= rank(i) of
 * min(1, (m − k + 1)·p_(k)), m = the number of finite p (NAN entries stay NAN and do not
 * count). level_out (may be NULL): the level 1 − α/(m − rank + 1) Holm compares cell i at —
 * the interval at that level is the one a corrected verdict reads. */
mgs_status mgs_stats_holm(const double *p, size_t n, double alpha, double *adjusted, double *level_out,
                          mgs_error *err);

/* The corrected verdict: "no" when Holm does not reject (adjusted p >= α), else the verdict
 * of the interval at the cell's Holm level (which then excludes 0, so it is yes, partly or
 * worse). */
mgs_stats_verdict mgs_stats_verdict_holm(const mgs_stats_interval *iv, double adjusted_p, double alpha,
                                         double holm_level, int direction, double target);

/* ---------------------------------------------------------------- Pareto front (H3) */
typedef struct mgs_stats_point {
  double count;          /* Gaussians (> 0) */
  double psnr;           /* dB */
} mgs_stats_point;

/* The non-dominated points of pts (fewer Gaussians and higher PSNR are better; a point is
 * dominated when another has count <= and PSNR >= with one strict; duplicates kept once),
 * written to front (capacity n) sorted by PSNR ascending — count then rises strictly too.
 * Points with a non-finite value or count <= 0 are skipped. Returns the front's size. */
size_t mgs_stats_pareto_front(const mgs_stats_point *pts, size_t n, mgs_stats_point *front);

typedef enum mgs_stats_front_at {
  MGS_STATS_FRONT_INSIDE = 0, /* *count set: log-count interpolated linearly in PSNR */
  MGS_STATS_FRONT_BELOW,      /* PSNR below the front's lowest */
  MGS_STATS_FRONT_ABOVE,      /* PSNR above the front's highest */
  MGS_STATS_FRONT_NONE        /* empty front or non-finite PSNR */
} mgs_stats_front_at;
mgs_stats_front_at mgs_stats_front_count_at(const mgs_stats_point *front, size_t n, double psnr, double *count);
/* 1 when some front point dominates p (has count <= and PSNR >= p's, one strict). */
int mgs_stats_front_dominates(const mgs_stats_point *front, size_t n, mgs_stats_point p);

/* Where a method's seeds fall against a base front. */
typedef struct mgs_stats_front_tally {
  int inside, below, above;  /* PSNR within / below / above the front's range (NONE: below) */
  int invalid;               /* non-finite PSNR or count <= 0 */
  int dominated;             /* of all seeds: dominated by a front point (the base does better
                                on both counts, whatever the range) */
} mgs_stats_front_tally;
/* change[i] = log(v[i].count / the front's count at v[i].psnr) inside the range, NAN
 * outside (the caller reports the tally, never drops them silently). */
void mgs_stats_front_changes(const mgs_stats_point *front, size_t nf, const mgs_stats_point *v, size_t n,
                             double *change, mgs_stats_front_tally *tally);

#ifdef __cplusplus
}
#endif
#endif

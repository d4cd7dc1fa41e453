/* The statistics of `morsegs experiment` on constructed data: every number checked here is
 * known independently (t tables, a closed-form incomplete beta, R's p.adjust(..., "holm")),
 * or computed by hand in the comment beside it. */
#include <math.h>
#include "mgs_test.h"
#include "stats/mgs_stats.h"

static void t_distribution(void) {
  /* two-sided 95 % critical values (any t table; R qt(0.975, df)) */
  CHECK_NEAR(mgs_stats_t_quantile(0.975, 1), 12.7062047, 1e-6);
  CHECK_NEAR(mgs_stats_t_quantile(0.975, 2), 4.30265273, 1e-7);
  CHECK_NEAR(mgs_stats_t_quantile(0.975, 4), 2.77644511, 1e-7);
  CHECK_NEAR(mgs_stats_t_quantile(0.975, 9), 2.26215716, 1e-7);
  CHECK_NEAR(mgs_stats_t_quantile(0.975, 30), 2.04227246, 1e-7);
  CHECK_NEAR(mgs_stats_t_quantile(0.975, 100), 1.98397152, 1e-7);
  CHECK_NEAR(mgs_stats_t_quantile(0.975, 1e6), 1.95996591, 1e-5); /* -> normal */
  CHECK_NEAR(mgs_stats_t_quantile(0.995, 5), 4.03214298, 1e-7);
  CHECK_NEAR(mgs_stats_t_quantile(0.025, 4), -2.77644511, 1e-7);  /* symmetric */
  CHECK(mgs_stats_t_quantile(0.5, 3) == 0);
  CHECK(isnan(mgs_stats_t_quantile(1.0, 3)) && isnan(mgs_stats_t_quantile(0.9, 0)) && isnan(mgs_stats_t_quantile(NAN, 3)));
  /* dof 1 is Cauchy: the 0.99 quantile is tan(0.49 pi) */
  CHECK_NEAR(mgs_stats_t_quantile(0.99, 1), tan(0.49 * M_PI), 1e-6);
  /* I_0.4(2, 3) = sum_{j=2..4} C(4,j) 0.4^j 0.6^(4-j) = 0.3456 + 0.1536 + 0.0256 */
  CHECK_NEAR(mgs_stats_betainc(2, 3, 0.4), 0.5248, 1e-12);
  CHECK_NEAR(mgs_stats_betainc(3, 2, 0.6), 1 - 0.5248, 1e-12);
  CHECK(mgs_stats_betainc(2, 3, 0) == 0 && mgs_stats_betainc(2, 3, 1) == 1 && isnan(mgs_stats_betainc(2, 3, 1.5)));
  /* p of t = 2 sqrt 3 at 2 dof: I_{1/7}(1, 1/2) = 1 - sqrt(6/7) */
  CHECK_NEAR(mgs_stats_t_p_two_sided(2 * sqrt(3.0), 2), 1 - sqrt(6.0 / 7.0), 1e-12);
  CHECK_NEAR(mgs_stats_t_p_two_sided(2.26215716, 9), 0.05, 1e-8);
  CHECK_NEAR(mgs_stats_t_cdf(0, 7), 0.5, 1e-15);
  CHECK_NEAR(mgs_stats_t_cdf(1, 1), 0.75, 1e-12); /* Cauchy: 1/2 + atan(1)/pi */
  CHECK(mgs_stats_t_p_two_sided(INFINITY, 3) == 0 && isnan(mgs_stats_t_p_two_sided(NAN, 3)));
}

static void intervals(void) {
  mgs_stats_interval iv;
  mgs_error err;
  /* {1, 2, 3}: mean 2, sd 1, half-width 4.30265 / sqrt 3 */
  const double x[3] = {1, 2, 3};
  CHECK_OK(mgs_stats_interval_of(x, 3, 0.95, 2000, &iv, &err), &err);
  CHECK(iv.n == 3 && iv.skipped == 0);
  CHECK_NEAR(iv.mean, 2, 1e-15);
  CHECK_NEAR(iv.sd, 1, 1e-15);
  CHECK_NEAR(iv.lo, 2 - 4.30265273 / sqrt(3.0), 1e-7);
  CHECK_NEAR(iv.hi, 2 + 4.30265273 / sqrt(3.0), 1e-7);
  CHECK_NEAR(iv.t, 2 * sqrt(3.0), 1e-12);
  CHECK_NEAR(iv.p, 1 - sqrt(6.0 / 7.0), 1e-12);
  /* the bootstrap of 3 values: within [1, 3] and narrower than the t-interval */
  CHECK(iv.boot_lo >= 1 && iv.boot_hi <= 3 && iv.boot_lo < 2 && iv.boot_hi > 2);
  /* the same changes at Holm's level 1 - 0.05/4: wider */
  double lo, hi;
  mgs_stats_interval_at(&iv, 1 - 0.05 / 4, &lo, &hi);
  CHECK(lo < iv.lo && hi > iv.hi);
  CHECK_NEAR(hi - 2, mgs_stats_t_quantile(1 - 0.0125 / 2, 2) / sqrt(3.0), 1e-9);
  /* one seed: a mean, no interval, no verdict */
  CHECK_OK(mgs_stats_interval_of(x, 1, 0.95, 100, &iv, &err), &err);
  CHECK(iv.n == 1 && iv.mean == 1 && isnan(iv.lo) && isnan(iv.hi) && isnan(iv.p) && isnan(iv.sd) && isnan(iv.boot_lo));
  CHECK(mgs_stats_verdict_of(iv.lo, iv.hi, -1, log(0.7)) == MGS_STATS_NA);
  /* NaN inputs are skipped and counted: {NaN, 1, inf, 3} is {1, 3} */
  const double y[4] = {NAN, 1, INFINITY, 3};
  CHECK_OK(mgs_stats_interval_of(y, 4, 0.95, 0, &iv, &err), &err);
  CHECK(iv.n == 2 && iv.skipped == 2 && iv.mean == 2 && isnan(iv.boot_lo));
  CHECK_NEAR(iv.hi - 2, 12.7062047 * sqrt(2.0) / sqrt(2.0), 1e-6); /* sd sqrt 2, n 2 */
  /* nothing at all */
  const double z[2] = {NAN, NAN};
  CHECK_OK(mgs_stats_interval_of(z, 2, 0.95, 10, &iv, &err), &err);
  CHECK(iv.n == 0 && iv.skipped == 2 && isnan(iv.mean));
  /* identical changes: a zero-width interval, p 0 (or 1 at zero change) */
  const double same[3] = {-0.25, -0.25, -0.25}, zero[2] = {0, 0};
  CHECK_OK(mgs_stats_interval_of(same, 3, 0.95, 0, &iv, &err), &err);
  CHECK(iv.lo == iv.hi && iv.p == 0);
  CHECK_OK(mgs_stats_interval_of(zero, 2, 0.95, 0, &iv, &err), &err);
  CHECK(iv.p == 1 && mgs_stats_verdict_of(iv.lo, iv.hi, -1, log(0.7)) == MGS_STATS_NO);
  CHECK(mgs_stats_interval_of(x, 3, 1.5, 0, &iv, &err) == MGS_ERR_ARG);
  /* the scale of a change */
  CHECK_NEAR(mgs_stats_change(50, 100, MGS_STATS_LOG_RATIO), log(0.5), 1e-15);
  CHECK_NEAR(mgs_stats_change(29.5, 29.0, MGS_STATS_DIFFERENCE), 0.5, 1e-12);
  CHECK(isnan(mgs_stats_change(0, 100, MGS_STATS_LOG_RATIO)) && isnan(mgs_stats_change(5, NAN, MGS_STATS_DIFFERENCE)));
  /* symmetric on the log scale: doubling and halving are equal and opposite */
  CHECK_NEAR(mgs_stats_change(200, 100, MGS_STATS_LOG_RATIO), -mgs_stats_change(50, 100, MGS_STATS_LOG_RATIO), 1e-15);
}

static void verdict_words(void) {
  const double t30 = log(0.7); /* H1: -30 % */
  CHECK(mgs_stats_verdict_of(log(0.5), log(0.6), -1, t30) == MGS_STATS_YES);
  CHECK(mgs_stats_verdict_of(log(0.5), log(0.8), -1, t30) == MGS_STATS_PARTLY); /* beyond 0, not wholly beyond -30 % */
  CHECK(mgs_stats_verdict_of(log(0.5), log(1.1), -1, t30) == MGS_STATS_NO);
  CHECK(mgs_stats_verdict_of(log(1.05), log(1.2), -1, t30) == MGS_STATS_WORSE);
  /* higher is better (dB) */
  CHECK(mgs_stats_verdict_of(0.6, 0.9, +1, 0.5) == MGS_STATS_YES);
  CHECK(mgs_stats_verdict_of(0.1, 0.9, +1, 0.5) == MGS_STATS_PARTLY);
  CHECK(mgs_stats_verdict_of(-0.1, 0.9, +1, 0.5) == MGS_STATS_NO);
  CHECK(mgs_stats_verdict_of(-0.9, -0.1, +1, 0.5) == MGS_STATS_WORSE);
  CHECK(mgs_stats_verdict_of(NAN, 0.9, +1, 0.5) == MGS_STATS_NA);
  CHECK(!strcmp(mgs_stats_verdict_name(MGS_STATS_WORSE), "worse") && !strcmp(mgs_stats_verdict_name(MGS_STATS_NA), "n/a"));
}

static void holm(void) {
  /* R: p.adjust(c(0.01, 0.04, 0.03, 0.005), "holm") = 0.03 0.06 0.06 0.02 */
  const double p[4] = {0.01, 0.04, 0.03, 0.005};
  double adj[4], lvl[4];
  mgs_error err;
  CHECK_OK(mgs_stats_holm(p, 4, 0.05, adj, lvl, &err), &err);
  CHECK_NEAR(adj[0], 0.03, 1e-15);
  CHECK_NEAR(adj[1], 0.06, 1e-15);
  CHECK_NEAR(adj[2], 0.06, 1e-15);
  CHECK_NEAR(adj[3], 0.02, 1e-15);
  /* the level each was compared at: alpha/4, /3, /2, /1 by rank */
  CHECK_NEAR(lvl[3], 1 - 0.05 / 4, 1e-15);
  CHECK_NEAR(lvl[0], 1 - 0.05 / 3, 1e-15);
  CHECK_NEAR(lvl[2], 1 - 0.05 / 2, 1e-15);
  CHECK_NEAR(lvl[1], 1 - 0.05 / 1, 1e-15);
  /* Holm is not Bonferroni: 0.04 alone would pass at 0.05, but Holm stopped at 0.03 */
  CHECK(p[1] < 0.05 && !(adj[1] < 0.05));
  /* NaN cells are not in the family: m = 3 here */
  const double q[4] = {0.01, NAN, 0.02, 0.5};
  CHECK_OK(mgs_stats_holm(q, 4, 0.05, adj, NULL, &err), &err);
  CHECK_NEAR(adj[0], 0.03, 1e-15);
  CHECK(isnan(adj[1]));
  CHECK_NEAR(adj[2], 0.04, 1e-15);
  CHECK_NEAR(adj[3], 0.5, 1e-15);
  /* capped at 1 */
  const double r[2] = {0.7, 0.9};
  CHECK_OK(mgs_stats_holm(r, 2, 0.05, adj, NULL, &err), &err);
  CHECK(adj[0] == 1 && adj[1] == 1);
  CHECK(mgs_stats_holm(r, 2, 0, adj, NULL, &err) == MGS_ERR_ARG);
  /* the corrected verdict: a cell beyond zero at 95 % that Holm does not reject is "no" */
  mgs_stats_interval iv;
  const double ch[3] = {-0.30, -0.20, -0.25}; /* p = 0.0132 */
  CHECK_OK(mgs_stats_interval_of(ch, 3, 0.95, 0, &iv, &err), &err);
  CHECK(mgs_stats_verdict_of(iv.lo, iv.hi, -1, log(0.7)) == MGS_STATS_PARTLY);
  CHECK(mgs_stats_verdict_holm(&iv, 0.08, 0.05, 1 - 0.05 / 6, -1, log(0.7)) == MGS_STATS_NO);
  CHECK(mgs_stats_verdict_holm(&iv, 0.0132, 0.05, 0.95, -1, log(0.7)) == MGS_STATS_PARTLY);
  /* rejected, and the wider interval at the Holm level still excludes zero */
  double lo, hi;
  mgs_stats_interval_at(&iv, 1 - 0.05 / 3, &lo, &hi);
  CHECK(iv.p < 0.05 / 3 ? hi < 0 : 1);
}

static void pareto_front(void) {
  /* a sweep whose curve by knob runs the wrong way: (3000, 24 dB) is dominated by (1000, 25) */
  const mgs_stats_point pts[7] = {{1000, 25}, {3000, 24}, {2000, 26}, {4000, 27}, {5000, 26.5}, {NAN, 30}, {2000, 26}};
  mgs_stats_point f[7];
  size_t n = mgs_stats_pareto_front(pts, 7, f);
  CHECK(n == 3);
  CHECK(f[0].count == 1000 && f[0].psnr == 25 && f[1].count == 2000 && f[1].psnr == 26 && f[2].count == 4000 && f[2].psnr == 27);
  for (size_t i = 0; i + 1 < n; i++) CHECK(f[i + 1].psnr > f[i].psnr && f[i + 1].count > f[i].count);
  double c;
  CHECK(mgs_stats_front_count_at(f, n, 25.5, &c) == MGS_STATS_FRONT_INSIDE);
  CHECK_NEAR(c, sqrt(1000.0 * 2000.0), 1e-9);
  CHECK(mgs_stats_front_count_at(f, n, 27, &c) == MGS_STATS_FRONT_INSIDE);
  CHECK_NEAR(c, 4000, 1e-9);
  CHECK(mgs_stats_front_count_at(f, n, 24.5, &c) == MGS_STATS_FRONT_BELOW && isnan(c));
  CHECK(mgs_stats_front_count_at(f, n, 27.5, &c) == MGS_STATS_FRONT_ABOVE && isnan(c));
  CHECK(mgs_stats_front_count_at(f, 0, 25, &c) == MGS_STATS_FRONT_NONE);
  CHECK(mgs_stats_front_count_at(f, n, NAN, &c) == MGS_STATS_FRONT_NONE);
  /* one-point front: only its own PSNR is inside */
  CHECK(mgs_stats_front_count_at(f, 1, 25, &c) == MGS_STATS_FRONT_INSIDE && c == 1000);
  CHECK(mgs_stats_front_count_at(f, 1, 25.1, &c) == MGS_STATS_FRONT_ABOVE);
  /* a variant's seeds: two inside, one above, one below (dominated), one invalid — all counted */
  const mgs_stats_point v[5] = {{700, 25.5}, {2000, 27.0}, {900, 28}, {1500, 24.9}, {0, 26}};
  double ch[5];
  mgs_stats_front_tally t;
  mgs_stats_front_changes(f, n, v, 5, ch, &t);
  CHECK(t.inside == 2 && t.above == 1 && t.below == 1 && t.invalid == 1 && t.dominated == 1);
  CHECK_NEAR(ch[0], log(700 / sqrt(2e6)), 1e-12);
  CHECK_NEAR(ch[1], log(0.5), 1e-12);
  CHECK(isnan(ch[2]) && isnan(ch[3]) && isnan(ch[4]));
}

/* ---- the H3 rule of the 2026-11-24 experiment, kept here only to show why it went ---- */
typedef struct old_curve_pt { double psnr, count; } old_curve_pt;
/* Log-count interpolated linearly in PSNR along the knob sweep's means, sorted by PSNR, with
 * no check that count falls as PSNR falls (apps/cmd_experiment_report.c before the fix). */
static double old_curve_count_at(const old_curve_pt *c, int n, double p) {
  if (p < c[0].psnr || p > c[n - 1].psnr) return NAN;
  for (int i = 0; i + 1 < n; i++)
    if (p <= c[i + 1].psnr) {
      double t = (p - c[i].psnr) / (c[i + 1].psnr - c[i].psnr);
      return exp((1 - t) * log(c[i].count) + t * log(c[i + 1].count));
    }
  return NAN;
}
/* The old verdict: significant when |mean| > 2 max(baseline spread, sd of the change). */
static const char *old_verdict(const double *ch, int n, double spread, double target) {
  double m = 0, s = 0;
  for (int i = 0; i < n; i++) m += ch[i];
  m /= n;
  for (int i = 0; i < n; i++) s += (ch[i] - m) * (ch[i] - m);
  double sd = sqrt(s / (n - 1)), noise = fmax(spread, sd);
  if (!(fabs(m) > 2 * noise)) return "no";
  if (m > 0) return "worse";
  return m <= target ? "yes" : "partly";
}

static void old_h3_rule_credits_a_dominated_variant(void) {
  /* docs/experiment-2026-11-24 (curves.csv, h3.csv), the sphere: the baseline's
     --grad-threshold sweep, every run ... */
  const mgs_stats_point base[5] = {{40848, 29.0391}, {40854, 29.0576}, {40614, 29.0190}, /* x1, seeds 0-2 */
                                   {89622, 28.8021},                                     /* x0.5 */
                                   {18420, 29.1794}};                                    /* x2 */
  /* ... and morse-d-literal, seeds 0-2 (mean 20,038 at 28.96 dB) */
  const mgs_stats_point var[3] = {{20134, 29.0061}, {20271, 28.9466}, {19714, 28.9339}};
  /* old: the curve of means by knob factor (geometric mean of counts), sorted by PSNR */
  const old_curve_pt curve[3] = {{28.8021, 89622}, {(29.0391 + 29.0576 + 29.0190) / 3, cbrt(40848.0 * 40854.0 * 40614.0)},
                                 {29.1794, 18420}};
  double ch[3];
  for (int s = 0; s < 3; s++) ch[s] = var[s].count / old_curve_count_at(curve, 3, var[s].psnr) - 1;
  double spread = 136.864896887405 / 40772; /* the baseline's sd / mean of counts (RESULTS.json) */
  const char *old = old_verdict(ch, 3, spread, -0.40);
  fprintf(stderr, "old rule: changes %+.1f %+.1f %+.1f %% -> %s\n", 100 * ch[0], 100 * ch[1], 100 * ch[2], old);
  CHECK(!strcmp(old, "yes")); /* "needs 40-60 % fewer Gaussians at equal PSNR" */
  /* new: the front of every baseline point is the x2 run alone, which beats every seed of
     the variant on both counts: nothing inside the front's range, all three dominated */
  mgs_stats_point f[5];
  size_t nf = mgs_stats_pareto_front(base, 5, f);
  CHECK(nf == 1 && f[0].count == 18420);
  mgs_stats_front_tally t;
  mgs_stats_front_changes(f, nf, var, 3, ch, &t);
  CHECK(t.inside == 0 && t.below == 3 && t.dominated == 3);
  mgs_stats_interval iv;
  mgs_error err;
  CHECK_OK(mgs_stats_interval_of(ch, 3, 0.95, 0, &iv, &err), &err);
  mgs_stats_verdict v = mgs_stats_verdict_of(iv.lo, iv.hi, -1, log(0.6));
  CHECK(v == MGS_STATS_NA && iv.skipped == 3);
  CHECK(v != MGS_STATS_YES);
}

int main(void) {
  RUN(t_distribution);
  RUN(intervals);
  RUN(verdict_words);
  RUN(holm);
  RUN(pareto_front);
  RUN(old_h3_rule_credits_a_dominated_variant);
  return mgs_test_finish();
}

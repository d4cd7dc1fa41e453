/* The report of `morsegs experiment`: DIR/RESULTS.md (readable), DIR/RESULTS.json (the same
 * figures as data), DIR/curves.csv (every evaluation point of every run), DIR/h3.csv (the
 * count–PSNR points by knob factor) and DIR/plots/<dataset>_*.{png,svg}. This file reads
 * runs and writes; the statistics are stats/mgs_stats.h's.
 *
 * Verdicts (computed here, never typed), per dataset × variant × measure ("cell"):
 *   - the per-seed change against the base run of the same seed on a log scale: log-ratio
 *     for Chamfer, floaters (the count with +1, so a zero count stays finite) and floater
 *     mass; the difference in dB for PSNR and in SSIM;
 *   - its 95 % t-interval over seeds (n−1 dof) and the paired t-test's p; the word from the
 *     interval: yes = wholly beyond the target (H1 −30 %, H2 −90 %, H3 −40 %, H4 +0.5 dB,
 *     SSIM +0.01), partly = beyond 0 in the right direction, worse = beyond 0 in the wrong
 *     one, no = contains 0, n/a = fewer than 2 seeds with a measurement (reason given);
 *   - Holm's correction within each hypothesis' family (H1 α-surface and depth-fused; H2 count and visible mass; H3;
 *     H4 PSNR and SSIM) over every dataset and variant: the Holm word is "no" unless Holm
 *     rejects the cell, else the word of the interval at the level Holm tested it at
 *     (stats/paired.c). Both words are printed, with the interval and the adjusted p.
 *   - H3 compares at equal PSNR against the Pareto front of the base method's sweep (every
 *     knob factor, every seed): each seed's log(count / the front's count at its PSNR);
 *     seeds outside the front's PSNR range are n/a and counted (and how many of all seeds
 *     the front dominates outright). */
#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "apps/mgs_experiment.h"
#include "core/mgs_core.h"
#include "stats/mgs_stats.h"

#define EXP_LEVEL 0.95      /* interval level and Holm's α = 1 − this */
#define EXP_BOOT 4000       /* bootstrap resamples (JSON only) */
#define EXP_BASE "baseline" /* what a variant is measured against unless --base names another */

typedef enum measure { M_CHAMFER, M_CHAMFER_FUSED, M_FLOATERS, M_FLOATER_MASS, M_GAUSSIANS, M_PSNR, M_SSIM } measure;

typedef struct hyp_def {
  const char *key, *family, *title;
  measure what;
  int direction;          /* −1 lower is better */
  double target;          /* as printed: % for log-ratios, else the measure's unit */
  mgs_stats_scale scale;
  double offset;          /* added to both sides before the log-ratio (counts that can be 0) */
  int front;              /* H3: against the base's Pareto front, not the paired base run */
  const char *unit;
} hyp_def;

static const hyp_def HYPS[] = {
  {"H1", "H1", "H1 Chamfer (α-surface)", M_CHAMFER, -1, -30, MGS_STATS_LOG_RATIO, 0, 0, "%"},
  /* the field's protocol: the surface fused from rendered depth (morsegs vdb RUN) */
  {"H1_fused", "H1", "H1 Chamfer (depth-fused surface)", M_CHAMFER_FUSED, -1, -30, MGS_STATS_LOG_RATIO, 0, 0, "%"},
  {"H2", "H2", "H2 floaters (seed's count)", M_FLOATERS, -1, -90, MGS_STATS_LOG_RATIO, 1, 0, "%"},
  {"H2_visible", "H2", "H2 floaters (visible mass)", M_FLOATER_MASS, -1, -90, MGS_STATS_LOG_RATIO, 0, 0, "%"},
  {"H3", "H3", "H3 Gaussians at equal PSNR (Pareto front)", M_GAUSSIANS, -1, -40, MGS_STATS_LOG_RATIO, 0, 1, "%"},
  {"H4", "H4", "H4 PSNR", M_PSNR, +1, 0.5, MGS_STATS_DIFFERENCE, 0, 0, "dB"},
  {"H4_ssim", "H4", "H4 SSIM", M_SSIM, +1, 0.01, MGS_STATS_DIFFERENCE, 0, 0, ""},
};
#define N_HYPS (sizeof HYPS / sizeof HYPS[0])

/* The target on the analysis scale. */
static double analysis_target(const hyp_def *h) { return h->scale == MGS_STATS_LOG_RATIO ? log1p(h->target / 100) : h->target; }
/* A value on the analysis scale as printed: % for log-ratios. */
static double shown(const hyp_def *h, double x) { return h->scale == MGS_STATS_LOG_RATIO ? 100 * expm1(x) : x; }

/* One cell: a variant's measure on a dataset against its base. */
typedef struct exp_cell {
  int computed;
  mgs_stats_interval iv;
  mgs_stats_verdict verdict, verdict_holm;
  double p_holm, holm_level, holm_lo, holm_hi;
  int only_base, only_variant;   /* seeds with a run on one side only: the base's, the variant's */
  mgs_stats_front_tally tally;   /* H3 */
  size_t front_n;                /* H3: points on the base's front */
  double base_mean, base_sd;     /* the base's measure over seeds (reference) */
  char note[240];
} exp_cell;

static double mean_of(const double *x, int n) { double s = 0; for (int i = 0; i < n; i++) s += x[i]; return n ? s / n : NAN; }
static double sd_of(const double *x, int n) {
  if (n < 2) return NAN;
  double m = mean_of(x, n), s = 0;
  for (int i = 0; i < n; i++) s += (x[i] - m) * (x[i] - m);
  return sqrt(s / (n - 1));
}

static const exp_point *final_pt(const exp_run *r) { return r->n_points ? &r->pt[r->n_points - 1] : NULL; }

static double metric(const exp_run *r, measure m) {
  const exp_point *p = final_pt(r);
  if (!p) return NAN;
  switch (m) {
    case M_CHAMFER: return p->chamfer;
    case M_CHAMFER_FUSED: return p->chamfer_fused;
    case M_FLOATERS: return p->floaters;
    case M_FLOATER_MASS: return p->floater_mass;
    case M_GAUSSIANS: return p->gaussians;
    case M_PSNR: return p->psnr;
    default: return p->ssim;
  }
}

/* main (factor 1) run of dataset/variant/seed, or NULL */
static const exp_run *find_run(const exp_report_in *in, const char *ds, const char *var, int seed, double factor) {
  for (size_t i = 0; i < in->n_runs; i++) {
    const exp_run *r = &in->runs[i];
    if (!strcmp(r->dataset, ds) && !strcmp(r->variant, var) && r->seed == seed && r->factor == factor) return r;
  }
  return NULL;
}

/* The count–PSNR points of a variant on a dataset by knob factor (means over seeds: PSNR
 * arithmetic, count geometric), sorted by PSNR — the sweep as a table and h3.csv; the
 * verdict reads the Pareto front of the individual runs instead. */
typedef struct curve_pt { double factor, psnr, count; int seeds; } curve_pt;
static int build_curve(const exp_report_in *in, const char *ds, const char *var, curve_pt *c, int cap) {
  int n = 0;
  for (size_t i = 0; i < in->n_runs; i++) {
    const exp_run *r = &in->runs[i];
    if (strcmp(r->dataset, ds) || strcmp(r->variant, var)) continue;
    const exp_point *p = final_pt(r);
    if (!p || !isfinite(p->psnr) || !(p->gaussians > 0)) continue;
    int k = 0;
    while (k < n && c[k].factor != r->factor) k++;
    if (k == n) { if (n == cap) continue; c[n].factor = r->factor; c[n].psnr = c[n].count = 0; c[n].seeds = 0; n++; }
    c[k].psnr += p->psnr;
    c[k].count += log(p->gaussians);
    c[k].seeds++;
  }
  for (int k = 0; k < n; k++) { c[k].psnr /= c[k].seeds; c[k].count = exp(c[k].count / c[k].seeds); }
  for (int i = 1; i < n; i++)
    for (int j = i; j > 0 && c[j].psnr < c[j - 1].psnr; j--) { curve_pt t = c[j]; c[j] = c[j - 1]; c[j - 1] = t; }
  return n;
}

/* The Pareto front of every run (every knob factor, every seed) of var on ds; malloc'ed
 * (NULL with *n = 0 when there is none). */
static mgs_status variant_front(const exp_report_in *in, const char *ds, const char *var, mgs_stats_point **front, size_t *n,
                                mgs_error *err) {
  *front = NULL;
  *n = 0;
  size_t m = 0;
  mgs_stats_point *pts = malloc((in->n_runs ? in->n_runs : 1) * sizeof *pts);
  if (!pts) return mgs_error_set(err, MGS_ERR_NOMEM, "experiment report: out of memory (front)");
  for (size_t i = 0; i < in->n_runs; i++) {
    const exp_run *r = &in->runs[i];
    const exp_point *p = final_pt(r);
    if (!p || strcmp(r->dataset, ds) || strcmp(r->variant, var)) continue;
    pts[m].count = p->gaussians;
    pts[m].psnr = p->psnr;
    m++;
  }
  *n = mgs_stats_pareto_front(pts, m, pts);
  if (*n == 0) { free(pts); return MGS_OK; }
  *front = pts;
  return MGS_OK;
}

/* A front as one sentence's end: "N Gaussians at P dB, ...". */
static void print_front(FILE *f, const mgs_stats_point *front, size_t nf) {
  if (!nf) fprintf(f, "none.\n");
  for (size_t k = 0; k < nf; k++) fprintf(f, "%s%.0f Gaussians at %.3f dB", k ? ", " : "", front[k].count, front[k].psnr);
  fprintf(f, "%s", nf ? ".\n" : "");
}

/* The variant var's changes are measured against (--base V=B; baseline otherwise). */
static const char *base_of(const exp_report_in *in, const char *var) {
  for (size_t v = 0; v < in->n_variants; v++)
    if (!strcmp(in->variants[v].name, var) && in->variants[v].base[0]) return in->variants[v].base;
  return EXP_BASE;
}

/* The cell of hypothesis h for variant var on dataset ds (before Holm). */
static mgs_status compute_cell(const exp_report_in *in, const char *ds, const char *var, const hyp_def *h, exp_cell *c,
                               mgs_error *err) {
  memset(c, 0, sizeof *c);
  c->computed = 1;
  c->p_holm = c->holm_level = c->holm_lo = c->holm_hi = NAN;
  const char *base = base_of(in, var);
  double ch[64], bvals[64];
  int n = 0, nb = 0;
  mgs_stats_point vpts[64];
  for (int s = 0; s < 64; s++) {
    const exp_run *b = find_run(in, ds, base, s, 1.0), *r = find_run(in, ds, var, s, 1.0);
    double mb = b ? metric(b, h->what) : NAN;
    if (b && isfinite(mb)) bvals[nb++] = mb;
    if (h->front) {
      if (r) { vpts[n].count = metric(r, M_GAUSSIANS); vpts[n].psnr = final_pt(r)->psnr; n++; }
      continue;
    }
    if (b && !r) c->only_base++;
    if (r && !b) c->only_variant++;
    if (!b || !r) continue;
    ch[n++] = mgs_stats_change(metric(r, h->what) + h->offset, mb + h->offset, h->scale);
  }
  c->base_mean = mean_of(bvals, nb);
  c->base_sd = sd_of(bvals, nb);
  mgs_stats_point *front = NULL;
  if (h->front) {
    mgs_status st = variant_front(in, ds, base, &front, &c->front_n, err);
    if (st) return st;
    mgs_stats_front_changes(front, c->front_n, vpts, (size_t)n, ch, &c->tally);
    free(front);
  }
  mgs_status st = mgs_stats_interval_of(ch, (size_t)n, EXP_LEVEL, EXP_BOOT, &c->iv, err);
  if (st) return st;
  c->verdict = mgs_stats_verdict_of(c->iv.lo, c->iv.hi, h->direction, analysis_target(h));
  size_t l = 0;
#define NOTE(...) do { if (l < sizeof c->note) l += (size_t)snprintf(c->note + l, sizeof c->note - l, __VA_ARGS__); } while (0)
  if (h->front) {
    const mgs_stats_front_tally *t = &c->tally;
    if (c->front_n == 0) NOTE("no %s sweep to compare with", base);
    else if (t->below + t->above) {
      NOTE("%d of %d seeds outside the front's PSNR range (%d below, %d above)", t->below + t->above, n, t->below, t->above);
    }
    if (t->dominated) NOTE("%s%d of %d seeds dominated by the front", l ? "; " : "", t->dominated, n);
    if (t->invalid) NOTE("%s%d seeds without a measurement", l ? "; " : "", t->invalid);
  } else {
    if (n == 0) NOTE("no paired measurement");
    else if (c->iv.skipped) NOTE("%d of %d seeds without a measurement%s", c->iv.skipped, n,
                                 h->scale == MGS_STATS_LOG_RATIO ? " (or 0)" : "");
    if (c->only_base) NOTE("%s%d of %s's seeds without a run of %s", l ? "; " : "", c->only_base, base, var);
    if (c->only_variant) NOTE("%s%d seeds without a run of %s", l ? "; " : "", c->only_variant, base);
  }
  if (c->iv.n == 1) NOTE("%s1 seed: no interval", l ? "; " : "");
#undef NOTE
  return MGS_OK;
}
static void fmt_or_na(char *buf, size_t n, const char *fmt, double v) {
  if (isfinite(v)) snprintf(buf, n, fmt, v);
  else if (isinf(v)) snprintf(buf, n, "inf");
  else snprintf(buf, n, "n/a");
}

static void fmt_betti(char *buf, size_t n, const int *b) {
  if (b[0] < 0) snprintf(buf, n, "n/a");
  else snprintf(buf, n, "(%d, %d, %d)", b[0], b[1], b[2]);
}

static void add_num(cJSON *o, const char *k, double v) {
  if (isfinite(v)) cJSON_AddNumberToObject(o, k, v);
  else if (isinf(v)) cJSON_AddStringToObject(o, k, v > 0 ? "inf" : "-inf");
  else cJSON_AddNullToObject(o, k);
}

/* Mean over seeds of the main runs' evaluation points (by index) -> series arrays. */
static size_t mean_series(const exp_report_in *in, const char *ds, const char *var, int which, double *x, double *y) {
  size_t m = 0;
  for (int k = 0; k < EXP_MAX_POINTS; k++) {
    double sx = 0, sy = 0;
    int c = 0;
    for (size_t i = 0; i < in->n_runs; i++) {
      const exp_run *r = &in->runs[i];
      if (strcmp(r->dataset, ds) || strcmp(r->variant, var) || r->factor != 1.0 || k >= r->n_points) continue;
      const exp_point *p = &r->pt[k];
      double v = which == 0 ? p->psnr : which == 1 ? p->chamfer : p->bottleneck;
      if (!isfinite(v) || !isfinite(p->wall_seconds)) continue;
      sx += p->wall_seconds; sy += v; c++;
    }
    if (c) { x[m] = sx / c; y[m] = sy / c; m++; }
  }
  return m;
}

static mgs_status write_plots(const exp_report_in *in, const char *ds, mgs_error *err) {
  char *pd = mgs_path_join(in->dir, "plots");
  mgs_status st = pd ? mgs_mkdir_p(pd, err) : mgs_error_set(err, MGS_ERR_NOMEM, "out of memory");
  if (st) { free(pd); return st; }
  size_t nv = in->n_variants;
  double *buf = calloc(nv * 2 * EXP_MAX_POINTS + 1, sizeof *buf);
  exp_series *s = calloc(nv + 1, sizeof *s);
  if (!buf || !s) { free(buf); free(s); free(pd); return mgs_error_set(err, MGS_ERR_NOMEM, "out of memory"); }
  static const char *names[3] = {"psnr_time", "chamfer_time", "bottleneck_time"};
  static const char *ylabels[3] = {"test PSNR (dB)", "Chamfer distance", "bottleneck distance to the GT diagram"};
  for (int w = 0; w < 4 && !st; w++) {
    size_t ns = 0;
    for (size_t v = 0; v < nv; v++) {
      double *x = buf + v * 2 * EXP_MAX_POINTS, *y = x + EXP_MAX_POINTS;
      size_t m;
      if (w < 3) m = mean_series(in, ds, in->variants[v].name, w, x, y);
      else { /* each method's Pareto front (at most EXP_MAX_POINTS of its points) */
        mgs_stats_point *front = NULL;
        size_t nf = 0;
        st = variant_front(in, ds, in->variants[v].name, &front, &nf, err);
        if (st) break;
        m = nf < EXP_MAX_POINTS ? nf : EXP_MAX_POINTS;
        for (size_t k = 0; k < m; k++) { x[k] = front[k].psnr; y[k] = front[k].count; }
        free(front);
      }
      if (m) { s[ns].name = in->variants[v].name; s[ns].n = m; s[ns].x = x; s[ns].y = y; ns++; }
    }
    if (st) break;
    char base[4200], title[300];
    snprintf(base, sizeof base, "%s/%s_%s", pd, ds, w < 3 ? names[w] : "h3_count_psnr");
    if (w < 3) snprintf(title, sizeof title, "%s: %s against training wall time (mean over seeds)", ds, ylabels[w]);
    else snprintf(title, sizeof title, "%s: Pareto fronts, Gaussians against test PSNR (every knob setting and seed)", ds);
    st = exp_plot_lines(base, title, w < 3 ? "training wall time (s)" : "test PSNR (dB)", w < 3 ? ylabels[w] : "Gaussians",
                        s, ns, w == 3, err);
  }
  free(buf); free(s); free(pd);
  return st;
}

static mgs_status write_csvs(const exp_report_in *in, mgs_error *err) {
  char *p = mgs_path_join(in->dir, "curves.csv");
  mgs_atomic_file *af = NULL;
  FILE *f = NULL;
  mgs_status st = mgs_atomic_open(p, &af, &f, err);
  free(p);
  if (st) return st;
  fprintf(f, "dataset,variant,seed,knob_factor,iteration,wall_seconds,psnr,ssim,gaussians,chamfer,fscore,floaters,"
             "floaters_fraction,floater_mass,floater_mass_fraction,betti0,betti1,betti2,pbetti0,pbetti1,pbetti2,"
             "bottleneck,train_seconds,analysis_seconds,chamfer_fused,fscore_fused,chamfer_mesh,fscore_mesh\n");
  for (size_t i = 0; i < in->n_runs; i++) {
    const exp_run *r = &in->runs[i];
    for (int k = 0; k < r->n_points; k++) {
      const exp_point *q = &r->pt[k];
      fprintf(f, "%s,%s,%d,%g,%d,%.6g,%.6g,%.6g,%.0f,%.9g,%.6g,%.0f,%.6g,%.6g,%.6g,%d,%d,%d,%d,%d,%d,%.6g,%.6g,%.6g,%.9g,%.6g,%.9g,%.6g\n",
              r->dataset, r->variant, r->seed, r->factor, q->iteration, q->wall_seconds, q->psnr, q->ssim, q->gaussians,
              q->chamfer, q->fscore, q->floaters, q->floaters_fraction, q->floater_mass, q->floater_mass_fraction,
              q->betti[0], q->betti[1], q->betti[2], q->betti_persistent[0], q->betti_persistent[1],
              q->betti_persistent[2], q->bottleneck, r->train_seconds, r->analysis_seconds, q->chamfer_fused, q->fscore_fused,
              q->chamfer_mesh, q->fscore_mesh);
    }
  }
  if ((st = mgs_atomic_commit(af, err))) return st;
  p = mgs_path_join(in->dir, "h3.csv");
  st = mgs_atomic_open(p, &af, &f, err);
  free(p);
  if (st) return st;
  fprintf(f, "dataset,variant,knob_factor,seeds,psnr_mean,gaussians_geomean\n");
  for (size_t d = 0; d < in->n_datasets; d++)
    for (size_t v = 0; v < in->n_variants; v++) {
      curve_pt c[32];
      int nc = build_curve(in, in->dataset_names[d], in->variants[v].name, c, 32);
      for (int k = 0; k < nc; k++)
        fprintf(f, "%s,%s,%g,%d,%.6g,%.6g\n", in->dataset_names[d], in->variants[v].name, c[k].factor, c[k].seeds, c[k].psnr, c[k].count);
    }
  return mgs_atomic_commit(af, err);
}

/* Mean over a variant's main runs on ds of one final-point figure (NAN when none has it). */
static double mean_final(const exp_report_in *in, const char *ds, const char *var, int what, int *n_out) {
  double s = 0;
  int n = 0;
  for (int seed = 0; seed < 64; seed++) {
    const exp_run *r = find_run(in, ds, var, seed, 1.0);
    const exp_point *p = r ? final_pt(r) : NULL;
    if (!p) continue;
    double x = what == 0 ? p->gaussians : what == 1 ? p->psnr : what == 2 ? p->chamfer : what == 3 ? p->chamfer_fused
             : what == 4 ? p->chamfer_mesh : r->train_cpu_seconds;
    if (isfinite(x)) { s += x; n++; }
  }
  if (n_out) *n_out = n;
  return n ? s / n : NAN;
}

/* The methods side by side on one dataset: means over seeds of the final figures, the
 * baseline's as the reference (what the issues on the proposal's baselines compare; the
 * verdicts above are the paired statistics). */
static void means_table(FILE *f, const exp_report_in *in, const char *ds) {
  fprintf(f, "\n### Every method beside the 3DGS baseline (means over seeds of the final point; not a verdict)\n\n"
             "| variant | seeds | Gaussians (%% of baseline) | PSNR dB (change) | α-surface Chamfer | depth-fused Chamfer "
             "| SuGaR mesh Chamfer | training CPU s (× baseline) |\n|---|---|---|---|---|---|---|---|\n");
  const double g0 = mean_final(in, ds, EXP_BASE, 0, NULL), p0 = mean_final(in, ds, EXP_BASE, 1, NULL),
               c0 = mean_final(in, ds, EXP_BASE, 5, NULL);
  for (size_t v = 0; v < in->n_variants; v++) {
    const char *var = in->variants[v].name;
    int n = 0;
    const double g = mean_final(in, ds, var, 0, &n);
    if (!n) continue;
    const double p = mean_final(in, ds, var, 1, NULL), cpu = mean_final(in, ds, var, 5, NULL);
    char gs[64], ps[64], ca[32], cf[32], cm[32], cs[64];
    snprintf(gs, sizeof gs, "%.0f (%.0f %%)", g, 100 * g / g0);
    if (!isfinite(g0)) snprintf(gs, sizeof gs, "%.0f", g);
    snprintf(ps, sizeof ps, "%.3f (%+.2f)", p, p - p0);
    if (!isfinite(p0)) snprintf(ps, sizeof ps, "%.3f", p);
    fmt_or_na(ca, sizeof ca, "%.5g", mean_final(in, ds, var, 2, NULL));
    fmt_or_na(cf, sizeof cf, "%.5g", mean_final(in, ds, var, 3, NULL));
    fmt_or_na(cm, sizeof cm, "%.5g", mean_final(in, ds, var, 4, NULL));
    if (isfinite(cpu) && isfinite(c0) && c0 > 0) snprintf(cs, sizeof cs, "%.0f (×%.2f)", cpu, cpu / c0);
    else fmt_or_na(cs, sizeof cs, "%.0f", cpu);
    fprintf(f, "| %s | %d | %s | %s | %s | %s | %s | %s |\n", var, n, gs, ps, ca, cf, cm, cs);
  }
}

/* One row of the runs table: the final point's figures in the formats `morsegs eval` prints. */
static void run_row(FILE *f, const exp_run *r) {
  const exp_point *p = final_pt(r);
  char ch[32], fs[32], fl[32], ms[48], bn[32], an[32], b1[32], b2[32], cf[32], ff[32], cm[32];
  fmt_or_na(ch, sizeof ch, "%.6g", p->chamfer);
  fmt_or_na(fs, sizeof fs, "%.4f", p->fscore);
  fmt_or_na(fl, sizeof fl, "%.0f", p->floaters);
  if (isfinite(p->floater_mass)) snprintf(ms, sizeof ms, "%.4g (%.2f %%)", p->floater_mass, 100 * p->floater_mass_fraction);
  else snprintf(ms, sizeof ms, "n/a");
  fmt_or_na(bn, sizeof bn, "%.4g", p->bottleneck);
  fmt_or_na(an, sizeof an, "%.1f", r->analysis_seconds);
  fmt_betti(b1, sizeof b1, p->betti);
  fmt_betti(b2, sizeof b2, p->betti_persistent);
  fmt_or_na(cf, sizeof cf, "%.6g", p->chamfer_fused);
  fmt_or_na(ff, sizeof ff, "%.4f", p->fscore_fused);
  fmt_or_na(cm, sizeof cm, "%.6g", p->chamfer_mesh);
  fprintf(f, "| %s | %s | %d | %d | %.3f | %.4f | %.0f | %s | %s | %s | %s | %s | %s | %s | %.1f | %s | %s | %s | %s |\n", r->dataset,
          r->variant, r->seed, p->iteration, p->psnr, p->ssim, p->gaussians, ch, fs, fl, ms, b1, b2, bn, r->train_seconds, an,
          cf, ff, cm);
}

/* "−12.3 % [−20.1, −4.0]" (log-ratios shown as %), "+0.12 dB [...]", "n/a". */
static void fmt_interval(char *buf, size_t n, const hyp_def *h, const exp_cell *c) {
  const char *f1 = h->scale == MGS_STATS_LOG_RATIO ? "%+.1f %%" : !strcmp(h->unit, "dB") ? "%+.2f dB" : "%+.4f";
  const char *f3 = h->scale == MGS_STATS_LOG_RATIO ? "%+.1f %% [%+.1f, %+.1f]"
                   : !strcmp(h->unit, "dB")       ? "%+.2f dB [%+.2f, %+.2f]"
                                                  : "%+.4f [%+.4f, %+.4f]";
  if (c->iv.n == 0) snprintf(buf, n, "n/a");
  else if (c->iv.n == 1) snprintf(buf, n, f1, shown(h, c->iv.mean));
  else snprintf(buf, n, f3, shown(h, c->iv.mean), shown(h, c->iv.lo), shown(h, c->iv.hi));
}

static void add_num(cJSON *o, const char *k, double v);

static void cell_json(cJSON *o, const hyp_def *h, const exp_cell *c) {
  cJSON_AddStringToObject(o, "verdict", mgs_stats_verdict_name(c->verdict));
  cJSON_AddStringToObject(o, "verdict_holm", mgs_stats_verdict_name(c->verdict_holm));
  cJSON_AddStringToObject(o, "scale", h->scale == MGS_STATS_LOG_RATIO ? "log-ratio" : "difference");
  cJSON_AddNumberToObject(o, "seeds", c->iv.n);
  cJSON_AddNumberToObject(o, "seeds_without_measurement", c->iv.skipped);
  add_num(o, "change_mean", c->iv.mean);           /* on the analysis scale */
  add_num(o, "change_sd", c->iv.sd);
  add_num(o, "ci95_lo", c->iv.lo);
  add_num(o, "ci95_hi", c->iv.hi);
  add_num(o, "bootstrap95_lo", c->iv.boot_lo);
  add_num(o, "bootstrap95_hi", c->iv.boot_hi);
  add_num(o, "p", c->iv.p);
  add_num(o, "p_holm", c->p_holm);
  add_num(o, "holm_level", c->holm_level);
  add_num(o, "holm_ci_lo", c->holm_lo);
  add_num(o, "holm_ci_hi", c->holm_hi);
  cJSON_AddStringToObject(o, "shown_as", h->scale == MGS_STATS_LOG_RATIO ? "percent" : h->unit);
  add_num(o, "shown_mean", c->iv.n ? shown(h, c->iv.mean) : NAN);
  add_num(o, "shown_ci95_lo", shown(h, c->iv.lo));
  add_num(o, "shown_ci95_hi", shown(h, c->iv.hi));
  add_num(o, "target", h->target);
  add_num(o, "target_analysis_scale", analysis_target(h));
  add_num(o, "baseline_mean", c->base_mean);
  if (h->front) {
    cJSON_AddNumberToObject(o, "front_points", (double)c->front_n);
    cJSON_AddNumberToObject(o, "seeds_inside_front", c->tally.inside);
    cJSON_AddNumberToObject(o, "seeds_below_front", c->tally.below);
    cJSON_AddNumberToObject(o, "seeds_above_front", c->tally.above);
    cJSON_AddNumberToObject(o, "seeds_dominated_by_front", c->tally.dominated);
  }
  cJSON_AddStringToObject(o, "note", c->note);
}

static int variant_compared(const exp_variant_status *v) {
  return strcmp(v->name, EXP_BASE) && strcmp(v->status, "not available") && strcmp(v->status, "pending");
}

/* Every cell, then Holm within each family. cells[(d * nv + v) * N_HYPS + h]. */
static mgs_status compute_cells(const exp_report_in *in, exp_cell *cells, mgs_error *err) {
  const size_t nv = in->n_variants, total = in->n_datasets * nv * N_HYPS;
  for (size_t d = 0; d < in->n_datasets; d++)
    for (size_t v = 0; v < nv; v++)
      for (size_t h = 0; h < N_HYPS; h++) {
        exp_cell *c = &cells[(d * nv + v) * N_HYPS + h];
        mgs_status st = compute_cell(in, in->dataset_names[d], in->variants[v].name, &HYPS[h], c, err);
        if (st) return st;
        c->computed = variant_compared(&in->variants[v]);
      }
  double *p = malloc((total ? total : 1) * sizeof *p), *adj = malloc((total ? total : 1) * sizeof *adj),
         *lvl = malloc((total ? total : 1) * sizeof *lvl);
  if (!p || !adj || !lvl) { free(p); free(adj); free(lvl); return mgs_error_set(err, MGS_ERR_NOMEM, "experiment report: out of memory (Holm)"); }
  mgs_status st = MGS_OK;
  for (size_t h0 = 0; h0 < N_HYPS && !st; h0++) {
    int first = 1; /* each family once, at its first measure */
    for (size_t k = 0; k < h0; k++) first &= strcmp(HYPS[k].family, HYPS[h0].family) != 0;
    if (!first) continue;
    for (size_t i = 0; i < total; i++) {
      size_t h = i % N_HYPS;
      p[i] = cells[i].computed && !strcmp(HYPS[h].family, HYPS[h0].family) ? cells[i].iv.p : NAN;
    }
    st = mgs_stats_holm(p, total, 1 - EXP_LEVEL, adj, lvl, err);
    for (size_t i = 0; i < total && !st; i++) {
      if (!cells[i].computed || strcmp(HYPS[i % N_HYPS].family, HYPS[h0].family)) continue;
      exp_cell *c = &cells[i];
      const hyp_def *h = &HYPS[i % N_HYPS];
      c->p_holm = adj[i];
      c->holm_level = lvl[i];
      mgs_stats_interval_at(&c->iv, lvl[i], &c->holm_lo, &c->holm_hi);
      c->verdict_holm = mgs_stats_verdict_holm(&c->iv, adj[i], 1 - EXP_LEVEL, lvl[i], h->direction, analysis_target(h));
    }
  }
  free(p); free(adj); free(lvl);
  return st;
}

/* "## Verdicts by hypothesis": one table per measure, every dataset and variant, and the
 * count of each word (raw and after Holm). */
static void write_hypothesis_tables(FILE *f, const exp_report_in *in, const exp_cell *cells, cJSON *root) {
  const size_t nv = in->n_variants;
  static const mgs_stats_verdict words[5] = {MGS_STATS_YES, MGS_STATS_PARTLY, MGS_STATS_NO, MGS_STATS_WORSE, MGS_STATS_NA};
  fprintf(f, "## Verdicts by hypothesis\n\nEach MorseGS variant and Topology-GS against the 3DGS baseline, seed by seed. "
             "Change = mean over seeds [95 %% t-interval]; p = paired t-test; Holm p = adjusted within the hypothesis' family.\n\n"
             "| measure | cells | yes | partly | no | worse | n/a | after Holm: yes | partly | no | worse | n/a |\n"
             "|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  cJSON *js = cJSON_AddObjectToObject(root, "verdict_counts");
  for (size_t h = 0; h < N_HYPS; h++) {
    int raw[5] = {0}, holm[5] = {0}, cellsn = 0;
    for (size_t d = 0; d < in->n_datasets; d++)
      for (size_t v = 0; v < nv; v++) {
        const exp_cell *c = &cells[(d * nv + v) * N_HYPS + h];
        if (!c->computed) continue;
        cellsn++;
        for (int w = 0; w < 5; w++) { raw[w] += c->verdict == words[w]; holm[w] += c->verdict_holm == words[w]; }
      }
    fprintf(f, "| %s | %d |", HYPS[h].title, cellsn);
    for (int w = 0; w < 5; w++) fprintf(f, " %d |", raw[w]);
    for (int w = 0; w < 5; w++) fprintf(f, " %d |", holm[w]);
    fprintf(f, "\n");
    cJSON *o = cJSON_AddObjectToObject(js, HYPS[h].key), *a = cJSON_AddObjectToObject(o, "raw"), *b = cJSON_AddObjectToObject(o, "holm");
    for (int w = 0; w < 5; w++) {
      cJSON_AddNumberToObject(a, mgs_stats_verdict_name(words[w]), raw[w]);
      cJSON_AddNumberToObject(b, mgs_stats_verdict_name(words[w]), holm[w]);
    }
  }
  fprintf(f, "\n");
  for (size_t h = 0; h < N_HYPS; h++) {
    fprintf(f, "### %s (target %s %+g %s)\n\n| dataset | variant | seeds | change [95 %% interval] | word | p | Holm p | Holm word | note |\n"
               "|---|---|---|---|---|---|---|---|---|\n", HYPS[h].title, HYPS[h].direction < 0 ? "<=" : ">=", HYPS[h].target, HYPS[h].unit);
    for (size_t d = 0; d < in->n_datasets; d++)
      for (size_t v = 0; v < nv; v++) {
        const exp_cell *c = &cells[(d * nv + v) * N_HYPS + h];
        if (!c->computed) continue;
        char iv[96], p1[32], p2[32];
        fmt_interval(iv, sizeof iv, &HYPS[h], c);
        fmt_or_na(p1, sizeof p1, "%.2g", c->iv.p);
        fmt_or_na(p2, sizeof p2, "%.2g", c->p_holm);
        fprintf(f, "| %s | %s | %d | %s | %s | %s | %s | **%s** | %s |\n", in->dataset_names[d], in->variants[v].name, c->iv.n, iv,
                mgs_stats_verdict_name(c->verdict), p1, p2, mgs_stats_verdict_name(c->verdict_holm), c->note);
      }
    fprintf(f, "\n");
  }
}

/* "## Verdicts against the earlier report" (re-analysis of old results): for each measure,
 * how many cells went from each old word to each new (Holm) word, then the cells that changed. */
static void write_previous_comparison(FILE *f, const exp_report_in *in, const exp_cell *cells) {
  char *text = NULL;
  size_t len;
  if (!in->previous_results || mgs_read_file(in->previous_results, &text, &len, NULL) != MGS_OK) return;
  cJSON *prev = cJSON_Parse(text);
  free(text);
  if (!prev) return;
  static const char *words[6] = {"yes", "partly", "no", "worse", "n/a", "(none)"};
  const size_t nv = in->n_variants;
  fprintf(f, "## Verdicts against the earlier report\n\nEarlier: `%s` (its rule: |mean change| > 2 max(baseline sd, sd of "
             "the change), no correction, H3 on the sweep's means by knob factor). Now: the Holm word. Rows: the earlier "
             "word; columns: the word now.\n\n", in->previous_results);
  for (size_t h = 0; h < N_HYPS; h++) {
    int m[6][6] = {{0}};
    for (size_t d = 0; d < in->n_datasets; d++) {
      const cJSON *od = NULL, *x;
      cJSON_ArrayForEach(x, cJSON_GetObjectItem(prev, "datasets"))
        if (cJSON_IsString(cJSON_GetObjectItem(x, "name")) && !strcmp(cJSON_GetObjectItem(x, "name")->valuestring, in->dataset_names[d])) od = x;
      for (size_t v = 0; v < nv; v++) {
        const exp_cell *c = &cells[(d * nv + v) * N_HYPS + h];
        if (!c->computed) continue;
        const char *old = NULL;
        cJSON_ArrayForEach(x, cJSON_GetObjectItem(od, "variants"))
          if (cJSON_IsString(cJSON_GetObjectItem(x, "name")) && !strcmp(cJSON_GetObjectItem(x, "name")->valuestring, in->variants[v].name)) {
            const cJSON *w = cJSON_GetObjectItem(cJSON_GetObjectItem(cJSON_GetObjectItem(x, "hypotheses"), HYPS[h].key), "verdict");
            if (cJSON_IsString(w)) old = w->valuestring;
          }
        int a = 5, b = 4;
        for (int k = 0; k < 5; k++) {
          if (old && !strcmp(old, words[k])) a = k;
          if (!strcmp(mgs_stats_verdict_name(c->verdict_holm), words[k])) b = k;
        }
        m[a][b]++;
      }
    }
    fprintf(f, "**%s**\n\n| earlier \\ now | yes | partly | no | worse | n/a |\n|---|---|---|---|---|---|\n", HYPS[h].title);
    for (int a = 0; a < 6; a++) {
      int any = 0;
      for (int b = 0; b < 5; b++) any |= m[a][b];
      if (!any) continue;
      fprintf(f, "| %s |", words[a]);
      for (int b = 0; b < 5; b++) fprintf(f, " %d |", m[a][b]);
      fprintf(f, "\n");
    }
    fprintf(f, "\n");
  }
  cJSON_Delete(prev);
}
/* Which builds evaluated the finished runs (result.json's evaluator): a report mixing them says
 * so, since the depth fusion and other measurements changed between builds (--reevaluate). */
static void write_evaluators(FILE *f, cJSON *root, const exp_report_in *in) {
  const char *names[64];
  size_t counts[64], n = 0;
  for (size_t i = 0; i < in->n_runs; i++) {
    const char *ev = in->runs[i].evaluator[0] ? in->runs[i].evaluator : "(not recorded)";
    size_t k = 0;
    while (k < n && strcmp(names[k], ev)) k++;
    if (k == n) {
      if (n == 64) continue;
      names[n] = ev, counts[n++] = 0;
    }
    counts[k]++;
  }
  cJSON *o = cJSON_AddObjectToObject(root, "evaluators");
  for (size_t k = 0; k < n; k++) cJSON_AddNumberToObject(o, names[k], (double)counts[k]);
  if (n < 2) return;
  fprintf(f, "The finished runs were evaluated by %zu builds (fingerprint: runs):", n);
  for (size_t k = 0; k < n; k++) fprintf(f, "%s %s: %zu", k ? "," : "", names[k], counts[k]);
  fprintf(f, "; measurements that changed between them (e.g. the depth fusion) are not comparable across builds: "
             "`morsegs experiment --reevaluate` evaluates runs whose saved models are here again with one build.  \n");
}


mgs_status exp_report_write(const exp_report_in *in, mgs_error *err) {
  const size_t n_cells = in->n_datasets * in->n_variants * N_HYPS;
  exp_cell *cells = calloc(n_cells ? n_cells : 1, sizeof *cells);
  if (!cells) return mgs_error_set(err, MGS_ERR_NOMEM, "experiment report: out of memory (%zu cells)", n_cells);
#define CELL(d, v, h) (((d) * in->n_variants + (v)) * N_HYPS + (h))
  mgs_status st = compute_cells(in, cells, err);
  if (!st) st = write_csvs(in, err);
  if (st) { free(cells); return st; }
  for (size_t d = 0; d < in->n_datasets && !st; d++) st = write_plots(in, in->dataset_names[d], err);
  if (st) { free(cells); return st; }
  char *mdp = mgs_path_join(in->dir, "RESULTS.md");
  mgs_atomic_file *af = NULL;
  FILE *f = NULL;
  st = mgs_atomic_open(mdp, &af, &f, err);
  free(mdp);
  if (st) { free(cells); return st; }
  cJSON *root = cJSON_CreateObject();
  cJSON_AddStringToObject(root, "format", "morsegs-experiment-results");
  cJSON_AddNumberToObject(root, "version", 2); /* 2: intervals, Holm, Pareto front */
  cJSON_AddStringToObject(root, "command", in->command_line);
  time_t now = time(NULL);
  char date[64];
  strftime(date, sizeof date, "%Y-%m-%d %H:%M UTC", gmtime(&now));
  cJSON_AddStringToObject(root, "written", date);
  cJSON_AddNumberToObject(root, "iterations", in->iters);
  cJSON_AddNumberToObject(root, "seeds", in->seeds);
  cJSON_AddNumberToObject(root, "runs_finished", (double)in->n_runs);
  cJSON_AddNumberToObject(root, "runs_planned", (double)in->planned_runs);
  add_num(root, "load_average_at_start", in->load_start);
  cJSON *consts = cJSON_AddObjectToObject(root, "definitions");
  cJSON_AddNumberToObject(consts, "topology_voxels_per_gt_diagonal", in->n_datasets ? in->truths[0].res : EXP_TOPO_RES);
  cJSON_AddNumberToObject(consts, "persistence_threshold_per_gt_diagonal", EXP_PERS_REL);
  cJSON_AddNumberToObject(consts, "visible_floater_distance_per_gt_diagonal", EXP_VISIBLE_DIST_REL);
  cJSON_AddNumberToObject(consts, "surface_tau", EXP_SURFACE_TAU);
  cJSON_AddStringToObject(consts, "knobs", in->knob_desc ? in->knob_desc : "");

  fprintf(f, "# morsegs experiment: results\n\n");
  fprintf(f, "Command: `%s`  \n", in->command_line);
  if (in->source_note) fprintf(f, "%s  \n", in->source_note);
  fprintf(f, "Written %s by morsegs 0.1.0: %zu of %zu planned runs finished; %d iterations per run; %d seed(s).  \n", date,
          in->n_runs, in->planned_runs, in->iters, in->seeds);
  fprintf(f, "Load average (1 min) when the experiment started: %.2f; wall times are taken under whatever load the machine "
             "had (2 cores shared).  \n", in->load_start);
  write_evaluators(f, root, in);
  fprintf(f, "\n");
  fprintf(f, "## Variants\n\n| variant | measured against | status | note |\n|---|---|---|---|\n");
  cJSON *jv = cJSON_AddArrayToObject(root, "variants");
  for (size_t v = 0; v < in->n_variants; v++) {
    fprintf(f, "| %s | %s | %s | %s |\n", in->variants[v].name,
            strcmp(in->variants[v].name, EXP_BASE) ? base_of(in, in->variants[v].name) : "(the reference)",
            in->variants[v].status, in->variants[v].reason);
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "name", in->variants[v].name);
    cJSON_AddStringToObject(o, "status", in->variants[v].status);
    cJSON_AddStringToObject(o, "reason", in->variants[v].reason);
    cJSON_AddStringToObject(o, "base", base_of(in, in->variants[v].name));
    cJSON_AddItemToArray(jv, o);
  }
  fprintf(f, "\nH3 knob sweep: %s\n\n", in->knob_desc && in->knob_desc[0] ? in->knob_desc : "none");
  fprintf(f,
    "## What is measured\n\n"
    "- PSNR, SSIM, Gaussians, Chamfer, F-score and H2 floaters are what `morsegs eval RUN --iteration N` reports "
    "(read from the results.json it writes; its copies are RUN/eval_N.json).\n"
    "- H2 floaters (the seed's definition): Gaussians with opacity < 0.01 whose centre is more than 3 sigma (largest "
    "std-dev) from the GT surface. Visible floater mass: the summed opacity of Gaussians whose centre is farther than "
    "%.0f %% of the GT bounding-box diagonal from the GT surface (share of the total opacity in brackets) - what a viewer "
    "sees as floaters.\n"
    "- Topology: the model's SDF of {A = %.1f} and the GT mesh's SDF (OpenVDB meshToLevelSet), both at voxel = GT diagonal "
    "/ %d, sublevel persistence (V construction) over a band wide enough for the threshold; Betti numbers at level 0 "
    "(all classes, and those persisting over %.0f %% of the GT diagonal); bottleneck distance between the two diagrams "
    "(all dimensions; inf when the numbers of essential classes differ).\n"
    "- Wall time at an evaluation point: the trainer's training seconds (train_stats.json) minus the time between that "
    "point's .ply and the final .ply. Analysis overhead: `analysis_seconds` of train_stats.json when the trainer reports it.\n"
    "- Verdicts (stats/mgs_stats.h): per seed, the change against the baseline run of the same seed on a log scale - "
    "log-ratio for Chamfer, floaters (count + 1, so 0 stays finite) and floater mass, shown as %%; the difference for PSNR "
    "(dB) and SSIM. Over seeds: the mean and its 95 %% t-interval (n-1 degrees of freedom; the report's interval - a "
    "percentile bootstrap is in RESULTS.json only, too narrow at 3-5 seeds) and the paired t-test's p. The word is read "
    "from the interval: **yes** = wholly beyond the target (H1 -30 %%, H2 -90 %%, H3 -40 %%, H4 +0.5 dB PSNR, +0.01 SSIM); "
    "**partly** = beyond 0 in the right direction only; **worse** = beyond 0 in the wrong direction; **no** = contains 0; "
    "**n/a** = fewer than 2 seeds with a measurement (the reason is given).\n"
    "- Multiple comparisons: Holm's step-down correction within each hypothesis' family (H1 α-surface and depth-fused; H2 count and visible mass; "
    "H3; H4 PSNR and SSIM), over every dataset and variant. The Holm word is **no** unless Holm rejects the cell (adjusted "
    "p < 0.05); then it is the word of the wider interval at the level Holm tested that cell at, 1 - 0.05/(m - k + 1) for "
    "the k-th smallest of m p-values (it then excludes 0). Both words are printed; the Holm word is the one to quote.\n"
    "- H3 at equal PSNR: the baseline's Pareto front = the non-dominated (Gaussians, PSNR) points of all its runs (every "
    "knob setting, every seed); a variant seed's change = log(its count / the front's count at its PSNR), log-count "
    "interpolated linearly in PSNR along the front (monotone by construction). Seeds outside the front's PSNR range are "
    "n/a and counted in the note, with how many of all seeds the front dominates outright (fewer Gaussians and higher "
    "PSNR).\n\n",
    100 * EXP_VISIBLE_DIST_REL, EXP_SURFACE_TAU, in->n_datasets ? in->truths[0].res : EXP_TOPO_RES, 100 * EXP_PERS_REL);

  write_previous_comparison(f, in, cells);
  write_hypothesis_tables(f, in, cells, root);
  cJSON *jds = cJSON_AddArrayToObject(root, "datasets");
  for (size_t d = 0; d < in->n_datasets; d++) {
    const char *ds = in->dataset_names[d];
    const exp_truth *t = &in->truths[d];
    cJSON *od = cJSON_CreateObject();
    cJSON_AddItemToArray(jds, od);
    cJSON_AddStringToObject(od, "name", ds);
    cJSON_AddStringToObject(od, "gt_mesh", t->mesh);
    fprintf(f, "## Dataset %s\n\n", ds);
    if (t->mesh[0]) {
      char b1[32], b2[32];
      fmt_betti(b1, sizeof b1, t->betti);
      fmt_betti(b2, sizeof b2, t->betti_persistent);
      char band[48] = "band not recorded"; /* a truth read back from a report (--report-from) */
      if (t->band > 0) snprintf(band, sizeof band, "band %d voxels", t->band);
      fprintf(f, "GT mesh `%s`: SDF Betti numbers %s, persisting over %.4g: %s; voxel %.4g, %s, visible-floater "
                 "distance %.4g.\n\n", t->mesh, b1, t->pers_threshold, b2, t->voxel, band, t->visible_dist);
      cJSON_AddItemToObject(od, "gt_betti", cJSON_CreateIntArray(t->betti, 3));
      cJSON_AddItemToObject(od, "gt_betti_persistent", cJSON_CreateIntArray(t->betti_persistent, 3));
      cJSON_AddNumberToObject(od, "voxel", t->voxel);
      cJSON_AddNumberToObject(od, "persistence_threshold", t->pers_threshold);
      cJSON_AddNumberToObject(od, "visible_floater_distance", t->visible_dist);
    } else {
      fprintf(f, "No GT mesh: geometry, floater and topology measures are n/a.\n\n");
    }
    /* verdicts */
    fprintf(f, "### Verdicts against the baseline: mean change [95 %% interval] → word, Holm word\n\n| variant |");
    for (size_t h = 0; h < N_HYPS; h++) fprintf(f, " %s |", HYPS[h].title);
    fprintf(f, "\n|---|");
    for (size_t h = 0; h < N_HYPS; h++) fprintf(f, "---|");
    fprintf(f, "\n| target |");
    for (size_t h = 0; h < N_HYPS; h++) fprintf(f, " %s %+g %s |", HYPS[h].direction < 0 ? "<=" : ">=", HYPS[h].target, HYPS[h].unit);
    fprintf(f, "\n");
    cJSON *jvars = cJSON_AddArrayToObject(od, "variants");
    for (size_t v = 0; v < in->n_variants; v++) {
      const char *var = in->variants[v].name;
      cJSON *ov = cJSON_CreateObject();
      cJSON_AddItemToArray(jvars, ov);
      cJSON_AddStringToObject(ov, "name", var);
      cJSON_AddStringToObject(ov, "status", in->variants[v].status);
      if (strcmp(base_of(in, var), EXP_BASE)) fprintf(f, "| %s (against %s) |", var, base_of(in, var));
      else fprintf(f, "| %s |", var);
      cJSON_AddStringToObject(ov, "base", base_of(in, var));
      if (!strcmp(in->variants[v].status, "not available") || !strcmp(in->variants[v].status, "pending")) {
        for (size_t h = 0; h < N_HYPS; h++) fprintf(f, " %s |", in->variants[v].status);
        fprintf(f, "\n");
        continue;
      }
      cJSON *oh = cJSON_AddObjectToObject(ov, "hypotheses");
      for (size_t h = 0; h < N_HYPS; h++) {
        const exp_cell *c = &cells[CELL(d, v, h)];
        cJSON *o = cJSON_AddObjectToObject(oh, HYPS[h].key);
        if (!strcmp(var, EXP_BASE)) {
          char a[32], b[32];
          fmt_or_na(a, sizeof a, "%.5g", c->base_mean);
          fmt_or_na(b, sizeof b, "%.2g", c->base_sd);
          fprintf(f, " %s ± %s (reference) |", a, b);
          cJSON_AddStringToObject(o, "verdict", "reference");
          add_num(o, "baseline_mean", c->base_mean);
          add_num(o, "baseline_sd", c->base_sd);
          continue;
        }
        char iv[96];
        fmt_interval(iv, sizeof iv, &HYPS[h], c);
        fprintf(f, " %s → **%s**, Holm **%s**%s%s%s |", iv, mgs_stats_verdict_name(c->verdict),
                mgs_stats_verdict_name(c->verdict_holm), c->note[0] ? " (" : "", c->note, c->note[0] ? ")" : "");
        cell_json(o, &HYPS[h], c);
      }
      fprintf(f, "\n");
    }
    /* topology over the final models */
    fprintf(f, "\n### Topology of the final α-surface against the GT (seed Theorem 1 made measurable)\n\n"
               "| variant | seeds | persistent Betti = GT | Betti (all classes), per seed | bottleneck distance, mean ± sd |\n"
               "|---|---|---|---|---|\n");
    for (size_t v = 0; v < in->n_variants; v++) {
      const char *var = in->variants[v].name;
      double bn[64];
      int nb = 0, match = 0, n = 0, inf = 0;
      char all[512] = "";
      for (int s = 0; s < 64; s++) {
        const exp_run *r = find_run(in, ds, var, s, 1.0);
        if (!r) continue;
        const exp_point *p = final_pt(r);
        n++;
        if (p->betti_persistent[0] >= 0 && !memcmp(p->betti_persistent, t->betti_persistent, sizeof t->betti_persistent)) match++;
        char b[40];
        fmt_betti(b, sizeof b, p->betti);
        size_t l = strlen(all);
        snprintf(all + l, sizeof all - l, "%s%s", l ? " " : "", b);
        if (isfinite(p->bottleneck)) bn[nb++] = p->bottleneck;
        else if (isinf(p->bottleneck)) inf++;
      }
      if (!n) continue;
      char a[32], b[32];
      fmt_or_na(a, sizeof a, "%.4g", mean_of(bn, nb));
      fmt_or_na(b, sizeof b, "%.2g", sd_of(bn, nb));
      fprintf(f, "| %s | %d | %d of %d | %s | %s ± %s%s |\n", var, n, match, n, all, a, b, inf ? " (some inf)" : "");
    }
    means_table(f, in, ds);
    /* the runs */
    fprintf(f, "\n### Runs (final evaluation point; figures as `morsegs eval` reports them)\n\n"
               "| dataset | variant | seed | iteration | PSNR | SSIM | Gaussians | Chamfer | F-score | floaters (H2) | visible "
               "floater mass | Betti | persistent Betti | bottleneck | train s | analysis s | fused Chamfer | fused F-score "
               "| SuGaR mesh Chamfer |\n"
               "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
    cJSON *jr = cJSON_AddArrayToObject(od, "runs");
    for (size_t i = 0; i < in->n_runs; i++) {
      const exp_run *r = &in->runs[i];
      if (strcmp(r->dataset, ds) || r->factor != 1.0) continue;
      run_row(f, r);
      const exp_point *p = final_pt(r);
      cJSON *o = cJSON_CreateObject();
      cJSON_AddStringToObject(o, "variant", r->variant);
      cJSON_AddNumberToObject(o, "seed", r->seed);
      cJSON_AddNumberToObject(o, "iteration", p->iteration);
      add_num(o, "PSNR", p->psnr);
      add_num(o, "SSIM", p->ssim);
      add_num(o, "gaussians", p->gaussians);
      add_num(o, "chamfer", p->chamfer);
      add_num(o, "fscore", p->fscore);
      add_num(o, "chamfer_fused", p->chamfer_fused);
      add_num(o, "fscore_fused", p->fscore_fused);
      add_num(o, "chamfer_mesh", p->chamfer_mesh);
      add_num(o, "fscore_mesh", p->fscore_mesh);
      add_num(o, "floaters", p->floaters);
      add_num(o, "floater_mass", p->floater_mass);
      add_num(o, "floater_mass_fraction", p->floater_mass_fraction);
      cJSON_AddItemToObject(o, "betti", cJSON_CreateIntArray(p->betti, 3));
      cJSON_AddItemToObject(o, "betti_persistent", cJSON_CreateIntArray(p->betti_persistent, 3));
      add_num(o, "bottleneck", p->bottleneck);
      add_num(o, "train_seconds", r->train_seconds);
      add_num(o, "train_cpu_seconds", r->train_cpu_seconds);
      add_num(o, "analysis_seconds", r->analysis_seconds);
      cJSON_AddItemToArray(jr, o);
    }
    /* H3 curves */
    fprintf(f, "\n### H3: Gaussian count against PSNR (knob multiplier; means over seeds)\n\n"
               "| variant | knob multiplier | seeds | PSNR | Gaussians (geometric mean) |\n|---|---|---|---|---|\n");
    for (size_t v = 0; v < in->n_variants; v++) {
      curve_pt c[32];
      int nc = build_curve(in, ds, in->variants[v].name, c, 32);
      for (int k = 0; k < nc; k++)
        fprintf(f, "| %s | %g | %d | %.3f | %.0f |\n", in->variants[v].name, c[k].factor, c[k].seeds, c[k].psnr, c[k].count);
    }
    {
      mgs_stats_point *front = NULL;
      size_t nf = 0;
      if ((st = variant_front(in, ds, EXP_BASE, &front, &nf, err))) break;
      fprintf(f, "\nThe %s's Pareto front (what H3 compares with; every run, every knob setting): ", EXP_BASE);
      print_front(f, front, nf);
      cJSON *jf = cJSON_AddArrayToObject(od, "baseline_front");
      for (size_t k = 0; k < nf; k++) {
        cJSON *o = cJSON_CreateObject();
        cJSON_AddNumberToObject(o, "gaussians", front[k].count);
        cJSON_AddNumberToObject(o, "psnr", front[k].psnr);
        cJSON_AddItemToArray(jf, o);
      }
      free(front);
    }
    for (size_t v = 0; v < in->n_variants && st == MGS_OK; v++) { /* the other bases' fronts (--base) */
      const char *b = in->variants[v].name;
      int is_base = 0;
      for (size_t w = 0; w < in->n_variants; w++) is_base |= !strcmp(base_of(in, in->variants[w].name), b);
      if (!is_base || !strcmp(b, EXP_BASE)) continue;
      mgs_stats_point *front = NULL;
      size_t nf = 0;
      if ((st = variant_front(in, ds, b, &front, &nf, err))) break;
      fprintf(f, "\nThe Pareto front of %s (what H3 compares the variants measured against it with): ", b);
      print_front(f, front, nf);
      free(front);
    }
    if (st) break;
    fprintf(f, "\n### Curves\n\nCSV: [curves.csv](curves.csv) (every evaluation point), [h3.csv](h3.csv).\n\n");
    static const char *pl[4][2] = {{"psnr_time", "PSNR against wall time"}, {"chamfer_time", "Chamfer against wall time"},
                                   {"bottleneck_time", "bottleneck distance against wall time"},
                                   {"h3_count_psnr", "Pareto fronts: Gaussians against PSNR"}};
    for (int k = 0; k < 4; k++) fprintf(f, "![%s](plots/%s_%s.png) ([SVG](plots/%s_%s.svg))\n", pl[k][1], ds, pl[k][0], ds, pl[k][0]);
    fprintf(f, "\n");
  }
#undef CELL
  free(cells);
  if (st) { mgs_atomic_abort(af); cJSON_Delete(root); return st; }
  st = mgs_atomic_commit(af, err);
  char *text = cJSON_Print(root);
  cJSON_Delete(root);
  char *jp = mgs_path_join(in->dir, "RESULTS.json");
  if (!st) st = text && jp ? mgs_write_file_atomic(jp, text, strlen(text), err) : mgs_error_set(err, MGS_ERR_NOMEM, "out of memory");
  free(text);
  free(jp);
  return st;
}

/* ---------------------------------------------------------------- re-analysis */
static const char CURVES_HEADER[] =
  "dataset,variant,seed,knob_factor,iteration,wall_seconds,psnr,ssim,gaussians,chamfer,fscore,floaters,"
  "floaters_fraction,floater_mass,floater_mass_fraction,betti0,betti1,betti2,pbetti0,pbetti1,pbetti2,"
  "bottleneck,train_seconds,analysis_seconds";
/* since session 6: the depth-fused surface and SuGaR's mesh (older files have 24 fields) */
static const char CURVES_HEADER_MORE[] = ",chamfer_fused,fscore_fused,chamfer_mesh,fscore_mesh";

static int in_list(const char *csv, const char *name) {
  size_t l = strlen(name);
  for (const char *p = csv; p && *p;) {
    const char *e = strchr(p, ',');
    size_t n = e ? (size_t)(e - p) : strlen(p);
    if (n == l && !strncmp(p, name, l)) return 1;
    p = e ? e + 1 : NULL;
  }
  return 0;
}

/* FROM/curves.csv -> runs (one per dataset, variant, seed, knob factor; points in file order). */
static mgs_status read_curves(const char *path, const char *keep, exp_run **runs, size_t *n_runs, mgs_error *err) {
  char *text = NULL;
  size_t len;
  *runs = NULL;
  *n_runs = 0;
  mgs_status st = mgs_read_file(path, &text, &len, err);
  if (st) return st;
  size_t cap = 0, n = 0;
  exp_run *r = NULL;
  int line_no = 0, nf = 24;
  char *save = NULL;
  for (char *line = strtok_r(text, "\n", &save); line; line = strtok_r(NULL, "\n", &save)) {
    line_no++;
    line[strcspn(line, "\r")] = 0;
    if (line_no == 1) {
      const size_t hl = strlen(CURVES_HEADER);
      if (!strncmp(line, CURVES_HEADER, hl) && !strcmp(line + hl, CURVES_HEADER_MORE)) nf = 28;
      else if (strcmp(line, CURVES_HEADER)) { st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: not a curves.csv of morsegs experiment (header)", path); break; }
      continue;
    }
    char *f[28], *sv = NULL;
    int k = 0;
    for (char *t = strtok_r(line, ",", &sv); t && k < 28; t = strtok_r(NULL, ",", &sv)) f[k++] = t;
    if (k != nf) { st = mgs_error_set(err, MGS_ERR_FORMAT, "%s:%d: %d fields, want %d", path, line_no, k, nf); break; }
    if (keep && strcmp(f[1], EXP_BASE) && !in_list(keep, f[1])) continue;
    double v[28];
    for (int q = 24; q < 28; q++) v[q] = NAN;
    for (int q = 2; q < nf; q++) {
      char *end;
      v[q] = strtod(f[q], &end);
      if (end == f[q] || *end) { st = mgs_error_set(err, MGS_ERR_FORMAT, "%s:%d: field %d is not a number ('%s')", path, line_no, q + 1, f[q]); break; }
    }
    if (st) break;
    exp_run *run = NULL;
    for (size_t i = 0; i < n && !run; i++)
      if (!strcmp(r[i].dataset, f[0]) && !strcmp(r[i].variant, f[1]) && r[i].seed == (int)v[2] && r[i].factor == v[3]) run = &r[i];
    if (!run) {
      if (n == cap) {
        size_t nc = cap ? 2 * cap : 64;
        exp_run *p = realloc(r, nc * sizeof *p);
        if (!p) { st = mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory (%zu runs)", path, nc); break; }
        r = p;
        cap = nc;
      }
      run = &r[n++];
      memset(run, 0, sizeof *run);
      snprintf(run->dataset, sizeof run->dataset, "%s", f[0]);
      snprintf(run->variant, sizeof run->variant, "%s", f[1]);
      run->seed = (int)v[2];
      run->factor = v[3];
      run->train_seconds = v[22];
      run->analysis_seconds = v[23];
      run->train_cpu_seconds = run->eval_cpu_seconds = run->run_seconds = NAN; /* not in curves.csv */
    }
    if (run->n_points == EXP_MAX_POINTS) { st = mgs_error_set(err, MGS_ERR_FORMAT, "%s:%d: more than %d points in one run", path, line_no, EXP_MAX_POINTS); break; }
    exp_point *p = &run->pt[run->n_points++];
    memset(p, 0, sizeof *p);
    p->iteration = (int)v[4];
    if (p->iteration > run->iters) run->iters = p->iteration;
    p->wall_seconds = v[5]; p->psnr = v[6]; p->ssim = v[7]; p->gaussians = v[8]; p->chamfer = v[9]; p->fscore = v[10];
    p->floaters = v[11]; p->floaters_fraction = v[12]; p->floater_mass = v[13]; p->floater_mass_fraction = v[14];
    for (int q = 0; q < 3; q++) { p->betti[q] = (int)v[15 + q]; p->betti_persistent[q] = (int)v[18 + q]; }
    p->bottleneck = v[21];
    p->chamfer_fused = v[24]; p->fscore_fused = v[25]; p->chamfer_mesh = v[26]; p->fscore_mesh = v[27];
    p->measure_seconds = NAN;
  }
  free(text);
  if (st) { free(r); return st; }
  *runs = r;
  *n_runs = n;
  return MGS_OK;
}

static double json_num(const cJSON *o, const char *k, double dflt) {
  const cJSON *x = cJSON_GetObjectItem(o, k);
  return cJSON_IsNumber(x) ? x->valuedouble : dflt;
}

static void json_ints3(const cJSON *o, const char *k, int *v) {
  const cJSON *a = cJSON_GetObjectItem(o, k);
  for (int q = 0; q < 3; q++) {
    const cJSON *x = cJSON_GetArrayItem(a, q);
    v[q] = cJSON_IsNumber(x) ? x->valueint : -1;
  }
}

mgs_status exp_report_from_results(const char *from, const char *out, const char *variants, mgs_error *err) {
  char *cp = mgs_path_join(from, "curves.csv"), *jp = mgs_path_join(from, "RESULTS.json"), *text = NULL;
  exp_run *runs = NULL;
  size_t n_runs = 0, len;
  cJSON *j = NULL;
  exp_truth *truths = NULL;
  exp_variant_status *vs = NULL;
  const char **names = NULL;
  char *command = NULL, *note = NULL;
  mgs_status st = cp && jp ? MGS_OK : mgs_error_set(err, MGS_ERR_NOMEM, "out of memory");
  if (!st) st = read_curves(cp, variants, &runs, &n_runs, err);
  if (!st) st = mgs_read_file(jp, &text, &len, err);
  if (!st && !(j = cJSON_Parse(text))) st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: not JSON", jp);
  const cJSON *jds = j ? cJSON_GetObjectItem(j, "datasets") : NULL, *jvs = j ? cJSON_GetObjectItem(j, "variants") : NULL;
  if (!st && (!cJSON_IsArray(jds) || !cJSON_IsArray(jvs)))
    st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: no datasets or variants (not a RESULTS.json of morsegs experiment)", jp);
  size_t nd = st ? 0 : (size_t)cJSON_GetArraySize(jds), nv = st ? 0 : (size_t)cJSON_GetArraySize(jvs), kv = 0;
  if (!st) {
    truths = calloc(nd ? nd : 1, sizeof *truths);
    names = calloc(nd ? nd : 1, sizeof *names);
    vs = calloc(nv ? nv : 1, sizeof *vs);
    if (!truths || !names || !vs) st = mgs_error_set(err, MGS_ERR_NOMEM, "out of memory");
  }
  const cJSON *defs = j ? cJSON_GetObjectItem(j, "definitions") : NULL;
  for (size_t d = 0; d < nd && !st; d++) {
    const cJSON *o = cJSON_GetArrayItem(jds, (int)d), *nm = cJSON_GetObjectItem(o, "name"), *mesh = cJSON_GetObjectItem(o, "gt_mesh");
    if (!cJSON_IsString(nm)) { st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: dataset %zu has no name", jp, d); break; }
    names[d] = nm->valuestring;
    exp_truth *t = &truths[d];
    t->res = (int)json_num(defs, "topology_voxels_per_gt_diagonal", EXP_TOPO_RES);
    if (cJSON_IsString(mesh)) snprintf(t->mesh, sizeof t->mesh, "%s", mesh->valuestring);
    json_ints3(o, "gt_betti", t->betti);
    json_ints3(o, "gt_betti_persistent", t->betti_persistent);
    t->voxel = json_num(o, "voxel", NAN);
    t->pers_threshold = json_num(o, "persistence_threshold", NAN);
    t->visible_dist = json_num(o, "visible_floater_distance", NAN);
  }
  for (size_t v = 0; v < nv && !st; v++) {
    const cJSON *o = cJSON_GetArrayItem(jvs, (int)v), *nm = cJSON_GetObjectItem(o, "name"), *s = cJSON_GetObjectItem(o, "status"),
                *rs = cJSON_GetObjectItem(o, "reason"), *bs = cJSON_GetObjectItem(o, "base");
    if (!cJSON_IsString(nm)) { st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: variant %zu has no name", jp, v); break; }
    if (variants && strcmp(nm->valuestring, EXP_BASE) && !in_list(variants, nm->valuestring)) continue;
    snprintf(vs[kv].name, sizeof vs[kv].name, "%s", nm->valuestring);
    snprintf(vs[kv].status, sizeof vs[kv].status, "%s", cJSON_IsString(s) ? s->valuestring : "available");
    snprintf(vs[kv].reason, sizeof vs[kv].reason, "%s", cJSON_IsString(rs) ? rs->valuestring : "");
    if (cJSON_IsString(bs) && strcmp(bs->valuestring, EXP_BASE) && strcmp(bs->valuestring, nm->valuestring))
      snprintf(vs[kv].base, sizeof vs[kv].base, "%s", bs->valuestring);
    kv++;
  }
  if (!st) st = mgs_mkdir_p(out, err);
  if (!st) {
    const cJSON *cmd = cJSON_GetObjectItem(j, "command"), *wr = cJSON_GetObjectItem(j, "written"), *kn = cJSON_GetObjectItem(defs, "knobs");
    size_t lc = strlen(from) + strlen(out) + (variants ? strlen(variants) : 0) + 96;
    size_t ln = (cJSON_IsString(cmd) ? strlen(cmd->valuestring) : 0) + 256;
    command = malloc(lc);
    note = malloc(ln);
    if (!command || !note) st = mgs_error_set(err, MGS_ERR_NOMEM, "out of memory");
    else {
      snprintf(command, lc, "morsegs experiment --report-from %s -o %s%s%s", from, out, variants ? " --variants " : "", variants ? variants : "");
      snprintf(note, ln, "Re-analysis, no training: the %zu runs of `%s` (written %s), read from its curves.csv.",
               n_runs, cJSON_IsString(cmd) ? cmd->valuestring : "?", cJSON_IsString(wr) ? wr->valuestring : "?");
      exp_report_in in = {.dir = out, .command_line = command, .iters = (int)json_num(j, "iterations", 0),
                          .seeds = (int)json_num(j, "seeds", 0), .knob_desc = cJSON_IsString(kn) ? kn->valuestring : "",
                          .n_datasets = nd, .dataset_names = names, .truths = truths, .n_variants = kv, .variants = vs,
                          .n_runs = n_runs, .runs = runs, .planned_runs = n_runs, .load_start = json_num(j, "load_average_at_start", NAN),
                          .source_note = note, .previous_results = jp};
      st = exp_report_write(&in, err);
    }
  }
  cJSON_Delete(j);
  free(text); free(cp); free(jp); free(runs); free(truths); free(names); free(vs); free(command); free(note);
  return st;
}

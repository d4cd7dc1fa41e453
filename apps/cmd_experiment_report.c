/* The report of `morsegs experiment`: DIR/RESULTS.md (readable), DIR/RESULTS.json (the same
 * figures as data), DIR/curves.csv (every evaluation point of every run), DIR/h3.csv (the
 * count–PSNR curves) and DIR/plots/<dataset>_*.{png,svg}.
 *
 * Verdicts (computed here, never typed): for each variant and hypothesis, the per-seed change
 * against the baseline run of the same seed (relative for Chamfer, floaters, Gaussian counts;
 * dB for PSNR); mean and sd over seeds. The seed-to-seed spread is the baseline's own sd over
 * seeds in the same units (relative: divided by its mean). With noise = max(spread, sd of the
 * change), a change is significant when |mean| > 2 noise. Then "yes" = significant, in the
 * hypothesis' direction and at least the seed's target (H1 -30 %, H2 -90 %, H3 -40 %, H4
 * +0.5 dB, SSIM +0.01); "partly" = significant in the right direction, short of the target; "worse" =
 * significant in the wrong direction; "no" = not significant; "n/a" = fewer than 2 seeds
 * or no measurement. H3 compares at equal PSNR: the variant's count against the baseline's
 * count–PSNR curve (the knob sweep, log-count interpolated linearly in PSNR) at the
 * variant's PSNR, per seed. */
#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "apps/mgs_experiment.h"
#include "core/mgs_core.h"

typedef struct hyp_def {
  const char *key, *title, *unit;
  int direction;      /* -1 lower is better */
  double target;
  int relative;
  const char *fmt, *fmt_sd; /* change (x100 when relative) and its sd */
} hyp_def;

/* Order matters: metric() below reads the measure by index. */
static const hyp_def HYPS[] = {
  {"H1", "H1 Chamfer", "%", -1, -0.30, 1, "%+.1f", "%.1f"},
  {"H2", "H2 floaters (seed's count)", "%", -1, -0.90, 1, "%+.1f", "%.1f"},
  {"H2_visible", "H2 floaters (visible mass)", "%", -1, -0.90, 1, "%+.1f", "%.1f"},
  {"H3", "H3 Gaussians at equal PSNR", "%", -1, -0.40, 1, "%+.1f", "%.1f"},
  {"H4", "H4 PSNR", "dB", +1, 0.5, 0, "%+.2f", "%.2f"},
  {"H4_ssim", "H4 SSIM", "", +1, 0.01, 0, "%+.4f", "%.4f"},
};
#define N_HYPS (sizeof HYPS / sizeof HYPS[0])

void exp_verdict_compute(const double *change, int n, double spread, int direction, double target, exp_verdict *v) {
  memset(v, 0, sizeof *v);
  v->n = n;
  v->spread = spread;
  v->mean = v->sd = NAN;
  v->verdict = "n/a";
  if (n < 1) { snprintf(v->note, sizeof v->note, "no paired measurement"); return; }
  double m = 0;
  for (int i = 0; i < n; i++) m += change[i];
  m /= n;
  double s = 0;
  for (int i = 0; i < n; i++) s += (change[i] - m) * (change[i] - m);
  v->mean = m;
  v->sd = n > 1 ? sqrt(s / (n - 1)) : NAN;
  if (n < 2 || !isfinite(spread)) { snprintf(v->note, sizeof v->note, "needs 2 seeds"); return; }
  const double noise = fmax(spread, v->sd);
  const int significant = fabs(m) > 2 * noise;
  const int right = direction * m > 0;
  const int reached = direction < 0 ? m <= target : m >= target;
  v->verdict = !significant ? "no" : !right ? "worse" : reached ? "yes" : "partly";
}

static double mean_of(const double *x, int n) { double s = 0; for (int i = 0; i < n; i++) s += x[i]; return n ? s / n : NAN; }
static double sd_of(const double *x, int n) {
  if (n < 2) return NAN;
  double m = mean_of(x, n), s = 0;
  for (int i = 0; i < n; i++) s += (x[i] - m) * (x[i] - m);
  return sqrt(s / (n - 1));
}

static const exp_point *final_pt(const exp_run *r) { return r->n_points ? &r->pt[r->n_points - 1] : NULL; }

static double metric(const exp_run *r, int h) {
  const exp_point *p = final_pt(r);
  if (!p) return NAN;
  switch (h) {
    case 0: return p->chamfer;
    case 1: return p->floaters;
    case 2: return p->floater_mass;
    case 3: return p->gaussians;
    case 4: return p->psnr;
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

/* The count–PSNR curve of a variant on a dataset: one point per knob factor (means over seeds),
 * sorted by PSNR. Returns the number of points. */
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

/* Count on the curve at PSNR p (log-linear); NAN outside its PSNR range. */
static double curve_count_at(const curve_pt *c, int n, double p) {
  if (n < 1 || !isfinite(p)) return NAN;
  if (n == 1) return p == c[0].psnr ? c[0].count : NAN;
  if (p < c[0].psnr || p > c[n - 1].psnr) return NAN;
  for (int i = 0; i + 1 < n; i++)
    if (p <= c[i + 1].psnr) {
      double d = c[i + 1].psnr - c[i].psnr, t = d > 0 ? (p - c[i].psnr) / d : 0;
      return exp((1 - t) * log(c[i].count) + t * log(c[i + 1].count));
    }
  return NAN;
}

/* Verdict of hypothesis h for variant var on dataset ds. */
static void hypothesis(const exp_report_in *in, const char *ds, const char *var, int h, exp_verdict *v, double *base_mean,
                       double *base_sd) {
  double ch[64], bvals[64];
  int n = 0, nb = 0;
  curve_pt curve[32];
  int nc = h == 3 ? build_curve(in, ds, "baseline", curve, 32) : 0;
  int outside = 0, zero_base = 0;
  for (int s = 0; s < 64; s++) {
    const exp_run *b = find_run(in, ds, "baseline", s, 1.0), *r = find_run(in, ds, var, s, 1.0);
    double mb = b ? metric(b, h) : NAN;
    if (b && isfinite(mb) && nb < 64) bvals[nb++] = mb;
    if (!b || !r) continue;
    double mv = metric(r, h);
    if (!isfinite(mb) || !isfinite(mv)) continue;
    double c;
    if (h == 3) {
      double nbp = curve_count_at(curve, nc, final_pt(r)->psnr);
      if (!isfinite(nbp)) { outside++; continue; }
      c = mv / nbp - 1;
    } else if (HYPS[h].relative) {
      if (!(mb > 0)) { zero_base++; continue; }
      c = mv / mb - 1;
    } else {
      c = mv - mb;
    }
    ch[n++] = c;
  }
  *base_mean = mean_of(bvals, nb);
  *base_sd = sd_of(bvals, nb);
  double spread = HYPS[h].relative ? (*base_mean > 0 ? *base_sd / *base_mean : NAN) : *base_sd;
  exp_verdict_compute(ch, n, spread, HYPS[h].direction, HYPS[h].target, v);
  if (h == 3 && nc < 2) snprintf(v->note, sizeof v->note, "needs the knob sweep (baseline count-PSNR curve)");
  else if (outside) snprintf(v->note, sizeof v->note, "%d seed(s) outside the baseline curve's PSNR range", outside);
  else if (zero_base) snprintf(v->note, sizeof v->note, "baseline measure is 0 for %d seed(s)", zero_base);
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
      else {
        curve_pt c[32];
        int nc = build_curve(in, ds, in->variants[v].name, c, 32);
        for (int k = 0; k < nc; k++) { x[k] = c[k].psnr; y[k] = c[k].count; }
        m = (size_t)nc;
      }
      if (m) { s[ns].name = in->variants[v].name; s[ns].n = m; s[ns].x = x; s[ns].y = y; ns++; }
    }
    char base[4200], title[300];
    snprintf(base, sizeof base, "%s/%s_%s", pd, ds, w < 3 ? names[w] : "h3_count_psnr");
    if (w < 3) snprintf(title, sizeof title, "%s: %s against training wall time (mean over seeds)", ds, ylabels[w]);
    else snprintf(title, sizeof title, "%s: Gaussians against test PSNR (densification knob sweep)", ds);
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
             "bottleneck,train_seconds,analysis_seconds\n");
  for (size_t i = 0; i < in->n_runs; i++) {
    const exp_run *r = &in->runs[i];
    for (int k = 0; k < r->n_points; k++) {
      const exp_point *q = &r->pt[k];
      fprintf(f, "%s,%s,%d,%g,%d,%.6g,%.6g,%.6g,%.0f,%.9g,%.6g,%.0f,%.6g,%.6g,%.6g,%d,%d,%d,%d,%d,%d,%.6g,%.6g,%.6g\n",
              r->dataset, r->variant, r->seed, r->factor, q->iteration, q->wall_seconds, q->psnr, q->ssim, q->gaussians,
              q->chamfer, q->fscore, q->floaters, q->floaters_fraction, q->floater_mass, q->floater_mass_fraction,
              q->betti[0], q->betti[1], q->betti[2], q->betti_persistent[0], q->betti_persistent[1],
              q->betti_persistent[2], q->bottleneck, r->train_seconds, r->analysis_seconds);
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

/* One row of the runs table: the final point's figures in the formats `morsegs eval` prints. */
static void run_row(FILE *f, const exp_run *r) {
  const exp_point *p = final_pt(r);
  char ch[32], fs[32], fl[32], ms[48], bn[32], an[32], b1[32], b2[32];
  fmt_or_na(ch, sizeof ch, "%.6g", p->chamfer);
  fmt_or_na(fs, sizeof fs, "%.4f", p->fscore);
  fmt_or_na(fl, sizeof fl, "%.0f", p->floaters);
  if (isfinite(p->floater_mass)) snprintf(ms, sizeof ms, "%.4g (%.2f %%)", p->floater_mass, 100 * p->floater_mass_fraction);
  else snprintf(ms, sizeof ms, "n/a");
  fmt_or_na(bn, sizeof bn, "%.4g", p->bottleneck);
  fmt_or_na(an, sizeof an, "%.1f", r->analysis_seconds);
  fmt_betti(b1, sizeof b1, p->betti);
  fmt_betti(b2, sizeof b2, p->betti_persistent);
  fprintf(f, "| %s | %s | %d | %d | %.3f | %.4f | %.0f | %s | %s | %s | %s | %s | %s | %s | %.1f | %s |\n", r->dataset,
          r->variant, r->seed, p->iteration, p->psnr, p->ssim, p->gaussians, ch, fs, fl, ms, b1, b2, bn, r->train_seconds, an);
}

mgs_status exp_report_write(const exp_report_in *in, mgs_error *err) {
  mgs_status st = write_csvs(in, err);
  if (st) return st;
  for (size_t d = 0; d < in->n_datasets && !st; d++) st = write_plots(in, in->dataset_names[d], err);
  if (st) return st;
  char *mdp = mgs_path_join(in->dir, "RESULTS.md");
  mgs_atomic_file *af = NULL;
  FILE *f = NULL;
  st = mgs_atomic_open(mdp, &af, &f, err);
  free(mdp);
  if (st) return st;
  cJSON *root = cJSON_CreateObject();
  cJSON_AddStringToObject(root, "format", "morsegs-experiment-results");
  cJSON_AddNumberToObject(root, "version", 1);
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
  fprintf(f, "Written %s by morsegs 0.1.0: %zu of %zu planned runs finished; %d iterations per run; %d seed(s).  \n", date,
          in->n_runs, in->planned_runs, in->iters, in->seeds);
  fprintf(f, "Load average (1 min) when the experiment started: %.2f; wall times are taken under whatever load the machine "
             "had (2 cores shared).\n\n", in->load_start);
  fprintf(f, "## Variants\n\n| variant | status | note |\n|---|---|---|\n");
  cJSON *jv = cJSON_AddArrayToObject(root, "variants");
  for (size_t v = 0; v < in->n_variants; v++) {
    fprintf(f, "| %s | %s | %s |\n", in->variants[v].name, in->variants[v].status, in->variants[v].reason);
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "name", in->variants[v].name);
    cJSON_AddStringToObject(o, "status", in->variants[v].status);
    cJSON_AddStringToObject(o, "reason", in->variants[v].reason);
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
    "- Verdicts: per-seed change against the baseline run of the same seed (relative; dB for PSNR); mean +- sd over "
    "seeds. Spread = the baseline's sd over seeds in the same units; noise = max(spread, sd of the change). \"yes\" = "
    "|mean| > 2 noise, right direction, target reached (H1 <= -30 %%, H2 <= -90 %%, H3 <= -40 %%, H4 >= +0.5 dB PSNR and >= +0.01 SSIM); "
    "\"partly\" = significant, right direction, short of the target; \"worse\" = significant, wrong direction; \"no\" = "
    "not significant; \"n/a\" = fewer than 2 seeds or nothing to compare. H3 compares at equal PSNR: each seed's count "
    "against the baseline's count-PSNR curve (knob sweep, log count interpolated in PSNR) at that seed's PSNR.\n\n",
    100 * EXP_VISIBLE_DIST_REL, EXP_SURFACE_TAU, in->n_datasets ? in->truths[0].res : EXP_TOPO_RES, 100 * EXP_PERS_REL);

  cJSON *jds = cJSON_AddArrayToObject(root, "datasets");
  for (size_t d = 0; d < in->n_datasets; d++) {
    const char *ds = in->dataset_names[d];
    const exp_truth *t = &in->truths[d];
    cJSON *od = cJSON_CreateObject();
    cJSON_AddItemToArray(jds, od);
    cJSON_AddStringToObject(od, "name", ds);
    cJSON_AddStringToObject(od, "gt_mesh", t->mesh);
    fprintf(f, "## Dataset %s\n\n", ds);
    if (t->diagram) {
      char b1[32], b2[32];
      fmt_betti(b1, sizeof b1, t->betti);
      fmt_betti(b2, sizeof b2, t->betti_persistent);
      fprintf(f, "GT mesh `%s`: SDF Betti numbers %s, persisting over %.4g: %s; voxel %.4g, band %d voxels, visible-floater "
                 "distance %.4g.\n\n", t->mesh, b1, t->pers_threshold, b2, t->voxel, t->band, t->visible_dist);
      cJSON_AddItemToObject(od, "gt_betti", cJSON_CreateIntArray(t->betti, 3));
      cJSON_AddItemToObject(od, "gt_betti_persistent", cJSON_CreateIntArray(t->betti_persistent, 3));
      cJSON_AddNumberToObject(od, "voxel", t->voxel);
      cJSON_AddNumberToObject(od, "persistence_threshold", t->pers_threshold);
      cJSON_AddNumberToObject(od, "visible_floater_distance", t->visible_dist);
    } else {
      fprintf(f, "No GT mesh: geometry, floater and topology measures are n/a.\n\n");
    }
    /* verdicts */
    fprintf(f, "### Verdicts: change against the baseline, mean ± sd over seeds\n\n| variant |");
    for (size_t h = 0; h < N_HYPS; h++) fprintf(f, " %s |", HYPS[h].title);
    fprintf(f, "\n|---|");
    for (size_t h = 0; h < N_HYPS; h++) fprintf(f, "---|");
    fprintf(f, "\n| target |");
    for (size_t h = 0; h < N_HYPS; h++)
      fprintf(f, HYPS[h].relative ? " <= %+.0f %% |" : " >= %+g %s |", HYPS[h].relative ? 100 * HYPS[h].target : HYPS[h].target,
              HYPS[h].unit);
    fprintf(f, "\n");
    cJSON *jvars = cJSON_AddArrayToObject(od, "variants");
    for (size_t v = 0; v < in->n_variants; v++) {
      const char *var = in->variants[v].name;
      cJSON *ov = cJSON_CreateObject();
      cJSON_AddItemToArray(jvars, ov);
      cJSON_AddStringToObject(ov, "name", var);
      cJSON_AddStringToObject(ov, "status", in->variants[v].status);
      fprintf(f, "| %s |", var);
      if (!strcmp(in->variants[v].status, "not available") || !strcmp(in->variants[v].status, "pending")) {
        for (size_t h = 0; h < N_HYPS; h++) fprintf(f, " %s |", in->variants[v].status);
        fprintf(f, "\n");
        continue;
      }
      cJSON *oh = cJSON_AddObjectToObject(ov, "hypotheses");
      for (size_t h = 0; h < N_HYPS; h++) {
        exp_verdict vd;
        double bm, bs;
        hypothesis(in, ds, var, (int)h, &vd, &bm, &bs);
        cJSON *o = cJSON_AddObjectToObject(oh, HYPS[h].key);
        if (!strcmp(var, "baseline")) {
          char a[32], b[32];
          fmt_or_na(a, sizeof a, "%.5g", bm);
          fmt_or_na(b, sizeof b, "%.2g", bs);
          fprintf(f, " %s ± %s (reference) |", a, b);
          cJSON_AddStringToObject(o, "verdict", "reference");
          add_num(o, "baseline_mean", bm);
          add_num(o, "baseline_sd", bs);
          continue;
        }
        double sc = HYPS[h].relative ? 100 : 1;
        char a[32], b[32];
        fmt_or_na(a, sizeof a, HYPS[h].fmt, vd.mean * sc);
        fmt_or_na(b, sizeof b, HYPS[h].fmt_sd, vd.sd * sc);
        fprintf(f, " %s ± %s %s → **%s**%s%s%s |", a, b, HYPS[h].unit, vd.verdict, vd.note[0] ? " (" : "",
                vd.note, vd.note[0] ? ")" : "");
        cJSON_AddStringToObject(o, "verdict", vd.verdict);
        cJSON_AddStringToObject(o, "unit", HYPS[h].relative ? "relative" : "dB");
        add_num(o, "change_mean", vd.mean);
        add_num(o, "change_sd", vd.sd);
        add_num(o, "spread", vd.spread);
        cJSON_AddNumberToObject(o, "seeds", vd.n);
        cJSON_AddNumberToObject(o, "target", HYPS[h].target);
        add_num(o, "baseline_mean", bm);
        cJSON_AddStringToObject(o, "note", vd.note);
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
    /* the runs */
    fprintf(f, "\n### Runs (final evaluation point; figures as `morsegs eval` reports them)\n\n"
               "| dataset | variant | seed | iteration | PSNR | SSIM | Gaussians | Chamfer | F-score | floaters (H2) | visible "
               "floater mass | Betti | persistent Betti | bottleneck | train s | analysis s |\n"
               "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
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
      add_num(o, "floaters", p->floaters);
      add_num(o, "floater_mass", p->floater_mass);
      add_num(o, "floater_mass_fraction", p->floater_mass_fraction);
      cJSON_AddItemToObject(o, "betti", cJSON_CreateIntArray(p->betti, 3));
      cJSON_AddItemToObject(o, "betti_persistent", cJSON_CreateIntArray(p->betti_persistent, 3));
      add_num(o, "bottleneck", p->bottleneck);
      add_num(o, "train_seconds", r->train_seconds);
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
    fprintf(f, "\n### Curves\n\nCSV: [curves.csv](curves.csv) (every evaluation point), [h3.csv](h3.csv).\n\n");
    static const char *pl[4][2] = {{"psnr_time", "PSNR against wall time"}, {"chamfer_time", "Chamfer against wall time"},
                                   {"bottleneck_time", "bottleneck distance against wall time"},
                                   {"h3_count_psnr", "Gaussians against PSNR"}};
    for (int k = 0; k < 4; k++) fprintf(f, "![%s](plots/%s_%s.png) ([SVG](plots/%s_%s.svg))\n", pl[k][1], ds, pl[k][0], ds, pl[k][0]);
    fprintf(f, "\n");
  }
  st = mgs_atomic_commit(af, err);
  char *text = cJSON_Print(root);
  cJSON_Delete(root);
  char *jp = mgs_path_join(in->dir, "RESULTS.json");
  if (!st) st = text && jp ? mgs_write_file_atomic(jp, text, strlen(text), err) : mgs_error_set(err, MGS_ERR_NOMEM, "out of memory");
  free(text);
  free(jp);
  return st;
}

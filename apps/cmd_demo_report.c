/* DIR/REPORT.md of `morsegs demo`: the baseline and the morse-full run side by side.
 * Every figure is read back from what the stages wrote (RUN/results.json of eval,
 * RUN/train_stats.json and RUN/cfg_args of train, RUN/morse_analysis.csv of the Morse
 * analysis, RUN/persistence/diagram.json of persistence); a file that is missing or lacks
 * a key shows as "n/a", never as a number the demo made up. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cjson/cJSON.h>
#include "apps/cmd_demo.h"
#include "apps/mgs_cli.h"
#include "core/mgs_fs.h"
#include "topo/mgs_diagram_tools.h"
#include "train/mgs_train.h"

/* One surface's geometry against the GT mesh (eval's results.json). */
typedef struct surf_figs {
  double chamfer, accuracy, completeness, fscore, pieces;
} surf_figs;

/* The figures of one run. NAN / -1 = not written by the stage. */
typedef struct run_figs {
  double psnr, ssim, gaussians, fscore_rel, floaters;
  surf_figs alpha, fused;                    /* the α-field's surface, the depth-fused one */
  double agree_fused, agree_alpha;           /* the export's criterion (agreement with the renders) */
  int export_alpha;                          /* geometry.fused.surface_choice.sdf: 1 "alpha", 0 "fused", -1 absent */
  double train_s, analyses, analysis_s, term_s;
  int betti[3], betti_p[3]; /* SDF at t = 0: all classes / those persisting over 2 voxels */
  double active_voxels, voxel;
  /* RUN/morse_analysis.csv */
  int csv_rows, first_it, last_it, betti_eps_last[3];
  double spawned, pruned, csv_seconds, stage_s[5]; /* stage_s: s_alpha .. s_components summed */
  mgs_settings cfg; /* RUN/cfg_args */
} run_figs;

static cJSON *read_json(const char *dir, const char *name) {
  char *p = dir ? mgs_path_join(dir, name) : NULL, *text = NULL;
  cJSON *j = NULL;
  if (p && mgs_read_file(p, &text, NULL, NULL) == MGS_OK) j = cJSON_Parse(text);
  free(text);
  free(p);
  return j;
}

static double num(const cJSON *o, const char *key) {
  const cJSON *v = o ? cJSON_GetObjectItemCaseSensitive(o, key) : NULL;
  return cJSON_IsNumber(v) ? v->valuedouble : NAN;
}

/* Column index of `name` in a CSV header line, -1 if absent. */
static int csv_col(const char *header, const char *name) {
  size_t len = strlen(name);
  int col = 0;
  for (const char *p = header; p && *p; col++) {
    const char *e = strpbrk(p, ",\r\n");
    size_t w = e ? (size_t)(e - p) : strlen(p);
    if (w == len && !strncmp(p, name, len)) return col;
    if (!e || *e != ',') break;
    p = e + 1;
  }
  return -1;
}

/* Field `col` of a CSV line as a number (NAN if absent). */
static double csv_field(const char *line, int col) {
  if (col < 0) return NAN;
  const char *p = line;
  for (int c = 0; c < col; c++) {
    p = strchr(p, ',');
    if (!p) return NAN;
    p++;
  }
  char *end;
  double v = strtod(p, &end);
  return end == p ? NAN : v;
}

/* Sums and last values of RUN/morse_analysis.csv (one row per analysis). */
static void read_csv(const char *run_dir, run_figs *f) {
  f->csv_rows = 0;
  f->first_it = f->last_it = -1;
  f->spawned = f->pruned = f->csv_seconds = 0;
  for (int k = 0; k < 5; k++) f->stage_s[k] = 0;
  for (int k = 0; k < 3; k++) f->betti_eps_last[k] = -1;
  char *p = mgs_path_join(run_dir, "morse_analysis.csv"), *text = NULL;
  if (!p || mgs_read_file(p, &text, NULL, NULL) != MGS_OK) { free(p); f->csv_rows = -1; return; }
  free(p);
  char *save = NULL, *line = strtok_r(text, "\n", &save);
  const char *header = line;
  int c_it = csv_col(header, "iteration"), c_sp = csv_col(header, "spawned"), c_pr = csv_col(header, "pruned");
  static const char *stage_cols[5] = {"s_alpha", "s_sdf", "s_persistence", "s_closest", "s_components"};
  int c_st[5];
  for (int k = 0; k < 5; k++) c_st[k] = csv_col(header, stage_cols[k]);
  int c_s = csv_col(header, "s_total"), c_b[3] = {csv_col(header, "betti_eps_0"), csv_col(header, "betti_eps_1"),
                                                  csv_col(header, "betti_eps_2")};
  while ((line = strtok_r(NULL, "\n", &save)) != NULL) {
    double it = csv_field(line, c_it);
    if (!isfinite(it)) continue; /* not a data row */
    if (f->first_it < 0) f->first_it = (int)it;
    f->last_it = (int)it;
    f->csv_rows++;
    f->spawned += csv_field(line, c_sp);
    f->pruned += csv_field(line, c_pr);
    f->csv_seconds += csv_field(line, c_s);
    for (int k = 0; k < 5; k++) f->stage_s[k] += csv_field(line, c_st[k]);
    for (int k = 0; k < 3; k++) {
      double b = csv_field(line, c_b[k]);
      f->betti_eps_last[k] = isfinite(b) ? (int)b : -1;
    }
  }
  free(text);
}

static void read_surface(const cJSON *o, surf_figs *s) {
  s->chamfer = num(o, "chamfer");
  s->accuracy = num(o, "chamfer_accuracy");
  s->completeness = num(o, "chamfer_completeness");
  s->fscore = num(o, "fscore");
  s->pieces = num(o, "surface_pieces");
}

static void read_figs(const demo_run *r, run_figs *f) {
  memset(f, 0, sizeof *f);
  mgs_settings_init(&f->cfg);
  char *cfg = r->run_dir ? mgs_path_join(r->run_dir, "cfg_args") : NULL;
  if (cfg && mgs_path_exists(cfg)) mgs_settings_read(cfg, &f->cfg, NULL);
  free(cfg);

  cJSON *res = read_json(r->run_dir, "results.json"), *it;
  const cJSON *ours = NULL, *geo = NULL;
  cJSON_ArrayForEach(it, res) ours = it; /* the last "ours_N" entry */
  if (ours) geo = cJSON_GetObjectItemCaseSensitive(ours, "geometry");
  f->psnr = num(ours, "PSNR");
  f->ssim = num(ours, "SSIM");
  f->gaussians = num(ours, "gaussians");
  read_surface(geo, &f->alpha);
  f->fscore_rel = num(geo, "fscore_threshold_relative");
  f->floaters = num(geo, "floaters");
  const cJSON *fu = geo ? cJSON_GetObjectItemCaseSensitive(geo, "fused") : NULL;
  const cJSON *ch = fu ? cJSON_GetObjectItemCaseSensitive(fu, "surface_choice") : NULL;
  read_surface(fu, &f->fused);
  f->agree_fused = num(ch, "fused_agreement");
  f->agree_alpha = num(ch, "alpha_agreement");
  const cJSON *sdf = ch ? cJSON_GetObjectItemCaseSensitive(ch, "sdf") : NULL;
  f->export_alpha = !cJSON_IsString(sdf) ? -1 : !strcmp(sdf->valuestring, "alpha");
  cJSON_Delete(res);

  cJSON *ts = read_json(r->run_dir, "train_stats.json");
  f->train_s = num(ts, "train_seconds");
  f->analyses = num(ts, "morse_analyses");
  f->analysis_s = num(ts, "morse_analysis_seconds");
  f->term_s = num(ts, "loss_term_seconds");
  cJSON_Delete(ts);

  cJSON *pers = read_json(r->pers_dir, "diagram.json");
  const cJSON *meta = pers ? cJSON_GetObjectItemCaseSensitive(pers, "meta") : NULL;
  if (!meta) meta = pers;
  const cJSON *betti = meta ? cJSON_GetObjectItemCaseSensitive(meta, "betti") : NULL;
  for (int k = 0; k < 3; k++) {
    const cJSON *e = cJSON_IsArray(betti) ? cJSON_GetArrayItem(betti, k) : NULL;
    f->betti[k] = cJSON_IsNumber(e) ? e->valueint : -1;
    f->betti_p[k] = pers ? 0 : -1;
  }
  /* Raw Betti numbers count every voxel-scale tunnel of a noisy field; the counts of
   * features that persist over more than 2 voxels are the ones to compare with the
   * shape's own (1, 2, 0). */
  double h = num(meta, "voxel_size"), level = num(meta, "level");
  if (!isfinite(level)) level = 0;
  char *dpath = pers && r->pers_dir ? mgs_path_join(r->pers_dir, "diagram.json") : NULL;
  mgs_diagram *d = NULL;
  if (dpath && mgs_diagram_read_json(dpath, &d, NULL) == MGS_OK) mgs_diagram_betti_persistent(d, level, 2 * h, f->betti_p);
  mgs_diagram_destroy(d);
  free(dpath);
  f->active_voxels = num(meta, "active_voxels");
  f->voxel = h;
  cJSON_Delete(pers);
  read_csv(r->run_dir, f);
}

/* Cell text helpers: "n/a" for what a stage did not write. */
static const char *fmt(char *buf, size_t n, const char *f, double v) {
  if (!isfinite(v)) snprintf(buf, n, "n/a");
  else snprintf(buf, n, f, v);
  return buf;
}
static const char *fmt_surface(char *buf, size_t n, const surf_figs *s) {
  if (!isfinite(s->chamfer)) snprintf(buf, n, "n/a");
  else snprintf(buf, n, "%.4f (%.4f / %.4f); %.0f", s->chamfer, s->accuracy, s->completeness, s->pieces);
  return buf;
}
static const char *fmt_betti(char *buf, size_t n, const int b[3]) {
  if (b[0] < 0) snprintf(buf, n, "n/a");
  else snprintf(buf, n, "%d, %d, %d", b[0], b[1], b[2]);
  return buf;
}
static const char *cfg(const run_figs *f, const char *key) {
  const char *v = mgs_settings_get(&f->cfg, key);
  return v ? v : "n/a";
}
static const char *share(char *buf, size_t n, double part, double whole) {
  if (!isfinite(part)) snprintf(buf, n, "–");
  else snprintf(buf, n, "%.1f s (%.1f %% of the training wall time)", part, isfinite(whole) && whole > 0 ? 100.0 * part / whole : NAN);
  return buf;
}

/* One table row: label, then one cell per run. */
static void row(FILE *b, const char *label, const char *cells[], int n) {
  fprintf(b, "| %s |", label);
  for (int i = 0; i < n; i++) fprintf(b, " %s |", cells[i]);
  fprintf(b, "\n");
}

/* Seconds in the loss terms without the analyses. train_stats.json's loss_term_seconds is
 * the trainer's loss-term phase, and with L_topo on, the analysis of an analysis iteration
 * runs inside it (the term asks for it before the strategy does: train/trainer.c runs the
 * model terms first), so its seconds are counted there and in morse_analysis_seconds. */
static double terms_only(const run_figs *f) {
  const char *topo = mgs_settings_get(&f->cfg, "topo_loss");
  int topo_on = topo && strcmp(topo, "none") && !(isfinite(f->term_s) && f->term_s < f->analysis_s);
  return topo_on ? f->term_s - f->analysis_s : f->term_s;
}

static void what_ran(char *buf, size_t n, const run_figs *f) {
  const char *topo = mgs_settings_get(&f->cfg, "topo_loss"), *from = mgs_settings_get(&f->cfg, "imported_from");
  if (from) /* eval MODEL --data: trained elsewhere */
    snprintf(buf, n, "trained elsewhere: %s model from %s", cfg(f, "model"), from);
  else if (!mgs_settings_get(&f->cfg, "strategy"))
    snprintf(buf, n, "n/a (no cfg_args)");
  else if (!strcmp(cfg(f, "strategy"), "morse") || topo)
    snprintf(buf, n, "strategy %s (spawn %s, prune %s), init %s, L_topo %s (β %s), normal loss %s, analysis r = %s",
             cfg(f, "strategy"), cfg(f, "morse_spawn"), cfg(f, "morse_prune"), cfg(f, "init"), cfg(f, "topo_loss"),
             cfg(f, "topo_beta"), cfg(f, "normal_loss"), cfg(f, "morse_resolution"));
  else
    snprintf(buf, n, "3DGS, strategy %s (ADC), init %s", cfg(f, "strategy"), cfg(f, "init"));
}

int demo_report(const demo_ctx *ctx) {
  int n = ctx->n_runs;
  run_figs figs[DEMO_RUNS];
  for (int i = 0; i < n; i++) read_figs(&ctx->runs[i], &figs[i]);
  enum { W = 320 };
  char cell[DEMO_RUNS][W];
  const char *cells[DEMO_RUNS];
  for (int i = 0; i < DEMO_RUNS; i++) cells[i] = cell[i];
  /* the text goes to REPORT.md and to stdout: built in memory once */
  char *text = NULL;
  size_t text_len = 0;
  FILE *b = open_memstream(&text, &text_len);
  if (!b) { fprintf(stderr, "morsegs demo: out of memory for the report\n"); return 1; }

  if (ctx->report_only) {
    fprintf(b, "# MorseGS report\n\nRuns (`morsegs report`):");
    for (int i = 0; i < n; i++) fprintf(b, "%s `%s`", i ? "," : "", ctx->runs[i].run_dir);
    fprintf(b, ". Each figure is read from the files the run's stages wrote; n/a: not written.\n\n");
  } else
  fprintf(b, "# MorseGS demo report\n\n"
                "Scene: built-in `genus2` (a closed double torus: Betti numbers of the solid 1, 2, 0), "
                "40 train / 8 test views at 128x128, rendered with Embree. ");
  if (ctx->report_only) {
  } else if (n > 1)
    fprintf(b, "Two training runs on it, the same seed and iterations: the 3DGS baseline (`run/`) and "
                  "MorseGS `--preset morse-full` (`run-morse/`), each evaluated, exported and analysed the same way.\n\n");
  else
    fprintf(b, "One training run (`--baseline-only`): the 3DGS baseline (`run/`).\n\n");

  fprintf(b, "| figure |");
  for (int i = 0; i < n; i++) fprintf(b, " %s |", ctx->runs[i].label);
  fprintf(b, "\n|---|");
  for (int i = 0; i < n; i++) fprintf(b, "---|");
  fprintf(b, "\n");
  char tmp[96];
#define ROW(label, expr) do { for (int i = 0; i < n; i++) { const run_figs *f = &figs[i]; char *c = cell[i]; (void)f; expr; } row(b, label, cells, n); } while (0)
  ROW("training", what_ran(c, W, f));
  ROW("iterations / seed", snprintf(c, W, "%s / %s", cfg(f, "iterations"), cfg(f, "seed")));
  ROW("PSNR (test views)", fmt(c, W, "%.2f dB", f->psnr));
  ROW("SSIM", fmt(c, W, "%.4f", f->ssim));
  ROW("Gaussians", fmt(c, W, "%.0f", f->gaussians));
  ROW("Chamfer vs GT mesh, α-field surface {A = 0.5} (mean of both directions; accuracy / completeness; pieces)",
      fmt_surface(c, W, &f->alpha));
  ROW("Chamfer vs GT mesh, depth-fused surface (TSDF of the training views' rendered depth; same columns)",
      fmt_surface(c, W, &f->fused));
  ROW("F-score, α-field / depth-fused surface (threshold: share of the GT diagonal)",
      isfinite(f->alpha.fscore) ? snprintf(c, W, "%.3f / %s (%g %%)", f->alpha.fscore,
                                           fmt(tmp, sizeof tmp, "%.3f", f->fused.fscore), 100.0 * f->fscore_rel)
                                : snprintf(c, W, "n/a"));
  ROW("surface `morsegs vdb RUN` exports as `sdf` (the one that agrees better with the rendered depth)",
      f->export_alpha < 0 ? snprintf(c, W, "n/a")
      : f->export_alpha   ? snprintf(c, W, "α-field (%.4f against %.4f)", f->agree_alpha, f->agree_fused)
                          : snprintf(c, W, "fused (%.4f against %.4f)", f->agree_fused, f->agree_alpha));
  ROW("floaters (H2: opacity < 0.01, > 3 sigma from GT)", fmt(c, W, "%.0f", f->floaters));
  ROW("Betti numbers of the SDF at t = 0, all features (shape: 1, 2, 0)", fmt_betti(c, W, f->betti));
  ROW("Betti numbers of features persisting over 2 voxels (shape: 1, 2, 0)", fmt_betti(c, W, f->betti_p));
  ROW("active voxels of the SDF", fmt(c, W, "%.0f", f->active_voxels));
  ROW("training wall time", fmt(c, W, "%.1f s", f->train_s));
  ROW("Morse analyses (α-field, SDF, persistence, ...)",
      !isfinite(f->analyses) ? snprintf(c, W, "–")
      : f->csv_rows > 0 ? snprintf(c, W, "%.0f, at iterations %d..%d: %s", f->analyses, f->first_it, f->last_it,
                                   share(tmp, sizeof tmp, f->analysis_s, f->train_s))
                        : snprintf(c, W, "%.0f: %s", f->analyses, share(tmp, sizeof tmp, f->analysis_s, f->train_s)));
  ROW("analysis seconds by stage, summed (α-field / SDF / persistence / closest points / components)",
      f->csv_rows > 0 ? snprintf(c, W, "%.2f / %.2f / %.2f / %.2f / %.2f", f->stage_s[0], f->stage_s[1], f->stage_s[2],
                                 f->stage_s[3], f->stage_s[4]) : snprintf(c, W, "–"));
  ROW("loss terms between analyses (L_topo, normal loss)", share(c, W, isfinite(f->analyses) ? terms_only(f) : NAN, f->train_s));
  ROW("MorseGS overhead in all", share(c, W, isfinite(f->analyses) ? f->analysis_s + terms_only(f) : NAN, f->train_s));
  ROW("Morse spawned / pruned Gaussians (sum over analyses)",
      f->csv_rows > 0 ? snprintf(c, W, "%.0f / %.0f", f->spawned, f->pruned) : snprintf(c, W, "–"));
  ROW("Betti numbers above ε at the last analysis (analysis grid)",
      f->csv_rows > 0 ? (void)fmt_betti(c, W, f->betti_eps_last) : (void)snprintf(c, W, "–"));
#undef ROW

  if (n > 1 && !ctx->report_only) {
    const run_figs *m = &figs[DEMO_MORSE];
    fprintf(b, "\nThe morse-full run used `--morse-warmup %s --morse-every %s` (from `run-morse/cfg_args`): the "
                  "preset's defaults (W = 3000, K = 500) belong to a 30000-iteration schedule and would never fire in "
                  "%d iterations, so the demo starts the analysis at a quarter of the run (where ADC starts densifying "
                  "in the default 2000-iteration demo) and repeats it every eighth",
              cfg(m, "morse_warmup"), cfg(m, "morse_every"), ctx->iters);
    if (m->csv_rows >= 0)
      fprintf(b, "; it ran %d times (rows of `run-morse/morse_analysis.csv`, %.1f s in all by its `s_total` column).\n",
                m->csv_rows, m->csv_seconds);
    else
      fprintf(b, "; the run wrote no `run-morse/morse_analysis.csv`.\n");
    fprintf(b, "\nOne seed, %d iterations, one small scene: this shows that both pipelines run and what each "
                  "produced here, not whether MorseGS helps. The experiment that asks that question (several scenes, "
                  "variants and seeds, with H1–H4 verdicts) is `morsegs experiment`; it also measures floaters by "
                  "their visible opacity mass, where `morsegs eval` (above) counts them.\n", ctx->iters);
  }
  if (!ctx->report_only) {
  fprintf(b, "\nStage wall times of this demo:");
  for (int i = 0; i < ctx->n_stages_done; i++) fprintf(b, "%s %s %.1f s", i ? "," : "", ctx->stage_name[i], ctx->stage_seconds[i]);
  fprintf(b, ".\n\nFiles (%s): `point_cloud/iteration_%d/point_cloud.ply` (3DGS layout), "
                "`eval/` (render | GT | error), `scene.vdb` (grids `density`, `sdf`), `surface.ply`, `persistence/` "
                "(diagram.txt/json/png/svg, barcode, betti.txt, critical.vdb)%s. Beside this file: REPORT.html (the page "
                "to open) and `surface_views/` (its Embree pictures of each run's surface.ply). `scene.vdb`, "
                "`surface.ply`, their pictures and `persistence/` are made from the trained `.ply` alone: the "
                "α-field's surface, the field MorseGS analyses. `morsegs vdb RUN -o OUT.vdb --mesh OUT.ply` on a run "
                "folder writes the surface of the table's export row as `sdf` (the depth-fused one also needs the "
                "run's cameras and renders).\n",
            n > 1 ? "per run, in `run/` and `run-morse/`" : "in `run/`", ctx->iters,
            n > 1 ? "; `run-morse/morse_analysis.csv` (one row per Morse analysis)" : "");
  }
  for (int i = 0; i < n; i++) mgs_settings_free(&figs[i].cfg);

  mgs_error err;
  mgs_error_clear(&err);
  char *path = mgs_path_join(ctx->out_dir, "REPORT.md");
  int failed = ferror(b);
  fclose(b); /* text, text_len final */
  mgs_status st = path && !failed && text ? mgs_write_file_atomic(path, text, text_len, &err) : mgs_error_set(&err, MGS_ERR_NOMEM, "out of memory");
  if (st == MGS_OK) {
    printf("%s", text);
    printf("  wrote %s\n", path);
    if (n > 1 && !ctx->report_only) /* the one-line comparison a user reads first */
      printf("  baseline vs morse-full: PSNR %.2f vs %.2f dB, %.0f vs %.0f Gaussians, persistent Betti %d,%d,%d vs %d,%d,%d "
             "(shape 1,2,0), %.1f vs %.1f s training\n",
             figs[0].psnr, figs[1].psnr, figs[0].gaussians, figs[1].gaussians, figs[0].betti_p[0], figs[0].betti_p[1],
             figs[0].betti_p[2], figs[1].betti_p[0], figs[1].betti_p[1], figs[1].betti_p[2], figs[0].train_s, figs[1].train_s);
  }
  int rc = st == MGS_OK ? 0 : mgs_cli_fail(ctx->report_only ? "report" : "demo", &err);
  if (rc == 0) {
    demo_html_figs hf[DEMO_RUNS];
    for (int i = 0; i < DEMO_RUNS; i++) hf[i] = (demo_html_figs){i < n ? figs[i].psnr : NAN, i < n ? figs[i].train_s : NAN};
    rc = demo_report_html(ctx, text, hf);
  }
  free(path);
  free(text);
  return rc;
}

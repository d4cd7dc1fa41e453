/* The report of `morsegs experiment` through the command, on constructed runs (no
 * training): a curves.csv and RESULTS.json as an earlier experiment leaves them, re-analysed
 * by `morsegs experiment --report-from`. Checks the verdicts the report derives (interval,
 * word, Holm word), H3 against the baseline's Pareto front with a seed outside its range
 * counted, one seed and missing measurements as n/a with a reason, the comparison with the
 * earlier verdicts, and the files. The statistics themselves are tests/stats'. */
#include <math.h>
#include <cjson/cJSON.h>
#include "mgs_test.h"
#include "core/mgs_core.h"

static const char HEADER[] =
  "dataset,variant,seed,knob_factor,iteration,wall_seconds,psnr,ssim,gaussians,chamfer,fscore,floaters,"
  "floaters_fraction,floater_mass,floater_mass_fraction,betti0,betti1,betti2,pbetti0,pbetti1,pbetti2,"
  "bottleneck,train_seconds,analysis_seconds\n";

static int n_points = 0;

/* Two evaluation points per main run (the final one at iteration 100), one per sweep run. */
static void run(FILE *f, const char *var, int seed, double factor, double psnr, double gaussians, double chamfer, double floaters) {
  for (int k = factor == 1 ? 0 : 1; k < 2; k++) {
    fprintf(f, "toy,%s,%d,%g,%d,%g,%.6g,0.9,%.0f,%.9g,0.5,%.0f,0.01,%g,0.01,1,0,0,1,0,0,%s,%d,nan\n", var, seed, factor,
            50 * (k + 1), 5.0 * (k + 1), psnr - (1 - k), gaussians, chamfer * (k ? 1 : 1.5), floaters, 0.1 * floaters,
            k ? "inf" : "0.05", 10 + seed);
    n_points++;
  }
}

static cJSON *hyp(cJSON *root, const char *var, const char *h) {
  cJSON *ds = cJSON_GetArrayItem(cJSON_GetObjectItem(root, "datasets"), 0), *v;
  cJSON_ArrayForEach(v, cJSON_GetObjectItem(ds, "variants"))
    if (!strcmp(cJSON_GetObjectItem(v, "name")->valuestring, var))
      return cJSON_GetObjectItem(cJSON_GetObjectItem(v, "hypotheses"), h);
  return NULL;
}
static const char *str(cJSON *o, const char *k) {
  cJSON *x = cJSON_GetObjectItem(o, k);
  return cJSON_IsString(x) ? x->valuestring : "";
}
static double num(cJSON *o, const char *k) {
  cJSON *x = cJSON_GetObjectItem(o, k);
  return cJSON_IsNumber(x) ? x->valuedouble : NAN;
}

int main(void) {
  const char *cli = getenv("MGS_CLI");
  if (!cli) { fprintf(stderr, "MGS_CLI not set\n"); return 2; }
  const char *dir = mgs_test_tmpdir("exp_report");
  char from[512], out[512], path[600];
  snprintf(from, sizeof from, "%s/earlier", dir);
  snprintf(out, sizeof out, "%s/again", dir);
  mgs_error err;
  CHECK_OK(mgs_mkdir_p(from, &err), &err);
  snprintf(path, sizeof path, "%s/curves.csv", from);
  FILE *f = fopen(path, "w");
  CHECK(f != NULL);
  if (!f) return mgs_test_finish();
  fputs(HEADER, f);
  /* baseline: 3 seeds; its sweep (every seed) puts (1000, 24 dB), (2000, 25), (4000, 26) on its front */
  run(f, "baseline", 0, 1.0, 25.00, 2000, 0.0100, 100);
  run(f, "baseline", 1, 1.0, 25.02, 2010, 0.0101, 104);
  run(f, "baseline", 2, 1.0, 24.98, 1990, 0.0099, 96);
  for (int s = 0; s < 3; s++) {
    run(f, "baseline", s, 4.0, 24.00 + 0.01 * s, 1000 + 5 * s, 0.012, 50);
    run(f, "baseline", s, 0.25, 26.00 + 0.01 * s, 4000 + 10 * s, 0.009, 200);
    run(f, "baseline", s, 2.0, 23.50, 3000, 0.012, 50); /* the knob's curve runs the wrong way here: dominated */
  }
  /* "good": Chamfer -50 %, floaters 5 (-94 % on count + 1), ~1414 Gaussians at 25.6 dB
     (the front needs 2000 * 2^0.6 = 3031 there: -53 %), +0.6 dB */
  run(f, "good", 0, 1.0, 25.61, 1414.2, 0.0050, 5);
  run(f, "good", 1, 1.0, 25.62, 1420, 0.0051, 5);
  run(f, "good", 2, 1.0, 25.57, 1410, 0.0049, 5);
  /* "bad": Chamfer +20 %, PSNR -1 dB; seed 2 at 23.4 dB is below the front's range */
  run(f, "bad", 0, 1.0, 24.0, 2000, 0.0120, 100);
  run(f, "bad", 1, 1.0, 24.03, 2000, 0.0122, 104);
  run(f, "bad", 2, 1.0, 23.4, 2000, 0.0119, 96);
  /* "single": one seed only; "nochamfer": no Chamfer measured */
  run(f, "single", 0, 1.0, 25.5, 1000, 0.005, 5);
  run(f, "nochamfer", 0, 1.0, 25.0, 2000, NAN, 100);
  run(f, "nochamfer", 1, 1.0, 25.0, 2000, NAN, 100);
  run(f, "nochamfer", 2, 1.0, 25.0, 2000, NAN, 100);
  /* "other": a second method (Chamfer +100 % against baseline); "on_other" (--base on_other=other):
     Chamfer -50 % against other, which is baseline's value: "yes" only against its own base */
  run(f, "other", 0, 1.0, 25.0, 2000, 0.0200, 100);
  run(f, "other", 1, 1.0, 25.0, 2000, 0.0202, 100);
  run(f, "other", 2, 1.0, 25.0, 2000, 0.0198, 100);
  run(f, "on_other", 0, 1.0, 25.0, 2000, 0.0100, 100);
  run(f, "on_other", 1, 1.0, 25.0, 2000, 0.01015, 100);
  run(f, "on_other", 2, 1.0, 25.0, 2000, 0.0099, 100);
  fclose(f);
  static const char results[] =
    "{\"format\":\"morsegs-experiment-results\",\"command\":\"morsegs experiment toy -o earlier\",\"written\":\"then\","
    "\"iterations\":100,\"seeds\":3,\"definitions\":{\"topology_voxels_per_gt_diagonal\":256,\"knobs\":\"baseline: "
    "--grad-threshold 0.0002 x {1, 4, 0.25, 2}\"},\"variants\":[{\"name\":\"baseline\",\"status\":\"available\"},"
    "{\"name\":\"good\",\"status\":\"available\"},{\"name\":\"bad\",\"status\":\"available\"},{\"name\":\"single\","
    "\"status\":\"available\"},{\"name\":\"nochamfer\",\"status\":\"available\"},{\"name\":\"other\",\"status\":\"available\"},"
    "{\"name\":\"on_other\",\"status\":\"available\",\"base\":\"other\"},{\"name\":\"missing\",\"status\":\"not available\","
    "\"reason\":\"morsegs train: --nope: unknown\"}],\"datasets\":[{\"name\":\"toy\",\"gt_mesh\":\"\",\"variants\":["
    "{\"name\":\"bad\",\"hypotheses\":{\"H3\":{\"verdict\":\"yes\"}}}]}]}";
  snprintf(path, sizeof path, "%s/RESULTS.json", from);
  CHECK_OK(mgs_write_file_atomic(path, results, strlen(results), &err), &err);
  /* the folder it reads from is refused as the output (the earlier report is kept) */
  CHECK(mgs_test_sh("%s experiment --report-from %s -o %s > /dev/null 2>&1", cli, from, from) == 2);
  CHECK(mgs_test_sh("%s experiment --report-from %s -o %s some/data > /dev/null 2>&1", cli, from, out) == 2);
  CHECK(mgs_test_sh("%s experiment --report-from %s -o %s", cli, from, out) == 0);
  /* --base names variants of the run */
  CHECK(mgs_test_sh("%s experiment nodata -o %s/b --variants baseline --base nope=baseline 2>&1 | grep -q \"'nope' is not among\"", cli, dir) == 0);
  CHECK(mgs_test_sh("%s experiment nodata -o %s/b --variants baseline --base baseline=baseline > /dev/null 2>&1", cli, dir) == 2);

  char *text = NULL;
  size_t len;
  snprintf(path, sizeof path, "%s/RESULTS.json", out);
  CHECK_OK(mgs_read_file(path, &text, &len, &err), &err);
  cJSON *root = text ? cJSON_Parse(text) : NULL;
  CHECK(root != NULL);
  if (!root) return mgs_test_finish();
  cJSON *h;
  h = hyp(root, "good", "H1");
  CHECK(h && !strcmp(str(h, "verdict"), "yes") && !strcmp(str(h, "verdict_holm"), "yes"));
  CHECK(h && fabs(num(h, "change_mean") - log(0.5)) < 0.01 && fabs(num(h, "shown_mean") + 50) < 1);
  CHECK(h && num(h, "ci95_lo") < num(h, "change_mean") && num(h, "ci95_hi") > num(h, "change_mean"));
  CHECK(h && num(h, "ci95_hi") < log(0.7) && num(h, "seeds") == 3 && num(h, "p") < 0.01);
  CHECK(h && num(h, "holm_ci_lo") < num(h, "ci95_lo") && num(h, "p_holm") >= num(h, "p"));
  h = hyp(root, "good", "H2");
  CHECK(h && !strcmp(str(h, "verdict"), "yes")); /* (5 + 1) / (100 + 1): -94 % */
  h = hyp(root, "good", "H3");
  CHECK(h && !strcmp(str(h, "verdict"), "yes") && num(h, "seeds_inside_front") == 3 && num(h, "front_points") == 9); /* x2 dominated */
  /* per seed: log(count / (2000 * 2^((psnr - 25) / 1))) along the front (the x1 seeds are on it too) */
  CHECK(h && fabs(num(h, "shown_mean") - 100 * (1414.2 / (2000 * pow(2, 0.6)) - 1)) < 3);
  h = hyp(root, "good", "H4");
  CHECK(h && !strcmp(str(h, "verdict"), "yes") && fabs(num(h, "change_mean") - 0.6) < 1e-6);
  h = hyp(root, "good", "H4_ssim"); /* SSIM equal in every run */
  CHECK(h && !strcmp(str(h, "verdict"), "no") && !strcmp(str(h, "verdict_holm"), "no"));
  h = hyp(root, "bad", "H1");
  CHECK(h && !strcmp(str(h, "verdict"), "worse"));
  h = hyp(root, "bad", "H4");
  CHECK(h && !strcmp(str(h, "verdict"), "worse"));
  h = hyp(root, "bad", "H3"); /* 23.4 dB is below the front: counted, not silently dropped */
  CHECK(h && num(h, "seeds") == 2 && num(h, "seeds_below_front") == 1 && strstr(str(h, "note"), "outside the front"));
  h = hyp(root, "single", "H1");
  CHECK(h && !strcmp(str(h, "verdict"), "n/a") && num(h, "seeds") == 1 && strstr(str(h, "note"), "1 seed"));
  h = hyp(root, "nochamfer", "H1");
  CHECK(h && !strcmp(str(h, "verdict"), "n/a") && num(h, "seeds") == 0 && strstr(str(h, "note"), "without a measurement"));
  h = hyp(root, "baseline", "H1");
  CHECK(h && !strcmp(str(h, "verdict"), "reference"));
  cJSON *counts = cJSON_GetObjectItem(cJSON_GetObjectItem(root, "verdict_counts"), "H1");
  h = hyp(root, "on_other", "H1"); /* against its --base */
  CHECK(h && !strcmp(str(h, "verdict"), "yes") && fabs(num(h, "change_mean") - log(0.5)) < 0.01);
  h = hyp(root, "other", "H1");
  CHECK(h && !strcmp(str(h, "verdict"), "worse"));
  CHECK(counts && num(cJSON_GetObjectItem(counts, "raw"), "yes") == 2 && num(cJSON_GetObjectItem(counts, "raw"), "worse") == 2);
  cJSON_Delete(root);
  free(text);
  /* RESULTS.md: intervals beside the words, the front, the comparison with the earlier words */
  snprintf(path, sizeof path, "%s/RESULTS.md", out);
  CHECK_OK(mgs_read_file(path, &text, &len, &err), &err);
  CHECK(text && strstr(text, "| toy | good | 3 | -50.0 % ["));
  /* the methods side by side: means over seeds, the baseline as the reference */
  CHECK_MSG(text && strstr(text, "| good | 3 | 1415 (71 %) | 25.600 (+0.60) | 0.005 |"), "no means row for good");
  CHECK(text && strstr(text, "| baseline | 3 | 2000 (100 %) | 25.000 (+0.00) | 0.01 |"));
  CHECK(text && strstr(text, "Pareto front (what H3 compares with"));
  CHECK(text && strstr(text, "## Verdicts against the earlier report"));
  CHECK(text && strstr(text, "| missing | baseline | not available |"));
  CHECK(text && strstr(text, "| on_other | other | available |") && strstr(text, "| on_other (against other) |"));
  CHECK(text && strstr(text, "The Pareto front of other"));
  free(text);
  static const char *files[] = {"curves.csv", "h3.csv", "plots/toy_psnr_time.png", "plots/toy_psnr_time.svg",
                                "plots/toy_chamfer_time.png", "plots/toy_chamfer_time.svg", "plots/toy_h3_count_psnr.png"};
  for (size_t i = 0; i < sizeof files / sizeof *files; i++) {
    snprintf(path, sizeof path, "%s/%s", out, files[i]);
    CHECK_MSG(mgs_path_exists(path), "%s missing", path);
  }
  /* the curves CSV written again holds every evaluation point of every run */
  snprintf(path, sizeof path, "%s/curves.csv", out);
  CHECK_OK(mgs_read_file(path, &text, &len, &err), &err);
  int lines = 0;
  for (char *q = text; q && *q; q++) lines += *q == '\n';
  CHECK_MSG(lines == 1 + n_points, "%d lines, want %d", lines, 1 + n_points);
  /* written in the current layout: the depth-fused surface and SuGaR's mesh at the end */
  CHECK(text && strstr(text, "analysis_seconds,chamfer_fused,fscore_fused,chamfer_mesh,fscore_mesh\n"));
  /* H1 on the depth-fused surface: the same file with each run's fused Chamfer at twice its
     α-surface one (so "good" is -50 % there too, "nochamfer" has none), re-analysed */
  char fused_dir[512], fused_out[512];
  snprintf(fused_dir, sizeof fused_dir, "%s/fused", dir);
  snprintf(fused_out, sizeof fused_out, "%s/fused_again", dir);
  CHECK_OK(mgs_mkdir_p(fused_dir, &err), &err);
  snprintf(path, sizeof path, "%s/curves.csv", fused_dir);
  f = fopen(path, "w");
  CHECK(f != NULL);
  int line_no = 0;
  char *save = NULL;
  for (char *line = text && f ? strtok_r(text, "\n", &save) : NULL; line; line = strtok_r(NULL, "\n", &save), line_no++) {
    if (line_no == 0) { fprintf(f, "%s\n", line); continue; }
    char *fld[28], *sv = NULL;
    int k = 0;
    for (char *t = strtok_r(line, ",", &sv); t && k < 28; t = strtok_r(NULL, ",", &sv)) fld[k++] = t;
    CHECK(k == 28);
    if (k != 28) break;
    char fused[64];
    snprintf(fused, sizeof fused, "%.9g", 2 * strtod(fld[9], NULL));
    fld[24] = fused;
    for (int q = 0; q < 28; q++) fprintf(f, "%s%s", fld[q], q < 27 ? "," : "\n");
  }
  if (f) fclose(f);
  free(text);
  text = NULL;
  snprintf(path, sizeof path, "%s/RESULTS.json", out);
  char dst[700];
  snprintf(dst, sizeof dst, "%s/RESULTS.json", fused_dir);
  CHECK(mgs_read_file(path, &text, &len, &err) == MGS_OK && mgs_write_file_atomic(dst, text, len, &err) == MGS_OK);
  free(text);
  text = NULL;
  CHECK(mgs_test_sh("%s experiment --report-from %s -o %s > /dev/null", cli, fused_dir, fused_out) == 0);
  snprintf(path, sizeof path, "%s/RESULTS.json", fused_out);
  CHECK_OK(mgs_read_file(path, &text, &len, &err), &err);
  root = text ? cJSON_Parse(text) : NULL;
  h = hyp(root, "good", "H1_fused");
  CHECK_MSG(h && !strcmp(str(h, "verdict"), "yes") && fabs(num(h, "change_mean") - log(0.5)) < 0.01, "H1_fused of good: %s",
            h ? str(h, "verdict") : "(none)");
  h = hyp(root, "bad", "H1_fused");
  CHECK(h && !strcmp(str(h, "verdict"), "worse"));
  h = hyp(root, "nochamfer", "H1_fused");
  CHECK(h && !strcmp(str(h, "verdict"), "n/a"));
  /* Holm over the H1 family: both surfaces' cells now count */
  h = hyp(root, "good", "H1");
  CHECK(h && !strcmp(str(h, "verdict"), "yes") && num(h, "p_holm") >= num(h, "p"));
  cJSON_Delete(root);
  free(text);
  text = NULL;
  snprintf(path, sizeof path, "%s/RESULTS.md", fused_out);
  CHECK_OK(mgs_read_file(path, &text, &len, &err), &err);
  CHECK(text && strstr(text, "H1 Chamfer (depth-fused surface)"));
  free(text);
  return mgs_test_finish();
}

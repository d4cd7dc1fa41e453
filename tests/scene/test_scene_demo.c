/* `morsegs demo`: builds the genus-2 dataset, trains the baseline and morse-full, evaluates,
 * exports and analyses both; the dataset loads, the report puts the two runs side by side
 * with figures a working pipeline reaches and that agree with the files the runs wrote
 * (morse-full's analyses = the rows of its morse_analysis.csv), and a second run with
 * --baseline-only keeps what exists (no overwrite without --force) and reports one column.
 * At --iters 1000 (the demo's 2000 halved: the same stages, half the test's time). */
#include <stdio.h>
#include <string.h>
#include <unistd.h>
#include "mgs_test.h"
#include "scene_test_util.h"
#include "core/mgs_dataset.h"
#include "core/mgs_fs.h"

int main(void) {
  const char *cli = getenv("MGS_CLI");
  if (!cli) { fprintf(stderr, "MGS_CLI not set\n"); return 1; }
  char cwd[512], root[1024], cmd[4096], log_path[1024], scene[1100];
  if (!getcwd(cwd, sizeof cwd)) return 1;
  snprintf(root, sizeof root, "%s/%s/out", cwd, mgs_test_tmpdir("scene_demo"));
  snprintf(log_path, sizeof log_path, "%s/demo_log.txt", cwd);
  snprintf(scene, sizeof scene, "%s/scene", root);
  snprintf(cmd, sizeof cmd, "'%s' demo -o '%s' -q --iters 1000", cli, root);
  CHECK(run_cmd(cmd, log_path) == 0);
  CHECK(file_contains(log_path, "transforms_train.json") && file_contains(log_path, "gt_mesh.ply"));
  mgs_dataset_options o;
  mgs_dataset_options_default(&o);
  mgs_dataset *d = NULL;
  mgs_error err;
  CHECK_OK(mgs_dataset_load(scene, &o, &d, &err), &err);
  if (d) {
    CHECK(d->n_views[MGS_SPLIT_TRAIN] == 40);
    CHECK(d->views[MGS_SPLIT_TRAIN][0].cam.width == 128);
    CHECK(d->init_points && d->init_points->n > 0);
  }
  mgs_dataset_destroy(d);
  /* The report: one column per run; PSNR well above what a broken trainer reaches, and
   * one persistent connected component in the SDF of each trained model. */
  char report[1100], line[2048];
  snprintf(report, sizeof report, "%s/REPORT.md", root);
  FILE *f = fopen(report, "r");
  CHECK(f != NULL);
  double psnr[2] = {0, 0}, gauss[2] = {0, 0};
  int b[2][3] = {{-1, -1, -1}, {-1, -1, -1}}, header = 0, analyses = -1, spawned = -1, pruned = -1, base_dash = 0;
  const char *k_psnr = "| PSNR (test views) |", *k_g = "| Gaussians |",
             *k_b = "| Betti numbers of features persisting over 2 voxels (shape: 1, 2, 0) |",
             *k_an = "| Morse analyses (", *k_sp = "| Morse spawned / pruned Gaussians (sum over analyses) |",
             *k_ca = "| Chamfer vs GT mesh, α-field surface", *k_cf = "| Chamfer vs GT mesh, depth-fused surface",
             *k_ex = "| surface `morsegs vdb RUN` exports as `sdf`";
  double cha[2] = {-1, -1}, chf[2] = {-1, -1};
  char ex[2][16] = {"", ""};
  while (f && fgets(line, sizeof line, f)) {
    if (!strncmp(line, "| figure | baseline | morse-full |", 34)) header = 1;
    if (!strncmp(line, k_psnr, strlen(k_psnr))) sscanf(line + strlen(k_psnr), " %lf dB | %lf dB |", &psnr[0], &psnr[1]);
    if (!strncmp(line, k_g, strlen(k_g))) sscanf(line + strlen(k_g), " %lf | %lf |", &gauss[0], &gauss[1]);
    if (!strncmp(line, k_b, strlen(k_b)))
      sscanf(line + strlen(k_b), " %d, %d, %d | %d, %d, %d |", &b[0][0], &b[0][1], &b[0][2], &b[1][0], &b[1][1], &b[1][2]);
    if (!strncmp(line, k_an, strlen(k_an))) {
      const char *cells = strstr(line, ") |"); /* past the label: baseline "–", then morse-full */
      if (cells) base_dash = !strncmp(cells, ") | – |", strlen(") | – |")), sscanf(cells + strlen(") | – |"), " %d,", &analyses);
    }
    if (!strncmp(line, k_sp, strlen(k_sp))) sscanf(line + strlen(k_sp), " – | %d / %d |", &spawned, &pruned);
    /* both surfaces' Chamfer and the one the export takes, per column (past the label's " |") */
    const char *cells = strstr(line, ") |");
    if (cells && !strncmp(line, k_ca, strlen(k_ca))) sscanf(cells + 3, " %lf (%*[^|]| %lf", &cha[0], &cha[1]);
    if (cells && !strncmp(line, k_cf, strlen(k_cf))) sscanf(cells + 3, " %lf (%*[^|]| %lf", &chf[0], &chf[1]);
    if (cells && !strncmp(line, k_ex, strlen(k_ex))) sscanf(cells + 3, " %15s (%*[^|]| %15s", ex[0], ex[1]);
  }
  if (f) fclose(f);
  CHECK(header);
  CHECK(psnr[0] > 25 && psnr[1] > 25);
  CHECK(gauss[0] > 1000 && gauss[1] > 1000);
  CHECK_MSG(gauss[0] != gauss[1], "the two columns hold the same model (%g Gaussians)\n", gauss[0]);
  CHECK(b[0][0] >= 1 && b[0][1] >= 0 && b[0][2] >= 0);
  CHECK(b[1][0] >= 1 && b[1][1] >= 0 && b[1][2] >= 0);
  CHECK(base_dash);
  CHECK(spawned >= 0 && pruned >= 0);
  for (int i = 0; i < 2; i++) {
    CHECK_MSG(cha[i] > 0 && cha[i] < 0.2 && chf[i] > 0 && chf[i] < 0.2, "column %d: Chamfer alpha %g, fused %g\n", i, cha[i],
              chf[i]);
    CHECK_MSG(!strcmp(ex[i], "fused") || !strcmp(ex[i], "α-field"), "column %d exports '%s'\n", i, ex[i]);
  }
  /* The morse-full run: its preset and scaled schedule recorded, one CSV row per analysis,
   * and the report's count is that number of rows. */
  char morse[1100], csv[1200], cfg[1200];
  snprintf(morse, sizeof morse, "%s/run-morse", root);
  snprintf(cfg, sizeof cfg, "%s/cfg_args", morse);
  CHECK(file_contains(cfg, "preset='morse-full'") && file_contains(cfg, "morse_warmup=250") &&
        file_contains(cfg, "morse_every=125") && file_contains(cfg, "iterations=1000"));
  snprintf(csv, sizeof csv, "%s/morse_analysis.csv", morse);
  f = fopen(csv, "r");
  CHECK(f != NULL);
  int rows = 0, first = 1, it;
  while (f && fgets(line, sizeof line, f)) {
    if (first) { CHECK(!strncmp(line, "iteration,", 10) && strstr(line, ",spawned,pruned,")); first = 0; continue; }
    if (sscanf(line, "%d,", &it) == 1 && it >= 250 && it <= 1000) rows++;
  }
  if (f) fclose(f);
  CHECK_MSG(rows >= 1, "%s: %d analysis rows\n", csv, rows);
  CHECK_MSG(analyses == rows, "report says %d analyses, the CSV has %d rows\n", analyses, rows);
  /* The demo's second training ran in the process after the first: the same training in a
     process of its own gives the same model, byte for byte (no state carried over). */
  snprintf(cmd, sizeof cmd, "'%s' train '%s' -o '%s/alone' --iters 1000 --preset morse-full --morse-warmup 250 "
           "--morse-every 125 --morse-resolution 128 --quiet", cli, scene, root);
  CHECK(run_cmd(cmd, log_path) == 0);
  snprintf(cmd, sizeof cmd, "cmp '%s/point_cloud/iteration_1000/point_cloud.ply' '%s/alone/point_cloud/iteration_1000/point_cloud.ply'",
           morse, root);
  CHECK_MSG(run_cmd(cmd, log_path) == 0, "the demo's morse-full model differs from the same training alone");
  /* --baseline-only: the kept baseline, re-evaluated, in a one-column report */
  snprintf(cmd, sizeof cmd, "'%s' demo -o '%s' -q --baseline-only --iters 1000", cli, root);
  CHECK(run_cmd(cmd, log_path) == 0);
  CHECK(file_contains(log_path, "kept") && !file_contains(log_path, "run-morse"));
  CHECK(file_contains(report, "| figure | baseline |\n") && !file_contains(report, "| morse-full |"));
  snprintf(cmd, sizeof cmd, "'%s' demo -o '%s' --bogus", cli, root);
  CHECK(run_cmd(cmd, log_path) == 2);
  return mgs_test_finish();
}

/* `morsegs demo`: builds the genus-2 dataset, trains, evaluates, exports and analyses it;
 * the dataset loads, the report holds figures a working pipeline reaches, and a second
 * run keeps what exists (no overwrite without --force). */
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
  snprintf(cmd, sizeof cmd, "'%s' demo -o '%s' -q", cli, root);
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
  /* The report: PSNR well above what a broken trainer reaches, and one persistent
   * connected component in the SDF of the trained model. */
  char report[1100], line[1024];
  snprintf(report, sizeof report, "%s/REPORT.md", root);
  FILE *f = fopen(report, "r");
  CHECK(f != NULL);
  double psnr = 0;
  int b0 = -1, b1 = -1, b2 = -1;
  while (f && fgets(line, sizeof line, f)) {
    if (strstr(line, "| PSNR |")) sscanf(strstr(line, "| PSNR |") + 8, "%lf", &psnr);
    const char *k = "| Betti numbers of features persisting over 2 voxels |";
    if (strstr(line, k)) sscanf(strstr(line, k) + strlen(k), "%d, %d, %d", &b0, &b1, &b2);
  }
  if (f) fclose(f);
  CHECK(psnr > 25);
  CHECK(b0 >= 1 && b1 >= 0 && b2 >= 0);
  CHECK(run_cmd(cmd, log_path) == 0);
  CHECK(file_contains(log_path, "kept"));
  snprintf(cmd, sizeof cmd, "'%s' demo -o '%s' --bogus", cli, root);
  CHECK(run_cmd(cmd, log_path) == 2);
  return mgs_test_finish();
}

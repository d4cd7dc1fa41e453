/* Every preset and strategy on every format as users have them (issue 21): a NeRF-synthetic
 * folder without any point file (as the original lego ships), a COLMAP text model with
 * photos on black, and a nerfstudio folder — all made from one rendered scene by
 * tests/train/nerf_to_formats.py — train end to end (short schedules), write a model and
 * record the preset; the background follows the format. */
#include "mgs_test.h"
#include "core/mgs_core.h"

int main(void) {
  const char *cli = getenv("MGS_CLI"), *src = getenv("MGS_SOURCE_DIR");
  if (!cli || !src) { fprintf(stderr, "MGS_CLI / MGS_SOURCE_DIR not set\n"); return 1; }
  const char *tmp = mgs_test_tmpdir("presets_formats");
  CHECK(mgs_test_sh("%s scene --builtin genus2 -o %s/scene --views 14 --test-views 2 --width 40 --height 40 --spp 1 -q", cli, tmp) == 0);
  CHECK(mgs_test_sh("/usr/bin/python3 %s/tests/train/nerf_to_formats.py %s/scene %s/f", src, tmp, tmp) == 0);
  static const char *formats[3] = {"lego", "colmap", "nerfstudio"}, *bg[3] = {"True", "False", "False"};
  static const char *runs[] = {
    "--preset baseline", "--preset morse-d", "--preset morse-r", "--preset morse-i", "--preset morse-full",
    "--preset topology-gs --pers-loss-schedule 20,60,20", "--preset morse-full --literal", "--strategy none",
    "--strategy morse --spawn literal --prune none",
  };
  const char *common = "--iters 60 --random-points 3000 --densify-from 10 --densify-every 10 --opacity-reset-every 1000 "
                       "--morse-warmup 20 --morse-every 20 --morse-resolution 32 --checkpoint-every 0 --save-at 1000 --quiet";
  for (int f = 0; f < 3; f++)
    for (size_t r = 0; r < sizeof runs / sizeof runs[0]; r++) {
      char run[600], path[800];
      snprintf(run, sizeof run, "%s/run_%s_%zu", tmp, formats[f], r);
      int rc = mgs_test_sh("%s train %s/f/%s -o %s %s %s > %s.log 2>&1", cli, tmp, formats[f], run, common, runs[r], run);
      CHECK_MSG(rc == 0, "%s on %s: exit %d (see %s.log)", runs[r], formats[f], rc, run);
      snprintf(path, sizeof path, "%s/point_cloud/iteration_60/point_cloud.ply", run);
      CHECK_MSG(mgs_path_exists(path), "%s on %s: no model", runs[r], formats[f]);
      snprintf(path, sizeof path, "%s/cfg_args", run);
      char want[64];
      snprintf(want, sizeof want, "white_background=%s", bg[f]);
      CHECK_MSG(mgs_test_file_has(path, want), "%s on %s: not %s", runs[r], formats[f], want);
    }
  return mgs_test_finish();
}

/* Every preset and strategy on every format as users have them (issue 21): a NeRF-synthetic
 * folder without any point file (as the original lego ships), a COLMAP text model with
 * photos on black, and a nerfstudio folder — all made from one rendered scene by
 * tests/train/nerf_to_formats.py — train end to end (short schedules), write a model and
 * record the preset; the background follows the format. The COLMAP folder with its images
 * also at half size in images_2 (as Mip-NeRF 360 ships images_2/4/8): `train --images
 * images_2` records the folder, its own evaluation reloads it, and `eval MODEL --data
 * --images images_2` of the same model gives the same PSNR. */
#include <dirent.h>
#include <cjson/cJSON.h>
#include "mgs_test.h"
#include "run_results.h"
#include "core/mgs_core.h"


static void colmap_images_folder(const char *cli, const char *tmp) {
  char dir[700], out[800], in[1200], o2[1200];
  snprintf(dir, sizeof dir, "%s/f/colmap", tmp);
  snprintf(out, sizeof out, "%s/images_2", dir);
  mgs_error err = {0};
  CHECK_OK(mgs_mkdir_p(out, &err), &err);
  snprintf(in, sizeof in, "%s/images", dir);
  DIR *d = opendir(in);
  CHECK(d != NULL);
  int n = 0;
  for (struct dirent *e; d && (e = readdir(d));) {
    if (e->d_name[0] == '.') continue;
    mgs_image *im = NULL;
    snprintf(in, sizeof in, "%s/images/%s", dir, e->d_name);
    snprintf(o2, sizeof o2, "%s/%s", out, e->d_name);
    CHECK_OK(mgs_image_read(in, &im, &err), &err);
    mgs_image *h = im ? mgs_image_downscale(im, 2) : NULL;
    CHECK(h && h->width * 2 == im->width);
    if (h) CHECK_OK(mgs_image_write(o2, h, &err), &err);
    mgs_image_destroy(im);
    mgs_image_destroy(h);
    n++;
  }
  if (d) closedir(d);
  CHECK(n > 0);
  char run[800], cfg[900];
  snprintf(run, sizeof run, "%s/run_colmap_i2", tmp);
  CHECK(mgs_test_sh("%s train %s -o %s --images images_2 --iters 60 --random-points 3000 --checkpoint-every 0 --quiet "
                    "> %s.log 2>&1", cli, dir, run, run) == 0);
  snprintf(cfg, sizeof cfg, "%s/cfg_args", run);
  CHECK(mgs_test_file_has(cfg, "images='images_2'"));
  CHECK(mgs_test_sh("%s eval %s --no-images --no-geometry > /dev/null", cli, run) == 0);
  const double own = mgs_test_results_psnr(run, 60, NULL);
  char imp[800];
  snprintf(imp, sizeof imp, "%s/imported_i2", tmp);
  CHECK(mgs_test_sh("%s eval %s/point_cloud/iteration_60/point_cloud.ply --data %s --images images_2 -o %s --no-images "
                    "--no-geometry > /dev/null", cli, run, dir, imp) == 0);
  const double imported = mgs_test_results_psnr(imp, 0, NULL);
  fprintf(stderr, "images_2: PSNR %.4f dB in its run, %.4f dB imported\n", own, imported);
  CHECK_MSG(own > 10 && fabs(own - imported) < 1e-3, "PSNR %.4f in the run, %.4f imported with --images", own, imported);
  /* the cameras are scaled to the images: 20x20 views of the 40x40 scene */
  snprintf(cfg, sizeof cfg, "%s/cameras.json", run);
  CHECK(mgs_test_file_has(cfg, "\"width\":\t20,"));
  CHECK(mgs_test_sh("%s eval %s/point_cloud/iteration_60/point_cloud.ply --images images_2 2>/dev/null", cli, run) == 2);

  /* --test-every 0 (the reference without --eval): every view trains, recorded; eval of the
     test split says why there is none, --split train evaluates */
  snprintf(run, sizeof run, "%s/run_colmap_all", tmp);
  CHECK(mgs_test_sh("%s train %s -o %s --test-every 0 --iters 30 --checkpoint-every 0 --quiet > %s.log 2>&1", cli, dir, run, run) == 0);
  snprintf(cfg, sizeof cfg, "%s.log", run);
  CHECK(mgs_test_file_has(cfg, ": 16 train views"));
  snprintf(cfg, sizeof cfg, "%s/cfg_args", run);
  CHECK(mgs_test_file_has(cfg, "test_every=0,"));
  CHECK(mgs_test_sh("%s eval %s --no-images --no-geometry > %s/eval_all.txt 2>&1", cli, run, tmp) == 1);
  snprintf(cfg, sizeof cfg, "%s/eval_all.txt", tmp);
  CHECK(mgs_test_file_has(cfg, "no test views (a run trained with --test-every 0"));
  CHECK(mgs_test_sh("%s eval %s --split train --no-images --no-geometry > /dev/null", cli, run) == 0);
}

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
  colmap_images_folder(cli, tmp);
  return mgs_test_finish();
}

/* `morsegs train --normal-loss` and `--init levelset` end to end on a tiny scene: the flags
 * run, are recorded in cfg_args and restored by --resume; bad values and a dataset without
 * points are one-line errors naming the flag. */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include "core/mgs_core.h"
#include "mgs_test.h"

int main(void) {
  const char *cli = getenv("MGS_CLI");
  if (!cli) { fprintf(stderr, "MGS_CLI not set\n"); return 1; }
  const char *tmp = mgs_test_tmpdir("morse_grad_cli");
  char path[512];
  CHECK(mgs_test_sh("%s scene --builtin genus2 -o %s/scene --views 4 --test-views 1 --width 24 --height 24 --spp 1 -q", cli, tmp) == 0);
  /* level-set init and the normal loss together (the term starts at half of 40 iterations) */
  CHECK(mgs_test_sh("%s train %s/scene -o %s/run --iters 40 --init levelset --normal-loss 0.05 --quiet --save-at 1000 "
           "--checkpoint-every 20 2> %s/log.txt", cli, tmp, tmp, tmp) == 0);
  snprintf(path, sizeof path, "%s/log.txt", tmp);
  CHECK(mgs_test_file_has(path, "level-set init"));
  snprintf(path, sizeof path, "%s/run/cfg_args", tmp);
  CHECK(mgs_test_file_has(path, "init='levelset'"));
  CHECK(mgs_test_file_has(path, "normal_loss=0.05"));
  snprintf(path, sizeof path, "%s/run/point_cloud/iteration_40/point_cloud.ply", tmp);
  CHECK(mgs_path_exists(path));
  /* the term acted: its weighted value at the last iteration is in train_stats.json */
  snprintf(path, sizeof path, "%s/run/train_stats.json", tmp);
  CHECK(mgs_test_file_has(path, "\"normal\":") && !mgs_test_file_has(path, "\"normal\":\t0,") && !mgs_test_file_has(path, "\"normal\":\t0\n"));
  /* its state (the SDF it samples, built at iteration 30) comes back with a resume: a run
     interrupted at 50 and resumed ends byte-identical to the uninterrupted one (a term that
     rebuilt its SDF from the model of iteration 50 would not) */
  const char *nl = "--iters 60 --init levelset --normal-loss 0.05 --quiet --save-at 1000 --checkpoint-every 20";
  CHECK(mgs_test_sh("%s train %s/scene -o %s/nu %s 2>/dev/null", cli, tmp, tmp, nl) == 0);
  CHECK(mgs_test_sh("MGS_TRAIN_INTERRUPT_AT=50 %s train %s/scene -o %s/ni %s 2>/dev/null", cli, tmp, tmp, nl) == 130);
  CHECK(mgs_test_sh("%s train %s/scene -o %s/ni --resume --quiet 2>/dev/null", cli, tmp, tmp) == 0);
  CHECK(mgs_test_sh("cmp %s/nu/point_cloud/iteration_60/point_cloud.ply %s/ni/point_cloud/iteration_60/point_cloud.ply", tmp, tmp) == 0);
  /* --resume keeps the recorded weight (and loads the term's state from the checkpoint) */
  CHECK(mgs_test_sh("%s train %s/scene -o %s/run --iters 60 --quiet --resume 2>/dev/null", cli, tmp, tmp) == 0);
  snprintf(path, sizeof path, "%s/run/cfg_args", tmp);
  CHECK(mgs_test_file_has(path, "normal_loss=0.05"));
  /* the space-separated form and the bare flag */
  CHECK(mgs_test_sh("%s train %s/scene -o %s/run2 --iters 4 --normal-loss 0.03 --quiet 2>/dev/null", cli, tmp, tmp) == 0);
  snprintf(path, sizeof path, "%s/run2/cfg_args", tmp);
  CHECK(mgs_test_file_has(path, "normal_loss=0.03"));
  CHECK(mgs_test_sh("%s train %s/scene -o %s/run3 --iters 4 --normal-loss --quiet 2>/dev/null", cli, tmp, tmp) == 0);
  snprintf(path, sizeof path, "%s/run3/cfg_args", tmp);
  CHECK(mgs_test_file_has(path, "normal_loss=0.02"));
  /* bad values: usage errors naming the flag, nothing written */
  CHECK(mgs_test_sh("%s train %s/scene -o %s/bad --normal-loss=-1 2> %s/err.txt", cli, tmp, tmp, tmp) == 2);
  snprintf(path, sizeof path, "%s/err.txt", tmp);
  CHECK(mgs_test_file_has(path, "--normal-loss"));
  CHECK(mgs_test_sh("%s train %s/scene -o %s/bad --normal-loss=1e9 2>/dev/null", cli, tmp, tmp) == 2);
  CHECK(mgs_test_sh("%s train %s/scene -o %s/bad --init level 2>/dev/null", cli, tmp, tmp) == 2);
  snprintf(path, sizeof path, "%s/bad", tmp);
  CHECK(!mgs_path_exists(path));
  /* a dataset without points (as the original lego ships): the level-set init takes its
     points from the visual hull of the train views' alpha (train/init_hull.c) */
  CHECK(mgs_test_sh("rm -f %s/scene/points3d.ply", tmp) == 0);
  CHECK(mgs_test_sh("%s train %s/scene -o %s/nopts --iters 4 --init levelset --quiet 2> %s/err2.txt", cli, tmp, tmp, tmp) == 0);
  snprintf(path, sizeof path, "%s/err2.txt", tmp);
  CHECK(mgs_test_file_has(path, "visual hull") && mgs_test_file_has(path, "level-set init"));
  return mgs_test_finish();
}

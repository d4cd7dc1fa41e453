/* `morsegs train --strategy gaussianpro` end to end (issue 24): a short run on a built-in
 * scene runs its propagation steps (logged, recorded in cfg_args), resumes from a
 * checkpoint taken inside the propagation window, and its model goes through
 * `morsegs eval` (with the scene's mesh) and `morsegs vdb`; a bad --gpro flag and
 * --gpro-schedule with EVERY 0 fail before anything is written. */
#include <string.h>
#include "mgs_test.h"
#include "core/mgs_core.h"

static char *slurp(const char *dir, const char *name) {
  char path[4200], *text = NULL;
  size_t n;
  snprintf(path, sizeof path, "%s/%s", dir, name);
  if (mgs_read_file(path, &text, &n, NULL) != MGS_OK) return NULL;
  return text;
}

static int count(const char *s, const char *needle) {
  int n = 0;
  for (const char *p = s; p && (p = strstr(p, needle)); p += strlen(needle)) n++;
  return n;
}

int main(void) {
  const char *cli = getenv("MGS_CLI");
  if (!cli) { fprintf(stderr, "MGS_CLI not set\n"); return 2; }
  const char *tmp = mgs_test_tmpdir("gaussianpro_cli");
  char data[4200], run[4200], run2[4200], bad[4200], log[4300], vdb[4300];
  snprintf(data, sizeof data, "%s/genus2", tmp);
  snprintf(run, sizeof run, "%s/run", tmp);
  snprintf(run2, sizeof run2, "%s/run-resumed", tmp);
  snprintf(bad, sizeof bad, "%s/run-bad", tmp);
  snprintf(log, sizeof log, "%s/train.log", tmp);
  snprintf(vdb, sizeof vdb, "%s/run.vdb", tmp);
  CHECK(mgs_test_sh("%s scene --builtin genus2 -o %s --views 16 --test-views 2 --width 64 --height 64 --spp 1 -q", cli, data) == 0);
  const char *common = "--strategy gaussianpro --gpro-schedule 100,260,50 --gpro-patch 11 --gpro-pm-iters 3 "
                       "--seed 1 --quiet --threads 2";
  CHECK(mgs_test_sh("%s train %s -o %s --iters 300 --checkpoint-every 0 %s > %s 2>&1", cli, data, run, common, log) == 0);
  char *text = slurp(tmp, "train.log"), *cfg = slurp(run, "cfg_args");
  /* steps at 150, 200, 250 (from < it < until, it %% every == 0) */
  CHECK_MSG(count(text, "gaussianpro @") == 3, "log:\n%s", text ? text : "(none)");
  CHECK(text && strstr(text, "gaussianpro @150: view 0") && strstr(text, "gaussianpro @250: view 2"));
  CHECK(cfg && strstr(cfg, "strategy='gaussianpro'") && strstr(cfg, "gpro_schedule=") && strstr(cfg, "gpro_patch=11"));
  free(text); free(cfg);

  /* stopped at 200 (its checkpoint), resumed to 300: the view cycle goes on where it was
     (the trainer runs no hooks at a run's last iteration, so 200's step is not made) */
  char log2[4300];
  snprintf(log2, sizeof log2, "%s/resume.log", tmp);
  CHECK(mgs_test_sh("%s train %s -o %s --iters 200 --checkpoint-every 200 %s", cli, data, run2, common) == 0);
  CHECK(mgs_test_sh("%s train %s -o %s --resume --iters 300 --checkpoint-every 0 --threads 2 > %s 2>&1", cli, data, run2,
                    log2) == 0);
  text = slurp(tmp, "resume.log");
  CHECK_MSG(text && strstr(text, "gaussianpro @250: view 1 ") && count(text, "gaussianpro @") == 1, "log:\n%s",
            text ? text : "(none)");
  free(text);
  CHECK(mgs_test_sh("test -s %s/point_cloud/iteration_300/point_cloud.ply", run2) == 0);

  CHECK(mgs_test_sh("%s eval %s --max-views 1 --no-images", cli, run) == 0);
  CHECK(mgs_test_sh("%s vdb %s -o %s", cli, run, vdb) == 0);
  CHECK(mgs_test_sh("test -s %s", vdb) == 0);

  /* bad flags: refused, nothing written */
  CHECK(mgs_test_sh("%s train %s -o %s --strategy gaussianpro --gpro-patch 1 --quiet", cli, data, bad) != 0);
  CHECK(mgs_test_sh("%s train %s -o %s --strategy gaussianpro --gpro-schedule 100,200,0 --quiet", cli, data, bad) != 0);
  CHECK(mgs_test_sh("test -e %s/cfg_args", bad) != 0);
  return mgs_test_finish();
}

/* `morsegs train` with MorseGS on a built-in scene (issue 14): --strategy morse with L_topo
 * runs, writes RUN/morse_analysis.csv (one row per analysis), records its settings in
 * cfg_args and the analysis time in train_stats.json; --preset morse-r is recorded as
 * such; bad MorseGS flags fail before anything is written. */
#include <stdarg.h>
#include <string.h>
#include <sys/wait.h>
#include "mgs_test.h"
#include "core/mgs_core.h"

static const char *cli;

static char *slurp(const char *dir, const char *name) {
  char path[4200], *text = NULL;
  size_t n;
  snprintf(path, sizeof path, "%s/%s", dir, name);
  if (mgs_read_file(path, &text, &n, NULL) != MGS_OK) return NULL;
  return text;
}

static int count_lines(const char *s) {
  int n = 0;
  for (; s && *s; s++) n += *s == '\n';
  return n;
}

int main(void) {
  cli = getenv("MGS_CLI");
  if (!cli) { fprintf(stderr, "MGS_CLI not set\n"); return 2; }
  const char *tmp = mgs_test_tmpdir("morse_cli");
  char data[4200], run[4200], run2[4200], bad[4200];
  snprintf(data, sizeof data, "%s/genus2", tmp);
  snprintf(run, sizeof run, "%s/run-morse", tmp);
  snprintf(run2, sizeof run2, "%s/run-r", tmp);
  snprintf(bad, sizeof bad, "%s/run-bad", tmp);
  CHECK(mgs_test_sh("%s scene --builtin genus2 -o %s --views 16 --test-views 2 --width 64 --height 64 --spp 1 -q", cli, data) == 0);
  const char *common = "--iters 250 --morse-warmup 100 --morse-every 100 --morse-resolution 96 --checkpoint-every 0 --seed 1 --quiet --threads 2";
  CHECK(mgs_test_sh("%s train %s -o %s --strategy morse --topo-loss %s", cli, data, run, common) == 0);
  char *csv = slurp(run, "morse_analysis.csv"), *cfg = slurp(run, "cfg_args"), *stats = slurp(run, "train_stats.json");
  CHECK(csv && !strncmp(csv, "iteration,s_alpha,s_sdf,s_persistence", 37));
  CHECK(count_lines(csv) == 3); /* header + analyses at 100 and 200 (the last iteration has no hooks) */
  CHECK(csv && strstr(csv, "\n100,") && strstr(csv, "\n200,"));
  CHECK(cfg && strstr(cfg, "strategy='morse'") && strstr(cfg, "morse_spawn='gaps'") && strstr(cfg, "morse_prune='floaters'") &&
        strstr(cfg, "topo_loss='eliminate'") && strstr(cfg, "preset='none'"));
  CHECK(stats && strstr(stats, "\"morse_analyses\":\t2"));
  free(csv); free(cfg); free(stats);

  CHECK(mgs_test_sh("%s train %s -o %s --preset morse-r %s", cli, data, run2, common) == 0);
  cfg = slurp(run2, "cfg_args");
  CHECK(cfg && strstr(cfg, "preset='morse-r'") && strstr(cfg, "strategy='adc'") && strstr(cfg, "topo_loss='eliminate'"));
  free(cfg);

  /* every MorseGS component at once (level-set init, normal loss, strategy, L_topo): the
     analyses run (a CSV row each) and the record names them */
  char run3[4200];
  snprintf(run3, sizeof run3, "%s/run-full", tmp);
  CHECK(mgs_test_sh("%s train %s -o %s --preset morse-full %s", cli, data, run3, common) == 0);
  cfg = slurp(run3, "cfg_args");
  csv = slurp(run3, "morse_analysis.csv");
  CHECK(cfg && strstr(cfg, "preset='morse-full'") && strstr(cfg, "init='levelset'") && strstr(cfg, "normal_loss=0.01") &&
        strstr(cfg, "strategy='morse'"));
  CHECK(count_lines(csv) == 3);
  free(cfg); free(csv);

  /* bad input: one-line errors, exit 2, no RUN */
  const char *bads[] = {"--topo-loss --eps-sig 0.9", "--topo-loss --beta -1", "--strategy morse --morse-every 0",
                        "--topo-loss --morse-resolution 2048 --morse-warmup 2", "--topo-loss --morse-warmup 10",
                        "--spawn gaps", "--preset nope", "--topo-loss --topo-dims 5"};
  for (size_t k = 0; k < sizeof bads / sizeof *bads; k++) {
    CHECK(mgs_test_sh("%s train %s -o %s %s --iters 5 --quiet 2> %s.err", cli, data, bad, bads[k], bad) == 2);
    CHECK(!mgs_path_exists(bad));
    char errp[4300], *e = NULL;
    size_t n;
    snprintf(errp, sizeof errp, "%s.err", bad);
    CHECK(mgs_read_file(errp, &e, &n, NULL) == MGS_OK && count_lines(e) == 1 && strstr(e, "--"));
    free(e);
  }
  return mgs_test_finish();
}

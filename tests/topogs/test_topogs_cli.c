/* `morsegs train` with the Topology-GS flags end to end on a tiny rendered scene:
 * --preset topology-gs runs LPVI (more Gaussians than input points) and PersLoss, records
 * both in cfg_args, and --resume continues with them; bad flag values exit 2 with a message
 * naming the flag, before any dataset is read. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include "mgs_test.h"

static const char *cli;

/* Runs the CLI with args; returns its exit code; its stderr+stdout goes to out (if set). */
static int run(const char *args, char *out, size_t cap) {
  char cmd[2048];
  snprintf(cmd, sizeof cmd, "MGS_THREADS=2 '%s' %s 2>&1", cli, args);
  FILE *p = popen(cmd, "r");
  if (!p) return -1;
  size_t n = 0;
  char buf[512];
  while (fgets(buf, sizeof buf, p)) {
    size_t l = strlen(buf);
    if (out && n + l + 1 < cap) { memcpy(out + n, buf, l); n += l; }
  }
  if (out) out[n] = 0;
  int st = pclose(p);
  return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

static char *slurp(const char *path) {
  FILE *f = fopen(path, "rb");
  if (!f) return NULL;
  static char buf[1 << 16];
  size_t n = fread(buf, 1, sizeof buf - 1, f);
  fclose(f);
  buf[n] = 0;
  return buf;
}

static void test_bad_flags(void) {
  static char out[1 << 14];
  static const struct { const char *args, *flag; } cases[] = {
    {"train nowhere -o x --pers-loss-form foo", "--pers-loss-form"},
    {"train nowhere -o x --pers-loss-k 1,2", "--pers-loss-k"},
    {"train nowhere -o x --pers-loss-schedule 300,200,10", "--pers-loss-schedule"},
    {"train nowhere -o x --pers-loss-downsample 0", "--pers-loss-downsample"},
    {"train nowhere -o x --pers-loss=-1", "--pers-loss"},
    {"train nowhere -o x --lpvi-tau -1", "--lpvi-tau"},
    {"train nowhere -o x --lpvi-max-edge 0", "--lpvi-max-edge"},
  };
  for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
    int rc = run(cases[i].args, out, sizeof out);
    CHECK_MSG(rc == 2 && strstr(out, cases[i].flag), "%s: rc %d, output: %s", cases[i].args, rc, out);
  }
}

static void test_preset_end_to_end(void) {
  static char out[1 << 16];
  CHECK(run("scene --builtin sphere -o tg_scene --force --views 4 --test-views 1 --width 32 --height 32 "
            "--init-points 400 --spp 1 -q", out, sizeof out) == 0);
  int rc = run("train tg_scene -o tg_run --force --preset topology-gs --iters 30 --pers-loss-schedule 10,30,10 "
               "--checkpoint-every 10 --save-at 30 --quiet", out, sizeof out);
  CHECK_MSG(rc == 0, "train failed: %s", out);
  CHECK_MSG(strstr(out, "LPVI (corrected): 400 points in"), "no LPVI report: %s", out);
  char *cfg = slurp("tg_run/cfg_args");
  CHECK(cfg && strstr(cfg, "init='lpvi'") && strstr(cfg, "preset='topology-gs'") && strstr(cfg, "pers_loss=10") &&
        strstr(cfg, "pers_loss_form='topk'") && strstr(cfg, "lpvi_faithful=False"));
  char *stats = slurp("tg_run/train_stats.json");
  CHECK(stats && strstr(stats, "\"iterations\""));
  /* resume: the settings come back from cfg_args */
  rc = run("train tg_scene -o tg_run --resume --iters 40 --quiet", out, sizeof out);
  CHECK_MSG(rc == 0 && strstr(out, "resuming"), "resume failed: %s", out);
  cfg = slurp("tg_run/cfg_args");
  CHECK(cfg && strstr(cfg, "pers_loss=10") && strstr(cfg, "iterations=40") && strstr(cfg, "pers_loss_schedule='10,30,10'"));
  /* faithful LPVI alone */
  rc = run("train tg_scene -o tg_run2 --force --init lpvi --lpvi-faithful --iters 5 --quiet", out, sizeof out);
  CHECK_MSG(rc == 0 && strstr(out, "LPVI (faithful)"), "faithful failed: %s", out);
}

int main(void) {
  cli = getenv("MGS_CLI");
  if (!cli) { fprintf(stderr, "MGS_CLI not set\n"); return 1; }
  RUN(test_bad_flags);
  RUN(test_preset_end_to_end);
  return mgs_test_finish();
}

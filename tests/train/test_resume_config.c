/* Interrupt and --resume with every setting that changes the result (issue 21): a run
 * stopped at iteration 70 (MGS_TRAIN_INTERRUPT_AT, as Ctrl-C) and resumed with a bare
 * `--resume` ends byte-identical to the uninterrupted run — for settings that were once
 * lost on resume (--sparse-adam/--dense-adam, --view-order, --visibility, --image-cache-mb)
 * and for a MorseGS preset, and with the SH degree raised before and after the interrupt; a
 * resume typing a contradicting value is refused naming both; cfg_args holds each of them; a
 * checkpoint whose cfg_args is gone is refused, not resumed with the flags typed now. */
#include "mgs_test.h"
#include "core/mgs_core.h"

int main(void) {
  const char *cli = getenv("MGS_CLI");
  if (!cli) { fprintf(stderr, "MGS_CLI not set\n"); return 1; }
  const char *tmp = mgs_test_tmpdir("resume_config");
  CHECK(mgs_test_sh("%s scene --builtin sphere -o %s/scene --views 10 --test-views 1 --width 32 --height 32 --spp 1 -q", cli, tmp) == 0);
  const char *common = "--iters 120 --checkpoint-every 40 --save-at 1000 --seed 3 --quiet --densify-from 20 --densify-every 20 "
                       "--opacity-reset-every 60";
  static const struct { const char *flags, *record, *contra, *named; } cases[] = {
    {"--sparse-adam", "adam='sparse'", "--dense-adam", "adam = sparse"},
    {"--dense-adam --visibility on", "adam='dense'", "--adam=sparse", "adam = dense"},
    {"--view-order locality", "view_order='locality'", "--view-order random", "view_order = locality"},
    {"--visibility on", "visibility='on'", "--visibility off", "visibility = on"},
    {"--image-cache-mb 1", "image_cache_mb=1", "--image-cache-mb 0", "image_cache_mb = 1"},
    {"--preset morse-r --morse-warmup 30 --morse-every 30 --morse-resolution 48", "topo_loss='eliminate'", "--beta 0.01",
     "topo_beta = 0.003"},
    /* the SH degree raised before and after the interrupt: SH-rest steps use feature_rest_lr,
       which a resume reads from the record (the trainer's own default once differed by an ulp) */
    {"--sh-every 30", "sh_increase_every=30", "--sh-every 40", "sh_increase_every = 30"},
    {"--sh-every 30 --sh-moments-bf16", "sh_moments_bf16=True", "--sh-moments-bf16=false", "sh_moments_bf16 = True"},
  };
  for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
    char a[512], b[512], path[1100];
    snprintf(a, sizeof a, "%s/a%zu", tmp, k);
    snprintf(b, sizeof b, "%s/b%zu", tmp, k);
    CHECK(mgs_test_sh("%s train %s/scene -o %s %s %s", cli, tmp, a, common, cases[k].flags) == 0);
    CHECK(mgs_test_sh("MGS_TRAIN_INTERRUPT_AT=70 %s train %s/scene -o %s %s %s 2>/dev/null", cli, tmp, b, common,
                      cases[k].flags) == 130);
    snprintf(path, sizeof path, "%s/cfg_args", b);
    CHECK_MSG(mgs_test_file_has(path, cases[k].record), "%s lacks %s", path, cases[k].record);
    /* a contradicting flag is refused, naming the flag's value and the record's */
    snprintf(path, sizeof path, "%s/err.txt", b);
    CHECK(mgs_test_sh("%s train %s/scene -o %s --resume --quiet %s 2> %s", cli, tmp, b, cases[k].contra, path) == 2);
    CHECK_MSG(mgs_test_file_has(path, cases[k].named) && mgs_test_file_has(path, "contradicts"), "%s: no '%s'", path, cases[k].named);
    /* a bare resume continues with every recorded setting */
    CHECK(mgs_test_sh("%s train %s/scene -o %s --resume --quiet", cli, tmp, b) == 0);
    CHECK_MSG(mgs_test_sh("cmp %s/point_cloud/iteration_120/point_cloud.ply %s/point_cloud/iteration_120/point_cloud.ply", a, b) == 0,
              "resumed run differs with %s", cases[k].flags);
  }
  /* a checkpoint without its settings record is not resumed with whatever is typed now */
  char r[512], path[1100];
  snprintf(r, sizeof r, "%s/norecord", tmp);
  CHECK(mgs_test_sh("MGS_TRAIN_INTERRUPT_AT=10 %s train %s/scene -o %s %s --lambda-dssim 0.5 2>/dev/null", cli, tmp, r, common) == 130);
  snprintf(path, sizeof path, "%s/cfg_args", r);
  CHECK(remove(path) == 0);
  snprintf(path, sizeof path, "%s/err.txt", tmp);
  CHECK(mgs_test_sh("%s train %s/scene -o %s --resume --quiet 2> %s", cli, tmp, r, path) == 2);
  CHECK_MSG(mgs_test_file_has(path, "cfg_args: not found") && mgs_test_file_has(path, "--force"), "%s: no refusal", path);
  snprintf(path, sizeof path, "%s/point_cloud/iteration_120", r);
  CHECK(mgs_test_sh("test -e %s", path) != 0);
  return mgs_test_finish();
}

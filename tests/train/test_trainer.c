/* The trainer on a small synthetic scene: the loss goes down, checkpoint -> resume
 * continues bit-identically, a NaN in a parameter stops training with a message naming
 * the group and no .ply is written. Single-threaded for determinism. */
#include <string.h>
#include "mgs_test.h"
#include "synth.h"
#include "train/mgs_train.h"
#include "train/mgs_strategy.h"

static mgs_dataset *ds;

static void small_options(mgs_train_options *o, int iters) {
  mgs_train_options_default(o);
  o->iterations = iters;
  o->sh_every = 10;
  o->adc.densify_from = 5;
  o->adc.densify_every = 10;
  o->adc.opacity_reset_every = 25;
  o->adc.densify_until = 1000;
  o->adc.grad_threshold = 2e-4f;
  o->seed = 3;
}

static mgs_trainer *make(const mgs_train_options *o, uint64_t init_seed) {
  mgs_rng r;
  mgs_rng_init(&r, init_seed, 1);
  double lo[3] = {-1, -1, -1}, hi[3] = {1, 1, 1};
  mgs_gaussians *g = NULL;
  mgs_error err;
  if (mgs_init_random(300, lo, hi, 3, &r, &g, &err) != MGS_OK) { fprintf(stderr, "%s\n", err.msg); exit(2); }
  mgs_trainer *t = NULL;
  if (mgs_trainer_create(ds, o, g, mgs_strategy_adc_create(&o->adc), &t, &err) != MGS_OK) {
    fprintf(stderr, "%s\n", err.msg);
    exit(2);
  }
  return t;
}

static int same_model(const mgs_gaussians *a, const mgs_gaussians *b) {
  if (a->n != b->n) { fprintf(stderr, "counts differ: %zu vs %zu\n", a->n, b->n); return 0; }
  for (int k = 0; k < MGS_PARAM_COUNT; k++) {
    size_t bytes = a->n * (size_t)mgs_param_dim((mgs_param_group)k) * sizeof(float);
    if (memcmp(mgs_gaussians_group((mgs_gaussians *)a, (mgs_param_group)k),
               mgs_gaussians_group((mgs_gaussians *)b, (mgs_param_group)k), bytes)) {
      fprintf(stderr, "group %s differs\n", mgs_param_name((mgs_param_group)k));
      return 0;
    }
  }
  return 1;
}

static void test_loss_decreases(void) {
  mgs_train_options o;
  small_options(&o, 150);
  mgs_trainer *t = make(&o, 1);
  mgs_error err;
  double p0, s0, p1, s1;
  CHECK_OK(mgs_trainer_evaluate(t, MGS_SPLIT_TEST, 0, &p0, &s0, &err), &err);
  CHECK_OK(mgs_trainer_run(t, &err), &err);
  CHECK(mgs_trainer_iteration(t) == 150);
  CHECK(mgs_trainer_active_sh(t) == 3);
  CHECK_OK(mgs_trainer_evaluate(t, MGS_SPLIT_TEST, 0, &p1, &s1, &err), &err);
  CHECK_MSG(p1 > p0 + 3, "test PSNR %.2f -> %.2f", p0, p1);
  CHECK(mgs_trainer_model(t)->n != 300); /* ADC acted */
  fprintf(stderr, "  test PSNR %.2f -> %.2f dB, SSIM %.3f -> %.3f, %zu Gaussians\n", p0, p1, s0, s1, mgs_trainer_model(t)->n);
  mgs_trainer_destroy(t);
}

static void test_resume_bit_identical(void) {
  const char *dir = mgs_test_tmpdir("resume");
  char ck[4200];
  snprintf(ck, sizeof ck, "%s/ck.mgsckpt", dir);
  mgs_train_options o;
  small_options(&o, 40);
  mgs_error err;
  mgs_trainer *a = make(&o, 5);
  CHECK_OK(mgs_trainer_run(a, &err), &err);
  /* interrupted at 17: between densifications, with accumulators and moments in flight */
  mgs_trainer *b = make(&o, 5);
  CHECK_OK(mgs_trainer_run_until(b, 17, &err), &err);
  CHECK_OK(mgs_trainer_save_checkpoint(b, ck, &err), &err);
  mgs_trainer_destroy(b);
  mgs_trainer *c = make(&o, 99); /* another init: everything must come from the checkpoint */
  CHECK_OK(mgs_trainer_load_checkpoint(c, ck, &err), &err);
  CHECK(mgs_trainer_iteration(c) == 17);
  CHECK_OK(mgs_trainer_run(c, &err), &err);
  CHECK(mgs_trainer_iteration(c) == 40);
  CHECK(same_model(mgs_trainer_model(a), mgs_trainer_model(c)));
  /* a corrupted checkpoint is refused with a message naming the file */
  FILE *f = fopen(ck, "r+b");
  CHECK(f != NULL);
  if (f) { fseek(f, 200, SEEK_SET); fputc(0x5a, f); fclose(f); }
  mgs_trainer *d = make(&o, 5);
  mgs_error_clear(&err);
  CHECK(mgs_trainer_load_checkpoint(d, ck, &err) == MGS_ERR_FORMAT);
  CHECK(strstr(err.msg, "ck.mgsckpt") != NULL);
  mgs_trainer_destroy(a); mgs_trainer_destroy(c); mgs_trainer_destroy(d);
}

static void test_nan_stops(void) {
  const char *groups[] = {"log_scale", "opacity", "mean"};
  for (int k = 0; k < 3; k++) {
    mgs_train_options o;
    small_options(&o, 50);
    mgs_trainer *t = make(&o, 2);
    mgs_error err;
    CHECK_OK(mgs_trainer_run_until(t, 4, &err), &err);
    mgs_gaussians *g = mgs_trainer_model_mut(t);
    if (k == 0) g->log_scale[3 * 7 + 1] = NAN;
    if (k == 1) g->opacity[11] = INFINITY;
    if (k == 2) g->mean[3 * 5] = NAN;
    mgs_error_clear(&err);
    mgs_status st = mgs_trainer_run(t, &err);
    CHECK(st == MGS_ERR_NUMERIC);
    CHECK_MSG(strstr(err.msg, groups[k]) != NULL, "message does not name '%s': %s", groups[k], err.msg);
    CHECK(mgs_trainer_iteration(t) < 50);
    /* the run writer refuses the model: no .ply */
    const char *dir = mgs_test_tmpdir("nanrun");
    mgs_error e2;
    CHECK(mgs_run_write_ply(dir, mgs_trainer_iteration(t), mgs_trainer_model(t), &e2) != MGS_OK);
    CHECK(mgs_run_latest_iteration(dir) < 0);
    mgs_trainer_destroy(t);
  }
}

static void test_stop_flag_checkpoints(void) {
  const char *dir = mgs_test_tmpdir("stop");
  char ck[4200];
  snprintf(ck, sizeof ck, "%s/ck.mgsckpt", dir);
  volatile sig_atomic_t stop = 0;
  mgs_train_options o;
  small_options(&o, 30);
  o.stop = &stop;
  o.checkpoint_path = ck;
  mgs_trainer *t = make(&o, 4);
  mgs_error err;
  CHECK_OK(mgs_trainer_run_until(t, 9, &err), &err);
  stop = 1;
  CHECK(mgs_trainer_run(t, &err) == MGS_ERR_INTERRUPTED);
  CHECK(mgs_path_exists(ck));
  mgs_trainer *u = make(&o, 4);
  stop = 0;
  CHECK_OK(mgs_trainer_load_checkpoint(u, ck, &err), &err);
  CHECK(mgs_trainer_iteration(u) == 9);
  CHECK(same_model(mgs_trainer_model(t), mgs_trainer_model(u)));
  mgs_trainer_destroy(t); mgs_trainer_destroy(u);
}

int main(void) {
  mgs_parallel_set_threads(1);
  mgs_log_set_level(MGS_LOG_WARN);
  mgs_gaussians *gt = synth_model(40, 7);
  ds = synth_dataset(gt, 8, 3, 40, 32);
  RUN(test_loss_decreases);
  RUN(test_resume_bit_identical);
  RUN(test_nan_stops);
  RUN(test_stop_flag_checkpoints);
  mgs_dataset_destroy(ds);
  mgs_gaussians_destroy(gt);
  return mgs_test_finish();
}

/* The trainer on a small synthetic scene: the loss goes down, checkpoint -> resume
 * continues bit-identically (also from the checkpoint written before the first step), a NaN in a parameter stops training with a message naming
 * the group and no .ply is written. Single-threaded for determinism. */
#include <string.h>
#include "mgs_test.h"
#include "synth.h"
#include "train/mgs_train.h"
#include "train/mgs_strategy.h"
#include "train/mgs_term.h"

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
  /* the run's initial checkpoint (morsegs train writes one before the first step, so that
     a run killed at once can --resume): the strategy's state is not sized yet, and the
     resumed run still ends as the uninterrupted one */
  mgs_trainer *b0 = make(&o, 5);
  CHECK_OK(mgs_trainer_save_checkpoint(b0, ck, &err), &err);
  mgs_trainer_destroy(b0);
  mgs_trainer *c0 = make(&o, 99);
  CHECK_OK(mgs_trainer_load_checkpoint(c0, ck, &err), &err);
  CHECK(mgs_trainer_iteration(c0) == 0);
  CHECK_OK(mgs_trainer_run(c0, &err), &err);
  CHECK(same_model(mgs_trainer_model(a), mgs_trainer_model(c0)));
  mgs_trainer_destroy(c0);
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


/* ---- loss terms (train/mgs_term.h) ---------------------------------------------------- */

/* A model term: weight * sum of opacity logits (gradient = weight per Gaussian), active on
 * every `every`-th iteration, with a call counter as its checkpointed state; and an image
 * term: weight * sum of rendered values (gradient = weight per pixel channel). */
typedef struct { double w; int every; int64_t calls; int model; } toy_term;
static unsigned toy_active(void *self, int it) {
  toy_term *t = self;
  return it % t->every == 0 ? (t->model ? MGS_TERM_MODEL : MGS_TERM_IMAGE) : 0;
}
static mgs_status toy_model(void *self, mgs_term_step *s, mgs_error *err) {
  (void)err;
  toy_term *t = self;
  t->calls++;
  double v = 0;
  for (size_t i = 0; i < s->model->n; i++) { s->grad->opacity[i] += (float)t->w; v += t->w * s->model->opacity[i]; }
  s->value = v;
  return MGS_OK;
}
static mgs_status toy_image(void *self, mgs_term_step *s, mgs_error *err) {
  (void)err;
  toy_term *t = self;
  t->calls++;
  size_t np = (size_t)s->width * (size_t)s->height * 3;
  double v = 0;
  for (size_t i = 0; i < np; i++) { s->dl_dcolor[i] += (float)t->w; v += t->w * s->color[i]; }
  s->value = v;
  return MGS_OK;
}
static mgs_status toy_save(void *self, FILE *f, mgs_error *err) {
  return fwrite(&((toy_term *)self)->calls, 8, 1, f) == 1 ? MGS_OK : mgs_error_set(err, MGS_ERR_IO, "toy: write");
}
static mgs_status toy_load(void *self, FILE *f, mgs_error *err) {
  return fread(&((toy_term *)self)->calls, 8, 1, f) == 1 ? MGS_OK : mgs_error_set(err, MGS_ERR_FORMAT, "toy: read");
}
static void toy_destroy(void *self) { free(self); }
static const mgs_term_ops toy_model_ops = {"toy-model", toy_active, NULL, toy_model, toy_save, toy_load, toy_destroy, NULL};
static const mgs_term_ops toy_image_ops = {"toy-image", toy_active, toy_image, NULL, toy_save, toy_load, toy_destroy, NULL};

static toy_term *add_toy(mgs_trainer *t, int model, double w, int every) {
  toy_term *tt = calloc(1, sizeof *tt);
  tt->w = w; tt->every = every; tt->model = model;
  mgs_error err;
  CHECK_OK(mgs_trainer_add_term(t, mgs_term_create(model ? &toy_model_ops : &toy_image_ops, tt), &err), &err);
  return tt;
}

static double mean_opacity(const mgs_gaussians *g) {
  double s = 0;
  for (size_t i = 0; i < g->n; i++) s += g->opacity[i];
  return s / (double)g->n;
}

static void test_terms(void) {
  mgs_error err;
  mgs_train_options o;
  small_options(&o, 40);
  o.adc.densify_from = 1000; /* fixed count: models comparable Gaussian by Gaussian */
  o.adc.opacity_reset_every = 0;
  /* a strong model term pushes every opacity logit down; a strong image term pushes
     rendered values down (so opacities too, on a white-free synthetic scene) */
  mgs_trainer *plain = make(&o, 8), *m = make(&o, 8), *im = make(&o, 8);
  toy_term *tm = add_toy(m, 1, 1.0, 1);
  add_toy(im, 0, 1e-3, 1);
  CHECK_OK(mgs_trainer_run(plain, &err), &err);
  CHECK_OK(mgs_trainer_run(m, &err), &err);
  CHECK_OK(mgs_trainer_run(im, &err), &err);
  double o0 = mean_opacity(mgs_trainer_model(plain)), o1 = mean_opacity(mgs_trainer_model(m));
  fprintf(stderr, "  mean opacity logit: plain %.3f, model term %.3f\n", o0, o1);
  CHECK(o1 < o0 - 0.5);
  CHECK(tm->calls == 39); /* every iteration but the last (no optimizer step there) */
  double v[2] = {0, 0};
  CHECK(mgs_trainer_term_values(m, v, 2) == 1);
  CHECK(!same_model(mgs_trainer_model(plain), mgs_trainer_model(im)));
  mgs_trainer_destroy(plain); mgs_trainer_destroy(m); mgs_trainer_destroy(im);

  /* checkpoint in the middle: the terms' state comes back and the run ends identical */
  const char *dir = mgs_test_tmpdir("terms");
  char ck[4200];
  snprintf(ck, sizeof ck, "%s/ck.mgsckpt", dir);
  small_options(&o, 40);
  mgs_trainer *a = make(&o, 9);
  add_toy(a, 1, 0.3, 3);
  add_toy(a, 0, 1e-4, 2);
  CHECK_OK(mgs_trainer_run(a, &err), &err);
  mgs_trainer *b = make(&o, 9);
  add_toy(b, 1, 0.3, 3);
  add_toy(b, 0, 1e-4, 2);
  CHECK_OK(mgs_trainer_run_until(b, 22, &err), &err);
  CHECK_OK(mgs_trainer_save_checkpoint(b, ck, &err), &err);
  mgs_trainer_destroy(b);
  mgs_trainer *c = make(&o, 9);
  toy_term *c1 = add_toy(c, 1, 0.3, 3);
  add_toy(c, 0, 1e-4, 2);
  CHECK_OK(mgs_trainer_load_checkpoint(c, ck, &err), &err);
  CHECK(c1->calls == 7); /* iterations 3, 6, ..., 21 */
  CHECK_OK(mgs_trainer_run(c, &err), &err);
  CHECK(same_model(mgs_trainer_model(a), mgs_trainer_model(c)));
  /* a run with other terms refuses that checkpoint, naming it */
  mgs_trainer *d = make(&o, 9);
  add_toy(d, 1, 0.3, 3);
  mgs_error_clear(&err);
  CHECK(mgs_trainer_load_checkpoint(d, ck, &err) != MGS_OK);
  CHECK(strstr(err.msg, "ck.mgsckpt") && strstr(err.msg, "loss terms"));
  mgs_trainer_destroy(a); mgs_trainer_destroy(c); mgs_trainer_destroy(d);
}

/* The position learning rate decays over position_lr_max_steps (30000 by default), not
 * over the run's own length; 0 restores the run's length. */
static void test_position_lr_steps(void) {
  mgs_error err;
  mgs_train_options o;
  small_options(&o, 20);
  mgs_trainer *t = make(&o, 1);
  CHECK_OK(mgs_trainer_run_until(t, 20, &err), &err);
  double ext = ds->extent > 0 ? ds->extent : 1.0;
  /* the lr of the last iteration run */
  double want = mgs_expon_lr(20, 1.6e-4 * ext, 1.6e-6 * ext, 30000);
  CHECK_NEAR(mgs_trainer_learning_rate(t, MGS_PARAM_MEAN), want, 1e-6 * want);
  mgs_trainer_destroy(t);
  o.lr_mean_max_steps = 0;
  mgs_trainer *u = make(&o, 1);
  CHECK_OK(mgs_trainer_run_until(u, 20, &err), &err);
  double short_run = mgs_expon_lr(20, 1.6e-4 * ext, 1.6e-6 * ext, 20);
  CHECK_NEAR(mgs_trainer_learning_rate(u, MGS_PARAM_MEAN), short_run, 1e-6 * short_run);
  mgs_trainer_destroy(u);
  CHECK(want > 1.5e-4 * ext && short_run < 1.7e-6 * ext);
  mgs_train_options d;
  mgs_train_options_default(&d);
  CHECK(d.lr_mean_max_steps == 30000);
}

/* Save points: run_to(N) stops where the reference saves N (N-1 iterations complete). */
static void test_save_point(void) {
  mgs_error err;
  mgs_train_options o;
  small_options(&o, 30);
  mgs_trainer *t = make(&o, 3);
  CHECK(mgs_trainer_model_iteration(t) == 1);
  CHECK_OK(mgs_trainer_run_to(t, 25, &err), &err); /* 25: an opacity reset */
  CHECK(mgs_trainer_iteration(t) == 24 && mgs_trainer_model_iteration(t) == 25);
  CHECK_OK(mgs_trainer_run_to(t, 30, &err), &err);
  CHECK(mgs_trainer_iteration(t) == 30 && mgs_trainer_model_iteration(t) == 30);
  mgs_trainer_destroy(t);
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
  RUN(test_terms);
  RUN(test_position_lr_steps);
  RUN(test_save_point);
  mgs_dataset_destroy(ds);
  mgs_gaussians_destroy(gt);
  return mgs_test_finish();
}

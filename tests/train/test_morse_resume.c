/* The MorseGS strategy and the L_topo term inside the trainer: a run with Morse analyses
 * (spawn gaps + floater pruning + L_topo eliminate, the morse-full components this
 * branch provides) interrupted between two analyses and resumed from its checkpoint ends
 * with the same model, bit for bit, as the uninterrupted run (same seed, one thread).
 * Also: analyses happen at W, W+K, ...; the per-analysis rows are written. */
#include <math.h>
#include <stdio.h>
#include <string.h>
#include "mgs_test.h"
#include "train/synth.h"
#include "train/mgs_train.h"
#include "train/mgs_strategy.h"
#include "train/mgs_morse.h"
#include "train/mgs_term.h"

static mgs_dataset *ds;
static char ck[512], csv[512];

static void small_options(mgs_train_options *o, mgs_morse_options *m, int iters) {
  mgs_train_options_default(o);
  o->iterations = iters;
  o->sh_every = 50;
  o->adc.densify_from = 30;
  o->adc.densify_every = 30;
  o->adc.densify_until = 1000;
  o->adc.opacity_reset_every = 0;
  o->adc.grad_threshold = 2e-4f;
  o->seed = 3;
  mgs_morse_options_default(m);
  m->warmup = 60; m->every = 60; m->until = 1000;
  m->resolution = 64;
  m->spawn = MGS_MORSE_SPAWN_GAPS;
  m->prune = MGS_MORSE_PRUNE_FLOATERS;
  m->topo = MGS_MORSE_TOPO_ELIMINATE;
  m->beta = 0.01;
}

static mgs_trainer *make(const mgs_train_options *o, const mgs_morse_options *m, mgs_morse_ctx **ctx_out) {
  mgs_gaussians *g = synth_model(150, 9);
  mgs_morse_ctx *ctx = NULL;
  mgs_strategy *s = NULL;
  mgs_term *term = NULL;
  mgs_trainer *t = NULL;
  mgs_error err;
  if (mgs_morse_ctx_create(m, ds, &ctx, &err) || mgs_strategy_morse_create(&o->adc, ctx, &s, &err) ||
      mgs_trainer_create(ds, o, g, s, &t, &err) || mgs_term_topo_create(ctx, 0, &term, &err) ||
      mgs_trainer_add_term(t, term, &err)) {
    fprintf(stderr, "%s\n", err.msg);
    exit(2);
  }
  *ctx_out = ctx;
  return t;
}

static int same_model(const mgs_gaussians *a, const mgs_gaussians *b) {
  if (a->n != b->n) { fprintf(stderr, "counts differ: %zu vs %zu\n", a->n, b->n); return 0; }
  for (int k = 0; k < MGS_PARAM_COUNT; k++) {
    size_t bytes = a->n * (size_t)mgs_param_dim((mgs_param_group)k) * sizeof(float);
    if (memcmp(mgs_gaussians_group((mgs_gaussians *)a, (mgs_param_group)k), mgs_gaussians_group((mgs_gaussians *)b, (mgs_param_group)k), bytes)) {
      fprintf(stderr, "group %s differs\n", mgs_param_name((mgs_param_group)k));
      return 0;
    }
  }
  return 1;
}

static void resume_identity(void) {
  mgs_train_options o;
  mgs_morse_options m;
  small_options(&o, &m, 200);
  mgs_error err;
  mgs_morse_ctx *ca, *cb, *cc;
  mgs_trainer *a = make(&o, &m, &ca);
  mgs_morse_ctx_set_csv(ca, csv);
  CHECK_OK(mgs_trainer_run(a, &err), &err);
  CHECK(mgs_morse_ctx_analyses(ca) == 3); /* 60, 120, 180 */
  const mgs_morse_result *r = mgs_morse_ctx_result(ca);
  CHECK(r->iteration == 180);
  CHECK(r->n > 0);
  double terms[1] = {0};
  CHECK(mgs_trainer_term_values(a, terms, 1) == 1);
  /* L_topo acted: a positive weighted value on short bars of the last pairing (a term that
     never ran reports exactly 0) */
  CHECK_MSG(terms[0] > 0 && isfinite(terms[0]), "L_topo value %g", terms[0]);
  fprintf(stderr, "uninterrupted: %zu Gaussians, %zu analyses, %.2f s of analysis in %.2f s\n", mgs_trainer_model(a)->n,
          mgs_morse_ctx_analyses(ca), mgs_morse_ctx_seconds(ca), mgs_trainer_seconds(a));
  CHECK_OK(mgs_morse_ctx_flush_csv(ca, &err), &err);
  char *text = NULL;
  size_t len = 0;
  CHECK_OK(mgs_read_file(csv, &text, &len, &err), &err);
  int lines = 0;
  for (size_t i = 0; text && i < len; i++) lines += text[i] == '\n';
  CHECK(lines == 4); /* header + 3 analyses */
  CHECK(text && !strncmp(text, "iteration,s_alpha", 17));
  free(text);

  /* interrupted at 150 (between the analyses at 120 and 180) */
  mgs_trainer *b = make(&o, &m, &cb);
  CHECK_OK(mgs_trainer_run_until(b, 150, &err), &err);
  CHECK_OK(mgs_trainer_save_checkpoint(b, ck, &err), &err);
  /* the SDF grid of the last analysis (what the normal loss samples) comes back too */
  const float probe[6] = {0.1f, 0.2f, 0.3f, -0.4f, 0.05f, 0.6f};
  float before[2] = {0, 0}, after[2] = {1, 1};
  size_t vox = 0;
  CHECK(mgs_morse_ctx_sdf(cb) != NULL);
  if (mgs_morse_ctx_sdf(cb)) {
    mgs_vdb_sample(mgs_morse_ctx_sdf(cb), 2, probe, before);
    vox = mgs_vdb_grid_active_voxel_count(mgs_morse_ctx_sdf(cb));
  }
  mgs_trainer_destroy(b);
  mgs_morse_ctx_unref(cb);
  mgs_trainer *c = make(&o, &m, &cc);
  CHECK_OK(mgs_trainer_load_checkpoint(c, ck, &err), &err);
  CHECK(mgs_morse_ctx_result(cc)->iteration == 120);
  CHECK(mgs_morse_ctx_sdf(cc) != NULL);
  if (mgs_morse_ctx_sdf(cc)) {
    mgs_vdb_sample(mgs_morse_ctx_sdf(cc), 2, probe, after);
    CHECK(mgs_vdb_grid_active_voxel_count(mgs_morse_ctx_sdf(cc)) == vox);
    CHECK(before[0] == after[0] && before[1] == after[1]);
  }
  CHECK_OK(mgs_trainer_run(c, &err), &err);
  CHECK(same_model(mgs_trainer_model(a), mgs_trainer_model(c)));
  mgs_trainer_destroy(a); mgs_trainer_destroy(c);
  mgs_morse_ctx_unref(ca); mgs_morse_ctx_unref(cc);
}

int main(void) {
  mgs_parallel_set_threads(1);
  mgs_log_set_level(MGS_LOG_WARN);
  const char *tmp = mgs_test_tmpdir("morse_resume");
  snprintf(ck, sizeof ck, "%s/ck.mgsckpt", tmp);
  snprintf(csv, sizeof csv, "%s/morse.csv", tmp);
  remove(csv);
  mgs_gaussians *gt = synth_model(40, 7);
  ds = synth_dataset(gt, 8, 0, 48, 40);
  RUN(resume_identity);
  mgs_dataset_destroy(ds);
  mgs_gaussians_destroy(gt);
  return mgs_test_finish();
}

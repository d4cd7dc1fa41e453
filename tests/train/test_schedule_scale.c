/* --schedule-scale: every iteration milestone of every strategy, loss term and learning-
 * rate schedule, as the layers' options are built from a config (train/config.c), is the
 * reference's times s (rounded; periods at least 1); nothing else changes; the value is
 * recorded in cfg_args. */
#include <math.h>
#include <string.h>
#include "mgs_test.h"
#include "train/mgs_config.h"

static int scaled(int v, double s) {
  if (v <= 0) return v;
  double r = floor(v * s + 0.5);
  return r < 1 ? 1 : (int)r;
}

static void parse(mgs_train_config *c, const char *strategy, const char *scale, const char *extra) {
  char *argv[16];
  int argc = 0;
  argv[argc++] = "train";
  argv[argc++] = "data";
  argv[argc++] = "-o";
  argv[argc++] = "/nonexistent/run";
  argv[argc++] = "--strategy";
  argv[argc++] = (char *)strategy;
  argv[argc++] = "--schedule-scale";
  argv[argc++] = (char *)scale;
  argv[argc++] = "--pers-loss";
  argv[argc++] = "1";
  argv[argc++] = "--normal-loss";
  argv[argc++] = "0.02";
  if (extra) argv[argc++] = (char *)extra;
  const char *data = NULL;
  mgs_error err;
  CHECK_OK(mgs_config_parse(c, argc, argv, &data, &err), &err);
}

/* The milestones of one config, in a fixed order (the list the test compares). */
static int milestones(const mgs_train_config *c, int *m) {
  int k = 0;
  mgs_train_options o;
  mgs_config_train_options(c, &o);
  m[k++] = o.sh_every;
  m[k++] = o.lr_mean_max_steps;
  m[k++] = o.adc.densify_from;
  m[k++] = o.adc.densify_until;
  m[k++] = o.adc.densify_every;
  m[k++] = o.adc.opacity_reset_every;
  mgs_morse_options mo;
  mgs_config_morse_options(c, &mo);
  m[k++] = mo.warmup;
  m[k++] = mo.every;
  m[k++] = mo.until;
  mgs_persloss_options po;
  CHECK(mgs_config_persloss_options(c, &po) == 1);
  m[k++] = po.from;
  m[k++] = po.until;
  m[k++] = po.every;
  mgs_normal_options no;
  CHECK(mgs_config_normal_options(c, &no) == 1);
  m[k++] = no.from_iter;
  m[k++] = no.every;
  mgs_minisplat_options so;
  mgs_config_minisplat_options(c, &so);
  m[k++] = so.reinit_every;
  m[k++] = so.simplify1;
  m[k++] = so.simplify2;
  m[k++] = so.lr_restart;
  m[k++] = so.adc.densify_from;
  m[k++] = so.adc.densify_until;
  m[k++] = so.adc.densify_every;
  return k;
}

static void every_strategy(void) {
  static const char *strategies[] = {"adc", "morse", "none", "mini-splatting", "mini-splatting-d"};
  for (size_t si = 0; si < sizeof strategies / sizeof strategies[0]; si++) {
    mgs_train_config ref, q;
    /* --iters 60000: the normal loss keeps its start (it moves it into the second half of
       shorter runs, a rule of its own) */
    parse(&ref, strategies[si], "1", "--iters=60000");
    parse(&q, strategies[si], "0.25", "--iters=60000");
    int a[32], b[32];
    int na = milestones(&ref, a), nb = milestones(&q, b);
    CHECK(na == nb && na == 21);
    for (int i = 0; i < na; i++)
      CHECK_MSG(b[i] == scaled(a[i], 0.25), "%s: milestone %d: %d at s = 0.25, reference %d", strategies[si], i, b[i],
                a[i]);
    /* the reference values are the published ones (not a scale applied twice or never) */
    CHECK(a[0] == 1000 && a[1] == 30000 && a[2] == 500 && a[3] == 15000 && a[4] == 100 && a[5] == 3000);
    CHECK(a[6] == 3000 && a[7] == 500 && a[9] == 1500 && a[10] == 15000 && a[11] == 200 && a[12] == 3000);
    CHECK(a[14] == 5000 && a[16] == 20000 && a[17] == 5000);
    CHECK(b[0] == 250 && b[1] == 7500 && b[2] == 125 && b[3] == 3750 && b[4] == 25 && b[5] == 750);
    CHECK(b[14] == 1250 && b[15] == 3750 && b[16] == 5000);
    /* what is not a milestone stays */
    mgs_train_options oa, ob;
    mgs_config_train_options(&ref, &oa);
    mgs_config_train_options(&q, &ob);
    CHECK(oa.iterations == ob.iterations && oa.lr_mean_init == ob.lr_mean_init && oa.adc.grad_threshold == ob.adc.grad_threshold);
  }
  /* tiny scales keep periods at least 1 */
  mgs_train_config t;
  parse(&t, "adc", "0.0001", NULL);
  mgs_train_options o;
  mgs_config_train_options(&t, &o);
  CHECK(o.adc.densify_every == 1 && o.sh_every == 1 && o.adc.densify_from == 1);
  /* 0 (off) stays off */
  parse(&t, "adc", "0.5", "--opacity-reset-every=0");
  mgs_config_train_options(&t, &o);
  CHECK(o.adc.opacity_reset_every == 0);
}

/* the compressed schedule waits the reference's 100 iterations after a reset before
   pruning transparent Gaussians; the reference schedule does not need to */
static void reset_prune_wait(void) {
  mgs_train_config c;
  mgs_train_options o;
  parse(&c, "adc", "0.1", NULL);
  mgs_config_train_options(&c, &o);
  CHECK(o.adc.reset_prune_wait == 100 && o.adc.densify_every == 10);
  parse(&c, "adc", "1", NULL);
  mgs_config_train_options(&c, &o);
  CHECK(o.adc.reset_prune_wait == 0);
}

static void recorded(void) {
  mgs_train_config c;
  parse(&c, "mini-splatting", "0.25", NULL);
  mgs_settings s;
  memset(&s, 0, sizeof s);
  mgs_config_record(&c, &s);
  const char *v = mgs_settings_get(&s, "schedule_scale");
  CHECK(v && atof(v) == 0.25);
  v = mgs_settings_get(&s, "strategy");
  CHECK(v && !strcmp(v, "mini-splatting"));
  mgs_settings_free(&s);
  /* out of range: refused naming the flag */
  mgs_train_config d;
  mgs_config_defaults(&d);
  mgs_error err;
  CHECK(mgs_config_set(&d, "schedule-scale", "0", MGS_CFG_TYPED, &err) == MGS_ERR_ARG);
  CHECK(strstr(err.msg, "schedule-scale") != NULL);
  /* under --mpi on several processes Mini-Splatting is refused with the reason */
  mgs_config_defaults(&d);
  CHECK_OK(mgs_config_set(&d, "strategy", "mini-splatting", MGS_CFG_TYPED, &err), &err);
  CHECK(mgs_config_validate(&d, 4, &err) == MGS_ERR_ARG);
  CHECK(strstr(err.msg, "mini-splatting") && strstr(err.msg, "every training view"));
  mgs_config_defaults(&d);
  CHECK_OK(mgs_config_set(&d, "schedule-scale", "0.25", MGS_CFG_TYPED, &err), &err);
  CHECK_OK(mgs_config_validate(&d, 4, &err), &err); /* honoured by --mpi */
}

int main(void) {
  RUN(every_strategy);
  RUN(recorded);
  RUN(reset_prune_wait);
  return mgs_test_finish();
}

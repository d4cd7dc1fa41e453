/* The option table (train/mgs_config.h): every default parses and agrees with the layer's
 * own default, every result-changing option reaches cfg_args under a unique key and comes
 * back from it, a resume that contradicts the record is refused naming both values, presets
 * are rows of values under what was typed, --mpi on several processes refuses what it does
 * not honour, and --help lists every option once. */
#include "mgs_test.h"
#include "train/mgs_config.h"

static mgs_status parse(mgs_train_config *c, const char *line, const char **data, mgs_error *err) {
  char buf[2048], *argv[64];
  int argc = 0;
  snprintf(buf, sizeof buf, "train %s", line);
  for (char *p = strtok(buf, " "); p && argc < 63; p = strtok(NULL, " ")) argv[argc++] = p;
  argv[argc] = NULL;
  return mgs_config_parse(c, argc, argv, data, err);
}

static void table_is_sound(void) {
  size_t n;
  const mgs_option *t = mgs_config_options(&n);
  CHECK(n > 60 && n < sizeof(((mgs_train_config *)0)->source));
  mgs_train_config c;
  for (size_t i = 0; i < n; i++) {
    mgs_error err;
    memset(&c, 0, sizeof c);
    CHECK_MSG(mgs_config_set(&c, t[i].name, t[i].def, MGS_CFG_DEFAULT, &err) == MGS_OK, "--%s default '%s': %s", t[i].name, t[i].def, err.msg);
    CHECK_MSG(t[i].help && t[i].help[0], "--%s has no help", t[i].name);
    CHECK_MSG((t[i].flags & MGS_OPT_MPI) || t[i].mpi_reason, "--%s: refused under --mpi without a reason", t[i].name);
    CHECK_MSG(!(t[i].flags & MGS_OPT_RECORDED) || t[i].key, "--%s recorded without a key", t[i].name);
    for (size_t j = 0; j < i; j++) {
      CHECK_MSG(strcmp(t[i].name, t[j].name), "--%s twice", t[i].name);
      CHECK_MSG(!t[i].key || !t[j].key || strcmp(t[i].key, t[j].key), "key %s twice", t[i].key);
    }
  }
}

/* The table's defaults are the layers' own (no drift between them). */
static void defaults_agree(void) {
  mgs_train_config c;
  mgs_config_defaults(&c);
  mgs_train_options o, d;
  mgs_config_train_options(&c, &o);
  mgs_train_options_default(&d);
  CHECK(o.iterations == d.iterations && o.sh_degree == d.sh_degree && o.sh_every == d.sh_every);
  CHECK(o.lr_mean_max_steps == d.lr_mean_max_steps && o.seed == d.seed);
  CHECK_NEAR(c.position_lr_init, d.lr_mean_init, 1e-12);
  CHECK_NEAR(c.position_lr_final, d.lr_mean_final, 1e-14);
  CHECK_NEAR(c.feature_lr, d.lr_sh_dc, 1e-9);
  CHECK_NEAR(c.feature_rest_lr, d.lr_sh_rest, 1e-9);
  CHECK_NEAR(c.opacity_lr, d.lr_opacity, 1e-9);
  CHECK_NEAR(c.scaling_lr, d.lr_log_scale, 1e-9);
  CHECK_NEAR(c.rotation_lr, d.lr_rot, 1e-9);
  CHECK_NEAR(c.lambda_dssim, d.lambda_dssim, 1e-7);
  CHECK(memcmp(&o.adc, &d.adc, sizeof o.adc) == 0); /* bit for bit, floats included */
  CHECK_NEAR(c.grad_threshold, d.adc.grad_threshold, 1e-9);
  CHECK_NEAR(c.percent_dense, d.adc.percent_dense, 1e-9);
  CHECK_NEAR(c.min_opacity, d.adc.min_opacity, 1e-9);
  CHECK_NEAR(c.max_screen_size, d.adc.max_screen_px, 1e-9);
  CHECK(c.densify_from == d.adc.densify_from && c.densify_until == d.adc.densify_until &&
        c.densify_every == d.adc.densify_every && c.opacity_reset_every == d.adc.opacity_reset_every);
  mgs_morse_options m, md;
  mgs_config_morse_options(&c, &m);
  mgs_morse_options_default(&md);
  CHECK(memcmp(&m, &md, sizeof m) == 0);
  mgs_lpvi_options l, ld;
  mgs_config_lpvi_options(&c, &l);
  mgs_lpvi_options_default(&ld);
  CHECK(l.faithful == ld.faithful && l.k_max == ld.k_max && l.k_min == ld.k_min && l.tau == ld.tau &&
        l.max_edge == ld.max_edge && l.extent == ld.extent);
  mgs_persloss_options p, pd;
  CHECK(mgs_config_persloss_options(&c, &p) == 0); /* off by default */
  mgs_persloss_options_default(&pd);
  CHECK(p.form == pd.form && p.from == pd.from && p.until == pd.until && p.every == pd.every &&
        p.downsample == pd.downsample && !memcmp(p.k, pd.k, sizeof p.k));
  mgs_normal_options no;
  CHECK(mgs_config_normal_options(&c, &no) == 0);
  /* bit for bit: a fresh run keeps the layer's default where nothing was typed, a resume
     takes the recorded table value (an ulp between them made resumes differ once SH rest
     was stepped) */
  mgs_settings s;
  mgs_settings_init(&s);
  mgs_config_record(&c, &s);
  mgs_train_config r;
  mgs_config_defaults(&r);
  mgs_error err;
  CHECK_OK(mgs_config_restore(&r, &s, "RUN/cfg_args", &err), &err);
  mgs_settings_free(&s);
  mgs_train_options ro;
  mgs_config_train_options(&r, &ro);
  static const char *const names[] = {"lambda-dssim", "position-lr-init", "position-lr-final", "feature-lr",
                                      "feature-rest-lr", "opacity-lr", "scaling-lr", "rotation-lr"};
  const double fresh[] = {d.lambda_dssim, d.lr_mean_init, d.lr_mean_final, d.lr_sh_dc, d.lr_sh_rest, d.lr_opacity, d.lr_log_scale, d.lr_rot};
  const double resumed[] = {ro.lambda_dssim, ro.lr_mean_init, ro.lr_mean_final, ro.lr_sh_dc, ro.lr_sh_rest, ro.lr_opacity,
                            ro.lr_log_scale, ro.lr_rot};
  for (size_t k = 0; k < sizeof names / sizeof names[0]; k++)
    CHECK_MSG(fresh[k] == resumed[k], "--%s: default %.17g, from the record %.17g", names[k], fresh[k], resumed[k]);
  CHECK(memcmp(&ro.adc, &d.adc, sizeof ro.adc) == 0);
}

static void parsing(void) {
  mgs_train_config c;
  const char *data;
  mgs_error err;
  CHECK_OK(parse(&c, "DATA -o RUN --iters 500 --dense-adam --view-order locality --white --normal-loss", &data, &err), &err);
  CHECK(data && !strcmp(data, "DATA") && !strcmp(c.output, "RUN"));
  CHECK(c.iters == 500 && c.adam == MGS_ADAM_DENSE && c.view_locality == 1 && c.background == MGS_BG_WHITE);
  CHECK_NEAR(c.normal_loss, 0.02, 1e-12);
  /* an optional value is taken only when the next word is one */
  CHECK_OK(parse(&c, "-o RUN --topo-loss DATA", &data, &err), &err);
  CHECK(c.topo_loss == MGS_TOPO_ELIMINATE && data && !strcmp(data, "DATA"));
  CHECK_OK(parse(&c, "-o RUN --normal-loss 0.05 DATA --topo-loss=literal", &data, &err), &err);
  CHECK_NEAR(c.normal_loss, 0.05, 1e-12);
  CHECK(c.topo_loss == MGS_TOPO_LITERAL);
  /* presets are rows under what was typed, wherever the preset stands */
  CHECK_OK(parse(&c, "DATA -o RUN --normal-loss 0.03 --preset morse-full", &data, &err), &err);
  CHECK(c.strategy == MGS_STRAT_MORSE && c.init == MGS_INIT_LEVELSET && c.topo_loss == MGS_TOPO_ELIMINATE);
  CHECK_NEAR(c.normal_loss, 0.03, 1e-12);
  CHECK(c.spawn == MGS_SPAWN_GAPS && c.prune == MGS_PRUNE_FLOATERS);
  CHECK_OK(parse(&c, "DATA -o RUN --preset morse-d --literal", &data, &err), &err);
  CHECK(c.spawn == MGS_SPAWN_LITERAL && c.prune == MGS_PRUNE_LITERAL && c.topo_loss == MGS_TOPO_NONE);
  CHECK_OK(parse(&c, "DATA -o RUN --preset morse-r --literal", &data, &err), &err);
  CHECK(c.topo_loss == MGS_TOPO_LITERAL && c.strategy == MGS_STRAT_ADC && c.spawn == MGS_SPAWN_NONE);
  CHECK_OK(parse(&c, "DATA -o RUN --preset topology-gs --init sfm", &data, &err), &err);
  CHECK(c.init == MGS_INIT_SFM && c.pers_loss == 10);
  CHECK_OK(parse(&c, "DATA -o RUN --downscale 2", &data, &err), &err);
  CHECK(c.max_width == 0); /* a resolution given: no width cap, as the reference */
  /* one-line errors naming the flag */
  CHECK(parse(&c, "DATA -o RUN --iters 0", &data, &err) == MGS_ERR_ARG && strstr(err.msg, "--iters"));
  CHECK(parse(&c, "DATA -o RUN --visibility maybe", &data, &err) == MGS_ERR_ARG && strstr(err.msg, "auto|on|off"));
  CHECK(parse(&c, "DATA -o RUN --bogus", &data, &err) == MGS_ERR_ARG && strstr(err.msg, "--bogus"));
  CHECK(parse(&c, "DATA -o RUN --white=1", &data, &err) == MGS_ERR_ARG);
  CHECK(parse(&c, "DATA OTHER -o RUN", &data, &err) == MGS_ERR_ARG && strstr(err.msg, "OTHER"));
  CHECK(parse(&c, "DATA --iters", &data, &err) == MGS_ERR_ARG && strstr(err.msg, "needs a value"));
  CHECK(parse(&c, "DATA", &data, &err) == MGS_ERR_ARG && strstr(err.msg, "-o RUN"));
  CHECK(parse(&c, "DATA -o R --seed -3", &data, &err) == MGS_ERR_ARG);
  CHECK(parse(&c, "DATA -o R --pers-loss-schedule 10,5,1", &data, &err) == MGS_ERR_ARG);
  CHECK(parse(&c, "DATA -o R --topo-dims 3", &data, &err) == MGS_ERR_ARG);
}

static void validation(void) {
  mgs_train_config c;
  const char *data;
  mgs_error err;
  CHECK_OK(parse(&c, "DATA -o RUN --morse-every 100", &data, &err), &err);
  CHECK_OK(mgs_config_validate(&c, 1, &err), &err); /* read by nothing: a warning */
  CHECK_OK(parse(&c, "DATA -o RUN --spawn gaps", &data, &err), &err);
  CHECK(mgs_config_validate(&c, 1, &err) == MGS_ERR_ARG && strstr(err.msg, "--strategy morse"));
  CHECK_OK(parse(&c, "DATA -o RUN --preset morse-d --iters 1000", &data, &err), &err);
  CHECK(mgs_config_validate(&c, 1, &err) == MGS_ERR_ARG && strstr(err.msg, "--morse-warmup")); /* W 3000 >= 1000 */
  CHECK_OK(parse(&c, "DATA -o RUN --resume --force", &data, &err), &err);
  CHECK(mgs_config_validate(&c, 1, &err) == MGS_ERR_ARG);
  /* Mini-Splatting runs on surfels (the 2DGS blending statistics); SuGaR is refused there
     with the reason */
  CHECK_OK(parse(&c, "DATA -o RUN --model 2dgs --strategy mini-splatting", &data, &err), &err);
  CHECK_OK(mgs_config_validate(&c, 1, &err), &err);
  CHECK_OK(parse(&c, "DATA -o RUN --model 2dgs --strategy mini-splatting-d", &data, &err), &err);
  CHECK_OK(mgs_config_validate(&c, 1, &err), &err);
  CHECK_OK(parse(&c, "DATA -o RUN --model 2dgs --preset sugar", &data, &err), &err);
  CHECK(mgs_config_validate(&c, 1, &err) == MGS_ERR_ARG && strstr(err.msg, "--strategy sugar: not with --model 2dgs"));
  CHECK_OK(parse(&c, "DATA -o RUN --model 2dgs --preset morse-r", &data, &err), &err);
  CHECK_OK(mgs_config_validate(&c, 1, &err), &err); /* MorseGS' loss sits on 2DGS */
  CHECK_OK(parse(&c, "DATA -o RUN --ghosts average", &data, &err), &err);
  CHECK(mgs_config_validate(&c, 1, &err) == MGS_ERR_ARG && strstr(err.msg, "--mpi"));
  /* several processes: what the distributed trainer honours, and a reason for the rest */
  CHECK_OK(parse(&c, "DATA -o RUN --mpi --threads 1 --dense-adam --grad-threshold 0.0004 --ghosts average", &data, &err), &err);
  CHECK_OK(mgs_config_validate(&c, 2, &err), &err);
  CHECK_OK(parse(&c, "DATA -o RUN --mpi --topo-loss", &data, &err), &err);
  CHECK(mgs_config_validate(&c, 2, &err) == MGS_ERR_ARG && strstr(err.msg, "--topo-loss") && strstr(err.msg, "not with --mpi"));
  CHECK_OK(parse(&c, "DATA -o RUN --mpi --preset morse-d", &data, &err), &err);
  CHECK(mgs_config_validate(&c, 2, &err) == MGS_ERR_ARG);
}

/* Every recorded option is in the record and comes back from it; a contradicting typed
   value is refused naming both values; --iters may change. */
static void record_and_resume(void) {
  mgs_train_config c, r;
  const char *data;
  mgs_error err;
  CHECK_OK(parse(&c, "DATA -o RUN --dense-adam --view-order locality --visibility on --image-cache-mb 1 --seed 7 "
                     "--preset morse-r --beta 0.005 --pers-loss 3 --grad-threshold 0.00031", &data, &err), &err);
  mgs_settings s;
  mgs_settings_init(&s);
  mgs_config_record(&c, &s);
  size_t n;
  const mgs_option *t = mgs_config_options(&n);
  for (size_t i = 0; i < n; i++)
    if (t[i].flags & MGS_OPT_RECORDED) CHECK_MSG(mgs_settings_get(&s, t[i].key), "--%s (%s) not recorded", t[i].name, t[i].key);
  CHECK(!strcmp(mgs_settings_get(&s, "adam"), "dense") && !strcmp(mgs_settings_get(&s, "view_order"), "locality"));
  CHECK(!strcmp(mgs_settings_get(&s, "visibility"), "on") && !strcmp(mgs_settings_get(&s, "image_cache_mb"), "1"));
  /* the record restores every value into a config parsed from a bare --resume */
  CHECK_OK(parse(&r, "DATA -o RUN --resume --iters 40000", &data, &err), &err);
  CHECK_OK(mgs_config_restore(&r, &s, "RUN/cfg_args", &err), &err);
  for (size_t i = 0; i < n; i++) {
    if (!(t[i].flags & MGS_OPT_RECORDED) || (t[i].flags & MGS_OPT_CHANGEABLE)) continue;
    char a[256], b[256];
    mgs_config_format(&c, &t[i], a, sizeof a);
    mgs_config_format(&r, &t[i], b, sizeof b);
    CHECK_MSG(!strcmp(a, b), "--%s: recorded %s, restored %s", t[i].name, a, b);
  }
  CHECK(r.iters == 40000 && r.adam == MGS_ADAM_DENSE && r.seed == 7);
  /* contradictions */
  CHECK_OK(parse(&r, "DATA -o RUN --resume --sparse-adam", &data, &err), &err);
  CHECK(mgs_config_restore(&r, &s, "RUN/cfg_args", &err) == MGS_ERR_ARG && strstr(err.msg, "--adam sparse") &&
        strstr(err.msg, "adam = dense") && strstr(err.msg, "RUN/cfg_args"));
  CHECK_OK(parse(&r, "DATA -o RUN --resume --grad-threshold 0.0002", &data, &err), &err);
  CHECK(mgs_config_restore(&r, &s, "RUN/cfg_args", &err) == MGS_ERR_ARG && strstr(err.msg, "0.00031"));
  /* the same value typed again is no contradiction */
  CHECK_OK(parse(&r, "DATA -o RUN --resume --view-order locality --seed 7", &data, &err), &err);
  CHECK_OK(mgs_config_restore(&r, &s, "RUN/cfg_args", &err), &err);
  /* a broken record names the file and the key */
  mgs_settings_set(&s, "densify_from_iter", "soon", 0);
  CHECK_OK(parse(&r, "DATA -o RUN --resume", &data, &err), &err);
  CHECK(mgs_config_restore(&r, &s, "RUN/cfg_args", &err) == MGS_ERR_FORMAT && strstr(err.msg, "densify_from_iter"));
  mgs_settings_free(&s);
}

static void help_lists_each_once(void) {
  char *text = NULL;
  size_t len = 0;
  FILE *f = open_memstream(&text, &len);
  mgs_config_usage(f);
  fclose(f);
  size_t n;
  const mgs_option *t = mgs_config_options(&n);
  for (size_t i = 0; i < n; i++) {
    char flag[80];
    snprintf(flag, sizeof flag, "    --%s ", t[i].name);
    char *at = strstr(text, flag);
    if (!at) { snprintf(flag, sizeof flag, "    --%s[", t[i].name); at = strstr(text, flag); }
    CHECK_MSG(at != NULL, "--%s not in --help", t[i].name);
    CHECK_MSG(!at || !strstr(at + 1, flag), "--%s twice in --help", t[i].name);
  }
  free(text);
}

int main(void) {
  RUN(table_is_sound);
  RUN(defaults_agree);
  RUN(parsing);
  RUN(validation);
  RUN(record_and_resume);
  RUN(help_lists_each_once);
  return mgs_test_finish();
}

/* Topology-GS's flags of `morsegs train` (apps/mgs_train_topogs.h). */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "apps/mgs_train_topogs.h"
#include "core/mgs_core.h"
#include "train/mgs_term.h"
#include "train/mgs_train.h"

enum { G_PRESET = 1, G_FAITHFUL = 2, G_TAU = 4, G_EDGE = 8, G_PERS = 16, G_FORM = 32, G_DOWN = 64, G_K = 128, G_SCHED = 256 };

void mgs_topogs_flags_init(mgs_topogs_flags *f) {
  memset(f, 0, sizeof *f);
  mgs_lpvi_options_default(&f->lpvi);
  mgs_persloss_options_default(&f->pl);
}

static int bad(const char *flag, const char *v, const char *want) {
  fprintf(stderr, "morsegs train: %s needs %s (got '%s')\n", flag, want, v ? v : "nothing");
  return 2;
}

static int parse_num(const char *s, double *out) {
  char *end;
  if (!s || !*s) return 0;
  double v = strtod(s, &end);
  if (*end || !isfinite(v)) return 0;
  *out = v;
  return 1;
}

/* "a,b,c" of integers >= lo */
static int parse_ints3(const char *s, int lo, int out[3]) {
  if (!s) return 0;
  const char *p = s;
  for (int i = 0; i < 3; i++) {
    char *end;
    long v = strtol(p, &end, 10);
    if (end == p || v < lo || v > 100000000) return 0;
    out[i] = (int)v;
    if (i < 2) { if (*end != ',') return 0; p = end + 1; }
    else if (*end) return 0;
  }
  return 1;
}

/* Matches "--name" or "--name=value"; *val gets the inline value or NULL. */
static int match(const char *arg, const char *name, const char **val) {
  size_t n = strlen(name);
  if (strncmp(arg, name, n)) return 0;
  if (arg[n] == 0) { *val = NULL; return 1; }
  if (arg[n] == '=') { *val = arg + n + 1; return 1; }
  return 0;
}

int mgs_topogs_flags_extract(int *argc, char **argv, mgs_topogs_flags *f) {
  int out = 1;
  for (int i = 1; i < *argc; i++) {
    const char *a = argv[i], *v = NULL;
    int take_next = 0; /* the value is the next argument */
#define VALUE() (v ? v : (i + 1 < *argc ? (take_next = 1, argv[i + 1]) : NULL))
    if (!strcmp(a, "--")) { /* the rest is positional */
      for (; i < *argc; i++) argv[out++] = argv[i];
      break;
    }
    if (match(a, "--preset", &v)) {
      const char *p = v ? v : (i + 1 < *argc ? argv[i + 1] : NULL);
      if (!p || strcmp(p, "topology-gs")) { argv[out++] = argv[i]; continue; } /* cmd_train.c's presets */
      if (!v) i++;
      f->preset = 1; f->pers = 1; f->given |= G_PRESET | G_PERS;
      continue;
    }
    if (match(a, "--lpvi-faithful", &v) && !v) { f->lpvi.faithful = 1; f->given |= G_FAITHFUL; continue; }
    if (match(a, "--lpvi-tau", &v)) {
      const char *s = VALUE();
      if (!parse_num(s, &f->lpvi.tau) || f->lpvi.tau < 0) return bad("--lpvi-tau", s, "a number >= 0");
      f->given |= G_TAU; i += take_next; continue;
    }
    if (match(a, "--lpvi-max-edge", &v)) {
      const char *s = VALUE();
      if (!parse_num(s, &f->lpvi.max_edge) || !(f->lpvi.max_edge > 0)) return bad("--lpvi-max-edge", s, "a number > 0");
      f->given |= G_EDGE; i += take_next; continue;
    }
    if (match(a, "--pers-loss", &v)) {
      /* optional weight: inline, or the next argument when it is a number */
      double w;
      if (v) { if (!parse_num(v, &w) || w < 0) return bad("--pers-loss", v, "a weight >= 0"); f->pl.lambda = w; }
      else if (i + 1 < *argc && parse_num(argv[i + 1], &w)) {
        if (w < 0) return bad("--pers-loss", argv[i + 1], "a weight >= 0");
        f->pl.lambda = w; i++;
      }
      f->pers = 1; f->given |= G_PERS; continue;
    }
    if (match(a, "--pers-loss-form", &v)) {
      const char *s = VALUE();
      if (s && !strcmp(s, "topk")) f->pl.form = MGS_PERSLOSS_TOPK;
      else if (s && !strcmp(s, "betti")) f->pl.form = MGS_PERSLOSS_BETTI;
      else return bad("--pers-loss-form", s, "topk or betti");
      f->given |= G_FORM; i += take_next; continue;
    }
    if (match(a, "--pers-loss-downsample", &v)) {
      const char *s = VALUE();
      if (!parse_num(s, &f->pl.downsample) || !(f->pl.downsample > 0 && f->pl.downsample <= 1)) return bad("--pers-loss-downsample", s, "a factor in (0, 1]");
      f->given |= G_DOWN; i += take_next; continue;
    }
    if (match(a, "--pers-loss-k", &v)) {
      const char *s = VALUE();
      if (!parse_ints3(s, 0, f->pl.k)) return bad("--pers-loss-k", s, "K0,K1,K2 (integers >= 0)");
      f->given |= G_K; i += take_next; continue;
    }
    if (match(a, "--pers-loss-schedule", &v)) {
      const char *s = VALUE();
      int t[3];
      if (!parse_ints3(s, 0, t) || t[1] < t[0] || t[2] < 1) return bad("--pers-loss-schedule", s, "FROM,UNTIL,EVERY (0 <= FROM <= UNTIL, EVERY >= 1)");
      f->pl.from = t[0]; f->pl.until = t[1]; f->pl.every = t[2];
      f->given |= G_SCHED; i += take_next; continue;
    }
#undef VALUE
    argv[out++] = argv[i];
  }
  *argc = out;
  argv[out] = NULL;
  return 0;
}

const char *mgs_topogs_init(const mgs_topogs_flags *f, const char *init, int init_given) {
  const char *use = f->preset && !init_given ? "lpvi" : init;
  if ((f->given & (G_FAITHFUL | G_TAU | G_EDGE)) && strcmp(use, "lpvi"))
    mgs_warn("--lpvi-faithful/--lpvi-tau/--lpvi-max-edge have no effect without --init lpvi (init is %s)", use);
  return use;
}

void mgs_topogs_flags_restore(mgs_topogs_flags *f, const mgs_settings *prev) {
  const char *v;
  if (!(f->given & G_PRESET) && (v = mgs_settings_get(prev, "topogs_preset"))) f->preset = !strcmp(v, "True");
  if (!(f->given & G_FAITHFUL) && (v = mgs_settings_get(prev, "lpvi_faithful"))) f->lpvi.faithful = !strcmp(v, "True");
  if (!(f->given & G_TAU) && (v = mgs_settings_get(prev, "lpvi_tau"))) f->lpvi.tau = atof(v);
  if (!(f->given & G_EDGE) && (v = mgs_settings_get(prev, "lpvi_max_edge"))) f->lpvi.max_edge = atof(v);
  if (!(f->given & G_PERS) && (v = mgs_settings_get(prev, "pers_loss"))) {
    double w = atof(v);
    f->pers = w > 0;
    if (f->pers) f->pl.lambda = w;
  }
  if (!(f->given & G_FORM) && (v = mgs_settings_get(prev, "pers_loss_form"))) f->pl.form = !strcmp(v, "betti") ? MGS_PERSLOSS_BETTI : MGS_PERSLOSS_TOPK;
  if (!(f->given & G_DOWN) && (v = mgs_settings_get(prev, "pers_loss_downsample"))) f->pl.downsample = atof(v);
  if (!(f->given & G_K) && (v = mgs_settings_get(prev, "pers_loss_k"))) parse_ints3(v, 0, f->pl.k);
  if (!(f->given & G_SCHED) && (v = mgs_settings_get(prev, "pers_loss_schedule"))) {
    int t[3];
    if (parse_ints3(v, 0, t)) { f->pl.from = t[0]; f->pl.until = t[1]; f->pl.every = t[2]; }
  }
}

void mgs_topogs_flags_record(const mgs_topogs_flags *f, int lpvi_used, mgs_settings *s) {
  char buf[96];
  mgs_settings_set(s, "topogs_preset", f->preset ? "True" : "False", 0);
  if (lpvi_used) {
    mgs_settings_set(s, "lpvi_faithful", f->lpvi.faithful ? "True" : "False", 0);
    mgs_settings_setf(s, "lpvi_tau", f->lpvi.tau);
    mgs_settings_setf(s, "lpvi_max_edge", f->lpvi.max_edge);
    mgs_settings_seti(s, "lpvi_k_max", f->lpvi.k_max);
    mgs_settings_seti(s, "lpvi_k_min", f->lpvi.k_min);
  }
  mgs_settings_setf(s, "pers_loss", f->pers ? f->pl.lambda : 0.0);
  if (f->pers) {
    mgs_settings_set(s, "pers_loss_form", f->pl.form == MGS_PERSLOSS_BETTI ? "betti" : "topk", 1);
    mgs_settings_setf(s, "pers_loss_downsample", f->pl.downsample);
    snprintf(buf, sizeof buf, "%d,%d,%d", f->pl.k[0], f->pl.k[1], f->pl.k[2]);
    mgs_settings_set(s, "pers_loss_k", buf, 1);
    snprintf(buf, sizeof buf, "%d,%d,%d", f->pl.from, f->pl.until, f->pl.every);
    mgs_settings_set(s, "pers_loss_schedule", buf, 1);
  }
}

mgs_status mgs_topogs_init_model(mgs_topogs_flags *f, const mgs_dataset *ds, int sh_degree, uint64_t seed,
                                 int random_points, mgs_gaussians **out, mgs_error *err) {
  const float *xyz, *rgb;
  size_t n;
  float *tx = NULL, *tc = NULL;
  if (ds->init_points && ds->init_points->n > 0) {
    xyz = ds->init_points->xyz; rgb = ds->init_points->rgb; n = ds->init_points->n;
  } else {
    /* no SfM points: LPVI over the random init's points (the trainer's random init) */
    mgs_gaussians *r = NULL;
    mgs_status st = mgs_init_random_for_dataset(ds, (size_t)random_points, 0, seed, &r, err);
    if (st) return st;
    n = r->n;
    tx = malloc(3 * n * sizeof *tx);
    tc = malloc(3 * n * sizeof *tc);
    if (!tx || !tc) { free(tx); free(tc); mgs_gaussians_destroy(r); return mgs_error_set(err, MGS_ERR_NOMEM, "LPVI: out of memory"); }
    for (size_t i = 0; i < 3 * n; i++) { tx[i] = r->mean[i]; tc[i] = r->sh_dc[i] * MGS_SH_C0 + 0.5f; }
    mgs_gaussians_destroy(r);
    xyz = tx; rgb = tc;
    mgs_info("--init lpvi: the dataset has no initial points; LPVI over %zu random points", n);
  }
  f->lpvi.extent = ds->extent;
  float *ox = NULL, *oc = NULL;
  size_t on = 0;
  mgs_lpvi_stats s;
  mgs_status st = mgs_init_lpvi(xyz, rgb, n, &f->lpvi, &ox, &oc, &on, &s, err);
  free(tx); free(tc);
  if (st) return st;
  mgs_info("LPVI (%s): %zu points in, %zu neighbourhoods (%zu accepted in 3-D, %zu tangent), %zu points added, %zu out, %.2f s",
           f->lpvi.faithful ? "faithful" : "corrected", s.input, s.processed, s.accepted_3d, s.tangent_2d, s.added, on, s.seconds);
  st = mgs_init_from_points(ox, oc, on, sh_degree, out, err);
  free(ox); free(oc);
  return st;
}

mgs_status mgs_topogs_add_terms(const mgs_topogs_flags *f, mgs_trainer *t, mgs_error *err) {
  if (!f->pers) return MGS_OK;
  mgs_term *term = NULL;
  mgs_status st = mgs_term_persloss_create(&f->pl, &term, err);
  if (st) return st;
  return mgs_trainer_add_term(t, term, err);
}

void mgs_topogs_usage(FILE *out) {
  fprintf(out,
    "  Topology-GS (SPEC 5.3):\n"
    "      --preset topology-gs  --init lpvi and --pers-loss with the authors' settings\n"
    "      --init lpvi           LPVI densification of the initial points (corrected; see docs/notes-topogs.md)\n"
    "      --lpvi-faithful       the authors' LPVI (lift from the point, no candidate filter, absolute\n"
    "                            thresholds, only the new points kept)\n"
    "      --lpvi-tau T (0.25)   --lpvi-max-edge E (2.0)   (corrected: scaled by extent / 4.4342)\n"
    "      --pers-loss[=W]       PersLoss with weight W (10)\n"
    "      --pers-loss-form topk|betti   top-k bar lengths (authors' code) or seed 001's Betti-weighted form\n"
    "      --pers-loss-downsample F (0.09)   --pers-loss-k K0,K1,K2 (10,20,50)\n"
    "      --pers-loss-schedule FROM,UNTIL,EVERY (1500,15000,200: iterations 1600..15000, 68 calls)\n");
}

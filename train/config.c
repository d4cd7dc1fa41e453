/* Values of the option table (train/mgs_config.h): parsing, printing, the record. */
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "train/mgs_config.h"
#include "core/mgs_core.h"
#include "train/mgs_sugar.h"
#include "train/mgs_gaussianpro.h"

#define NOT_DIST_MS_REASON "Mini-Splatting renders every training view for its global reinitialisation and simplification; the distributed trainer has no such pass"

static void *field(mgs_train_config *c, const mgs_option *o) { return (char *)c + o->offset; }
static const void *cfield(const mgs_train_config *c, const mgs_option *o) { return (const char *)c + o->offset; }
static size_t index_of(const mgs_option *o) {
  size_t n;
  return (size_t)(o - mgs_config_options(&n));
}

/* The position of `v` among "a|b|c", or -1. */
static int enum_index(const char *names, const char *v) {
  size_t len = strlen(v);
  int i = 0;
  for (const char *p = names; *p; i++) {
    const char *bar = strchr(p, '|');
    size_t n = bar ? (size_t)(bar - p) : strlen(p);
    if (n == len && !strncmp(p, v, n)) return i;
    if (!bar) break;
    p = bar + 1;
  }
  return -1;
}

static void enum_name(const char *names, int k, char *buf, size_t cap) {
  const char *p = names;
  for (int i = 0; i < k && p; i++) { p = strchr(p, '|'); if (p) p++; }
  if (!p) { snprintf(buf, cap, "%d", k); return; }
  const char *bar = strchr(p, '|');
  snprintf(buf, cap, "%.*s", (int)(bar ? (size_t)(bar - p) : strlen(p)), p);
}

static int parse_bool(const char *v, int *out) {
  static const char *yes[] = {"1", "True", "true", "yes", "on"}, *no[] = {"0", "False", "false", "no", "off"};
  for (size_t i = 0; i < 5; i++) {
    if (!strcmp(v, yes[i])) { *out = 1; return 1; }
    if (!strcmp(v, no[i])) { *out = 0; return 1; }
  }
  return 0;
}

static int parse_long(const char *v, long long *out) {
  char *end;
  errno = 0;
  long long x = strtoll(v, &end, 10);
  if (!*v || *end || errno) return 0;
  *out = x;
  return 1;
}

static mgs_status bad(const mgs_option *o, const char *v, const char *want, mgs_error *err) {
  return mgs_error_set(err, MGS_ERR_ARG, "--%s needs %s (got '%s')", o->name, want, v);
}

mgs_status mgs_config_set(mgs_train_config *c, const char *name, const char *v, mgs_cfg_source src, mgs_error *err) {
  const mgs_option *o = mgs_config_find(name);
  if (!o) return mgs_error_set(err, MGS_ERR_ARG, "unknown option --%s (morsegs train --help lists them)", name);
  if (!v) {
    if (!o->implicit) return mgs_error_set(err, MGS_ERR_ARG, "--%s needs a value", o->name);
    v = o->implicit;
  }
  char want[160];
  switch (o->type) {
    case MGS_OPT_INT: {
      long long x;
      snprintf(want, sizeof want, "an integer in [%.0f, %.0f]", o->min, o->max);
      if (!parse_long(v, &x) || x < o->min || x > o->max) return bad(o, v, want, err);
      *(int *)field(c, o) = (int)x;
      break;
    }
    case MGS_OPT_U64: {
      char *end;
      errno = 0;
      unsigned long long x = strtoull(v, &end, 10);
      if (!*v || *end || errno || *v == '-') return bad(o, v, "a non-negative integer", err);
      *(uint64_t *)field(c, o) = x;
      break;
    }
    case MGS_OPT_DOUBLE: {
      char *end;
      double x = strtod(v, &end);
      snprintf(want, sizeof want, "a number in [%g, %g]", o->min, o->max);
      if (!*v || *end || !isfinite(x) || x < o->min || x > o->max) return bad(o, v, want, err);
      *(double *)field(c, o) = x;
      break;
    }
    case MGS_OPT_BOOL: {
      int b;
      if (!parse_bool(v, &b)) return bad(o, v, "no value (or true/false)", err);
      *(int *)field(c, o) = b;
      break;
    }
    case MGS_OPT_ENUM: {
      int k = enum_index(o->names, v);
      if (k < 0) {
        snprintf(want, sizeof want, "one of %s", o->names);
        return bad(o, v, want, err);
      }
      *(int *)field(c, o) = k;
      break;
    }
    case MGS_OPT_STRING:
      if (strlen(v) >= o->size) return bad(o, v, "a shorter value", err);
      memcpy(field(c, o), v, strlen(v) + 1);
      break;
    case MGS_OPT_INT3: {
      int t[3];
      const char *p = v;
      for (int i = 0; i < 3; i++) {
        char *end;
        errno = 0;
        long x = strtol(p, &end, 10);
        if (end == p || errno || x < o->min || x > o->max || (i < 2 ? *end != ',' : *end != 0))
          return bad(o, v, "three comma-separated integers", err);
        t[i] = (int)x;
        p = end + 1;
      }
      if (!strcmp(o->name, "pers-loss-schedule") && (t[1] < t[0] || t[2] < 1))
        return bad(o, v, "FROM,UNTIL,EVERY with FROM <= UNTIL and EVERY >= 1", err);
      memcpy(field(c, o), t, sizeof t);
      break;
    }
    case MGS_OPT_DIMS: {
      unsigned m = 0;
      for (const char *p = v; *p; p++) {
        if (*p >= '0' && *p <= '2') m |= 1u << (*p - '0');
        else if (*p != ',') return bad(o, v, "dimensions among 0,1,2", err);
      }
      if (!m) return bad(o, v, "dimensions among 0,1,2", err);
      *(int *)field(c, o) = (int)m;
      break;
    }
  }
  c->source[index_of(o)] = (unsigned char)src;
  return MGS_OK;
}

/* The shortest text that reads back as the same double. */
static void format_double(double x, char *buf, size_t cap) {
  for (int prec = 6; prec <= 17; prec++) {
    snprintf(buf, cap, "%.*g", prec, x);
    if (strtod(buf, NULL) == x) return;
  }
}

void mgs_config_format(const mgs_train_config *c, const mgs_option *o, char *buf, size_t cap) {
  const void *f = cfield(c, o);
  switch (o->type) {
    case MGS_OPT_INT: snprintf(buf, cap, "%d", *(const int *)f); break;
    case MGS_OPT_U64: snprintf(buf, cap, "%llu", (unsigned long long)*(const uint64_t *)f); break;
    case MGS_OPT_DOUBLE: format_double(*(const double *)f, buf, cap); break;
    case MGS_OPT_BOOL: snprintf(buf, cap, "%s", *(const int *)f ? "True" : "False"); break;
    case MGS_OPT_ENUM: enum_name(o->names, *(const int *)f, buf, cap); break;
    case MGS_OPT_STRING: snprintf(buf, cap, "%s", (const char *)f); break;
    case MGS_OPT_INT3: {
      const int *t = f;
      snprintf(buf, cap, "%d,%d,%d", t[0], t[1], t[2]);
      break;
    }
    case MGS_OPT_DIMS: {
      unsigned m = (unsigned)*(const int *)f;
      size_t len = 0;
      buf[0] = 0;
      for (int k = 0; k < 3 && len + 3 < cap; k++)
        if ((m >> k) & 1u) len += (size_t)snprintf(buf + len, cap - len, len ? ",%d" : "%d", k);
      break;
    }
  }
}

const char *mgs_config_enum_name(const mgs_train_config *c, const char *option) {
  static _Thread_local char buf[64]; /* a name for a message, read at once */
  const mgs_option *o = mgs_config_find(option);
  if (!o || o->type != MGS_OPT_ENUM) return "?";
  enum_name(o->names, *(const int *)cfield(c, o), buf, sizeof buf);
  return buf;
}

void mgs_config_defaults(mgs_train_config *c) {
  memset(c, 0, sizeof *c);
  size_t n;
  const mgs_option *t = mgs_config_options(&n);
  for (size_t i = 0; i < n; i++) {
    mgs_error err;
    /* the defaults are part of the table: a bad one is a programming error caught by
       tests/train/test_config.c, never a user's */
    if (mgs_config_set(c, t[i].name, t[i].def, MGS_CFG_DEFAULT, &err)) mgs_warn("option table: %s", err.msg);
  }
}

#define NOT_DIST_SUGAR "its neighbour lists and samples are global; the distributed trainer has none yet"

/* ---- presets: rows of values over the table ---- */
typedef struct { const char *option, *value; } preset_value;
static const struct {
  int preset;
  preset_value v[5];
} PRESETS[] = {
  {MGS_PRESET_BASELINE, {{"strategy", "adc"}}},
  {MGS_PRESET_MORSE_D, {{"strategy", "morse"}}},
  {MGS_PRESET_MORSE_R, {{"strategy", "adc"}, {"topo-loss", "eliminate"}}},
  {MGS_PRESET_MORSE_I, {{"strategy", "adc"}, {"init", "levelset"}}},
  {MGS_PRESET_MORSE_FULL, {{"strategy", "morse"}, {"init", "levelset"}, {"topo-loss", "eliminate"}, {"normal-loss", "0.01"}}},
  {MGS_PRESET_TOPOLOGY_GS, {{"init", "lpvi"}, {"pers-loss", "10"}}},
  {MGS_PRESET_SUGAR, {{"strategy", "sugar"}, {"iters", "15000"}, {"densify-until", "7000"}}},
};

static mgs_status apply_preset(mgs_train_config *c, mgs_error *err) {
  for (size_t i = 0; i < sizeof PRESETS / sizeof PRESETS[0]; i++) {
    if (PRESETS[i].preset != c->preset) continue;
    for (const preset_value *p = PRESETS[i].v; p < PRESETS[i].v + 5 && p->option; p++) {
      mgs_status st = mgs_config_set(c, p->option, p->value, MGS_CFG_PRESET, err);
      if (st) return st;
    }
  }
  return MGS_OK;
}

static int typed(const mgs_train_config *c, const char *name) {
  const mgs_option *o = mgs_config_find(name);
  return o && c->source[index_of(o)] == MGS_CFG_TYPED;
}

/* What the table leaves to other settings, decided once (the record holds the result). */
static void resolve(mgs_train_config *c) {
  int morse = c->strategy == MGS_STRAT_MORSE;
  if (c->spawn == MGS_SPAWN_AUTO) c->spawn = morse ? (c->literal ? MGS_SPAWN_LITERAL : MGS_SPAWN_GAPS) : MGS_SPAWN_NONE;
  if (c->prune == MGS_PRUNE_AUTO)
    c->prune = morse ? (c->literal ? MGS_PRUNE_LITERAL : MGS_PRUNE_FLOATERS) : MGS_PRUNE_NONE;
  if (c->literal && c->topo_loss == MGS_TOPO_ELIMINATE && !typed(c, "topo-loss")) c->topo_loss = MGS_TOPO_LITERAL;
  /* a resolution given: no width cap, as the reference */
  if (typed(c, "downscale") && !typed(c, "max-width") && c->source[index_of(mgs_config_find("max-width"))] != MGS_CFG_RECORD)
    c->max_width = 0;
}

/* ---- argv ---- */
typedef struct { const char *alias, *option, *value; } alias_def;
static const alias_def ALIASES[] = {
  {"white", "background", "white"}, {"black", "background", "black"},
  {"sparse-adam", "adam", "sparse"}, {"dense-adam", "adam", "dense"},
};

/* Can `v` be the value of optional-value option o (else it is the next argument)? */
static int takes_word(const mgs_option *o, const char *v) {
  mgs_train_config scratch;
  memset(&scratch, 0, sizeof scratch);
  mgs_error e;
  return v[0] != '-' || (v[1] >= '0' && v[1] <= '9') ? mgs_config_set(&scratch, o->name, v, MGS_CFG_TYPED, &e) == MGS_OK
                                                    : 0;
}

typedef struct { const mgs_option *o; const char *v; } typed_value;

mgs_status mgs_config_parse(mgs_train_config *c, int argc, char **argv, const char **data, mgs_error *err) {
  mgs_config_defaults(c);
  *data = NULL;
  typed_value *tv = calloc((size_t)argc + 1, sizeof *tv);
  if (!tv) return mgs_error_set(err, MGS_ERR_NOMEM, "out of memory");
  size_t n = 0;
  mgs_status st = MGS_OK;
  mgs_train_config scratch = *c; /* every value is checked before any is applied */
  for (int i = 1; i < argc && st == MGS_OK; i++) {
    const char *a = argv[i];
    if (!strcmp(a, "--")) {
      for (i++; i < argc && st == MGS_OK; i++) {
        if (*data) st = mgs_error_set(err, MGS_ERR_ARG, "exactly one DATA folder is expected (got '%s' and '%s')", *data, argv[i]);
        *data = argv[i];
      }
      break;
    }
    if (a[0] != '-' || !a[1]) {
      if (*data) { st = mgs_error_set(err, MGS_ERR_ARG, "exactly one DATA folder is expected (got '%s' and '%s')", *data, a); break; }
      *data = a;
      continue;
    }
    char name[64];
    const char *v = NULL;
    if (!strcmp(a, "-o")) snprintf(name, sizeof name, "output");
    else if (!strcmp(a, "-h")) snprintf(name, sizeof name, "help");
    else if (a[1] != '-') { st = mgs_error_set(err, MGS_ERR_ARG, "unknown option %s (morsegs train --help lists them)", a); break; }
    else {
      const char *eq = strchr(a + 2, '=');
      size_t len = eq ? (size_t)(eq - a - 2) : strlen(a + 2);
      snprintf(name, sizeof name, "%.*s", (int)(len < 63 ? len : 63), a + 2);
      if (eq) v = eq + 1;
    }
    const alias_def *al = NULL;
    for (size_t k = 0; k < sizeof ALIASES / sizeof ALIASES[0]; k++)
      if (!strcmp(name, ALIASES[k].alias)) al = &ALIASES[k];
    if (al) {
      if (v) { st = mgs_error_set(err, MGS_ERR_ARG, "--%s takes no value (got '%s')", al->alias, v); break; }
      tv[n].o = mgs_config_find(al->option);
      tv[n++].v = al->value;
      st = mgs_config_set(&scratch, al->option, al->value, MGS_CFG_TYPED, err);
      continue;
    }
    const mgs_option *o = mgs_config_find(name);
    if (!o) { st = mgs_error_set(err, MGS_ERR_ARG, "unknown option --%s (morsegs train --help lists them)", name); break; }
    if (!v && o->type != MGS_OPT_BOOL) {
      if (o->flags & MGS_OPT_OPTIONAL) {
        if (i + 1 < argc && takes_word(o, argv[i + 1])) v = argv[++i];
      } else if (i + 1 < argc) {
        v = argv[++i];
      } else {
        st = mgs_error_set(err, MGS_ERR_ARG, "--%s needs a value", o->name);
        break;
      }
    }
    tv[n].o = o;
    tv[n++].v = v;
    st = mgs_config_set(&scratch, o->name, v, MGS_CFG_TYPED, err);
  }
  /* the preset first, what was typed over it */
  for (size_t k = 0; k < n && st == MGS_OK; k++)
    if (!strcmp(tv[k].o->name, "preset")) st = mgs_config_set(c, "preset", tv[k].v, MGS_CFG_TYPED, err);
  if (st == MGS_OK) st = apply_preset(c, err);
  for (size_t k = 0; k < n && st == MGS_OK; k++) st = mgs_config_set(c, tv[k].o->name, tv[k].v, MGS_CFG_TYPED, err);
  free(tv);
  if (st) return st;
  if (c->help) return MGS_OK;
  if (!c->output[0]) return mgs_error_set(err, MGS_ERR_ARG, "-o RUN is required");
  if (!*data) return mgs_error_set(err, MGS_ERR_ARG, "a DATA folder is required");
  if (c->resume) {
    char *path = mgs_path_join(c->output, "cfg_args");
    mgs_settings rec;
    mgs_settings_init(&rec);
    if (path && mgs_path_exists(path)) {
      st = mgs_settings_read(path, &rec, err);
      if (st == MGS_OK) st = mgs_config_restore(c, &rec, path, err);
    } else if (path) {
      /* without the record a resume would silently train with whatever was typed now (a run
         killed between its first checkpoint and its record has trained nothing yet) */
      char *ck = mgs_path_join(c->output, "checkpoint.mgsckpt");
      if (ck && mgs_path_exists(ck))
        st = mgs_error_set(err, MGS_ERR_FORMAT,
                           "%s: not found: the run's settings are unknown, so --resume cannot continue it "
                           "(a run stopped before it recorded them has trained nothing: start it again with --force)",
                           path);
      free(ck);
    }
    mgs_settings_free(&rec);
    free(path);
    if (st) return st;
  }
  resolve(c);
  return MGS_OK;
}

mgs_status mgs_config_restore(mgs_train_config *c, const mgs_settings *rec, const char *path, mgs_error *err) {
  size_t n;
  const mgs_option *t = mgs_config_options(&n);
  for (size_t i = 0; i < n; i++) {
    const mgs_option *o = &t[i];
    if (!(o->flags & MGS_OPT_RECORDED) || !o->key) continue;
    const char *v = mgs_settings_get(rec, o->key);
    /* records of earlier versions: the reference's white_background */
    char compat[16];
    if (!v && !strcmp(o->name, "background") && (v = mgs_settings_get(rec, "white_background")))
      v = strcpy(compat, !strcmp(v, "True") ? "white" : "black");
    if (!v) continue; /* not in this record (an older run): the default or what was typed */
    mgs_train_config was = *c;
    mgs_status st = mgs_config_set(&was, o->name, v, MGS_CFG_RECORD, err);
    if (st) return mgs_error_set(err, MGS_ERR_FORMAT, "%s: %s = %s: %s", path, o->key, v, err->msg);
    if (c->source[i] == MGS_CFG_TYPED) {
      char now[256], then[256];
      mgs_config_format(c, o, now, sizeof now);
      mgs_config_format(&was, o, then, sizeof then);
      if (strcmp(now, then) && !(o->flags & MGS_OPT_CHANGEABLE))
        return mgs_error_set(err, MGS_ERR_ARG,
                             "--%s %s contradicts the run's record %s = %s (%s): a resumed run keeps its settings; "
                             "drop the flag or train a new run",
                             o->name, now, o->key, then, path);
      continue;
    }
    memcpy(field(c, o), cfield(&was, o), o->size);
    c->source[i] = MGS_CFG_RECORD;
  }
  return MGS_OK;
}

mgs_status mgs_config_validate(const mgs_train_config *c, int ranks, mgs_error *err) {
  if (c->resume && c->force) return mgs_error_set(err, MGS_ERR_ARG, "--resume and --force exclude each other");
  size_t n;
  const mgs_option *t = mgs_config_options(&n);
  if (ranks > 1) {
    mgs_train_config def;
    mgs_config_defaults(&def);
    for (size_t i = 0; i < n; i++) {
      /* what was set (not what defaults resolved to) and differs from the default */
      if ((t[i].flags & MGS_OPT_MPI) || c->source[i] == MGS_CFG_DEFAULT) continue;
      char a[256], b[256];
      mgs_config_format(c, &t[i], a, sizeof a);
      mgs_config_format(&def, &t[i], b, sizeof b);
      if (strcmp(a, b))
        return mgs_error_set(err, MGS_ERR_ARG, "--%s %s: not with --mpi on %d processes (%s)", t[i].name, a, ranks,
                             t[i].mpi_reason ? t[i].mpi_reason : "not supported");
    }
    if (c->strategy == MGS_STRAT_MINISPLAT || c->strategy == MGS_STRAT_MINISPLAT_D)
      return mgs_error_set(err, MGS_ERR_ARG, "--strategy %s: not with --mpi on %d processes (%s)", mgs_config_enum_name(c, "strategy"), ranks, NOT_DIST_MS_REASON);
    if (c->strategy == MGS_STRAT_SUGAR) return mgs_error_set(err, MGS_ERR_ARG, "--strategy sugar: not with --mpi on %d processes (%s)", ranks, NOT_DIST_SUGAR);
    if (c->strategy == MGS_STRAT_MORSE) return mgs_error_set(err, MGS_ERR_ARG, "--strategy morse: not with --mpi on %d processes (%s)", ranks, "the Morse analysis is global; the distributed trainer has none yet");
    if (c->strategy == MGS_STRAT_GAUSSIANPRO) return mgs_error_set(err, MGS_ERR_ARG, "--strategy gaussianpro: not with --mpi on %d processes (%s)", ranks, "its patch matching reads other views' images; the distributed trainer has none yet");
    if (c->init != MGS_INIT_SFM) return mgs_error_set(err, MGS_ERR_ARG, "--init %s: not with --mpi on %d processes (each rank initialises its block from the dataset's points)", mgs_config_enum_name(c, "init"), ranks);
  } else {
    for (size_t i = 0; i < n; i++)
      if ((t[i].flags & MGS_OPT_MPI_ONLY) && c->source[i] == MGS_CFG_TYPED && !c->mpi)
        return mgs_error_set(err, MGS_ERR_ARG, "--%s is read only by --mpi", t[i].name);
  }
  /* methods built on 3DGS only: refused on surfels with the reason, never run on data they
     misread */
  if (c->model == MGS_MODEL_2DGS && c->strategy == MGS_STRAT_SUGAR)
    return mgs_error_set(err, MGS_ERR_ARG, "--strategy sugar: not with --model 2dgs (SuGaR's density and SDF need 3D "
                         "Gaussians; a surfel has no third axis, and 2DGS is itself the surface-aligned model SuGaR "
                         "regularizes 3DGS toward)");
  /* SuGaR settings: read only by --strategy sugar; its milestones in order */
  for (size_t i = 0; i < n && c->strategy != MGS_STRAT_SUGAR; i++)
    if (t[i].group == MGS_GROUP_SUGAR && c->source[i] == MGS_CFG_TYPED)
      return mgs_error_set(err, MGS_ERR_ARG, "--%s needs --strategy sugar (or --preset sugar; the strategy is '%s')",
                           t[i].name, mgs_config_enum_name(c, "strategy"));
  if (c->strategy == MGS_STRAT_SUGAR && c->sugar_prune_at < c->sugar_from)
    return mgs_error_set(err, MGS_ERR_ARG, "--sugar-prune-at %d comes before --sugar-from %d", c->sugar_prune_at,
                         c->sugar_from);
  /* compressed so far that densification averages gradients over a handful of views */
  mgs_train_config sc;
  mgs_config_scheduled(c, &sc);
  if (c->schedule_scale < 1.0 && sc.densify_every > 0 && sc.densify_every < 10 && sc.densify_until > sc.densify_from)
    mgs_warn("--schedule-scale %g: densification every %d iteration(s) (unscaled: %d) judges gradients of so few views "
             "that the counts are no longer the reference's (Mini-Splatting at 0.01: 488k Gaussians by iteration 100)",
             c->schedule_scale, sc.densify_every, c->densify_every);
  /* MorseGS settings that nothing would read */
  mgs_morse_options mo;
  int morse_used = mgs_config_morse_options(c, &mo);
  if (!morse_used) {
    for (size_t i = 0; i < n; i++) {
      if (t[i].group != MGS_GROUP_MORSE || c->source[i] != MGS_CFG_TYPED) continue;
      if (!strcmp(t[i].name, "preset") || !strcmp(t[i].name, "normal-loss") || !strcmp(t[i].name, "literal")) continue;
      if ((!strcmp(t[i].name, "spawn") && c->spawn == MGS_SPAWN_NONE) || (!strcmp(t[i].name, "prune") && c->prune == MGS_PRUNE_NONE)) continue;
      if (!strcmp(t[i].name, "spawn") || !strcmp(t[i].name, "prune"))
        return mgs_error_set(err, MGS_ERR_ARG, "--spawn/--prune need --strategy morse (the strategy is '%s')", mgs_config_enum_name(c, "strategy"));
      /* a uniform set of flags over several presets (as the experiment passes) is fine */
      mgs_warn("--%s has no effect: neither --strategy morse nor --topo-loss reads it", t[i].name);
    }
    return MGS_OK;
  }
  mgs_status st = mgs_morse_options_check(&mo, c->iters, err);
  if (st) return st;
  return mgs_morse_grid_budget_check(&mo, err);
}

void mgs_config_record(const mgs_train_config *c, mgs_settings *s) {
  size_t n;
  const mgs_option *t = mgs_config_options(&n);
  for (size_t i = 0; i < n; i++) {
    if (!(t[i].flags & MGS_OPT_RECORDED) || !t[i].key) continue;
    char buf[MGS_CFG_PATH];
    mgs_config_format(c, &t[i], buf, sizeof buf);
    int quoted = t[i].type == MGS_OPT_ENUM || t[i].type == MGS_OPT_STRING || t[i].type == MGS_OPT_INT3 ||
                 t[i].type == MGS_OPT_DIMS;
    mgs_settings_set(s, t[i].key, buf, quoted);
  }
}

void mgs_config_usage(FILE *f) {
  static const char *titles[MGS_GROUP_COUNT] = {
    "run", "3DGS baseline (the reference's defaults)", "large scenes (docs/notes/scale.md)",
    "distributed: under mpirun -np K with --mpi", "MorseGS (lengths are fractions of the bounding-box diagonal)",
    "Topology-GS", "SuGaR (--strategy sugar: from the 3DGS model at --sugar-from, docs/notes/sugar.md)"};
  fprintf(f, "usage: morsegs train DATA -o RUN [options]\n"
             "  DATA: NeRF-synthetic (transforms_train.json), nerfstudio (transforms.json) or COLMAP folder\n"
             "  --name V and --name=V are the same; (R) = recorded in RUN/cfg_args and kept by --resume\n");
  size_t n;
  const mgs_option *t = mgs_config_options(&n);
  for (int g = 0; g < MGS_GROUP_COUNT; g++) {
    fprintf(f, "\n  %s:\n", titles[g]);
    for (size_t i = 0; i < n; i++) {
      if ((int)t[i].group != g) continue;
      char flag[96];
      if (t[i].type == MGS_OPT_BOOL) snprintf(flag, sizeof flag, "--%s", t[i].name);
      else if (t[i].type == MGS_OPT_ENUM) snprintf(flag, sizeof flag, "--%s%s%s%s", t[i].name, t[i].flags & MGS_OPT_OPTIONAL ? "[=" : " ", t[i].names, t[i].flags & MGS_OPT_OPTIONAL ? "]" : "");
      else snprintf(flag, sizeof flag, "--%s%s", t[i].name, t[i].flags & MGS_OPT_OPTIONAL ? "[=V]" : " V");
      fprintf(f, "    %-34s %s%s", flag, t[i].help, t[i].flags & MGS_OPT_RECORDED ? " (R)" : "");
      if (t[i].type != MGS_OPT_BOOL && t[i].def[0]) fprintf(f, " [%s]", t[i].def);
      fputc('\n', f);
    }
  }
}

/* ---- the options of each layer ---- */
/* A value the user (or a preset or the record) set; otherwise the layer's own default
   stays, bit for bit. A resume takes every value from the record, so each layer default
   must equal its table value converted (tests/train/test_config.c checks it). */
static int set_here(const mgs_train_config *c, const char *name) {
  const mgs_option *o = mgs_config_find(name);
  return o && c->source[index_of(o)] != MGS_CFG_DEFAULT;
}
#define TAKE(name, dst, val) do { if (set_here(c, name)) (dst) = (val); } while (0)

/* ---- --schedule-scale: the one place where iteration milestones are scaled ---- */
int mgs_config_scale_iteration(const mgs_train_config *c, int iteration) {
  if (iteration <= 0 || c->schedule_scale == 1.0) return iteration;
  double v = floor((double)iteration * c->schedule_scale + 0.5);
  return v < 1 ? 1 : v > 2e9 ? 2000000000 : (int)v;
}

void mgs_config_scheduled(const mgs_train_config *c, mgs_train_config *out) {
  if (out != c) *out = *c;
  if (c->schedule_scale == 1.0) return;
  int *ms[] = {&out->sh_every, &out->densify_from, &out->densify_until, &out->densify_every,
               &out->opacity_reset_every, &out->position_lr_max_steps, &out->morse_every, &out->morse_warmup,
               &out->morse_until, &out->pers_loss_schedule[0], &out->pers_loss_schedule[1],
               &out->pers_loss_schedule[2], &out->sugar_from, &out->sugar_prune_at, &out->sugar_knn_every,
               &out->gpro_schedule[0], &out->gpro_schedule[1], &out->gpro_schedule[2]};
  for (size_t i = 0; i < sizeof ms / sizeof ms[0]; i++) *ms[i] = mgs_config_scale_iteration(c, *ms[i]);
  out->schedule_scale = 1.0; /* applied */
}
#define SCHEDULED(c) mgs_train_config sched_; mgs_config_scheduled(c, &sched_); c = &sched_

void mgs_config_train_options(const mgs_train_config *c, mgs_train_options *o) {
  const int unscaled_densify_every = c->densify_every;
  const double scale = c->schedule_scale;
  SCHEDULED(c);
  mgs_train_options_default(o);
  o->iterations = c->iters;
  o->sh_degree = c->sh_degree;
  o->sh_every = c->sh_every;
  o->seed = c->seed;
  o->checkpoint_every = c->checkpoint_every;
  o->freeze = c->freeze;
  o->progress = !c->quiet;
  o->lr_mean_max_steps = c->position_lr_max_steps;
  TAKE("lambda-dssim", o->lambda_dssim, (float)c->lambda_dssim);
  TAKE("position-lr-init", o->lr_mean_init, c->position_lr_init);
  TAKE("position-lr-final", o->lr_mean_final, c->position_lr_final);
  TAKE("feature-lr", o->lr_sh_dc, (float)c->feature_lr);
  TAKE("feature-rest-lr", o->lr_sh_rest, (float)c->feature_rest_lr);
  TAKE("opacity-lr", o->lr_opacity, (float)c->opacity_lr);
  TAKE("scaling-lr", o->lr_log_scale, (float)c->scaling_lr);
  TAKE("rotation-lr", o->lr_rot, (float)c->rotation_lr);
  o->adc.densify_from = c->densify_from;
  o->adc.densify_until = c->densify_until;
  o->adc.densify_every = c->densify_every;
  o->adc.opacity_reset_every = c->opacity_reset_every;
  TAKE("grad-threshold", o->adc.grad_threshold, (float)c->grad_threshold);
  TAKE("percent-dense", o->adc.percent_dense, (float)c->percent_dense);
  TAKE("min-opacity", o->adc.min_opacity, (float)c->min_opacity);
  if (c->model == MGS_MODEL_2DGS && !set_here(c, "min-opacity")) o->adc.min_opacity = 0.05f; /* the authors' opacity_cull */
  TAKE("max-screen-size", o->adc.max_screen_px, (float)c->max_screen_size);
  o->adc.white_background = c->background == MGS_BG_WHITE;
  /* compressed: transparent Gaussians get the reference's iterations after a reset (its
     unscaled densification interval) before they are pruned */
  if (scale < 1.0) o->adc.reset_prune_wait = unscaled_densify_every;
  o->visibility = c->visibility == MGS_AUTO_OFF_ON_AUTO ? -1 : c->visibility == MGS_AUTO_OFF_ON_ON;
  o->vis_tile = c->vis_tile;
  o->sparse_adam = c->adam == MGS_ADAM_AUTO ? -1 : c->adam == MGS_ADAM_SPARSE;
  o->image_cache_mb = (size_t)c->image_cache_mb;
  o->sh_moments_bf16 = c->sh_moments_bf16;
  o->view_locality = c->view_locality;
}

void mgs_config_dataset_options(const mgs_train_config *c, mgs_dataset_options *o) {
  mgs_dataset_options_default(o);
  o->downscale = c->downscale;
  o->max_width = c->max_width;
  o->white_background = c->background == MGS_BG_AUTO ? -1 : c->background == MGS_BG_WHITE;
  o->load_images = c->image_cache_mb == 0; /* the cache decodes on demand */
  o->test_every = c->test_every;
  o->images = c->images;
}

int mgs_config_morse_options(const mgs_train_config *c, mgs_morse_options *o) {
  SCHEDULED(c);
  mgs_morse_options_default(o);
  static const mgs_morse_spawn spawn[] = {MGS_MORSE_SPAWN_GAPS, MGS_MORSE_SPAWN_GAPS, MGS_MORSE_SPAWN_LITERAL, MGS_MORSE_SPAWN_NONE};
  static const mgs_morse_prune prune[] = {MGS_MORSE_PRUNE_FLOATERS, MGS_MORSE_PRUNE_FLOATERS, MGS_MORSE_PRUNE_LITERAL, MGS_MORSE_PRUNE_NONE};
  static const mgs_morse_topo topo[] = {MGS_MORSE_TOPO_NONE, MGS_MORSE_TOPO_ELIMINATE, MGS_MORSE_TOPO_LITERAL};
  int morse = c->strategy == MGS_STRAT_MORSE;
  o->spawn = morse ? spawn[c->spawn] : MGS_MORSE_SPAWN_NONE;
  o->prune = morse ? prune[c->prune] : MGS_MORSE_PRUNE_NONE;
  if (morse && c->literal && c->spawn == MGS_SPAWN_AUTO) o->spawn = MGS_MORSE_SPAWN_LITERAL;
  if (morse && c->literal && c->prune == MGS_PRUNE_AUTO) o->prune = MGS_MORSE_PRUNE_LITERAL;
  o->topo = topo[c->topo_loss];
  o->beta = c->beta;
  o->eps_p = c->eps_p;
  o->eps_sig = c->eps_sig;
  o->dims = (unsigned)c->topo_dims;
  o->min_bar = c->min_bar;
  o->every = c->morse_every;
  o->warmup = c->morse_warmup;
  /* under --strategy morse the analyses end with densification */
  o->until = morse && c->morse_until > c->densify_until ? c->densify_until : c->morse_until;
  o->resolution = c->morse_resolution;
  o->tau = c->morse_tau;
  o->sdf_method = (mgs_vdb_sdf_method)c->morse_sdf;
  o->gap_max = c->gap_max;
  o->min_cameras = c->min_cameras;
  o->floater_volume = c->floater_volume;
  o->floater_mass = c->floater_mass;
  o->max_spawn = c->max_spawn;
  o->incremental = c->morse_incremental;
  return morse || o->topo != MGS_MORSE_TOPO_NONE;
}

void mgs_config_lpvi_options(const mgs_train_config *c, mgs_lpvi_options *o) {
  mgs_lpvi_options_default(o);
  o->faithful = c->lpvi_faithful;
  o->tau = c->lpvi_tau;
  o->max_edge = c->lpvi_max_edge;
}

int mgs_config_persloss_options(const mgs_train_config *c, mgs_persloss_options *o) {
  SCHEDULED(c);
  mgs_persloss_options_default(o);
  o->lambda = c->pers_loss;
  o->form = (mgs_persloss_form)c->pers_loss_form;
  o->downsample = c->pers_loss_downsample;
  memcpy(o->k, c->pers_loss_k, sizeof o->k);
  o->from = c->pers_loss_schedule[0];
  o->until = c->pers_loss_schedule[1];
  o->every = c->pers_loss_schedule[2];
  return c->pers_loss > 0;
}

int mgs_config_sugar_options(const mgs_train_config *c, mgs_sugar_options *o) {
  SCHEDULED(c);
  mgs_sugar_options_default(o);
  o->from_iter = c->sugar_from;
  o->prune_at = c->sugar_prune_at;
  o->prune_alpha = c->sugar_prune_alpha;
  o->entropy = c->sugar_entropy;
  o->sdf_weight = c->sugar_sdf;
  o->normal_weight = c->sugar_normal;
  o->samples = c->sugar_samples;
  o->knn_every = c->sugar_knn_every;
  return c->strategy == MGS_STRAT_SUGAR;
}

int mgs_config_normal_options(const mgs_train_config *c, mgs_normal_options *o) {
  mgs_normal_options_default(o);
  o->from_iter = mgs_config_scale_iteration(c, o->from_iter);
  o->until_iter = mgs_config_scale_iteration(c, o->until_iter);
  o->every = mgs_config_scale_iteration(c, o->every);
  o->gamma = c->normal_loss;
  if (c->iters < 2 * o->from_iter) o->from_iter = c->iters / 2 > 0 ? c->iters / 2 : 1; /* short runs: the second half */
  return c->normal_loss > 0;
}

int mgs_config_2dgs_options(const mgs_train_config *c, int format, mgs_2dgs_term_options *o) {
  mgs_2dgs_term_options_default(o);
  o->dist_from = mgs_config_scale_iteration(c, o->dist_from);
  o->normal_from = mgs_config_scale_iteration(c, o->normal_from);
  o->lambda_dist = c->lambda_dist >= 0 ? c->lambda_dist : (format == MGS_DATASET_NERF_SYNTHETIC ? 1000.0 : 0.0);
  o->lambda_normal = c->lambda_normal;
  if (c->iters < o->dist_from) o->dist_from = c->iters / 2 > 0 ? c->iters / 2 : 1;       /* short runs: */
  if (c->iters < o->normal_from) o->normal_from = (3 * c->iters) / 4 > 0 ? (3 * c->iters) / 4 : 1; /* the later part */
  return c->model == MGS_MODEL_2DGS;
}

int mgs_config_gpro_options(const mgs_train_config *c, mgs_gpro_options *o) {
  SCHEDULED(c);
  mgs_gpro_options_default(o);
  o->from = c->gpro_schedule[0];
  o->until = c->gpro_schedule[1];
  o->every = c->gpro_schedule[2];
  o->patch_size = c->gpro_patch;
  o->pm_iterations = c->gpro_pm_iters;
  o->neighbors = c->gpro_neighbors;
  o->error_max = c->gpro_error_max;
  o->error_min = c->gpro_error_min;
  o->seed = c->seed;
  return c->strategy == MGS_STRAT_GAUSSIANPRO;
}

int mgs_config_minisplat_options(const mgs_train_config *c, mgs_minisplat_options *o) {
  mgs_minisplat_options_default(o);
  mgs_train_options to;
  mgs_config_train_options(c, &to); /* ADC's settings, scaled */
  o->adc = to.adc;
  o->dense = c->strategy == MGS_STRAT_MINISPLAT_D;
  o->reinit_every = mgs_config_scale_iteration(c, o->reinit_every);
  o->simplify1 = o->dense ? o->adc.densify_until : mgs_config_scale_iteration(c, o->simplify1);
  o->simplify2 = mgs_config_scale_iteration(c, o->simplify2);
  o->lr_restart = mgs_config_scale_iteration(c, o->lr_restart);
  o->simplify_fraction = c->simplify_fraction;
  o->depth_points = (size_t)c->ms_depth_points;
  o->blur_min_px = c->ms_blur_min_px;
  return c->strategy == MGS_STRAT_MINISPLAT || c->strategy == MGS_STRAT_MINISPLAT_D;
}

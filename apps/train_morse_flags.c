/* MorseGS flags of `morsegs train` (see apps/train_morse_flags.h). Presets (seed §5.3):
 *   baseline    ADC, no loss terms
 *   morse-d     --strategy morse --spawn gaps --prune floaters
 *   morse-r     --topo-loss eliminate (ADC)
 *   morse-i     --init levelset
 *   morse-full  all of them and --normal-loss 0.01
 * --literal switches every rule to the seed's printed form (spawn, prune, L_topo). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include "apps/train_morse_flags.h"
#include "core/mgs_core.h"

const char *train_morse_flags_usage =
    "  MorseGS (SPEC §5.2; lengths are fractions of the bounding-box diagonal):\n"
    "      --preset NAME       baseline | morse-d | morse-r | morse-i | morse-full\n"
    "      --literal           every rule in the seed's printed form (spawn, prune, L_topo)\n"
    "      --strategy morse    Morse-guided densification with ADC as fallback\n"
    "      --spawn gaps|literal|none     (gaps)   --prune floaters|literal|none (floaters)\n"
    "      --topo-loss[=eliminate|literal]  persistence regularization (eliminate)\n"
    "      --beta B (0.003, in units of eps-sig squared)  --eps-sig E (0.02)  --eps-p E (0.01)  --topo-dims 0,1,2\n"
    "      --min-bar V         bars shorter than V voxels stay out of L_topo (0.5)\n"
    "      --morse-every K (500)  --morse-warmup W (3000)  --morse-until U (15000)\n"
    "      --morse-resolution R (256)  --morse-tau T (0.5)  --morse-sdf sweep|closest|mesh (sweep)\n"
    "      --gap-max G (0.05)  --min-cameras M (3)  --floater-volume F (0.01)  --floater-mass F (0.01)\n"
    "      --max-spawn N (1000)  --morse-incremental: keep the lattice, redo only the α leaves, SDF band and critical cells that changed\n"
    "      analysis rows: RUN/morse_analysis.csv\n";

typedef enum { K_PRESET, K_LITERAL, K_SPAWN, K_PRUNE, K_TOPO, K_BETA, K_EPSP, K_EPSSIG, K_DIMS, K_EVERY, K_WARMUP,
               K_UNTIL, K_RES, K_TAU, K_SDF, K_GAP, K_MINCAM, K_FVOL, K_FMASS, K_MAXSPAWN, K_MINBAR, K_INCR, K_COUNT } key;
static const struct { const char *name; int arg; const char *cfg; } flags[K_COUNT] = {
    {"preset", 1, "preset"}, {"literal", 0, "literal"}, {"spawn", 1, "morse_spawn"}, {"prune", 1, "morse_prune"},
    {"topo-loss", 2, "topo_loss"}, {"beta", 1, "topo_beta"}, {"eps-p", 1, "eps_p"}, {"eps-sig", 1, "eps_sig"},
    {"topo-dims", 1, "topo_dims"}, {"morse-every", 1, "morse_every"}, {"morse-warmup", 1, "morse_warmup"},
    {"morse-until", 1, "morse_until"}, {"morse-resolution", 1, "morse_resolution"}, {"morse-tau", 1, "morse_tau"},
    {"morse-sdf", 1, "morse_sdf"}, {"gap-max", 1, "gap_max"}, {"min-cameras", 1, "min_cameras"},
    {"floater-volume", 1, "floater_volume"}, {"floater-mass", 1, "floater_mass"}, {"max-spawn", 1, "max_spawn"}, {"min-bar", 1, "min_bar"},
    {"morse-incremental", 0, "morse_incremental"}};

static int fail(const char *flag, const char *fmt, const char *v) {
  fprintf(stderr, "morsegs train: --%s ", flag);
  fprintf(stderr, fmt, v);
  fputc('\n', stderr);
  return 0;
}

static int num(const char *flag, const char *v, double lo, double hi, double *out) {
  char *end;
  double x = strtod(v, &end);
  if (!*v || *end || !isfinite(x) || x < lo || x > hi) {
    fprintf(stderr, "morsegs train: --%s must be a number in [%g, %g] (got '%s')\n", flag, lo, hi, v);
    return 0;
  }
  *out = x;
  return 1;
}

static const char *spawn_names[] = {"none", "literal", "gaps"};
static const char *prune_names[] = {"none", "literal", "floaters"};
static const char *topo_names[] = {"none", "eliminate", "literal"};
static const char *sdf_names[] = {"mesh", "sweep", "closest"};
static int pick(const char *v, const char *const *names, int n) {
  for (int i = 0; i < n; i++) if (!strcmp(v, names[i])) return i;
  return -1;
}

/* One flag's value into f (typed = from the command line, else from cfg_args). */
static int apply(train_morse_flags *f, key k, const char *v) {
  mgs_morse_options *o = &f->o;
  double x = 0;
  int i;
  switch (k) {
    case K_PRESET:
      if (strcmp(v, "baseline") && strcmp(v, "morse-d") && strcmp(v, "morse-r") && strcmp(v, "morse-i") && strcmp(v, "morse-full"))
        return fail("preset", "must be baseline, morse-d, morse-r, morse-i or morse-full (got '%s')", v);
      f->preset = v; return 1;
    case K_LITERAL: f->literal = !v || !strcmp(v, "True") || !strcmp(v, "1"); return 1;
    case K_INCR: o->incremental = !v || !strcmp(v, "True") || !strcmp(v, "1"); return 1;
    case K_SPAWN: if ((i = pick(v, spawn_names, 3)) < 0) return fail("spawn", "must be gaps, literal or none (got '%s')", v); o->spawn = (mgs_morse_spawn)i; f->spawn_typed = 1; return 1;
    case K_PRUNE: if ((i = pick(v, prune_names, 3)) < 0) return fail("prune", "must be floaters, literal or none (got '%s')", v); o->prune = (mgs_morse_prune)i; f->prune_typed = 1; return 1;
    case K_TOPO: if ((i = pick(v ? v : "eliminate", topo_names, 3)) < 0) return fail("topo-loss", "must be eliminate, literal or none (got '%s')", v); o->topo = (mgs_morse_topo)i; f->topo_typed = 1; return 1;
    case K_SDF: if ((i = pick(v, sdf_names, 3)) < 0) return fail("morse-sdf", "must be sweep, closest or mesh (got '%s')", v); o->sdf_method = (mgs_vdb_sdf_method)i; return 1;
    case K_BETA: if (!num("beta", v, 0, 100, &x)) return 0; o->beta = x; return 1;
    case K_EPSP: if (!num("eps-p", v, 1e-6, 0.5, &x)) return 0; o->eps_p = x; return 1;
    case K_EPSSIG: if (!num("eps-sig", v, 1e-6, 0.5, &x)) return 0; o->eps_sig = x; return 1;
    case K_TAU: if (!num("morse-tau", v, 1e-3, 0.999, &x)) return 0; o->tau = x; return 1;
    case K_GAP: if (!num("gap-max", v, 1e-6, 0.5, &x)) return 0; o->gap_max = x; return 1;
    case K_FVOL: if (!num("floater-volume", v, 0, 0.999, &x)) return 0; o->floater_volume = x; return 1;
    case K_MINBAR: if (!num("min-bar", v, 0, 16, &x)) return 0; o->min_bar = x; return 1;
    case K_FMASS: if (!num("floater-mass", v, 0, 0.999, &x)) return 0; o->floater_mass = x; return 1;
    case K_EVERY: if (!num("morse-every", v, 1, 1e6, &x) || x != floor(x)) return x != floor(x) ? fail("morse-every", "must be an integer in [1, 1000000] (got '%s')", v) : 0; o->every = (int)x; return 1;
    case K_WARMUP: if (!num("morse-warmup", v, 1, 1e7, &x) || x != floor(x)) return x != floor(x) ? fail("morse-warmup", "must be an integer >= 1 (got '%s')", v) : 0; o->warmup = (int)x; return 1;
    case K_UNTIL: if (!num("morse-until", v, 1, 1e7, &x) || x != floor(x)) return x != floor(x) ? fail("morse-until", "must be an integer >= 1 (got '%s')", v) : 0; o->until = (int)x; return 1;
    case K_RES: if (!num("morse-resolution", v, 16, 2048, &x) || x != floor(x)) return x != floor(x) ? fail("morse-resolution", "must be an integer in [16, 2048] (got '%s')", v) : 0; o->resolution = (int)x; return 1;
    case K_MINCAM: if (!num("min-cameras", v, 0, 1e6, &x) || x != floor(x)) return x != floor(x) ? fail("min-cameras", "must be an integer >= 0 (got '%s')", v) : 0; o->min_cameras = (int)x; return 1;
    case K_MAXSPAWN: if (!num("max-spawn", v, 0, 1e8, &x) || x != floor(x)) return x != floor(x) ? fail("max-spawn", "must be an integer >= 0 (got '%s')", v) : 0; o->max_spawn = (int)x; return 1;
    case K_DIMS: {
      unsigned m = 0;
      for (const char *p = v; *p; p++) {
        if (*p >= '0' && *p <= '2') m |= 1u << (*p - '0');
        else if (*p != ',') return fail("topo-dims", "must list dimensions among 0,1,2 (got '%s')", v);
      }
      if (!m) return fail("topo-dims", "must list dimensions among 0,1,2 (got '%s')", v);
      o->dims = m;
      return 1;
    }
    default: return 0;
  }
}

static void add_arg(int *argc, char **out, train_morse_flags *f, const char *s) {
  for (int i = 0; i < 8; i++)
    if (!f->argv_storage[i]) { f->argv_storage[i] = mgs_strdup(s); out[(*argc)++] = f->argv_storage[i]; return; }
}

int train_morse_flags_take(int *argc, char ***argv, train_morse_flags *f) {
  memset(f, 0, sizeof *f);
  mgs_morse_options_default(&f->o);
  int n = *argc, m = 0;
  char **in = *argv, **out = calloc((size_t)n + 8, sizeof(char *));
  if (!out) return 0;
  unsigned char typed[K_COUNT] = {0};
  const char *run = NULL;
  int resume = 0, strategy_typed = 0, init_typed = 0, normal_typed = 0;
  for (int i = 0; i < n; i++) {
    const char *a = in[i];
    if (i == 0 || strncmp(a, "--", 2) != 0 || !a[2]) {
      if (i > 0 && (!strcmp(a, "-o")) && i + 1 < n) { out[m++] = in[i]; run = in[++i]; out[m++] = in[i]; continue; }
      out[m++] = in[i];
      if (i > 0 && !strcmp(a, "--")) while (++i < n) out[m++] = in[i];
      continue;
    }
    char name[64];
    const char *eq = strchr(a + 2, '=');
    size_t len = eq ? (size_t)(eq - a - 2) : strlen(a + 2);
    snprintf(name, sizeof name, "%.*s", (int)(len < 63 ? len : 63), a + 2);
    if (!strcmp(name, "output")) { out[m++] = in[i]; if (eq) run = eq + 1; else if (i + 1 < n) { run = in[++i]; out[m++] = in[i]; } continue; }
    if (!strcmp(name, "resume")) resume = 1;
    if (!strcmp(name, "strategy")) strategy_typed = 1;
    if (!strcmp(name, "init")) init_typed = 1;
    if (!strcmp(name, "normal-loss")) normal_typed = 1;
    int k = -1;
    for (int j = 0; j < K_COUNT; j++) if (!strcmp(name, flags[j].name)) k = j;
    if (k < 0) { out[m++] = in[i]; continue; }
    const char *v = eq ? eq + 1 : NULL;
    if (flags[k].arg == 1 && !v) {
      if (i + 1 >= n) { free(out); return fail(flags[k].name, "needs a value%s", ""); }
      v = in[++i];
    }
    /* --topo-loss takes its kind as --topo-loss=KIND or as the next word when it is one */
    if (flags[k].arg == 2 && !v && i + 1 < n && pick(in[i + 1], topo_names, 3) >= 0) v = in[++i];
    if (flags[k].arg == 0 && v) { free(out); return fail(flags[k].name, "takes no value (got '%s')", v); }
    if (!apply(f, (key)k, v)) { free(out); return 0; }
    typed[k] = 1;
    f->any_typed = 1;
  }
  /* --resume: what was not typed comes from the run's record */
  if (resume && run) {
    char *cfg = mgs_path_join(run, "cfg_args");
    mgs_settings prev;
    mgs_settings_init(&prev);
    if (cfg && mgs_path_exists(cfg) && mgs_settings_read(cfg, &prev, NULL) == MGS_OK) {
      for (int k = 0; k < K_COUNT; k++) {
        const char *v = mgs_settings_get(&prev, flags[k].cfg);
        if (typed[k] || !v) continue;
        if (k == K_PRESET) { if (strcmp(v, "none")) { f->argv_storage[7] = mgs_strdup(v); f->preset = f->argv_storage[7]; } continue; }
        if (!apply(f, (key)k, v)) { mgs_settings_free(&prev); free(cfg); free(out); return 0; }
      }
      /* the record holds the resolved values: no preset defaults on top */
      f->spawn_typed = f->prune_typed = f->topo_typed = 1;
    }
    mgs_settings_free(&prev);
    free(cfg);
  }
  /* a preset's plain flags, unless typed (on resume cmd_train restores them itself) */
  if (f->preset && !resume) {
    const char *p = f->preset;
    int d = !strcmp(p, "morse-d") || !strcmp(p, "morse-full");
    int r = !strcmp(p, "morse-r") || !strcmp(p, "morse-full");
    int ini = !strcmp(p, "morse-i") || !strcmp(p, "morse-full");
    if (!strategy_typed) add_arg(&m, out, f, d ? "--strategy=morse" : "--strategy=adc");
    if (ini && !init_typed) add_arg(&m, out, f, "--init=levelset");
    if (!strcmp(p, "morse-full") && !normal_typed) add_arg(&m, out, f, "--normal-loss=0.01");
    if (r && !typed[K_TOPO]) { f->o.topo = f->literal ? MGS_MORSE_TOPO_LITERAL : MGS_MORSE_TOPO_ELIMINATE; f->topo_typed = 1; }
  }
  if (f->literal && f->o.topo == MGS_MORSE_TOPO_ELIMINATE && !typed[K_TOPO]) f->o.topo = MGS_MORSE_TOPO_LITERAL;
  out[m] = NULL;
  *argc = m;
  *argv = out;
  f->argv_alloc = out;
  return 1;
}

int train_morse_flags_check(train_morse_flags *f, const char *strategy, int iterations) {
  mgs_morse_options *o = &f->o;
  int morse = !strcmp(strategy, "morse");
  if (morse) {
    if (!f->spawn_typed) o->spawn = f->literal ? MGS_MORSE_SPAWN_LITERAL : MGS_MORSE_SPAWN_GAPS;
    if (!f->prune_typed) o->prune = f->literal ? MGS_MORSE_PRUNE_LITERAL : MGS_MORSE_PRUNE_FLOATERS;
  } else if ((f->spawn_typed && o->spawn != MGS_MORSE_SPAWN_NONE) || (f->prune_typed && o->prune != MGS_MORSE_PRUNE_NONE)) {
    fprintf(stderr, "morsegs train: --spawn/--prune need --strategy morse (the strategy is '%s')\n", strategy);
    return 0;
  }
  if (f->any_typed && !morse && o->topo == MGS_MORSE_TOPO_NONE && !(f->preset && (!strcmp(f->preset, "baseline") || !strcmp(f->preset, "morse-i")))) {
    fprintf(stderr, "morsegs train: MorseGS settings given, but neither --strategy morse nor --topo-loss uses them\n");
    return 0;
  }
  if (!morse && o->topo == MGS_MORSE_TOPO_NONE) return 1; /* nothing reads the options */
  mgs_error err;
  mgs_error_clear(&err);
  if (mgs_morse_options_check(o, iterations, &err) != MGS_OK) { fprintf(stderr, "morsegs train: %s\n", err.msg); return 0; }
  /* the grids: a band of 2w+1 voxels around a surface of about 6 r² voxels (a cube's
     faces; trained surfaces are larger, so 4x that), ~40 bytes per band voxel for the
     α-field, the SDF and the persistence engine together */
  if (morse || o->topo != MGS_MORSE_TOPO_NONE) {
    int hw = mgs_topo_band_for_threshold(mgs_morse_eps_in_use(o, 1.0), o->spawn == MGS_MORSE_SPAWN_GAPS ? o->gap_max : 0, 1.0 / o->resolution);
    double bytes = 4.0 * 6.0 * (double)o->resolution * o->resolution * (2.0 * hw + 1) * 40.0;
    long pages = sysconf(_SC_PHYS_PAGES), psize = sysconf(_SC_PAGE_SIZE);
    double phys = pages > 0 && psize > 0 ? (double)pages * (double)psize : 8e9;
    if (bytes > 0.6 * phys) {
      fprintf(stderr, "morsegs train: --morse-resolution %d needs about %.1f GB for the analysis grids (band %d voxels), more than 60%% of this machine's %.1f GB; lower it\n",
              o->resolution, bytes / 1e9, hw, phys / 1e9);
      return 0;
    }
  }
  return 1;
}

void train_morse_flags_record(const train_morse_flags *f, const char *strategy, mgs_settings *s) {
  const mgs_morse_options *o = &f->o;
  mgs_settings_set(s, "preset", f->preset ? f->preset : "none", 1);
  mgs_settings_set(s, "literal", f->literal ? "True" : "False", 0);
  mgs_settings_set(s, "morse_incremental", f->o.incremental ? "True" : "False", 0);
  int morse = !strcmp(strategy, "morse");
  if (!morse && o->topo == MGS_MORSE_TOPO_NONE) return;
  mgs_settings_set(s, "morse_spawn", spawn_names[o->spawn], 1);
  mgs_settings_set(s, "morse_prune", prune_names[o->prune], 1);
  mgs_settings_set(s, "topo_loss", topo_names[o->topo], 1);
  mgs_settings_setf(s, "topo_beta", o->beta);
  mgs_settings_setf(s, "eps_p", o->eps_p);
  mgs_settings_setf(s, "eps_sig", o->eps_sig);
  char dims[8] = "", *p = dims;
  for (int k = 0; k < 3; k++) if ((o->dims >> k) & 1u) p += snprintf(p, 3, p == dims ? "%d" : ",%d", k);
  mgs_settings_set(s, "topo_dims", dims, 1);
  mgs_settings_seti(s, "morse_every", o->every);
  mgs_settings_seti(s, "morse_warmup", o->warmup);
  mgs_settings_seti(s, "morse_until", o->until);
  mgs_settings_seti(s, "morse_resolution", o->resolution);
  mgs_settings_setf(s, "morse_tau", o->tau);
  mgs_settings_set(s, "morse_sdf", sdf_names[o->sdf_method], 1);
  mgs_settings_setf(s, "gap_max", o->gap_max);
  mgs_settings_seti(s, "min_cameras", o->min_cameras);
  mgs_settings_setf(s, "floater_volume", o->floater_volume);
  mgs_settings_setf(s, "floater_mass", o->floater_mass);
  mgs_settings_seti(s, "max_spawn", o->max_spawn);
  mgs_settings_setf(s, "min_bar", o->min_bar);
}

void train_morse_flags_free(train_morse_flags *f) {
  for (int i = 0; i < 8; i++) free(f->argv_storage[i]);
  free(f->argv_alloc);
  f->argv_alloc = NULL;
  memset(f->argv_storage, 0, sizeof f->argv_storage);
}

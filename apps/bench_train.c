/* morsegs bench train: test PSNR against wall time for the built-in scenes (datasets made
 * by `morsegs scene --builtin`), plus a run matched to the OpenSplat CPU figures of
 * PEERS.md (200x200, 2000 Gaussians, SH 3, no densification, 1000 iterations).
 * Writes OUT/train.csv, OUT/train.md (tables) and OUT/train.png (PSNR against time). */
#include <errno.h>
#include <getopt.h>
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <cairo.h>
#include "apps/mgs_cli.h"
#include "core/mgs_core.h"
#include "train/mgs_train.h"
#include "train/mgs_strategy.h"

typedef struct {
  char scene[32];
  char config[32];
  int iteration;
  double seconds, ms_per_iter, cpu_ms_per_iter, psnr, ssim;
  double cpu_seconds; /* this process' CPU time (all threads) spent training so far */
  double phase_ms[MGS_TRAIN_PHASES]; /* per iteration in the segment */
  size_t gaussians;
} sample;

typedef struct {
  sample *s;
  size_t n, cap;
} samples;

static void push(samples *ss, const sample *x) {
  if (ss->n == ss->cap) {
    size_t cap = ss->cap ? 2 * ss->cap : 64;
    sample *p = realloc(ss->s, cap * sizeof *p);
    if (!p) return;
    ss->s = p; ss->cap = cap;
  }
  ss->s[ss->n++] = *x;
}

/* Samples back from a train.csv this bench wrote (--from: new --reach targets and plots
 * without training again). Older files without the cpu_seconds column read as NAN. */
static mgs_status read_csv(const char *path, samples *ss, mgs_error *err) {
  FILE *f = fopen(path, "r");
  if (!f) return mgs_error_set(err, MGS_ERR_IO, "%s: cannot open (%s)", path, strerror(errno));
  char line[1024];
  int ln = 0;
  mgs_status st = MGS_OK;
  while (fgets(line, sizeof line, f)) {
    ln++;
    if (ln == 1) {
      if (strncmp(line, "scene,config,iteration,train_seconds", 36)) {
        st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: not a train.csv of morsegs bench train (header)", path);
        break;
      }
      continue;
    }
    sample s;
    memset(&s, 0, sizeof s);
    s.cpu_seconds = NAN;
    char *save = NULL, *tok[16];
    int n = 0;
    for (char *t = strtok_r(line, ",\n", &save); t && n < 16; t = strtok_r(NULL, ",\n", &save)) tok[n++] = t;
    if (n < 15) { st = mgs_error_set(err, MGS_ERR_FORMAT, "%s:%d: %d fields, expected 15 or 16", path, ln, n); break; }
    snprintf(s.scene, sizeof s.scene, "%s", tok[0]);
    snprintf(s.config, sizeof s.config, "%s", tok[1]);
    s.iteration = atoi(tok[2]);
    s.seconds = atof(tok[3]); s.ms_per_iter = atof(tok[4]); s.cpu_ms_per_iter = atof(tok[5]);
    s.gaussians = (size_t)strtoull(tok[6], NULL, 10);
    s.psnr = atof(tok[7]); s.ssim = atof(tok[8]);
    for (int k = 0; k < MGS_TRAIN_PHASES && 9 + k < 15; k++) s.phase_ms[k] = atof(tok[9 + k]);
    if (n >= 16) s.cpu_seconds = atof(tok[15]);
    if (!isfinite(s.psnr) || s.iteration <= 0) { st = mgs_error_set(err, MGS_ERR_FORMAT, "%s:%d: bad iteration or PSNR", path, ln); break; }
    push(ss, &s);
  }
  fclose(f);
  if (st == MGS_OK && ss->n == 0) st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: no samples", path);
  return st;
}

static void usage(FILE *f) {
  fprintf(f,
    "usage: morsegs bench train [options]\n"
    "  --full              7000 iterations at 200x200 on every built-in scene (default: 2000 on 'sphere')\n"
    "  --scenes A,B        built-in scenes (sphere, genus2, thin)\n"
    "  --iters N           iterations per scene\n"
    "  --res N             image size NxN (200)\n"
    "  --random N          random init of N Gaussians in [-1.3,1.3]^3 (the reference's NeRF-synthetic\n"
    "                      init) instead of the scene's surface points\n"
    "  --no-densify        no density control (fixed Gaussian count)\n"
    "  --no-peer           skip the OpenSplat-matched run (2000 Gaussians, no densification, 1000 it)\n"
    "  --work DIR          where the datasets are made (/tmp/mgs-bench-train)\n"
    "  -o, --output DIR    CSV, tables and plot (bench/train)\n"
    "  --threads N         worker threads (all cores)\n"
    "  --method NAME=ARGS  train NAME as `morsegs train DATA --iters N --seed 1 ARGS` (any train option,\n"
    "                      e.g. sugar='--preset sugar' or 2dgs='--model 2dgs'); repeatable, up to 8;\n"
    "                      replaces the default ADC run\n"
    "  --from CSV          no training: reach.md, train.md and the plots again from an earlier train.csv\n"
    "  --reach DB,...      time to reach each test PSNR (reach.md; default: per scene the lowest final\n"
    "                      PSNR of its configurations, so every one reaches it)\n");
}

static int make_scene(const char *name, const char *dir, int res) {
  char ds_json[PATH_MAX];
  snprintf(ds_json, sizeof ds_json, "%s/transforms_train.json", dir);
  if (mgs_path_exists(ds_json)) return 0; /* made by an earlier run */
  char w[16], h[16];
  snprintf(w, sizeof w, "%d", res);
  snprintf(h, sizeof h, "%d", res);
  char *argv[] = {"scene", "--builtin", (char *)name, "-o", (char *)dir, "--width", w, "--height", h, "-q", "--force", NULL};
  return mgs_cmd_scene(11, argv);
}

/* Trains t to each of the given iterations, evaluating the test split there. */
static mgs_status sample_run(mgs_trainer *t, const char *scene, const char *config, int iters, const int *evals,
                             int n_evals, samples *out, mgs_error *err) {
  mgs_status st = MGS_OK;
  double last_s = 0, last_ph[MGS_TRAIN_PHASES] = {0}, cpu_total = 0;
  int last_it = 0;
  printf("%-8s %-10s %6s %9s %9s %9s %9s %8s %10s   %s\n", "scene", "config", "iter", "time s", "ms/iter", "cpu ms/it",
         "PSNR", "SSIM", "Gaussians", "ms/iter: fwd loss bwd strategy adam terms");
  for (int e = 0; e < n_evals && st == MGS_OK; e++) {
    if (evals[e] > iters) break;
    clock_t c0 = clock();
    if ((st = mgs_trainer_run_to(t, evals[e], err))) break; /* the model the reference evaluates at evals[e] */
    double cpu = (double)(clock() - c0) / CLOCKS_PER_SEC;
    sample s;
    memset(&s, 0, sizeof s);
    snprintf(s.scene, sizeof s.scene, "%s", scene);
    snprintf(s.config, sizeof s.config, "%s", config);
    s.iteration = mgs_trainer_model_iteration(t);
    s.seconds = mgs_trainer_seconds(t);
    int done = mgs_trainer_iteration(t), seg = done - last_it > 0 ? done - last_it : 1;
    s.ms_per_iter = 1000.0 * (s.seconds - last_s) / (double)seg;
    s.cpu_ms_per_iter = 1000.0 * cpu / (double)seg;
    cpu_total += cpu;
    s.cpu_seconds = cpu_total;
    s.gaussians = mgs_trainer_model(t)->n;
    double ph[MGS_TRAIN_PHASES];
    mgs_trainer_phase_seconds(t, ph);
    for (int k = 0; k < MGS_TRAIN_PHASES; k++) {
      s.phase_ms[k] = 1000.0 * (ph[k] - last_ph[k]) / (double)seg;
      last_ph[k] = ph[k];
    }
    if ((st = mgs_trainer_evaluate(t, MGS_SPLIT_TEST, 0, &s.psnr, &s.ssim, err))) break;
    last_s = s.seconds;
    last_it = done;
    printf("%-8s %-10s %6d %9.1f %9.2f %9.2f %9.3f %8.4f %10zu   %.1f %.1f %.1f %.1f %.1f %.1f\n", s.scene, s.config,
           s.iteration, s.seconds, s.ms_per_iter, s.cpu_ms_per_iter, s.psnr, s.ssim, s.gaussians, s.phase_ms[0], s.phase_ms[1],
           s.phase_ms[2], s.phase_ms[3], s.phase_ms[4], s.phase_ms[5]);
    fflush(stdout);
    push(out, &s);
  }
  return st;
}

/* Trains one configuration, evaluating the test split at the given iterations. */
static mgs_status run_config(const char *scene, const char *config, const char *dir, int iters, int init_points,
                             int random_init, int densify, const int *evals, int n_evals, samples *out, mgs_error *err) {
  mgs_dataset_options o;
  mgs_dataset_options_default(&o);
  o.load_images = 1;
  mgs_dataset *ds = NULL;
  mgs_status st = mgs_dataset_load(dir, &o, &ds, err);
  if (st) return st;
  mgs_train_options to;
  mgs_train_options_default(&to);
  to.iterations = iters;
  to.seed = 1;
  to.adc.white_background = o.white_background;
  mgs_gaussians *g = NULL;
  if (!random_init && ds->init_points && ds->init_points->n > 0) {
    size_t n = ds->init_points->n;
    if (init_points > 0 && (size_t)init_points < n) n = (size_t)init_points;
    st = mgs_init_from_points(ds->init_points->xyz, ds->init_points->rgb, n, 3, &g, err);
  } else {
    mgs_rng r;
    mgs_rng_init(&r, 1, 1);
    double lo[3] = {-1.3, -1.3, -1.3}, hi[3] = {1.3, 1.3, 1.3};
    st = mgs_init_random(init_points > 0 ? (size_t)init_points : 100000, lo, hi, 3, &r, &g, err);
  }
  mgs_trainer *t = NULL;
  if (st == MGS_OK) st = mgs_trainer_create(ds, &to, g, densify ? mgs_strategy_adc_create(&to.adc) : NULL, &t, err);
  if (st == MGS_OK) st = sample_run(t, scene, config, iters, evals, n_evals, out, err);
  mgs_trainer_destroy(t);
  mgs_dataset_destroy(ds);
  return st;
}

/* Trains one method as `morsegs train DIR --iters N --seed 1 ARGS` would (the one option
 * table and the trainer setup of the train command; nothing is written). */
static mgs_status run_method(const char *scene, const char *name, const char *args, const char *dir, const char *work,
                             int iters, const int *evals, int n_evals, samples *out, mgs_error *err) {
  char *words = mgs_strdup(args), its[16], run[PATH_MAX], *wsave = NULL;
  if (!words) return mgs_error_set(err, MGS_ERR_NOMEM, "out of memory");
  snprintf(its, sizeof its, "%d", iters);
  snprintf(run, sizeof run, "%s/run-%s", work, name);
  char *argv[96] = {"train", (char *)dir, "-o", run, "--iters", its, "--seed", "1"};
  int argc = 8;
  for (char *w = strtok_r(words, " \t", &wsave); w; w = strtok_r(NULL, " \t", &wsave)) {
    if (argc == 95) { free(words); return mgs_error_set(err, MGS_ERR_ARG, "--method %s: too many words", name); }
    argv[argc++] = w;
  }
  mgs_train_config c;
  const char *data = NULL;
  mgs_status st = mgs_config_parse(&c, argc, argv, &data, err);
  if (st == MGS_OK) st = mgs_config_validate(&c, 1, err);
  mgs_dataset *ds = NULL;
  if (st == MGS_OK) {
    mgs_dataset_options dopt;
    mgs_config_dataset_options(&c, &dopt);
    dopt.load_images = 1;
    st = mgs_dataset_load(dir, &dopt, &ds, err);
  }
  mgs_train_setup su = {0};
  if (st == MGS_OK) {
    mgs_train_options o;
    mgs_config_train_options(&c, &o);
    o.progress = 0;
    o.checkpoint_every = 0;
    st = mgs_train_setup_create(&c, ds, &o, NULL, 0, &su, err);
  }
  if (st == MGS_OK) st = sample_run(su.trainer, scene, name, c.iters, evals, n_evals, out, err);
  if (st && !strstr(err->msg, "--method")) {
    char m[sizeof err->msg];
    snprintf(m, sizeof m, "%s", err->msg);
    mgs_error_set(err, st, "--method %s: %s", name, m);
  }
  if (su.trainer) mgs_train_setup_destroy(&su);
  mgs_dataset_destroy(ds);
  free(words);
  return st;
}

/* Time to quality: for each scene, configuration and target PSNR, the training time at
 * which the test PSNR first reaches the target, interpolated linearly between the two
 * evaluations around the crossing (the evaluations are the only PSNRs known). Targets:
 * the given list, else per scene the lowest final PSNR of its configurations rounded
 * down to 0.1 dB (a quality every configuration reaches). Writes a Markdown table. */
static void write_reach(const samples *ss, const double *targets, int n_targets, FILE *f) {
  fprintf(f, "| scene | config | target PSNR dB | reached at iteration | wall s | CPU s (all threads) |\n"
             "|---|---|---|---|---|---|\n");
  for (size_t i = 0; i < ss->n;) {
    size_t scene_end = i;
    while (scene_end < ss->n && !strcmp(ss->s[scene_end].scene, ss->s[i].scene)) scene_end++;
    double tg[16];
    int nt = n_targets;
    if (nt > 0) memcpy(tg, targets, sizeof(double) * (size_t)nt);
    else {
      double lowest = 1e9;
      for (size_t j = i; j < scene_end;) {
        size_t k = j;
        while (k < scene_end && !strcmp(ss->s[k].config, ss->s[j].config)) k++;
        if (strcmp(ss->s[j].config, "peer-2000")) lowest = fmin(lowest, ss->s[k - 1].psnr);
        j = k;
      }
      tg[0] = floor(lowest * 10.0) / 10.0;
      nt = lowest < 1e9 ? 1 : 0;
    }
    for (int t = 0; t < nt; t++)
      for (size_t j = i; j < scene_end;) {
        size_t k = j;
        while (k < scene_end && !strcmp(ss->s[k].config, ss->s[j].config)) k++;
        const sample *a = NULL, *b = NULL;
        for (size_t q = j; q < k; q++)
          if (ss->s[q].psnr >= tg[t]) { b = &ss->s[q]; a = q > j ? &ss->s[q - 1] : NULL; break; }
        if (!strcmp(ss->s[j].config, "peer-2000")) { j = k; continue; }
        if (!b)
          fprintf(f, "| %s | %s | %.2f | not reached by %d (%.2f dB) | – | – |\n", ss->s[j].scene, ss->s[j].config, tg[t],
                  ss->s[k - 1].iteration, ss->s[k - 1].psnr);
        else {
          double w = a && b->psnr > a->psnr ? (tg[t] - a->psnr) / (b->psnr - a->psnr) : 1.0;
          double wall = a ? a->seconds + w * (b->seconds - a->seconds) : b->seconds;
          double cpu = a ? a->cpu_seconds + w * (b->cpu_seconds - a->cpu_seconds) : b->cpu_seconds;
          double it = a ? a->iteration + w * (b->iteration - a->iteration) : b->iteration;
          fprintf(f, "| %s | %s | %.2f | %.0f (between %d and %d) | %.1f | %.1f |\n", ss->s[j].scene, ss->s[j].config, tg[t], it,
                  a ? a->iteration : 0, b->iteration, wall, cpu);
        }
        j = k;
      }
    i = scene_end;
  }
}

/* x: the sample's wall seconds, or its CPU seconds (on a shared machine the robust one) */
static double xval(const sample *s, int cpu) { return cpu ? s->cpu_seconds : s->seconds; }

static void plot(const samples *ss, const char *path, int cpu) {
  const int W = 800, H = 500, L = 70, R = 20, T = 30, B = 50;
  double tmax = 0, pmin = 1e9, pmax = -1e9;
  for (size_t i = 0; i < ss->n; i++) {
    tmax = fmax(tmax, xval(&ss->s[i], cpu));
    pmin = fmin(pmin, ss->s[i].psnr);
    pmax = fmax(pmax, ss->s[i].psnr);
  }
  if (ss->n == 0 || tmax <= 0) return;
  pmin = floor(pmin) - 1; pmax = ceil(pmax) + 1;
  cairo_surface_t *sf = cairo_image_surface_create(CAIRO_FORMAT_RGB24, W, H);
  cairo_t *cr = cairo_create(sf);
  cairo_set_source_rgb(cr, 1, 1, 1);
  cairo_paint(cr);
  cairo_set_source_rgb(cr, 0, 0, 0);
  cairo_set_line_width(cr, 1);
  cairo_rectangle(cr, L, T, W - L - R, H - T - B);
  cairo_stroke(cr);
  cairo_select_font_face(cr, "sans-serif", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
  cairo_set_font_size(cr, 12);
  char buf[96];
  for (int k = 0; k <= 5; k++) {
    double tx = tmax * k / 5, py = pmin + (pmax - pmin) * k / 5;
    double x = L + (W - L - R) * k / 5.0, y = H - B - (H - T - B) * k / 5.0;
    snprintf(buf, sizeof buf, "%.0f", tx);
    cairo_move_to(cr, x - 10, H - B + 18); cairo_show_text(cr, buf);
    snprintf(buf, sizeof buf, "%.1f", py);
    cairo_move_to(cr, 20, y + 4); cairo_show_text(cr, buf);
  }
  cairo_move_to(cr, W / 2 - 60, H - 12); cairo_show_text(cr, cpu ? "training CPU time, all threads (s)" : "training wall time (s)");
  cairo_move_to(cr, L, 20); cairo_show_text(cr, "test PSNR (dB) against training time, morsegs bench train");
  static const double col[6][3] = {{0.8, 0.1, 0.1}, {0.1, 0.4, 0.8}, {0.1, 0.6, 0.2}, {0.6, 0.3, 0.7}, {0.9, 0.5, 0.0}, {0.3, 0.3, 0.3}};
  int series = 0;
  for (size_t i = 0; i < ss->n;) {
    size_t j = i;
    while (j < ss->n && !strcmp(ss->s[j].scene, ss->s[i].scene) && !strcmp(ss->s[j].config, ss->s[i].config)) j++;
    const double *c = col[series % 6];
    cairo_set_source_rgb(cr, c[0], c[1], c[2]);
    cairo_set_line_width(cr, 2);
    for (size_t k = i; k < j; k++) {
      double x = L + (W - L - R) * xval(&ss->s[k], cpu) / tmax;
      double y = H - B - (H - T - B) * (ss->s[k].psnr - pmin) / (pmax - pmin);
      if (k == i) cairo_move_to(cr, x, y); else cairo_line_to(cr, x, y);
    }
    cairo_stroke(cr);
    for (size_t k = i; k < j; k++) {
      double x = L + (W - L - R) * xval(&ss->s[k], cpu) / tmax;
      double y = H - B - (H - T - B) * (ss->s[k].psnr - pmin) / (pmax - pmin);
      cairo_arc(cr, x, y, 3, 0, 2 * MGS_PI);
      cairo_fill(cr);
    }
    snprintf(buf, sizeof buf, "%s / %s", ss->s[i].scene, ss->s[i].config);
    cairo_move_to(cr, W - R - 190, H - B - 20 - 16 * series);
    cairo_show_text(cr, buf);
    series++;
    i = j;
  }
  cairo_destroy(cr);
  cairo_surface_write_to_png(sf, path);
  cairo_surface_destroy(sf);
}

int mgs_bench_train(int argc, char **argv) {
  static const struct option opts[] = {{"full", no_argument, 0, 'F'}, {"scenes", required_argument, 0, 's'},
                                       {"iters", required_argument, 0, 'i'}, {"res", required_argument, 0, 'r'},
                                       {"no-peer", no_argument, 0, 'P'}, {"random", required_argument, 0, 'R'},
                                       {"no-densify", no_argument, 0, 'D'}, {"work", required_argument, 0, 'w'},
                                       {"output", required_argument, 0, 'o'}, {"threads", required_argument, 0, 't'},
                                       {"method", required_argument, 0, 'm'}, {"reach", required_argument, 0, 'T'},
                                       {"from", required_argument, 0, 'f'},
                                       {"help", no_argument, 0, 'h'},
                                       {0, 0, 0, 0}};
  int full = 0, iters = 0, res = 200, peer = 1, threads = 0, random_n = 0, densify = 1, c;
  const char *scenes = NULL, *work = "/tmp/mgs-bench-train", *out = "bench/train", *methods[8], *from = NULL;
  int n_methods = 0, n_targets = 0;
  double targets[16];
  optind = 1;
  while ((c = getopt_long(argc, argv, "o:h", opts, NULL)) != -1) {
    switch (c) {
      case 'F': full = 1; break;
      case 's': scenes = optarg; break;
      case 'i': iters = atoi(optarg); if (iters < 1) { fprintf(stderr, "morsegs bench train: --iters needs N >= 1\n"); return 2; } break;
      case 'r': res = atoi(optarg); if (res < 16) { fprintf(stderr, "morsegs bench train: --res needs N >= 16\n"); return 2; } break;
      case 'P': peer = 0; break;
      case 'R': random_n = atoi(optarg); if (random_n < 1) { fprintf(stderr, "morsegs bench train: --random needs N >= 1\n"); return 2; } break;
      case 'D': densify = 0; break;
      case 'w': work = optarg; break;
      case 'o': out = optarg; break;
      case 't': threads = atoi(optarg); break;
      case 'm': {
        const char *eq = strchr(optarg, '=');
        if (!eq || eq == optarg || eq - optarg > 31 || n_methods == 8) {
          fprintf(stderr, "morsegs bench train: --method needs NAME=ARGS (NAME 1-31 characters, at most 8 methods): '%s'\n", optarg);
          return 2;
        }
        methods[n_methods++] = optarg;
        break;
      }
      case 'f': from = optarg; break;
      case 'T': {
        n_targets = 0;
        for (const char *p = optarg; *p && n_targets < 16;) {
          char *end;
          double v = strtod(p, &end);
          if (end == p || !(v > 0 && v < 100) || (*end && *end != ',')) {
            fprintf(stderr, "morsegs bench train: --reach needs PSNR targets in dB, e.g. 30,33: '%s'\n", optarg);
            return 2;
          }
          targets[n_targets++] = v;
          p = *end ? end + 1 : end;
        }
        break;
      }
      case 'h': usage(stdout); return 0;
      default: usage(stderr); return 2;
    }
  }
  if (threads > 0) mgs_parallel_set_threads(threads);
  if (!scenes) scenes = full ? "sphere,genus2,thin" : "sphere";
  if (!iters) iters = full ? 7000 : 2000;
  mgs_log_set_level(MGS_LOG_WARN);
  mgs_error err;
  mgs_error_clear(&err);
  if ((!from && mgs_mkdir_p(work, &err)) || mgs_mkdir_p(out, &err)) return mgs_cli_fail("bench train", &err);
  /* Evaluated as the reference does: at iteration N, the model before N's densification
     and opacity reset (mgs_trainer_run_to), so reset iterations need no detour. */
  static const int evals[] = {100, 250, 500, 1000, 1500, 2000, 2500, 3000, 3500, 4000, 5000, 6000, 6500, 7000,
                              10000, 15000, 20000, 30000};
  int n_evals = (int)(sizeof evals / sizeof *evals);
  int my_evals[32], nm = 0;
  for (int e = 0; e < n_evals; e++) if (evals[e] < iters) my_evals[nm++] = evals[e];
  my_evals[nm++] = iters;
  samples ss = {0};
  if (from) {
    if (mgs_mkdir_p(out, &err) || read_csv(from, &ss, &err)) { free(ss.s); return mgs_cli_fail("bench train", &err); }
    peer = 0;
    scenes = "";
  }
  char *list = mgs_strdup(scenes);
  if (!from) printf("morsegs bench train: %d iterations at %dx%d, %d threads\n", iters, res, res, mgs_parallel_max_threads());
  char *lsave = NULL;
  mgs_status st = MGS_OK;
  for (char *tok = strtok_r(list, ",", &lsave); tok && st == MGS_OK; tok = strtok_r(NULL, ",", &lsave)) {
    char dir[PATH_MAX];
    snprintf(dir, sizeof dir, "%s/%s_%d", work, tok, res);
    if (make_scene(tok, dir, res) != 0) { st = mgs_error_set(&err, MGS_ERR_ARG, "cannot make the built-in scene '%s'", tok); break; }
    for (int m = 0; m < n_methods && st == MGS_OK; m++) {
      char name[32];
      const char *eq = strchr(methods[m], '=');
      snprintf(name, sizeof name, "%.*s", (int)(eq - methods[m]), methods[m]);
      st = run_method(tok, name, eq + 1, dir, work, iters, my_evals, nm, &ss, &err);
    }
    if (n_methods || st) continue;
    char cfgname[32];
    snprintf(cfgname, sizeof cfgname, "%s%s", densify ? "adc" : "fixed", random_n ? "-random" : "");
    st = run_config(tok, cfgname, dir, iters, random_n, random_n > 0, densify, my_evals, nm, &ss, &err);
  }
  if (st == MGS_OK && peer) {
    /* matched to PEERS.md's OpenSplat rows: 200x200, 2000 Gaussians, SH 3, no densification */
    char dir[PATH_MAX];
    snprintf(dir, sizeof dir, "%s/sphere_200", work);
    static const int pe[] = {300, 1000};
    if (make_scene("sphere", dir, 200) != 0) st = mgs_error_set(&err, MGS_ERR_ARG, "cannot make the built-in scene 'sphere'");
    else st = run_config("sphere", "peer-2000", dir, 1000, 2000, 0, 0, pe, 2, &ss, &err);
  }
  free(list);
  if (st) { free(ss.s); return mgs_cli_fail("bench train", &err); }
  char path[PATH_MAX];
  snprintf(path, sizeof path, "%s/train.csv", out);
  FILE *f = fopen(path, "w");
  if (f) {
    fprintf(f, "scene,config,iteration,train_seconds,ms_per_iter,cpu_ms_per_iter,gaussians,test_psnr,test_ssim,fwd_ms,loss_ms,bwd_ms,strategy_ms,adam_ms,terms_ms,cpu_seconds\n");
    for (size_t i = 0; i < ss.n; i++)
      fprintf(f, "%s,%s,%d,%.3f,%.3f,%.3f,%zu,%.4f,%.5f,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f\n", ss.s[i].scene, ss.s[i].config, ss.s[i].iteration,
              ss.s[i].seconds, ss.s[i].ms_per_iter, ss.s[i].cpu_ms_per_iter, ss.s[i].gaussians, ss.s[i].psnr, ss.s[i].ssim, ss.s[i].phase_ms[0],
              ss.s[i].phase_ms[1], ss.s[i].phase_ms[2], ss.s[i].phase_ms[3], ss.s[i].phase_ms[4], ss.s[i].phase_ms[5], ss.s[i].cpu_seconds);
    fclose(f);
  }
  snprintf(path, sizeof path, "%s/train.md", out);
  f = fopen(path, "w");
  if (f) {
    fprintf(f, "| scene | config | iteration | train time (s) | ms/iteration (segment) | CPU ms/iteration (all threads) | fwd / loss / bwd / strategy / Adam / terms ms | Gaussians | test PSNR (dB) | test SSIM |\n");
    fprintf(f, "|---|---|---|---|---|---|---|---|---|---|\n");
    for (size_t i = 0; i < ss.n; i++)
      fprintf(f, "| %s | %s | %d | %.1f | %.2f | %.2f | %.1f / %.1f / %.1f / %.1f / %.1f / %.1f | %zu | %.2f | %.4f |\n", ss.s[i].scene,
              ss.s[i].config, ss.s[i].iteration, ss.s[i].seconds, ss.s[i].ms_per_iter, ss.s[i].cpu_ms_per_iter, ss.s[i].phase_ms[0],
              ss.s[i].phase_ms[1], ss.s[i].phase_ms[2], ss.s[i].phase_ms[3], ss.s[i].phase_ms[4], ss.s[i].phase_ms[5], ss.s[i].gaussians,
              ss.s[i].psnr, ss.s[i].ssim);
    fclose(f);
  }
  snprintf(path, sizeof path, "%s/reach.md", out);
  f = fopen(path, "w");
  if (f) {
    write_reach(&ss, targets, n_targets, f);
    fclose(f);
  }
  snprintf(path, sizeof path, "%s/train.png", out);
  plot(&ss, path, 0);
  snprintf(path, sizeof path, "%s/train_cpu.png", out);
  plot(&ss, path, 1);
  printf("wrote %s/train.csv, %s/train.md, %s/reach.md (time to reach a test PSNR), %s/train.png and train_cpu.png (PSNR "
         "against wall and CPU time)\n", out, out, out, out);
  free(ss.s);
  return 0;
}

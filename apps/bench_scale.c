/* morsegs bench scale: how the cost of training follows the scene's size. The builtin
 * city at N = 1, 2, 4 (1x, 4x, 16x the content, the same content per view), trained for
 * a fixed number of iterations (no densification, so counts stay put) in two settings:
 *   reference  every Gaussian projected and stepped, all images in memory as floats;
 *   scale      tile visibility, sparse Adam, images streamed through an 8-bit cache;
 * each run in its own process (so peak RSS is that run's), all runs in one invocation
 * (compare within it: the machine may be shared). Reports seconds per iteration, peak
 * RSS, the marginal resident bytes per Gaussian between N = 1 and the largest N, the
 * bytes per Gaussian of the training state by component, the image-cache hit rate, and
 * the Morse analysis' seconds from scratch and incremental after one block changed.
 * Writes OUT/scale.md, OUT/scale.csv and OUT/scale.png. */
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <cairo.h>
#include "apps/mgs_cli.h"
#include "assets/mgs_assets.h"
#include "core/mgs_core.h"
#include "core/mgs_image_cache.h"
#include "render/mgs_scene.h"
#include "train/mgs_train.h"
#include "train/mgs_strategy.h"
#include "train/mgs_morse.h"

enum { CONF_REF = 0, CONF_SCALE = 1, N_CONF = 2 };
static const char *conf_name[N_CONF] = {"reference", "scale"};
#define MAX_SIZES 4

typedef struct result {
  int size, conf, ok;
  size_t gaussians, views;
  double s_per_iter, peak_mb, listed, hit_rate, setup_s, loss, fwd_ms, bwd_ms;
  /* Morse analysis of the trained model (scale runs): from scratch, then again after one
     corner block of the city changed, incremental (-1: not measured) */
  /* analysis seconds: total, α, SDF, persistence; from scratch and after one block changed */
  double an_full[4], an_incr[4], an_reused, an_leaves, an_sdf_reused, an_sdf_leaves, an_pers_reused, an_pers_leaves;
} result;

/* ---- child: one training run, one line of results on stdout ---- */
static int child(const char *data, int conf, int iters, int warmup, int cache_mb, int size, int analysis) {
  mgs_error err;
  mgs_error_clear(&err);
  mgs_dataset_options dopt;
  mgs_dataset_options_default(&dopt);
  dopt.load_images = conf == CONF_REF;
  double t0 = mgs_now();
  mgs_dataset *ds = NULL;
  mgs_status st = mgs_dataset_load(data, &dopt, &ds, &err);
  if (st) return mgs_cli_fail("bench scale", &err);
  if (!ds->init_points) { fprintf(stderr, "bench scale: %s has no points3d.ply\n", data); return 1; }
  mgs_train_options o;
  mgs_train_options_default(&o);
  o.iterations = iters + 1; /* the last iteration does no optimizer step */
  o.sh_degree = 3;
  o.sh_every = 1000000;     /* SH 0 throughout: the same work every iteration */
  o.adc.densify_from = 1 << 30; /* no densification: counts stay put */
  o.adc.opacity_reset_every = 0;
  o.visibility = conf == CONF_SCALE;
  o.sparse_adam = conf == CONF_SCALE;
  o.image_cache_mb = conf == CONF_SCALE ? (size_t)cache_mb : 0;
  mgs_gaussians *g0 = NULL;
  st = mgs_init_from_points(ds->init_points->xyz, ds->init_points->rgb, ds->init_points->n, o.sh_degree, &g0, &err);
  mgs_trainer *t = NULL;
  if (!st) st = mgs_trainer_create(ds, &o, g0, mgs_strategy_adc_create(&o.adc), &t, &err);
  if (st) { mgs_dataset_destroy(ds); return mgs_cli_fail("bench scale", &err); }
  double setup = mgs_now() - t0;
  double ph0[MGS_TRAIN_PHASES], ph1[MGS_TRAIN_PHASES];
  if (!st) st = mgs_trainer_run_until(t, warmup, &err);
  mgs_trainer_phase_seconds(t, ph0);
  double t1 = mgs_now();
  if (!st) st = mgs_trainer_run_until(t, iters, &err);
  double t2 = mgs_now();
  mgs_trainer_phase_seconds(t, ph1);
  double per = 1e3 / (double)(iters - warmup);
  if (st) { mgs_trainer_destroy(t); mgs_dataset_destroy(ds); return mgs_cli_fail("bench scale", &err); }
  double listed = 0;
  mgs_trainer_visibility_stats(t, &listed, NULL, NULL);
  size_t hits = 0, misses = 0;
  mgs_trainer_image_cache_stats(t, &hits, &misses, NULL);
  printf("RESULT %d %d %zu %zu %.6f %.3f %.1f %.4f %.3f %.6f %.3f %.3f\n", size, conf, mgs_trainer_model(t)->n,
         ds->n_views[MGS_SPLIT_TRAIN], (t2 - t1) / (double)(iters - warmup), (double)mgs_peak_rss() / 1048576.0,
         conf == CONF_SCALE ? listed : (double)mgs_trainer_model(t)->n,
         hits + misses ? (double)hits / (double)(hits + misses) : -1.0, setup, mgs_trainer_last_loss(t),
         (ph1[0] - ph0[0]) * per, (ph1[2] + ph1[4] - ph0[2] - ph0[4]) * per);
  fflush(stdout);
  if (conf == CONF_SCALE && analysis) {
    /* the Morse analysis at a fixed voxel size (128 voxels along the diagonal of city 1),
       from scratch, then after the Gaussians of one corner block (1/N² of the city) changed
       their opacity: incremental, only that block's α leaves rebuilt */
    mgs_gaussians *g = mgs_gaussians_clone(mgs_trainer_model(t));
    mgs_morse_options mo;
    mgs_morse_options_default(&mo);
    mo.topo = MGS_MORSE_TOPO_ELIMINATE; /* so the persistence is computed */
    mo.warmup = 1; mo.every = 1; mo.until = 1 << 30;
    mo.resolution = 128 * size;
    mo.eps_sig /= size; mo.eps_p /= size; /* thresholds, and so the band, fixed in world units */
    mo.incremental = 1;
    mgs_morse_ctx *mc = NULL;
    double lo[3], hi[3];
    if (g && mgs_points_bounds_robust(g->mean, g->n, lo, hi) && !mgs_morse_ctx_create(&mo, NULL, &mc, &err) &&
        !mgs_morse_analyze(mc, g, 1, &err)) {
      mgs_morse_result a = *mgs_morse_ctx_result(mc);
      for (size_t i = 0; i < g->n; i++)
        if (g->mean[3 * i] < lo[0] + (hi[0] - lo[0]) / size && g->mean[3 * i + 1] < lo[1] + (hi[1] - lo[1]) / size)
          g->opacity[i] += 0.5f;
      if (!mgs_morse_analyze(mc, g, 2, &err)) {
        const mgs_morse_result *b = mgs_morse_ctx_result(mc);
        printf("ANALYSIS %.4f %.4f %.4f %.4f %.4f %.4f %.4f %.4f %zu %zu %zu %zu %zu %zu\n", a.seconds[5], a.seconds[0], a.seconds[1],
               a.seconds[2], b->seconds[5], b->seconds[0], b->seconds[1], b->seconds[2], b->leaves_reused, b->leaves,
               b->sdf_leaves_reused, b->sdf_leaves, b->pers_leaves_reused, b->pers_leaves);
      }
    }
    if (err.msg[0]) fprintf(stderr, "bench scale: analysis: %s\n", err.msg);
    mgs_morse_ctx_unref(mc);
    mgs_gaussians_destroy(g);
  }
  mgs_trainer_destroy(t);
  mgs_dataset_destroy(ds);
  return 0;
}

static int run_child(const char *self, const char *data, int conf, int iters, int warmup, int cache_mb, int size,
                     int analysis, result *r) {
  char cmd[8192];
  snprintf(cmd, sizeof cmd, "'%s' bench scale --child '%s' --conf %d --iters %d --warmup %d --cache-mb %d --sizes %d%s",
           self, data, conf, iters, warmup, cache_mb, size, analysis ? "" : " --no-analysis");
  FILE *p = popen(cmd, "r");
  if (!p) return 0;
  char line[512];
  int ok = 0;
  for (int k = 0; k < 4; k++) r->an_full[k] = r->an_incr[k] = -1;
  r->an_reused = r->an_leaves = r->an_sdf_reused = r->an_sdf_leaves = r->an_pers_reused = r->an_pers_leaves = -1;
  while (fgets(line, sizeof line, p)) {
    sscanf(line, "ANALYSIS %lf %lf %lf %lf %lf %lf %lf %lf %lf %lf %lf %lf %lf %lf", &r->an_full[0], &r->an_full[1], &r->an_full[2],
           &r->an_full[3], &r->an_incr[0], &r->an_incr[1], &r->an_incr[2], &r->an_incr[3], &r->an_reused, &r->an_leaves,
           &r->an_sdf_reused, &r->an_sdf_leaves, &r->an_pers_reused, &r->an_pers_leaves);
    if (sscanf(line, "RESULT %d %d %zu %zu %lf %lf %lf %lf %lf %lf %lf %lf", &r->size, &r->conf, &r->gaussians, &r->views,
               &r->s_per_iter, &r->peak_mb, &r->listed, &r->hit_rate, &r->setup_s, &r->loss, &r->fwd_ms, &r->bwd_ms) == 12)
      ok = 1;
  }
  int rc = pclose(p);
  r->ok = ok && rc == 0;
  return r->ok;
}

/* ---- plot: seconds per iteration and peak RSS against the content multiple ---- */
static void plot(const result *res, int n_sizes, const int *sizes, const char *path) {
  const int W = 900, H = 420, L = 70, R = 20, T = 40, B = 50, gap = 80;
  int pw = (W - L - R - gap) / 2;
  cairo_surface_t *sf = cairo_image_surface_create(CAIRO_FORMAT_RGB24, W, H);
  cairo_t *cr = cairo_create(sf);
  cairo_set_source_rgb(cr, 1, 1, 1);
  cairo_paint(cr);
  cairo_select_font_face(cr, "sans-serif", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
  cairo_set_font_size(cr, 12);
  static const double col[N_CONF][3] = {{0.80, 0.25, 0.15}, {0.15, 0.40, 0.80}};
  for (int panel = 0; panel < 2; panel++) {
    int x0 = L + panel * (pw + gap);
    double ymax = 0;
    for (int k = 0; k < n_sizes * N_CONF; k++)
      if (res[k].ok) ymax = fmax(ymax, panel ? res[k].peak_mb : res[k].s_per_iter);
    ymax = ymax > 0 ? ymax * 1.15 : 1;
    cairo_set_source_rgb(cr, 0, 0, 0);
    cairo_set_line_width(cr, 1);
    cairo_rectangle(cr, x0, T, pw, H - T - B);
    cairo_stroke(cr);
    char buf[96];
    for (int tk = 0; tk <= 4; tk++) {
      double v = ymax * tk / 4, y = H - B - (H - T - B) * tk / 4.0;
      snprintf(buf, sizeof buf, panel ? "%.0f" : "%.3f", v);
      cairo_move_to(cr, x0 - 52, y + 4);
      cairo_show_text(cr, buf);
    }
    /* x: log4 of the content multiple N^2 */
    double xmax = log((double)sizes[n_sizes - 1] * sizes[n_sizes - 1]) / log(4.0);
    for (int s = 0; s < n_sizes; s++) {
      double xs = xmax > 0 ? log((double)sizes[s] * sizes[s]) / log(4.0) / xmax : 0.5;
      snprintf(buf, sizeof buf, "%dx", sizes[s] * sizes[s]);
      cairo_move_to(cr, x0 + 20 + (pw - 40) * xs - 8, H - B + 18);
      cairo_show_text(cr, buf);
    }
    cairo_move_to(cr, x0 + pw / 2 - 70, H - 12);
    cairo_show_text(cr, "content (city N x N blocks)");
    cairo_move_to(cr, x0, T - 12);
    cairo_show_text(cr, panel ? "peak RSS (MiB)" : "seconds per iteration");
    for (int c = 0; c < N_CONF; c++) {
      cairo_set_source_rgb(cr, col[c][0], col[c][1], col[c][2]);
      cairo_set_line_width(cr, 2);
      int started = 0;
      for (int s = 0; s < n_sizes; s++) {
        const result *r = &res[s * N_CONF + c];
        if (!r->ok) continue;
        double xs = xmax > 0 ? log((double)sizes[s] * sizes[s]) / log(4.0) / xmax : 0.5;
        double x = x0 + 20 + (pw - 40) * xs, y = H - B - (H - T - B) * (panel ? r->peak_mb : r->s_per_iter) / ymax;
        if (!started) cairo_move_to(cr, x, y); else cairo_line_to(cr, x, y);
        started = 1;
      }
      cairo_stroke(cr);
      for (int s = 0; s < n_sizes; s++) {
        const result *r = &res[s * N_CONF + c];
        if (!r->ok) continue;
        double xs = xmax > 0 ? log((double)sizes[s] * sizes[s]) / log(4.0) / xmax : 0.5;
        cairo_arc(cr, x0 + 20 + (pw - 40) * xs, H - B - (H - T - B) * (panel ? r->peak_mb : r->s_per_iter) / ymax, 3.5, 0,
                  2 * MGS_PI);
        cairo_fill(cr);
      }
      cairo_move_to(cr, x0 + 10, T + 18 + 16 * c);
      cairo_show_text(cr, conf_name[c]);
    }
  }
  cairo_destroy(cr);
  cairo_surface_write_to_png(sf, path);
  cairo_surface_destroy(sf);
}

static void usage(FILE *f) {
  fprintf(f,
          "usage: morsegs bench scale [options]\n"
          "  --sizes LIST     city sizes N (1,2,4): N x N blocks, N^2 times the content\n"
          "  --iters N        training iterations per run (60), of which --warmup N (10) untimed\n"
          "  --res PX         image width and height (160)\n"
          "  --cache-mb M     image cache of the scale runs (4)\n"
          "  --points N       initial points (= Gaussians) per city block (10000); e.g. --sizes 8 --points 156250\n"
          "                   trains 10M Gaussians\n"
          "  --configs LIST   reference,scale (both)\n"
          "  --no-analysis    skip the Morse analysis of the trained scale models\n"
          "  --data DIR       keep the city datasets here (reused when present; default a temp folder)\n"
          "  -o, --output DIR scale.md, scale.csv, scale.png (bench/scale)\n");
}

int mgs_bench_scale(int argc, char **argv) {
  static const struct option longopts[] = {
      {"sizes", required_argument, 0, 's'}, {"iters", required_argument, 0, 'i'}, {"warmup", required_argument, 0, 'w'},
      {"res", required_argument, 0, 'r'}, {"cache-mb", required_argument, 0, 'c'}, {"data", required_argument, 0, 'd'},
      {"output", required_argument, 0, 'o'}, {"child", required_argument, 0, 'C'}, {"conf", required_argument, 0, 'k'},
      {"points", required_argument, 0, 'p'}, {"configs", required_argument, 0, 'g'}, {"no-analysis", no_argument, 0, 'n'},
      {"help", no_argument, 0, 'h'}, {0, 0, 0, 0}};
  const char *sizes_arg = "1,2,4", *data = NULL, *out = "bench/scale", *child_data = NULL;
  int iters = 60, warmup = 10, res = 160, cache_mb = 4, conf = 0, analysis = 1, run_conf[N_CONF] = {1, 1};
  long points = 10000;
  optind = 1;
  opterr = 0;
  int c;
  while ((c = getopt_long(argc, argv, "o:h", longopts, NULL)) != -1) {
    switch (c) {
    case 's': sizes_arg = optarg; break;
    case 'i': iters = atoi(optarg); break;
    case 'w': warmup = atoi(optarg); break;
    case 'r': res = atoi(optarg); break;
    case 'c': cache_mb = atoi(optarg); break;
    case 'd': data = optarg; break;
    case 'o': out = optarg; break;
    case 'C': child_data = optarg; break;
    case 'k': conf = atoi(optarg); break;
    case 'p': points = strtol(optarg, NULL, 10); break;
    case 'n': analysis = 0; break;
    case 'g':
      run_conf[CONF_REF] = strstr(optarg, "reference") != NULL;
      run_conf[CONF_SCALE] = strstr(optarg, "scale") != NULL;
      break;
    case 'h': usage(stdout); return 0;
    default: fprintf(stderr, "morsegs bench scale: bad option %s\n", argv[optind - 1]); usage(stderr); return 2;
    }
  }
  int sizes[MAX_SIZES], n_sizes = 0;
  for (const char *p = sizes_arg; *p && n_sizes < MAX_SIZES;) {
    char *end;
    long v = strtol(p, &end, 10);
    if (end == p || v < 1 || v > 16) { fprintf(stderr, "morsegs bench scale: bad --sizes '%s'\n", sizes_arg); return 2; }
    sizes[n_sizes++] = (int)v;
    p = *end == ',' ? end + 1 : end;
    if (*end && *end != ',') { fprintf(stderr, "morsegs bench scale: bad --sizes '%s'\n", sizes_arg); return 2; }
  }
  if (iters < 2 || warmup < 0 || warmup >= iters || res < 16 || res > 4096 || cache_mb < 1 || conf < 0 || conf >= N_CONF ||
      points < 1 || points > 100000000 || !(run_conf[0] || run_conf[1])) {
    fprintf(stderr, "morsegs bench scale: bad --iters/--warmup/--res/--cache-mb/--points/--configs\n");
    return 2;
  }
  if (child_data) return child(child_data, conf, iters, warmup, cache_mb, sizes[0], analysis);

  char self[4096];
  ssize_t sl = readlink("/proc/self/exe", self, sizeof self - 1);
  if (sl <= 0) { fprintf(stderr, "morsegs bench scale: cannot find its own executable\n"); return 1; }
  self[sl] = 0;
  char tmpl[] = "/tmp/mgs-bench-scale-XXXXXX";
  const char *base = data;
  if (!base) {
    if (!mkdtemp(tmpl)) { fprintf(stderr, "morsegs bench scale: cannot make a temp folder\n"); return 1; }
    base = tmpl;
  }
  mgs_error err;
  mgs_error_clear(&err);
  char load0[128] = "", load1[128] = "";
  FILE *lf = fopen("/proc/loadavg", "r");
  if (lf) { if (!fgets(load0, sizeof load0, lf)) load0[0] = 0; fclose(lf); }
  load0[strcspn(load0, "\n")] = 0;
  result results[MAX_SIZES * N_CONF];
  memset(results, 0, sizeof results);
  char dirs[MAX_SIZES][4096];
  for (int s = 0; s < n_sizes; s++) {
    if (points == 10000) snprintf(dirs[s], sizeof dirs[s], "%s/city%d_%d", base, sizes[s], res);
    else snprintf(dirs[s], sizeof dirs[s], "%s/city%d_%d_p%ld", base, sizes[s], res, points);
    if (mgs_path_exists(dirs[s])) continue;
    mgs_mesh *mesh = NULL;
    if (mgs_assets_city(sizes[s], 1, &mesh, &err) != MGS_OK) return mgs_cli_fail("bench scale", &err);
    mgs_scene_options o;
    mgs_scene_options_default(&o);
    o.city_size = sizes[s];
    o.n_train = 16 * sizes[s] * sizes[s];
    o.n_test = 0;
    o.width = o.height = res;
    o.spp = 2;
    o.init_points = (size_t)points * (size_t)sizes[s] * (size_t)sizes[s];
    o.quiet = 1;
    o.mesh_name = "builtin:city";
    double t0 = mgs_now();
    mgs_status st = mgs_scene_render_dataset(mesh, &o, dirs[s], &err);
    mgs_mesh_destroy(mesh);
    if (st) return mgs_cli_fail("bench scale", &err);
    printf("city %d: %d views rendered in %.1f s\n", sizes[s], o.n_train, mgs_now() - t0);
  }
  for (int s = 0; s < n_sizes; s++)
    for (int k = 0; k < N_CONF; k++) {
      result *r = &results[s * N_CONF + k];
      if (!run_conf[k]) continue;
      if (!run_child(self, dirs[s], k, iters, warmup, cache_mb, sizes[s], analysis, r))
        fprintf(stderr, "morsegs bench scale: the %s run at N = %d failed\n", conf_name[k], sizes[s]);
      else
        printf("N=%d %-9s %7zu Gaussians %4zu views: %.4f s/iter (fwd %.1f ms, bwd+Adam %.1f ms), peak RSS %.0f MiB, "
               "%.0f projected/iter, hit rate %s%.2f\n",
               sizes[s], conf_name[k], r->gaussians, r->views, r->s_per_iter, r->fwd_ms, r->bwd_ms, r->peak_mb, r->listed,
               r->hit_rate < 0 ? "-" : "", r->hit_rate < 0 ? 0.0 : r->hit_rate);
      if (r->an_full[0] >= 0)
        printf("N=%d Morse analysis %.2f s (alpha %.2f, SDF %.2f, persistence %.2f s); after one block changed, incremental "
               "%.2f s (alpha %.2f, SDF %.2f, persistence %.2f s; %.0f of %.0f alpha leaves, %.0f of %.0f SDF leaves, %.0f of %.0f "
               "persistence leaves reused)\n",
               sizes[s], r->an_full[0], r->an_full[1], r->an_full[2], r->an_full[3], r->an_incr[0], r->an_incr[1], r->an_incr[2],
               r->an_incr[3], r->an_reused, r->an_leaves, r->an_sdf_reused, r->an_sdf_leaves, r->an_pers_reused, r->an_pers_leaves);
      fflush(stdout);
    }
  lf = fopen("/proc/loadavg", "r");
  if (lf) { if (!fgets(load1, sizeof load1, lf)) load1[0] = 0; fclose(lf); }
  load1[strcspn(load1, "\n")] = 0;
  if (!data) { mgs_error e2; mgs_remove_tree(tmpl, &e2); }
  if (mgs_mkdir_p(out, &err)) return mgs_cli_fail("bench scale", &err);

  /* bytes per Gaussian of the training state, by component (what the code allocates
     per Gaussian: float parameters at SH 3, Adam's two moments, ADC's accumulators, the
     trainer's gradient model and 2D-gradient norms, the rasterizer's per-Gaussian
     buffers, the visibility's tile arrays) */
  const double b_param = 4.0 * (3 + 3 + 4 + 1 + 3 + 45), b_adam = 2 * b_param, b_adc = 4 + 4 + 4;
  const double b_grad = b_param + 4, b_raster = 48 + 32 + 4 + 8 + 4 + 16 + 4, b_vis = 4 + 4 + 16 + 4 + 0.125;
  const double b_total = b_param + b_adam + b_adc + b_grad + b_raster + b_vis;
  int lo = -1, hi = -1;
  for (int s = 0; s < n_sizes; s++)
    if (results[s * N_CONF + CONF_SCALE].ok) { if (lo < 0) lo = s; hi = s; }
  double marginal = -1;
  if (lo >= 0 && hi > lo) {
    const result *a = &results[lo * N_CONF + CONF_SCALE], *b = &results[hi * N_CONF + CONF_SCALE];
    marginal = (b->peak_mb - a->peak_mb) * 1048576.0 / (double)(b->gaussians - a->gaussians);
  }
  char path[4096];
  snprintf(path, sizeof path, "%s/scale.csv", out);
  FILE *f = fopen(path, "w");
  if (!f) { fprintf(stderr, "morsegs bench scale: cannot write %s\n", path); return 1; }
  fprintf(f, "size,content,config,gaussians,views,s_per_iter,peak_rss_mb,projected_per_iter,cache_hit_rate,final_loss\n");
  for (int k = 0; k < n_sizes * N_CONF; k++) {
    const result *r = &results[k];
    if (!r->ok) continue;
    fprintf(f, "%d,%d,%s,%zu,%zu,%.6f,%.1f,%.0f,%.4f,%.5f\n", r->size, r->size * r->size, conf_name[r->conf], r->gaussians,
            r->views, r->s_per_iter, r->peak_mb, r->listed, r->hit_rate, r->loss);
  }
  fclose(f);
  snprintf(path, sizeof path, "%s/scale.md", out);
  f = fopen(path, "w");
  if (!f) { fprintf(stderr, "morsegs bench scale: cannot write %s\n", path); return 1; }
  fprintf(f, "`morsegs bench scale --sizes %s --iters %d --warmup %d --res %d --cache-mb %d --points %ld%s`, MGS_THREADS=%s; "
             "load average before: %s; after: %s.\n\n",
          sizes_arg, iters, warmup, res, cache_mb, points, analysis ? "" : " --no-analysis", getenv("MGS_THREADS") ? getenv("MGS_THREADS") : "(all)", load0, load1);
  fprintf(f, "| N | content | config | Gaussians | views | s/iter | vs N=%d | forward ms | backward+Adam ms | peak RSS MiB | "
             "projected/iter | cache hits |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n", sizes[0]);
  for (int k = 0; k < n_sizes * N_CONF; k++) {
    const result *r = &results[k];
    if (!r->ok) continue;
    const result *r0 = &results[r->conf];
    char hr[32];
    if (r->hit_rate < 0) snprintf(hr, sizeof hr, "-");
    else snprintf(hr, sizeof hr, "%.0f%%", 100.0 * r->hit_rate);
    fprintf(f, "| %d | %dx | %s | %zu | %zu | %.4f | %.2fx | %.1f | %.1f | %.0f | %.0f | %s |\n", r->size,
            r->size * r->size, conf_name[r->conf], r->gaussians, r->views, r->s_per_iter,
            r0->ok ? r->s_per_iter / r0->s_per_iter : 0, r->fwd_ms, r->bwd_ms, r->peak_mb, r->listed, hr);
  }
  fprintf(f, "\nBytes per Gaussian of the training state (allocated per Gaussian, SH degree 3): parameters %.0f, "
             "Adam moments %.0f, ADC state %.0f, gradient model + 2D-gradient norm %.0f, rasterizer buffers %.0f, "
             "visibility tiles %.0f: **%.0f B**.",
          b_param, b_adam, b_adc, b_grad, b_raster, b_vis, b_total);
  if (marginal > 0)
    fprintf(f, " Measured: peak RSS grows by **%.0f B per added Gaussian** in the scale runs from N = %d to N = %d "
               "(everything included: the dataset's cameras and points, the city's images through a fixed cache).",
            marginal, sizes[lo], sizes[hi]);
  size_t largest = 0;
  for (int k = 0; k < n_sizes * N_CONF; k++)
    if (results[k].ok && results[k].gaussians > largest) largest = results[k].gaussians;
  double per = marginal > 0 ? fmax(marginal, b_total) : b_total;
  if (largest >= 10000000)
    fprintf(f, " The largest run above trained %zu Gaussians: its peak RSS is measured, not projected.\n", largest);
  else
    fprintf(f, " At %.0f B a Gaussian, 10M Gaussians need %.1f GiB (projected from these figures, not run).\n",
            per, per * 1e7 / 1073741824.0);
  fprintf(f, "\nMorse analysis of each scale run's model (α-field, SDF, persistence; 128 voxels along city 1's diagonal, "
             "the same voxel size and band at every N), from scratch and again after the Gaussians of one corner block (1/N² of "
             "the city) changed, with `--morse-incremental` (the α leaves of that block and the SDF band around them rebuilt, "
             "the persistence's critical cells of the unchanged band leaves reused; its sort and pairing run whole):\n\n"
             "| N | analysis s | α s | SDF s | persistence s | after one block "
             "changed: analysis s | α s | SDF s | persistence s | α leaves reused | SDF leaves reused | persistence leaves reused |\n"
             "|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (int k = 0; k < n_sizes * N_CONF; k++) {
    const result *r = &results[k];
    if (!r->ok || r->conf != CONF_SCALE || r->an_full[0] < 0) continue;
    fprintf(f, "| %d | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %.0f of %.0f (%.0f %%) | %.0f of %.0f (%.0f %%) | %.0f of %.0f (%.0f %%) |\n",
            r->size, r->an_full[0], r->an_full[1], r->an_full[2], r->an_full[3], r->an_incr[0], r->an_incr[1], r->an_incr[2],
            r->an_incr[3], r->an_reused, r->an_leaves, r->an_leaves > 0 ? 100.0 * r->an_reused / r->an_leaves : 0.0,
            r->an_sdf_reused, r->an_sdf_leaves, r->an_sdf_leaves > 0 ? 100.0 * r->an_sdf_reused / r->an_sdf_leaves : 0.0,
            r->an_pers_reused, r->an_pers_leaves, r->an_pers_leaves > 0 ? 100.0 * r->an_pers_reused / r->an_pers_leaves : 0.0);
  }
  fclose(f);
  snprintf(path, sizeof path, "%s/scale.png", out);
  plot(results, n_sizes, sizes, path);
  printf("load average before: %s; after: %s\nwrote %s/scale.md, %s/scale.csv, %s/scale.png\n", load0, load1, out, out, out);
  return 0;
}

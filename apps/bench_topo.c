/* morsegs bench topo: narrow-band persistence time and memory at effective 128³..1024³ for a
 * torus SDF band and a noisy scene with floaters, beside GUDHI's dense cubical persistence
 * (python3-gudhi, T construction, run as a subprocess on the same clamped field).
 * Fields are analytic SDFs built directly as sparse blocks: a block whose centre is farther
 * from the surface than the band plus its half-diagonal is a constant tile (inside) or
 * background (outside), so building costs follow the band. Each measurement runs in a
 * forked child so its peak RSS is its own. */
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/time.h>
#include <sys/wait.h>
#include <unistd.h>
#include "apps/mgs_cli.h"
#include "core/mgs_log.h"
#include "core/mgs_parallel.h"
#include "topo/mgs_persistence.h"

enum { F_TORUS = 0, F_NOISY = 1 };
static const char *field_names[] = {"torus band", "noisy + floaters"};

typedef struct scene {
  int kind, N;
  double h, w;
  int nballs;
  double balls[50][4];
} scene;

static uint32_t hash32(uint32_t x) {
  x ^= x >> 16; x *= 0x7feb352dU; x ^= x >> 15; x *= 0x846ca68bU; x ^= x >> 16;
  return x;
}
static double unoise(uint32_t a, uint32_t b) { return (hash32(a * 0x9e3779b9U ^ hash32(b)) & 0xffffff) / 16777216.0; }

static void scene_init(scene *s, int kind, int N) {
  memset(s, 0, sizeof *s);
  s->kind = kind;
  s->N = N;
  s->h = 1.0 / N;
  s->w = 3 * s->h;
  if (kind == F_NOISY) {
    s->nballs = 50;
    for (int i = 0; i < 50; i++) {
      /* tiny floaters (radius 1.5-3 voxels) away from the torus tube */
      for (uint32_t t = 0;; t++) {
        double x = .08 + .84 * unoise(i, 3 * t), y = .08 + .84 * unoise(i, 3 * t + 1), z = .08 + .84 * unoise(i, 3 * t + 2);
        double q = sqrt((x - .5) * (x - .5) + (y - .5) * (y - .5)) - .3, dt = sqrt(q * q + (z - .5) * (z - .5)) - .1;
        if (dt > .05) { s->balls[i][0] = x; s->balls[i][1] = y; s->balls[i][2] = z; break; }
      }
      s->balls[i][3] = (1.5 + 1.5 * unoise(i, 999)) * s->h;
    }
  }
}

/* The smooth part (Lipschitz <= ~1.1) and the per-voxel noise (|noise| <= 0.3 h). */
static double smooth_sdf(const scene *s, double x, double y, double z) {
  double q = sqrt((x - .5) * (x - .5) + (y - .5) * (y - .5)) - .3;
  double d = sqrt(q * q + (z - .5) * (z - .5)) - .1;
  if (s->kind == F_NOISY) {
    d += 2 * s->h * sin(6.2831853 * 3 * x) * sin(6.2831853 * 2 * y) * cos(6.2831853 * 3 * z);
    for (int i = 0; i < s->nballs; i++) {
      double b = sqrt((x - s->balls[i][0]) * (x - s->balls[i][0]) + (y - s->balls[i][1]) * (y - s->balls[i][1]) +
                      (z - s->balls[i][2]) * (z - s->balls[i][2])) - s->balls[i][3];
      if (b < d) d = b;
    }
  }
  return d;
}
static float voxel_value(const scene *s, int i, int j, int k) {
  double d = smooth_sdf(s, (i + .5) * s->h, (j + .5) * s->h, (k + .5) * s->h);
  if (s->kind == F_NOISY) d += 0.3 * s->h * (2 * unoise((uint32_t)(i * 73856093) ^ (uint32_t)(j * 19349663), (uint32_t)k) - 1);
  return (float)(d < -s->w ? -s->w : (d > s->w ? s->w : d));
}

static mgs_status build_sparse(const scene *s, mgs_topo_sparse **out, size_t *active, mgs_error *err) {
  float w = (float)s->w;
  mgs_status st = mgs_topo_sparse_create(w, out, err);
  if (st != MGS_OK) return st;
  int nb = s->N / 8;
  double margin = 1.15 * (s->w + 4 * sqrt(3.0) * s->h) + 0.3 * s->h;
  float vals[512];
  *active = 0;
  for (int bx = 0; bx < nb; bx++)
    for (int by = 0; by < nb; by++)
      for (int bz = 0; bz < nb; bz++) {
        double d = smooth_sdf(s, (bx * 8 + 4) * s->h, (by * 8 + 4) * s->h, (bz * 8 + 4) * s->h);
        int32_t o[3] = {bx * 8, by * 8, bz * 8};
        if (d > margin) continue;
        if (d < -margin) { st = mgs_topo_sparse_add_tile(*out, o, 8, -w, err); if (st) return st; continue; }
        size_t na = 0;
        int lo = 0, hi = 0;
        for (int i = 0; i < 8; i++)
          for (int j = 0; j < 8; j++)
            for (int k = 0; k < 8; k++) {
              float v = voxel_value(s, o[0] + i, o[1] + j, o[2] + k);
              vals[(i << 6) | (j << 3) | k] = v;
              na += (v > -w && v < w);
              lo += v == -w;
              hi += v == w;
            }
        if (hi == 512) continue;
        if (lo == 512) st = mgs_topo_sparse_add_tile(*out, o, 8, -w, err);
        else st = mgs_topo_sparse_add_leaf(*out, o, vals, err);
        if (st != MGS_OK) return st;
        *active += na;
      }
  return MGS_OK;
}

typedef struct result {
  int ok;
  size_t active, leaves, tiles, cells_total, cells_built, critical, pairs, truncated, band_cells;
  double build_s, wall_s, cpu_s, rss_before_mb, rss_peak_mb, wall_t_s, cpu_t_s;
  double startup_mb;                        /* first parallel loop of the process (not the engine) */
  double ratio, grad_s, morse_s, pairs_s;   /* gradient path: reduction ratio and phase walls */
  int with_full, full_same;                 /* full-reduction path in the same run */
  double full_wall_s, full_cpu_s;
  size_t full_cells;
  size_t pairs_t;
  double gudhi_s, gudhi_rss_mb;
  long gudhi_pairs;
  char msg[256];
} result;

static double cpu_seconds(void) {
  struct rusage ru;
  getrusage(RUSAGE_SELF, &ru);
  return ru.ru_utime.tv_sec + ru.ru_stime.tv_sec + 1e-6 * (ru.ru_utime.tv_usec + ru.ru_stime.tv_usec);
}
static double rss_mb(void) { return (double)mgs_peak_rss() / (1024.0 * 1024.0); }

static const char *gudhi_script =
    "import sys, time, resource, numpy as np\n"
    "import gudhi\n"
    "n = int(sys.argv[2]); f = np.fromfile(sys.argv[1], dtype='<f4').astype(np.float64).reshape(n, n, n)\n"
    "t = time.process_time(); w = time.time()\n"
    "cc = gudhi.CubicalComplex(top_dimensional_cells=f)\n"
    "p = cc.persistence(homology_coeff_field=2, min_persistence=0)\n"
    "print('%.3f %.3f %.1f %d' % (time.process_time() - t, time.time() - w, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0, len(p)))\n";

static void run_gudhi(const scene *s, result *r) {
  r->gudhi_s = -1;
  char path[] = "/tmp/mgs_bench_topo_XXXXXX";
  int fd = mkstemp(path);
  if (fd < 0) return;
  FILE *fp = fdopen(fd, "wb");
  size_t n = (size_t)s->N;
  float *row = malloc(n * sizeof *row);
  for (size_t i = 0; i < n; i++)
    for (size_t j = 0; j < n; j++) {
      for (size_t k = 0; k < n; k++) row[k] = voxel_value(s, (int)i, (int)j, (int)k);
      fwrite(row, sizeof *row, n, fp);
    }
  free(row);
  fclose(fp);
  char spath[] = "/tmp/mgs_bench_topo_py_XXXXXX";
  int sfd = mkstemp(spath);
  if (sfd >= 0) {
    FILE *sp = fdopen(sfd, "w");
    fputs(gudhi_script, sp);
    fclose(sp);
    char cmd[512];
    const char *py = access("/usr/bin/python3", X_OK) == 0 ? "/usr/bin/python3" : "python3";
    snprintf(cmd, sizeof cmd, "%s %s %s %d", py, spath, path, s->N);
    FILE *p = popen(cmd, "r");
    double cpu = -1, wall = -1, rss = 0;
    long np = -1;
    if (p) {
      if (fscanf(p, "%lf %lf %lf %ld", &cpu, &wall, &rss, &np) != 4) cpu = -1;
      pclose(p);
    }
    r->gudhi_s = cpu;
    r->gudhi_rss_mb = rss;
    r->gudhi_pairs = np;
    remove(spath);
  }
  remove(path);
}

static int same_diagram(const mgs_diagram *a, const mgs_diagram *b) {
  if (a->n != b->n) return 0;
  for (size_t i = 0; i < a->n; i++) /* both sorted by mgs_diagram_sort */
    if (a->pairs[i].dim != b->pairs[i].dim || a->pairs[i].birth != b->pairs[i].birth || a->pairs[i].death != b->pairs[i].death)
      return 0;
  return 1;
}

static void nop_range(void *ctx, size_t b, size_t e) { (void)ctx; (void)b; (void)e; }

static void child_run(const scene *s, int with_t, int with_gudhi, int with_full, result *r) {
  mgs_error err = {0};
  mgs_topo_sparse *sp = NULL;
  double t0 = mgs_now();
  if (build_sparse(s, &sp, &r->active, &err) != MGS_OK) { snprintf(r->msg, sizeof r->msg, "%.200s", err.msg); return; }
  r->build_s = mgs_now() - t0;
  /* Start the thread pool before the baseline: TBB's first loop in a process dlopens
   * libtbbmalloc, whose symbol lookups touch the hash tables of every library morsegs links;
   * a forked child does not inherit those file-backed pages, so this costs ~12 MB of RSS once
   * per process. Reported in its own column, not charged to the engine. */
  double rss_built = rss_mb();
  mgs_parallel_for(0, 2, 1, nop_range, NULL);
  r->rss_before_mb = rss_mb();
  r->startup_mb = r->rss_before_mb - rss_built;
  mgs_topo_opts o;
  mgs_topo_opts_default(&o);
  o.half_width = s->w;
  o.voxel_size = s->h;
  mgs_topo_stats st;
  mgs_diagram *d = NULL;
  double c0 = cpu_seconds();
  t0 = mgs_now();
  if (mgs_topo_persistence_sparse(sp, &o, &d, &st, &err) != MGS_OK) { snprintf(r->msg, sizeof r->msg, "%.200s", err.msg); mgs_topo_sparse_destroy(sp); return; }
  r->wall_s = mgs_now() - t0;
  r->cpu_s = cpu_seconds() - c0;
  r->rss_peak_mb = rss_mb();
  r->leaves = st.leaves;
  r->tiles = st.tiles;
  r->cells_total = st.cells_total;
  r->cells_built = st.cells_built;
  r->critical = st.critical_cells;
  r->band_cells = st.band_cells;
  r->ratio = st.reduction_ratio;
  r->grad_s = st.seconds_build;
  r->morse_s = st.seconds_morse;
  r->pairs_s = st.seconds_pairs - st.seconds_morse;
  r->pairs = d->n;
  r->truncated = st.truncated;
  if (with_full) { /* the full reduction of every band cell: same diagram, the old cost */
    mgs_topo_opts of = o;
    of.full_reduction = 1;
    mgs_diagram *df = NULL;
    mgs_topo_stats sf;
    double cf = cpu_seconds(), tf = mgs_now();
    if (mgs_topo_persistence_sparse(sp, &of, &df, &sf, &err) == MGS_OK) {
      r->with_full = 1;
      r->full_wall_s = mgs_now() - tf;
      r->full_cpu_s = cpu_seconds() - cf;
      r->full_cells = sf.cells_built;
      r->full_same = same_diagram(d, df);
      mgs_diagram_destroy(df);
    }
  }
  mgs_diagram_destroy(d);
  if (with_t) {
    o.construction = MGS_TOPO_T;
    t0 = mgs_now();
    c0 = cpu_seconds();
    if (mgs_topo_persistence_sparse(sp, &o, &d, &st, &err) == MGS_OK) {
      r->wall_t_s = mgs_now() - t0;
      r->cpu_t_s = cpu_seconds() - c0;
      r->pairs_t = d->n;
      mgs_diagram_destroy(d);
    }
  }
  mgs_topo_sparse_destroy(sp);
  if (with_gudhi) run_gudhi(s, r);
  r->ok = 1;
}

static int run_forked(const scene *s, int with_t, int with_gudhi, int with_full, result *r) {
  memset(r, 0, sizeof *r);
  int fds[2];
  if (pipe(fds) != 0) return 0;
  fflush(stdout);
  fflush(stderr);
  pid_t pid = fork();
  if (pid < 0) { close(fds[0]); close(fds[1]); return 0; }
  if (pid == 0) {
    close(fds[0]);
    result cr;
    memset(&cr, 0, sizeof cr);
    child_run(s, with_t, with_gudhi, with_full, &cr);
    ssize_t wr = write(fds[1], &cr, sizeof cr);
    (void)wr;
    close(fds[1]);
    _exit(0);
  }
  close(fds[1]);
  ssize_t got = read(fds[0], r, sizeof *r);
  close(fds[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  if (got != (ssize_t)sizeof *r) { snprintf(r->msg, sizeof r->msg, "child failed (status %d)", status); r->ok = 0; }
  return r->ok;
}

static void usage(FILE *f) {
  fprintf(f, "usage: morsegs bench topo [--quick] [--min-res N] [--max-res N] [--field torus|noisy|all]\n"
             "                          [--gudhi-max N] [--no-t] [--full-max N]\n"
             "  Narrow-band persistence (V construction, band half-width 3 voxels) of a torus SDF\n"
             "  and a noisy scene with 50 floaters at effective 128^3 .. N^3 (default N = 512;\n"
             "  1024 allowed), beside GUDHI 3.7 dense cubical persistence (T construction, python3-gudhi)\n"
             "  on the same clamped field up to --gudhi-max (default 128; 0 = never). Our T\n"
             "  construction is timed too (--no-t skips it) for a like-for-like ratio.\n"
             "  --full-max N: up to N (default 512; 0 = never) also run the full reduction of every\n"
             "  band cell (no discrete gradient, the reference path) after the V run, in the same\n"
             "  process, and check that both diagrams are equal.\n"
             "  --quick: 64^3 and 128^3 only.\n");
}

int mgs_bench_topo(int argc, char **argv) {
  int quick = 0, max_res = 512, min_res = 128, gudhi_max = 128, with_t = 1, only = -1, full_max = 512;
  static const struct option longopts[] = {{"quick", no_argument, 0, 'q'}, {"max-res", required_argument, 0, 'm'},
                                           {"gudhi-max", required_argument, 0, 'g'}, {"no-t", no_argument, 0, 't'},
                                           {"min-res", required_argument, 0, 'n'}, {"field", required_argument, 0, 'f'},
                                           {"full-max", required_argument, 0, 'F'},
                                           {"help", no_argument, 0, 'h'}, {0, 0, 0, 0}};
  int c;
  optind = 1;
  while ((c = getopt_long(argc, argv, "qm:g:thn:f:F:", longopts, NULL)) != -1) {
    switch (c) {
    case 'q': quick = 1; break;
    case 'm': max_res = atoi(optarg); break;
    case 'g': gudhi_max = atoi(optarg); break;
    case 't': with_t = 0; break;
    case 'n': min_res = atoi(optarg); break;
    case 'F': full_max = atoi(optarg); break;
    case 'f':
      if (!strcmp(optarg, "torus")) only = F_TORUS;
      else if (!strcmp(optarg, "noisy")) only = F_NOISY;
      else if (strcmp(optarg, "all")) { fprintf(stderr, "morsegs bench topo: --field must be torus, noisy or all\n"); return 2; }
      break;
    case 'h': usage(stdout); return 0;
    default: usage(stderr); return 2;
    }
  }
  if (optind < argc || max_res < 64 || max_res > 1024 || (max_res & (max_res - 1)) || min_res < 16 || min_res > max_res ||
      (min_res & (min_res - 1))) {
    fprintf(stderr, "morsegs bench topo: --min-res / --max-res must be powers of two, 16 <= min <= max <= 1024\n");
    usage(stderr);
    return 2;
  }
  int sizes[8], ns = 0;
  for (int n = quick ? 64 : min_res; n <= (quick ? 128 : max_res); n *= 2) sizes[ns++] = n;
  printf("| field | N | active voxels | leaves / tiles | band cells (full box) | critical (reduction) | pairs (truncated) |"
         " ours V wall s | ours V CPU s | wall s: enumerate+gradient / Morse boundaries / sort+pairs | peak RSS MB (before) | B / active voxel |"
         " pool start-up MB |"
         " full reduction wall / CPU s (same diagram) | ours T wall / CPU s | GUDHI T CPU s | GUDHI RSS MB | GUDHI CPU / ours T CPU |\n");
  printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  fflush(stdout);
  int failures = 0;
  for (int kind = 0; kind < 2; kind++)
    for (int i = 0; i < ns; i++) {
      if (only >= 0 && kind != only) continue;
      scene s;
      scene_init(&s, kind, sizes[i]);
      result r;
      int g = gudhi_max > 0 && sizes[i] <= gudhi_max;
      int fu = full_max > 0 && sizes[i] <= full_max;
      if (!run_forked(&s, with_t, g, fu, &r)) {
        printf("| %s | %d | failed: %s |\n", field_names[kind], sizes[i], r.msg);
        failures++;
        continue;
      }
      char gs[64] = "—", grss[32] = "—", ratio[32] = "—", ts[32] = "—", fs[64] = "—";
      if (r.with_full) {
        snprintf(fs, sizeof fs, "%.3f / %.3f (%s)", r.full_wall_s, r.full_cpu_s, r.full_same ? "yes" : "NO");
        if (!r.full_same) failures++;
      }
      if (with_t) snprintf(ts, sizeof ts, "%.3f / %.3f", r.wall_t_s, r.cpu_t_s);
      if (g && r.gudhi_s >= 0) {
        snprintf(gs, sizeof gs, "%.2f (%ld pairs vs our T %zu)", r.gudhi_s, r.gudhi_pairs, r.pairs_t);
        snprintf(grss, sizeof grss, "%.0f", r.gudhi_rss_mb);
        if (with_t && r.cpu_t_s > 0) snprintf(ratio, sizeof ratio, "%.0fx", r.gudhi_s / r.cpu_t_s);
      } else if (g) snprintf(gs, sizeof gs, "failed");
      double bpv = r.active ? (r.rss_peak_mb - r.rss_before_mb) * 1048576.0 / (double)r.active : 0;
      printf("| %s | %d | %zu | %zu / %zu | %zu (%zu) | %zu (%.2f %%) | %zu (%zu) | %.3f | %.3f | %.3f / %.3f / %.3f | %.0f (%.0f) | %.0f | %.1f | %s | %s | %s | %s | %s |\n",
             field_names[kind], sizes[i], r.active, r.leaves, r.tiles, r.band_cells, r.cells_total, r.critical, 100 * r.ratio,
             r.pairs, r.truncated, r.wall_s, r.cpu_s, r.grad_s, r.morse_s, r.pairs_s, r.rss_peak_mb, r.rss_before_mb, bpv, r.startup_mb, fs,
             ts, gs, grss, ratio);
      fflush(stdout);
    }
  printf("\nV = voxels as vertices (default); T = voxels as cubes (GUDHI's construction). Wall = 2 threads.\n"
         "B / active voxel = (peak RSS of the V run - RSS after building the input and starting the thread pool) / active\n"
         "voxels; pool start-up = RSS of the process's first parallel loop (TBB loading libtbbmalloc), once per process.\n"
         "CPU = user + sys of the process (both threads); on a loaded machine compare CPU, not wall.\n");
  return failures ? 1 : 0;
}

/* morsegs bench patchmatch: wall and CPU time of one mgs_pm_run (render/mgs_patchmatch.h)
 * on a deterministic textured scene built in memory — a textured sphere before a textured
 * back plane with a flat (untextured) band, seen by a reference and up to 8 source views —
 * from a depth a few % off with the true normals, as GaussianPro starts it from the render.
 * Prints the median of N runs and a checksum of the outputs (depth, normal, cost), so two
 * builds can be compared for bit-identical results as well as for time. */
#include <getopt.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <time.h>
#include "apps/mgs_cli.h"
#include "core/mgs_camera.h"
#include "core/mgs_parallel.h"
#include "render/mgs_patchmatch.h"

#define BP_MAX_SRC 8

static const double SPHERE_R = 0.7, PLANE_Z = -0.9;

static double bp_texture(double a, double b) {
  return 128 + 45 * sin(9.1 * a + 1.3) * cos(7.3 * b) + 30 * sin(17.7 * a - 11.9 * b) + 25 * cos(23.3 * b + 5.1 * a) +
         15 * sin(41.0 * a + 37.0 * b);
}

/* First hit of a ray with the scene: grey value, world normal, camera depth; 0 if none. */
static int bp_trace(const mgs_camera *c, double u, double v, double *grey, double nrm[3], double *depth) {
  double o[3], d[3];
  mgs_camera_ray(c, u, v, o, d);
  double b = o[0] * d[0] + o[1] * d[1] + o[2] * d[2], cc = o[0] * o[0] + o[1] * o[1] + o[2] * o[2] - SPHERE_R * SPHERE_R;
  double dd = d[0] * d[0] + d[1] * d[1] + d[2] * d[2], disc = b * b - dd * cc, s = -1;
  int sphere = 0;
  if (disc > 0) { s = (-b - sqrt(disc)) / dd; sphere = s > 0; }
  if (!sphere) {
    if (!(fabs(d[2]) > 1e-12)) return 0;
    s = (PLANE_Z - o[2]) / d[2];
    if (!(s > 0)) return 0;
  }
  double X[3] = {o[0] + s * d[0], o[1] + s * d[1], o[2] + s * d[2]};
  if (sphere) {
    for (int i = 0; i < 3; i++) nrm[i] = X[i] / SPHERE_R;
    *grey = bp_texture(2.0 * atan2(X[1], X[0]), 3.0 * X[2]);
  } else {
    nrm[0] = 0; nrm[1] = 0; nrm[2] = 1;
    *grey = X[0] > 0.8 ? 90.0 : bp_texture(X[0], X[1]); /* a flat band: patch match skips it */
  }
  double pc[3];
  mgs_camera_world_to_cam(c, X, pc);
  *depth = pc[2];
  return 1;
}

static void bp_render(const mgs_camera *c, float *gray, float *depth, float *normal) {
  for (int y = 0; y < c->height; y++)
    for (int x = 0; x < c->width; x++) {
      size_t p = (size_t)y * (size_t)c->width + (size_t)x;
      double sum = 0, g, n[3], z;
      for (int k = 0; k < 4; k++) /* 2x2 supersampling */
        sum += bp_trace(c, x + 0.25 + 0.5 * (k & 1), y + 0.25 + 0.5 * (k >> 1), &g, n, &z) ? g : 255.0;
      gray[p] = (float)(sum / 4);
      if (!depth) continue;
      int hit = bp_trace(c, x + 0.5, y + 0.5, &g, n, &z);
      /* a depth a few % off, unknown (0) on a sparse grid of pixels */
      uint64_t h = (uint64_t)p * 0x9E3779B97F4A7C15ull;
      h ^= h >> 29;
      double jitter = (double)(h % 1000) / 1000.0 - 0.5;
      depth[p] = hit && p % 37 ? (float)(z * (1.0 + 0.08 * jitter)) : 0.0f;
      for (int i = 0; i < 3; i++) normal[3 * p + i] = hit ? (float)n[i] : 0.0f;
    }
}

static uint64_t bp_hash(uint64_t h, const void *data, size_t n) { /* FNV-1a */
  const unsigned char *b = data;
  for (size_t i = 0; i < n; i++) h = (h ^ b[i]) * 0x100000001B3ull;
  return h;
}

static double bp_now(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}
static double bp_cpu(void) {
  struct rusage ru;
  getrusage(RUSAGE_SELF, &ru);
  return (double)(ru.ru_utime.tv_sec + ru.ru_stime.tv_sec) + 1e-6 * (double)(ru.ru_utime.tv_usec + ru.ru_stime.tv_usec);
}
static int bp_cmp(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return (x > y) - (x < y);
}

static void usage(FILE *f) {
  fprintf(f, "usage: morsegs bench patchmatch [--size N] [--runs N] [--sources N] [--patch N] [--step N]\n"
             "                                [--iters N] [--seed N]\n"
             "  Times mgs_pm_run (GaussianPro's plane patch matching) on a textured sphere before a\n"
             "  textured plane with a flat band, N x N pixels (default 200), 4 source views, the\n"
             "  authors' settings (patch 20, step 2, 6 iterations); prints wall and CPU ms per run\n"
             "  (median, min, max of --runs, default 3) and a checksum of depth, normal and cost.\n"
             "  Threads: MGS_THREADS (use 1 for a one-core figure).\n");
}

int mgs_bench_patchmatch(int argc, char **argv) {
  int size = 200, runs = 3, n_src = 4;
  mgs_pm_options o;
  mgs_pm_options_default(&o);
  static const struct option longopts[] = {{"size", required_argument, 0, 's'}, {"runs", required_argument, 0, 'r'},
                                           {"sources", required_argument, 0, 'n'}, {"patch", required_argument, 0, 'p'},
                                           {"step", required_argument, 0, 't'}, {"iters", required_argument, 0, 'i'},
                                           {"seed", required_argument, 0, 'S'}, {"help", no_argument, 0, 'h'},
                                           {0, 0, 0, 0}};
  int c;
  optind = 1;
  while ((c = getopt_long(argc, argv, "s:r:n:p:t:i:S:h", longopts, NULL)) != -1) {
    switch (c) {
    case 's': size = atoi(optarg); break;
    case 'r': runs = atoi(optarg); break;
    case 'n': n_src = atoi(optarg); break;
    case 'p': o.patch_size = atoi(optarg); break;
    case 't': o.patch_step = atoi(optarg); break;
    case 'i': o.iterations = atoi(optarg); break;
    case 'S': o.seed = strtoull(optarg, NULL, 10); break;
    case 'h': usage(stdout); return 0;
    default: usage(stderr); return 2;
    }
  }
  if (optind < argc || size < 16 || size > 4096 || runs < 1 || runs > 100 || n_src < 1 || n_src > BP_MAX_SRC) {
    fprintf(stderr, "morsegs bench patchmatch: --size 16..4096, --runs 1..100, --sources 1..%d\n", BP_MAX_SRC);
    usage(stderr);
    return 2;
  }
  o.depth_min = 0.5f;
  o.depth_max = 10.0f;
  /* the reference on the axis, sources ~5-9 degrees around it (GaussianPro's best parallax) */
  static const double eyes[1 + BP_MAX_SRC][3] = {{0, 0, 3},        {0.35, 0.05, 2.98}, {-0.3, 0.3, 2.97},
                                                 {0.05, -0.4, 2.97}, {-0.45, -0.1, 2.96}, {0.3, 0.35, 2.96},
                                                 {-0.25, -0.35, 2.96}, {0.5, -0.2, 2.95}, {-0.5, 0.25, 2.94}};
  mgs_camera cams[1 + BP_MAX_SRC];
  float *gray[1 + BP_MAX_SRC] = {0};
  size_t np = (size_t)size * (size_t)size;
  float *init_d = malloc(np * sizeof(float)), *init_n = malloc(3 * np * sizeof(float));
  float *depth = malloc(np * sizeof(float)), *normal = malloc(3 * np * sizeof(float)), *cost = malloc(np * sizeof(float));
  double *wall = malloc((size_t)runs * sizeof(double)), *cpu = malloc((size_t)runs * sizeof(double));
  int rc = 0;
  for (int k = 0; k <= n_src; k++) {
    mgs_camera_init_fovx(&cams[k], size, size, 50.0 * M_PI / 180.0);
    double target[3] = {0, 0, 0}, up[3] = {0, -1, 0};
    mgs_camera_look_at(&cams[k], eyes[k], target, up);
    gray[k] = malloc(np * sizeof(float));
    if (!gray[k]) break;
    bp_render(&cams[k], gray[k], k ? NULL : init_d, k ? NULL : init_n);
  }
  if (!init_d || !init_n || !depth || !normal || !cost || !wall || !cpu || !gray[n_src]) {
    fprintf(stderr, "morsegs bench patchmatch: out of memory\n");
    rc = 1;
    goto done;
  }
  mgs_pm_view ref = {&cams[0], gray[0]}, src[BP_MAX_SRC];
  for (int k = 0; k < n_src; k++) { src[k].cam = &cams[k + 1]; src[k].gray = gray[k + 1]; }
  uint64_t sum = 0;
  for (int r = 0; r < runs; r++) {
    mgs_error err = {0};
    double w0 = bp_now(), c0 = bp_cpu();
    mgs_status st = mgs_pm_run(&ref, src, n_src, init_d, init_n, &o, depth, normal, cost, &err);
    wall[r] = 1e3 * (bp_now() - w0);
    cpu[r] = 1e3 * (bp_cpu() - c0);
    if (st != MGS_OK) { rc = mgs_cli_fail("bench patchmatch", &err); goto done; }
    uint64_t h = bp_hash(0xCBF29CE484222325ull, depth, np * sizeof(float));
    h = bp_hash(h, normal, 3 * np * sizeof(float));
    h = bp_hash(h, cost, np * sizeof(float));
    if (r && h != sum) { fprintf(stderr, "morsegs bench patchmatch: run %d gave other results than run 0\n", r); rc = 1; }
    sum = h;
  }
  size_t matched = 0;
  for (size_t p = 0; p < np; p++) matched += cost[p] < 2.0f;
  qsort(wall, (size_t)runs, sizeof(double), bp_cmp);
  qsort(cpu, (size_t)runs, sizeof(double), bp_cmp);
  printf("| size | sources | patch / step / iters | threads | runs | wall ms median (min-max) | CPU ms median (min-max) |"
         " pixels matched | checksum |\n|---|---|---|---|---|---|---|---|---|\n");
  printf("| %dx%d | %d | %d / %d / %d | %d | %d | %.0f (%.0f-%.0f) | %.0f (%.0f-%.0f) | %zu of %zu | %016llx |\n", size, size,
         n_src, o.patch_size, o.patch_step, o.iterations, mgs_parallel_max_threads(), runs, wall[runs / 2], wall[0],
         wall[runs - 1], cpu[runs / 2], cpu[0], cpu[runs - 1], matched, np, (unsigned long long)sum);
done:
  for (int k = 0; k <= n_src; k++) free(gray[k]);
  free(init_d); free(init_n); free(depth); free(normal); free(cost); free(wall); free(cpu);
  return rc;
}

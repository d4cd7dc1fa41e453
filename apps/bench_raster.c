/* `morsegs bench raster`: forward and backward ms of the tile rasterizer at 200x200 and
 * 800x800 with 10k, 100k and 1M Gaussians, tile intersections, and the achieved fraction
 * of the machine's peak FLOP/s.
 *
 * Peak: an FMA loop (12 independent 16-wide chains) on one thread, timed in that thread's
 * CPU time, gives the per-core peak; the machine's is that times the threads. The
 * fraction of peak is computed from CPU time (flops / (process CPU seconds x per-core
 * peak)), which stays meaningful when the machine is shared: wall-clock figures on a busy
 * machine measure the other tenants too. Both wall and CPU ms are printed.
 *
 * Scene: Gaussians uniform in a cube of side 2 seen from distance 4 (fov 60 deg), random
 * rotations, scales log-normal around 0.015 * (1e5 / n)^(1/3) world units (so the mean
 * screen radius is a few px at 200x200 whatever n, as in a trained scene where more
 * Gaussians are smaller), opacity logits N(-1, 2) (many faint, some opaque, as trained
 * scenes), SH degree 3 with small random coefficients.
 *
 * FLOP model: the vector operations per lane of the tile kernels, per Gaussian x pixel
 * evaluation they perform (evaluations are counted exactly, 16 per tile row processed),
 * an FMA counting 2 and a compare, select or integer op 1: forward 49 (conic quadratic 4,
 * exp 26, alpha and thresholds 8, transmittance 2, blend of colour+depth 8, bookkeeping 1),
 * backward 88 (alpha recomputed 35, reciprocal 5, transmittance 3, colour/depth gradient 8,
 * dL/dalpha 15, opacity 2, screen mean and conic 20). Per-Gaussian work (projection, SH,
 * sorting) is not counted, so the fraction of peak understates the machine's use. */
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "apps/mgs_cli.h"
#include "core/mgs_camera.h"
#include "core/mgs_gaussians.h"
#include "core/mgs_log.h"
#include "core/mgs_parallel.h"
#include "core/mgs_rng.h"
#include "render/mgs_loss.h"
#include "render/mgs_raster.h"
#include "train/mgs_train.h"
#if defined(__AVX512F__) || defined(__AVX2__)
#include <immintrin.h>
#endif

#define FLOPS_FWD 49.0
#define FLOPS_BWD 88.0

/* ---- peak FLOP/s: independent FMA chains on every thread ---- */
typedef struct peak_ctx { long iters; float sink[64]; } peak_ctx;

__attribute__((noinline)) static void peak_range(void *vctx, size_t b, size_t e) {
  peak_ctx *pc = vctx;
  volatile float vm = 0.999999f, vc = 1e-7f; /* opaque to the optimizer */
  const float mul = vm, add = vc;
  for (size_t t = b; t < e; t++) {
#if defined(__AVX512F__)
    __m512 a[12], m = _mm512_set1_ps(mul), c = _mm512_set1_ps(add);
    for (int k = 0; k < 12; k++) a[k] = _mm512_set1_ps((float)k);
    for (long i = 0; i < pc->iters; i++)
      for (int k = 0; k < 12; k++) a[k] = _mm512_fmadd_ps(a[k], m, c);
    __m512 s = a[0];
    for (int k = 1; k < 12; k++) s = _mm512_add_ps(s, a[k]);
    pc->sink[t % 64] = _mm512_reduce_add_ps(s);
#elif defined(__AVX2__) && defined(__FMA__)
    __m256 a[12], m = _mm256_set1_ps(mul), c = _mm256_set1_ps(add);
    for (int k = 0; k < 12; k++) a[k] = _mm256_set1_ps((float)k);
    for (long i = 0; i < pc->iters; i++)
      for (int k = 0; k < 12; k++) a[k] = _mm256_fmadd_ps(a[k], m, c);
    float o[8];
    _mm256_storeu_ps(o, a[0]);
    pc->sink[t % 64] = o[0];
#else
    float a[12] = {0};
    for (long i = 0; i < pc->iters; i++)
      for (int k = 0; k < 12; k++) a[k] = a[k] * mul + add;
    pc->sink[t % 64] = a[0];
#endif
  }
}

static double thread_cpu_now(void) {
  struct timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* per-core peak FLOP/s, in CPU time of the calling thread */
static double measure_peak(const char **isa) {
#if defined(__AVX512F__)
  const double lanes = 16; *isa = "AVX-512 FMA";
#elif defined(__AVX2__) && defined(__FMA__)
  const double lanes = 8; *isa = "AVX2 FMA";
#else
  const double lanes = 1; *isa = "scalar";
#endif
  peak_ctx pc;
  memset(&pc, 0, sizeof pc);
  pc.iters = 2000000;
  double best = 0;
  for (int rep = 0; rep < 3; rep++) {
    double t0 = thread_cpu_now();
    peak_range(&pc, 0, 1);
    double dt = thread_cpu_now() - t0;
    double flops = (double)pc.iters * 12 * lanes * 2;
    if (flops / dt > best) best = flops / dt;
  }
  return best;
}

/* ---- scene ---- */
static mgs_gaussians *bench_scene(size_t n, uint64_t seed) {
  mgs_gaussians *g = mgs_gaussians_create(n, 3);
  size_t first;
  if (!g || mgs_gaussians_append(g, n, &first, NULL) != MGS_OK) { mgs_gaussians_destroy(g); return NULL; }
  mgs_rng rng;
  mgs_rng_init(&rng, seed, 1);
  double s0 = 0.015 * cbrt(1e5 / (double)n);
  for (size_t i = 0; i < n; i++) {
    for (int k = 0; k < 3; k++) {
      g->mean[3 * i + k] = (float)(2.0 * mgs_rng_uniform(&rng) - 1.0);
      g->log_scale[3 * i + k] = (float)(log(s0) + 0.5 * mgs_rng_normal(&rng));
      g->sh_dc[3 * i + k] = (float)(0.8 * mgs_rng_normal(&rng));
    }
    for (int k = 0; k < 4; k++) g->rot[4 * i + k] = (float)mgs_rng_normal(&rng);
    g->opacity[i] = (float)(-1.0 + 2.0 * mgs_rng_normal(&rng));
    for (int k = 0; k < MGS_SH_REST_MAX; k++) g->sh_rest[MGS_SH_REST_MAX * i + k] = (float)(0.1 * mgs_rng_normal(&rng));
  }
  return g;
}

static double cpu_now(void) {
  struct timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static int cmp_double(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return x < y ? -1 : x > y;
}

typedef struct bench_result {
  double fwd_ms, bwd_ms, evals_f, evals_b, fwd_cpu, bwd_cpu;
  mgs_raster_profile prof;
  size_t n_isect, n_vis;
  double mean_radius;
} bench_result;

static int run_case(int size, size_t n, double min_time, bench_result *res) {
  mgs_error err;
  mgs_gaussians *g = bench_scene(n, 12345);
  mgs_gaussians *grad = bench_scene(n, 1);
  if (!g || !grad) { fprintf(stderr, "morsegs bench raster: out of memory for %zu Gaussians\n", n); return 1; }
  mgs_camera cam;
  mgs_camera_init_fovx(&cam, size, size, 60.0 * 3.14159265358979 / 180.0);
  double eye[3] = {2.4, -2.8, 1.6}, target[3] = {0, 0, 0}, up[3] = {0, 0, 1};
  mgs_camera_look_at(&cam, eye, target, up);
  mgs_raster_settings s;
  mgs_raster_settings_default(&s);
  s.sh_degree = 3;
  mgs_raster *r = mgs_raster_create();
  size_t np = (size_t)size * size;
  float *dl = malloc(np * 3 * sizeof(float));
  float *gm = malloc(n * sizeof(float));
  if (!r || !dl || !gm) { fprintf(stderr, "morsegs bench raster: out of memory\n"); return 1; }
  double tf[64], tb[64], cf[64], cb[64];
  int reps = 0;
  double t_start = mgs_now();
  for (int it = 0; it < 65; it++) {
    mgs_raster_output out;
    double c0 = cpu_now();
    double t0 = mgs_now();
    if (mgs_raster_forward(r, g, &cam, &s, &out, &err) != MGS_OK) return mgs_cli_fail("bench raster", &err);
    double t1 = mgs_now();
    double c1 = cpu_now();
    if (it == 0)
      for (size_t p = 0; p < 3 * np; p++) dl[p] = (out.color[p] > 0.5f ? 1.0f : -1.0f) / (float)(3 * np); /* an L1-like gradient */
    double c2 = cpu_now();
    double t2 = mgs_now();
    if (mgs_raster_backward(r, dl, NULL, NULL, grad, gm, &err) != MGS_OK) return mgs_cli_fail("bench raster", &err);
    double t3 = mgs_now();
    double c3 = cpu_now();
    if (it == 0) { /* warm-up */
      res->n_isect = out.n_intersections;
      res->n_vis = out.n_visible;
      double sr = 0;
      for (size_t i = 0; i < n; i++) sr += out.radii[i];
      res->mean_radius = out.n_visible ? sr / (double)out.n_visible : 0;
      continue;
    }
    tf[reps] = (t1 - t0) * 1e3;
    tb[reps] = (t3 - t2) * 1e3;
    cf[reps] = (c1 - c0) * 1e3;
    cb[reps] = (c3 - c2) * 1e3;
    reps++;
    if (reps >= 3 && mgs_now() - t_start > min_time) break;
  }
  mgs_raster_last_evals(r, &res->evals_f, &res->evals_b);
  mgs_raster_last_profile(r, &res->prof);
  qsort(tf, (size_t)reps, sizeof(double), cmp_double);
  qsort(tb, (size_t)reps, sizeof(double), cmp_double);
  res->fwd_ms = tf[reps / 2];
  res->bwd_ms = tb[reps / 2];
  qsort(cf, (size_t)reps, sizeof(double), cmp_double);
  qsort(cb, (size_t)reps, sizeof(double), cmp_double);
  res->fwd_cpu = cf[reps / 2];
  res->bwd_cpu = cb[reps / 2];
  free(dl); free(gm);
  mgs_raster_destroy(r);
  mgs_gaussians_destroy(g);
  mgs_gaussians_destroy(grad);
  return 0;
}

/* ---- a whole training iteration (--iteration) ----
 * The trainer's steady-state step (train/trainer.c) on the benchmark scene with SH degree
 * 3 active: forward, (1-0.2) L1 + 0.2 D-SSIM against a fixed target image (a render of
 * another random scene of the same kind), backward, Adam on every group with the reference
 * learning rates, fused into the backward as the trainer runs it outside densification
 * steps (--unfused: separate, clearing the gradients for the next backward). Each phase is
 * timed in wall and process CPU time (all threads); medians over the iterations, after two
 * warm-up iterations. */
/* ---- the machine's memory bandwidth: STREAM copy (c = a) and triad (a = b + s c) ----
 * Three arrays of STREAM_FLOATS floats (192 MB each, far beyond any last-level cache),
 * first touched in parallel; each kernel STREAM_REPS times on one thread (the whole range
 * as one mgs_parallel_for grain) and on all threads (grains of 1 M floats). Bytes as
 * STREAM counts them: copy 8 per element, triad 12 (the write-allocate read of the
 * destination not counted). Best and median of the repetitions, GB/s = 1e9 bytes/s, on
 * wall time and on process CPU time / threads (a shared machine takes the threads off the
 * cores: the CPU basis is what the phases' cpu GB/s compare with). */
#define STREAM_FLOATS ((size_t)48 << 20)
#define STREAM_REPS 7
typedef struct stream_ctx { float *a, *b, *c; int kernel; } stream_ctx;

static void stream_range(void *vctx, size_t b, size_t e) {
  stream_ctx *sc = vctx;
  float *restrict A = sc->a, *restrict B = sc->b, *restrict C = sc->c;
  const float s = 3.0f;
  if (sc->kernel == 0) for (size_t i = b; i < e; i++) A[i] = B[i] = C[i] = 1.0f; /* first touch */
  else if (sc->kernel == 1) for (size_t i = b; i < e; i++) C[i] = A[i];
  else for (size_t i = b; i < e; i++) A[i] = B[i] + s * C[i];
}

/* [1 thread, all][best, median] GB/s; cpu: on CPU time */
typedef struct stream_bw { double copy[2][2], triad[2][2], copy_cpu[2][2], triad_cpu[2][2]; } stream_bw;

static int measure_stream(stream_bw *bw) {
  stream_ctx sc;
  sc.a = malloc(STREAM_FLOATS * sizeof(float));
  sc.b = malloc(STREAM_FLOATS * sizeof(float));
  sc.c = malloc(STREAM_FLOATS * sizeof(float));
  if (!sc.a || !sc.b || !sc.c) { free(sc.a); free(sc.b); free(sc.c); return 1; }
  sc.kernel = 0;
  mgs_parallel_for(0, STREAM_FLOATS, 1 << 20, stream_range, &sc);
  for (int all = 0; all < 2; all++)
    for (int k = 1; k <= 2; k++) {
      double gbs[STREAM_REPS], gbc[STREAM_REPS];
      sc.kernel = k;
      int thr = all ? mgs_parallel_max_threads() : 1;
      for (int rep = 0; rep < STREAM_REPS; rep++) {
        double c0 = cpu_now(), t0 = mgs_now();
        mgs_parallel_for(0, STREAM_FLOATS, all ? (size_t)1 << 20 : STREAM_FLOATS, stream_range, &sc);
        double dt = mgs_now() - t0, dc = (cpu_now() - c0) / thr;
        double bytes = (double)STREAM_FLOATS * sizeof(float) * (k == 1 ? 2 : 3);
        gbs[rep] = bytes / dt * 1e-9;
        gbc[rep] = bytes / (dc > 0 ? dc : dt) * 1e-9;
      }
      qsort(gbs, STREAM_REPS, sizeof(double), cmp_double);
      qsort(gbc, STREAM_REPS, sizeof(double), cmp_double);
      double *o = k == 1 ? bw->copy[all] : bw->triad[all], *oc = k == 1 ? bw->copy_cpu[all] : bw->triad_cpu[all];
      o[0] = gbs[STREAM_REPS - 1];
      o[1] = gbs[STREAM_REPS / 2];
      oc[0] = gbc[STREAM_REPS - 1];
      oc[1] = gbc[STREAM_REPS / 2];
    }
  free(sc.a); free(sc.b); free(sc.c);
  return 0;
}

enum { PH_PROJECT, PH_BIN, PH_FWD_TILES, PH_LOSS, PH_ZERO, PH_BWD_TILES, PH_BWD_GAUSS, PH_ADAM, PH_TOTAL, PH_N };
static const char *const ph_name[PH_N] = {"project+SH", "bin+sort", "forward tiles", "loss L1+SSIM", "zero grads",
                                          "backward tiles", "per-Gaussian bwd", "Adam", "full iteration"};

static void read_loadavg(char *buf, size_t len) {
  buf[0] = 0;
  FILE *f = fopen("/proc/loadavg", "r");
  if (!f) { snprintf(buf, len, "?"); return; }
  if (!fgets(buf, (int)len, f)) snprintf(buf, len, "?");
  fclose(f);
  size_t l = strlen(buf);
  if (l && buf[l - 1] == '\n') buf[l - 1] = 0;
}

static int run_iteration(int size, size_t n, int iters, int fused, int bf16) {
  mgs_error err;
  mgs_error_clear(&err);
  mgs_gaussians *g = bench_scene(n, 12345), *other = bench_scene(n, 777);
  mgs_gaussians *grad = mgs_gaussians_create(n, 3);
  mgs_adam *adam = mgs_adam_create(n);
  size_t first;
  if (!g || !other || !grad || !adam || mgs_gaussians_append(grad, n, &first, &err) != MGS_OK) {
    fprintf(stderr, "morsegs bench raster: out of memory for %zu Gaussians\n", n);
    return 1;
  }
  /* the reference learning rates (scene extent ~ 2) */
  adam->lr[MGS_PARAM_MEAN] = 1.6e-4f * 2.0f; adam->lr[MGS_PARAM_LOG_SCALE] = 5e-3f; adam->lr[MGS_PARAM_ROT] = 1e-3f;
  adam->lr[MGS_PARAM_OPACITY] = 0.05f; adam->lr[MGS_PARAM_SH_DC] = 2.5e-3f; adam->lr[MGS_PARAM_SH_REST] = 1.25e-4f;
  adam->sh_rest_active = 15;
  if (mgs_adam_set_sh_rest_bf16(adam, bf16, &err)) { fprintf(stderr, "morsegs bench raster: %s\n", err.msg); return 1; }
  mgs_camera cam;
  mgs_camera_init_fovx(&cam, size, size, 60.0 * 3.14159265358979 / 180.0);
  double eye[3] = {2.4, -2.8, 1.6}, target[3] = {0, 0, 0}, up[3] = {0, 0, 1};
  mgs_camera_look_at(&cam, eye, target, up);
  mgs_raster_settings s;
  mgs_raster_settings_default(&s);
  s.sh_degree = 3;
  s.background[0] = s.background[1] = s.background[2] = 1.0f;
  mgs_raster *r = mgs_raster_create();
  size_t np = (size_t)size * size * 3;
  float *gt = malloc(np * sizeof(float)), *dl = malloc(np * sizeof(float)), *gm = malloc(n * sizeof(float));
  if (!r || !gt || !dl || !gm) { fprintf(stderr, "morsegs bench raster: out of memory\n"); return 1; }
  mgs_raster_output out;
  if (mgs_raster_forward(r, other, &cam, &s, &out, &err) != MGS_OK) return mgs_cli_fail("bench raster", &err);
  memcpy(gt, out.color, np * sizeof(float));
  mgs_gaussians_destroy(other);
  double (*wall)[PH_N] = calloc((size_t)iters, sizeof *wall), (*cpu)[PH_N] = calloc((size_t)iters, sizeof *cpu);
  if (!wall || !cpu) { fprintf(stderr, "morsegs bench raster: out of memory\n"); return 1; }
  stream_bw bw;
  if (measure_stream(&bw)) { fprintf(stderr, "morsegs bench raster: out of memory for the stream arrays\n"); return 1; }
  char la0[128], la1[128];
  read_loadavg(la0, sizeof la0);
  const float lam = 0.2f;
  double loss = 0;
  size_t isect = 0;
  int clean = 0;
  for (int it = -2; it < iters; it++) {
    double w[PH_N + 1], c[PH_N + 1];
    c[0] = cpu_now(); w[0] = mgs_now();
    if (mgs_raster_forward(r, g, &cam, &s, &out, &err) != MGS_OK) return mgs_cli_fail("bench raster", &err);
    w[1] = mgs_now(); c[1] = cpu_now();
    memset(dl, 0, np * sizeof(float));
    double l1 = mgs_loss_l1(out.color, gt, size, size, 3, 1.0f - lam, dl);
    double ss = mgs_ssim(out.color, gt, size, size, 3, -lam, dl);
    loss = (1.0 - lam) * l1 + lam * (1.0 - ss);
    (void)mgs_psnr(out.color, gt, size, size, 3); /* the trainer's progress figure */
    w[2] = mgs_now(); c[2] = cpu_now();
    if (!clean && !fused) /* as the trainer: Adam clears the gradients it consumed */
      for (int k = 0; k < MGS_PARAM_COUNT; k++)
        memset(mgs_gaussians_group(grad, (mgs_param_group)k), 0, n * (size_t)mgs_param_dim((mgs_param_group)k) * sizeof(float));
    w[3] = mgs_now(); c[3] = cpu_now();
    if (fused) { /* the trainer's steady state: Adam inside the backward */
      if (mgs_adam_step_backward(adam, g, r, dl, NULL, NULL, gm, (1u << MGS_PARAM_COUNT) - 1, &err) != MGS_OK)
        return mgs_cli_fail("bench raster", &err);
      w[4] = mgs_now(); c[4] = cpu_now();
    } else {
      if (mgs_raster_backward(r, dl, NULL, NULL, grad, gm, &err) != MGS_OK) return mgs_cli_fail("bench raster", &err);
      w[4] = mgs_now(); c[4] = cpu_now();
      if (mgs_adam_step_zero(adam, g, grad, (1u << MGS_PARAM_COUNT) - 1, 1, &err) != MGS_OK) return mgs_cli_fail("bench raster", &err);
    }
    clean = 1;
    w[5] = mgs_now(); c[5] = cpu_now();
    if (it < 0) continue;
    isect = out.n_intersections;
    mgs_raster_profile p;
    mgs_raster_last_profile(r, &p);
    double *W = wall[it], *C = cpu[it];
    W[PH_PROJECT] = p.project_ms; W[PH_BIN] = p.bin_ms; W[PH_FWD_TILES] = p.render_ms;
    C[PH_PROJECT] = p.project_cpu; C[PH_BIN] = p.bin_cpu; C[PH_FWD_TILES] = p.render_cpu;
    W[PH_LOSS] = (w[2] - w[1]) * 1e3; C[PH_LOSS] = (c[2] - c[1]) * 1e3;
    W[PH_ZERO] = (w[3] - w[2]) * 1e3; C[PH_ZERO] = (c[3] - c[2]) * 1e3;
    W[PH_BWD_TILES] = p.tiles_ms; C[PH_BWD_TILES] = p.tiles_cpu;
    /* the per-Gaussian part takes the rest of the backward call (gradient-norm clear too) */
    W[PH_BWD_GAUSS] = (w[4] - w[3]) * 1e3 - p.tiles_ms; C[PH_BWD_GAUSS] = (c[4] - c[3]) * 1e3 - p.tiles_cpu;
    W[PH_ADAM] = (w[5] - w[4]) * 1e3; C[PH_ADAM] = (c[5] - c[4]) * 1e3;
    W[PH_TOTAL] = (w[5] - w[0]) * 1e3; C[PH_TOTAL] = (c[5] - c[0]) * 1e3;
  }
  read_loadavg(la1, sizeof la1);
  /* bytes of the last iteration (the same every iteration: a fixed scene), counted from
     the layout by the modules that own the arrays */
  double by[PH_N][2];
  memset(by, 0, sizeof by);
  mgs_raster_counts rc;
  mgs_raster_bytes rb;
  mgs_raster_last_bytes(r, &rc, &rb);
  memcpy(by[PH_PROJECT], rb.project, sizeof rb.project);
  memcpy(by[PH_BIN], rb.bin, sizeof rb.bin);
  memcpy(by[PH_FWD_TILES], rb.render, sizeof rb.render);
  memcpy(by[PH_BWD_TILES], rb.tiles, sizeof rb.tiles);
  memcpy(by[PH_BWD_GAUSS], rb.reduce, sizeof rb.reduce);
  {
    double l1[2], ss[2], ps[2];
    mgs_loss_l1_bytes(size, size, 3, l1);
    mgs_ssim_bytes(size, size, 3, ss);
    mgs_psnr_bytes(size, size, 3, ps);
    by[PH_LOSS][0] = l1[0] + ss[0] + ps[0];
    by[PH_LOSS][1] = l1[1] + ss[1] + ps[1] + (double)np * sizeof(float); /* + clearing dL */
    double ar, aw;
    mgs_adam_bytes(adam, n, (1u << MGS_PARAM_COUNT) - 1, !fused, !fused, &ar, &aw);
    int k = fused ? PH_BWD_GAUSS : PH_ADAM;
    by[k][0] += ar; by[k][1] += aw;
    for (int q = 0; q < PH_TOTAL; q++) { by[PH_TOTAL][0] += by[q][0]; by[PH_TOTAL][1] += by[q][1]; }
  }
  printf("full training iteration: %dx%d, %zu Gaussians, SH degree 3, %zu tile intersections, %d iterations "
         "(median), %d threads, final loss %.4f\n", size, size, n, isect, iters, mgs_parallel_max_threads(), loss);
  printf("load average before: %s | after: %s\n", la0, la1);
  printf("backward and Adam: %s; SH-rest moments %s\n", fused ? "fused (mgs_adam_step_backward; per-Gaussian bwd includes Adam)" : "separate (--unfused)",
         bf16 ? "bfloat16 (--sh-moments-bf16)" : "float");
  printf("stream bandwidth (measured before the iterations, GB/s best / median of %d): copy 1 thread %.1f / %.1f, "
         "all threads %.1f / %.1f; triad 1 thread %.1f / %.1f, all threads %.1f / %.1f\n", STREAM_REPS, bw.copy[0][0],
         bw.copy[0][1], bw.copy[1][0], bw.copy[1][1], bw.triad[0][0], bw.triad[0][1], bw.triad[1][0], bw.triad[1][1]);
  printf("  on CPU time (bytes / (CPU s / threads)): copy 1 thread %.1f / %.1f, all threads %.1f / %.1f; triad 1 thread "
         "%.1f / %.1f, all threads %.1f / %.1f\n", bw.copy_cpu[0][0], bw.copy_cpu[0][1], bw.copy_cpu[1][0],
         bw.copy_cpu[1][1], bw.triad_cpu[0][0], bw.triad_cpu[0][1], bw.triad_cpu[1][0], bw.triad_cpu[1][1]);
  printf("counts: %zu Gaussians, %zu in front, %zu shaded, %zu binned, %zu intersections (forward visited %zu, backward "
         "%zu), %zu with a gradient, %d sort passes\n", rc.n, rc.n_front, rc.n_shaded, rc.n_binned, rc.n_isect,
         rc.fwd_visit, rc.bwd_visit, rc.n_live, rc.sort_passes);
  int nthr = mgs_parallel_max_threads();
  printf("bytes counted from the data layout (render/raster_bytes.c, render/loss_*.c, train/adam.c); GB/s = bytes / "
         "median wall, cpu GB/s = bytes / (median CPU ms / %d threads) (what an unshared machine would see when the "
         "phase keeps all threads busy); %% bw = cpu GB/s of the all-threads triad on CPU time (best)\n", nthr);
  printf("  %-18s %9s %9s %9s %9s %8s %8s %6s\n", "phase", "wall ms", "CPU ms", "MB read", "MB write", "GB/s", "cpu GB/s",
         "% bw");
  double col[2][PH_N];
  double *tmp = malloc((size_t)iters * sizeof(double));
  for (int k = 0; k < PH_N; k++)
    for (int which = 0; which < 2; which++) {
      for (int i = 0; i < iters; i++) tmp[i] = which ? cpu[i][k] : wall[i][k];
      qsort(tmp, (size_t)iters, sizeof(double), cmp_double);
      col[which][k] = tmp[iters / 2];
    }
  double sw = 0, sc = 0;
  for (int k = 0; k < PH_N; k++) {
    if (k == PH_TOTAL) printf("  %-18s %9.2f %9.2f\n", "(sum of medians)", sw, sc);
    double b = by[k][0] + by[k][1], gbs = col[0][k] > 0 ? b / (col[0][k] * 1e-3) * 1e-9 : 0;
    double cgbs = col[1][k] > 0 ? b / (col[1][k] / nthr * 1e-3) * 1e-9 : 0;
    if (b > 0)
      printf("  %-18s %9.2f %9.2f %9.2f %9.2f %8.1f %8.1f %5.0f%%\n", ph_name[k], col[0][k], col[1][k], by[k][0] * 1e-6,
             by[k][1] * 1e-6, gbs, cgbs, 100 * cgbs / bw.triad_cpu[1][0]);
    else printf("  %-18s %9.2f %9.2f\n", ph_name[k], col[0][k], col[1][k]);
    if (k < PH_TOTAL) { sw += col[0][k]; sc += col[1][k]; }
  }
  double floor_ms = (by[PH_TOTAL][0] + by[PH_TOTAL][1]) / (bw.triad_cpu[1][0] * 1e9) * 1e3;
  printf("bandwidth floor: %.1f MB / %.1f GB/s = %.2f ms (the iteration if every byte moved at the CPU-time triad's rate); "
         "CPU ms / %d threads = %.2f ms\n", (by[PH_TOTAL][0] + by[PH_TOTAL][1]) * 1e-6, bw.triad_cpu[1][0], floor_ms, nthr,
         col[1][PH_TOTAL] / nthr);
  printf("full iteration %dx%d %zuk SH3: %.2f ms wall, %.2f ms CPU (median; load %s)\n", size, size, n / 1000, col[0][PH_TOTAL],
         col[1][PH_TOTAL], la1);
  free(tmp); free(wall); free(cpu);
  free(gt); free(dl); free(gm);
  mgs_raster_destroy(r);
  mgs_adam_destroy(adam);
  mgs_gaussians_destroy(g);
  mgs_gaussians_destroy(grad);
  return 0;
}

/* ---- 2DGS vs 3DGS (--model 2dgs) ----
 * The trainer's fused step (forward, L1 + D-SSIM, backward with Adam) of the benchmark
 * scene as 3D Gaussians and as 2DGS surfels (the same centres, colours, opacities and the
 * first two scales; the scene's rotations), alternated A B A B in one run so that both see
 * the same machine load; medians over the iterations after two warm-up pairs, and the
 * median of the per-pair ratios. */
static int run_model_pair(int size, size_t n, int iters) {
  mgs_error err;
  mgs_error_clear(&err);
  mgs_gaussians *g[2] = {bench_scene(n, 12345), bench_scene(n, 12345)}, *other = bench_scene(n, 777);
  mgs_adam *adam[2] = {mgs_adam_create(n), mgs_adam_create(n)};
  mgs_raster *r[2] = {mgs_raster_create(), mgs_raster_create()};
  size_t np = (size_t)size * size * 3;
  float *gt = malloc(np * sizeof(float)), *dl = malloc(np * sizeof(float)), *gm = malloc(n * sizeof(float));
  double *t[2] = {calloc((size_t)iters, sizeof(double)), calloc((size_t)iters, sizeof(double))};
  double *tc[2] = {calloc((size_t)iters, sizeof(double)), calloc((size_t)iters, sizeof(double))};
  double *ratio = calloc((size_t)iters, sizeof(double));
  double *ph[2][5]; /* CPU ms of the rasterizer's phases */
  for (int m = 0; m < 2; m++)
    for (int k = 0; k < 5; k++) ph[m][k] = calloc((size_t)iters, sizeof(double));
  if (!g[0] || !g[1] || !other || !adam[0] || !adam[1] || !r[0] || !r[1] || !gt || !dl || !gm || !t[0] || !t[1] ||
      !tc[0] || !tc[1] || !ratio) {
    fprintf(stderr, "morsegs bench raster: out of memory for %zu Gaussians\n", n);
    return 1;
  }
  g[1]->kind = MGS_MODEL_2DGS;
  for (size_t i = 0; i < n; i++) g[1]->log_scale[3 * i + 2] = MGS_SURFEL_LOG_SCALE2;
  for (int m = 0; m < 2; m++) {
    mgs_adam *a = adam[m];
    a->lr[MGS_PARAM_MEAN] = 1.6e-4f * 2.0f; a->lr[MGS_PARAM_LOG_SCALE] = 5e-3f; a->lr[MGS_PARAM_ROT] = 1e-3f;
    a->lr[MGS_PARAM_OPACITY] = 0.05f; a->lr[MGS_PARAM_SH_DC] = 2.5e-3f; a->lr[MGS_PARAM_SH_REST] = 1.25e-4f;
    a->sh_rest_active = 15;
  }
  mgs_camera cam;
  mgs_camera_init_fovx(&cam, size, size, 60.0 * 3.14159265358979 / 180.0);
  double eye[3] = {2.4, -2.8, 1.6}, target[3] = {0, 0, 0}, up[3] = {0, 0, 1};
  mgs_camera_look_at(&cam, eye, target, up);
  mgs_raster_settings s;
  mgs_raster_settings_default(&s);
  s.sh_degree = 3;
  s.background[0] = s.background[1] = s.background[2] = 1.0f;
  mgs_raster_output out;
  if (mgs_raster_forward(r[0], other, &cam, &s, &out, &err) != MGS_OK) return mgs_cli_fail("bench raster", &err);
  memcpy(gt, out.color, np * sizeof(float));
  mgs_gaussians_destroy(other);
  char la0[128], la1[128];
  read_loadavg(la0, sizeof la0);
  size_t isect[2] = {0, 0};
  double evf[2] = {0, 0}, evb[2] = {0, 0};
  const float lam = 0.2f;
  for (int it = -2; it < iters; it++)
    for (int m = 0; m < 2; m++) {
      double c0 = cpu_now(), w0 = mgs_now();
      if (mgs_raster_forward(r[m], g[m], &cam, &s, &out, &err) != MGS_OK) return mgs_cli_fail("bench raster", &err);
      memset(dl, 0, np * sizeof(float));
      (void)mgs_loss_l1(out.color, gt, size, size, 3, 1.0f - lam, dl);
      (void)mgs_ssim(out.color, gt, size, size, 3, -lam, dl);
      if (mgs_adam_step_backward(adam[m], g[m], r[m], dl, NULL, NULL, gm, (1u << MGS_PARAM_COUNT) - 1, &err) != MGS_OK)
        return mgs_cli_fail("bench raster", &err);
      if (it < 0) continue;
      t[m][it] = (mgs_now() - w0) * 1e3;
      tc[m][it] = (cpu_now() - c0) * 1e3;
      mgs_raster_profile pr;
      mgs_raster_last_profile(r[m], &pr);
      ph[m][0][it] = pr.project_cpu; ph[m][1][it] = pr.bin_cpu; ph[m][2][it] = pr.render_cpu;
      ph[m][3][it] = pr.tiles_cpu; ph[m][4][it] = pr.reduce_cpu;
      isect[m] = out.n_intersections;
      mgs_raster_last_evals(r[m], &evf[m], &evb[m]);
      if (m == 1) ratio[it] = t[1][it] / t[0][it];
    }
  read_loadavg(la1, sizeof la1);
  double med[2], medc[2];
  for (int m = 0; m < 2; m++) {
    qsort(t[m], (size_t)iters, sizeof(double), cmp_double);
    qsort(tc[m], (size_t)iters, sizeof(double), cmp_double);
    med[m] = t[m][iters / 2];
    medc[m] = tc[m][iters / 2];
  }
  qsort(ratio, (size_t)iters, sizeof(double), cmp_double);
  printf("training iteration (forward, L1+D-SSIM, fused backward+Adam), %dx%d, %zu primitives, SH 3, %d pairs "
         "alternated 3DGS/2DGS, %d threads\n", size, size, n, iters, mgs_parallel_max_threads());
  printf("load average before: %s | after: %s\n", la0, la1);
  printf("  3DGS: %8.2f ms wall, %8.2f ms CPU (median), %zu tile intersections, %.3g / %.3g pixel evaluations\n", med[0],
         medc[0], isect[0], evf[0], evb[0]);
  printf("  2DGS: %8.2f ms wall, %8.2f ms CPU (median), %zu tile intersections, %.3g / %.3g pixel evaluations\n", med[1],
         medc[1], isect[1], evf[1], evb[1]);
  static const char *const phn[5] = {"project+SH", "bin+sort", "forward tiles", "backward tiles", "per-primitive bwd+Adam"};
  printf("  phase CPU ms (median)      3DGS      2DGS\n");
  for (int k = 0; k < 5; k++) {
    double v[2];
    for (int m = 0; m < 2; m++) {
      qsort(ph[m][k], (size_t)iters, sizeof(double), cmp_double);
      v[m] = ph[m][k][iters / 2];
      free(ph[m][k]);
    }
    printf("  %-22s %9.2f %9.2f\n", phn[k], v[0], v[1]);
  }
  printf("2DGS / 3DGS: %.2fx (median of per-pair wall ratios; CPU medians %.2fx)\n", ratio[iters / 2], medc[1] / medc[0]);
  for (int m = 0; m < 2; m++) {
    free(t[m]); free(tc[m]);
    mgs_raster_destroy(r[m]);
    mgs_adam_destroy(adam[m]);
    mgs_gaussians_destroy(g[m]);
  }
  free(ratio); free(gt); free(dl); free(gm);
  return 0;
}

int mgs_bench_raster(int argc, char **argv) {
  static const struct option longopts[] = {{"quick", no_argument, 0, 'q'}, {"threads", required_argument, 0, 't'},
                                           {"size", required_argument, 0, 's'}, {"gaussians", required_argument, 0, 'n'},
                                           {"iteration", no_argument, 0, 'I'}, {"iters", required_argument, 0, 'i'},
                                           {"unfused", no_argument, 0, 'U'}, {"sh-moments-bf16", no_argument, 0, 'B'}, {"model", required_argument, 0, 'M'},
                                           {"help", no_argument, 0, 'h'}, {0, 0, 0, 0}};
  int quick = 0, iteration = 0, unfused = 0, model2 = 0, bf16 = 0;
  long iters = 50;
  long threads = 0, one_size = 0, one_n = 0;
  optind = 1;
  opterr = 0;
  int c;
  while ((c = getopt_long(argc, argv, "h", longopts, NULL)) != -1) {
    char *end = NULL;
    switch (c) {
    case 'q': quick = 1; break;
    case 'I': iteration = 1; break;
    case 'U': unfused = 1; break;
    case 'B': bf16 = 1; break;
    case 'M':
      if (strcmp(optarg, "2dgs") && strcmp(optarg, "3dgs")) {
        fprintf(stderr, "morsegs bench raster: bad --model '%s' (3dgs or 2dgs)\n", optarg);
        return 2;
      }
      model2 = !strcmp(optarg, "2dgs");
      break;
    case 'i':
      iters = strtol(optarg, &end, 10);
      if (*end || iters < 1 || iters > 100000) { fprintf(stderr, "morsegs bench raster: bad --iters '%s'\n", optarg); return 2; }
      break;
    case 't':
      threads = strtol(optarg, &end, 10);
      if (*end || threads < 1 || threads > 1024) { fprintf(stderr, "morsegs bench raster: bad --threads '%s'\n", optarg); return 2; }
      break;
    case 's':
      one_size = strtol(optarg, &end, 10);
      if (*end || one_size < 16 || one_size > 8192) { fprintf(stderr, "morsegs bench raster: bad --size '%s'\n", optarg); return 2; }
      break;
    case 'n':
      one_n = strtol(optarg, &end, 10);
      if (*end || one_n < 1 || one_n > 100000000) { fprintf(stderr, "morsegs bench raster: bad --gaussians '%s'\n", optarg); return 2; }
      break;
    case 'h':
      printf("usage: morsegs bench raster [--quick] [--threads N] [--iteration [--iters N]]\n"
             "Forward and backward ms of the rasterizer at 200x200 and 800x800 with 10k, 100k and 1M\n"
             "Gaussians (SH degree 3), tile intersections, and the fraction of the measured peak FLOP/s.\n"
             "  --quick      only 200x200 with 10k and 100k Gaussians\n"
             "  --threads N  worker threads (default: all cores)\n"
             "  --size S --gaussians N  one case only (SxS image, N Gaussians)\n"
             "  --iteration  a whole training iteration instead (forward, L1+D-SSIM, backward, Adam; SH 3)\n"
             "               split by phase, wall and CPU ms, bytes read and written per phase (counted from\n"
             "               the data layout) against the machine's stream bandwidth measured in the same run;\n"
             "               default 200x200, 100k Gaussians\n"
             "  --iters N    iterations timed by --iteration (50)\n"
             "  --unfused    --iteration with the backward and Adam as separate passes (as the trainer on\n"
             "               densification steps)\n"
             "  --sh-moments-bf16  --iteration with the SH-rest Adam moments in bfloat16 (train --sh-moments-bf16)\n"
             "  --model 2dgs a training iteration of 2DGS surfels against 3DGS on the same scene, alternated\n"
             "               in one run (default 200x200, 100k primitives; --iters pairs, 50)\n");
      return 0;
    default: fprintf(stderr, "morsegs bench raster: bad option %s (see --help)\n", argv[optind - 1]); return 2;
    }
  }
  if (optind < argc) { fprintf(stderr, "morsegs bench raster: unexpected argument '%s'\n", argv[optind]); return 2; }
  if (threads > 0) mgs_parallel_set_threads((int)threads);
  if (model2) return run_model_pair(one_size ? (int)one_size : 200, one_n ? (size_t)one_n : 100000, (int)iters);
  if (iteration) return run_iteration(one_size ? (int)one_size : 200, one_n ? (size_t)one_n : 100000, (int)iters, !unfused, bf16);
  int nthr = mgs_parallel_max_threads();
  const char *isa = "";
  double peak = measure_peak(&isa);
  printf("threads %d; measured peak %.1f GFLOP/s per core (%s, in CPU time), %.1f GFLOP/s for %d threads\n", nthr,
         peak * 1e-9, isa, peak * nthr * 1e-9, nthr);
  printf("FLOP model: %.0f per Gaussian-pixel evaluation forward, %.0f backward; %%pk = kernel flops / (CPU time x\n"
         "per-core peak); ms = median wall, cpu = median process CPU time (all threads); mean r = mean 3-sigma radius px\n\n",
         FLOPS_FWD, FLOPS_BWD);
  printf("%-8s %9s %9s %6s %9s %9s %9s %9s %9s %8s %8s\n", "size", "gaussians", "isect", "mean r", "fwd evals",
         "fwd ms", "bwd ms", "fwd cpu", "bwd cpu", "fwd %pk", "bwd %pk");
  int sizes[2] = {200, 800};
  size_t counts[3] = {10000, 100000, 1000000};
  int nsz = 2, ncnt = 3;
  if (one_size || one_n) {
    sizes[0] = one_size ? (int)one_size : 200;
    counts[0] = one_n ? (size_t)one_n : 100000;
    nsz = ncnt = 1;
  }
  for (int si = 0; si < nsz; si++)
    for (int ci = 0; ci < ncnt; ci++) {
      if (quick && (si > 0 || ci > 1)) continue;
      bench_result res;
      memset(&res, 0, sizeof res);
      if (run_case(sizes[si], counts[ci], quick ? 1.0 : 2.0, &res)) return 1;
      double pf = res.evals_f * FLOPS_FWD / (res.fwd_cpu * 1e-3) / peak * 100;
      double pb = res.evals_b * FLOPS_BWD / (res.bwd_cpu * 1e-3) / peak * 100;
      char sz[32];
      snprintf(sz, sizeof sz, "%dx%d", sizes[si], sizes[si]);
      printf("%-8s %9zu %9zu %6.1f %9.3g %9.2f %9.2f %9.2f %9.2f %7.1f%% %7.1f%%\n", sz, counts[ci], res.n_isect,
             res.mean_radius, res.evals_f, res.fwd_ms, res.bwd_ms, res.fwd_cpu, res.bwd_cpu, pf, pb);
      printf("         phases of the last call (wall ms): project %.2f, bin+sort %.2f, tiles %.2f | tiles %.2f, "
             "per-Gaussian %.2f\n", res.prof.project_ms, res.prof.bin_ms, res.prof.render_ms, res.prof.tiles_ms,
             res.prof.reduce_ms);
      fflush(stdout);
    }
  return 0;
}

/* Cost of LPVI and of one PersLoss evaluation (not a test; built beside the tests):
 *   bench_topogs lpvi N [faithful]   N points sampled on a torus (NeRF-synthetic scale,
 *                                    extent 4.4342) with noise 0.002
 *   bench_topogs persloss W H F      a W x H synthetic image pair, downsampling F */
#include "mgs_test.h"
#include "core/mgs_log.h"
#include "core/mgs_parallel.h"
#include "core/mgs_rng.h"
#include "train/mgs_lpvi.h"
#include "train/mgs_persloss.h"

int main(int argc, char **argv) {
  if (argc >= 3 && !strcmp(argv[1], "lpvi")) {
    size_t n = (size_t)atol(argv[2]);
    int faithful = argc > 3 && !strcmp(argv[3], "faithful");
    float *xyz = malloc(3 * n * sizeof *xyz), *rgb = malloc(3 * n * sizeof *rgb);
    mgs_rng g;
    mgs_rng_init(&g, 1, 1);
    for (size_t i = 0; i < n; i++) {
      double u = 2 * M_PI * mgs_rng_uniform(&g), v = 2 * M_PI * mgs_rng_uniform(&g);
      double R = 1.0, r = 0.4;
      xyz[3*i] = (float)((R + r * cos(v)) * cos(u) + 0.002 * mgs_rng_normal(&g));
      xyz[3*i+1] = (float)((R + r * cos(v)) * sin(u) + 0.002 * mgs_rng_normal(&g));
      xyz[3*i+2] = (float)(r * sin(v) + 0.002 * mgs_rng_normal(&g));
      for (int k = 0; k < 3; k++) rgb[3*i+k] = (float)mgs_rng_uniform(&g);
    }
    mgs_lpvi_options o;
    mgs_lpvi_options_default(&o);
    o.faithful = faithful;
    o.extent = MGS_LPVI_REF_EXTENT;
    float *ox, *oc; size_t on; mgs_lpvi_stats s; mgs_error err = {0};
    if (mgs_init_lpvi(xyz, rgb, n, &o, &ox, &oc, &on, &s, &err)) { fprintf(stderr, "%s\n", err.msg); return 1; }
    printf("lpvi %s: %zu points in, %zu out, %zu added, %zu neighbourhoods (%zu 3-D, %zu tangent), %zu discarded, %.2f s, %.1f s per 100k input points, %d threads\n",
           faithful ? "faithful" : "corrected", n, on, s.added, s.processed, s.accepted_3d, s.tangent_2d, s.discarded, s.seconds,
           s.seconds * 1e5 / (double)n, mgs_parallel_max_threads());
    free(ox); free(oc); free(xyz); free(rgb);
    return 0;
  }
  if (argc >= 5 && !strcmp(argv[1], "persloss")) {
    int w = atoi(argv[2]), h = atoi(argv[3]);
    mgs_persloss_options o;
    mgs_persloss_options_default(&o);
    o.downsample = atof(argv[4]);
    float *a = malloc((size_t)w * h * 3 * sizeof *a), *gt = malloc((size_t)w * h * 3 * sizeof *gt), *gr = calloc((size_t)w * h * 3, sizeof *gr);
    mgs_rng g;
    mgs_rng_init(&g, 2, 2);
    for (int y = 0; y < h; y++) for (int x = 0; x < w; x++) for (int c = 0; c < 3; c++) {
      double base = 0.5 + 0.4 * sin(0.02 * x + c) * cos(0.015 * y);
      gt[(y * w + x) * 3 + c] = (float)base;
      a[(y * w + x) * 3 + c] = (float)(base + 0.05 * (mgs_rng_uniform(&g) - 0.5));
    }
    double L, t0 = mgs_now();
    mgs_error err = {0};
    int reps = 3;
    for (int r = 0; r < reps; r++)
      if (mgs_persloss_eval(&o, a, gt, w, h, 1.0, &L, gr, &err)) { fprintf(stderr, "%s\n", err.msg); return 1; }
    double dt = (mgs_now() - t0) / reps;
    printf("persloss %dx%d f=%.3g (%dx%d points per image): loss %.4g, %.3f s per call (both images' diagrams + gradient; the term caches the ground truth's, so about half)\n",
           w, h, o.downsample, (int)floor(w * o.downsample), (int)floor(h * o.downsample), L, dt);
    free(a); free(gt); free(gr);
    return 0;
  }
  fprintf(stderr, "usage: bench_topogs lpvi N [faithful] | persloss W H F\n");
  return 2;
}

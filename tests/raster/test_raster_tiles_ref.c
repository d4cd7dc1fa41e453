/* The 3DGS tile kernels against their code before the 8-lane rows (raster_tiles_ref.c),
 * bit for bit: on random scenes (SH degrees 0..3, images whose sides are not multiples of
 * 16, tiny and huge scales, opacities near 1/255 and near 1 so that the 1/255 skip, the
 * 0.99 clamp and the T < 1e-4 stop all happen), the forward's colour, alpha, depth, final
 * transmittance, contributor counts and row counts, then the backward's intersection
 * gradient slots and row counts with and without dL/dalpha and dL/ddepth, with the
 * normal-map gradient, and with output gradients that are huge, infinite or NaN in places
 * (the kernels' "tame" guard). The per-Gaussian part of the backward (slot sums, the
 * projection backward, the 2D-mean gradient) reads only the slots and did not change. */
#include <stdio.h>
#include "mgs_test.h"
#include "raster_test_util.h"
#include "render/raster_kernel.h"

void ref_render_tiles(mgs_raster *r);
void ref_backward_tiles(mgs_raster *r, const float *dL_dcolor, const float *dL_dalpha, const float *dL_ddepth,
                        const float *dL_dnormal);

typedef struct tcase {
  const char *name;
  int w, h, sh;
  scene_opts so;
  double dist;
  int extremes; /* huge / inf / NaN output gradients in a few pixels */
} tcase;

/* bit-for-bit equality of float arrays, reporting the first difference. Two NaNs count as
 * equal whatever their sign and payload: which NaN an operation with two NaN operands
 * returns follows the operand order the compiler picked (x86 returns the first), which
 * differs between -O2 and -O3 builds of the same code. */
static int same_bits(const char *what, const char *cname, const void *a, const void *b, size_t bytes) {
  const unsigned char *x = a, *y = b;
  size_t nan_only = 0;
  for (size_t k = 0; k + 4 <= bytes; k += 4) {
    uint32_t wa, wb;
    memcpy(&wa, x + k, 4);
    memcpy(&wb, y + k, 4);
    if (wa == wb) continue;
    float fa, fb;
    memcpy(&fa, &wa, 4);
    memcpy(&fb, &wb, 4);
    if (isnan(fa) && isnan(fb)) { nan_only++; continue; }
    fprintf(stderr, "  %s: %s differs first at word %zu of %zu: %08x, reference %08x\n", cname, what, k / 4,
            bytes / 4, wa, wb);
    return 0;
  }
  if (nan_only) fprintf(stderr, "  %s: %s: %zu NaNs of another sign or payload\n", cname, what, nan_only);
  return 1;
}

/* the same for integer arrays: exact */
static int same_ints(const char *what, const char *cname, const void *a, const void *b, size_t bytes) {
  if (!memcmp(a, b, bytes)) return 1;
  fprintf(stderr, "  %s: %s differ\n", cname, what);
  return 0;
}

static float *dup(const void *p, size_t bytes) {
  float *q = malloc(bytes ? bytes : 1);
  memcpy(q, p, bytes);
  return q;
}

static void fill(float *p, size_t n, mgs_rng *rng, double lo, double hi) {
  for (size_t i = 0; i < n; i++) p[i] = (float)rt_uniform(rng, lo, hi);
}

/* A few pixels of an output gradient made huge, infinite, NaN or -0. */
static void spoil(float *p, size_t n, mgs_rng *rng) {
  const float bad[5] = {1e20f, -INFINITY, NAN, -0.0f, 3e38f};
  for (int k = 0; k < 5; k++) p[(size_t)(mgs_rng_uniform(rng) * (double)n) % n] = bad[k];
}

/* The backward's slots and row counts, new kernel against the reference; nrm: with the
 * normal-map gradient. */
static void check_backward(const char *cname, mgs_raster *r, const float *dc, const float *da, const float *dd,
                           const float *dn) {
  size_t nt = (size_t)r->tiles_x * r->tiles_y, ns = r->n_isect * GS_STRIDE;
  memset(r->isect_grad, 0x7f, ns * sizeof(float));
  mgs_raster_backward_tiles(r, dc, da, dd);
  float *g_new = dup(r->isect_grad, ns * sizeof(float));
  uint32_t *ev_new = (uint32_t *)dup(r->tile_evals, nt * sizeof(uint32_t));
  uint32_t *vis_new = (uint32_t *)dup(r->tile_visit, 2 * nt * sizeof(uint32_t));
  memset(r->isect_grad, 0x7f, ns * sizeof(float));
  ref_backward_tiles(r, dc, da, dd, dn);
  char what[64];
  snprintf(what, sizeof what, "slots (alpha %d depth %d normal %d)", da != NULL, dd != NULL, dn != NULL);
  CHECK_MSG(same_bits(what, cname, g_new, r->isect_grad, ns * sizeof(float)), "%s: backward %s", cname, what);
  CHECK_MSG(same_ints("backward row counts", cname, ev_new, r->tile_evals, nt * sizeof(uint32_t)), "%s", cname);
  CHECK_MSG(same_ints("backward visits", cname, vis_new, r->tile_visit, 2 * nt * sizeof(uint32_t)), "%s", cname);
  size_t nz = 0;
  for (size_t k = 0; k < ns; k++) nz += g_new[k] != 0;
  CHECK_MSG(nz > 0, "%s: every slot zero", cname);
  free(g_new); free(ev_new); free(vis_new);
}

static void run_case(const tcase *tc, uint64_t seed) {
  mgs_gaussians *g = rt_random_scene(seed, &tc->so);
  mgs_camera cam;
  const double target[3] = {0, 0, 0};
  rt_camera(&cam, tc->w, tc->h, 1.0, tc->dist, target, seed);
  mgs_raster_settings s;
  mgs_raster_settings_default(&s);
  s.sh_degree = tc->sh;
  s.background[0] = 0.25f; s.background[1] = 0.5f; s.background[2] = 1.0f;
  mgs_raster *r = mgs_raster_create();
  mgs_raster_output out;
  mgs_error err;
  char cname[96];
  snprintf(cname, sizeof cname, "%s seed %llu", tc->name, (unsigned long long)seed);
  CHECK_OK(mgs_raster_forward(r, g, &cam, &s, &out, &err), &err);
  size_t np = (size_t)tc->w * tc->h, nt = (size_t)r->tiles_x * r->tiles_y;
  /* the forward, new against the reference over the same binned lists */
  float *col = dup(r->out_color, 3 * np * sizeof(float)), *al = dup(r->out_alpha, np * sizeof(float));
  float *dep = dup(r->out_depth, np * sizeof(float)), *tf = dup(r->final_T, np * sizeof(float));
  int32_t *nc = (int32_t *)dup(r->n_contrib, np * sizeof(int32_t));
  uint32_t *ev = (uint32_t *)dup(r->tile_evals, nt * sizeof(uint32_t));
  uint32_t *vis = (uint32_t *)dup(r->tile_visit, 2 * nt * sizeof(uint32_t));
  ref_render_tiles(r);
  CHECK_MSG(same_bits("colour", cname, col, r->out_color, 3 * np * sizeof(float)), "%s", cname);
  CHECK_MSG(same_bits("alpha", cname, al, r->out_alpha, np * sizeof(float)), "%s", cname);
  CHECK_MSG(same_bits("depth", cname, dep, r->out_depth, np * sizeof(float)), "%s", cname);
  CHECK_MSG(same_bits("final T", cname, tf, r->final_T, np * sizeof(float)), "%s", cname);
  CHECK_MSG(same_ints("contributors", cname, nc, r->n_contrib, np * sizeof(int32_t)), "%s", cname);
  CHECK_MSG(same_ints("forward row counts", cname, ev, r->tile_evals, nt * sizeof(uint32_t)), "%s", cname);
  CHECK_MSG(same_ints("forward visits", cname, vis, r->tile_visit, 2 * nt * sizeof(uint32_t)), "%s", cname);
  /* how much of the thresholds the scene exercises */
  size_t stopped = 0, covered = 0;
  for (size_t p = 0; p < np; p++) { stopped += r->final_T[p] < 1e-3f; covered += r->n_contrib[p] > 0; }
  fprintf(stderr, "  %s: %zu Gaussians, %zu intersections, %zu of %zu pixels covered, %zu near the T stop\n", cname,
          g->n, r->n_isect, covered, np, stopped);
  CHECK_MSG(r->n_isect > 0, "%s: nothing binned", cname);

  mgs_rng rng;
  mgs_rng_init(&rng, seed, 5);
  float *dc = malloc(3 * np * sizeof(float)), *da = malloc(np * sizeof(float)), *dd = malloc(np * sizeof(float));
  fill(dc, 3 * np, &rng, -1, 1);
  fill(da, np, &rng, -1, 1);
  fill(dd, np, &rng, -0.3, 0.3);
  if (tc->extremes) { spoil(dc, 3 * np, &rng); spoil(da, np, &rng); spoil(dd, np, &rng); }
  check_backward(cname, r, dc, NULL, NULL, NULL);
  check_backward(cname, r, dc, da, NULL, NULL);
  check_backward(cname, r, dc, NULL, dd, NULL);
  check_backward(cname, r, dc, da, dd, NULL);
  /* the normal-map gradient's instance of the kernel */
  mgs_raster_map_grad mg;
  CHECK_OK(mgs_raster_map_grads(r, &mg, &err), &err);
  fill(mg.normal, 3 * np, &rng, -1, 1);
  if (tc->extremes) spoil(mg.normal, 3 * np, &rng);
  check_backward(cname, r, dc, da, dd, mg.normal);

  free(col); free(al); free(dep); free(tf); free(nc); free(ev); free(vis);
  free(dc); free(da); free(dd);
  mgs_raster_destroy(r);
  mgs_gaussians_destroy(g);
}

static void test_same_as_reference(void) {
  /* n, spread, scale lo/hi, logit mu/sigma, SH sigma */
  const tcase cases[] = {
      {"mixed 100x100 SH3", 100, 100, 3, {600, 1.0, 0.005, 0.3, 0.0, 2.0, 0.3}, 4.0, 0},
      {"mixed 77x45 SH2", 77, 45, 2, {400, 1.0, 0.01, 0.2, 0.0, 2.5, 0.3}, 3.5, 0},
      {"tiny 33x17 SH1", 33, 17, 1, {300, 0.6, 1e-4, 3e-3, 1.0, 2.0, 0.3}, 3.0, 0},
      {"huge 50x38 SH0", 50, 38, 0, {60, 1.0, 0.5, 40.0, -1.0, 2.0, 0.3}, 4.0, 0},
      {"opaque 64x48 SH3", 64, 48, 3, {500, 1.0, 0.01, 0.2, 8.0, 2.0, 0.3}, 4.0, 0},
      {"faint 70x70 SH1", 70, 70, 1, {800, 1.0, 0.01, 0.4, -5.3, 0.4, 0.3}, 4.0, 0},
      {"near camera 61x29 SH2", 61, 29, 2, {300, 2.0, 0.01, 0.5, 1.0, 2.0, 0.3}, 1.5, 0},
      {"extremes 90x52 SH3", 90, 52, 3, {500, 1.0, 0.005, 0.3, 0.5, 2.5, 0.3}, 4.0, 1},
      {"one pixel row 16x1 SH0", 16, 1, 0, {200, 1.0, 0.01, 0.3, 0.0, 2.0, 0.3}, 3.0, 0},
      {"5x3 SH3", 5, 3, 3, {100, 1.0, 0.05, 0.5, 0.0, 2.0, 0.3}, 3.0, 1},
  };
  for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++)
    for (uint64_t seed = 1; seed <= 3; seed++) run_case(&cases[k], 100 * k + seed);
}

/* The kernels' power floor (MGS_ROWS8 builds): below it, opacity * exp() < 1/255 for
 * certain. Every 16th float opacity of [1/255, 256/255) (the inline bound) and a few
 * outside (the log): at least 0.019 under log((1/255) / opacity) in double, and the
 * kernels' own exp at the floor times the opacity under 1/255. */
static void test_power_floor(void) {
#if defined(MGS_ROWS8)
  float lo = MGS_ALPHA_MIN;
  uint32_t b;
  memcpy(&b, &lo, sizeof b);
  size_t n = 0, bad = 0;
  double worst = 1.0;
  for (;; b += 16) {
    float op;
    memcpy(&op, &b, sizeof op);
    if (op * 255.0f >= 256.0f) break;
    float f = mgs_power_floor(op);
    double margin = log((double)MGS_ALPHA_MIN / op) - f;
    float a = op * v8f_exp_neg(v8f_set1(f))[0];
    if (!(margin >= 0.019) || !(a < MGS_ALPHA_MIN)) bad++;
    if (margin < worst) worst = margin;
    n++;
  }
  const float other[4] = {1.5f, 1e30f, 0.001f, 1e-30f};
  for (int k = 0; k < 4; k++) {
    float f = mgs_power_floor(other[k]);
    if (!(log((double)MGS_ALPHA_MIN / other[k]) - f >= 0.019)) bad++;
  }
  fprintf(stderr, "  %zu opacities, smallest margin %.6f\n", n, worst);
  CHECK_MSG(bad == 0, "%zu opacities with the power floor too high", bad);
  CHECK(isnan(mgs_power_floor(NAN)));
#else
  CHECK(1); /* the 16-lane kernels have no floor */
#endif
}

int main(void) {
  RUN(test_power_floor);
  RUN(test_same_as_reference);
  return mgs_test_finish();
}

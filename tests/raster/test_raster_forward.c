/* The tiled forward equals the brute-force per-pixel reference (raster_test_util.h) on
 * random scenes: colour, alpha, depth to 2e-5 absolute (colour, alpha; the float
 * projection's relative error ~1e-6 times up to ~20 layers) and 2e-5 relative (depth),
 * on every pixel whose result does not hinge on a threshold decision within rounding
 * (those are counted and must stay rare); radii equal. */
#include <stdio.h>
#include "mgs_test.h"
#include "raster_test_util.h"

static void compare_case(const char *name, const mgs_gaussians *g, const mgs_camera *cam, const mgs_raster_settings *s) {
  mgs_raster *r = mgs_raster_create();
  mgs_raster_output out;
  mgs_error err;
  CHECK_OK(mgs_raster_forward(r, g, cam, s, &out, &err), &err);
  int W = cam->width, H = cam->height;
  size_t np = (size_t)W * H;
  double *col = malloc(np * 3 * sizeof(double)), *al = malloc(np * sizeof(double)), *dp = malloc(np * sizeof(double));
  unsigned char *amb = malloc(np);
  bf_gauss *proj = NULL;
  bf_render(g, cam, s, col, al, dp, amb, &proj);
  size_t n_amb = 0, n_bad = 0;
  double max_err = 0, max_derr = 0;
  for (size_t p = 0; p < np; p++) {
    if (amb[p]) { n_amb++; continue; }
    double e = fabs(out.alpha[p] - al[p]);
    for (int c = 0; c < 3; c++) e = fmax(e, fabs(out.color[3 * p + c] - col[3 * p + c]));
    double de = fabs(out.depth[p] - dp[p]) / (1 + fabs(dp[p]));
    if (e > max_err) max_err = e;
    if (de > max_derr) max_derr = de;
    if (e > 2e-5 || de > 2e-5) {
      if (n_bad < 5)
        fprintf(stderr, "  %s: pixel (%zu,%zu) color %g %g %g vs %g %g %g alpha %g vs %g depth %g vs %g\n", name,
                p % W, p / W, out.color[3 * p], out.color[3 * p + 1], out.color[3 * p + 2], col[3 * p], col[3 * p + 1],
                col[3 * p + 2], out.alpha[p], al[p], out.depth[p], dp[p]);
      n_bad++;
    }
  }
  size_t nvis = 0, rad_bad = 0;
  for (size_t i = 0; i < g->n; i++) {
    nvis += proj[i].visible;
    if (!proj[i].ambiguous && out.radii[i] != (proj[i].visible ? proj[i].radius : 0)) rad_bad++;
  }
  fprintf(stderr, "  %s: %zu px, %zu ambiguous, max err %.3g (depth rel %.3g), %zu/%zu visible, %zu isect\n", name, np,
          n_amb, max_err, max_derr, nvis, g->n, out.n_intersections);
  CHECK_MSG(n_bad == 0, "%s: %zu pixels differ", name, n_bad);
  CHECK_MSG(n_amb * 100 <= np, "%s: %zu ambiguous pixels (> 1%%)", name, n_amb);
  CHECK_MSG(rad_bad == 0, "%s: %zu radii differ", name, rad_bad);
  CHECK(out.n_visible >= nvis - (nvis > 0 ? 1 : 0) && out.n_visible <= nvis + 1);
  /* a second forward on the same context gives the same image (buffers reused) */
  float c0 = out.color[3 * (np / 2)];
  CHECK_OK(mgs_raster_forward(r, g, cam, s, &out, &err), &err);
  CHECK(out.color[3 * (np / 2)] == c0);
  free(col); free(al); free(dp); free(amb); free(proj);
  mgs_raster_destroy(r);
}

static void test_random_scenes(void) {
  static const int sizes[][2] = {{61, 47}, {32, 32}, {80, 50}};
  for (int seed = 1; seed <= 6; seed++) {
    scene_opts o = {300, 1.0, 0.02, 0.3, 0.0, 1.5, 0.3};
    mgs_gaussians *g = rt_random_scene((uint64_t)seed, &o);
    mgs_camera cam;
    double target[3] = {0, 0, 0};
    const int *sz = sizes[seed % 3];
    rt_camera(&cam, sz[0], sz[1], 0.9, 3.5, target, (uint64_t)seed);
    mgs_raster_settings s;
    mgs_raster_settings_default(&s);
    s.sh_degree = seed % 4;
    s.background[0] = 0.1f * seed; s.background[1] = 0.5f; s.background[2] = 1.0f - 0.1f * seed;
    char name[64];
    snprintf(name, sizeof name, "random seed %d sh %d", seed, s.sh_degree);
    compare_case(name, g, &cam, &s);
    mgs_gaussians_destroy(g);
  }
}

/* Off-centre principal point, Gaussians beyond the image edges (the Jacobian clamp),
 * scale modifier, camera close (near plane culls some). */
static void test_offcentre_offscreen(void) {
  scene_opts o = {400, 2.5, 0.05, 0.6, 0.5, 1.0, 0.3};
  mgs_gaussians *g = rt_random_scene(42, &o);
  mgs_camera cam;
  double target[3] = {0.2, -0.1, 0.0};
  rt_camera(&cam, 64, 48, 1.0, 2.2, target, 42);
  cam.cx = 20.0; cam.cy = 30.5; cam.fy = cam.fx * 1.1;
  mgs_raster_settings s;
  mgs_raster_settings_default(&s);
  s.sh_degree = 3;
  s.scale_modifier = 0.8f;
  compare_case("off-centre, off-screen", g, &cam, &s);
  mgs_gaussians_destroy(g);
}

/* Many opaque Gaussians: pixels terminate at T < 1e-4, alpha clamps at 0.99. */
static void test_opaque_termination(void) {
  scene_opts o = {1500, 0.6, 0.05, 0.4, 4.0, 2.0, 0.2};
  mgs_gaussians *g = rt_random_scene(7, &o);
  mgs_camera cam;
  double target[3] = {0, 0, 0};
  rt_camera(&cam, 40, 33, 0.8, 3.0, target, 7);
  mgs_raster_settings s;
  mgs_raster_settings_default(&s);
  s.sh_degree = 1;
  s.background[1] = 1.0f;
  compare_case("opaque, early termination", g, &cam, &s);
  mgs_gaussians_destroy(g);
}

static void test_bad_arguments(void) {
  scene_opts o = {10, 1.0, 0.05, 0.2, 0, 1, 0.1};
  mgs_gaussians *g = rt_random_scene(3, &o);
  mgs_camera cam;
  double target[3] = {0, 0, 0};
  rt_camera(&cam, 16, 16, 0.9, 3.0, target, 3);
  mgs_raster_settings s;
  mgs_raster_settings_default(&s);
  mgs_raster *r = mgs_raster_create();
  mgs_raster_output out;
  mgs_error err;
  mgs_error_clear(&err);
  /* backward before any forward */
  float dl[16 * 16 * 3] = {0};
  mgs_gaussians *grad = mgs_gaussians_clone(g);
  CHECK(mgs_raster_backward(r, dl, NULL, NULL, grad, NULL, &err) == MGS_ERR_ARG);
  s.sh_degree = 4;
  CHECK(mgs_raster_forward(r, g, &cam, &s, &out, &err) == MGS_ERR_ARG);
  CHECK(strstr(err.msg, "SH degree") != NULL);
  s.sh_degree = 0;
  mgs_camera bad = cam;
  bad.width = 0;
  CHECK(mgs_raster_forward(r, g, &bad, &s, &out, &err) == MGS_ERR_ARG);
  bad = cam;
  bad.fx = NAN;
  CHECK(mgs_raster_forward(r, g, &bad, &s, &out, &err) == MGS_ERR_ARG);
  CHECK_OK(mgs_raster_forward(r, g, &cam, &s, &out, &err), &err);
  mgs_gaussians *small = mgs_gaussians_create(4, 3);
  CHECK(mgs_raster_backward(r, dl, NULL, NULL, small, NULL, &err) == MGS_ERR_ARG);
  mgs_gaussians_destroy(small);
  mgs_gaussians_destroy(grad);
  mgs_gaussians_destroy(g);
  mgs_raster_destroy(r);
}

/* --large (label slow): bigger images and scenes, every SH degree, many tiles. */
static void test_large_scenes(void) {
  for (int seed = 20; seed < 24; seed++) {
    scene_opts o = {4000, 1.2, 0.01, 0.25, -0.5, 2.0, 0.3};
    mgs_gaussians *g = rt_random_scene((uint64_t)seed, &o);
    mgs_camera cam;
    double target[3] = {0.1, 0, -0.1};
    rt_camera(&cam, 160, 120, 1.0, 3.0, target, (uint64_t)seed);
    mgs_raster_settings s;
    mgs_raster_settings_default(&s);
    s.sh_degree = seed % 4;
    s.background[0] = 1.0f; s.background[2] = 0.5f;
    char name[64];
    snprintf(name, sizeof name, "large seed %d sh %d", seed, s.sh_degree);
    compare_case(name, g, &cam, &s);
    mgs_gaussians_destroy(g);
  }
}

int main(int argc, char **argv) {
  if (argc > 1 && !strcmp(argv[1], "--large")) {
    RUN(test_large_scenes);
    return mgs_test_finish();
  }
  RUN(test_random_scenes);
  RUN(test_offcentre_offscreen);
  RUN(test_opaque_termination);
  RUN(test_bad_arguments);
  return mgs_test_finish();
}

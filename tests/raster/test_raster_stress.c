/* Numerical stress suite of the rasterizer (SPEC section 7): nothing becomes NaN/Inf in
 * images or gradients, and outputs stay within the tolerances stated per case:
 *  - scales from 1e-7 to 1e3 of the scene extent
 *  - opacities saturating at 0 and 1 (logits -30 and +30)
 *  - near-singular covariances (one scale 1e-9 of the others)
 *  - 10^5 Gaussians over one pixel
 *  - camera inside a Gaussian (centre at the camera, and centre in front of it)
 *  - Gaussians behind the camera
 *  - a scene offset 1e5 from the origin
 *  - empty views (no Gaussians; all culled) */
#include <stdio.h>
#include "mgs_test.h"
#include "raster_test_util.h"

typedef struct run_result {
  mgs_raster_output out;
  mgs_gaussians *grad;
  float *gm2d;
  size_t nonfinite_img, nonfinite_grad;
} run_result;

static mgs_gaussians *zeros_like(const mgs_gaussians *g) {
  mgs_gaussians *z = mgs_gaussians_create(g->n ? g->n : 1, 3);
  size_t first;
  mgs_gaussians_append(z, g->n, &first, NULL);
  for (int grp = 0; grp < MGS_PARAM_COUNT; grp++)
    if (g->n) memset(mgs_gaussians_group(z, (mgs_param_group)grp), 0, g->n * mgs_param_dim((mgs_param_group)grp) * sizeof(float));
  return z;
}

/* Forward + backward with a random linear loss on colour, alpha and depth; counts
 * non-finite values. r stays alive (outputs point into it). */
static void run(mgs_raster *r, const mgs_gaussians *g, const mgs_camera *cam, const mgs_raster_settings *s, run_result *rr) {
  mgs_error err;
  memset(rr, 0, sizeof *rr);
  CHECK_OK(mgs_raster_forward(r, g, cam, s, &rr->out, &err), &err);
  size_t np = (size_t)cam->width * cam->height;
  for (size_t p = 0; p < np; p++) {
    for (int c = 0; c < 3; c++) rr->nonfinite_img += !isfinite(rr->out.color[3 * p + c]);
    rr->nonfinite_img += !isfinite(rr->out.alpha[p]) + !isfinite(rr->out.depth[p]);
  }
  float *wc = malloc(np * 3 * sizeof(float)), *wa = malloc(np * sizeof(float)), *wd = malloc(np * sizeof(float));
  mgs_rng rng;
  mgs_rng_init(&rng, 99, 1);
  for (size_t p = 0; p < 3 * np; p++) wc[p] = (float)rt_uniform(&rng, -1, 1);
  for (size_t p = 0; p < np; p++) { wa[p] = (float)rt_uniform(&rng, -1, 1); wd[p] = (float)rt_uniform(&rng, -1, 1); }
  rr->grad = zeros_like(g);
  rr->gm2d = calloc(g->n ? g->n : 1, sizeof(float));
  CHECK_OK(mgs_raster_backward(r, wc, wa, wd, rr->grad, rr->gm2d, &err), &err);
  for (int grp = 0; grp < MGS_PARAM_COUNT; grp++) {
    const float *a = mgs_gaussians_group(rr->grad, (mgs_param_group)grp);
    size_t m = g->n * mgs_param_dim((mgs_param_group)grp);
    for (size_t i = 0; i < m; i++) rr->nonfinite_grad += !isfinite(a[i]);
  }
  for (size_t i = 0; i < g->n; i++) rr->nonfinite_grad += !isfinite(rr->gm2d[i]);
  free(wc); free(wa); free(wd);
}

static void free_result(run_result *rr) {
  mgs_gaussians_destroy(rr->grad);
  free(rr->gm2d);
}

static void default_cam(mgs_camera *cam, int w, int h) {
  double target[3] = {0, 0, 0};
  rt_camera(cam, w, h, 0.9, 4.0, target, 5);
}

static mgs_gaussians *one_gaussian_at(const double p[3], float log_scale, float logit) {
  mgs_gaussians *g = mgs_gaussians_create(1, 3);
  size_t first;
  mgs_gaussians_append(g, 1, &first, NULL);
  for (int k = 0; k < 3; k++) { g->mean[k] = (float)p[k]; g->log_scale[k] = log_scale; g->sh_dc[k] = 1.0f; }
  g->opacity[0] = logit;
  return g;
}

/* Scales log-uniform over 1e-7 .. 1e3 of the scene extent (2). A 1e-7 Gaussian is the
 * 0.3 px^2 dilation kernel: at its centre pixel alpha = opacity to 1e-4; a 1e3 one covers
 * the camera with alpha ~ opacity everywhere. */
static void test_extreme_scales(void) {
  mgs_camera cam;
  default_cam(&cam, 48, 48);
  mgs_raster_settings s;
  mgs_raster_settings_default(&s);
  s.sh_degree = 3;
  scene_opts o = {400, 1.0, 2e-7, 2e3, 0.0, 2.0, 0.3};
  mgs_gaussians *g = rt_random_scene(11, &o);
  mgs_raster *r = mgs_raster_create();
  run_result rr;
  run(r, g, &cam, &s, &rr);
  CHECK_MSG(rr.nonfinite_img == 0 && rr.nonfinite_grad == 0, "%zu / %zu non-finite", rr.nonfinite_img, rr.nonfinite_grad);
  free_result(&rr);
  mgs_gaussians_destroy(g);

  /* tiny Gaussian exactly at a pixel centre */
  double cc[3], dir[3];
  mgs_camera_ray(&cam, 20.5, 30.5, cc, dir);
  double p[3] = {cc[0] + 4 * dir[0], cc[1] + 4 * dir[1], cc[2] + 4 * dir[2]};
  g = one_gaussian_at(p, (float)log(2e-7), 0.0f);
  run(r, g, &cam, &s, &rr);
  CHECK(rr.nonfinite_img == 0 && rr.nonfinite_grad == 0);
  CHECK_NEAR(rr.out.alpha[30 * 48 + 20], 0.5, 1e-4);
  CHECK_NEAR(rr.out.alpha[30 * 48 + 21], 0.5 * exp(-0.5 / 0.3), 1e-4); /* one pixel over: exp(-1/(2*0.3)) */
  free_result(&rr);
  mgs_gaussians_destroy(g);

  /* huge Gaussian (1e3 x extent) around the scene: uniform alpha = opacity */
  double z[3] = {0, 0, 0};
  g = one_gaussian_at(z, (float)log(2e3), 0.0f);
  run(r, g, &cam, &s, &rr);
  CHECK(rr.nonfinite_img == 0 && rr.nonfinite_grad == 0);
  double amin = 1, amax = 0;
  for (int p2 = 0; p2 < 48 * 48; p2++) { amin = fmin(amin, rr.out.alpha[p2]); amax = fmax(amax, rr.out.alpha[p2]); }
  CHECK_NEAR(amin, 0.5, 1e-4);
  CHECK_NEAR(amax, 0.5, 1e-4);
  free_result(&rr);
  mgs_gaussians_destroy(g);
  mgs_raster_destroy(r);
}

/* Logits +-30: alpha clamps at 0.99 (visible ones) or the Gaussian vanishes. Adding a
 * logit -30 Gaussian leaves the image unchanged (to 1e-6). */
static void test_saturated_opacity(void) {
  mgs_camera cam;
  default_cam(&cam, 40, 40);
  mgs_raster_settings s;
  mgs_raster_settings_default(&s);
  scene_opts o = {60, 0.8, 0.05, 0.3, 0.0, 1.0, 0.2};
  mgs_gaussians *g = rt_random_scene(12, &o);
  for (size_t i = 0; i < g->n; i++) g->opacity[i] = (i % 2) ? 30.0f : -30.0f;
  mgs_raster *r = mgs_raster_create();
  run_result rr;
  run(r, g, &cam, &s, &rr);
  CHECK_MSG(rr.nonfinite_img == 0 && rr.nonfinite_grad == 0, "%zu / %zu non-finite", rr.nonfinite_img, rr.nonfinite_grad);
  float *img = malloc(40 * 40 * 3 * sizeof(float));
  memcpy(img, rr.out.color, 40 * 40 * 3 * sizeof(float));
  free_result(&rr);
  /* drop the -30 ones */
  uint8_t *keep = malloc(g->n);
  for (size_t i = 0; i < g->n; i++) keep[i] = (uint8_t)(i % 2);
  mgs_gaussians *h = mgs_gaussians_clone(g);
  mgs_gaussians_compact(h, keep);
  run(r, h, &cam, &s, &rr);
  double md = 0;
  for (int p = 0; p < 40 * 40 * 3; p++) md = fmax(md, fabs(img[p] - rr.out.color[p]));
  CHECK_MSG(md < 1e-6, "transparent Gaussians changed the image by %g", md);
  /* a single logit +30 Gaussian: alpha at its centre is exactly the 0.99 clamp */
  free_result(&rr);
  double cc[3], dir[3];
  mgs_camera_ray(&cam, 10.5, 12.5, cc, dir);
  double p[3] = {cc[0] + 4 * dir[0], cc[1] + 4 * dir[1], cc[2] + 4 * dir[2]};
  mgs_gaussians *one = one_gaussian_at(p, (float)log(0.1), 30.0f);
  run(r, one, &cam, &s, &rr);
  CHECK_NEAR(rr.out.alpha[12 * 40 + 10], 0.99, 1e-6);
  CHECK(rr.nonfinite_grad == 0);
  free_result(&rr);
  mgs_gaussians_destroy(one);
  mgs_gaussians_destroy(h);
  free(keep);
  free(img);
  mgs_gaussians_destroy(g);
  mgs_raster_destroy(r);
}

/* One scale 1e-9 of the others: the Gaussian is a disc; its image changes by < 1e-3
 * when the thin scale goes to 1e-12 (both far below a pixel). */
static void test_near_singular(void) {
  mgs_camera cam;
  default_cam(&cam, 48, 40);
  mgs_raster_settings s;
  mgs_raster_settings_default(&s);
  s.sh_degree = 2;
  scene_opts o = {80, 0.8, 0.1, 0.4, 0.5, 1.0, 0.3};
  mgs_gaussians *g = rt_random_scene(13, &o);
  for (size_t i = 0; i < g->n; i++) g->log_scale[3 * i + (i % 3)] = (float)(log(0.3) + log(1e-9));
  mgs_raster *r = mgs_raster_create();
  run_result rr;
  run(r, g, &cam, &s, &rr);
  CHECK_MSG(rr.nonfinite_img == 0 && rr.nonfinite_grad == 0, "%zu / %zu non-finite", rr.nonfinite_img, rr.nonfinite_grad);
  CHECK(rr.out.n_visible > 40);
  float *img = malloc(48 * 40 * 3 * sizeof(float));
  memcpy(img, rr.out.color, 48 * 40 * 3 * sizeof(float));
  free_result(&rr);
  for (size_t i = 0; i < g->n; i++) g->log_scale[3 * i + (i % 3)] = (float)(log(0.3) + log(1e-12));
  run(r, g, &cam, &s, &rr);
  CHECK(rr.nonfinite_img == 0 && rr.nonfinite_grad == 0);
  double md = 0;
  for (int p = 0; p < 48 * 40 * 3; p++) md = fmax(md, fabs(img[p] - rr.out.color[p]));
  CHECK_MSG(md < 1e-3, "thin scale 1e-9 vs 1e-12: images differ by %g", md);
  free_result(&rr);
  free(img);
  mgs_gaussians_destroy(g);
  mgs_raster_destroy(r);
}

/* 10^5 Gaussians on one pixel (same depth: a stress of the sort's ties, the early stop
 * and the per-tile lists): the pixel ends opaque (0.999 < alpha <= 0.9999), gradients
 * finite, only the contributors up to the stop get gradient. */
static void test_many_on_one_pixel(void) {
  mgs_camera cam;
  default_cam(&cam, 32, 32);
  mgs_raster_settings s;
  mgs_raster_settings_default(&s);
  s.sh_degree = 1;
  size_t n = 100000;
  mgs_gaussians *g = mgs_gaussians_create(n, 3);
  size_t first;
  mgs_gaussians_append(g, n, &first, NULL);
  double cc[3], dir[3];
  mgs_camera_ray(&cam, 16.5, 16.5, cc, dir);
  mgs_rng rng;
  mgs_rng_init(&rng, 14, 1);
  for (size_t i = 0; i < n; i++) {
    for (int k = 0; k < 3; k++) {
      g->mean[3 * i + k] = (float)(cc[k] + 4 * dir[k]);
      g->log_scale[3 * i + k] = (float)log(1e-4);
      g->sh_dc[3 * i + k] = (float)mgs_rng_normal(&rng);
    }
    g->rot[4 * i] = 1;
    g->opacity[i] = (float)(-2.0 + mgs_rng_normal(&rng));
  }
  mgs_raster *r = mgs_raster_create();
  run_result rr;
  run(r, g, &cam, &s, &rr);
  CHECK_MSG(rr.nonfinite_img == 0 && rr.nonfinite_grad == 0, "%zu / %zu non-finite", rr.nonfinite_img, rr.nonfinite_grad);
  /* the stop leaves T in [1e-4, 1e-4 / (1 - alpha_next)) */
  CHECK(rr.out.alpha[16 * 32 + 16] > 0.999f && rr.out.alpha[16 * 32 + 16] <= 0.9999f + 1e-6f);
  CHECK(rr.out.n_visible == n);
  size_t with_grad = 0;
  for (size_t i = 0; i < n; i++) with_grad += rr.grad->opacity[i] != 0;
  fprintf(stderr, "  %zu of %zu Gaussians on the pixel received gradient\n", with_grad, n);
  CHECK(with_grad > 10 && with_grad < n / 10);
  free_result(&rr);
  mgs_gaussians_destroy(g);
  mgs_raster_destroy(r);
}

/* Camera inside Gaussians: one centred on the camera (z = 0 -> culled, as the reference's
 * near plane), one large one with its centre 0.5 in front (the camera inside its 1 sigma
 * ellipsoid): alpha ~ opacity over the whole image; Gaussians behind the camera: culled,
 * radius 0, exactly zero gradient. */
static void test_camera_inside_and_behind(void) {
  mgs_camera cam;
  default_cam(&cam, 40, 30);
  mgs_raster_settings s;
  mgs_raster_settings_default(&s);
  s.sh_degree = 3;
  double eye[3], dir[3];
  mgs_camera_ray(&cam, 20, 15, eye, dir);
  mgs_gaussians *g = mgs_gaussians_create(4, 3);
  size_t first;
  mgs_gaussians_append(g, 4, &first, NULL);
  double pos[4] = {0.0, 0.5, -1.0, -3.0};
  float lsc[4] = {0.0f, (float)log(2.0), (float)log(0.2), (float)log(5.0)};
  for (int i = 0; i < 4; i++) {
    for (int k = 0; k < 3; k++) {
      g->mean[3 * i + k] = (float)(eye[k] + pos[i] * dir[k]);
      g->log_scale[3 * i + k] = lsc[i];
      g->sh_dc[3 * i + k] = 0.5f;
    }
    g->opacity[i] = 1.0f;
    for (int k = 0; k < MGS_SH_REST_MAX; k++) g->sh_rest[MGS_SH_REST_MAX * i + k] = 0.1f;
  }
  mgs_raster *r = mgs_raster_create();
  run_result rr;
  run(r, g, &cam, &s, &rr);
  CHECK_MSG(rr.nonfinite_img == 0 && rr.nonfinite_grad == 0, "%zu / %zu non-finite", rr.nonfinite_img, rr.nonfinite_grad);
  CHECK(rr.out.radii[0] == 0 && rr.out.radii[1] > 0 && rr.out.radii[2] == 0 && rr.out.radii[3] == 0);
  double op = 1.0 / (1.0 + exp(-1.0));
  /* the centre pixel sees the in-front Gaussian at its peak (0.3 px^2 dilation aside) */
  CHECK(fabs(rr.out.alpha[15 * 40 + 20] - op) < 1e-3);
  for (int i = 0; i < 4; i++) {
    if (i == 1) continue;
    float sum = 0;
    for (int grp = 0; grp < MGS_PARAM_COUNT; grp++) {
      int d = mgs_param_dim((mgs_param_group)grp);
      const float *a = mgs_gaussians_group(rr.grad, (mgs_param_group)grp);
      for (int k = 0; k < d; k++) sum += fabsf(a[(size_t)i * d + k]);
    }
    CHECK_MSG(sum == 0, "culled Gaussian %d got gradient %g", i, sum);
    CHECK(rr.gm2d[i] == 0);
  }
  free_result(&rr);
  mgs_gaussians_destroy(g);
  mgs_raster_destroy(r);
}

/* The same scene 1e5 from the origin (camera moved with it). Means are snapped to a
 * 1/64 grid so that they are exactly representable after the offset (floats at 1e5 are
 * spaced 1/128): the model then holds the same scene, and the rasterizer's double
 * world->camera transform must reproduce the image to 1e-4. Without the snap, the float
 * model itself moves Gaussians by up to 1/256 world units: the image then differs by the
 * resulting sub-pixel shifts only (mean |diff| < 5e-3). */
static void test_far_from_origin(void) {
  scene_opts o = {300, 1.0, 0.05, 0.3, 0.0, 1.5, 0.3};
  mgs_gaussians *g = rt_random_scene(15, &o);
  for (size_t i = 0; i < 3 * g->n; i++) g->mean[i] = floorf(g->mean[i] * 64.0f) / 64.0f;
  mgs_camera cam, cam2;
  double t0[3] = {0, 0, 0}, off[3] = {1e5, -1e5, 1e5};
  rt_camera(&cam, 48, 40, 0.9, 3.5, t0, 15);
  double t1[3] = {off[0], off[1], off[2]};
  rt_camera(&cam2, 48, 40, 0.9, 3.5, t1, 15);
  mgs_gaussians *h = mgs_gaussians_clone(g);
  for (size_t i = 0; i < g->n; i++)
    for (int k = 0; k < 3; k++) h->mean[3 * i + k] = (float)((double)g->mean[3 * i + k] + off[k]);
  for (size_t i = 0; i < 3 * g->n; i++) CHECK((double)h->mean[i] - off[i % 3] == (double)g->mean[i]);
  mgs_raster_settings s;
  mgs_raster_settings_default(&s);
  s.sh_degree = 3;
  mgs_raster *r = mgs_raster_create(), *r2 = mgs_raster_create();
  run_result a, b;
  run(r, g, &cam, &s, &a);
  run(r2, h, &cam2, &s, &b);
  CHECK(b.nonfinite_img == 0 && b.nonfinite_grad == 0);
  double md = 0, gd = 0, gs = 0;
  for (int p = 0; p < 48 * 40 * 3; p++) md = fmax(md, fabs(a.out.color[p] - b.out.color[p]));
  for (size_t i = 0; i < 3 * g->n; i++) { gd = fmax(gd, fabs(a.grad->mean[i] - b.grad->mean[i])); gs = fmax(gs, fabs(a.grad->mean[i])); }
  fprintf(stderr, "  offset 1e5 (snapped means): max image diff %.3g, max mean-gradient diff %.3g (max %.3g)\n", md, gd, gs);
  CHECK_MSG(md < 1e-4, "image at 1e5 differs by %g", md);
  CHECK_MSG(gd < 1e-3 * gs + 1e-4, "mean gradient at 1e5 differs by %g", gd);
  free_result(&b);
  free_result(&a);
  /* unsnapped: the float model rounds the offset means */
  mgs_gaussians_destroy(g);
  g = rt_random_scene(15, &o);
  for (size_t i = 0; i < g->n; i++)
    for (int k = 0; k < 3; k++) h->mean[3 * i + k] = (float)((double)g->mean[3 * i + k] + off[k]);
  run(r, g, &cam, &s, &a);
  run(r2, h, &cam2, &s, &b);
  double mean_diff = 0;
  for (int p = 0; p < 48 * 40 * 3; p++) mean_diff += fabs(a.out.color[p] - b.out.color[p]);
  mean_diff /= 48 * 40 * 3;
  fprintf(stderr, "  offset 1e5 (float-rounded means): mean image diff %.3g\n", mean_diff);
  CHECK(b.nonfinite_img == 0 && b.nonfinite_grad == 0);
  CHECK_MSG(mean_diff < 5e-3, "mean image diff %g", mean_diff);
  free_result(&a);
  free_result(&b);
  mgs_gaussians_destroy(g);
  mgs_gaussians_destroy(h);
  mgs_raster_destroy(r);
  mgs_raster_destroy(r2);
}

/* Empty model, and a model whose Gaussians are all culled (behind the camera, below the
 * near plane, off-screen): image = background, alpha = depth = 0, zero gradients. */
static void test_empty_views(void) {
  mgs_camera cam;
  default_cam(&cam, 33, 17);
  mgs_raster_settings s;
  mgs_raster_settings_default(&s);
  s.background[0] = 0.25f; s.background[1] = 0.5f; s.background[2] = 1.0f;
  mgs_raster *r = mgs_raster_create();
  for (int variant = 0; variant < 2; variant++) {
    mgs_gaussians *g;
    if (variant == 0) {
      g = mgs_gaussians_create(1, 3);
    } else {
      scene_opts o = {50, 0.5, 0.05, 0.2, 0.0, 1.0, 0.2};
      g = rt_random_scene(16, &o);
      double eye[3], dir[3];
      mgs_camera_ray(&cam, 16.5, 8.5, eye, dir);
      for (size_t i = 0; i < g->n; i++) {
        double t = (i % 3 == 0) ? -2.0 : (i % 3 == 1 ? 0.1 : 3.0);
        double side = (i % 3 == 2) ? 50.0 : 0.0; /* far off-screen */
        double cx = cam.c2w[0], cy = cam.c2w[4], cz = cam.c2w[8];
        g->mean[3 * i] = (float)(eye[0] + t * dir[0] + side * cx);
        g->mean[3 * i + 1] = (float)(eye[1] + t * dir[1] + side * cy);
        g->mean[3 * i + 2] = (float)(eye[2] + t * dir[2] + side * cz);
      }
    }
    run_result rr;
    run(r, g, &cam, &s, &rr);
    CHECK(rr.nonfinite_img == 0 && rr.nonfinite_grad == 0);
    CHECK(rr.out.n_visible == 0 && rr.out.n_intersections == 0);
    double md = 0;
    for (int p = 0; p < 33 * 17; p++) {
      for (int c = 0; c < 3; c++) md = fmax(md, fabs(rr.out.color[3 * p + c] - s.background[c]));
      md = fmax(md, fabs(rr.out.alpha[p]) + fabs(rr.out.depth[p]));
    }
    CHECK_MSG(md == 0, "empty view (variant %d) differs from the background by %g", variant, md);
    double gsum = 0;
    for (int grp = 0; grp < MGS_PARAM_COUNT; grp++) {
      const float *a = mgs_gaussians_group(rr.grad, (mgs_param_group)grp);
      for (size_t i = 0; i < g->n * mgs_param_dim((mgs_param_group)grp); i++) gsum += fabs(a[i]);
    }
    CHECK(gsum == 0);
    free_result(&rr);
    mgs_gaussians_destroy(g);
  }
  mgs_raster_destroy(r);
}

/* Non-finite parameters (a diverged model) are culled, not propagated: the rest of the
 * image stays finite. */
static void test_nonfinite_params(void) {
  mgs_camera cam;
  default_cam(&cam, 32, 32);
  mgs_raster_settings s;
  mgs_raster_settings_default(&s);
  scene_opts o = {40, 0.5, 0.05, 0.3, 0.0, 1.0, 0.2};
  mgs_gaussians *g = rt_random_scene(17, &o);
  g->mean[0] = NAN;
  g->log_scale[3 * 1] = INFINITY;
  g->rot[4 * 2] = NAN;
  g->sh_dc[3 * 3] = INFINITY;
  g->log_scale[3 * 4 + 1] = 200.0f; /* exp overflows */
  mgs_raster *r = mgs_raster_create();
  run_result rr;
  run(r, g, &cam, &s, &rr);
  CHECK_MSG(rr.nonfinite_img == 0 && rr.nonfinite_grad == 0, "%zu / %zu non-finite", rr.nonfinite_img, rr.nonfinite_grad);
  for (int i = 0; i < 5; i++) CHECK_MSG(rr.out.radii[i] == 0, "Gaussian %d radius %d", i, rr.out.radii[i]);
  free_result(&rr);
  mgs_gaussians_destroy(g);
  mgs_raster_destroy(r);
}

int main(void) {
  RUN(test_extreme_scales);
  RUN(test_saturated_opacity);
  RUN(test_near_singular);
  RUN(test_many_on_one_pixel);
  RUN(test_camera_inside_and_behind);
  RUN(test_far_from_origin);
  RUN(test_empty_views);
  RUN(test_nonfinite_params);
  return mgs_test_finish();
}

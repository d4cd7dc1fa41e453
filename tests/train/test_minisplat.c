/* Mini-Splatting (train/mgs_minisplat.h) and the rasterizer's blending statistics it reads
 * (mgs_raster_blend_stats), on controlled scenes:
 *  - blend statistics agree with the forward (1 - T = alpha, sum of weights = 1 - T,
 *    area_max counts the max_index map) and pick the dominant Gaussian of two;
 *  - a Gaussian dominating more than H*W/5000 pixels is split, a hidden one is not;
 *  - the reinitialisation's ray points are the Mahalanobis-closest points of the ray, and
 *    on a sphere of surfels they lie on the sphere within a pixel footprint; for a 2DGS
 *    model the ray's intersection with the max-weight surfel's plane (on a plane of surfels:
 *    on the plane), the centre's depth where the screen-space filter gave the weight;
 *  - the weighted sampling without replacement has the exact inclusion probabilities of
 *    successive sampling (numpy's choice(p, replace=False)), never draws a zero weight;
 *    the 1 % cumulative-importance cut; the simplification count;
 *  - in the trainer: counts, opacities, SH degree and position lr around each milestone,
 *    and a checkpoint/resume that ends bit for bit as the uninterrupted run; on a 2DGS model
 *    the replacements are surfels of 2DGS's init, and resume is bit for bit too. */
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>
#include "mgs_test.h"
#include "train/mgs_term.h"
#include "core/mgs_parallel.h"
#include "train/synth.h"
#include "train/mgs_train.h"
#include "train/mgs_minisplat.h"

static void set_gaussian(mgs_gaussians *g, size_t i, const float mu[3], const float s[3], float alpha, float gray) {
  for (int k = 0; k < 3; k++) {
    g->mean[3 * i + k] = mu[k];
    g->log_scale[3 * i + k] = logf(s[k]);
    g->sh_dc[3 * i + k] = (gray - 0.5f) / MGS_SH_C0;
  }
  g->rot[4 * i] = 1;
  g->rot[4 * i + 1] = g->rot[4 * i + 2] = g->rot[4 * i + 3] = 0;
  g->opacity[i] = mgs_logitf(alpha);
}

static mgs_gaussians *model_of(size_t n) {
  mgs_gaussians *g = mgs_gaussians_create(n, 3);
  size_t first;
  if (!g || mgs_gaussians_append(g, n, &first, NULL) != MGS_OK) exit(2);
  return g;
}

static void front_camera(mgs_camera *cam, int W, int H) {
  mgs_camera_init_fovx(cam, W, H, 0.75);
  double eye[3] = {0, 0, 3}, target[3] = {0, 0, 0}, up[3] = {0, 1, 0};
  mgs_camera_look_at(cam, eye, target, up);
}

static void blend_consistency(void) {
  mgs_gaussians *g = synth_model(300, 5);
  mgs_camera cam;
  synth_camera(&cam, 80, 64, 1, 7, 0.0);
  mgs_raster *r = mgs_raster_create();
  mgs_raster_settings rs;
  mgs_raster_settings_default(&rs);
  mgs_raster_output ro;
  mgs_raster_blend b;
  mgs_error err;
  CHECK_OK(mgs_raster_forward(r, g, &cam, &rs, &ro, &err), &err);
  CHECK_OK(mgs_raster_blend_stats(r, &b, &err), &err);
  CHECK(b.n == g->n && b.width == 80 && b.height == 64);
  size_t npix = 80 * 64, covered = 0, area = 0;
  double sum_alpha = 0, sum_imp = 0, max_dev = 0;
  for (size_t p = 0; p < npix; p++) {
    max_dev = fmax(max_dev, fabs((1.0 - b.final_T[p]) - ro.alpha[p]));
    sum_alpha += 1.0 - b.final_T[p];
    covered += b.max_index[p] >= 0;
    CHECK((b.max_index[p] >= 0) == (b.final_T[p] < 1.0f));
    if (b.max_index[p] >= 0) CHECK(ro.radii[b.max_index[p]] > 0);
  }
  for (size_t i = 0; i < g->n; i++) {
    sum_imp += b.importance[i];
    area += b.area_max[i];
    if (b.area_max[i]) CHECK(b.importance[i] > 0);
    if (ro.radii[i] == 0) CHECK(b.importance[i] == 0 && b.area_max[i] == 0);
  }
  CHECK(max_dev < 1e-6);
  CHECK(covered > npix / 4 && area == covered);
  /* front-to-back: the weights of a pixel sum to 1 - T */
  CHECK_NEAR(sum_imp, sum_alpha, 1e-4 * sum_alpha);
  /* no forward: refused */
  mgs_raster *r2 = mgs_raster_create();
  CHECK(mgs_raster_blend_stats(r2, &b, &err) == MGS_ERR_ARG);
  mgs_raster_destroy(r2);

  /* two Gaussians: a small opaque one in front of a large faint one */
  mgs_gaussians *t = model_of(2);
  set_gaussian(t, 0, (float[3]){0, 0, 0.5f}, (float[3]){0.05f, 0.05f, 0.05f}, 0.95f, 0.2f);
  set_gaussian(t, 1, (float[3]){0, 0, -0.5f}, (float[3]){0.6f, 0.6f, 0.6f}, 0.5f, 0.8f);
  front_camera(&cam, 64, 64);
  CHECK_OK(mgs_raster_forward(r, t, &cam, &rs, &ro, &err), &err);
  CHECK_OK(mgs_raster_blend_stats(r, &b, &err), &err);
  CHECK(b.max_index[32 * 64 + 32] == 0); /* the centre: the opaque front one */
  CHECK(b.max_index[32 * 64 + 8] == 1);  /* far off its footprint: the large one */
  CHECK(b.max_index[0] == 1 || b.max_index[0] == -1);
  CHECK(b.area_max[0] > 0 && b.area_max[1] > 5 * b.area_max[0]);
  mgs_gaussians_destroy(t);
  mgs_gaussians_destroy(g);
  mgs_raster_destroy(r);
}

/* One strategy step on the forward of `g` at `cam` (no trainer: no reinit/simplify). */
static mgs_status strategy_step(mgs_strategy *s, mgs_gaussians *g, mgs_adam *a, mgs_raster *r, const mgs_camera *cam,
                                int it, mgs_rng *rng, mgs_error *err) {
  mgs_raster_settings rs;
  mgs_raster_settings_default(&rs);
  mgs_raster_output ro;
  mgs_status st = mgs_raster_forward(r, g, cam, &rs, &ro, err);
  if (st) return st;
  float *gm = calloc(g->n, sizeof(float));
  mgs_strategy_step ss;
  memset(&ss, 0, sizeof ss);
  ss.iteration = it; ss.model = g; ss.adam = a; ss.grad_mean2d = gm; ss.radii = ro.radii;
  ss.width = ro.width; ss.height = ro.height; ss.extent = 1.0; ss.rng = rng; ss.raster = r;
  st = s->ops->pre_backward(s->self, &ss, err);
  if (!st) st = s->ops->post_backward(s->self, &ss, err);
  free(gm);
  return st;
}

static void blur_split(void) {
  /* A: large, in front, dominating most of the 100x100 view; B: small, right behind A's
     centre (never the max weight); the threshold is max(100*100/5000 = 2, the floor of 8) pixels;
     variant 2: a floor above the view's pixel count splits nothing */
  for (int variant = 0; variant < 3; variant++) {
    mgs_gaussians *g = model_of(2);
    set_gaussian(g, 0, (float[3]){0, 0, 0.3f}, (float[3]){0.4f, 0.3f, 0.02f}, 0.9f, 0.5f);
    set_gaussian(g, 1, (float[3]){0, 0, -0.3f}, (float[3]){0.03f, 0.03f, 0.03f}, 0.9f, 0.5f);
    mgs_adam *a = mgs_adam_create(2);
    mgs_minisplat_options o;
    mgs_minisplat_options_default(&o);
    o.adc.densify_from = 0; o.adc.densify_every = 10; o.adc.densify_until = 1000;
    o.adc.percent_dense = 1.0f; /* nothing is large for ADC's own split */
    if (variant == 1) o.blur_share = 1.0; /* no Gaussian dominates the whole view */
    if (variant == 2) o.blur_min_px = 100 * 100 + 1;
    mgs_strategy *s = NULL;
    mgs_error err;
    CHECK_OK(mgs_strategy_minisplat_create(&o, &s, &err), &err);
    mgs_raster *r = mgs_raster_create();
    mgs_camera cam;
    front_camera(&cam, 100, 100);
    mgs_rng rng;
    mgs_rng_init(&rng, 1, 2);
    /* an ordinary iteration marks A; the densification iteration splits it */
    CHECK_OK(strategy_step(s, g, a, r, &cam, 9, &rng, &err), &err);
    CHECK(g->n == 2);
    CHECK_OK(strategy_step(s, g, a, r, &cam, 10, &rng, &err), &err);
    if (variant == 0) {
      CHECK_MSG(g->n == 3, "%zu Gaussians after the blur split", g->n);
      /* B (kept, first) and A's two halves: scale / 1.6, same opacity */
      CHECK(g->n == 3 && g->mean[2] == -0.3f);
      for (size_t i = 1; i < g->n; i++) CHECK_NEAR(expf(g->log_scale[3 * i]), 0.4 / 1.6, 1e-5);
      CHECK(a->n == g->n);
    } else {
      CHECK(g->n == 2);
    }
    mgs_strategy_destroy(s);
    mgs_raster_destroy(r);
    mgs_adam_destroy(a);
    mgs_gaussians_destroy(g);
  }
}

static void invert3(const double m[9], double inv[9]) {
  double d = m[0] * (m[4] * m[8] - m[5] * m[7]) - m[1] * (m[3] * m[8] - m[5] * m[6]) + m[2] * (m[3] * m[7] - m[4] * m[6]);
  inv[0] = (m[4] * m[8] - m[5] * m[7]) / d; inv[1] = (m[2] * m[7] - m[1] * m[8]) / d; inv[2] = (m[1] * m[5] - m[2] * m[4]) / d;
  inv[3] = (m[5] * m[6] - m[3] * m[8]) / d; inv[4] = (m[0] * m[8] - m[2] * m[6]) / d; inv[5] = (m[2] * m[3] - m[0] * m[5]) / d;
  inv[6] = (m[3] * m[7] - m[4] * m[6]) / d; inv[7] = (m[1] * m[6] - m[0] * m[7]) / d; inv[8] = (m[0] * m[4] - m[1] * m[3]) / d;
}

static void ray_points_closest(void) {
  /* one rotated anisotropic Gaussian off the axis: each pixel's point is on the pixel's
     ray (projects to its centre) and minimizes the Mahalanobis distance along it */
  mgs_gaussians *g = model_of(1);
  set_gaussian(g, 0, (float[3]){0.15f, -0.1f, 0.2f}, (float[3]){0.3f, 0.08f, 0.02f}, 0.8f, 0.5f);
  float q[4] = {0.9f, 0.3f, -0.2f, 0.25f};
  float qn = sqrtf(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  for (int k = 0; k < 4; k++) g->rot[k] = q[k] / qn;
  mgs_camera cam;
  synth_camera(&cam, 60, 50, 2, 9, 0.0);
  mgs_raster *r = mgs_raster_create();
  mgs_raster_settings rs;
  mgs_raster_settings_default(&rs);
  mgs_raster_output ro;
  mgs_error err;
  CHECK_OK(mgs_raster_forward(r, g, &cam, &rs, &ro, &err), &err);
  float *xyz = malloc(60 * 50 * 3 * sizeof(float));
  CHECK_OK(mgs_minisplat_ray_points(r, g, &cam, xyz, &err), &err);
  double cov[9], inv[9], c[3];
  mgs_gaussian_covariance(g, 0, cov);
  invert3(cov, inv);
  mgs_camera_center(&cam, c);
  int valid = 0;
  double worst_px = 0, worst_grad = 0;
  for (int y = 0; y < 50; y++)
    for (int x = 0; x < 60; x++) {
      const float *p = xyz + 3 * (y * 60 + x);
      if (!isfinite(p[0])) continue;
      valid++;
      double pw[3] = {p[0], p[1], p[2]}, uv[2], pc[3];
      mgs_camera_world_to_cam(&cam, pw, pc);
      uv[0] = cam.fx * pc[0] / pc[2] + cam.cx;
      uv[1] = cam.fy * pc[1] / pc[2] + cam.cy;
      worst_px = fmax(worst_px, fmax(fabs(uv[0] - (x + 0.5)), fabs(uv[1] - (y + 0.5))));
      /* d/dt of (p - mu)^T inv (p - mu) along the ray is 0 at the minimum */
      double d[3], e[3], dn = 0, en = 0, dot = 0;
      for (int i = 0; i < 3; i++) { d[i] = pw[i] - c[i]; e[i] = pw[i] - g->mean[i]; dn += d[i] * d[i]; }
      double ie[3];
      for (int i = 0; i < 3; i++) { ie[i] = inv[3 * i] * e[0] + inv[3 * i + 1] * e[1] + inv[3 * i + 2] * e[2]; en += ie[i] * ie[i]; }
      for (int i = 0; i < 3; i++) dot += d[i] * ie[i];
      worst_grad = fmax(worst_grad, fabs(dot) / (sqrt(dn) * sqrt(en) + 1e-3));
    }
  CHECK(valid > 100);
  CHECK_MSG(worst_px < 2e-3, "a ray point projects %g px from its pixel centre", worst_px);
  CHECK_MSG(worst_grad < 2e-3, "not the Mahalanobis minimum along the ray: %g", worst_grad);
  free(xyz);
  mgs_gaussians_destroy(g);
  mgs_raster_destroy(r);
}

/* as_2dgs: the same rows as a 2DGS model (true surfels, mgs_minisplat_ray_points takes the
 * ray's intersection with the max-weight surfel's plane) */
static void sphere_case(int as_2dgs) {
  /* 3000 surfels (flat, tangent) on a sphere of radius 0.5 */
  const double R = 0.5;
  size_t n = 3000;
  mgs_gaussians *g = model_of(n);
  for (size_t i = 0; i < n; i++) {
    double z = 1 - 2 * (i + 0.5) / n, rr = sqrt(1 - z * z), ph = i * 2.399963229728653;
    double nrm[3] = {rr * cos(ph), rr * sin(ph), z};
    set_gaussian(g, i, (float[3]){(float)(R * nrm[0]), (float)(R * nrm[1]), (float)(R * nrm[2])},
                 (float[3]){0.02f, 0.02f, 1e-4f}, 0.9f, 0.5f);
    /* rotation taking +z to the normal: axis z x n, angle acos(n_z) */
    double ax[3] = {-nrm[1], nrm[0], 0}, an = sqrt(ax[0] * ax[0] + ax[1] * ax[1]), ang = acos(fmax(-1, fmin(1, nrm[2])));
    if (an < 1e-9) { ax[0] = 1; ax[1] = 0; an = 1; }
    g->rot[4 * i] = (float)cos(ang / 2);
    for (int k = 0; k < 3; k++) g->rot[4 * i + 1 + k] = (float)(sin(ang / 2) * ax[k] / an);
    if (as_2dgs) g->log_scale[3 * i + 2] = MGS_SURFEL_LOG_SCALE2;
  }
  if (as_2dgs) g->kind = MGS_MODEL_2DGS;
  mgs_camera cam;
  synth_camera(&cam, 96, 96, 3, 8, 0.0);
  mgs_raster *r = mgs_raster_create();
  mgs_raster_settings rs;
  mgs_raster_settings_default(&rs);
  mgs_raster_output ro;
  mgs_error err;
  CHECK_OK(mgs_raster_forward(r, g, &cam, &rs, &ro, &err), &err);
  float *xyz = malloc(96 * 96 * 3 * sizeof(float));
  CHECK_OK(mgs_minisplat_ray_points(r, g, &cam, xyz, &err), &err);
  /* where the ray meets the sphere at a slant below 60 degrees from the normal, the
     points must lie on it within one pixel footprint; towards the silhouette a ray
     grazes the tangent surfels and their closest point drifts off (the authors' rule) */
  int valid = 0, within = 0, facing = 0, facing_within = 0;
  double c[3], worst_fp = 0, wsum = 0, wwithin = 0;
  mgs_camera_center(&cam, c);
  mgs_raster_blend b; /* the sampling weights 1 - T */
  CHECK_OK(mgs_raster_blend_stats(r, &b, &err), &err);
  for (size_t p = 0; p < 96 * 96; p++) {
    const float *x = xyz + 3 * p;
    if (!isfinite(x[0])) continue;
    valid++;
    double dist = sqrt((double)x[0] * x[0] + (double)x[1] * x[1] + (double)x[2] * x[2]);
    double d[3] = {x[0] - c[0], x[1] - c[1], x[2] - c[2]}, depth = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    for (int k = 0; k < 3; k++) d[k] /= depth;
    double footprint = depth / cam.fx; /* one pixel at that depth */
    int ok = fabs(dist - R) <= footprint;
    within += ok;
    worst_fp = fmax(worst_fp, fabs(dist - R) / footprint);
    wsum += 1.0 - b.final_T[p];
    if (ok) wwithin += 1.0 - b.final_T[p];
    /* the ray's first hit of the true sphere and its incidence */
    double bq = c[0] * d[0] + c[1] * d[1] + c[2] * d[2], cq = c[0] * c[0] + c[1] * c[1] + c[2] * c[2] - R * R;
    double disc = bq * bq - cq;
    if (disc <= 0) continue;
    double t = -bq - sqrt(disc), h[3] = {c[0] + t * d[0], c[1] + t * d[1], c[2] + t * d[2]};
    double cosi = -(h[0] * d[0] + h[1] * d[1] + h[2] * d[2]) / R;
    if (cosi < 0.5) continue;
    facing++;
    facing_within += ok;
  }
  fprintf(stderr, "sphere (%s): %d ray points, %d within a footprint (%d of %d facing the camera; %.1f %% of the "
          "sampling weight 1 - T), the farthest %.2f footprints off\n", as_2dgs ? "2dgs" : "3dgs", valid, within,
          facing_within, facing, 100 * wwithin / wsum, worst_fp);
  CHECK(facing > 800);
  CHECK_MSG(facing_within == facing, "%d of %d pixels off the surface", facing - facing_within, facing);
  CHECK(within >= 0.85 * valid);
  /* surfels: the others lie in the screen-space filter's halo round the silhouette (alpha
     reaches 1/255 up to 2.3 px beyond a surfel's edge there), at the centre's depth */
  if (as_2dgs) CHECK_MSG(worst_fp < 3 && wwithin >= 0.93 * wsum, "%.2f footprints off, %.3f of the weight within one",
                         worst_fp, wwithin / wsum);
  free(xyz);
  mgs_gaussians_destroy(g);
  mgs_raster_destroy(r);
}

static void ray_points_on_sphere(void) { sphere_case(0); }
static void ray_points_on_sphere_2dgs(void) { sphere_case(1); }

/* 2DGS: a tilted plane tiled by coplanar surfels seen obliquely. Where the ray meets the
 * max-weight surfel's plane on its splat the point is that intersection (on the plane to
 * rounding); at the plane's rim, where a pixel's weight came from the screen-space filter,
 * the point is the ray's at the surfel centre's camera depth. */
static void ray_points_on_plane_2dgs(void) {
  const int side = 24;
  size_t n = (size_t)side * side;
  mgs_gaussians *g = model_of(n);
  /* the plane through the origin with normal nrm; e1, e2 span it */
  double nrm[3] = {0.3, -0.2, 1}, nl = sqrt(0.09 + 0.04 + 1);
  for (int k = 0; k < 3; k++) nrm[k] /= nl;
  double e1[3] = {nrm[2], 0, -nrm[0]}, l1 = sqrt(e1[0] * e1[0] + e1[2] * e1[2]);
  for (int k = 0; k < 3; k++) e1[k] /= l1;
  double e2[3] = {nrm[1] * e1[2] - nrm[2] * e1[1], nrm[2] * e1[0] - nrm[0] * e1[2], nrm[0] * e1[1] - nrm[1] * e1[0]};
  double Rm[9] = {e1[0], e2[0], nrm[0], e1[1], e2[1], nrm[1], e1[2], e2[2], nrm[2]}, q[4];
  mgs_mat3_to_quatd(Rm, q);
  for (int a = 0; a < side; a++)
    for (int b = 0; b < side; b++) {
      size_t i = (size_t)a * side + b;
      double u = -0.6 + 1.2 * (a + 0.5) / side, v = -0.6 + 1.2 * (b + 0.5) / side;
      float mu[3];
      for (int k = 0; k < 3; k++) mu[k] = (float)(u * e1[k] + v * e2[k]);
      set_gaussian(g, i, mu, (float[3]){0.04f, 0.04f, 1e-6f}, 0.9f, 0.5f);
      for (int k = 0; k < 4; k++) g->rot[4 * i + k] = (float)q[k];
      g->log_scale[3 * i + 2] = MGS_SURFEL_LOG_SCALE2;
    }
  g->kind = MGS_MODEL_2DGS;
  mgs_camera cam;
  mgs_camera_init_fovx(&cam, 80, 64, 0.9);
  double eye[3] = {1.2, 0.9, 2.0}, target[3] = {0, 0, 0}, up[3] = {0, 0, 1};
  mgs_camera_look_at(&cam, eye, target, up);
  mgs_raster *r = mgs_raster_create();
  mgs_raster_settings rs;
  mgs_raster_settings_default(&rs);
  mgs_raster_output ro;
  mgs_error err;
  CHECK_OK(mgs_raster_forward(r, g, &cam, &rs, &ro, &err), &err);
  float *xyz = malloc(80 * 64 * 3 * sizeof(float));
  CHECK_OK(mgs_minisplat_ray_points(r, g, &cam, xyz, &err), &err);
  mgs_raster_blend b;
  CHECK_OK(mgs_raster_blend_stats(r, &b, &err), &err);
  double c[3];
  mgs_camera_center(&cam, c);
  int valid = 0, on = 0, within = 0, at_centre_depth = 0;
  double worst_px = 0;
  for (int y = 0; y < 64; y++)
    for (int x = 0; x < 80; x++) {
      size_t p = (size_t)y * 80 + x;
      const float *pt = xyz + 3 * p;
      CHECK((b.max_index[p] >= 0) == (isfinite(pt[0]) != 0)); /* every covered pixel gets a point */
      if (!isfinite(pt[0])) continue;
      valid++;
      double pw[3] = {pt[0], pt[1], pt[2]}, pc[3], mc[3];
      mgs_camera_world_to_cam(&cam, pw, pc);
      worst_px = fmax(worst_px, fmax(fabs(cam.fx * pc[0] / pc[2] + cam.cx - (x + 0.5)), fabs(cam.fy * pc[1] / pc[2] + cam.cy - (y + 0.5))));
      double dist = fabs(pw[0] * nrm[0] + pw[1] * nrm[1] + pw[2] * nrm[2]);
      on += dist < 1e-5;
      within += dist <= pc[2] / cam.fx;
      const float *mu = g->mean + 3 * (size_t)b.max_index[p];
      double mw[3] = {mu[0], mu[1], mu[2]};
      mgs_camera_world_to_cam(&cam, mw, mc);
      at_centre_depth += dist >= 1e-5 && fabs(pc[2] - mc[2]) < 1e-5;
    }
  fprintf(stderr, "plane (2dgs): %d ray points, %d on the plane, %d within a footprint, the others at their surfel "
          "centre's depth: %d; worst reprojection %.2g px\n", valid, on, within, at_centre_depth, worst_px);
  CHECK(valid > 1500);
  CHECK_MSG(worst_px < 2e-3, "a ray point projects %g px from its pixel centre", worst_px);
  CHECK(on >= 0.95 * valid);
  CHECK(on + at_centre_depth == valid);
  /* one surfel seen edge-on (the camera in its plane, a hair off): the ray misses the
     splat, the screen-space filter alone gives the weight: every point at its centre's depth */
  mgs_gaussians *e = model_of(1);
  set_gaussian(e, 0, (float[3]){0, 0, 0}, (float[3]){0.2f, 0.2f, 1e-6f}, 0.9f, 0.5f);
  e->log_scale[2] = MGS_SURFEL_LOG_SCALE2;
  e->kind = MGS_MODEL_2DGS;
  double eo[3] = {0, 3.0, 1e-4}, up2[3] = {0, 0, 1};
  mgs_camera_look_at(&cam, eo, target, up2); /* identity rotation: normal +z, the camera at z = 1e-4 */
  CHECK_OK(mgs_raster_forward(r, e, &cam, &rs, &ro, &err), &err);
  CHECK_OK(mgs_minisplat_ray_points(r, e, &cam, xyz, &err), &err);
  int edge_pts = 0, edge_ok = 0;
  for (size_t p = 0; p < 80 * 64; p++) {
    const float *pt = xyz + 3 * p;
    if (!isfinite(pt[0])) continue;
    edge_pts++;
    double pw[3] = {pt[0], pt[1], pt[2]}, pc[3];
    mgs_camera_world_to_cam(&cam, pw, pc);
    edge_ok += fabs(pc[2] - 3.0) < 1e-4;
  }
  fprintf(stderr, "edge-on surfel: %d ray points, %d at its centre's depth\n", edge_pts, edge_ok);
  CHECK(edge_pts > 5 && edge_ok == edge_pts);
  mgs_gaussians_destroy(e);
  free(xyz);
  mgs_gaussians_destroy(g);
  mgs_raster_destroy(r);
}

static void sampling_rules(void) {
  /* exact inclusion probabilities of successive sampling of 2 out of weights 1,2,3,4 (and a
     zero): P(i) = sum over first draws */
  const double w[5] = {1, 0, 2, 3, 4};
  double exact[5] = {0}, tot = 10;
  for (int a = 0; a < 5; a++)
    for (int b = 0; b < 5; b++) {
      if (a == b || w[a] == 0 || w[b] == 0) continue;
      double p = w[a] / tot * w[b] / (tot - w[a]);
      exact[a] += p;
      exact[b] += p;
    }
  mgs_rng rng;
  mgs_rng_init(&rng, 7, 1);
  int hits[5] = {0}, trials = 40000;
  uint32_t out[5];
  for (int t = 0; t < trials; t++) {
    size_t k = mgs_minisplat_weighted_sample(w, 5, 2, &rng, out);
    CHECK(k == 2 && out[0] < out[1]);
    for (size_t j = 0; j < k; j++) hits[out[j]]++;
  }
  CHECK(hits[1] == 0);
  for (int i = 0; i < 5; i++)
    CHECK_MSG(fabs((double)hits[i] / trials - exact[i]) < 0.012, "item %d: drawn %.4f, exact %.4f", i,
              (double)hits[i] / trials, exact[i]);
  /* more asked than non-zero weights: those only */
  CHECK(mgs_minisplat_weighted_sample(w, 5, 5, &rng, out) == 4);
  /* the 1 % cut of the authors' init_cdf_mask */
  const double imp[7] = {0, 0, 0, 1, 1, 1, 96};
  uint8_t keep[7];
  mgs_minisplat_cdf_keep(imp, 7, 0.01, keep);
  for (int i = 0; i < 6; i++) CHECK(keep[i] == 0);
  CHECK(keep[6] == 1);
  double flat[200];
  for (int i = 0; i < 200; i++) flat[i] = 1.0 + i; /* 1..200: the lowest 1 % of 20100 is 1..19 */
  uint8_t k2[200];
  mgs_minisplat_cdf_keep(flat, 200, 0.01, k2);
  int kept = 0;
  for (int i = 0; i < 200; i++) kept += k2[i];
  CHECK_MSG(kept == 200 - 20, "%d kept", kept); /* 1..19 sum to 190 < 201; 1..20 to 210 > 201: 20 is the split, dropped */
  CHECK(mgs_minisplat_simplify_count(1000, 800, 0.5) == 400);
  CHECK(mgs_minisplat_simplify_count(1000, 1000, 0.3) == 300);
}

/* ---- in the trainer ---- */

static mgs_dataset *ds;

static void small_options(mgs_train_options *o, mgs_minisplat_options *m, int dense) {
  mgs_train_options_default(o);
  o->iterations = 100;
  o->sh_every = 10;
  o->seed = 4;
  o->adc.densify_from = 10;
  o->adc.densify_every = 10;
  o->adc.densify_until = 60;
  o->adc.opacity_reset_every = 40;
  mgs_minisplat_options_default(m);
  m->adc = o->adc;
  m->dense = dense;
  m->reinit_every = 30;
  m->simplify1 = 60;
  m->simplify2 = 80;
  m->lr_restart = 20;
}

static int as_surfels; /* make() builds a 2DGS model (the 2DGS init's rotations and third scale) */

static mgs_trainer *make(const mgs_train_options *o, const mgs_minisplat_options *m) {
  mgs_gaussians *g = synth_model(200, 9);
  if (as_surfels) mgs_init_to_surfels(g, 3);
  mgs_strategy *s = NULL;
  mgs_trainer *t = NULL;
  mgs_error err;
  if (mgs_strategy_minisplat_create(m, &s, &err) || mgs_trainer_create(ds, o, g, s, &t, &err)) {
    fprintf(stderr, "%s\n", err.msg);
    exit(2);
  }
  return t;
}

static int all_opacity(const mgs_gaussians *g, float alpha) {
  for (size_t i = 0; i < g->n; i++)
    if (fabsf(mgs_sigmoidf(g->opacity[i]) - alpha) > 1e-6f) return 0;
  return 1;
}

/* A loss term that records the trainer's model_replaced notices (the reinitialisation and
 * the simplification's re-initialisation replace every Gaussian; the 1 % cut does not). */
static int notices[8], n_notices;
static unsigned rec_active(void *self, int it) { (void)self; (void)it; return 0; }
static void rec_replaced(void *self, int it) { (void)self; if (n_notices < 8) notices[n_notices++] = it; }
static void rec_destroy(void *self) { (void)self; }
static const mgs_term_ops rec_ops = {"record-replaced", rec_active, NULL, NULL, NULL, NULL, rec_destroy, rec_replaced};

static void in_trainer(void) {
  mgs_train_options o;
  mgs_minisplat_options m;
  small_options(&o, &m, 0);
  mgs_error err;
  mgs_trainer *t = make(&o, &m);
  static int rec_self;
  CHECK_OK(mgs_trainer_add_term(t, mgs_term_create(&rec_ops, &rec_self), &err), &err);
  CHECK_OK(mgs_trainer_run_until(t, 29, &err), &err);
  size_t n29 = mgs_trainer_model(t)->n;
  CHECK_OK(mgs_trainer_step(t, &err), &err); /* 30: reinitialisation */
  const mgs_gaussians *g = mgs_trainer_model(t);
  size_t nv = ds->n_views[MGS_SPLIT_TRAIN];
  /* per view int(pixels * N / all pixels) = int(N / views) points */
  CHECK_MSG(g->n == nv * (n29 / nv), "%zu Gaussians after reinit from %zu", g->n, n29);
  CHECK(all_opacity(g, 0.1f));
  CHECK(mgs_trainer_active_sh(t) == 0);
  CHECK_OK(mgs_trainer_run_until(t, 59, &err), &err);
  size_t n59 = mgs_trainer_model(t)->n;
  CHECK(mgs_trainer_active_sh(t) == 0);
  CHECK_OK(mgs_trainer_step(t, &err), &err); /* 60: simplification */
  g = mgs_trainer_model(t);
  CHECK_MSG(g->n > 0 && g->n <= n59 / 2, "%zu Gaussians after simplification from %zu", g->n, n59);
  CHECK(all_opacity(g, 0.1f));
  CHECK_OK(mgs_trainer_step(t, &err), &err); /* 61: lr at step 61 - 60 + 20 */
  double ext = ds->extent;
  CHECK_NEAR(mgs_trainer_learning_rate(t, MGS_PARAM_MEAN), (float)mgs_expon_lr(21, o.lr_mean_init * ext, o.lr_mean_final * ext, o.lr_mean_max_steps), 1e-12);
  CHECK(mgs_trainer_active_sh(t) == 0);
  CHECK_OK(mgs_trainer_run_until(t, 70, &err), &err);
  CHECK(mgs_trainer_active_sh(t) == 1);
  CHECK_OK(mgs_trainer_run_until(t, 79, &err), &err);
  size_t n79 = mgs_trainer_model(t)->n;
  CHECK_OK(mgs_trainer_step(t, &err), &err); /* 80: the 1 % cut */
  CHECK_MSG(mgs_trainer_model(t)->n < n79 && mgs_trainer_model(t)->n > n79 / 2, "%zu -> %zu", n79, mgs_trainer_model(t)->n);
  CHECK_OK(mgs_trainer_run(t, &err), &err);
  /* the terms were told of the two replacements, not of the cut nor of densification */
  CHECK_MSG(n_notices == 2 && notices[0] == 30 && notices[1] == 60, "%d notices (%d, %d)", n_notices, notices[0], notices[1]);
  double psnr, ssim;
  CHECK_OK(mgs_trainer_evaluate(t, MGS_SPLIT_TEST, 0, &psnr, &ssim, &err), &err);
  fprintf(stderr, "mini-splatting: %zu -> %zu (reinit) ... %zu (before simplifying) ... %zu Gaussians, test PSNR %.2f\n", n29,
          nv * (n29 / nv), n59, mgs_trainer_model(t)->n, psnr);
  CHECK(isfinite(psnr) && psnr > 12);
  mgs_trainer_destroy(t);

  /* -D: reinitialisation with replacement (duplicates dropped: at most as many), no
     simplification, the reset at densify_until */
  small_options(&o, &m, 1);
  t = make(&o, &m);
  CHECK_OK(mgs_trainer_run_until(t, 29, &err), &err);
  n29 = mgs_trainer_model(t)->n;
  CHECK_OK(mgs_trainer_step(t, &err), &err);
  CHECK(mgs_trainer_model(t)->n <= nv * (n29 / nv) && mgs_trainer_model(t)->n > nv * (n29 / nv) / 2);
  CHECK_OK(mgs_trainer_run_until(t, 59, &err), &err);
  n59 = mgs_trainer_model(t)->n;
  CHECK_OK(mgs_trainer_step(t, &err), &err);
  CHECK(mgs_trainer_model(t)->n == n59 && all_opacity(mgs_trainer_model(t), 0.1f));
  CHECK_OK(mgs_trainer_run_until(t, 79, &err), &err);
  n79 = mgs_trainer_model(t)->n;
  CHECK_OK(mgs_trainer_step(t, &err), &err);
  CHECK(mgs_trainer_model(t)->n == n79);
  mgs_trainer_destroy(t);
}

/* Every surfel as 2DGS's init makes it from a point: kind kept, the two disc scales equal
 * (3-NN), the third the surfel constant, opacity 0.1, rotation components in [0, 1) (the
 * authors' torch.rand) and not all the identity. */
static int surfel_init(const mgs_gaussians *g) {
  if (g->kind != MGS_MODEL_2DGS || !all_opacity(g, 0.1f)) return 0;
  size_t identity = 0;
  for (size_t i = 0; i < g->n; i++) {
    if (g->log_scale[3 * i] != g->log_scale[3 * i + 1] || g->log_scale[3 * i + 2] != MGS_SURFEL_LOG_SCALE2) return 0;
    for (int k = 0; k < 4; k++) if (!(g->rot[4 * i + k] >= 0 && g->rot[4 * i + k] < 1)) return 0;
    identity += g->rot[4 * i] == 1 && g->rot[4 * i + 1] == 0;
  }
  return identity < g->n / 10 + 1;
}

/* --model 2dgs: the same milestones on surfels, for both variants; replacements are
 * surfels of 2DGS's init */
static void in_trainer_2dgs(void) {
  mgs_train_options o;
  mgs_minisplat_options m;
  small_options(&o, &m, 0);
  m.adc.min_opacity = 0.05f; /* the 2DGS default (train/config.c) */
  mgs_error err;
  as_surfels = 1;
  mgs_trainer *t = make(&o, &m);
  CHECK_OK(mgs_trainer_run_until(t, 29, &err), &err);
  size_t n29 = mgs_trainer_model(t)->n, nv = ds->n_views[MGS_SPLIT_TRAIN];
  CHECK_OK(mgs_trainer_step(t, &err), &err); /* 30: reinitialisation from the surfels' ray points */
  const mgs_gaussians *g = mgs_trainer_model(t);
  CHECK_MSG(g->n == nv * (n29 / nv), "%zu surfels after reinit from %zu", g->n, n29);
  CHECK_MSG(surfel_init(g), "the reinitialised model is not 2DGS's init");
  CHECK_OK(mgs_trainer_run_until(t, 59, &err), &err);
  size_t n59 = mgs_trainer_model(t)->n;
  CHECK_OK(mgs_trainer_step(t, &err), &err); /* 60: simplification, every kept surfel re-initialised */
  g = mgs_trainer_model(t);
  CHECK_MSG(g->n > 0 && g->n <= n59 / 2, "%zu surfels after simplification from %zu", g->n, n59);
  CHECK_MSG(surfel_init(g), "the simplified model is not 2DGS's init");
  CHECK_OK(mgs_trainer_run_until(t, 79, &err), &err);
  size_t n79 = mgs_trainer_model(t)->n;
  CHECK_OK(mgs_trainer_step(t, &err), &err); /* 80: the 1 % cut */
  CHECK(mgs_trainer_model(t)->n < n79 && mgs_trainer_model(t)->kind == MGS_MODEL_2DGS);
  CHECK_OK(mgs_trainer_run(t, &err), &err);
  double psnr, ssim;
  CHECK_OK(mgs_trainer_evaluate(t, MGS_SPLIT_TEST, 0, &psnr, &ssim, &err), &err);
  fprintf(stderr, "mini-splatting on surfels: %zu -> %zu (reinit) ... %zu (before simplifying) ... %zu surfels, test "
          "PSNR %.2f\n", n29, nv * (n29 / nv), n59, mgs_trainer_model(t)->n, psnr);
  CHECK(isfinite(psnr) && psnr > 12);
  mgs_trainer_destroy(t);
  /* -D: reinitialisation with replacement, the reset of every surfel at densify_until */
  small_options(&o, &m, 1);
  m.adc.min_opacity = 0.05f;
  t = make(&o, &m);
  CHECK_OK(mgs_trainer_run_until(t, 30, &err), &err);
  CHECK(surfel_init(mgs_trainer_model(t)));
  CHECK_OK(mgs_trainer_run_until(t, 59, &err), &err);
  size_t d59 = mgs_trainer_model(t)->n;
  CHECK_OK(mgs_trainer_step(t, &err), &err);
  CHECK(mgs_trainer_model(t)->n == d59 && surfel_init(mgs_trainer_model(t)));
  CHECK_OK(mgs_trainer_run(t, &err), &err);
  CHECK_OK(mgs_trainer_evaluate(t, MGS_SPLIT_TEST, 0, &psnr, &ssim, &err), &err);
  fprintf(stderr, "mini-splatting-d on surfels: %zu surfels, test PSNR %.2f\n", mgs_trainer_model(t)->n, psnr);
  CHECK(isfinite(psnr) && psnr > 12);
  mgs_trainer_destroy(t);
  as_surfels = 0;
}

static int same_model(const mgs_gaussians *a, const mgs_gaussians *b) {
  if (a->n != b->n) { fprintf(stderr, "counts differ: %zu vs %zu\n", a->n, b->n); return 0; }
  for (int k = 0; k < MGS_PARAM_COUNT; k++) {
    size_t bytes = a->n * (size_t)mgs_param_dim((mgs_param_group)k) * sizeof(float);
    if (memcmp(mgs_gaussians_group((mgs_gaussians *)a, (mgs_param_group)k),
               mgs_gaussians_group((mgs_gaussians *)b, (mgs_param_group)k), bytes)) {
      fprintf(stderr, "group %s differs\n", mgs_param_name((mgs_param_group)k));
      return 0;
    }
  }
  return 1;
}

static void resume_identity_case(void) {
  mgs_train_options o;
  mgs_minisplat_options m;
  small_options(&o, &m, 0);
  mgs_error err;
  char ck[] = "/tmp/mgs_test_minisplat_XXXXXX";
  int fd = mkstemp(ck);
  CHECK(fd >= 0);
  if (fd >= 0) close(fd);
  mgs_trainer *a = make(&o, &m);
  CHECK_OK(mgs_trainer_run(a, &err), &err);
  /* interrupted at 45: between the reinitialisation and the simplification, blur marks
     and ADC statistics of an interval in flight */
  for (int stop = 0; stop <= 75; stop += stop ? 30 : 45) { /* 0: the initial checkpoint, state not sized yet */
    mgs_trainer *b = make(&o, &m);
    CHECK_OK(mgs_trainer_run_until(b, stop, &err), &err);
    CHECK_OK(mgs_trainer_save_checkpoint(b, ck, &err), &err);
    mgs_trainer_destroy(b);
    mgs_trainer *c = make(&o, &m);
    CHECK_OK(mgs_trainer_load_checkpoint(c, ck, &err), &err);
    CHECK(mgs_trainer_iteration(c) == stop);
    CHECK_OK(mgs_trainer_run(c, &err), &err);
    CHECK_MSG(same_model(mgs_trainer_model(a), mgs_trainer_model(c)), "resumed at %d", stop);
    mgs_trainer_destroy(c);
  }
  mgs_trainer_destroy(a);
  remove(ck);
}

/* 3DGS, then surfels (whose replacements draw their rotations from the run's generator) */
static void resume_identity(void) {
  resume_identity_case();
  as_surfels = 1;
  resume_identity_case();
  as_surfels = 0;
}

int main(void) {
  mgs_parallel_set_threads(2);
  RUN(blend_consistency);
  RUN(blur_split);
  RUN(ray_points_closest);
  RUN(ray_points_on_sphere);
  RUN(ray_points_on_sphere_2dgs);
  RUN(ray_points_on_plane_2dgs);
  RUN(sampling_rules);
  mgs_gaussians *gt = synth_model(300, 21);
  ds = synth_dataset(gt, 8, 4, 48, 48);
  mgs_gaussians_destroy(gt);
  RUN(in_trainer);
  RUN(in_trainer_2dgs);
  RUN(resume_identity);
  mgs_dataset_destroy(ds);
  return mgs_test_finish();
}

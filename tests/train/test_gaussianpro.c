/* GaussianPro's propagation step (train/mgs_gaussianpro.h) on a shell of flat Gaussians
 * (the unit sphere, random colours as texture), its training images rendered from the
 * whole shell: after a cap facing view 0 is cut out, one step on view 0 adds Gaussians in
 * the cap and nowhere else, on the sphere; on the intact shell it adds none; the kept
 * propagated normals are unit, camera-facing and radial on the shell. Also: the
 * strategy's state (depths and normals) survives a save/load; the planar loss' gradient
 * (depth half, normal half, both) matches differences; the normal half alone turns a
 * tilted flat Gaussian onto a known propagated normal. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "tests/mgs_test.h"
#include "core/mgs_math.h"
#include "core/mgs_rng.h"
#include "render/mgs_raster.h"
#include "train/mgs_gaussianpro.h"
#include "train/mgs_strategy.h"

#define NV 13
#define SIZE 88
#define CAP_DEG 30.0

static mgs_gaussians *shell(size_t n) {
  mgs_gaussians *g = mgs_gaussians_create(n, 0);
  size_t first;
  mgs_error err = {0};
  if (mgs_gaussians_append(g, n, &first, &err)) return NULL;
  mgs_rng rng;
  mgs_rng_init(&rng, 7, 1);
  double spacing = sqrt(4 * M_PI / (double)n);
  for (size_t i = 0; i < n; i++) { /* Fibonacci sphere */
    double z = 1 - (2.0 * i + 1) / (double)n, r = sqrt(1 - z * z), ph = (double)i * M_PI * (3 - sqrt(5.0));
    double p[3] = {r * cos(ph), r * sin(ph), z};
    for (int k = 0; k < 3; k++) g->mean[3 * i + k] = (float)p[k];
    /* local z onto the radial direction */
    float q[4] = {(float)(1 + p[2]), (float)-p[1], (float)p[0], 0};
    if (p[2] < -0.9999) { q[0] = 0; q[1] = 1; q[2] = 0; }
    float l = sqrtf(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    for (int k = 0; k < 4; k++) g->rot[4 * i + k] = q[k] / l;
    /* opaque also where the shell is seen edge-on (flat, thin Gaussians would leave a
       semi-transparent silhouette that GaussianPro rightly fills) */
    g->log_scale[3 * i] = g->log_scale[3 * i + 1] = (float)log(0.8 * spacing);
    g->log_scale[3 * i + 2] = (float)log(0.3 * spacing);
    g->opacity[i] = (float)log(0.99 / 0.01);
    for (int k = 0; k < 3; k++) g->sh_dc[3 * i + k] = (float)((0.1 + 0.8 * mgs_rng_uniform(&rng) - 0.5) / MGS_SH_C0);
  }
  return g;
}

static void setup_views(mgs_view *v, const mgs_gaussians *g) {
  mgs_raster *r = mgs_raster_create();
  mgs_raster_settings rs;
  mgs_raster_settings_default(&rs);
  rs.sh_degree = 0;
  rs.background[0] = rs.background[1] = rs.background[2] = 1;
  mgs_error err = {0};
  /* view 0 on the z axis, the others on rings 12 and 24 degrees around it (neighbours
     with parallax, as a capture around an object has) */
  for (int i = 0; i < NV; i++) {
    double tilt = i == 0 ? 0 : (i <= 6 ? 12 : 24) * M_PI / 180, az = (i % 6) * M_PI / 3 + (i > 6 ? M_PI / 6 : 0);
    double dir[3] = {sin(tilt) * cos(az), sin(tilt) * sin(az), cos(tilt)};
    double eye[3] = {3.5 * dir[0], 3.5 * dir[1], 3.5 * dir[2]}, target[3] = {0, 0, 0}, up[3] = {0, 1, 0};
    memset(&v[i], 0, sizeof v[i]);
    mgs_camera_init_fovx(&v[i].cam, SIZE, SIZE, 45.0 * M_PI / 180.0);
    mgs_camera_look_at(&v[i].cam, eye, target, up);
    mgs_raster_output ro;
    CHECK_OK(mgs_raster_forward(r, g, &v[i].cam, &rs, &ro, &err), &err);
    v[i].image = mgs_image_create(SIZE, SIZE, 3);
    memcpy(v[i].image->data, ro.color, sizeof(float) * SIZE * SIZE * 3);
    v[i].alpha = mgs_image_create(SIZE, SIZE, 1); /* as an RGBA file's */
    memcpy(v[i].alpha->data, ro.alpha, sizeof(float) * SIZE * SIZE);
  }
  mgs_raster_destroy(r);
}

static void view_dir(const mgs_view *v, double d[3]) {
  double c[3];
  mgs_camera_center(&v->cam, c);
  double l = sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
  for (int k = 0; k < 3; k++) d[k] = c[k] / l;
}

static void options(mgs_gpro_options *o) {
  mgs_gpro_options_default(o);
  o->patch_size = 11;
  o->pm_iterations = 6;
  o->neighbors = 4;
  o->stride = 3;
  o->error_max = 1.0; /* the authors' */
  o->error_min = 0.8;
  o->min_pixels = 20;
  o->depth_min = 0.5;
  o->depth_max = 8;
  o->seed = 3;
}

static void test_fills_cut_cap(void) {
  mgs_gaussians *full = shell(3000);
  mgs_view v[NV];
  setup_views(v, full);
  double d0[3];
  view_dir(&v[0], d0);
  /* the intact shell: nothing to add */
  mgs_gpro_options o;
  options(&o);
  mgs_gpro *p = NULL;
  mgs_error err = {0};
  mgs_gpro_report r;
  CHECK_OK(mgs_gpro_create(&o, v, NV, 3.5, &p, &err), &err);
  mgs_gaussians *g = mgs_gaussians_clone(full);
  CHECK_OK(mgs_gpro_propagate(p, g, NULL, 0, 1.0, &r, &err), &err);
  fprintf(stderr, "  intact: %zu neighbours, %zu consistent px, %zu disagree, %zu added (%.2f s)\n", r.neighbors,
          r.consistent, r.accepted, r.added, r.seconds);
  CHECK(r.neighbors == 4);
  CHECK(r.consistent > 1500); /* the shell covers ~3100 px */
  CHECK(r.added == 0 && g->n == full->n);
  mgs_gaussians_destroy(g);
  mgs_gpro_destroy(p);
  /* cut the cap facing view 0 */
  uint8_t *keep = malloc(full->n);
  size_t cut = 0;
  for (size_t i = 0; i < full->n; i++) {
    const float *m = full->mean + 3 * i;
    /* and the opposite cap: a tunnel onto the background, the holes the authors' depth
       error threshold (> 80 %: the render shows nothing there) is made for */
    keep[i] = fabs(m[0] * d0[0] + m[1] * d0[1] + m[2] * d0[2]) <= cos(CAP_DEG * M_PI / 180);
    cut += !keep[i];
  }
  g = mgs_gaussians_clone(full);
  mgs_gaussians_compact(g, keep);
  size_t n0 = g->n;
  CHECK_OK(mgs_gpro_create(&o, v, NV, 3.5, &p, &err), &err);
  CHECK_OK(mgs_gpro_propagate(p, g, NULL, 0, 1.0, &r, &err), &err);
  fprintf(stderr, "  cap of %zu Gaussians cut: %zu consistent px, %zu disagree, %zu added (%.2f s)\n", cut, r.consistent,
          r.accepted, r.added, r.seconds);
  CHECK(g->n == n0 + r.added);
  /* the cap shows ~ pi (0.5 * 116 / 2.6)^2 ~ 150 px / 16 per stride-4 sample */
  CHECK_MSG(r.added >= 10, "%zu added", r.added);
  size_t outside = 0, off_surface = 0;
  double worst_angle = 0;
  for (size_t i = n0; i < g->n; i++) {
    const float *m = g->mean + 3 * i;
    double l = sqrt((double)m[0] * m[0] + (double)m[1] * m[1] + (double)m[2] * m[2]);
    double a = acos((m[0] * d0[0] + m[1] * d0[1] + m[2] * d0[2]) / l) * 180 / M_PI;
    if (a > worst_angle) worst_angle = a;
    outside += a > CAP_DEG + 5; /* the rim: a few degrees of tolerance */
    /* planes propagated in from the rim are the sphere's tangent planes there, outside it
       by up to 1 / cos(cap) at the centre; six sweeps of +-2 % refinement do not undo all */
    off_surface += l < 0.95 || l > 1.0 / cos(CAP_DEG * M_PI / 180) + 0.01;
    /* flat, facing outwards (within 60 degrees: normals inside the hole come from the
       random-normal refinement of planes propagated in from the rim) */
    float R[9];
    const float *q = g->rot + 4 * i;
    float w = q[0], x = q[1], y = q[2], z = q[3];
    R[2] = 2 * (x * z + w * y); R[5] = 2 * (y * z - w * x); R[8] = 1 - 2 * (x * x + y * y);
    double cosn = fabs((R[2] * m[0] + R[5] * m[1] + R[8] * m[2]) / l);
    CHECK_MSG(cosn > 0.5, "new Gaussian %zu: normal %.1f deg off the radial direction", i, acos(cosn) * 180 / M_PI);
    CHECK(g->log_scale[3 * i + 2] < g->log_scale[3 * i]);
  }
  fprintf(stderr, "  new Gaussians: farthest %.1f deg from the cap centre (cap %.0f)\n", worst_angle, CAP_DEG);
  CHECK_MSG(outside == 0, "%zu new Gaussians outside the cap", outside);
  CHECK_MSG(off_surface == 0, "%zu new Gaussians off the sphere beyond the tangent planes of the rim", off_surface);
  CHECK(mgs_gpro_cached_depth(p, 0) != NULL);
  /* the propagated normals kept for the planar loss: unit and facing the camera where the
     checked depth is, zero elsewhere; on the intact shell's part within 60 degrees of the
     view's axis, near the sphere's radial direction */
  {
    const float *dn = mgs_gpro_checked_depth(p, 0), *nn = mgs_gpro_checked_normal(p, 0);
    CHECK(dn && nn);
    size_t n_set = 0, bad = 0, radial = 0, n_rad = 0;
    double eye[3];
    mgs_camera_center(&v[0].cam, eye);
    for (int y = 0; y < SIZE && dn && nn; y++)
      for (int x = 0; x < SIZE; x++) {
        size_t k = (size_t)y * SIZE + x;
        const float *nv = nn + 3 * k;
        double l = sqrt((double)nv[0] * nv[0] + (double)nv[1] * nv[1] + (double)nv[2] * nv[2]);
        if (!(dn[k] > 0)) { bad += l != 0; continue; }
        if (l == 0) continue; /* background by the image's alpha */
        n_set++;
        double ro[3], rd[3];
        mgs_camera_ray(&v[0].cam, x + 0.5, y + 0.5, ro, rd);
        double zc = v[0].cam.c2w[2] * rd[0] + v[0].cam.c2w[6] * rd[1] + v[0].cam.c2w[10] * rd[2];
        double P[3] = {ro[0] + rd[0] * dn[k] / zc, ro[1] + rd[1] * dn[k] / zc, ro[2] + rd[2] * dn[k] / zc};
        bad += fabs(l - 1) > 1e-3 || nv[0] * (eye[0] - P[0]) + nv[1] * (eye[1] - P[1]) + nv[2] * (eye[2] - P[2]) < 0;
        double pl = sqrt(P[0] * P[0] + P[1] * P[1] + P[2] * P[2]);
        if ((P[0] * d0[0] + P[1] * d0[1] + P[2] * d0[2]) / pl > cos(M_PI / 3) && pl < 1.02) {
          n_rad++;
          radial += (nv[0] * P[0] + nv[1] * P[1] + nv[2] * P[2]) / pl > cos(20 * M_PI / 180);
        }
      }
    fprintf(stderr, "  propagated normals: %zu set, %zu bad, %zu of %zu on the shell within 20 deg of radial\n", n_set, bad,
            radial, n_rad);
    CHECK(n_set > 1000 && bad == 0);
    CHECK_MSG(radial >= 0.8 * n_rad && n_rad > 500, "%zu of %zu normals near radial", radial, n_rad);
  }

  /* the kept depths round-trip through the checkpoint state */
  FILE *f = tmpfile();
  CHECK_OK(mgs_gpro_save(p, f, &err), &err);
  mgs_gpro *q = NULL;
  CHECK_OK(mgs_gpro_create(&o, v, NV, 3.5, &q, &err), &err);
  rewind(f);
  CHECK_OK(mgs_gpro_load(q, f, &err), &err);
  int same = 1, n_cached = 0;
  for (int i = 0; i < NV; i++) {
    const float *a = mgs_gpro_cached_depth(p, (size_t)i), *b = mgs_gpro_cached_depth(q, (size_t)i);
    n_cached += a != NULL;
    if ((a == NULL) != (b == NULL) || (a && memcmp(a, b, sizeof(float) * SIZE * SIZE))) same = 0;
    const float *na = mgs_gpro_checked_normal(p, (size_t)i), *nb = mgs_gpro_checked_normal(q, (size_t)i);
    if ((na == NULL) != (nb == NULL) || (na && memcmp(na, nb, sizeof(float) * 3 * SIZE * SIZE))) same = 0;
  }
  CHECK(same && n_cached == 5);
  /* a damaged state is an error */
  rewind(f);
  fputc('x', f);
  rewind(f);
  CHECK(mgs_gpro_load(q, f, &err) != MGS_OK);
  fclose(f);
  mgs_gpro_destroy(q);
  mgs_gpro_destroy(p);
  for (int i = 0; i < NV; i++) { mgs_image_destroy(v[i].image); mgs_image_destroy(v[i].alpha); }
  mgs_gaussians_destroy(g);
  mgs_gaussians_destroy(full);
  free(keep);
}

/* The planar loss' gradient against central differences of its value, for Gaussians of
 * ordinary, tiny and near-opaque kinds, and far from the origin. */
static double g_roll = 0; /* the camera rolled about its axis: the L1 half depends on the frame */
static void planar_fd(double offset, float log_scale, float opacity_logit, double w_depth, double w_normal, double w_l1) {
  const int S = 32;
  mgs_camera cam;
  mgs_camera_init_fovx(&cam, S, S, 0.9);
  double eye[3] = {offset, 0, -3}, target[3] = {offset, 0, 0}, up[3] = {sin(g_roll), -cos(g_roll), 0};
  mgs_camera_look_at(&cam, eye, target, up);
  mgs_gaussians *g = mgs_gaussians_create(8, 0);
  size_t first;
  mgs_error err = {0};
  CHECK_OK(mgs_gaussians_append(g, 8, &first, &err), &err);
  mgs_rng rng;
  mgs_rng_init(&rng, 11, 2);
  for (size_t i = 0; i < g->n; i++) {
    g->mean[3 * i] = (float)(offset + 0.6 * (mgs_rng_uniform(&rng) - 0.5));
    g->mean[3 * i + 1] = (float)(0.6 * (mgs_rng_uniform(&rng) - 0.5));
    g->mean[3 * i + 2] = (float)(0.4 * (mgs_rng_uniform(&rng) - 0.5));
    for (int k = 0; k < 3; k++) g->log_scale[3 * i + k] = log_scale + (float)(0.3 * mgs_rng_uniform(&rng));
    for (int k = 0; k < 4; k++) g->rot[4 * i + k] = (float)(k == 0 ? 1 : 0.3 * (mgs_rng_uniform(&rng) - 0.5));
    g->opacity[i] = opacity_logit;
  }
  float *tgt = malloc(sizeof(float) * S * S);
  for (int k = 0; k < S * S; k++) tgt[k] = (k % 3) ? 5.0f + 0.01f * (float)(k % 7) : 0.0f; /* beyond the render: one sign */
  /* propagated normals: tilted up to ~40 degrees from the camera axis, none on every 5th px */
  float *tn = malloc(sizeof(float) * 3 * S * S);
  for (int k = 0; k < S * S; k++) {
    float a = 0.7f * (float)sin(0.37 * k), b = 0.7f * (float)cos(0.23 * k), l = sqrtf(1 + a * a + b * b);
    tn[3 * k] = (k % 5) ? a / l : 0; tn[3 * k + 1] = (k % 5) ? b / l : 0; tn[3 * k + 2] = (k % 5) ? -1 / l : 0;
  }
  mgs_planar_target pt = {tgt, tn, w_depth, w_normal, w_l1};
  mgs_raster *r = mgs_raster_create();
  float *dd = NULL, *dc = NULL;
  size_t cap = 0;
  mgs_gaussians *grad = mgs_gaussians_create(8, 0);
  CHECK_OK(mgs_gaussians_append(grad, 8, &first, &err), &err);
  for (int gr = 0; gr < MGS_PARAM_COUNT; gr++)
    memset(mgs_gaussians_group(grad, (mgs_param_group)gr), 0, sizeof(float) * 8 * (size_t)mgs_param_dim((mgs_param_group)gr));
  double v0;
  CHECK_OK(mgs_planar_loss(r, g, &cam, &pt, &dd, &dc, &cap, grad, &v0, &err), &err);
  CHECK(v0 > 0);
  static const mgs_param_group groups[4] = {MGS_PARAM_MEAN, MGS_PARAM_LOG_SCALE, MGS_PARAM_ROT, MGS_PARAM_OPACITY};
  double worst = 0, gmax = 0;
  int n_all = 0, n_ok = 0;
  for (int gi = 0; gi < 4; gi++) {
    int dim = mgs_param_dim(groups[gi]);
    float *par = mgs_gaussians_group(g, groups[gi]), *gp = mgs_gaussians_group(grad, groups[gi]);
    for (size_t i = 0; i < g->n; i++)
      for (int k = 0; k < dim; k++) {
        float keep = par[dim * i + k];
        double an = gp[dim * i + k], e = 1e30;
        int ok = 0;
        /* as tests/raster/test_raster_grad.c: steps h, h/4, h/16, the float forward's
           rounding noise (1e-8 x loss / step) in the tolerance */
        for (int t = 0; t < 3 && !ok; t++) {
          float h = (groups[gi] == MGS_PARAM_MEAN && fabsf(keep) > 1e3f ? 2e-2f : 2e-3f) / (float)(1 << (2 * t));
          double vp, vm;
          par[dim * i + k] = keep + h;
          float hp = par[dim * i + k] - keep; /* the step float really took */
          mgs_planar_loss(r, g, &cam, &pt, &dd, &dc, &cap, NULL, &vp, &err);
          par[dim * i + k] = keep - h;
          float hm = keep - par[dim * i + k];
          mgs_planar_loss(r, g, &cam, &pt, &dd, &dc, &cap, NULL, &vm, &err);
          par[dim * i + k] = keep;
          if (!(hp + hm > 0)) continue;
          double fd = (vp - vm) / (double)(hp + hm);
          e = fmin(e, fabs(fd - an));
          ok = fabs(fd - an) <= 2e-2 * fmax(fabs(an), fabs(fd)) + 1e-5 + 1e-8 * v0 / (double)(0.5f * (hp + hm));
        }
        if (fabs(an) > gmax) gmax = fabs(an);
        if (e > worst) worst = e;
        n_all++;
        n_ok += ok;
      }
  }
  fprintf(stderr, "  depth %g normal %g L1 %g, offset %g, log scale %.1f, opacity logit %.1f: loss %.4g, largest gradient %.3g, worst |fd - analytic| "
          "%.3g, %d of %d agree\n", w_depth, w_normal, w_l1, offset, (double)log_scale, (double)opacity_logit, v0, gmax, worst, n_ok, n_all);
  CHECK(gmax > 1e-3);
  /* the forward's 1/255 alpha cut makes the loss step (~1e-5) where a Gaussian's tail
     crosses it inside a difference's interval: a few entries may miss, a wrong formula
     misses most */
  CHECK_MSG(n_ok >= 0.9 * n_all, "%d of %d derivatives agree", n_ok, n_all);
  free(tgt); free(tn); free(dd); free(dc);
  mgs_raster_destroy(r);
  mgs_gaussians_destroy(g);
  mgs_gaussians_destroy(grad);
}

static void test_planar_grad(void) {
  for (int h = 0; h < 4; h++) { /* depth half, cosine half, both, the L1 of the normals alone */
    double wd = h == 1 || h == 3 ? 0 : 0.5, wn = h == 0 || h == 3 ? 0 : 0.5, wl = h == 3 ? 0.5 : 0;
    g_roll = h == 3 ? 0.7 : 0; /* world and camera frames differ for the L1 half */
    planar_fd(0, -2.0f, 0.0f, wd, wn, wl);     /* ordinary */
    planar_fd(0, -4.0f, 0.0f, wd, wn, wl);     /* small (a few px) */
    planar_fd(0, -2.0f, 3.0f, wd, wn, wl);     /* alpha 0.95 */
    planar_fd(1e5, -2.0f, 0.0f, wd, wn, wl);   /* far from the origin */
  }
}

/* The normal half at work: a flat Gaussian tilted 35 degrees about x from the camera
 * axis, plain gradient descent on its rotation alone by the term's gradient (normal half
 * only, weight 1) towards a known propagated normal on every pixel: the camera axis, and
 * 20 degrees to the other side (55 degrees away). It ends within 1 degree of each. */
static double tilt_of(const mgs_gaussians *g, const double t[3]) {
  /* the angle between the Gaussian's smallest axis (local z here) and t, either sign */
  float R[9];
  mgs_quat_to_mat3f(g->rot, R);
  return acos(fmin(1.0, fabs(R[2] * t[0] + R[5] * t[1] + R[8] * t[2]))) * 180 / M_PI;
}

static double rotate_flat(double target_deg, int steps, double *first_drop) {
  const int S = 32;
  mgs_camera cam;
  mgs_camera_init_fovx(&cam, S, S, 0.9);
  double eye[3] = {0, 0, -3}, target[3] = {0, 0, 0}, up[3] = {0, -1, 0};
  mgs_camera_look_at(&cam, eye, target, up);
  mgs_gaussians *g = mgs_gaussians_create(1, 0), *grad = mgs_gaussians_create(1, 0);
  size_t first;
  mgs_error err = {0};
  CHECK_OK(mgs_gaussians_append(g, 1, &first, &err), &err);
  CHECK_OK(mgs_gaussians_append(grad, 1, &first, &err), &err);
  memset(g->mean, 0, 3 * sizeof(float));
  g->log_scale[0] = g->log_scale[1] = (float)log(0.5); g->log_scale[2] = (float)log(0.01);
  const double a = 35 * M_PI / 180; /* about the x axis: local z (the smallest) at 35 deg from z */
  g->rot[0] = (float)cos(a / 2); g->rot[1] = (float)sin(a / 2); g->rot[2] = g->rot[3] = 0;
  g->opacity[0] = 2.0f;
  const double b = target_deg * M_PI / 180, t[3] = {0, sin(b), -cos(b)}; /* facing the camera */
  float *tn = malloc(sizeof(float) * 3 * S * S);
  for (int k = 0; k < S * S; k++) for (int j = 0; j < 3; j++) tn[3 * k + j] = (float)t[j];
  mgs_planar_target pt = {NULL, tn, 0, 1.0, 0};
  mgs_raster *r = mgs_raster_create();
  float *dd = NULL, *dc = NULL;
  size_t cap = 0;
  double t0 = tilt_of(g, t);
  for (int it = 0; it < steps; it++) {
    for (int gr = 0; gr < MGS_PARAM_COUNT; gr++)
      memset(mgs_gaussians_group(grad, (mgs_param_group)gr), 0, sizeof(float) * (size_t)mgs_param_dim((mgs_param_group)gr));
    double v;
    CHECK_OK(mgs_planar_loss(r, g, &cam, &pt, &dd, &dc, &cap, grad, &v, &err), &err);
    for (int k = 0; k < 4; k++) g->rot[k] -= 0.05f * grad->rot[k];
    if (it == 0) *first_drop = t0 - tilt_of(g, t);
  }
  double t1 = tilt_of(g, t);
  fprintf(stderr, "  target %+.0f deg: off by %.2f -> %.2f deg in %d steps (first step %.3f deg)\n", target_deg, t0, t1, steps,
          *first_drop);
  free(tn); free(dd); free(dc);
  mgs_raster_destroy(r);
  mgs_gaussians_destroy(g);
  mgs_gaussians_destroy(grad);
  return t1;
}

static void test_planar_normal_rotates(void) {
  double drop;
  double t = rotate_flat(0, 100, &drop);
  CHECK(drop > 0);
  CHECK_MSG(t < 1.0, "the normal half left the Gaussian %.2f deg off the camera axis", t);
  t = rotate_flat(-20, 100, &drop);
  CHECK(drop > 0);
  CHECK_MSG(t < 1.0, "the normal half left the Gaussian %.2f deg off a target 20 deg to the other side", t);
}

int main(void) {
  RUN(test_planar_grad);
  RUN(test_planar_normal_rotates);
  RUN(test_fills_cut_cap);
  return mgs_test_finish();
}

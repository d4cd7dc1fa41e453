/* Finite-difference checks of every gradient group of the rasterizer backward.
 *
 * Loss: L = sum w_c*colour + sum w_a*alpha + sum w_d*depth with random weights (so the
 * colour, alpha and depth paths are all exercised). Central differences of the float
 * forward, summed in double. A parameter passes when the analytic gradient matches the
 * difference quotient at step eps, eps/4 or eps/16 (eps: 2e-3 for mean, log-scale,
 * quaternion, opacity logit; 5e-3 for SH) within
 *     |an - fd| <= 2e-2 * max(|an|, |fd|) + atol,
 *     atol = 1e-3 * max|an| over the group + 4e-6 * sum|w*out| / step
 * (the second term is the float forward's rounding noise divided by the step). The
 * rasterizer's hard thresholds (alpha >= 1/255, T >= 1e-4, the tile rectangle) make L
 * piecewise smooth; a step that crosses one gives a jump, hence the smaller steps, and
 * up to 2 % of a group's parameters may still fail (they are printed) — a wrong formula
 * fails nearly all of them. */
#include <stdio.h>
#include "mgs_test.h"
#include "raster_test_util.h"

typedef struct fd_case {
  mgs_gaussians *g;
  mgs_camera cam;
  mgs_raster_settings s;
  mgs_raster *r;
  float *wc, *wa, *wd;
  int use_alpha, use_depth;
  double lsum_abs;
} fd_case;

static double eval_loss(fd_case *c) {
  mgs_raster_output out;
  mgs_error err;
  if (mgs_raster_forward(c->r, c->g, &c->cam, &c->s, &out, &err) != MGS_OK) {
    fprintf(stderr, "forward failed: %s\n", err.msg);
    return NAN;
  }
  size_t np = (size_t)out.width * out.height;
  double L = 0, La = 0;
  for (size_t p = 0; p < np; p++) {
    for (int k = 0; k < 3; k++) { L += (double)c->wc[3 * p + k] * out.color[3 * p + k]; La += fabs(c->wc[3 * p + k] * out.color[3 * p + k]); }
    if (c->use_alpha) { L += (double)c->wa[p] * out.alpha[p]; La += fabs(c->wa[p] * out.alpha[p]); }
    if (c->use_depth) { L += (double)c->wd[p] * out.depth[p]; La += fabs(c->wd[p] * out.depth[p]); }
  }
  c->lsum_abs = La;
  return L;
}

static double fd_at(fd_case *c, float *p, double eps) {
  float v0 = *p;
  *p = (float)(v0 + eps);
  double lp = eval_loss(c);
  double ep = (double)*p - v0;
  *p = (float)(v0 - eps);
  double lm = eval_loss(c);
  double em = v0 - (double)*p;
  *p = v0;
  return (lp - lm) / (ep + em);
}

/* Does an match the central difference at step eps, eps/4 or eps/16 (the noise term of
 * atol grows as the step shrinks)? A step crossing a threshold at distance d only spoils
 * the steps larger than d. */
static int fd_match(fd_case *c, float *p, double an, double eps, double atol, double *fd_out, double *ratio) {
  double e = eps, at = atol;
  for (int k = 0; k < 3; k++, e /= 4, at *= 4) {
    double fd = fd_at(c, p, e);
    if (k == 0) *fd_out = fd;
    double err = fabs(an - fd), tol = 2e-2 * fmax(fabs(an), fabs(fd)) + at;
    if (err <= tol) { *ratio = err / tol; return 1; }
  }
  return 0;
}

/* Checks count parameters p[0..count) against analytic an[0..count). Returns failures. */
static int check_group(fd_case *c, const char *name, float *p, const float *an, size_t count, int stride_ok,
                       double eps, const char *cname) {
  double gmax = 0;
  for (size_t i = 0; i < count; i++) gmax = fmax(gmax, fabs(an[i]));
  eval_loss(c);
  double atol = 1e-3 * gmax + 4e-6 * c->lsum_abs / eps;
  size_t bad = 0, checked = 0;
  double worst = 0;
  for (size_t i = 0; i < count; i++) {
    if (!stride_ok) continue;
    checked++;
    double fd1 = 0, ratio = 0;
    if (fd_match(c, p + i, an[i], eps, atol, &fd1, &ratio)) { worst = fmax(worst, ratio); continue; }
    bad++;
    fprintf(stderr, "    %s %s[%zu]: analytic %.6g, fd %.6g (atol %.3g)\n", cname, name, i, an[i], fd1, atol);
  }
  fprintf(stderr, "  %s %-9s: %zu checked, %zu off, worst pass ratio %.2f, max |grad| %.3g\n", cname, name, checked, bad,
          worst, gmax);
  CHECK_MSG(bad * 50 <= checked, "%s %s: %zu of %zu gradients disagree with finite differences", cname, name, bad, checked);
  CHECK_MSG(gmax > 0, "%s %s: gradient identically zero", cname, name);
  return (int)bad;
}

static void setup_weights(fd_case *c, uint64_t seed) {
  size_t np = (size_t)c->cam.width * c->cam.height;
  c->wc = malloc(np * 3 * sizeof(float));
  c->wa = malloc(np * sizeof(float));
  c->wd = malloc(np * sizeof(float));
  mgs_rng rng;
  mgs_rng_init(&rng, seed, 3);
  for (size_t p = 0; p < 3 * np; p++) c->wc[p] = (float)rt_uniform(&rng, -1, 1);
  for (size_t p = 0; p < np; p++) { c->wa[p] = (float)rt_uniform(&rng, -1, 1); c->wd[p] = (float)rt_uniform(&rng, -0.3, 0.3); }
}

static mgs_gaussians *zero_like(const mgs_gaussians *g) {
  mgs_gaussians *z = mgs_gaussians_create(g->n, 3);
  size_t first;
  mgs_gaussians_append(z, g->n, &first, NULL);
  for (int grp = 0; grp < MGS_PARAM_COUNT; grp++)
    memset(mgs_gaussians_group(z, (mgs_param_group)grp), 0, g->n * mgs_param_dim((mgs_param_group)grp) * sizeof(float));
  return z;
}

static void run_case(const char *cname, fd_case *c) {
  mgs_gaussians *grad = zero_like(c->g);
  size_t n = c->g->n;
  float *gm2d = malloc(n * sizeof(float));
  mgs_raster_output out;
  mgs_error err;
  CHECK_OK(mgs_raster_forward(c->r, c->g, &c->cam, &c->s, &out, &err), &err);
  size_t culled = 0, clipped = 0;
  for (size_t i = 0; i < n; i++) culled += out.radii[i] == 0;
  for (size_t i = 0; i < n; i++) {
    double m[3] = {c->g->mean[3 * i], c->g->mean[3 * i + 1], c->g->mean[3 * i + 2]}, u, v, d;
    if (out.radii[i] > 0 && mgs_camera_project(&c->cam, m, &u, &v, &d) && (u < 0 || v < 0 || u > c->cam.width || v > c->cam.height)) clipped++;
  }
  fprintf(stderr, "  %s: %zu Gaussians, %zu culled, %zu visible with centre off-screen\n", cname, n, culled, clipped);
  CHECK_OK(mgs_raster_backward(c->r, c->wc, c->use_alpha ? c->wa : NULL, c->use_depth ? c->wd : NULL, grad, gm2d, &err), &err);
  check_group(c, "mean", c->g->mean, grad->mean, 3 * n, 1, 2e-3, cname);
  check_group(c, "log_scale", c->g->log_scale, grad->log_scale, 3 * n, 1, 2e-3, cname);
  check_group(c, "rot", c->g->rot, grad->rot, 4 * n, 1, 2e-3, cname);
  check_group(c, "opacity", c->g->opacity, grad->opacity, n, 1, 2e-3, cname);
  check_group(c, "sh_dc", c->g->sh_dc, grad->sh_dc, 3 * n, 1, 5e-3, cname);
  int nk = (c->s.sh_degree + 1) * (c->s.sh_degree + 1) - 1;
  size_t bad_inactive = 0;
  for (size_t i = 0; i < n; i++)
    for (int k = 3 * nk; k < MGS_SH_REST_MAX; k++) bad_inactive += grad->sh_rest[MGS_SH_REST_MAX * i + k] != 0;
  CHECK_MSG(bad_inactive == 0, "%s: %zu inactive SH coefficients got a gradient", cname, bad_inactive);
  if (nk > 0) {
    /* the active coefficients of every Gaussian, gathered */
    float *an = malloc(n * 3 * nk * sizeof(float));
    for (size_t i = 0; i < n; i++) memcpy(an + i * 3 * nk, grad->sh_rest + MGS_SH_REST_MAX * i, 3 * nk * sizeof(float));
    /* check in place: parameters i*45 + k for k < 3nk */
    double gmax = 0;
    for (size_t q = 0; q < n * 3 * nk; q++) gmax = fmax(gmax, fabs(an[q]));
    size_t bad = 0, checked = 0;
    eval_loss(c);
    double atol = 1e-3 * gmax + 4e-6 * c->lsum_abs / 5e-3;
    for (size_t i = 0; i < n; i++)
      for (int k = 0; k < 3 * nk; k++) {
        float *p = c->g->sh_rest + MGS_SH_REST_MAX * i + k;
        double a = an[i * 3 * nk + k];
        double fd = 0, ratio = 0;
        checked++;
        if (!fd_match(c, p, a, 5e-3, atol, &fd, &ratio)) {
          bad++;
          fprintf(stderr, "    %s sh_rest[%zu][%d]: analytic %.6g fd %.6g\n", cname, i, k, a, fd);
        }
      }
  fprintf(stderr, "  %s sh_rest  : %zu checked, %zu off, max |grad| %.3g\n", cname, checked, bad, gmax);
    CHECK_MSG(bad * 50 <= checked, "%s sh_rest: %zu of %zu disagree", cname, bad, checked);
    CHECK(gmax > 0);
    free(an);
  }
  for (size_t i = 0; i < n; i++) {
    CHECK(isfinite(gm2d[i]) && gm2d[i] >= 0);
    if (out.radii[i] == 0) CHECK(gm2d[i] == 0);
  }
  free(gm2d);
  mgs_gaussians_destroy(grad);
}

static void free_case(fd_case *c) {
  free(c->wc); free(c->wa); free(c->wd);
  mgs_raster_destroy(c->r);
  mgs_gaussians_destroy(c->g);
}

/* Random small scenes at SH degrees 0..3 with some Gaussians straddling the image
 * border and beyond the Jacobian clamp, one with alpha clamped at 0.99. */
static void test_fd_sh_degrees(void) {
  for (int deg = 0; deg <= 3; deg++) {
    fd_case c;
    memset(&c, 0, sizeof c);
    scene_opts o = {9, 1.0, 0.12, 0.45, 0.0, 1.2, 0.4};
    c.g = rt_random_scene(100 + (uint64_t)deg, &o);
    double target[3] = {0, 0, 0};
    rt_camera(&c.cam, 40, 32, 0.9, 3.5, target, 100 + (uint64_t)deg);
    /* partly off-screen: place two Gaussians straddling the left and bottom borders, one
     * well outside (Jacobian clamp active) but large enough to reach in */
    size_t first;
    mgs_gaussians_append(c.g, 3, &first, NULL);
    double eye[3];
    mgs_camera_center(&c.cam, eye);
    const double px[3][3] = {{-1.0, 16.0, 3.0}, {20.0, 33.0, 3.2}, {-14.0, 10.0, 2.8}}; /* u, v, depth */
    mgs_rng rng;
    mgs_rng_init(&rng, 5 + (uint64_t)deg, 1);
    for (int k = 0; k < 3; k++) {
      size_t i = first + k;
      double o_[3], dir[3];
      mgs_camera_ray(&c.cam, px[k][0], px[k][1], o_, dir);
      /* depth along the camera z: scale the unit ray by depth / cos */
      double zc = c.cam.c2w[2] * dir[0] + c.cam.c2w[6] * dir[1] + c.cam.c2w[10] * dir[2];
      for (int a = 0; a < 3; a++) c.g->mean[3 * i + a] = (float)(eye[a] + dir[a] * px[k][2] / zc);
      for (int a = 0; a < 3; a++) c.g->log_scale[3 * i + a] = (float)log(k == 2 ? 0.5 : 0.2) + 0.3f * (float)mgs_rng_normal(&rng);
      for (int a = 0; a < 4; a++) c.g->rot[4 * i + a] = (float)mgs_rng_normal(&rng);
      c.g->opacity[i] = k == 0 ? 6.0f : 0.5f; /* the first one saturates: alpha clamped at 0.99 */
      for (int a = 0; a < 3; a++) c.g->sh_dc[3 * i + a] = (float)mgs_rng_normal(&rng);
      for (int a = 0; a < MGS_SH_REST_MAX; a++) c.g->sh_rest[MGS_SH_REST_MAX * i + a] = (float)(0.3 * mgs_rng_normal(&rng));
    }
    mgs_raster_settings_default(&c.s);
    c.s.sh_degree = deg;
    c.s.background[0] = 0.3f; c.s.background[1] = 0.6f; c.s.background[2] = 0.9f;
    c.r = mgs_raster_create();
    c.use_alpha = deg % 2 == 0;
    c.use_depth = deg >= 2 || deg == 0;
    setup_weights(&c, 200 + (uint64_t)deg);
    char name[64];
    snprintf(name, sizeof name, "sh%d%s%s", deg, c.use_alpha ? "+alpha" : "", c.use_depth ? "+depth" : "");
    run_case(name, &c);
    free_case(&c);
  }
}

/* Overlapping opaque layers (long back-to-front chains, termination near T = 1e-4). */
static void test_fd_dense(void) {
  fd_case c;
  memset(&c, 0, sizeof c);
  scene_opts o = {24, 0.5, 0.15, 0.4, 2.0, 1.0, 0.3};
  c.g = rt_random_scene(77, &o);
  double target[3] = {0, 0, 0};
  rt_camera(&c.cam, 32, 32, 0.8, 3.0, target, 77);
  mgs_raster_settings_default(&c.s);
  c.s.sh_degree = 2;
  c.r = mgs_raster_create();
  c.use_alpha = 1;
  c.use_depth = 1;
  setup_weights(&c, 78);
  run_case("dense", &c);
  free_case(&c);
}

/* The two clamps: a large elongated Gaussian whose centre is far outside the image (the
 * Jacobian's x/z and y/z clamp active: x- and y-gradients through J vanish, the depth one
 * halves) and a large opaque one (logit 9) whose core has opacity*G > 0.99 (alpha clamped,
 * no gradient through it). */
static void test_fd_clamps(void) {
  fd_case c;
  memset(&c, 0, sizeof c);
  scene_opts o = {2, 0.1, 0.3, 0.3, 0.0, 0.1, 0.3};
  c.g = rt_random_scene(91, &o);
  double target[3] = {0, 0, 0};
  rt_camera(&c.cam, 40, 32, 0.9, 3.5, target, 91);
  double eye[3], dir[3];
  const double uv[2][3] = {{-30.0, -20.0, 2.5}, {22.0, 14.0, 3.5}};
  for (int k = 0; k < 2; k++) {
    mgs_camera_ray(&c.cam, uv[k][0], uv[k][1], eye, dir);
    double zc = c.cam.c2w[2] * dir[0] + c.cam.c2w[6] * dir[1] + c.cam.c2w[10] * dir[2];
    for (int a = 0; a < 3; a++) c.g->mean[3 * k + a] = (float)(eye[a] + dir[a] * uv[k][2] / zc);
  }
  c.g->log_scale[0] = (float)log(1.6); c.g->log_scale[1] = (float)log(0.3); c.g->log_scale[2] = (float)log(0.8);
  c.g->opacity[0] = 0.5f;
  for (int a = 0; a < 3; a++) c.g->log_scale[3 + a] = (float)log(1.2);
  c.g->opacity[1] = 9.0f;
  mgs_raster_settings_default(&c.s);
  c.s.sh_degree = 1;
  c.r = mgs_raster_create();
  c.use_alpha = 1;
  c.use_depth = 1;
  setup_weights(&c, 92);
  mgs_raster_output out;
  mgs_error err;
  CHECK_OK(mgs_raster_forward(c.r, c.g, &c.cam, &c.s, &out, &err), &err);
  CHECK(out.radii[0] > 0 && out.radii[1] > 0);
  size_t sat = 0;
  for (int p = 0; p < 40 * 32; p++) sat += out.alpha[p] > 0.989f;
  fprintf(stderr, "  clamps: %zu pixels at the 0.99 alpha clamp\n", sat);
  CHECK(sat >= 5);
  run_case("clamps", &c);
  free_case(&c);
}

/* grad_mean2d: for a Gaussian on the optical axis with SH degree 0, a move along the
 * camera x (y) axis changes only the screen mean to first order (du = fx/z dx), so its
 * pixel gradient is the finite difference of L along that axis divided by fx/z. */
static void test_grad_mean2d(void) {
  fd_case c;
  memset(&c, 0, sizeof c);
  scene_opts o = {6, 0.8, 0.1, 0.3, 0.5, 1.0, 0.0};
  c.g = rt_random_scene(55, &o);
  double target[3] = {0.1, 0.2, -0.1};
  rt_camera(&c.cam, 48, 40, 0.9, 3.0, target, 55);
  size_t i0 = 0;
  for (int a = 0; a < 3; a++) c.g->mean[a] = (float)target[a];
  for (int a = 0; a < 3; a++) c.g->log_scale[a] = (float)log(0.25);
  c.g->opacity[0] = 1.0f;
  mgs_raster_settings_default(&c.s);
  c.r = mgs_raster_create();
  setup_weights(&c, 56);
  mgs_gaussians *grad = zero_like(c.g);
  float *gm2d = calloc(c.g->n, sizeof(float));
  mgs_raster_output out;
  mgs_error err;
  CHECK_OK(mgs_raster_forward(c.r, c.g, &c.cam, &c.s, &out, &err), &err);
  CHECK_OK(mgs_raster_backward(c.r, c.wc, NULL, NULL, grad, gm2d, &err), &err);
  double z = 3.0, eps = 1e-4, g_uv[2];
  for (int ax = 0; ax < 2; ax++) {
    double dirw[3] = {c.cam.c2w[ax], c.cam.c2w[4 + ax], c.cam.c2w[8 + ax]}; /* camera axis in world */
    float m0[3];
    memcpy(m0, c.g->mean, sizeof m0);
    /* median over 5 steps: robust to one step crossing an alpha >= 1/255 threshold */
    double fds[5];
    for (int k = 0; k < 5; k++) {
      double e = eps * (1.0 - 0.18 * k);
      for (int a = 0; a < 3; a++) c.g->mean[a] = (float)(m0[a] + e * dirw[a]);
      double lp = eval_loss(&c);
      for (int a = 0; a < 3; a++) c.g->mean[a] = (float)(m0[a] - e * dirw[a]);
      double lm = eval_loss(&c);
      fds[k] = (lp - lm) / (2 * e);
    }
    memcpy(c.g->mean, m0, sizeof m0);
    for (int k = 0; k < 5; k++)
      for (int l = k + 1; l < 5; l++) if (fds[l] < fds[k]) { double t = fds[k]; fds[k] = fds[l]; fds[l] = t; }
    double f = ax == 0 ? c.cam.fx : c.cam.fy;
    g_uv[ax] = fds[2] / (f / z);
  }
  double expect = sqrt(pow(g_uv[0] * 0.5 * c.cam.width, 2) + pow(g_uv[1] * 0.5 * c.cam.height, 2));
  fprintf(stderr, "  grad_mean2d %.6g vs finite difference %.6g\n", gm2d[i0], expect);
  CHECK_NEAR(gm2d[i0], expect, 0.03 * expect + 1e-3);
  CHECK(expect > 0);
  free(gm2d);
  mgs_gaussians_destroy(grad);
  free_case(&c);
}

int main(void) {
  RUN(test_fd_sh_degrees);
  RUN(test_fd_dense);
  RUN(test_fd_clamps);
  RUN(test_grad_mean2d);
  return mgs_test_finish();
}

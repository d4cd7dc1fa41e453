/* The 2DGS rasterizer (render/raster_2dgs_*.c): its forward against a ray-plane
 * intersection written out independently, and finite-difference checks of every gradient
 * group of its backward, through every output (colour, alpha, sum w z, median depth,
 * normal, distortion), on random scenes at SH degrees 0..3 and on the edge cases: surfels
 * seen nearly edge-on (the camera almost in their plane), degenerate (tiny and zero)
 * scales, the 0.99 alpha clamp, a scene 1e5 from the origin; and that the 16-lane
 * projection and per-surfel backward give a surfel the same records in any lane.
 *
 * Loss: L = sum of random weights times every output. Central differences of the float
 * forward, summed in double, at step eps, eps/4, eps/16 or eps/64; a parameter passes within
 * |an - fd| <= 2e-2 max(|an|, |fd|) + atol, atol = 1e-3 max|an| over the group + 4e-6
 * sum|w out| / step (the forward's rounding noise over the step). Hard thresholds (alpha >=
 * 1/255, T >= 1e-4, the switch between the ray-splat and the screen-space distance, the
 * median's T > 0.5 (its weight is left out where it is that close), the tile rectangle)
 * make L piecewise smooth, so 1 + 4 % of a group may fail (printed); a wrong formula fails
 * nearly all. */
#include <stdio.h>
#include "mgs_test.h"
#include "raster_test_util.h"

typedef struct fd_case {
  mgs_gaussians *g;
  mgs_camera cam;
  mgs_raster_settings s;
  mgs_raster *r;
  float *wc, *wa, *wd, *wm, *wn, *wdist;
  double lsum_abs;
} fd_case;

static double eval_loss(fd_case *c) {
  mgs_raster_output out;
  mgs_render_maps mp;
  mgs_error err;
  if (mgs_raster_forward(c->r, c->g, &c->cam, &c->s, &out, &err) != MGS_OK ||
      mgs_raster_maps(c->r, MGS_MAP_DEPTH_MEDIAN | MGS_MAP_NORMAL | MGS_MAP_DISTORTION, &mp, &err) != MGS_OK) {
    fprintf(stderr, "forward failed: %s\n", err.msg);
    return NAN;
  }
  size_t np = (size_t)out.width * out.height;
  double L = 0, La = 0;
#define ADD(w, v) do { double t_ = (double)(w) * (v); L += t_; La += fabs(t_); } while (0)
  for (size_t p = 0; p < np; p++) {
    for (int k = 0; k < 3; k++) { ADD(c->wc[3 * p + k], out.color[3 * p + k]); ADD(c->wn[3 * p + k], mp.normal[3 * p + k]); }
    ADD(c->wa[p], out.alpha[p]);
    ADD(c->wd[p], out.depth[p]);
    ADD(c->wm[p], mp.depth_median[p]);
    ADD(c->wdist[p], mp.distortion[p]);
  }
#undef ADD
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

static int fd_match(fd_case *c, float *p, double an, double eps, double atol, double *fd_out) {
  double e = eps, at = atol;
  for (int k = 0; k < 4; k++, e /= 4, at *= 4) {
    double fd = fd_at(c, p, e);
    if (k == 0) *fd_out = fd;
    if (fabs(an - fd) <= 2e-2 * fmax(fabs(an), fabs(fd)) + at) return 1;
  }
  return 0;
}

/* Checks p[i] for i < count with i % dim < use (dim, use: the group's row layout). */
static void check_group(fd_case *c, const char *cname, const char *name, float *p, const float *an, size_t count,
                        int dim, int use, double eps, int want_nonzero) {
  double gmax = 0;
  for (size_t i = 0; i < count; i++) gmax = fmax(gmax, fabs(an[i]));
  eval_loss(c);
  double atol = 1e-3 * gmax + 4e-6 * c->lsum_abs / eps;
  size_t bad = 0, checked = 0;
  for (size_t i = 0; i < count; i++) {
    if ((int)(i % (size_t)dim) >= use) continue;
    checked++;
    double fd = 0;
    if (fd_match(c, p + i, an[i], eps, atol, &fd)) continue;
    bad++;
    fprintf(stderr, "    %s %s[%zu]: analytic %.6g, fd %.6g (atol %.3g)\n", cname, name, i, an[i], fd, atol);
  }
  fprintf(stderr, "  %s %-9s: %zu checked, %zu off, max |grad| %.3g\n", cname, name, checked, bad, gmax);
  CHECK_MSG(bad <= 1 + checked / 25, "%s %s: %zu of %zu gradients disagree with finite differences", cname, name, bad, checked);
  if (want_nonzero) CHECK_MSG(gmax > 0, "%s %s: gradient identically zero", cname, name);
}

static void setup(fd_case *c, uint64_t seed) {
  size_t np = (size_t)c->cam.width * c->cam.height;
  c->wc = malloc(np * 3 * sizeof(float));
  c->wn = malloc(np * 3 * sizeof(float));
  c->wa = malloc(np * sizeof(float));
  c->wd = malloc(np * sizeof(float));
  c->wm = malloc(np * sizeof(float));
  c->wdist = malloc(np * sizeof(float));
  mgs_rng rng;
  mgs_rng_init(&rng, seed, 3);
  for (size_t p = 0; p < 3 * np; p++) {
    c->wc[p] = (float)rt_uniform(&rng, -1, 1);
    c->wn[p] = (float)rt_uniform(&rng, -0.5, 0.5);
  }
  for (size_t p = 0; p < np; p++) {
    c->wa[p] = (float)rt_uniform(&rng, -1, 1);
    c->wd[p] = (float)rt_uniform(&rng, -0.3, 0.3);
    c->wm[p] = (float)rt_uniform(&rng, -0.3, 0.3);
    c->wdist[p] = (float)rt_uniform(&rng, -20, 20);
  }
  c->g->kind = MGS_MODEL_2DGS;
  if (!c->r) c->r = mgs_raster_create();
}

/* The median depth jumps where a contributor's T crosses 0.5: no derivative there. Its
 * weight is zeroed on pixels whose median changes when every opacity logit moves by
 * +-0.05 (a T within ~1 % of 0.5), far more than the finite differences' steps move T. */
static void stable_median_weights(fd_case *c) {
  size_t np = (size_t)c->cam.width * c->cam.height, n = c->g->n;
  float *base = malloc(np * sizeof(float));
  mgs_render_maps mp;
  mgs_raster_output out;
  mgs_error err;
  size_t dropped = 0;
  for (int k = 0; k < 3; k++) {
    float d = k == 0 ? 0.0f : (k == 1 ? 0.05f : -0.05f);
    for (size_t i = 0; i < n; i++) c->g->opacity[i] += d;
    if (mgs_raster_forward(c->r, c->g, &c->cam, &c->s, &out, &err) == MGS_OK &&
        mgs_raster_maps(c->r, MGS_MAP_DEPTH_MEDIAN, &mp, &err) == MGS_OK)
      for (size_t p = 0; p < np; p++) {
        if (k == 0) base[p] = mp.depth_median[p];
        else if (mp.depth_median[p] != base[p] && c->wm[p] != 0) { c->wm[p] = 0; dropped++; }
      }
    for (size_t i = 0; i < n; i++) c->g->opacity[i] -= d;
  }
  free(base);
  (void)dropped;
}

static mgs_gaussians *zero_like(const mgs_gaussians *g) {
  mgs_gaussians *z = mgs_gaussians_create(g->n, 3);
  size_t first;
  mgs_gaussians_append(z, g->n, &first, NULL);
  for (int grp = 0; grp < MGS_PARAM_COUNT; grp++)
    memset(mgs_gaussians_group(z, (mgs_param_group)grp), 0, g->n * mgs_param_dim((mgs_param_group)grp) * sizeof(float));
  return z;
}

/* Forward, backward with every output's weights, the analytic gradients (caller frees). */
static mgs_gaussians *analytic(fd_case *c, float *gm2d) {
  mgs_gaussians *grad = zero_like(c->g);
  mgs_raster_output out;
  mgs_error err;
  CHECK_OK(mgs_raster_forward(c->r, c->g, &c->cam, &c->s, &out, &err), &err);
  mgs_raster_map_grad mg;
  CHECK_OK(mgs_raster_map_grads(c->r, &mg, &err), &err);
  size_t np = (size_t)c->cam.width * c->cam.height;
  memcpy(mg.depth_median, c->wm, np * sizeof(float));
  memcpy(mg.normal, c->wn, 3 * np * sizeof(float));
  memcpy(mg.distortion, c->wdist, np * sizeof(float));
  CHECK_OK(mgs_raster_backward(c->r, c->wc, c->wa, c->wd, grad, gm2d, &err), &err);
  return grad;
}

/* groups: bit per mgs_param_group to check */
static void run_case(const char *cname, fd_case *c, unsigned groups, int want_nonzero) {
  size_t n = c->g->n;
  stable_median_weights(c);
  float *gm2d = calloc(n, sizeof(float));
  mgs_gaussians *grad = analytic(c, gm2d);
  size_t vis = 0;
  mgs_raster_output out;
  mgs_error err;
  CHECK_OK(mgs_raster_forward(c->r, c->g, &c->cam, &c->s, &out, &err), &err);
  for (size_t i = 0; i < n; i++) vis += out.radii[i] > 0;
  fprintf(stderr, "  %s: %zu surfels, %zu visible\n", cname, n, vis);
  if (groups & (1u << MGS_PARAM_MEAN)) check_group(c, cname, "mean", c->g->mean, grad->mean, 3 * n, 3, 3, 2e-3, want_nonzero);
  if (groups & (1u << MGS_PARAM_LOG_SCALE))
    check_group(c, cname, "log_scale", c->g->log_scale, grad->log_scale, 3 * n, 3, 2, 2e-3, want_nonzero);
  if (groups & (1u << MGS_PARAM_ROT)) check_group(c, cname, "rot", c->g->rot, grad->rot, 4 * n, 4, 4, 2e-3, want_nonzero);
  if (groups & (1u << MGS_PARAM_OPACITY))
    check_group(c, cname, "opacity", c->g->opacity, grad->opacity, n, 1, 1, 2e-3, want_nonzero);
  if (groups & (1u << MGS_PARAM_SH_DC)) check_group(c, cname, "sh_dc", c->g->sh_dc, grad->sh_dc, 3 * n, 3, 3, 5e-3, want_nonzero);
  int nk = (c->s.sh_degree + 1) * (c->s.sh_degree + 1) - 1;
  if ((groups & (1u << MGS_PARAM_SH_REST)) && nk > 0)
    check_group(c, cname, "sh_rest", c->g->sh_rest, grad->sh_rest, MGS_SH_REST_MAX * n, MGS_SH_REST_MAX, 3 * nk, 5e-3,
                want_nonzero);
  /* the unused third scale and inactive SH get nothing; culled surfels nothing at all */
  size_t stray = 0;
  for (size_t i = 0; i < n; i++) {
    stray += grad->log_scale[3 * i + 2] != 0;
    for (int k = 3 * nk; k < MGS_SH_REST_MAX; k++) stray += grad->sh_rest[MGS_SH_REST_MAX * i + k] != 0;
    CHECK(isfinite(gm2d[i]) && gm2d[i] >= 0);
    if (out.radii[i] == 0) stray += gm2d[i] != 0 || grad->opacity[i] != 0;
  }
  CHECK_MSG(stray == 0, "%s: %zu gradients where there must be none", cname, stray);
  free(gm2d);
  mgs_gaussians_destroy(grad);
}

static void free_case(fd_case *c) {
  free(c->wc); free(c->wa); free(c->wd); free(c->wm); free(c->wn); free(c->wdist);
  mgs_raster_destroy(c->r);
  mgs_gaussians_destroy(c->g);
  memset(c, 0, sizeof *c);
}

static const unsigned ALL = (1u << MGS_PARAM_COUNT) - 1;

static void random_case(fd_case *c, uint64_t seed, int deg, size_t n) {
  memset(c, 0, sizeof *c);
  scene_opts o = {n, 0.8, 0.15, 0.5, 0.5, 1.2, 0.4};
  c->g = rt_random_scene(seed, &o);
  double target[3] = {0, 0, 0};
  rt_camera(&c->cam, 40, 32, 0.9, 3.5, target, seed);
  mgs_raster_settings_default(&c->s);
  c->s.sh_degree = deg;
  c->s.background[0] = 0.2f; c->s.background[1] = 0.5f; c->s.background[2] = 0.9f;
  setup(c, seed + 1);
}

static void test_fd_sh_degrees(void) {
  for (int deg = 0; deg <= 3; deg++) {
    fd_case c;
    random_case(&c, 200 + (uint64_t)deg, deg, 8);
    char name[32];
    snprintf(name, sizeof name, "sh%d", deg);
    run_case(name, &c, ALL, 1);
    free_case(&c);
  }
}

/* Sets surfel i's rotation so that its normal makes angle (pi/2 - tilt) with the line of
 * sight to its centre (tilt 0: the camera lies in its plane), its first axis in the plane
 * spanned by the normal and the line of sight. */
static void set_tilt(fd_case *c, size_t i, double tilt) {
  double eye[3], v[3];
  mgs_camera_center(&c->cam, eye);
  for (int k = 0; k < 3; k++) v[k] = eye[k] - c->g->mean[3 * i + k];
  mgs_normalize3d(v);
  /* a unit vector perpendicular to v */
  double a[3] = {-v[1], v[0], 0};
  if (fabs(v[2]) > 0.9) { a[0] = 0; a[1] = -v[2]; a[2] = v[1]; }
  mgs_normalize3d(a);
  double nrm[3], e1[3], e2[3];
  for (int k = 0; k < 3; k++) nrm[k] = cos(tilt) * a[k] + sin(tilt) * v[k];
  mgs_normalize3d(nrm);
  /* e1 in span(v, nrm) perpendicular to nrm; e2 = nrm x e1 */
  double d = v[0] * nrm[0] + v[1] * nrm[1] + v[2] * nrm[2];
  for (int k = 0; k < 3; k++) e1[k] = v[k] - d * nrm[k];
  mgs_normalize3d(e1);
  e2[0] = nrm[1] * e1[2] - nrm[2] * e1[1];
  e2[1] = nrm[2] * e1[0] - nrm[0] * e1[2];
  e2[2] = nrm[0] * e1[1] - nrm[1] * e1[0];
  double R[9] = {e1[0], e2[0], nrm[0], e1[1], e2[1], nrm[1], e1[2], e2[2], nrm[2]}, q[4];
  mgs_mat3_to_quatd(R, q);
  for (int k = 0; k < 4; k++) c->g->rot[4 * i + k] = (float)q[k];
}

/* Surfels seen nearly edge-on (the camera a hair off their plane: the ray-splat distance
 * explodes and the screen-space filter takes over), and one exactly edge-on (culled,
 * nothing rendered, no gradient). */
static void test_fd_edge_on(void) {
  fd_case c;
  random_case(&c, 300, 1, 5);
  /* (a step of the rotation or the centre larger than the tilt turns the surfel through
     edge-on, where the normal flips and the footprint has a kink: no derivative there) */
  const double tilts[5] = {0.01, 0.02, -0.05, 0.3, -0.015};
  for (size_t i = 0; i < 5; i++) set_tilt(&c, i, tilts[i]);
  for (size_t i = 0; i < 5; i++) c.g->opacity[i] = 2.0f;
  run_case("edge-on", &c, ALL, 1);
  free_case(&c);
  /* 1e-5 off the plane: every group but those moving the plane through the camera */
  random_case(&c, 302, 1, 4);
  for (size_t i = 0; i < 4; i++) set_tilt(&c, i, i % 2 ? 1e-5 : -1e-5);
  for (size_t i = 0; i < 4; i++) c.g->opacity[i] = 2.0f;
  run_case("edge-1e-5", &c, ALL & ~(1u << MGS_PARAM_ROT) & ~(1u << MGS_PARAM_MEAN), 1);
  free_case(&c);
  /* exactly in the plane: the centre's normal test is 0 in double only by luck, so the
     check is that the render stays finite and the gradients too */
  random_case(&c, 301, 0, 3);
  for (size_t i = 0; i < 3; i++) set_tilt(&c, i, 0.0);
  float *gm = calloc(c.g->n, sizeof(float));
  mgs_gaussians *grad = analytic(&c, gm);
  mgs_error err;
  CHECK_OK(mgs_gaussians_check_finite(grad, &err), &err);
  mgs_raster_output out;
  CHECK_OK(mgs_raster_forward(c.r, c.g, &c.cam, &c.s, &out, &err), &err);
  double amax = 0;
  for (int p = 0; p < 40 * 32; p++) { CHECK(isfinite(out.color[3 * p]) && isfinite(out.depth[p])); amax = fmax(amax, out.alpha[p]); }
  fprintf(stderr, "  in-plane: max alpha %.3g (a line of screen-space filter at most)\n", amax);
  free(gm);
  mgs_gaussians_destroy(grad);
  free_case(&c);
}

/* One scale tiny (a needle), both tiny (a point: only the screen-space filter), both
 * zero (log-scale -120: T singular, p.z = 0 everywhere). */
static void test_fd_degenerate_scales(void) {
  fd_case c;
  random_case(&c, 400, 1, 6);
  c.g->log_scale[0] = (float)log(1e-6);
  c.g->log_scale[3 + 0] = (float)log(1e-6); c.g->log_scale[3 + 1] = (float)log(1e-6);
  c.g->log_scale[6 + 0] = -120.0f; c.g->log_scale[6 + 1] = -120.0f;
  for (size_t i = 0; i < 3; i++) c.g->opacity[i] = 3.0f;
  /* the degenerate ones' scale gradients are ~0 by construction: check the other groups
     on all, the scales on the healthy rest */
  run_case("degenerate", &c, ALL & ~(1u << MGS_PARAM_LOG_SCALE), 1);
  float *gm = calloc(c.g->n, sizeof(float));
  mgs_gaussians *grad = analytic(&c, gm);
  mgs_error err;
  CHECK_OK(mgs_gaussians_check_finite(grad, &err), &err);
  check_group(&c, "degenerate", "log_scale", c.g->log_scale + 9, grad->log_scale + 9, 9, 3, 2, 2e-3, 1);
  free(gm);
  mgs_gaussians_destroy(grad);
  free_case(&c);
}

/* Opaque surfels: alpha at the 0.99 clamp over many pixels (no gradient through it). */
static void test_fd_alpha_clamp(void) {
  fd_case c;
  random_case(&c, 500, 1, 4);
  /* one opaque (alpha = 0.99 needs rho < 0.02: a small core; its 3-sigma disc kept in front
     of the camera plane, where the authors' box is defined), three translucent
     ones (two clamped layers would leave T = 1e-4, the stop threshold itself) */
  const double uvz[4][3] = {{10.3, 16.2, 3.4}, {30.3, 16.2, 3.6}, {16.3, 12.2, 3.0}, {26.3, 20.2, 3.1}};
  for (size_t i = 0; i < 4; i++) {
    double eye[3], dir[3];
    mgs_camera_ray(&c.cam, uvz[i][0], uvz[i][1], eye, dir);
    double zc = c.cam.c2w[2] * dir[0] + c.cam.c2w[6] * dir[1] + c.cam.c2w[10] * dir[2];
    for (int k = 0; k < 3; k++) c.g->mean[3 * i + k] = (float)(eye[k] + dir[k] * uvz[i][2] / zc);
    c.g->opacity[i] = i == 0 ? 9.0f : 0.5f;
    c.g->log_scale[3 * i] = c.g->log_scale[3 * i + 1] = (float)log(i == 0 ? 0.9 : 0.25);
    set_tilt(&c, i, i == 0 ? 1.5 : 0.7 + 0.2 * (double)i); /* the opaque one face-on */
  }
  mgs_raster_output out;
  mgs_error err;
  CHECK_OK(mgs_raster_forward(c.r, c.g, &c.cam, &c.s, &out, &err), &err);
  size_t sat = 0;
  for (int p = 0; p < 40 * 32; p++) sat += out.alpha[p] > 0.989f;
  fprintf(stderr, "  clamp: %zu pixels at alpha >= 0.989\n", sat);
  CHECK(sat >= 4);
  run_case("clamp", &c, ALL, 1);
  free_case(&c);
}

/* The same scene 1e5 from the origin (camera moved with it; means snapped to a 1/64 grid
 * so that they are exact at both places): same image and gradients, and finite
 * differences of every group but the means (a float at 1e5 cannot take a 2e-3 step) pass
 * there. */
static void test_fd_far(void) {
  fd_case a, b;
  random_case(&a, 600, 2, 7);
  random_case(&b, 600, 2, 7);
  const double off[3] = {1e5, -1e5, 1e5};
  for (size_t i = 0; i < a.g->n; i++)
    for (int k = 0; k < 3; k++) {
      double m = floor(a.g->mean[3 * i + k] * 64.0 + 0.5) / 64.0;
      a.g->mean[3 * i + k] = (float)m;
      b.g->mean[3 * i + k] = (float)(m + off[k]);
    }
  double c2w[16];
  memcpy(c2w, a.cam.c2w, sizeof c2w);
  for (int k = 0; k < 3; k++) c2w[4 * k + 3] += off[k];
  mgs_camera_set_c2w_opencv(&b.cam, c2w);
  float *ga = calloc(a.g->n, sizeof(float)), *gb = calloc(a.g->n, sizeof(float));
  mgs_gaussians *da = analytic(&a, ga), *db = analytic(&b, gb);
  mgs_raster_output oa, ob;
  mgs_error err;
  CHECK_OK(mgs_raster_forward(a.r, a.g, &a.cam, &a.s, &oa, &err), &err);
  CHECK_OK(mgs_raster_forward(b.r, b.g, &b.cam, &b.s, &ob, &err), &err);
  double md = 0, gd = 0, gs = 0;
  for (int p = 0; p < 40 * 32 * 3; p++) md = fmax(md, fabs(oa.color[p] - ob.color[p]));
  for (size_t i = 0; i < 3 * a.g->n; i++) { gd = fmax(gd, fabs(da->mean[i] - db->mean[i])); gs = fmax(gs, fabs(da->mean[i])); }
  fprintf(stderr, "  far: max image diff %.3g, max mean-gradient diff %.3g (max %.3g)\n", md, gd, gs);
  CHECK_MSG(md < 2e-4, "image at 1e5 differs by %g", md);
  CHECK_MSG(gd < 2e-3 * gs + 1e-4, "mean gradient at 1e5 differs by %g", gd);
  run_case("far", &b, ALL & ~(1u << MGS_PARAM_MEAN), 1);
  free(ga); free(gb);
  mgs_gaussians_destroy(da); mgs_gaussians_destroy(db);
  free_case(&a);
  free_case(&b);
}

/* The forward against a direct ray-plane intersection (double): one surfel, every pixel's
 * ray meets its plane at local (u, v); alpha = min(0.99, o exp(-min(u^2 + v^2, 2 d^2)/2))
 * with d the pixel's distance to the centre of the box of the projected 3-sigma ellipse
 * (its boundary projected point by point), on the tiles of that box; colour and depth
 * follow (the intersection's depth, the centre's where the filter wins). */
static void forward_vs_ray(double s0_, double s1_, double tilt, float logit) {
  fd_case c;
  random_case(&c, 700, 0, 1);
  for (int k = 0; k < 3; k++) c.g->mean[k] = 0;
  c.g->log_scale[0] = (float)log(s0_); c.g->log_scale[1] = (float)log(s1_);
  set_tilt(&c, 0, tilt);
  c.g->opacity[0] = logit;
  mgs_raster_output out;
  mgs_error err;
  CHECK_OK(mgs_raster_forward(c.r, c.g, &c.cam, &c.s, &out, &err), &err);
  float R[9];
  mgs_quat_to_mat3f(c.g->rot, R);
  double s0 = exp(c.g->log_scale[0]), s1 = exp(c.g->log_scale[1]), op = 1.0 / (1.0 + exp(-(double)logit));
  double rgb0 = 0.5 + MGS_SH_C0 * c.g->sh_dc[0];
  /* the screen-space filter is centred on the box of the projected 3-sigma ellipse (the
     authors' compute_aabb), found here by projecting its boundary */
  double xmin = 1e30, xmax = -1e30, ymin = 1e30, ymax = -1e30;
  for (int k = 0; k < 20000; k++) {
    double th = 2 * M_PI * k / 20000.0, pt[3], u, v, dd;
    for (int a = 0; a < 3; a++) pt[a] = 3 * s0 * cos(th) * R[3 * a] + 3 * s1 * sin(th) * R[3 * a + 1];
    mgs_camera_project(&c.cam, pt, &u, &v, &dd);
    xmin = fmin(xmin, u); xmax = fmax(xmax, u); ymin = fmin(ymin, v); ymax = fmax(ymax, v);
  }
  double cu = 0.5 * (xmin + xmax), cv = 0.5 * (ymin + ymax);
  /* the authors' tiles: those of the box (radius at least 3 sqrt(2)/2 px) */
  double rad = ceil(fmax(fmax(0.5 * (xmax - xmin), 0.5 * (ymax - ymin)), 3 * 0.707106));
  int tx0 = (int)fmax(0, floor((cu - 0.5 - rad) / 16)), ty0 = (int)fmax(0, floor((cv - 0.5 - rad) / 16));
  int tx1 = (int)floor((cu - 0.5 + rad + 15) / 16), ty1 = (int)floor((cv - 0.5 + rad + 15) / 16);
  double maxd = 0, maxz = 0, asum = 0;
  for (int y = 0; y < 32; y++)
    for (int x = 0; x < 40; x++) {
      double o[3], d[3];
      mgs_camera_ray(&c.cam, x + 0.5, y + 0.5, o, d);
      double nd = d[0] * R[2] + d[1] * R[5] + d[2] * R[8];
      double t = -(o[0] * R[2] + o[1] * R[5] + o[2] * R[8]) / nd;
      double hit[3] = {o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]};
      double u = (hit[0] * R[0] + hit[1] * R[3] + hit[2] * R[6]) / s0;
      double v = (hit[0] * R[1] + hit[1] * R[4] + hit[2] * R[7]) / s1;
      double dx = x + 0.5 - cu, dy = y + 0.5 - cv;
      double rho = fmin(u * u + v * v, 2.0 * (dx * dx + dy * dy));
      double hc[3], centre[3], origin[3] = {0, 0, 0};
      mgs_camera_world_to_cam(&c.cam, hit, hc);
      mgs_camera_world_to_cam(&c.cam, origin, centre);
      /* where the filter wins, the depth is the centre's (the authors' Tw.z) */
      double z = u * u + v * v <= 2.0 * (dx * dx + dy * dy) ? hc[2] : centre[2];
      double a = fmin(0.99, op * exp(-0.5 * rho));
      if (a < 1.0 / 255 || z < 0.2) a = 0;
      if (x / 16 < tx0 || x / 16 >= tx1 || y / 16 < ty0 || y / 16 >= ty1) a = 0;
      size_t p = (size_t)y * 40 + x;
      double col = a * (rgb0 < 0 ? 0 : rgb0) + (1 - a) * c.s.background[0];
      if (fabs(2.0 * (dx * dx + dy * dy) - (u * u + v * v)) < 1e-3) continue; /* at the switch */
      maxd = fmax(maxd, fabs(col - out.color[3 * p]));
      if (a > 0) maxz = fmax(maxz, fabs(a * z - out.depth[p]));
      asum += a;
    }
  fprintf(stderr, "  forward vs ray (scales %g, %g, tilt %g, logit %g): max colour diff %.3g, max depth diff %.3g, "
          "sum alpha %.1f\n", s0_, s1_, tilt, logit, maxd, maxz, asum);
  CHECK(asum > 3);
  CHECK_MSG(maxd < 1e-4, "colour differs from the ray-plane intersection by %g", maxd);
  CHECK_MSG(maxz < 1e-3, "depth differs from the ray-plane intersection by %g", maxz);
  free_case(&c);
}

/* Large and small, face-on and oblique, faint and opaque (the rows a surfel can reach are
 * bounded per surfel: a wrong bound drops pixels these comparisons see). */
static void test_forward_vs_ray(void) {
  forward_vs_ray(0.6, 0.3, 1.2, 1.5f);
  forward_vs_ray(0.6, 0.3, 0.25, 1.5f);
  forward_vs_ray(0.9, 0.05, 0.6, 4.0f);
  forward_vs_ray(0.3, 0.8, 1.5, -2.0f);
  forward_vs_ray(0.08, 0.08, 0.9, 3.0f);
}

/* Camera close to the scene (depths 0.7 .. 2.3: m spread widely) with the distortion's
 * weight alone large: its gradient dominates. */
static void test_fd_distortion(void) {
  fd_case c;
  memset(&c, 0, sizeof c);
  scene_opts o = {8, 0.6, 0.2, 0.5, 1.0, 0.8, 0.2};
  c.g = rt_random_scene(800, &o);
  double target[3] = {0, 0, 0};
  rt_camera(&c.cam, 40, 32, 1.2, 1.6, target, 800);
  mgs_raster_settings_default(&c.s);
  c.s.sh_degree = 1;
  setup(&c, 801);
  size_t np = 40 * 32;
  for (size_t p = 0; p < np; p++) c.wdist[p] *= 50.0f;
  mgs_render_maps mp;
  mgs_raster_output out;
  mgs_error err;
  CHECK_OK(mgs_raster_forward(c.r, c.g, &c.cam, &c.s, &out, &err), &err);
  CHECK_OK(mgs_raster_maps(c.r, MGS_MAP_DISTORTION, &mp, &err), &err);
  double dsum = 0;
  for (size_t p = 0; p < np; p++) dsum += mp.distortion[p];
  fprintf(stderr, "  distortion: mean %.3g per pixel\n", dsum / (double)np);
  CHECK(dsum > 1e-5 * (double)np);
  run_case("distortion", &c, ALL, 1);
  free_case(&c);
}

/* The projection and the per-surfel backward take 16 surfels at a time (lanes, blocks, a
 * partial last block). A surfel's records must not depend on its lane: the same scene in
 * two orders (reversed, then rotated by 5) gives the same image bit for bit and the same
 * gradients per surfel, on a mix of the edge cases (edge-on, the camera in the plane,
 * degenerate scales, a zero and a NaN quaternion, one behind the camera, one below
 * alpha 1/255), at the origin and 1e5 from it. */
static void lanes_case(const double off[3]) {
  enum { N = 37 };
  fd_case a, b;
  random_case(&a, 800, 3, N);
  for (size_t i = 0; i < N; i++) a.g->log_scale[3 * i + 2] = MGS_SURFEL_LOG_SCALE2;
  const double tilts[5] = {0.01, -0.02, 0.0, 1e-5, 0.3};
  for (size_t i = 0; i < 5; i++) set_tilt(&a, 3 + 7 * i, tilts[i]);
  a.g->log_scale[3 * 8] = (float)log(1e-6);
  a.g->log_scale[3 * 9] = a.g->log_scale[3 * 9 + 1] = -120.0f;
  for (int k = 0; k < 4; k++) a.g->rot[4 * 11 + k] = 0.0f;
  a.g->rot[4 * 12 + 1] = NAN;
  a.g->opacity[13] = -7.0f;
  double eye[3];
  mgs_camera_center(&a.cam, eye);
  for (int k = 0; k < 3; k++) a.g->mean[3 * 14 + k] = (float)(2.0 * eye[k]); /* behind the camera */
  for (size_t i = 0; i < N; i++)
    for (int k = 0; k < 3; k++) a.g->mean[3 * i + k] = (float)(floor(a.g->mean[3 * i + k] * 64.0 + 0.5) / 64.0 + off[k]);
  double c2w[16];
  memcpy(c2w, a.cam.c2w, sizeof c2w);
  for (int k = 0; k < 3; k++) c2w[4 * k + 3] += off[k];
  mgs_camera_set_c2w_opencv(&a.cam, c2w);
  random_case(&b, 800, 3, N);
  b.cam = a.cam;
  size_t perm[N]; /* b's surfel perm[i] is a's surfel i */
  for (size_t i = 0; i < N; i++) perm[i] = (N - 1 - i + 5) % N;
  for (int grp = 0; grp < MGS_PARAM_COUNT; grp++) {
    size_t dim = mgs_param_dim((mgs_param_group)grp);
    float *pa = mgs_gaussians_group(a.g, (mgs_param_group)grp), *pb = mgs_gaussians_group(b.g, (mgs_param_group)grp);
    for (size_t i = 0; i < N; i++) memcpy(pb + dim * perm[i], pa + dim * i, dim * sizeof(float));
  }
  float *gma = calloc(N, sizeof(float)), *gmb = calloc(N, sizeof(float));
  mgs_gaussians *da = analytic(&a, gma), *db = analytic(&b, gmb);
  mgs_raster_output oa, ob;
  mgs_error err;
  CHECK_OK(mgs_raster_forward(a.r, a.g, &a.cam, &a.s, &oa, &err), &err);
  size_t np = (size_t)oa.width * oa.height;
  float *ca = malloc(np * 5 * sizeof(float));
  memcpy(ca, oa.color, 3 * np * sizeof(float));
  memcpy(ca + 3 * np, oa.alpha, np * sizeof(float));
  memcpy(ca + 4 * np, oa.depth, np * sizeof(float));
  CHECK_OK(mgs_raster_forward(b.r, b.g, &b.cam, &b.s, &ob, &err), &err);
  size_t img_diff = 0, grad_diff = 0, vis = 0;
  double asum = 0;
  for (size_t p = 0; p < np; p++) {
    for (int k = 0; k < 3; k++) img_diff += ca[3 * p + k] != ob.color[3 * p + k];
    img_diff += (ca[3 * np + p] != ob.alpha[p]) + (ca[4 * np + p] != ob.depth[p]);
    asum += ob.alpha[p];
  }
  for (size_t i = 0; i < N; i++) {
    vis += oa.radii[i] > 0;
    CHECK_MSG(oa.radii[i] == ob.radii[perm[i]], "lanes: surfel %zu's radius %d in one order, %d in the other", i,
              oa.radii[i], ob.radii[perm[i]]);
    grad_diff += memcmp(&gma[i], &gmb[perm[i]], sizeof(float)) != 0;
    for (int grp = 0; grp < MGS_PARAM_COUNT; grp++) {
      size_t dim = mgs_param_dim((mgs_param_group)grp);
      const float *ga = mgs_gaussians_group(da, (mgs_param_group)grp), *gb = mgs_gaussians_group(db, (mgs_param_group)grp);
      for (size_t k = 0; k < dim; k++) grad_diff += ga[dim * i + k] != gb[dim * perm[i] + k];
    }
  }
  fprintf(stderr, "  lanes (offset %g): %zu of %d surfels visible, sum alpha %.4g, %zu pixel values and %zu gradients differ\n",
          off[0], vis, N, asum, img_diff, grad_diff);
  CHECK(vis >= 20 && asum > 1.0);
  CHECK(oa.radii[12] == 0 && oa.radii[14] == 0);
  CHECK_MSG(img_diff == 0, "lanes: %zu pixel values depend on the surfels' order", img_diff);
  CHECK_MSG(grad_diff == 0, "lanes: %zu gradients depend on the surfels' order", grad_diff);
  CHECK_OK(mgs_gaussians_check_finite(da, &err), &err);
  free(ca); free(gma); free(gmb);
  mgs_gaussians_destroy(da); mgs_gaussians_destroy(db);
  free_case(&a);
  free_case(&b);
}

static void test_lanes(void) {
  const double zero[3] = {0, 0, 0}, far[3] = {1e5, -1e5, 1e5};
  lanes_case(zero);
  lanes_case(far);
}

/* One forward (+ maps, + backward through every map) of c into copies: hinted or not. */
typedef struct hint_run {
  float *color, *alpha, *depth, *median, *normal, *dist;
  mgs_gaussians *grad;
} hint_run;

static void run_hinted(fd_case *c, int hint, hint_run *h) {
  size_t np = (size_t)c->cam.width * c->cam.height;
  mgs_raster_output out;
  mgs_render_maps mp;
  mgs_error err;
  if (hint) mgs_raster_hint_maps(c->r, MGS_MAP_DEPTH_MEDIAN | MGS_MAP_NORMAL | MGS_MAP_DISTORTION);
  CHECK_OK(mgs_raster_forward(c->r, c->g, &c->cam, &c->s, &out, &err), &err);
  CHECK_OK(mgs_raster_maps(c->r, MGS_MAP_DEPTH_MEDIAN | MGS_MAP_NORMAL | MGS_MAP_DISTORTION, &mp, &err), &err);
#define KEEP(dst, src, k) do { dst = malloc((k) * np * sizeof(float)); memcpy(dst, src, (k) * np * sizeof(float)); } while (0)
  KEEP(h->color, out.color, 3); KEEP(h->alpha, out.alpha, 1); KEEP(h->depth, out.depth, 1);
  KEEP(h->median, mp.depth_median, 1); KEEP(h->normal, mp.normal, 3); KEEP(h->dist, mp.distortion, 1);
#undef KEEP
  mgs_raster_map_grad mg;
  CHECK_OK(mgs_raster_map_grads(c->r, &mg, &err), &err);
  memcpy(mg.depth_median, c->wm, np * sizeof(float));
  memcpy(mg.normal, c->wn, 3 * np * sizeof(float));
  memcpy(mg.distortion, c->wdist, np * sizeof(float));
  h->grad = zero_like(c->g);
  float *gm2d = calloc(c->g->n, sizeof(float));
  CHECK_OK(mgs_raster_backward(c->r, c->wc, c->wa, c->wd, h->grad, gm2d, &err), &err);
  free(gm2d);
}

static void free_hint_run(hint_run *h) {
  free(h->color); free(h->alpha); free(h->depth); free(h->median); free(h->normal); free(h->dist);
  mgs_gaussians_destroy(h->grad);
}

/* The maps hint (mgs_raster_hint_maps): a forward told ahead writes the geometry maps in
 * its own pass; everything (image, maps, every gradient group) must equal, bit for bit,
 * the unhinted forward followed by the separate maps pass. The hint lasts one forward. */
static void test_hint_maps(void) {
  fd_case c;
  random_case(&c, 71, 3, 160);
  size_t np = (size_t)c.cam.width * c.cam.height, n = c.g->n;
  hint_run a, b, d;
  run_hinted(&c, 0, &a);
  run_hinted(&c, 1, &b);
  run_hinted(&c, 1, &d); /* hinted again */
  /* then unhinted on a moved model: the hint's maps are stale and must not be handed out
     (the maps pass has to run again); the reference is a fresh context's */
  for (size_t i = 0; i < 3 * n; i++) c.g->mean[i] += 0.01f;
  hint_run moved, moved_ref;
  run_hinted(&c, 0, &moved);
  mgs_raster *keep = c.r;
  c.r = mgs_raster_create();
  run_hinted(&c, 0, &moved_ref);
  mgs_raster_destroy(c.r);
  c.r = keep;
#define SAME(x, y, k) (memcmp(x, y, (k) * np * sizeof(float)) == 0)
  CHECK_MSG(SAME(a.color, b.color, 3) && SAME(a.alpha, b.alpha, 1) && SAME(a.depth, b.depth, 1), "hinted image differs");
  CHECK_MSG(SAME(a.median, b.median, 1) && SAME(a.normal, b.normal, 3) && SAME(a.dist, b.dist, 1), "hinted maps differ");
  CHECK_MSG(SAME(a.median, d.median, 1) && SAME(a.normal, d.normal, 3), "second hinted forward's maps differ");
  CHECK_MSG(SAME(moved.median, moved_ref.median, 1) && SAME(moved.normal, moved_ref.normal, 3) && SAME(moved.dist, moved_ref.dist, 1),
            "an unhinted forward after a hinted one handed out stale maps");
  CHECK_MSG(!SAME(moved.median, a.median, 1), "moving the model did not change the median map (the check above is void)");
#undef SAME
  size_t nz = 0;
  for (int grp = 0; grp < MGS_PARAM_COUNT; grp++) {
    size_t k = n * mgs_param_dim((mgs_param_group)grp);
    const float *ga = mgs_gaussians_group(a.grad, (mgs_param_group)grp), *gb = mgs_gaussians_group(b.grad, (mgs_param_group)grp);
    CHECK_MSG(memcmp(ga, gb, k * sizeof(float)) == 0, "hinted gradient of group %d differs", grp);
    for (size_t i = 0; i < k; i++) nz += ga[i] != 0;
  }
  CHECK_MSG(nz > n, "only %zu nonzero gradients: the comparison is void", nz);
  free_hint_run(&a); free_hint_run(&b); free_hint_run(&d); free_hint_run(&moved); free_hint_run(&moved_ref);
  free_case(&c);
}

int main(void) {
  RUN(test_hint_maps);
  RUN(test_forward_vs_ray);
  RUN(test_fd_sh_degrees);
  RUN(test_fd_edge_on);
  RUN(test_fd_degenerate_scales);
  RUN(test_fd_alpha_clamp);
  RUN(test_fd_far);
  RUN(test_fd_distortion);
  RUN(test_lanes);
  return mgs_test_finish();
}

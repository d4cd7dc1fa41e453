/* The 3DGS normal map's backward (render/raster_maps_backward.c through
 * mgs_raster_map_grads): finite-difference checks of every parameter group of
 * L = sum w_n . N (+ colour and sum w z in one case), N = sum_i w_i n_i the rendered normal
 * (n_i the smallest axis turned towards the camera), on random scenes and the edge cases:
 * near-equal and exactly equal smallest scales (the axis switch: the gradient is the
 * side the forward took), alpha near the 1/255 skip and at the 0.99 clamp, tiny and huge
 * scales, a scene 1e5 from the origin. Also: a backward after map_grads with a zero
 * normal gradient equals the plain one bit for bit, and the sink backward equals the
 * gradient-array one.
 *
 * Central differences of the float forward, summed in double, at steps eps/4^k; a
 * parameter passes where one step's difference agrees with the next smaller step's and
 * with the analytic value, within 2e-2 max(|an|, |fd|) + 1e-3 max|an| over the group +
 * 1e-8 sum|w out| / step (the float forward's rounding). The forward's hard
 * thresholds (alpha >= 1/255, T >= 1e-4, the tile rectangle, the axis switch and the
 * turn towards the camera) make L piecewise smooth, so 1 + 4 % of a group may fail
 * (printed); a wrong formula fails nearly all. */
#include <stdio.h>
#include "mgs_test.h"
#include "raster_test_util.h"

typedef struct fd_case {
  mgs_gaussians *g;
  mgs_camera cam;
  mgs_raster_settings s;
  mgs_raster *r;
  float *wc, *wd, *wn;
  int colour; /* include colour and depth in L */
  double lsum_abs;
} fd_case;

static double eval_loss(fd_case *c) {
  mgs_raster_output out;
  mgs_render_maps mp;
  mgs_error err;
  if (mgs_raster_forward(c->r, c->g, &c->cam, &c->s, &out, &err) != MGS_OK ||
      mgs_raster_maps(c->r, MGS_MAP_NORMAL, &mp, &err) != MGS_OK) {
    fprintf(stderr, "forward failed: %s\n", err.msg);
    return NAN;
  }
  size_t np = (size_t)out.width * out.height;
  double L = 0, La = 0;
#define ADD(w, v) do { double t_ = (double)(w) * (v); L += t_; La += fabs(t_); } while (0)
  for (size_t p = 0; p < np; p++) {
    for (int k = 0; k < 3; k++) ADD(c->wn[3 * p + k], mp.normal[3 * p + k]);
    if (c->colour) {
      for (int k = 0; k < 3; k++) ADD(c->wc[3 * p + k], out.color[3 * p + k]);
      ADD(c->wd[p], out.depth[p]);
    }
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

/* Does an match a stable central difference: at some step eps/4^k (k < 6) the difference
 * agrees with the next smaller step's and with an, both within the tolerance (a step
 * crossing a threshold of the forward makes the two disagree)? */
static int fd_match(fd_case *c, float *p, double an, double eps, double atol, double *fd_out) {
  double e = eps, prev = fd_at(c, p, e);
  *fd_out = prev;
  for (int k = 0; k < 5; k++) {
    double noise = 1e-8 * c->lsum_abs / e, tol = 2e-2 * fmax(fabs(an), fabs(prev)) + atol + noise;
    e /= 4;
    double fd = fd_at(c, p, e);
    if (fabs(an - prev) <= tol && fabs(fd - prev) <= tol) return 1;
    prev = fd;
  }
  return 0;
}

static void check_group(fd_case *c, const char *cname, const char *name, float *p, const float *an, size_t count,
                        double eps, int want_nonzero) {
  double gmax = 0;
  for (size_t i = 0; i < count; i++) gmax = fmax(gmax, fabs(an[i]));
  eval_loss(c);
  double atol = 1e-3 * gmax;
  size_t bad = 0, checked = 0;
  for (size_t i = 0; i < count; i++) {
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

static mgs_gaussians *zero_like(const mgs_gaussians *g) {
  mgs_gaussians *z = mgs_gaussians_create(g->n, 3);
  size_t first;
  mgs_gaussians_append(z, g->n, &first, NULL);
  for (int grp = 0; grp < MGS_PARAM_COUNT; grp++)
    memset(mgs_gaussians_group(z, (mgs_param_group)grp), 0, g->n * mgs_param_dim((mgs_param_group)grp) * sizeof(float));
  return z;
}

/* Forward, the normal gradient handed in through mgs_raster_map_grads, backward. */
static mgs_gaussians *analytic(fd_case *c) {
  mgs_gaussians *grad = zero_like(c->g);
  size_t np = (size_t)c->cam.width * c->cam.height;
  float *zc = calloc(3 * np, sizeof(float));
  mgs_raster_output out;
  mgs_raster_map_grad mg;
  mgs_error err;
  CHECK_OK(mgs_raster_forward(c->r, c->g, &c->cam, &c->s, &out, &err), &err);
  CHECK_OK(mgs_raster_map_grads(c->r, &mg, &err), &err);
  CHECK(mg.normal && !mg.depth_median && !mg.distortion);
  memcpy(mg.normal, c->wn, 3 * np * sizeof(float));
  CHECK_OK(mgs_raster_backward(c->r, c->colour ? c->wc : zc, NULL, c->colour ? c->wd : NULL, grad, NULL, &err), &err);
  free(zc);
  return grad;
}

enum { G_MEAN = 1, G_SCALE = 2, G_ROT = 4, G_OP = 8, G_SH = 16, G_ALL = 31 };

static void run_case(const char *cname, fd_case *c, unsigned groups) {
  size_t n = c->g->n;
  mgs_gaussians *grad = analytic(c);
  mgs_raster_output out;
  mgs_error err;
  CHECK_OK(mgs_raster_forward(c->r, c->g, &c->cam, &c->s, &out, &err), &err);
  size_t vis = 0;
  for (size_t i = 0; i < n; i++) vis += out.radii[i] > 0;
  fprintf(stderr, "  %s: %zu Gaussians, %zu visible\n", cname, n, vis);
  if (groups & G_MEAN) check_group(c, cname, "mean", c->g->mean, grad->mean, 3 * n, 2e-3, 1);
  if (groups & G_SCALE) check_group(c, cname, "log_scale", c->g->log_scale, grad->log_scale, 3 * n, 2e-3, 1);
  if (groups & G_ROT) check_group(c, cname, "rot", c->g->rot, grad->rot, 4 * n, 2e-3, 1);
  if (groups & G_OP) check_group(c, cname, "opacity", c->g->opacity, grad->opacity, n, 2e-3, 1);
  if (groups & G_SH) check_group(c, cname, "sh_dc", c->g->sh_dc, grad->sh_dc, 3 * n, 5e-3, c->colour);
  /* without colour in L the colours get nothing; culled Gaussians nothing at all */
  size_t stray = 0;
  for (size_t i = 0; i < n; i++) {
    if (!c->colour)
      for (int k = 0; k < 3; k++) stray += grad->sh_dc[3 * i + k] != 0;
    if (out.radii[i] == 0) stray += grad->opacity[i] != 0 || grad->rot[4 * i] != 0;
  }
  CHECK_MSG(stray == 0, "%s: %zu gradients where there must be none", cname, stray);
  mgs_gaussians_destroy(grad);
}

static void free_case(fd_case *c) {
  free(c->wc); free(c->wd); free(c->wn);
  mgs_raster_destroy(c->r);
  mgs_gaussians_destroy(c->g);
  memset(c, 0, sizeof *c);
}

static void make_case(fd_case *c, uint64_t seed, size_t n, int colour) {
  memset(c, 0, sizeof *c);
  scene_opts o = {n, 0.8, 0.15, 0.5, 0.5, 1.2, 0.4};
  c->g = rt_random_scene(seed, &o);
  double target[3] = {0, 0, 0};
  rt_camera(&c->cam, 40, 32, 0.9, 3.5, target, seed);
  mgs_raster_settings_default(&c->s);
  c->s.sh_degree = 1;
  c->s.background[0] = 0.2f; c->s.background[1] = 0.5f; c->s.background[2] = 0.9f;
  c->colour = colour;
  size_t np = (size_t)c->cam.width * c->cam.height;
  c->wc = malloc(3 * np * sizeof(float));
  c->wn = malloc(3 * np * sizeof(float));
  c->wd = malloc(np * sizeof(float));
  mgs_rng rng;
  mgs_rng_init(&rng, seed + 1, 3);
  for (size_t p = 0; p < 3 * np; p++) {
    c->wc[p] = (float)rt_uniform(&rng, -1, 1);
    c->wn[p] = (float)rt_uniform(&rng, -1, 1);
  }
  for (size_t p = 0; p < np; p++) c->wd[p] = (float)rt_uniform(&rng, -0.3, 0.3);
  c->r = mgs_raster_create();
}

static void test_fd_random(void) {
  fd_case c;
  make_case(&c, 100, 8, 0);
  run_case("normal-only", &c, G_ALL & ~G_SH);
  free_case(&c);
  make_case(&c, 101, 8, 1);
  run_case("with-colour", &c, G_ALL);
  free_case(&c);
}

/* Smallest two log-scales 1e-3 apart (steps below the gap stay on one side), and exactly
 * equal: the forward takes the first axis; the gradient is that side's, a one-sided
 * difference that keeps the tie's choice (moving the chosen scale down) agrees, while
 * moving it up switches the axis and the map jumps. */
static void test_fd_near_equal_scales(void) {
  fd_case c;
  make_case(&c, 200, 6, 0);
  for (size_t i = 0; i < 6; i++) {
    float *ls = c.g->log_scale + 3 * i;
    ls[0] = -1.6f; ls[1] = -1.6f + (i % 2 ? 1e-3f : -1e-3f); ls[2] = -0.9f;
  }
  run_case("near-equal", &c, G_ALL & ~G_SH);
  for (size_t i = 0; i < 6; i++) c.g->log_scale[3 * i + 1] = c.g->log_scale[3 * i];
  mgs_gaussians *grad = analytic(&c);
  double L0 = eval_loss(&c);
  size_t agree = 0, jumps = 0, tested = 0;
  double lsum = c.lsum_abs, gmax = 0;
  for (size_t i = 0; i < 18; i++) gmax = fmax(gmax, fabs(grad->log_scale[i]));
  for (size_t i = 0; i < 6; i++) {
    float *p = c.g->log_scale + 3 * i, v0 = *p;
    double an = grad->log_scale[3 * i], back = 0, fwd = 0;
    int ok = 0, seen = 0;
    /* second-order one-sided differences on the kept side, steps 4e-4, 1e-4, 2.5e-5 (as
       fd_match: a step may cross another threshold) */
    for (int t = 0; t < 3 && !ok; t++) {
      double e = 4e-4 / (double)(1 << (2 * t));
      *p = (float)(v0 - e);
      double lm = eval_loss(&c), em = (double)v0 - *p;
      *p = (float)(v0 - 2 * em);
      double lm2 = eval_loss(&c);
      *p = (float)(v0 + e);
      double lp = eval_loss(&c), ep = (double)*p - v0;
      *p = v0;
      double b = (3 * L0 - 4 * lm + lm2) / (2 * em);
      if (t == 0) { back = b; fwd = (lp - L0) / ep; }
      seen |= fabs(b) > 1e-6 || fabs(an) > 1e-6;
      ok = fabs(an - b) <= 2e-2 * fmax(fabs(an), fabs(b)) + 1e-3 * gmax + 4e-6 * lsum / em;
    }
    if (!seen) continue;
    tested++;
    agree += ok;
    jumps += fabs(fwd - back) > 10 * fabs(back) + 1.0; /* a jump of the map over the step */
    fprintf(stderr, "    tie %zu: analytic %.5g, one-sided kept %.5g, switched %.5g\n", i, an, back, fwd);
  }
  fprintf(stderr, "  tie: %zu tested, %zu agree with the kept side, %zu jump on the other\n", tested, agree, jumps);
  CHECK(tested >= 3);
  CHECK_MSG(agree == tested, "tie: %zu of %zu scale gradients differ from the forward's side", tested - agree, tested);
  CHECK_MSG(jumps >= tested / 2, "tie: the axis switch shows no jump (%zu of %zu)", jumps, tested);
  mgs_gaussians_destroy(grad);
  free_case(&c);
}

/* alpha at the 0.99 clamp (no gradient through it) and near the 1/255 skip. */
static void test_fd_alpha_extremes(void) {
  fd_case c;
  make_case(&c, 300, 6, 0);
  for (size_t i = 0; i < 3; i++) c.g->opacity[i] = 9.0f;    /* clamped over a core */
  for (size_t i = 3; i < 6; i++) c.g->opacity[i] = -4.6f;   /* ~0.01: 1/255 at ~1.4 sigma */
  run_case("alpha-0/1", &c, G_ALL & ~G_SH);
  free_case(&c);
}

/* A tiny Gaussian (1e-6: only the 0.3 px dilation; its normal still defined), a needle, a
 * disc 1e-6 thick, and one larger than the view. */
static void test_fd_tiny_huge(void) {
  fd_case c;
  make_case(&c, 400, 6, 0);
  float *ls = c.g->log_scale;
  for (int k = 0; k < 3; k++) ls[k] = (float)log(1e-6);
  ls[3] = ls[4] = (float)log(1e-6); ls[5] = (float)log(0.4);
  ls[6] = (float)log(1e-6); ls[7] = (float)log(0.3); ls[8] = (float)log(0.35);
  ls[9] = (float)log(30.0); ls[10] = (float)log(20.0); ls[11] = (float)log(3.0);
  c.g->opacity[0] = c.g->opacity[1] = 3.0f;
  c.g->opacity[3] = -2.0f;
  /* the tiny ones' scale gradients vanish by construction (a 1e-6 axis under the
     dilation): check scales on the others, every other group on all */
  run_case("tiny/huge", &c, G_ALL & ~G_SH & ~G_SCALE);
  mgs_gaussians *grad = analytic(&c);
  check_group(&c, "tiny/huge", "log_scale", c.g->log_scale + 6, grad->log_scale + 6, 12, 2e-3, 1);
  mgs_error err;
  CHECK_OK(mgs_gaussians_check_finite(grad, &err), &err);
  mgs_gaussians_destroy(grad);
  free_case(&c);
}

/* The same scene 1e5 from the origin (means on a 1/64 grid, exact at both places): same
 * normal map and gradients; finite differences of every group but the means there. */
static void test_fd_far(void) {
  fd_case a, b;
  make_case(&a, 500, 7, 0);
  make_case(&b, 500, 7, 0);
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
  mgs_gaussians *da = analytic(&a), *db = analytic(&b);
  double gr = 0, grs = 0, go = 0, gos = 0;
  for (size_t i = 0; i < 4 * a.g->n; i++) { gr = fmax(gr, fabs(da->rot[i] - db->rot[i])); grs = fmax(grs, fabs(da->rot[i])); }
  for (size_t i = 0; i < a.g->n; i++) { go = fmax(go, fabs(da->opacity[i] - db->opacity[i])); gos = fmax(gos, fabs(da->opacity[i])); }
  fprintf(stderr, "  far: rotation gradients differ by %.3g (max %.3g), opacity by %.3g (max %.3g)\n", gr, grs, go, gos);
  CHECK(grs > 0 && gos > 0);
  CHECK_MSG(gr < 2e-3 * grs + 1e-5 && go < 2e-3 * gos + 1e-5, "gradients at 1e5 differ");
  run_case("far", &b, G_ALL & ~G_SH & ~G_MEAN);
  mgs_gaussians_destroy(da);
  mgs_gaussians_destroy(db);
  free_case(&a);
  free_case(&b);
}

typedef struct sink_acc { mgs_gaussians *g; } sink_acc;
static void sink_add(void *ctx, size_t first, size_t count, const mgs_gaussians *blk) {
  mgs_gaussians *g = ((sink_acc *)ctx)->g;
  for (size_t i = 0; i < count; i++) {
    for (int k = 0; k < 3; k++) g->mean[3 * (first + i) + k] += blk->mean[3 * i + k];
    for (int k = 0; k < 3; k++) g->log_scale[3 * (first + i) + k] += blk->log_scale[3 * i + k];
    for (int k = 0; k < 4; k++) g->rot[4 * (first + i) + k] += blk->rot[4 * i + k];
    g->opacity[first + i] += blk->opacity[i];
  }
}

static double max_diff(const mgs_gaussians *a, const mgs_gaussians *b) {
  double d = 0;
  for (size_t i = 0; i < a->n; i++) {
    for (int k = 0; k < 3; k++) d = fmax(d, fabs(a->mean[3 * i + k] - b->mean[3 * i + k]));
    for (int k = 0; k < 3; k++) d = fmax(d, fabs(a->log_scale[3 * i + k] - b->log_scale[3 * i + k]));
    for (int k = 0; k < 4; k++) d = fmax(d, fabs(a->rot[4 * i + k] - b->rot[4 * i + k]));
    d = fmax(d, fabs(a->opacity[i] - b->opacity[i]));
  }
  return d;
}

/* The training path's backward is unchanged by the feature (a zero normal gradient adds
 * exactly nothing), and the sink backward carries the normal's gradients as the array one. */
static void test_paths(void) {
  fd_case c;
  make_case(&c, 600, 40, 1);
  mgs_error err;
  mgs_raster_output out;
  size_t np = (size_t)c.cam.width * c.cam.height;
  mgs_gaussians *plain = zero_like(c.g), *zero_n = zero_like(c.g);
  CHECK_OK(mgs_raster_forward(c.r, c.g, &c.cam, &c.s, &out, &err), &err);
  CHECK_OK(mgs_raster_backward(c.r, c.wc, NULL, c.wd, plain, NULL, &err), &err);
  CHECK_OK(mgs_raster_forward(c.r, c.g, &c.cam, &c.s, &out, &err), &err);
  mgs_raster_map_grad mg;
  CHECK_OK(mgs_raster_map_grads(c.r, &mg, &err), &err);
  CHECK_OK(mgs_raster_backward(c.r, c.wc, NULL, c.wd, zero_n, NULL, &err), &err);
  double d0 = max_diff(plain, zero_n);
  fprintf(stderr, "  zero normal gradient: max difference %.3g\n", d0);
  CHECK_MSG(d0 == 0, "a zero normal gradient changes the backward by %g", d0);
  /* sink vs arrays, with the normal */
  mgs_gaussians *arr = analytic(&c), *snk = zero_like(c.g);
  CHECK_OK(mgs_raster_forward(c.r, c.g, &c.cam, &c.s, &out, &err), &err);
  CHECK_OK(mgs_raster_map_grads(c.r, &mg, &err), &err);
  memcpy(mg.normal, c.wn, 3 * np * sizeof(float));
  sink_acc sa = {snk};
  CHECK_OK(mgs_raster_backward_sink(c.r, c.g, c.wc, NULL, c.wd, NULL, sink_add, &sa, &err), &err);
  double d1 = max_diff(arr, snk), d2 = max_diff(arr, plain);
  fprintf(stderr, "  sink vs arrays: %.3g (the normal's share: %.3g)\n", d1, d2);
  CHECK_MSG(d1 == 0, "the sink backward differs by %g", d1);
  CHECK(d2 > 0);
  /* a forward clears the map gradient: the next backward is the plain one again */
  mgs_gaussians *again = zero_like(c.g);
  CHECK_OK(mgs_raster_forward(c.r, c.g, &c.cam, &c.s, &out, &err), &err);
  CHECK_OK(mgs_raster_backward(c.r, c.wc, NULL, c.wd, again, NULL, &err), &err);
  CHECK(max_diff(plain, again) == 0);
  mgs_gaussians_destroy(plain); mgs_gaussians_destroy(zero_n); mgs_gaussians_destroy(arr);
  mgs_gaussians_destroy(snk); mgs_gaussians_destroy(again);
  free_case(&c);
}

int main(void) {
  RUN(test_paths);
  RUN(test_fd_random);
  RUN(test_fd_near_equal_scales);
  RUN(test_fd_alpha_extremes);
  RUN(test_fd_tiny_huge);
  RUN(test_fd_far);
  return mgs_test_finish();
}

/* The 2DGS loss term (train/term_2dgs.c): finite differences of its value (depth
 * distortion + normal consistency against the normals of the median depth, without the
 * authors' detached alpha weight, which makes the gradient differ from the value's
 * derivative by design) with respect
 * to every parameter group, through the map gradients it hands the rasterizer and that
 * rasterizer's backward. Scene: a few large, mostly opaque surfels at different depths and
 * tilts (so the median depth is defined on most pixels and its contributor changes only on
 * a few lines, where the loss has jumps: 1 + 4 % of a group may miss). */
#include <stdio.h>
#include "core/mgs_dataset.h"
#include "core/mgs_math.h"
#include "core/mgs_rng.h"
#include "mgs_test.h"
#include "render/mgs_raster.h"
#include "train/mgs_term_2dgs.h"

typedef struct tc {
  mgs_gaussians *g;
  mgs_view view;
  mgs_raster_settings s;
  mgs_raster *r;
  mgs_term *term;
  float *dl;
} tc;

/* The term's value at the current parameters (its gradients left in the context). */
static double loss(tc *c) {
  mgs_raster_output out;
  mgs_error err;
  if (mgs_raster_forward(c->r, c->g, &c->view.cam, &c->s, &out, &err) != MGS_OK) return NAN;
  mgs_term_step st;
  memset(&st, 0, sizeof st);
  st.iteration = 10000;
  st.model = c->g;
  st.view = &c->view;
  st.raster = c->r;
  st.width = out.width;
  st.height = out.height;
  if (c->term->ops->image_grad(c->term->self, &st, &err) != MGS_OK) return NAN;
  return st.value;
}

static void check(tc *c, const char *name, float *p, const float *an, size_t count, int dim, int use) {
  double gmax = 0;
  for (size_t i = 0; i < count; i++) gmax = fmax(gmax, fabs(an[i]));
  size_t bad = 0, checked = 0;
  for (size_t i = 0; i < count; i++) {
    if ((int)(i % (size_t)dim) >= use) continue;
    checked++;
    int ok = 0;
    double fd0 = 0;
    for (double e = 1e-3; e > 1e-5 && !ok; e /= 4) {
      float v0 = p[i];
      p[i] = (float)(v0 + e);
      double lp = loss(c), ep = (double)p[i] - v0;
      p[i] = (float)(v0 - e);
      double lm = loss(c), em = v0 - (double)p[i];
      p[i] = v0;
      double fd = (lp - lm) / (ep + em);
      if (e == 1e-3) fd0 = fd;
      ok = fabs(fd - an[i]) <= 3e-2 * fmax(fabs(fd), fabs(an[i])) + 2e-3 * gmax + 2e-7 / e;
    }
    if (!ok) { bad++; fprintf(stderr, "    %s[%zu]: analytic %.6g, fd %.6g\n", name, i, an[i], fd0); }
  }
  fprintf(stderr, "  %-9s: %zu checked, %zu off, max |grad| %.3g\n", name, checked, bad, gmax);
  CHECK_MSG(bad <= 1 + checked / 25, "%s: %zu of %zu disagree", name, bad, checked);
  CHECK(gmax > 0);
}

static void fd_case(double lambda_dist, double lambda_normal) {
  tc c;
  memset(&c, 0, sizeof c);
  const int n = 4;
  c.g = mgs_gaussians_create(n, 1);
  size_t first;
  mgs_gaussians_append(c.g, n, &first, NULL);
  c.g->kind = MGS_MODEL_2DGS;
  mgs_rng rng;
  mgs_rng_init(&rng, 5, 1);
  const double pos[4][3] = {{0, 0, 0}, {0.3, 0.2, 0.4}, {-0.3, -0.1, -0.3}, {0.1, -0.35, 0.2}};
  for (int i = 0; i < n; i++) {
    for (int k = 0; k < 3; k++) {
      c.g->mean[3 * i + k] = (float)pos[i][k];
      c.g->sh_dc[3 * i + k] = (float)(0.5 * mgs_rng_normal(&rng));
    }
    c.g->log_scale[3 * i] = (float)log(0.8 + 0.1 * i);
    c.g->log_scale[3 * i + 1] = (float)log(0.6 + 0.05 * i);
    c.g->log_scale[3 * i + 2] = MGS_SURFEL_LOG_SCALE2;
    c.g->rot[4 * i] = 1.0f;
    for (int k = 1; k < 4; k++) c.g->rot[4 * i + k] = (float)(0.35 * mgs_rng_normal(&rng));
    c.g->opacity[i] = 2.5f;
    for (int k = 0; k < MGS_SH_REST_MAX; k++) c.g->sh_rest[MGS_SH_REST_MAX * i + k] = 0;
  }
  mgs_camera_init_fovx(&c.view.cam, 36, 30, 0.9);
  double eye[3] = {0.4, -3.0, 0.8}, target[3] = {0, 0, 0}, up[3] = {0, 0, 1};
  mgs_camera_look_at(&c.view.cam, eye, target, up);
  mgs_raster_settings_default(&c.s);
  c.s.sh_degree = 0;
  c.r = mgs_raster_create();
  mgs_2dgs_term_options o;
  mgs_2dgs_term_options_default(&o);
  o.lambda_dist = lambda_dist;
  o.lambda_normal = lambda_normal;
  o.alpha_weight = 0; /* the authors' weight is a detached alpha: not a derivative of the value */
  fprintf(stderr, "  lambda_dist %g, lambda_normal %g\n", lambda_dist, lambda_normal);
  mgs_error err;
  CHECK_OK(mgs_term_2dgs_create(&o, &c.term, &err), &err);
  if (!c.term) return;
  /* analytic: the term's map gradients through the backward (no colour gradient) */
  size_t np = 36 * 30;
  c.dl = calloc(3 * np, sizeof(float));
  double L = loss(&c);
  mgs_gaussians *grad = mgs_gaussians_create(n, 1);
  mgs_gaussians_append(grad, n, &first, NULL);
  for (int grp = 0; grp < MGS_PARAM_COUNT; grp++)
    memset(mgs_gaussians_group(grad, (mgs_param_group)grp), 0, n * mgs_param_dim((mgs_param_group)grp) * sizeof(float));
  CHECK_OK(mgs_raster_backward(c.r, c.dl, NULL, NULL, grad, NULL, &err), &err);
  mgs_render_maps mp;
  CHECK_OK(mgs_raster_maps(c.r, MGS_MAP_DEPTH_MEDIAN, &mp, &err), &err);
  size_t covered = 0;
  for (size_t p = 0; p < np; p++) covered += mp.depth_median[p] > 0;
  fprintf(stderr, "  loss %.5f, %zu of %zu pixels with a median depth\n", L, covered, np);
  CHECK(covered > np / 2);
  check(&c, "mean", c.g->mean, grad->mean, 3 * n, 3, 3);
  check(&c, "log_scale", c.g->log_scale, grad->log_scale, 3 * n, 3, 2);
  check(&c, "rot", c.g->rot, grad->rot, 4 * n, 4, 4);
  check(&c, "opacity", c.g->opacity, grad->opacity, n, 1, 1);
  mgs_gaussians_destroy(grad);
  free(c.dl);
  mgs_term_destroy(c.term);
  mgs_raster_destroy(c.r);
  mgs_gaussians_destroy(c.g);
}

/* each loss alone, then both */
static void test_fd(void) {
  fd_case(100, 0);
  fd_case(0, 0.5);
  fd_case(100, 0.5);
}

int main(void) {
  RUN(test_fd);
  return mgs_test_finish();
}

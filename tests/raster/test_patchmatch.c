/* Patch matching (render/mgs_patchmatch.h) on analytic views of a textured plane: from a
 * depth 15 % off and random normals it recovers the plane's depth and normal; the
 * geometric consistency check counts agreeing views; neighbour selection prefers
 * parallax over a near-duplicate view and ignores a view looking elsewhere. */
#include <math.h>
#include <stdlib.h>
#include "tests/mgs_test.h"
#include "core/mgs_camera.h"
#include "render/mgs_patchmatch.h"

/* The plane n.X = 0 through the origin, tilted; texture in its own 2-D coordinates. */
static const double PN[3] = {0.25, -0.15, 0.9565};

static double texture(double a, double b) {
  return 128 + 45 * sin(9.1 * a + 1.3) * cos(7.3 * b) + 30 * sin(17.7 * a - 11.9 * b) + 25 * cos(23.3 * b + 5.1 * a) +
         15 * sin(41.0 * a + 37.0 * b);
}

static void plane_axes(double e1[3], double e2[3]) {
  double l = sqrt(PN[0] * PN[0] + PN[1] * PN[1] + PN[2] * PN[2]);
  double n[3] = {PN[0] / l, PN[1] / l, PN[2] / l};
  double t[3] = {1, 0, 0};
  double d = t[0] * n[0] + t[1] * n[1] + t[2] * n[2];
  for (int i = 0; i < 3; i++) e1[i] = t[i] - d * n[i];
  l = sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]);
  for (int i = 0; i < 3; i++) e1[i] /= l;
  e2[0] = n[1] * e1[2] - n[2] * e1[1];
  e2[1] = n[2] * e1[0] - n[0] * e1[2];
  e2[2] = n[0] * e1[1] - n[1] * e1[0];
}

/* Ray (pixel u, v) to the plane: depth along the optical axis, texture there. */
static double ray_plane(const mgs_camera *c, double u, double v, double *tex) {
  double o[3], d[3];
  mgs_camera_ray(c, u, v, o, d);
  double nd = PN[0] * d[0] + PN[1] * d[1] + PN[2] * d[2], no = PN[0] * o[0] + PN[1] * o[1] + PN[2] * o[2];
  double s = -no / nd;
  double X[3] = {o[0] + s * d[0], o[1] + s * d[1], o[2] + s * d[2]};
  if (tex) {
    double e1[3], e2[3];
    plane_axes(e1, e2);
    *tex = texture(X[0] * e1[0] + X[1] * e1[1] + X[2] * e1[2], X[0] * e2[0] + X[1] * e2[1] + X[2] * e2[2]);
  }
  double pc[3];
  mgs_camera_world_to_cam(c, X, pc);
  return pc[2];
}

static float *render_gray(const mgs_camera *c) {
  float *g = malloc((size_t)c->width * c->height * sizeof *g);
  for (int y = 0; y < c->height; y++)
    for (int x = 0; x < c->width; x++) {
      double sum = 0, t;
      for (int k = 0; k < 4; k++) { /* 2x2 supersampling */
        ray_plane(c, x + 0.25 + 0.5 * (k & 1), y + 0.25 + 0.5 * (k >> 1), &t);
        sum += t;
      }
      g[(size_t)y * c->width + x] = (float)(sum / 4);
    }
  return g;
}

static float *true_depth(const mgs_camera *c) {
  float *d = malloc((size_t)c->width * c->height * sizeof *d);
  for (int y = 0; y < c->height; y++)
    for (int x = 0; x < c->width; x++) d[(size_t)y * c->width + x] = (float)ray_plane(c, x + 0.5, y + 0.5, NULL);
  return d;
}

static void camera_at(mgs_camera *c, double ex, double ey, double ez, int size) {
  mgs_camera_init_fovx(c, size, size, 50.0 * M_PI / 180.0);
  double eye[3] = {ex, ey, ez}, target[3] = {0, 0, 0}, up[3] = {0, -1, 0};
  mgs_camera_look_at(c, eye, target, up);
}

static int cmp_float(const void *a, const void *b) {
  float x = *(const float *)a, y = *(const float *)b;
  return (x > y) - (x < y);
}

static void test_recovers_plane(void) {
  const int S = 80;
  mgs_camera cams[3];
  camera_at(&cams[0], 0, 0, 3, S);
  camera_at(&cams[1], 0.45, 0.05, 2.95, S);
  camera_at(&cams[2], -0.3, 0.35, 2.95, S);
  float *gray[3], *gt = true_depth(&cams[0]);
  for (int i = 0; i < 3; i++) gray[i] = render_gray(&cams[i]);
  size_t np = (size_t)S * S;
  float *init = malloc(np * sizeof *init), *depth = malloc(np * sizeof *depth), *normal = malloc(3 * np * sizeof *normal);
  for (size_t p = 0; p < np; p++) init[p] = 1.15f * gt[p]; /* 15 % too far */
  mgs_pm_view ref = {&cams[0], gray[0]}, src[2] = {{&cams[1], gray[1]}, {&cams[2], gray[2]}};
  mgs_pm_options o;
  mgs_pm_options_default(&o);
  o.patch_size = 11;
  o.iterations = 4;
  o.depth_min = 1.0f;
  o.depth_max = 6.0f;
  mgs_error err = {0};
  for (int nsrc = 1; nsrc <= 2; nsrc++) {
    CHECK_OK(mgs_pm_run(&ref, src, nsrc, init, NULL, &o, depth, normal, NULL, &err), &err);
    /* interior pixels (the window fits, the plane is seen by the sources) */
    float *rel = malloc(np * sizeof *rel);
    size_t m = 0, init_bad = 0;
    double nerr_sum = 0;
    double l = sqrt(PN[0] * PN[0] + PN[1] * PN[1] + PN[2] * PN[2]);
    for (int y = 8; y < S - 8; y++)
      for (int x = 8; x < S - 8; x++) {
        size_t p = (size_t)y * S + x;
        rel[m++] = fabsf(depth[p] - gt[p]) / gt[p];
        if (fabsf(init[p] - gt[p]) / gt[p] > 0.02f) init_bad++;
        double dot = fabs((normal[3 * p] * PN[0] + normal[3 * p + 1] * PN[1] + normal[3 * p + 2] * PN[2]) / l);
        nerr_sum += acos(dot > 1 ? 1 : dot) * 180 / M_PI;
      }
    qsort(rel, m, sizeof *rel, cmp_float);
    float med = rel[m / 2], p90 = rel[(size_t)(0.9 * m)];
    fprintf(stderr, "  %d source(s): |rel depth error| median %.4f, 90%% %.4f; mean normal error %.2f deg\n", nsrc,
            (double)med, (double)p90, nerr_sum / (double)m);
    CHECK(init_bad == m);          /* every pixel started wrong */
    CHECK(med < 0.005f);           /* recovered: median within 0.5 % */
    CHECK(p90 < 0.02f);            /* 90 % within 2 % */
    CHECK(nerr_sum / (double)m < 10.0);
    free(rel);
  }
  /* zero iterations leave the wrong initial depth: the propagation did the work */
  o.iterations = 0;
  CHECK_OK(mgs_pm_run(&ref, src, 2, init, NULL, &o, depth, NULL, NULL, &err), &err);
  CHECK_NEAR(depth[(size_t)(S / 2) * S + S / 2], init[(size_t)(S / 2) * S + S / 2], 1e-3);
  /* bad input is an error, not a crash */
  CHECK(mgs_pm_run(&ref, src, 0, init, NULL, &o, depth, NULL, NULL, &err) != MGS_OK);
  o.depth_max = 0.5f;
  CHECK(mgs_pm_run(&ref, src, 2, init, NULL, &o, depth, NULL, NULL, &err) != MGS_OK);
  for (int i = 0; i < 3; i++) free(gray[i]);
  free(gt); free(init); free(depth); free(normal);
}

static void test_consistency(void) {
  const int S = 48;
  mgs_camera cams[3];
  camera_at(&cams[0], 0, 0, 3, S);
  camera_at(&cams[1], 0.45, 0.05, 2.95, S);
  camera_at(&cams[2], -0.3, 0.35, 2.95, S);
  float *d[3];
  for (int i = 0; i < 3; i++) d[i] = true_depth(&cams[i]);
  const mgs_camera *sc[2] = {&cams[1], &cams[2]};
  const float *sd[2] = {d[1], d[2]};
  uint8_t *cnt = malloc((size_t)S * S);
  mgs_pm_geometric_consistency(&cams[0], d[0], sc, sd, 2, 2.0f, 0.01f, cnt);
  size_t both = 0, total = 0;
  for (int y = 4; y < S - 4; y++)
    for (int x = 4; x < S - 4; x++, total++) both += cnt[(size_t)y * S + x] == 2;
  CHECK_MSG(both > 0.95 * total, "%zu of %zu interior pixels agree with both views", both, total);
  /* a source depth 3 % off disagrees everywhere (the 1 % test) */
  for (size_t p = 0; p < (size_t)S * S; p++) d[1][p] *= 1.03f;
  mgs_pm_geometric_consistency(&cams[0], d[0], sc, sd, 2, 2.0f, 0.01f, cnt);
  size_t two = 0;
  for (size_t p = 0; p < (size_t)S * S; p++) two += cnt[p] >= 2;
  CHECK(two == 0);
  free(cnt);
  for (int i = 0; i < 3; i++) free(d[i]);
}

static void test_neighbors(void) {
  const int S = 40;
  mgs_camera cams[5];
  camera_at(&cams[0], 0, 0, 3, S);
  camera_at(&cams[1], 0.02, 0, 3, S);         /* ~0.4 degrees: no parallax */
  camera_at(&cams[2], 0.27, 0, 2.99, S);      /* ~5 degrees */
  camera_at(&cams[3], -1.0, 0.2, 2.8, S);     /* ~20 degrees */
  mgs_camera_init_fovx(&cams[4], S, S, 0.8);  /* behind the plane, looking away */
  double eye[3] = {0, 0, 3.5}, target[3] = {0, 0, 10}, up[3] = {0, -1, 0};
  mgs_camera_look_at(&cams[4], eye, target, up);
  float *d = true_depth(&cams[0]);
  size_t out[4];
  size_t m = mgs_pm_select_neighbors(cams, 5, 0, d, 2, 4, out);
  CHECK(m == 3);
  CHECK(m >= 1 && out[0] == 2);
  for (size_t i = 0; i < m; i++) CHECK(out[i] != 4 && out[i] != 0);
  CHECK(m == 3 && out[2] == 1); /* the near-duplicate comes last */
  free(d);
}

int main(void) {
  RUN(test_recovers_plane);
  RUN(test_consistency);
  RUN(test_neighbors);
  return mgs_test_finish();
}

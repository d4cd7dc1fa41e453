/* Patch matching (render/mgs_patchmatch.h) on analytic views of a textured plane: from a
 * depth 15 % off and random normals it recovers the plane's depth and normal; its output
 * is bit-identical to the code before the speed-up (patchmatch_ref.c) on views of several
 * sizes with a flat band, border pixels and non-finite texels; the geometric consistency
 * check counts agreeing views; neighbour selection prefers parallax over a near-duplicate
 * view and ignores a view looking elsewhere. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include "tests/mgs_test.h"
#include "core/mgs_camera.h"
#include "render/mgs_patchmatch.h"

/* The plane n.X = 0 through the origin, tilted; texture in its own 2-D coordinates. */
static const double PN[3] = {0.25, -0.15, 0.9565};

static double flat_above = INFINITY; /* texture coordinate a beyond which the plane is black */

static double texture(double a, double b) {
  if (a > flat_above) return 0;
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

static void camera_at_wh(mgs_camera *c, double ex, double ey, double ez, int w, int h) {
  mgs_camera_init_fovx(c, w, h, 50.0 * M_PI / 180.0);
  double eye[3] = {ex, ey, ez}, target[3] = {0, 0, 0}, up[3] = {0, -1, 0};
  mgs_camera_look_at(c, eye, target, up);
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

/* patchmatch_ref.c: mgs_pm_run before the speed-up */
mgs_status pm_ref_run(const mgs_pm_view *ref, const mgs_pm_view *src, int n_src, const float *init_depth,
                      const float *init_normal, const mgs_pm_options *o, float *depth, float *normal, float *cost,
                      mgs_error *err);

static size_t count_diff(const float *a, const float *b, size_t n) { /* bit patterns */
  size_t d = 0;
  for (size_t i = 0; i < n; i++) d += memcmp(a + i, b + i, sizeof(float)) != 0;
  return d;
}

/* The same maps, bit for bit, as the reference, over windows cut by the border, a flat
 * band, a source smaller and one larger than the reference, non-finite and out-of-range
 * texels, several seeds and option sets (with and without initial normals). */
static void test_same_as_reference(void) {
  const int S = 56;
  mgs_camera cams[4];
  camera_at(&cams[0], 0, 0, 3, S);
  camera_at_wh(&cams[1], 0.45, 0.05, 2.95, S, S);
  camera_at_wh(&cams[2], -0.3, 0.35, 2.95, 40, 30); /* smaller, another aspect */
  camera_at_wh(&cams[3], 0.2, -0.4, 2.9, 64, 60);
  flat_above = 0.25;
  float *gray[4], *gt = true_depth(&cams[0]);
  for (int i = 0; i < 4; i++) gray[i] = render_gray(&cams[i]);
  flat_above = INFINITY;
  size_t np = (size_t)S * S;
  gray[0][(size_t)20 * S + 30] = 700;      /* |dc| beyond the colour table: zero weights */
  gray[0][(size_t)40 * S + 12] = NAN;
  gray[2][(size_t)15 * 40 + 20] = NAN;
  gray[3][(size_t)30 * 64 + 33] = INFINITY;
  gray[1][(size_t)S * S - 1] = -40;         /* the clamped corner texel */
  gray[1][(size_t)20 * S + S - 1] = INFINITY; /* on the last column / row, which the clamp reads twice */
  gray[3][(size_t)59 * 64 + 10] = INFINITY;
  float *init = malloc(np * sizeof *init), *init_n = malloc(3 * np * sizeof *init_n);
  double l = sqrt(PN[0] * PN[0] + PN[1] * PN[1] + PN[2] * PN[2]);
  for (size_t p = 0; p < np; p++) {
    uint32_t h = (uint32_t)p * 2654435761u;
    h ^= h >> 15;
    init[p] = p % 11 == 3 ? 0.0f : gt[p] * (1.0f + 0.1f * ((float)(h % 1000) / 1000.0f - 0.5f));
    for (int i = 0; i < 3; i++) /* the plane's normal towards the camera, tilted; some unusable */
      init_n[3 * p + i] = p % 13 == 5 ? 0.0f : (float)(PN[i] / l) + 0.05f * (float)((h >> (8 * i)) % 7) - 0.15f;
  }
  struct { int patch, step, iters, n_src, top_k, normals; uint64_t seed; const int *srcs; } cfg[] = {
    {20, 2, 2, 3, 4, 1, 1, (const int[]){1, 2, 3}},
    {11, 1, 2, 2, 1, 0, 7, (const int[]){3, 1}},
    {7, 3, 3, 3, 2, 1, 12345, (const int[]){2, 3, 1}},
    {20, 2, 1, 1, 4, 0, 99, (const int[]){2}},
  };
  float *d[2], *n[2], *c[2];
  for (int k = 0; k < 2; k++) {
    d[k] = malloc(np * sizeof(float));
    n[k] = malloc(3 * np * sizeof(float));
    c[k] = malloc(np * sizeof(float));
  }
  mgs_error err = {0};
  for (size_t t = 0; t < sizeof cfg / sizeof cfg[0]; t++) {
    mgs_pm_options o;
    mgs_pm_options_default(&o);
    o.patch_size = cfg[t].patch;
    o.patch_step = cfg[t].step;
    o.iterations = cfg[t].iters;
    o.top_k = cfg[t].top_k;
    o.seed = cfg[t].seed;
    o.depth_min = 1.0f;
    o.depth_max = 6.0f;
    if (t == 2) o.perturbation = 0.05f;
    mgs_pm_view ref = {&cams[0], gray[0]}, src[3];
    for (int j = 0; j < cfg[t].n_src; j++) { src[j].cam = &cams[cfg[t].srcs[j]]; src[j].gray = gray[cfg[t].srcs[j]]; }
    const float *nrm = cfg[t].normals ? init_n : NULL;
    CHECK_OK(mgs_pm_run(&ref, src, cfg[t].n_src, init, nrm, &o, d[0], n[0], c[0], &err), &err);
    CHECK_OK(pm_ref_run(&ref, src, cfg[t].n_src, init, nrm, &o, d[1], n[1], c[1], &err), &err);
    size_t dd = count_diff(d[0], d[1], np), dn = count_diff(n[0], n[1], 3 * np), dc = count_diff(c[0], c[1], np);
    size_t matched = 0;
    for (size_t p = 0; p < np; p++) matched += c[1][p] < 2.0f;
    fprintf(stderr, "  patch %d step %d, %d source(s), seed %llu: %zu of %zu pixels matched; differing depth %zu, normal %zu, cost %zu\n",
            cfg[t].patch, cfg[t].step, cfg[t].n_src, (unsigned long long)cfg[t].seed, matched, np, dd, dn, dc);
    CHECK(dd == 0 && dn == 0 && dc == 0);
    /* a real match, and the black band left unmatched (black: a window of some other single
     * grey need not count as flat, the moments' float rounding can exceed the 1e-5 threshold) */
    CHECK(matched > np / 4 && matched < np - np / 5);
  }
  for (int k = 0; k < 2; k++) { free(d[k]); free(n[k]); free(c[k]); }
  for (int i = 0; i < 4; i++) free(gray[i]);
  free(gt); free(init); free(init_n);
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
  RUN(test_same_as_reference);
  RUN(test_consistency);
  RUN(test_neighbors);
  return mgs_test_finish();
}

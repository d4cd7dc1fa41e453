/* The SoA model: append/compact/select keep every group in step; covariance; checks. */
#include "core/mgs_core.h"
#include "mgs_test.h"

/* Tag every float of Gaussian i with a value derived from (group, i, component). */
static float tag(int group, size_t i, int c) { return (float)(group * 1000000 + (int)i * 100 + c); }

static void fill(mgs_gaussians *g) {
  for (int k = 0; k < MGS_PARAM_COUNT; k++) {
    float *p = mgs_gaussians_group(g, (mgs_param_group)k);
    int d = mgs_param_dim((mgs_param_group)k);
    for (size_t i = 0; i < g->n; i++) for (int c = 0; c < d; c++) p[i * d + c] = tag(k, i, c);
  }
}

static int row_is(mgs_gaussians *g, size_t row, size_t orig) {
  for (int k = 0; k < MGS_PARAM_COUNT; k++) {
    float *p = mgs_gaussians_group(g, (mgs_param_group)k);
    int d = mgs_param_dim((mgs_param_group)k);
    for (int c = 0; c < d; c++) if (p[row * d + c] != tag(k, orig, c)) return 0;
  }
  return 1;
}

static void test_append_compact_select(void) {
  mgs_error err;
  mgs_gaussians *g = mgs_gaussians_create(2, 3);
  size_t first = 99;
  CHECK_OK(mgs_gaussians_append(g, 10, &first, &err), &err);
  CHECK(first == 0 && g->n == 10 && g->capacity >= 10);
  CHECK(g->rot[0] == 1.0f && g->rot[1] == 0.0f && g->sh_rest[44] == 0.0f);
  fill(g);
  CHECK_OK(mgs_gaussians_append(g, 1000, &first, &err), &err); /* growth keeps old rows */
  CHECK(first == 10 && g->n == 1010);
  for (size_t i = 0; i < 10; i++) CHECK(row_is(g, i, i));
  CHECK(g->rot[4 * 500] == 1.0f && g->mean[3 * 500] == 0.0f);
  g->n = 10;
  uint8_t keep[10] = {1, 0, 0, 1, 1, 0, 1, 0, 0, 1};
  CHECK(mgs_gaussians_compact(g, keep) == 5);
  size_t expect[5] = {0, 3, 4, 6, 9};
  for (size_t i = 0; i < 5; i++) CHECK(row_is(g, i, expect[i]));
  /* the same mask on a moment-like array keeps it aligned */
  float m[30];
  for (int i = 0; i < 30; i++) m[i] = (float)i;
  CHECK(mgs_rows_compact(m, 10, 3, keep) == 5);
  CHECK(m[3] == 9.0f && m[14] == 29.0f);
  size_t idx[2] = {4, 1};
  mgs_gaussians *s = mgs_gaussians_select(g, idx, 2);
  CHECK(s->n == 2 && s->sh_degree == 3);
  CHECK(row_is(s, 0, 9) && row_is(s, 1, 3));
  mgs_gaussians *c = mgs_gaussians_clone(g);
  CHECK(c->n == 5 && row_is(c, 4, 9));
  mgs_gaussians_destroy(s);
  mgs_gaussians_destroy(c);
  mgs_gaussians_destroy(g);
}

static void test_covariance_and_finite(void) {
  mgs_gaussians *g = mgs_gaussians_create(1, 0);
  mgs_error err;
  CHECK_OK(mgs_gaussians_append(g, 1, NULL, &err), &err);
  g->log_scale[0] = logf(2.0f); g->log_scale[1] = logf(0.5f); g->log_scale[2] = logf(1e-4f);
  /* 90 degrees about z: local x -> world y */
  g->rot[0] = 0.70710678f; g->rot[3] = 0.70710678f;
  double cov[9];
  mgs_gaussian_covariance(g, 0, cov);
  CHECK_NEAR(cov[0], 0.25, 1e-6);
  CHECK_NEAR(cov[4], 4.0, 1e-5);
  CHECK_NEAR(cov[8], 1e-8, 1e-12);
  CHECK_NEAR(cov[1], 0.0, 1e-6);
  g->opacity[0] = 0.0f;
  CHECK_NEAR(mgs_gaussian_alpha(g, 0), 0.5, 1e-7);
  CHECK(mgs_gaussians_check_finite(g, &err) == MGS_OK);
  g->sh_dc[2] = NAN;
  CHECK(mgs_gaussians_check_finite(g, &err) == MGS_ERR_NUMERIC);
  CHECK(strstr(err.msg, "sh_dc") != NULL);
  mgs_gaussians_destroy(g);
}

static void test_robust_bounds(void) {
  /* a unit cube's surface sample: the robust box is the true box (compact cloud) */
  const size_t n = 5000;
  float *p = malloc((n + 5) * 3 * sizeof(float));
  mgs_rng r;
  mgs_rng_init(&r, 3, 0);
  for (size_t i = 0; i < n; i++) {
    for (int k = 0; k < 3; k++) p[3 * i + k] = (float)mgs_rng_uniform(&r);
    int face = (int)(i % 6);
    p[3 * i + face / 2] = (float)(face % 2);
  }
  double lo[3], hi[3], tlo[3], thi[3];
  CHECK(mgs_points_bounds_robust(p, n, lo, hi));
  for (int k = 0; k < 3; k++) { CHECK(lo[k] == 0.0); CHECK(hi[k] == 1.0); }
  /* five points 10-50 units away do not stretch it; the true box does */
  for (size_t k = 0; k < 5; k++)
    for (int a = 0; a < 3; a++) p[3 * (n + k) + a] = (float)((a == (int)(k % 3)) ? (k % 2 ? 10.0 + 10 * k : -10.0 - 10 * k) : 0.5);
  CHECK(mgs_points_bounds_robust(p, n + 5, lo, hi));
  mgs_gaussians g = {0};
  g.n = n + 5;
  g.mean = p;
  CHECK(mgs_gaussians_bounds(&g, tlo, thi));
  for (int k = 0; k < 3; k++) { /* the quantiles widened by 10 % of the extent */
    CHECK(lo[k] >= -0.11 && lo[k] <= 0.0);
    CHECK(hi[k] >= 1.0 && hi[k] <= 1.11);
  }
  CHECK(thi[0] > 40 || tlo[0] < -40 || thi[1] > 40 || tlo[1] < -40);
  CHECK(mgs_point_in_box(p, lo, hi) && !mgs_point_in_box(p + 3 * n, lo, hi));
  /* few points: the true box; none: 0 */
  CHECK(mgs_points_bounds_robust(p + 3 * (n - 10), 15, lo, hi));
  CHECK(hi[0] >= 10 || lo[0] <= -10 || hi[1] >= 10 || lo[1] <= -10 || hi[2] >= 10 || lo[2] <= -10);
  CHECK(!mgs_points_bounds_robust(p, 0, lo, hi));
  free(p);
}

int main(void) {
  RUN(test_robust_bounds);
  RUN(test_append_compact_select);
  RUN(test_covariance_and_finite);
  return mgs_test_finish();
}

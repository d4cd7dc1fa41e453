/* LPVI (train/mgs_lpvi.h): corrected mode keeps a plane's new points in the plane and a
 * sphere's near the sphere (a proven bound: a candidate lies in the ball of its
 * neighbourhood, centre the mean m, radius R; for points on the unit sphere within a cap
 * of chord 2R, 1 − 2R^2 − R <= |c| <= 1 + R); the result does not depend on the thread
 * count; degenerate input (collinear, duplicates, fewer points than K) gives a defined
 * result; the faithful mode returns only new points. */
#include "mgs_test.h"
#include "core/mgs_parallel.h"
#include "core/mgs_rng.h"
#include "train/mgs_lpvi.h"

static mgs_status run(const float *xyz, size_t n, int faithful, float **ox, float **oc, size_t *on, mgs_lpvi_stats *s,
                      mgs_error *err) {
  mgs_lpvi_options o;
  mgs_lpvi_options_default(&o);
  o.faithful = faithful;
  o.extent = 1.0; /* unit-size test clouds: thresholds scaled like a scene of extent 1 */
  return mgs_init_lpvi(xyz, NULL, n, &o, ox, oc, on, s, err);
}

static void test_plane(void) {
  enum { N = 400 };
  float xyz[3 * N];
  mgs_rng g;
  mgs_rng_init(&g, 1, 2);
  /* a tilted plane through x0 with orthonormal in-plane axes u, v and normal nn */
  double u[3] = {0.6, 0.8, 0}, v[3] = {-0.48, 0.36, 0.8}, nn[3] = {0.64, -0.48, 0.6}, x0[3] = {0.3, -0.2, 0.5};
  for (int i = 0; i < N; i++) {
    double a = mgs_rng_uniform(&g) * 2 - 1, b = mgs_rng_uniform(&g) * 2 - 1;
    for (int k = 0; k < 3; k++) xyz[3 * i + k] = (float)(x0[k] + a * u[k] + b * v[k]);
  }
  float *ox, *oc; size_t on; mgs_lpvi_stats s; mgs_error err = {0};
  CHECK_OK(run(xyz, N, 0, &ox, &oc, &on, &s, &err), &err);
  CHECK(on > N && s.added == on - N);
  CHECK(!memcmp(ox, xyz, sizeof xyz)); /* originals first */
  double worst = 0, worst_in = 0;
  for (size_t i = 0; i < on; i++) {
    double d = 0;
    for (int k = 0; k < 3; k++) d += (ox[3 * i + k] - x0[k]) * nn[k];
    if (i >= N) worst = fmax(worst, fabs(d)); else worst_in = fmax(worst_in, fabs(d));
  }
  fprintf(stderr, "  plane: %zu added (%zu in 3-D, %zu tangent), max distance %.2e (input's own float rounding %.2e)\n",
          s.added, s.accepted_3d, s.tangent_2d, worst, worst_in);
  CHECK(worst <= 4 * worst_in + 1e-6);
  free(ox); free(oc);
  /* faithful: the lift from the point instead of the mean shifts points within the plane
     here (point and mean both lie in it); it returns the new points only */
  CHECK_OK(run(xyz, N, 1, &ox, &oc, &on, &s, &err), &err);
  CHECK(on == s.added);
  free(ox); free(oc);
}

static double knn_radius_max(const float *xyz, size_t n, size_t k) {
  mgs_kdtree *t = mgs_kdtree_build(xyz, n);
  size_t idx[64]; double d2[64], rmax = 0;
  for (size_t i = 0; i < n; i++) {
    double q[3] = {xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]};
    size_t m = mgs_kdtree_knn(t, q, k, idx, d2);
    double mean[3] = {0, 0, 0}, r = 0;
    for (size_t j = 0; j < m; j++) for (int a = 0; a < 3; a++) mean[a] += xyz[3 * idx[j] + a] / (double)m;
    for (size_t j = 0; j < m; j++) {
      double d = 0;
      for (int a = 0; a < 3; a++) d += (xyz[3 * idx[j] + a] - mean[a]) * (xyz[3 * idx[j] + a] - mean[a]);
      r = fmax(r, sqrt(d));
    }
    rmax = fmax(rmax, r);
  }
  mgs_kdtree_destroy(t);
  return rmax;
}

static void sphere(float *xyz, size_t n, uint64_t seed) {
  mgs_rng g;
  mgs_rng_init(&g, seed, 3);
  for (size_t i = 0; i < n; i++) {
    double p[3], r = 0;
    for (int k = 0; k < 3; k++) { p[k] = mgs_rng_normal(&g); r += p[k] * p[k]; }
    for (int k = 0; k < 3; k++) xyz[3 * i + k] = (float)(p[k] / sqrt(r));
  }
}

static void test_sphere(void) {
  enum { N = 600 };
  static float xyz[3 * N];
  sphere(xyz, N, 4);
  double R = knn_radius_max(xyz, N, 16);
  float *ox, *oc; size_t on; mgs_lpvi_stats s; mgs_error err = {0};
  CHECK_OK(run(xyz, N, 0, &ox, &oc, &on, &s, &err), &err);
  double worst = 0, mean_dev = 0;
  for (size_t i = N; i < on; i++) {
    double r = sqrt((double)ox[3*i]*ox[3*i] + (double)ox[3*i+1]*ox[3*i+1] + (double)ox[3*i+2]*ox[3*i+2]);
    worst = fmax(worst, fabs(r - 1));
    mean_dev += fabs(r - 1) / (double)(on - N);
    for (int k = 0; k < 3; k++) CHECK(oc[3 * i + k] >= 0.0f && oc[3 * i + k] <= 1.0f);
  }
  double bound = R + 2 * R * R;
  fprintf(stderr, "  sphere corrected: %zu added (%zu 3-D, %zu tangent, %zu discarded), |r-1| max %.4f mean %.4f, bound %.4f (R = %.4f)\n",
          s.added, s.accepted_3d, s.tangent_2d, s.discarded, worst, mean_dev, bound, R);
  CHECK(s.added > 0);
  CHECK(worst <= bound);
  free(ox); free(oc);
  /* the authors' behaviour: unfiltered Voronoi vertices and the shifted lift */
  CHECK_OK(run(xyz, N, 1, &ox, &oc, &on, &s, &err), &err);
  double fw = 0;
  for (size_t i = 0; i < on; i++) {
    double r = sqrt((double)ox[3*i]*ox[3*i] + (double)ox[3*i+1]*ox[3*i+1] + (double)ox[3*i+2]*ox[3*i+2]);
    fw = fmax(fw, fabs(r - 1));
  }
  fprintf(stderr, "  sphere faithful: %zu new points only (%zu 3-D, %zu tangent), |r-1| max %.4f\n", on, s.accepted_3d, s.tangent_2d, fw);
  CHECK(on == s.added && on > 0);
  free(ox); free(oc);
}

static void test_threads_equal(void) {
  enum { N = 500 };
  static float xyz[3 * N];
  sphere(xyz, N, 9);
  float *a, *ac, *b, *bc; size_t na, nb; mgs_lpvi_stats sa, sb; mgs_error err = {0};
  mgs_parallel_set_threads(1);
  CHECK_OK(run(xyz, N, 0, &a, &ac, &na, &sa, &err), &err);
  mgs_parallel_set_threads(2);
  CHECK_OK(run(xyz, N, 0, &b, &bc, &nb, &sb, &err), &err);
  mgs_parallel_set_threads(0);
  CHECK(na == nb && sa.processed == sb.processed);
  CHECK(na == nb && !memcmp(a, b, 3 * na * sizeof *a) && !memcmp(ac, bc, 3 * na * sizeof *ac));
  fprintf(stderr, "  1 vs 2 threads: %zu points each, identical; %zu processed, %zu speculative evaluations discarded with 2\n", na, sa.processed, sb.discarded);
  free(a); free(ac); free(b); free(bc);
}

static void finite_and_bounded(const float *ox, size_t on, double lo, double hi) {
  for (size_t i = 0; i < 3 * on; i++) CHECK(isfinite(ox[i]) && ox[i] >= lo && ox[i] <= hi);
}

static void test_degenerate(void) {
  float xyz[3 * 64];
  float *ox, *oc; size_t on; mgs_lpvi_stats s; mgs_error err = {0};
  /* collinear: candidates kept within the neighbourhood's ball (so inside the segment's
     bounding box grown by nothing more than the ball) */
  for (int i = 0; i < 40; i++) { xyz[3*i] = (float)i / 39; xyz[3*i+1] = 2 * (float)i / 39; xyz[3*i+2] = 0.5f; }
  CHECK_OK(run(xyz, 40, 0, &ox, &oc, &on, &s, &err), &err);
  CHECK(on >= 40);
  finite_and_bounded(ox, on, -0.5, 2.5);
  free(ox); free(oc);
  /* all points equal: nothing to add, the originals come back */
  for (int i = 0; i < 30; i++) { xyz[3*i] = 0.1f; xyz[3*i+1] = 0.2f; xyz[3*i+2] = 0.3f; }
  CHECK_OK(run(xyz, 30, 0, &ox, &oc, &on, &s, &err), &err);
  CHECK(on == 30 && s.added == 0);
  free(ox); free(oc);
  /* the faithful mode then has nothing to return: a clear error */
  CHECK(run(xyz, 30, 1, &ox, &oc, &on, &s, &err) == MGS_ERR_NUMERIC && strstr(err.msg, "LPVI"));
  /* duplicates among distinct points */
  sphere(xyz, 64, 2);
  for (int i = 32; i < 64; i++) memcpy(xyz + 3 * i, xyz + 3 * (i - 32), 3 * sizeof *xyz);
  CHECK_OK(run(xyz, 64, 0, &ox, &oc, &on, &s, &err), &err);
  finite_and_bounded(ox, on, -1.5, 1.5);
  free(ox); free(oc);
  /* fewer points than K_max (and than K_min, and than a 3-D simplex needs) */
  for (size_t n = 1; n <= 10; n += 3) {
    sphere(xyz, n, 5 + n);
    CHECK_OK(run(xyz, n, 0, &ox, &oc, &on, &s, &err), &err);
    CHECK(on >= n);
    finite_and_bounded(ox, on, -1.5, 1.5);
    free(ox); free(oc);
  }
  /* no points, a non-finite point */
  CHECK(run(xyz, 0, 0, &ox, &oc, &on, &s, &err) != MGS_OK);
  xyz[4] = NAN;
  CHECK(run(xyz, 5, 0, &ox, &oc, &on, &s, &err) == MGS_ERR_NUMERIC);
}

static void test_knn(void) {
  enum { N = 300 };
  static float xyz[3 * N];
  sphere(xyz, N, 21);
  mgs_kdtree *t = mgs_kdtree_build(xyz, N);
  for (int i = 0; i < N; i += 7) {
    double q[3] = {xyz[3*i], xyz[3*i+1], xyz[3*i+2]};
    size_t idx[16]; double d2[16];
    CHECK(mgs_kdtree_knn(t, q, 16, idx, d2) == 16);
    CHECK(idx[0] == (size_t)i);
    /* brute force: the 16th distance and every closer point */
    int closer = 0;
    for (int j = 0; j < N; j++) {
      double d = 0;
      for (int a = 0; a < 3; a++) d += (xyz[3*j+a] - q[a]) * (xyz[3*j+a] - q[a]);
      closer += d < d2[15];
    }
    CHECK(closer <= 15);
  }
  mgs_kdtree_destroy(t);
}

int main(void) {
  RUN(test_knn);
  RUN(test_plane);
  RUN(test_sphere);
  RUN(test_threads_equal);
  RUN(test_degenerate);
  return mgs_test_finish();
}

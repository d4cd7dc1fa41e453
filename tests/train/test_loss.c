/* L1, SSIM and PSNR: values against direct references, gradients against central
 * differences in double. */
#include <math.h>
#include <stdlib.h>
#include "mgs_test.h"
#include "render/mgs_loss.h"
#include "core/mgs_rng.h"

/* Direct (non-separable) SSIM in double: 11x11 window, zero padding, as torch conv2d. */
static double ssim_ref(const double *x, const double *y, int W, int H, int C) {
  double g1[11], s = 0, win[11][11];
  for (int i = 0; i < 11; i++) { double d = i - 5; g1[i] = exp(-d * d / (2 * 1.5 * 1.5)); s += g1[i]; }
  for (int i = 0; i < 11; i++) for (int j = 0; j < 11; j++) win[i][j] = g1[i] / s * g1[j] / s;
  const double C1 = 1e-4, C2 = 9e-4;
  double total = 0;
  for (int c = 0; c < C; c++)
    for (int py = 0; py < H; py++)
      for (int px = 0; px < W; px++) {
        double m1 = 0, m2 = 0, e11 = 0, e22 = 0, e12 = 0;
        for (int dy = -5; dy <= 5; dy++)
          for (int dx = -5; dx <= 5; dx++) {
            int qx = px + dx, qy = py + dy;
            if (qx < 0 || qy < 0 || qx >= W || qy >= H) continue;
            double w = win[dy + 5][dx + 5];
            double a = x[(qy * W + qx) * C + c], b = y[(qy * W + qx) * C + c];
            m1 += w * a; m2 += w * b; e11 += w * a * a; e22 += w * b * b; e12 += w * a * b;
          }
        double s11 = e11 - m1 * m1, s22 = e22 - m2 * m2, s12 = e12 - m1 * m2;
        total += ((2 * m1 * m2 + C1) * (2 * s12 + C2)) / ((m1 * m1 + m2 * m2 + C1) * (s11 + s22 + C2));
      }
  return total / ((double)W * H * C);
}

static void random_pair(mgs_rng *r, float *a, float *b, double *da, double *db, size_t n, double corr) {
  for (size_t i = 0; i < n; i++) {
    double u = mgs_rng_uniform(r), v = mgs_rng_uniform(r);
    a[i] = (float)u;
    b[i] = (float)(corr * u + (1 - corr) * v);
    da[i] = a[i]; db[i] = b[i];
  }
}

static void test_ssim_identical(void) {
  int W = 23, H = 17, C = 3;
  size_t n = (size_t)W * H * C;
  float *a = malloc(n * sizeof(float)), *g = calloc(n, sizeof(float));
  mgs_rng r; mgs_rng_init(&r, 1, 0);
  for (size_t i = 0; i < n; i++) a[i] = (float)mgs_rng_uniform(&r);
  CHECK_NEAR(mgs_ssim(a, a, W, H, C, 1.0f, g), 1.0, 1e-5);
  /* at the maximum the gradient vanishes */
  double gmax = 0;
  for (size_t i = 0; i < n; i++) gmax = fmax(gmax, fabs(g[i]));
  CHECK(gmax < 1e-5);
  /* constant images (zero variance, C1/C2 keep it finite) */
  for (size_t i = 0; i < n; i++) a[i] = 0.0f;
  CHECK_NEAR(mgs_ssim(a, a, W, H, C, 1.0f, NULL), 1.0, 1e-6);
  free(a); free(g);
}

static void test_ssim_matches_direct(void) {
  int sizes[][3] = {{23, 17, 3}, {7, 5, 1}, {40, 33, 3}, {1, 1, 3}};
  for (int k = 0; k < 4; k++) {
    int W = sizes[k][0], H = sizes[k][1], C = sizes[k][2];
    size_t n = (size_t)W * H * C;
    float *a = malloc(n * sizeof(float)), *b = malloc(n * sizeof(float));
    double *da = malloc(n * sizeof(double)), *db = malloc(n * sizeof(double));
    mgs_rng r; mgs_rng_init(&r, 7 + k, 0);
    random_pair(&r, a, b, da, db, n, 0.6);
    double s = mgs_ssim(a, b, W, H, C, 0.0f, NULL), ref = ssim_ref(da, db, W, H, C);
    CHECK_NEAR(s, ref, 2e-5);
    CHECK(s < 0.999); /* different images */
    free(a); free(b); free(da); free(db);
  }
}

static void test_ssim_gradient_fd(void) {
  int W = 13, H = 9, C = 3;
  size_t n = (size_t)W * H * C;
  float *a = malloc(n * sizeof(float)), *b = malloc(n * sizeof(float)), *g = malloc(n * sizeof(float));
  double *da = malloc(n * sizeof(double)), *db = malloc(n * sizeof(double));
  mgs_rng r; mgs_rng_init(&r, 3, 0);
  random_pair(&r, a, b, da, db, n, 0.5);
  for (size_t i = 0; i < n; i++) g[i] = 0.25f; /* gradients are ADDED */
  const float w = -0.2f;
  mgs_ssim(a, b, W, H, C, w, g);
  double num = 0, den = 0, worst = 0;
  for (size_t i = 0; i < n; i++) {
    double h = 1e-5, keep = da[i];
    da[i] = keep + h; double fp = ssim_ref(da, db, W, H, C);
    da[i] = keep - h; double fm = ssim_ref(da, db, W, H, C);
    da[i] = keep;
    double fd = w * (fp - fm) / (2 * h), an = g[i] - 0.25;
    num += (fd - an) * (fd - an); den += fd * fd;
    worst = fmax(worst, fabs(fd - an));
  }
  CHECK_MSG(sqrt(num / den) < 2e-3, "relative gradient error %g", sqrt(num / den));
  CHECK_MSG(worst < 1e-5, "worst abs gradient error %g", worst);
  CHECK(den > 0);
  free(a); free(b); free(g); free(da); free(db);
}

static void test_ssim_extremes_finite(void) {
  int W = 16, H = 16, C = 3;
  size_t n = (size_t)W * H * C;
  float *a = malloc(n * sizeof(float)), *b = malloc(n * sizeof(float)), *g = calloc(n, sizeof(float));
  for (size_t i = 0; i < n; i++) { a[i] = 0.0f; b[i] = 1.0f; }
  double s = mgs_ssim(a, b, W, H, C, 1.0f, g);
  CHECK(isfinite(s) && s < 0.01);
  int finite = 1;
  for (size_t i = 0; i < n; i++) finite &= isfinite(g[i]);
  CHECK(finite);
  free(a); free(b); free(g);
}

static double l1_ref(const double *x, const double *y, size_t n) {
  double s = 0;
  for (size_t i = 0; i < n; i++) s += fabs(x[i] - y[i]);
  return s / (double)n;
}

static void test_l1_gradient_fd(void) {
  int W = 11, H = 6, C = 3;
  size_t n = (size_t)W * H * C;
  float *a = malloc(n * sizeof(float)), *b = malloc(n * sizeof(float)), *g = malloc(n * sizeof(float));
  double *da = malloc(n * sizeof(double)), *db = malloc(n * sizeof(double));
  mgs_rng r; mgs_rng_init(&r, 5, 0);
  for (size_t i = 0; i < n; i++) {
    a[i] = (float)mgs_rng_uniform(&r);
    double off = 0.02 + 0.3 * mgs_rng_uniform(&r); /* keep away from the kink */
    b[i] = (float)(a[i] + (i % 2 ? off : -off));
    da[i] = a[i]; db[i] = b[i];
    g[i] = 1.0f;
  }
  double v = mgs_loss_l1(a, b, W, H, C, 0.8f, g);
  CHECK_NEAR(v, l1_ref(da, db, n), 1e-6);
  double worst = 0;
  for (size_t i = 0; i < n; i++) {
    double h = 1e-4, keep = da[i];
    da[i] = keep + h; double fp = l1_ref(da, db, n);
    da[i] = keep - h; double fm = l1_ref(da, db, n);
    da[i] = keep;
    worst = fmax(worst, fabs(0.8 * (fp - fm) / (2 * h) - (g[i] - 1.0)));
  }
  CHECK_MSG(worst < 1e-6, "worst L1 gradient error %g", worst);
  /* equal pixels: zero gradient (as torch's abs) */
  float z = 0.5f, gz = 0.0f;
  CHECK_NEAR(mgs_loss_l1(&z, &z, 1, 1, 1, 1.0f, &gz), 0.0, 0);
  CHECK(gz == 0.0f);
  free(a); free(b); free(g); free(da); free(db);
}

static void test_psnr(void) {
  float a[12], b[12];
  for (int i = 0; i < 12; i++) { a[i] = 0.5f; b[i] = 0.6f; }
  CHECK_NEAR(mgs_psnr(a, b, 2, 2, 3), 20.0, 1e-4);
  b[0] = 0.5f; /* mse = 11/12 * 0.01 */
  CHECK_NEAR(mgs_psnr(a, b, 2, 2, 3), -10 * log10(0.01 * 11 / 12), 1e-4);
  CHECK_NEAR(mgs_psnr(a, a, 2, 2, 3), 100.0, 0);
}

int main(void) {
  RUN(test_ssim_identical);
  RUN(test_ssim_matches_direct);
  RUN(test_ssim_gradient_fd);
  RUN(test_ssim_extremes_finite);
  RUN(test_l1_gradient_fd);
  RUN(test_psnr);
  return mgs_test_finish();
}

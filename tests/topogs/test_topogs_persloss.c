/* PersLoss (train/mgs_persloss.h): zero for identical images; its gradient (through the
 * critical edges and the area downsampling) equals central finite differences for both
 * forms (h = 2^-20 on pixel values of a 2^-12 grid: exact in float, the pairing fixed);
 * constant, grey and tiny images give defined values; the schedule is the authors' (68
 * calls). */
#include "mgs_test.h"
#include "core/mgs_rng.h"
#include "train/mgs_persloss.h"

enum { W = 22, H = 18 };

static void random_image(float *img, uint64_t seed) {
  mgs_rng g;
  mgs_rng_init(&g, seed, 5);
  /* smooth-ish colours plus noise, quantised to 2^-12 */
  for (int y = 0; y < H; y++)
    for (int x = 0; x < W; x++)
      for (int c = 0; c < 3; c++) {
        double v = 0.5 + 0.3 * sin(0.3 * x + 1.7 * c) * cos(0.25 * y - c) + 0.15 * (mgs_rng_uniform(&g) - 0.5);
        img[(y * W + x) * 3 + c] = (float)(floor(v * 4096.0) / 4096.0);
      }
}

static void test_identical(void) {
  static float a[W * H * 3], g[W * H * 3];
  random_image(a, 1);
  mgs_persloss_options o;
  mgs_persloss_options_default(&o);
  o.downsample = 0.5;
  for (int form = 0; form < 2; form++) {
    o.form = (mgs_persloss_form)form;
    double L = -1;
    memset(g, 0, sizeof g);
    mgs_error err = {0};
    CHECK_OK(mgs_persloss_eval(&o, a, a, W, H, 1.0, &L, g, &err), &err);
    CHECK(L == 0.0);
    double gs = 0;
    for (size_t i = 0; i < sizeof g / sizeof *g; i++) gs += fabs(g[i]);
    CHECK(gs == 0.0);
  }
}

static void fd_check(mgs_persloss_form form, double factor) {
  static float a[W * H * 3], gt[W * H * 3], grad[W * H * 3];
  random_image(a, 2);
  random_image(gt, 3);
  mgs_persloss_options o;
  mgs_persloss_options_default(&o);
  o.form = form;
  o.downsample = factor;
  double L;
  mgs_error err = {0};
  memset(grad, 0, sizeof grad);
  CHECK_OK(mgs_persloss_eval(&o, a, gt, W, H, 1.0, &L, grad, &err), &err);
  CHECK(L > 0);
  /* 2^-20: pixel values are multiples of 2^-12 above 2^-4, so x ± h is exact in float;
     small enough that no critical edge or sorted position changes (the pairing is fixed;
     at h = 2^-12 about one entry in ten crosses a tie and the difference quotient mixes
     two pairings) */
  const double h = 1.0 / 1048576.0;
  int checked = 0, nonzero = 0, bad = 0;
  double maxg = 0;
  for (size_t i = 0; i < W * H * 3; i++) maxg = fmax(maxg, fabs(grad[i]));
  for (size_t i = 0; i < W * H * 3; i += 11) {
    float keep = a[i];
    double lp, lm;
    a[i] = keep + (float)h;
    CHECK_OK(mgs_persloss_eval(&o, a, gt, W, H, 1.0, &lp, NULL, &err), &err);
    a[i] = keep - (float)h;
    CHECK_OK(mgs_persloss_eval(&o, a, gt, W, H, 1.0, &lm, NULL, &err), &err);
    a[i] = keep;
    double fd = (lp - lm) / (2 * h);
    checked++;
    nonzero += grad[i] != 0;
    if (fabs(fd - grad[i]) > 1e-4 * maxg + 1e-3 * fabs(fd)) {
      if (bad++ < 5) fprintf(stderr, "  %s f=%.2f pixel-channel %zu: analytic %.8g fd %.8g\n", form ? "betti" : "topk", factor, i, grad[i], fd);
    }
  }
  fprintf(stderr, "  %s f=%.2f: loss %.6g, %d entries checked, %d with a gradient, %d mismatches (max |g| %.3g)\n",
          form ? "betti" : "topk", factor, L, checked, nonzero, bad, maxg);
  CHECK(bad == 0);
  CHECK(nonzero > 10);
}

static void test_fd(void) {
  fd_check(MGS_PERSLOSS_TOPK, 0.5);
  fd_check(MGS_PERSLOSS_BETTI, 0.5);
  fd_check(MGS_PERSLOSS_TOPK, 1.0);
}

static void test_degenerate(void) {
  static float c[W * H * 3], gt[W * H * 3], grad[W * H * 3];
  random_image(gt, 4);
  mgs_persloss_options o;
  mgs_persloss_options_default(&o);
  o.downsample = 0.5;
  mgs_error err = {0};
  double L = -1;
  /* constant colour: one point, no finite bar; the loss is the ground truth's features'
     mean square, the gradient zero (nothing to move) */
  for (size_t i = 0; i < W * H * 3; i++) c[i] = 0.25f;
  memset(grad, 0, sizeof grad);
  CHECK_OK(mgs_persloss_eval(&o, c, gt, W, H, 1.0, &L, grad, &err), &err);
  CHECK(isfinite(L) && L > 0);
  double gs = 0;
  for (size_t i = 0; i < W * H * 3; i++) gs += fabs(grad[i]);
  CHECK(gs == 0);
  CHECK_OK(mgs_persloss_eval(&o, c, c, W, H, 1.0, &L, grad, &err), &err);
  CHECK(L == 0);
  /* grey image: collinear points in RGB */
  for (int i = 0; i < W * H; i++) c[3 * i] = c[3 * i + 1] = c[3 * i + 2] = gt[3 * i];
  memset(grad, 0, sizeof grad);
  CHECK_OK(mgs_persloss_eval(&o, c, gt, W, H, 1.0, &L, grad, &err), &err);
  CHECK(isfinite(L));
  for (size_t i = 0; i < W * H * 3; i++) CHECK(isfinite(grad[i]));
  /* two colours only; a 1x1 image; a factor making the image one pixel */
  for (int i = 0; i < W * H * 3; i++) c[i] = (i / 3) % 2 ? 1.0f : 0.0f;
  CHECK_OK(mgs_persloss_eval(&o, c, gt, W, H, 1.0, &L, grad, &err), &err);
  CHECK(isfinite(L));
  CHECK_OK(mgs_persloss_eval(&o, c, gt, 1, 1, 1.0, &L, NULL, &err), &err);
  CHECK(L == 0);
  o.downsample = 0.01;
  CHECK_OK(mgs_persloss_eval(&o, c, gt, W, H, 1.0, &L, NULL, &err), &err);
  CHECK(L == 0);
  /* bad options and non-finite pixels: errors naming the problem */
  o.downsample = 0;
  CHECK(mgs_persloss_eval(&o, c, gt, W, H, 1.0, &L, NULL, &err) == MGS_ERR_ARG && strstr(err.msg, "downsample"));
  o.downsample = 0.5;
  c[7] = NAN;
  CHECK(mgs_persloss_eval(&o, c, gt, W, H, 1.0, &L, NULL, &err) == MGS_ERR_NUMERIC);
}

static void test_schedule(void) {
  mgs_persloss_options o;
  mgs_persloss_options_default(&o);
  mgs_term *t = NULL;
  mgs_error err = {0};
  CHECK_OK(mgs_term_persloss_create(&o, &t, &err), &err);
  int calls = 0, first = 0, last = 0;
  for (int it = 1; it <= 30000; it++)
    if (t->ops->active(t->self, it)) { calls++; if (!first) first = it; last = it; }
  CHECK(calls == 68 && first == 1600 && last == 15000);
  mgs_term_destroy(t);
}

int main(void) {
  RUN(test_identical);
  RUN(test_fd);
  RUN(test_degenerate);
  RUN(test_schedule);
  return mgs_test_finish();
}

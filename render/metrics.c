/* PSNR over all pixels and channels of one image, as the reference's psnr(). */
#include <math.h>
#include "render/mgs_loss.h"

double mgs_psnr(const float *img, const float *gt, int width, int height, int channels) {
  size_t n = (size_t)width * (size_t)height * (size_t)channels;
  if (n == 0) return 0.0;
  double se = 0.0;
  for (size_t i = 0; i < n; i++) {
    double d = (double)img[i] - (double)gt[i];
    se += d * d;
  }
  double mse = se / (double)n;
  /* identical images: report a finite ceiling (JSON has no inf) */
  if (mse < 1e-10) return 100.0;
  return -10.0 * log10(mse);
}

void mgs_psnr_bytes(int width, int height, int channels, double rw[2]) {
  rw[0] = 2.0 * width * height * channels * sizeof(float);
  rw[1] = 0;
}

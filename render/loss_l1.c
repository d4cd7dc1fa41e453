/* L1 photometric loss (mean absolute error) and its gradient. */
#include <math.h>
#include "render/mgs_loss.h"

double mgs_loss_l1(const float *img, const float *gt, int width, int height, int channels,
                   float w, float *grad) {
  size_t n = (size_t)width * (size_t)height * (size_t)channels;
  if (n == 0) return 0.0;
  double sum = 0.0;
  float g = w / (float)n;
  for (size_t i = 0; i < n; i++) {
    float d = img[i] - gt[i];
    sum += fabsf(d);
    /* d|x|/dx = sign(x), 0 at 0 as torch's abs */
    if (grad) grad[i] += d > 0 ? g : (d < 0 ? -g : 0.0f);
  }
  return sum / (double)n;
}

void mgs_loss_l1_bytes(int width, int height, int channels, double rw[2]) {
  double n = (double)width * height * channels;
  rw[0] = 3 * n * sizeof(float); /* img, gt, grad (added into) */
  rw[1] = n * sizeof(float);
}

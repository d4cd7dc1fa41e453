/* Photometric losses with gradients and image metrics, on interleaved float images
 * (height*width*channels, channels <= 4 for SSIM). Owned by the training work:
 * render/loss_l1.c, render/loss_ssim.c, render/metrics.c. SSIM uses the reference's
 * 11x11 Gaussian window (sigma 1.5) with zero padding ('same' convolution, as torch
 * conv2d with padding 5), C1 = 0.01^2, C2 = 0.03^2. */
#ifndef MGS_LOSS_H
#define MGS_LOSS_H
#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Mean absolute error; if grad != NULL, ADDS w * dL1/dimg into grad. */
double mgs_loss_l1(const float *img, const float *gt, int width, int height, int channels,
                   float w, float *grad);
/* Mean SSIM over pixels and channels; if grad != NULL, ADDS w * dSSIM/dimg into grad
 * (pass w = -lambda to get the gradient of lambda*(1 - SSIM)). */
double mgs_ssim(const float *img, const float *gt, int width, int height, int channels,
                float w, float *grad);
/* -10 log10(MSE) over all pixels and channels (the reference's psnr); identical images
 * give 100 dB (a finite ceiling, since JSON has no infinity). */
double mgs_psnr(const float *img, const float *gt, int width, int height, int channels);

/* Bytes each function above reads ([0]) and writes ([1]) on a width x height x channels
 * image with a gradient, counted from its loops (every sweep of an image or scratch plane;
 * rows kept in L1 not counted): for the benchmark's memory accounting. */
void mgs_loss_l1_bytes(int width, int height, int channels, double rw[2]);
void mgs_ssim_bytes(int width, int height, int channels, double rw[2]);
void mgs_psnr_bytes(int width, int height, int channels, double rw[2]);

#ifdef __cplusplus
}
#endif
#endif

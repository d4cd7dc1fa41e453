/* Float images: creation and the pixel operations datasets need (alpha compositing,
 * integer box downscale). File I/O lives in image_oiio.cpp. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/mgs_image.h"

mgs_image *mgs_image_create(int width, int height, int channels) {
  if (width <= 0 || height <= 0 || channels <= 0 || channels > 64) return NULL;
  size_t n = (size_t)width * (size_t)height * (size_t)channels;
  mgs_image *img = calloc(1, sizeof *img);
  if (!img) return NULL;
  img->data = calloc(n, sizeof(float));
  if (!img->data) { free(img); return NULL; }
  img->width = width;
  img->height = height;
  img->channels = channels;
  return img;
}

void mgs_image_destroy(mgs_image *img) {
  if (!img) return;
  free(img->data);
  free(img);
}

mgs_image *mgs_image_clone(const mgs_image *img) {
  if (!img) return NULL;
  mgs_image *c = mgs_image_create(img->width, img->height, img->channels);
  if (c) memcpy(c->data, img->data, sizeof(float) * (size_t)img->width * (size_t)img->height * (size_t)img->channels);
  return c;
}

mgs_image *mgs_image_composite(const mgs_image *rgba, const float bg[3]) {
  if (!rgba || rgba->channels < 3) return NULL;
  mgs_image *out = mgs_image_create(rgba->width, rgba->height, 3);
  if (!out) return NULL;
  const size_t n = (size_t)rgba->width * (size_t)rgba->height;
  const int ch = rgba->channels;
  for (size_t i = 0; i < n; i++) {
    const float *p = rgba->data + i * (size_t)ch;
    /* Grey+alpha (2 ch) is not handled here; 3 channels: opaque copy. */
    float a = ch >= 4 ? p[3] : 1.0f;
    for (int c = 0; c < 3; c++) out->data[i * 3 + (size_t)c] = p[c] * a + bg[c] * (1.0f - a);
  }
  return out;
}

mgs_image *mgs_image_downscale(const mgs_image *img, int factor) {
  if (!img || factor < 1) return NULL;
  if (factor == 1) return mgs_image_clone(img);
  /* Partial blocks at the right/bottom edge are dropped, as PIL's resize to w//f does
     for integer factors. */
  int w = img->width / factor, h = img->height / factor, ch = img->channels;
  if (w < 1 || h < 1) return NULL;
  mgs_image *out = mgs_image_create(w, h, ch);
  if (!out) return NULL;
  const float inv = 1.0f / (float)(factor * factor);
  for (int y = 0; y < h; y++)
    for (int x = 0; x < w; x++)
      for (int c = 0; c < ch; c++) {
        float s = 0;
        for (int dy = 0; dy < factor; dy++) {
          const float *row = img->data + ((size_t)(y * factor + dy) * (size_t)img->width + (size_t)x * (size_t)factor) * (size_t)ch;
          for (int dx = 0; dx < factor; dx++) s += row[(size_t)dx * (size_t)ch + (size_t)c];
        }
        out->data[((size_t)y * (size_t)w + (size_t)x) * (size_t)ch + (size_t)c] = s * inv;
      }
  return out;
}

/* PIL's bicubic kernel (Keys, a = -0.5), support 2. */
static double cubic_w(double x) {
  const double a = -0.5;
  x = fabs(x);
  if (x < 1.0) return ((a + 2.0) * x - (a + 3.0)) * x * x + 1.0;
  if (x < 2.0) return (((x - 5.0) * x + 8.0) * x - 4.0) * a;
  return 0.0;
}

/* One axis's taps as PIL's precompute_coeffs: output pixel i reads inputs
 * first[i] .. first[i] + count[i] - 1 with normalized weights w[i * taps ...]. */
typedef struct { int taps; int *first, *count; double *w; } resample_axis;

static int axis_init(resample_axis *ax, int in, int out) {
  double scale = (double)in / out, fscale = scale > 1.0 ? scale : 1.0;
  double support = 2.0 * fscale;
  ax->taps = (int)ceil(support) * 2 + 1;
  ax->first = malloc(sizeof(int) * (size_t)out);
  ax->count = malloc(sizeof(int) * (size_t)out);
  ax->w = malloc(sizeof(double) * (size_t)out * (size_t)ax->taps);
  if (!ax->first || !ax->count || !ax->w) return 0;
  for (int i = 0; i < out; i++) {
    double center = (i + 0.5) * scale, ss = 1.0 / fscale;
    int lo = (int)(center - support + 0.5), hi = (int)(center + support + 0.5);
    if (lo < 0) lo = 0;
    if (hi > in) hi = in;
    int n = hi - lo;
    if (n > ax->taps) n = ax->taps;
    double sum = 0, *w = ax->w + (size_t)i * (size_t)ax->taps;
    for (int k = 0; k < n; k++) sum += (w[k] = cubic_w((k + lo - center + 0.5) * ss));
    for (int k = 0; k < n; k++) w[k] = sum != 0 ? w[k] / sum : 0;
    ax->first[i] = lo;
    ax->count[i] = n;
  }
  return 1;
}

static void axis_free(resample_axis *ax) { free(ax->first); free(ax->count); free(ax->w); }

mgs_image *mgs_image_resize_bicubic(const mgs_image *img, int w, int h) {
  if (!img || w < 1 || h < 1) return NULL;
  if (w == img->width && h == img->height) return mgs_image_clone(img);
  const int ch = img->channels, iw = img->width, ih = img->height;
  resample_axis ax = {0}, ay = {0};
  mgs_image *out = NULL;
  float *tmp = NULL;
  if (!axis_init(&ax, iw, w) || !axis_init(&ay, ih, h)) goto done;
  /* horizontal pass into an iw -> w by ih buffer, then vertical; PIL does the same order
     and clips between passes (its 8-bit intermediate), as here */
  tmp = malloc(sizeof(float) * (size_t)w * (size_t)ih * (size_t)ch);
  out = mgs_image_create(w, h, ch);
  if (!tmp || !out) { mgs_image_destroy(out); out = NULL; goto done; }
  for (int y = 0; y < ih; y++)
    for (int x = 0; x < w; x++) {
      const double *wt = ax.w + (size_t)x * (size_t)ax.taps;
      for (int c = 0; c < ch; c++) {
        double s = 0;
        for (int k = 0; k < ax.count[x]; k++)
          s += wt[k] * img->data[((size_t)y * (size_t)iw + (size_t)(ax.first[x] + k)) * (size_t)ch + (size_t)c];
        tmp[((size_t)y * (size_t)w + (size_t)x) * (size_t)ch + (size_t)c] = (float)(s < 0 ? 0 : (s > 1 ? 1 : s));
      }
    }
  for (int y = 0; y < h; y++) {
    const double *wt = ay.w + (size_t)y * (size_t)ay.taps;
    for (int x = 0; x < w; x++)
      for (int c = 0; c < ch; c++) {
        double s = 0;
        for (int k = 0; k < ay.count[y]; k++)
          s += wt[k] * tmp[((size_t)(ay.first[y] + k) * (size_t)w + (size_t)x) * (size_t)ch + (size_t)c];
        out->data[((size_t)y * (size_t)w + (size_t)x) * (size_t)ch + (size_t)c] = (float)(s < 0 ? 0 : (s > 1 ? 1 : s));
      }
  }
done:
  free(tmp);
  axis_free(&ax);
  axis_free(&ay);
  return out;
}

/* Float images: creation and the pixel operations datasets need (alpha compositing,
 * integer box downscale). File I/O lives in image_oiio.cpp. */
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

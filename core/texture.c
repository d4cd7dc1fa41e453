/* Colour textures (core/mgs_texture.h): RGB texels and the bilinear wrap lookup. */
#include <math.h>
#include <stdlib.h>

#include "core/mgs_texture.h"

struct mgs_texture {
  int w, h;
  float *rgb; /* w*h*3, top row first (as mgs_image) */
};

mgs_texture *mgs_texture_from_image(const mgs_image *img) {
  if (!img || img->width < 1 || img->height < 1 || img->channels < 1 || img->channels > 4 || !img->data) return NULL;
  mgs_texture *t = calloc(1, sizeof *t);
  if (!t) return NULL;
  const size_t n = (size_t)img->width * (size_t)img->height;
  t->rgb = malloc(n * 3 * sizeof(float));
  if (!t->rgb) { free(t); return NULL; }
  t->w = img->width;
  t->h = img->height;
  const int ch = img->channels, grey = ch < 3; /* 1: grey, 2: grey + alpha */
  for (size_t i = 0; i < n; i++)
    for (int c = 0; c < 3; c++) {
      float x = img->data[i * (size_t)ch + (size_t)(grey ? 0 : c)];
      t->rgb[i * 3 + (size_t)c] = isfinite(x) ? x : 0.0f;
    }
  return t;
}

mgs_status mgs_texture_read(const char *path, mgs_texture **out, mgs_error *err) {
  *out = NULL;
  mgs_image *img = NULL;
  mgs_status s = mgs_image_read(path, &img, err);
  if (s != MGS_OK) return s;
  mgs_texture *t = mgs_texture_from_image(img);
  const int ch = img->channels;
  mgs_image_destroy(img);
  if (!t) return mgs_error_set(err, ch < 1 || ch > 4 ? MGS_ERR_FORMAT : MGS_ERR_NOMEM, "%s: cannot use as a texture (%d channels)", path, ch);
  *out = t;
  return MGS_OK;
}

void mgs_texture_destroy(mgs_texture *t) {
  if (!t) return;
  free(t->rgb);
  free(t);
}

int mgs_texture_width(const mgs_texture *t) { return t ? t->w : 0; }
int mgs_texture_height(const mgs_texture *t) { return t ? t->h : 0; }

static int wrap(long i, int n) {
  long r = i % n;
  return (int)(r < 0 ? r + n : r);
}

void mgs_texture_sample(const mgs_texture *t, float u, float v, float rgb[3]) {
  /* in texel units, row 0 at the top: v = 1 is the top edge */
  double x = (double)u * t->w - 0.5, y = (1.0 - (double)v) * t->h - 0.5;
  /* keep floor() and the long cast in range for huge (tiled) coordinates */
  x = fmod(x, (double)t->w);
  y = fmod(y, (double)t->h);
  const double fx0 = floor(x), fy0 = floor(y);
  const float ax = (float)(x - fx0), ay = (float)(y - fy0);
  const int x0 = wrap((long)fx0, t->w), x1 = wrap((long)fx0 + 1, t->w);
  const int y0 = wrap((long)fy0, t->h), y1 = wrap((long)fy0 + 1, t->h);
  const float *p00 = t->rgb + 3 * ((size_t)y0 * (size_t)t->w + (size_t)x0), *p10 = t->rgb + 3 * ((size_t)y0 * (size_t)t->w + (size_t)x1);
  const float *p01 = t->rgb + 3 * ((size_t)y1 * (size_t)t->w + (size_t)x0), *p11 = t->rgb + 3 * ((size_t)y1 * (size_t)t->w + (size_t)x1);
  for (int c = 0; c < 3; c++) {
    const float top = p00[c] + (p10[c] - p00[c]) * ax, bottom = p01[c] + (p11[c] - p01[c]) * ax;
    rgb[c] = top + (bottom - top) * ay;
  }
}

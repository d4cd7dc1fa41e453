/* The geometry maps of `morsegs render --depth --normal --alpha` as files: depth as
 * float EXR (or 16-bit PNG of depth * scale, the depth-image convention) plus a
 * colour-mapped PNG to look at; normals as float EXR (sum w n, world space) plus a PNG of
 * the unit normal mapped to (n + 1) / 2; alpha as a 16-bit PNG. */
#include "apps/mgs_render_maps_io.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include "core/mgs_fs.h"
#include "core/mgs_image.h"

/* Turbo colour map (Mikhailov 2019, polynomial fit), t in [0,1]. */
static void turbo(double t, float rgb[3]) {
  t = t < 0 ? 0 : t > 1 ? 1 : t;
  const double r = 0.13572138 + t * (4.61539260 + t * (-42.66032258 + t * (132.13108234 + t * (-152.94239396 + t * 59.28637943))));
  const double g = 0.09140261 + t * (2.19418839 + t * (4.84296658 + t * (-14.18503333 + t * (4.27729857 + t * 2.82956604))));
  const double b = 0.10667330 + t * (12.64194608 + t * (-60.58204836 + t * (110.36276771 + t * (-89.90310912 + t * 27.34824973))));
  rgb[0] = (float)fmin(1, fmax(0, r)); rgb[1] = (float)fmin(1, fmax(0, g)); rgb[2] = (float)fmin(1, fmax(0, b));
}

static mgs_status write_named(const char *dir, const char *name, const char *suffix, const mgs_image *img, int u16,
                              mgs_error *err) {
  char file[600];
  snprintf(file, sizeof file, "%s%s", name, suffix);
  char *path = mgs_path_join(dir, file);
  if (!path) return mgs_error_set(err, MGS_ERR_NOMEM, "out of memory");
  mgs_status st = u16 ? mgs_image_write_u16(path, img, err) : mgs_image_write(path, img, err);
  free(path);
  return st;
}

static mgs_status write_depth(const char *dir, const char *name, const char *what, const float *d, int W, int H,
                              const mgs_maps_io_opts *o, mgs_error *err) {
  size_t np = (size_t)W * H;
  mgs_image *img = mgs_image_create(W, H, 1);
  if (!img) return mgs_error_set(err, MGS_ERR_NOMEM, "out of memory");
  char suffix[64];
  mgs_status st;
  if (o->png16) {
    for (size_t p = 0; p < np; p++) img->data[p] = (float)(d[p] * o->depth_scale / 65535.0);
    snprintf(suffix, sizeof suffix, "_%s.png", what);
    st = write_named(dir, name, suffix, img, 1, err);
  } else {
    for (size_t p = 0; p < np; p++) img->data[p] = d[p];
    snprintf(suffix, sizeof suffix, "_%s.exr", what);
    st = write_named(dir, name, suffix, img, 0, err);
  }
  mgs_image_destroy(img);
  return st;
}

mgs_status mgs_write_render_maps(const char *dir, const char *name, const mgs_render_maps *m, const mgs_maps_io_opts *o,
                                 mgs_error *err) {
  const int W = m->width, H = m->height;
  const size_t np = (size_t)W * H;
  mgs_status st = MGS_OK;
  mgs_image *rgb = mgs_image_create(W, H, 3), *one = mgs_image_create(W, H, 1);
  if (!rgb || !one) { st = mgs_error_set(err, MGS_ERR_NOMEM, "out of memory"); goto done; }
  if (o->alpha) {
    for (size_t p = 0; p < np; p++) one->data[p] = m->alpha[p];
    if ((st = write_named(dir, name, "_alpha.png", one, 1, err))) goto done;
  }
  if (o->depth && m->depth_expected && m->depth_median) {
    if ((st = write_depth(dir, name, "depth_expected", m->depth_expected, W, H, o, err))) goto done;
    if ((st = write_depth(dir, name, "depth_median", m->depth_median, W, H, o, err))) goto done;
    /* to look at: the median depth over this view's own foreground range, near = red */
    double lo = INFINITY, hi = -INFINITY;
    for (size_t p = 0; p < np; p++)
      if (m->depth_median[p] > 0) { lo = fmin(lo, m->depth_median[p]); hi = fmax(hi, m->depth_median[p]); }
    for (size_t p = 0; p < np; p++) {
      float *c = rgb->data + 3 * p;
      if (!(m->depth_median[p] > 0)) { c[0] = c[1] = c[2] = 0; continue; }
      turbo(hi > lo ? 1 - (m->depth_median[p] - lo) / (hi - lo) : 1, c);
    }
    if ((st = write_named(dir, name, "_depth.png", rgb, 0, err))) goto done;
  }
  if (o->normal && m->normal) {
    mgs_image *n3 = mgs_image_create(W, H, 3);
    if (!n3) { st = mgs_error_set(err, MGS_ERR_NOMEM, "out of memory"); goto done; }
    for (size_t p = 0; p < 3 * np; p++) n3->data[p] = m->normal[p];
    st = write_named(dir, name, "_normal.exr", n3, 0, err);
    mgs_image_destroy(n3);
    if (st) goto done;
    for (size_t p = 0; p < np; p++) {
      const float *n = m->normal + 3 * p;
      float len = sqrtf(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
      for (int c = 0; c < 3; c++) rgb->data[3 * p + c] = len > 0 && m->alpha[p] >= 0.5f ? 0.5f * (n[c] / len + 1) : 0;
    }
    if ((st = write_named(dir, name, "_normal.png", rgb, 0, err))) goto done;
  }
done:
  mgs_image_destroy(rgb);
  mgs_image_destroy(one);
  return st;
}

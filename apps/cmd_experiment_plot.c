/* Line plots of `morsegs experiment` (PSNR / Chamfer / bottleneck distance against training
 * wall time, Gaussian count against PSNR): cairo, one series per variant, markers at the
 * evaluation points, written as base.png and base.svg through atomic files. (topo/plot.c
 * draws persistence diagrams only; its canvas helper is private to topo.) */
#include <cairo.h>
#include <cairo/cairo-svg.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "apps/mgs_experiment.h"
#include "core/mgs_fs.h"

static cairo_status_t write_fp(void *closure, const unsigned char *data, unsigned int len) {
  return fwrite(data, 1, len, (FILE *)closure) == len ? CAIRO_STATUS_SUCCESS : CAIRO_STATUS_WRITE_ERROR;
}

static double nice_step(double lo, double hi, int n) {
  double raw = (hi - lo) / n;
  if (!(raw > 0) || !isfinite(raw)) return 1;
  double p = pow(10, floor(log10(raw))), f = raw / p;
  return (f < 1.5 ? 1 : f < 3.5 ? 2 : f < 7.5 ? 5 : 10) * p;
}

static const double palette[][3] = {{0.12, 0.47, 0.71}, {0.84, 0.15, 0.16}, {0.17, 0.63, 0.17}, {1.0, 0.5, 0.05},
                                    {0.58, 0.40, 0.74}, {0.55, 0.34, 0.29}, {0.89, 0.47, 0.76}, {0.5, 0.5, 0.5},
                                    {0.74, 0.74, 0.13}, {0.09, 0.75, 0.81}};

static void draw(cairo_t *cr, int W, int H, const char *title, const char *xl, const char *yl, const exp_series *s,
                 size_t ns, int logy) {
  const double L = 96, R = 190, T = 36, B = 52;
  double x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY;
  for (size_t k = 0; k < ns; k++)
    for (size_t i = 0; i < s[k].n; i++) {
      double x = s[k].x[i], y = s[k].y[i];
      if (!isfinite(x) || !isfinite(y) || (logy && !(y > 0))) continue;
      if (logy) y = log10(y);
      x0 = fmin(x0, x); x1 = fmax(x1, x); y0 = fmin(y0, y); y1 = fmax(y1, y);
    }
  if (!isfinite(x0)) { x0 = 0; x1 = 1; y0 = 0; y1 = 1; }
  if (x1 - x0 < 1e-12) { x0 -= 0.5; x1 += 0.5; }
  if (y1 - y0 < 1e-12 * fmax(1, fabs(y0))) { y0 -= 0.5; y1 += 0.5; }
  double py = 0.05 * (y1 - y0);
  y0 -= py; y1 += py;
  double px = 0.03 * (x1 - x0);
  x0 -= px; x1 += px;
  const double pw = W - L - R, ph = H - T - B;
#define PX(x) (L + ((x) - x0) / (x1 - x0) * pw)
#define PY(y) (T + ph - ((y) - y0) / (y1 - y0) * ph)
  cairo_set_source_rgb(cr, 1, 1, 1);
  cairo_paint(cr);
  cairo_select_font_face(cr, "sans-serif", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
  cairo_set_font_size(cr, 12);
  cairo_set_line_width(cr, 1);
  char buf[64];
  double sx = nice_step(x0, x1, 6), sy = nice_step(y0, y1, 6);
  for (double v = ceil(x0 / sx) * sx; v <= x1 + 1e-9 * sx; v += sx) {
    cairo_set_source_rgb(cr, 0.9, 0.9, 0.9);
    cairo_move_to(cr, PX(v), T); cairo_line_to(cr, PX(v), T + ph); cairo_stroke(cr);
    cairo_set_source_rgb(cr, 0, 0, 0);
    snprintf(buf, sizeof buf, "%g", fabs(v) < 1e-12 * sx ? 0.0 : v);
    cairo_move_to(cr, PX(v) - 3 * (double)strlen(buf), T + ph + 16); cairo_show_text(cr, buf);
  }
  for (double v = ceil(y0 / sy) * sy; v <= y1 + 1e-9 * sy; v += sy) {
    cairo_set_source_rgb(cr, 0.9, 0.9, 0.9);
    cairo_move_to(cr, L, PY(v)); cairo_line_to(cr, L + pw, PY(v)); cairo_stroke(cr);
    cairo_set_source_rgb(cr, 0, 0, 0);
    snprintf(buf, sizeof buf, "%.4g", logy ? pow(10, v) : (fabs(v) < 1e-12 * sy ? 0.0 : v));
    cairo_text_extents_t te;
    cairo_text_extents(cr, buf, &te);
    cairo_move_to(cr, L - 6 - te.x_advance, PY(v) + 4); cairo_show_text(cr, buf); /* right-aligned at the axis */
  }
  cairo_set_source_rgb(cr, 0, 0, 0);
  cairo_rectangle(cr, L, T, pw, ph);
  cairo_stroke(cr);
  cairo_move_to(cr, L + pw / 2 - 3.2 * (double)strlen(xl), H - 14); cairo_show_text(cr, xl);
  char ylab[160];
  snprintf(ylab, sizeof ylab, "%s%s", yl, logy ? " (log scale)" : "");
  cairo_save(cr);
  cairo_text_extents_t yt;
  cairo_text_extents(cr, ylab, &yt);
  cairo_translate(cr, 16, T + ph / 2 + yt.x_advance / 2);
  cairo_rotate(cr, -M_PI / 2);
  cairo_move_to(cr, 0, 0);
  cairo_show_text(cr, ylab);
  cairo_restore(cr);
  cairo_set_font_size(cr, 13);
  cairo_move_to(cr, L, 22); cairo_show_text(cr, title);
  cairo_set_font_size(cr, 12);
  for (size_t k = 0; k < ns; k++) {
    const double *c = palette[k % (sizeof palette / sizeof *palette)];
    cairo_set_source_rgb(cr, c[0], c[1], c[2]);
    cairo_set_line_width(cr, 2);
    int started = 0;
    for (size_t i = 0; i < s[k].n; i++) {
      double x = s[k].x[i], y = s[k].y[i];
      if (!isfinite(x) || !isfinite(y) || (logy && !(y > 0))) continue;
      if (logy) y = log10(y);
      if (!started) cairo_move_to(cr, PX(x), PY(y)); else cairo_line_to(cr, PX(x), PY(y));
      started = 1;
    }
    cairo_stroke(cr);
    for (size_t i = 0; i < s[k].n; i++) {
      double x = s[k].x[i], y = s[k].y[i];
      if (!isfinite(x) || !isfinite(y) || (logy && !(y > 0))) continue;
      if (logy) y = log10(y);
      cairo_arc(cr, PX(x), PY(y), 3.5, 0, 2 * M_PI);
      cairo_fill(cr);
    }
    cairo_rectangle(cr, W - R + 12, T + 8 + 18 * (double)k, 14, 10);
    cairo_fill(cr);
    cairo_set_source_rgb(cr, 0, 0, 0);
    cairo_move_to(cr, W - R + 32, T + 17 + 18 * (double)k);
    cairo_show_text(cr, s[k].name);
  }
#undef PX
#undef PY
}

static mgs_status plot_one(const char *path, int svg, const char *title, const char *xl, const char *yl,
                           const exp_series *s, size_t ns, int logy, mgs_error *err) {
  const int W = 860, H = 500;
  mgs_atomic_file *af = NULL;
  FILE *fp = NULL;
  mgs_status st = mgs_atomic_open(path, &af, &fp, err);
  if (st) return st;
  cairo_surface_t *sf = svg ? cairo_svg_surface_create_for_stream(write_fp, fp, W, H)
                            : cairo_image_surface_create(CAIRO_FORMAT_RGB24, W, H);
  cairo_t *cr = cairo_create(sf);
  draw(cr, W, H, title, xl, yl, s, ns, logy);
  cairo_status_t cs = cairo_status(cr);
  cairo_destroy(cr);
  if (!svg && cs == CAIRO_STATUS_SUCCESS) cs = cairo_surface_write_to_png_stream(sf, write_fp, fp);
  cairo_surface_finish(sf);
  if (cs == CAIRO_STATUS_SUCCESS) cs = cairo_surface_status(sf);
  cairo_surface_destroy(sf);
  if (cs != CAIRO_STATUS_SUCCESS) {
    mgs_atomic_abort(af);
    return mgs_error_set(err, MGS_ERR_IO, "%s: cairo failed: %s", path, cairo_status_to_string(cs));
  }
  return mgs_atomic_commit(af, err);
}

mgs_status exp_plot_lines(const char *base, const char *title, const char *xlabel, const char *ylabel,
                          const exp_series *s, size_t ns, int logy, mgs_error *err) {
  size_t n = strlen(base) + 8;
  char *p = malloc(n);
  if (!p) return mgs_error_set(err, MGS_ERR_NOMEM, "out of memory");
  snprintf(p, n, "%s.png", base);
  mgs_status st = plot_one(p, 0, title, xlabel, ylabel, s, ns, logy, err);
  snprintf(p, n, "%s.svg", base);
  if (!st) st = plot_one(p, 1, title, xlabel, ylabel, s, ns, logy, err);
  free(p);
  return st;
}

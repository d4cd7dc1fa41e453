/* Persistence diagram and barcode plots with cairo (declared in topo/mgs_diagram_plot.h). */
#include <cairo/cairo.h>
#include <cairo/cairo-svg.h>
#include <dlfcn.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include "core/mgs_fs.h"
#include "topo/mgs_diagram_plot.h"

static const double dim_rgb[3][3] = {{0.84, 0.15, 0.16}, {0.12, 0.47, 0.71}, {0.17, 0.63, 0.17}};
static const char *dim_name[3] = {"H0", "H1", "H2"};

typedef enum { FMT_PNG, FMT_SVG, FMT_NONE } plot_format;
static plot_format format_of(const char *path) {
  const char *dot = strrchr(path, '.');
  if (dot && !strcasecmp(dot, ".png")) return FMT_PNG;
  if (dot && !strcasecmp(dot, ".svg")) return FMT_SVG;
  return FMT_NONE;
}

static cairo_status_t write_fp(void *closure, const unsigned char *data, unsigned int len) {
  return fwrite(data, 1, len, (FILE *)closure) == len ? CAIRO_STATUS_SUCCESS : CAIRO_STATUS_WRITE_ERROR;
}

/* A drawing target: an image surface (PNG) or an SVG stream into an atomic temp file. */
typedef struct canvas {
  plot_format fmt;
  cairo_surface_t *surf;
  cairo_t *cr;
  mgs_atomic_file *af;
  FILE *fp;
} canvas;

static mgs_status canvas_open(canvas *cv, const char *path, int w, int h, mgs_error *err) {
  memset(cv, 0, sizeof *cv);
  cv->fmt = format_of(path);
  if (cv->fmt == FMT_NONE)
    return mgs_error_set(err, MGS_ERR_ARG, "%s: plot format must be .png or .svg", path);
  mgs_status st = mgs_atomic_open(path, &cv->af, &cv->fp, err);
  if (st != MGS_OK) return st;
  if (cv->fmt == FMT_PNG) cv->surf = cairo_image_surface_create(CAIRO_FORMAT_ARGB32, w, h);
  else cv->surf = cairo_svg_surface_create_for_stream(write_fp, cv->fp, w, h);
  if (cairo_surface_status(cv->surf) != CAIRO_STATUS_SUCCESS) {
    cairo_surface_destroy(cv->surf);
    mgs_atomic_abort(cv->af);
    return mgs_error_set(err, MGS_ERR_NOMEM, "%s: cannot create a %dx%d cairo surface", path, w, h);
  }
  cv->cr = cairo_create(cv->surf);
  cairo_set_source_rgb(cv->cr, 1, 1, 1);
  cairo_paint(cv->cr);
  return MGS_OK;
}

static mgs_status canvas_close(canvas *cv, const char *path, mgs_error *err) {
  cairo_status_t cs = cairo_status(cv->cr);
  cairo_destroy(cv->cr);
  if (cv->fmt == FMT_PNG && cs == CAIRO_STATUS_SUCCESS)
    cs = cairo_surface_write_to_png_stream(cv->surf, write_fp, cv->fp);
  cairo_surface_finish(cv->surf); /* flushes the SVG stream */
  if (cs == CAIRO_STATUS_SUCCESS) cs = cairo_surface_status(cv->surf);
  cairo_surface_destroy(cv->surf);
  if (cs != CAIRO_STATUS_SUCCESS) {
    mgs_atomic_abort(cv->af);
    return mgs_error_set(err, MGS_ERR_IO, "%s: cairo failed: %s", path, cairo_status_to_string(cs));
  }
  return mgs_atomic_commit(cv->af, err);
}

/* "Nice" tick step (1, 2, 5 × 10^k) giving about n ticks over [lo, hi]. */
static double nice_step(double lo, double hi, int n) {
  double raw = (hi - lo) / n;
  if (!(raw > 0)) return 1;
  double mag = pow(10, floor(log10(raw))), f = raw / mag;
  return (f < 1.5 ? 1 : f < 3 ? 2 : f < 7 ? 5 : 10) * mag;
}

static void text_at(cairo_t *cr, double x, double y, const char *s, double ax, double ay) {
  cairo_text_extents_t te;
  cairo_text_extents(cr, s, &te);
  cairo_move_to(cr, x - te.width * ax - te.x_bearing, y - te.height * ay - te.y_bearing);
  cairo_show_text(cr, s);
}

static void fmt_tick(char *buf, size_t n, double v, double step) {
  if (fabs(v) < step * 1e-6) v = 0;
  int dec = step >= 1 ? 0 : (int)ceil(-log10(step) - 1e-9);
  if (dec > 8) snprintf(buf, n, "%.2g", v);
  else snprintf(buf, n, "%.*f", dec, v);
}

/* Range of the finite values of the diagram (padded), [0,1] when there are none. */
static void value_range(const mgs_diagram *d, double *lo, double *hi) {
  double a = INFINITY, b = -INFINITY;
  for (size_t i = 0; i < d->n; i++) {
    const mgs_pair *p = &d->pairs[i];
    if (isfinite(p->birth)) { a = fmin(a, p->birth); b = fmax(b, p->birth); }
    if (isfinite(p->death)) { a = fmin(a, p->death); b = fmax(b, p->death); }
  }
  if (!(a <= b)) { a = 0; b = 1; }
  if (b - a < 1e-12 * fmax(1.0, fabs(a))) { a -= 0.5; b += 0.5; }
  double pad = 0.05 * (b - a);
  *lo = a - pad; *hi = b + pad;
}

static void set_dim_colour(cairo_t *cr, int dim, double alpha) {
  int k = dim < 0 ? 0 : dim > 2 ? 2 : dim;
  cairo_set_source_rgba(cr, dim_rgb[k][0], dim_rgb[k][1], dim_rgb[k][2], alpha);
}

static void draw_title(cairo_t *cr, double w, const char *title) {
  if (!title) return;
  cairo_set_source_rgb(cr, 0, 0, 0);
  cairo_select_font_face(cr, "sans-serif", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_BOLD);
  cairo_set_font_size(cr, 16);
  text_at(cr, w / 2, 22, title, 0.5, 0.5);
  cairo_select_font_face(cr, "sans-serif", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
}

static void draw_legend(cairo_t *cr, double x, double y, const size_t count[3]) {
  cairo_set_font_size(cr, 13);
  double yy = y;
  for (int k = 0; k < 3; k++) {
    char buf[64];
    snprintf(buf, sizeof buf, "%s (%zu)", dim_name[k], count[k]);
    set_dim_colour(cr, k, 1);
    cairo_arc(cr, x + 6, yy, 5, 0, 2 * M_PI);
    cairo_fill(cr);
    cairo_set_source_rgb(cr, 0, 0, 0);
    text_at(cr, x + 16, yy, buf, 0, 0.5);
    yy += 20;
  }
}

mgs_status mgs_diagram_plot(const mgs_diagram *d, const char *path, const char *title, mgs_error *err) {
  if (!d || !path) return mgs_error_set(err, MGS_ERR_ARG, "diagram plot: null argument");
  const int W = 800, H = 800;
  const double L = 90, R = 40, T = 50, B = 70; /* margins */
  canvas cv;
  mgs_status st = canvas_open(&cv, path, W, H, err);
  if (st != MGS_OK) return st;
  cairo_t *cr = cv.cr;
  double lo, hi;
  value_range(d, &lo, &hi);
  int has_pinf = 0, has_minf = 0;
  size_t count[3] = {0, 0, 0};
  for (size_t i = 0; i < d->n; i++) {
    const mgs_pair *p = &d->pairs[i];
    if (p->dim >= 0 && p->dim <= 2) count[p->dim]++;
    if (isinf(p->death)) { if (p->death > 0) has_pinf = 1; else has_minf = 1; }
  }
  /* plot area; the inf lines sit in bands above/below the finite square */
  double band = 30;
  double x0 = L, x1 = W - R, y0 = H - B - (has_minf ? band : 0), y1 = T + (has_pinf ? band : 0);
  double sx = (x1 - x0) / (hi - lo), sy = (y0 - y1) / (hi - lo);
#define PX(v) (x0 + ((v) - lo) * sx)
#define PY(v) (y0 - ((v) - lo) * sy)
  /* frame, ticks, grid */
  cairo_set_line_width(cr, 1);
  double step = nice_step(lo, hi, 8);
  cairo_set_font_size(cr, 12);
  for (double v = ceil(lo / step) * step; v <= hi + 1e-9 * step; v += step) {
    char buf[32];
    fmt_tick(buf, sizeof buf, v, step);
    cairo_set_source_rgb(cr, 0.92, 0.92, 0.92);
    cairo_move_to(cr, PX(v), y0); cairo_line_to(cr, PX(v), y1); cairo_stroke(cr);
    cairo_move_to(cr, x0, PY(v)); cairo_line_to(cr, x1, PY(v)); cairo_stroke(cr);
    cairo_set_source_rgb(cr, 0, 0, 0);
    cairo_move_to(cr, PX(v), H - B); cairo_line_to(cr, PX(v), H - B + 5); cairo_stroke(cr);
    cairo_move_to(cr, x0 - 5, PY(v)); cairo_line_to(cr, x0, PY(v)); cairo_stroke(cr);
    text_at(cr, PX(v), H - B + 8, buf, 0.5, 0);
    text_at(cr, x0 - 8, PY(v), buf, 1, 0.5);
  }
  cairo_set_source_rgb(cr, 0, 0, 0);
  cairo_rectangle(cr, x0, T, x1 - x0, H - B - T);
  cairo_stroke(cr);
  /* the diagonal */
  cairo_set_source_rgb(cr, 0.4, 0.4, 0.4);
  cairo_move_to(cr, PX(lo), PY(lo)); cairo_line_to(cr, PX(hi), PY(hi)); cairo_stroke(cr);
  /* inf lines */
  double dash[2] = {6, 4};
  double yinf = T + band * 0.5, yminf = H - B - band * 0.5;
  cairo_set_dash(cr, dash, 2, 0);
  if (has_pinf) { cairo_move_to(cr, x0, yinf); cairo_line_to(cr, x1, yinf); cairo_stroke(cr); text_at(cr, x0 - 8, yinf, "inf", 1, 0.5); }
  if (has_minf) { cairo_move_to(cr, x0, yminf); cairo_line_to(cr, x1, yminf); cairo_stroke(cr); text_at(cr, x0 - 8, yminf, "-inf", 1, 0.5); }
  cairo_set_dash(cr, NULL, 0, 0);
  /* axis labels */
  cairo_set_source_rgb(cr, 0, 0, 0);
  cairo_set_font_size(cr, 14);
  text_at(cr, (x0 + x1) / 2, H - 22, "birth", 0.5, 0.5);
  cairo_save(cr);
  cairo_translate(cr, 22, (T + H - B) / 2);
  cairo_rotate(cr, -M_PI / 2);
  text_at(cr, 0, 0, "death", 0.5, 0.5);
  cairo_restore(cr);
  /* points: higher dimensions last so sparse H1/H2 stay visible over many H0 points */
  for (int k = 0; k < 3; k++)
    for (size_t i = 0; i < d->n; i++) {
      const mgs_pair *p = &d->pairs[i];
      if (p->dim != k || !isfinite(p->birth)) continue;
      double y = isinf(p->death) ? (p->death > 0 ? yinf : yminf) : PY(p->death);
      set_dim_colour(cr, k, 0.75);
      cairo_arc(cr, PX(p->birth), y, isinf(p->death) ? 5 : 3.5, 0, 2 * M_PI);
      cairo_fill(cr);
    }
  /* legend: top-left inside the frame (the diagonal leaves that corner empty for
   * sublevel diagrams; for superlevel ones the bottom-right) */
  int superlevel = 0;
  for (size_t i = 0; i < d->n; i++) if (d->pairs[i].death < d->pairs[i].birth) { superlevel = 1; break; }
  cairo_set_source_rgba(cr, 1, 1, 1, 0.85);
  double lx = superlevel ? x1 - 130 : x0 + 10, ly = superlevel ? y0 - 75 : y1 + 10;
  cairo_rectangle(cr, lx, ly, 120, 66);
  cairo_fill(cr);
  draw_legend(cr, lx + 6, ly + 13, count);
  draw_title(cr, W, title);
#undef PX
#undef PY
  return canvas_close(&cv, path, err);
}

typedef struct bar { double pers, birth, death; int dim; } bar;
static int cmp_bar(const void *a, const void *b) {
  const bar *x = a, *y = b;
  if (x->dim != y->dim) return x->dim - y->dim;
  if (x->pers != y->pers) return x->pers > y->pers ? -1 : 1;
  return x->birth < y->birth ? -1 : x->birth > y->birth;
}
static int cmp_bar_pers(const void *a, const void *b) {
  const bar *x = a, *y = b;
  if (x->pers != y->pers) return x->pers > y->pers ? -1 : 1;
  return cmp_bar(a, b);
}

mgs_status mgs_diagram_plot_barcode(const mgs_diagram *d, const char *path, const char *title, mgs_error *err) {
  if (!d || !path) return mgs_error_set(err, MGS_ERR_ARG, "barcode plot: null argument");
  size_t n = 0;
  bar *bars = malloc((d->n ? d->n : 1) * sizeof *bars);
  if (!bars) return mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory for %zu bars", path, d->n);
  for (size_t i = 0; i < d->n; i++) {
    const mgs_pair *p = &d->pairs[i];
    if (!isfinite(p->birth) || p->dim < 0 || p->dim > 2) continue;
    bars[n++] = (bar){isinf(p->death) ? INFINITY : fabs(p->death - p->birth), p->birth, p->death, p->dim};
  }
  size_t total = n;
  if (n > MGS_PLOT_MAX_BARS) { qsort(bars, n, sizeof *bars, cmp_bar_pers); n = MGS_PLOT_MAX_BARS; }
  qsort(bars, n, sizeof *bars, cmp_bar);
  const int W = 900, H = 700;
  const double L = 70, R = 60, T = 50, B = 60;
  canvas cv;
  mgs_status st = canvas_open(&cv, path, W, H, err);
  if (st != MGS_OK) { free(bars); return st; }
  cairo_t *cr = cv.cr;
  double lo, hi;
  value_range(d, &lo, &hi);
  double x0 = L, x1 = W - R - 40, xinf = W - R; /* essential bars run to the "inf" column */
  double y_top = T + 12, y_bot = H - B;
  double sx = (x1 - x0) / (hi - lo);
#define PX(v) (isinf(v) ? ((v) > 0 ? xinf : x0 - 20) : x0 + ((v) - lo) * sx)
  double step = nice_step(lo, hi, 10);
  cairo_set_line_width(cr, 1);
  cairo_set_font_size(cr, 12);
  for (double v = ceil(lo / step) * step; v <= hi + 1e-9 * step; v += step) {
    char buf[32];
    fmt_tick(buf, sizeof buf, v, step);
    cairo_set_source_rgb(cr, 0.92, 0.92, 0.92);
    cairo_move_to(cr, PX(v), y_top); cairo_line_to(cr, PX(v), y_bot); cairo_stroke(cr);
    cairo_set_source_rgb(cr, 0, 0, 0);
    cairo_move_to(cr, PX(v), y_bot); cairo_line_to(cr, PX(v), y_bot + 5); cairo_stroke(cr);
    text_at(cr, PX(v), y_bot + 8, buf, 0.5, 0);
  }
  cairo_set_source_rgb(cr, 0, 0, 0);
  cairo_move_to(cr, x0, y_bot); cairo_line_to(cr, xinf, y_bot); cairo_stroke(cr);
  text_at(cr, xinf, y_bot + 8, "inf", 0.5, 0);
  for (size_t i = 0; i < n; i++)
    if (bars[i].death == -INFINITY) { text_at(cr, x0 - 20, y_bot + 8, "-inf", 0.5, 0); break; }
  cairo_set_font_size(cr, 14);
  text_at(cr, (x0 + x1) / 2, H - 20, "filtration value", 0.5, 0.5);
  double slot = n ? (y_bot - y_top) / (double)n : 0;
  double lw = fmin(fmax(slot * 0.7, 0.4), 8);
  cairo_set_line_width(cr, lw);
  for (size_t i = 0; i < n; i++) {
    double y = y_top + (i + 0.5) * slot;
    set_dim_colour(cr, bars[i].dim, 0.9);
    double xa = PX(bars[i].birth), xb = PX(bars[i].death);
    if (fabs(xb - xa) < 1) xb = xa + (xb >= xa ? 1 : -1); /* keep tiny bars visible */
    cairo_move_to(cr, xa, y); cairo_line_to(cr, xb, y); cairo_stroke(cr);
  }
  size_t count[3] = {0, 0, 0};
  for (size_t i = 0; i < n; i++) count[bars[i].dim]++;
  /* legend: one row between the title and the bars */
  cairo_set_font_size(cr, 13);
  for (int k = 0; k < 3; k++) {
    char buf[64];
    snprintf(buf, sizeof buf, "%s (%zu)", dim_name[k], count[k]);
    double lx = W / 2.0 - 180 + 130 * k;
    set_dim_colour(cr, k, 1);
    cairo_arc(cr, lx, T - 5, 5, 0, 2 * M_PI);
    cairo_fill(cr);
    cairo_set_source_rgb(cr, 0, 0, 0);
    text_at(cr, lx + 10, T - 5, buf, 0, 0.5);
  }
  char full[512];
  if (total > n) snprintf(full, sizeof full, "%s (top %zu of %zu bars)", title ? title : "barcode", n, total);
  else snprintf(full, sizeof full, "%s", title ? title : "barcode");
  draw_title(cr, W, full);
#undef PX
  free(bars);
  return canvas_close(&cv, path, err);
}

void mgs_diagram_plot_release(void) {
  cairo_debug_reset_static_data();
  /* fontconfig (loaded by cairo) keeps its configuration until FcFini; looked up at run
   * time so users need not link fontconfig themselves */
  void (*fc_fini)(void);
  *(void **)&fc_fini = dlsym(RTLD_DEFAULT, "FcFini");
  if (fc_fini) fc_fini();
}

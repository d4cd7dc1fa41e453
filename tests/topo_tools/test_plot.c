/* Plots: valid PNG/SVG files (signature, size), the PNG not blank (pixels read back with
 * cairo, each dimension's colour present), unknown extensions refused, nothing left behind. */
#include <cairo/cairo.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "mgs_test.h"
#include "core/mgs_fs.h"
#include "core/mgs_rng.h"
#include "topo/mgs_diagram_plot.h"

static mgs_diagram *sample(size_t n, int superlevel) {
  mgs_diagram *d = mgs_diagram_create();
  mgs_rng r;
  mgs_rng_init(&r, 3, 1);
  for (size_t i = 0; i < n; i++) {
    mgs_pair p;
    memset(&p, 0, sizeof p);
    p.dim = (int)(i % 3);
    p.birth = mgs_rng_uniform(&r) - 0.5;
    p.death = p.birth + 0.3 * mgs_rng_uniform(&r) + 0.01;
    if (i == 0) p.death = INFINITY;
    if (superlevel) { p.birth = -p.birth; p.death = -p.death; }
    mgs_diagram_push(d, &p, NULL);
  }
  return d;
}

static long file_size(const char *path) {
  FILE *f = fopen(path, "rb");
  if (!f) return -1;
  fseek(f, 0, SEEK_END);
  long n = ftell(f);
  fclose(f);
  return n;
}

static int starts_with(const char *path, const void *sig, size_t n) {
  unsigned char buf[64] = {0};
  FILE *f = fopen(path, "rb");
  if (!f) return 0;
  size_t got = fread(buf, 1, n, f);
  fclose(f);
  return got == n && !memcmp(buf, sig, n);
}

/* Counts non-white pixels and pixels close to each dimension's colour. */
static void png_stats(const char *path, long *nonwhite, long colour[3]) {
  static const int rgb[3][3] = {{214, 38, 41}, {31, 120, 181}, {43, 161, 43}};
  *nonwhite = -1;
  cairo_surface_t *s = cairo_image_surface_create_from_png(path);
  if (cairo_surface_status(s) != CAIRO_STATUS_SUCCESS) { cairo_surface_destroy(s); return; }
  int w = cairo_image_surface_get_width(s), h = cairo_image_surface_get_height(s);
  int stride = cairo_image_surface_get_stride(s);
  const unsigned char *px = cairo_image_surface_get_data(s);
  *nonwhite = 0;
  colour[0] = colour[1] = colour[2] = 0;
  for (int y = 0; y < h; y++)
    for (int x = 0; x < w; x++) {
      uint32_t v;
      memcpy(&v, px + (size_t)y * stride + 4 * (size_t)x, 4);
      int r = (v >> 16) & 255, g = (v >> 8) & 255, b = v & 255;
      if (r < 250 || g < 250 || b < 250) (*nonwhite)++;
      for (int k = 0; k < 3; k++)
        if (abs(r - rgb[k][0]) < 40 && abs(g - rgb[k][1]) < 40 && abs(b - rgb[k][2]) < 40) colour[k]++;
    }
  cairo_surface_destroy(s);
}

static void check_outputs(const char *dir, const char *stem, int superlevel, size_t n) {
  mgs_diagram *d = sample(n, superlevel);
  mgs_error e;
  char png[4200], svg[4200], bpng[4200], bsvg[4200];
  snprintf(png, sizeof png, "%s/%s.png", dir, stem);
  snprintf(svg, sizeof svg, "%s/%s.svg", dir, stem);
  snprintf(bpng, sizeof bpng, "%s/%s_barcode.png", dir, stem);
  snprintf(bsvg, sizeof bsvg, "%s/%s_barcode.SVG", dir, stem);
  CHECK_OK(mgs_diagram_plot(d, png, "test diagram", &e), &e);
  CHECK_OK(mgs_diagram_plot(d, svg, "test diagram", &e), &e);
  CHECK_OK(mgs_diagram_plot_barcode(d, bpng, "test barcode", &e), &e);
  CHECK_OK(mgs_diagram_plot_barcode(d, bsvg, NULL, &e), &e);
  static const unsigned char png_sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  CHECK(starts_with(png, png_sig, 8) && starts_with(bpng, png_sig, 8));
  CHECK(starts_with(svg, "<?xml", 5) && starts_with(bsvg, "<?xml", 5));
  CHECK(file_size(png) > 5000 && file_size(bpng) > 5000);
  CHECK(file_size(svg) > 5000 && file_size(bsvg) > 5000);
  long nonwhite, colour[3];
  png_stats(png, &nonwhite, colour);
  CHECK_MSG(nonwhite > 10000, "diagram png: %ld non-white pixels", nonwhite);
  CHECK_MSG(colour[0] > 50 && colour[1] > 50 && colour[2] > 50, "diagram png colours %ld %ld %ld", colour[0], colour[1], colour[2]);
  png_stats(bpng, &nonwhite, colour);
  CHECK_MSG(nonwhite > 10000, "barcode png: %ld non-white pixels", nonwhite);
  CHECK_MSG(colour[0] > 200 && colour[1] > 200 && colour[2] > 200, "barcode png colours %ld %ld %ld", colour[0], colour[1], colour[2]);
  mgs_diagram_destroy(d);
}

static void test_plots(void) {
  const char *dir = mgs_test_tmpdir("plots");
  check_outputs(dir, "sub", 0, 300);
  check_outputs(dir, "super", 1, 300);
  check_outputs(dir, "many", 0, 5000); /* more bars than MGS_PLOT_MAX_BARS */
}

static void test_edge_cases(void) {
  const char *dir = mgs_test_tmpdir("plots_edge");
  mgs_error e;
  char path[4200];
  /* empty diagram and a single point: still valid files */
  mgs_diagram *d = mgs_diagram_create();
  snprintf(path, sizeof path, "%s/empty.png", dir);
  CHECK_OK(mgs_diagram_plot(d, path, "empty", &e), &e);
  CHECK(file_size(path) > 1000);
  snprintf(path, sizeof path, "%s/empty_bar.svg", dir);
  CHECK_OK(mgs_diagram_plot_barcode(d, path, "empty", &e), &e);
  mgs_pair p;
  memset(&p, 0, sizeof p);
  p.birth = 2.0; p.death = 2.0;
  mgs_diagram_push(d, &p, NULL);
  snprintf(path, sizeof path, "%s/one.png", dir);
  CHECK_OK(mgs_diagram_plot(d, path, "one", &e), &e);
  /* wrong extension: error naming the file, nothing written */
  snprintf(path, sizeof path, "%s/plot.jpg", dir);
  CHECK(mgs_diagram_plot(d, path, "x", &e) == MGS_ERR_ARG && strstr(e.msg, "plot.jpg"));
  CHECK(!mgs_path_exists(path));
  /* unwritable directory */
  CHECK(mgs_diagram_plot(d, "/nonexistent_dir/x.png", "x", &e) != MGS_OK && strstr(e.msg, "/nonexistent_dir"));
  mgs_diagram_destroy(d);
}

int main(void) {
  RUN(test_plots);
  RUN(test_edge_cases);
  mgs_diagram_plot_release();
  return mgs_test_finish();
}

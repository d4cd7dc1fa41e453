/* DIR/REPORT.html of `morsegs demo`: the page to open. Self-contained (no network, no
 * script): images by relative links into DIR, the PSNR-vs-time chart as inline SVG.
 * Holds the figures table of REPORT.md (converted from its text, so the two never
 * disagree), render | GT | error of a few test views (the PNGs `morsegs eval` writes into RUN/eval/),
 * the persistence diagram and barcode (RUN/persistence/), and pictures of the extracted
 * surface (RUN/surface.ply) rendered by the scene's Embree renderer into DIR/surface_views/.
 * What a stage did not write is said in the page, never left as a broken image. */
#include <dirent.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "apps/cmd_demo.h"
#include "apps/mgs_cli.h"
#include "core/mgs_fs.h"
#include "core/mgs_image.h"
#include "core/mgs_mesh.h"
#include "render/mgs_scene.h"

enum { EVAL_VIEWS = 3, SURFACE_VIEWS = 3, SURFACE_SIZE = 256 };

/* Text with &, <, > escaped; `code` spans as <code>. */
static void put_text(FILE *f, const char *s, size_t n) {
  int code = 0;
  for (size_t i = 0; i < n && s[i]; i++) {
    char c = s[i];
    if (c == '&') fputs("&amp;", f);
    else if (c == '<') fputs("&lt;", f);
    else if (c == '>') fputs("&gt;", f);
    else if (c == '`') { fputs(code ? "</code>" : "<code>", f); code = !code; }
    else fputc(c, f);
  }
  if (code) fputs("</code>", f);
}

/* Text for an attribute value: &, <, >, " escaped. */
static void put_attr(FILE *f, const char *s) {
  for (; *s; s++) {
    if (*s == '&') fputs("&amp;", f);
    else if (*s == '<') fputs("&lt;", f);
    else if (*s == '>') fputs("&gt;", f);
    else if (*s == '"') fputs("&quot;", f);
    else fputc(*s, f);
  }
}

/* The Markdown of REPORT.md as HTML: "# " headings, tables of "| a | b |" lines (the
 * "|---|" line ends the header), every other line a paragraph. */
static void put_markdown(FILE *f, const char *md) {
  int in_table = 0, header = 0;
  for (const char *line = md; line && *line;) {
    const char *e = strchr(line, '\n');
    size_t n = e ? (size_t)(e - line) : strlen(line);
    if (n > 0 && line[0] == '|') {
      if (!in_table) { fputs("<table>\n", f); in_table = 1; header = 1; }
      if (n >= 4 && !strncmp(line, "|---", 4)) { header = 0; goto next; }
      fputs("<tr>", f);
      const char *p = line + 1, *end = line + n;
      while (p < end) {
        const char *q = memchr(p, '|', (size_t)(end - p));
        if (!q) break;
        const char *a = p, *b = q;
        while (a < b && *a == ' ') a++;
        while (b > a && b[-1] == ' ') b--;
        fputs(header ? "<th>" : "<td>", f);
        put_text(f, a, (size_t)(b - a));
        fputs(header ? "</th>" : "</td>", f);
        p = q + 1;
      }
      fputs("</tr>\n", f);
    } else {
      if (in_table) { fputs("</table>\n", f); in_table = 0; }
      if (n >= 2 && !strncmp(line, "# ", 2)) { fputs("<h1>", f); put_text(f, line + 2, n - 2); fputs("</h1>\n", f); }
      else if (n > 0) { fputs("<p>", f); put_text(f, line, n); fputs("</p>\n", f); }
    }
  next:
    line = e ? e + 1 : NULL;
  }
  if (in_table) fputs("</table>\n", f);
}

static int cmp_str(const void *a, const void *b) { return strcmp(*(char *const *)a, *(char *const *)b); }

/* Up to `max` PNG names in dir, sorted; returns how many (names malloc'd). */
static int list_pngs(const char *dir, char **names, int max) {
  DIR *d = dir ? opendir(dir) : NULL;
  if (!d) return 0;
  char *all[512];
  int n = 0;
  for (struct dirent *e; (e = readdir(d)) != NULL && n < 512;) {
    size_t len = strlen(e->d_name);
    if (len > 4 && !strcmp(e->d_name + len - 4, ".png")) all[n] = strdup(e->d_name), n += all[n] != NULL;
  }
  closedir(d);
  qsort(all, (size_t)n, sizeof *all, cmp_str);
  int k = n < max ? n : max;
  for (int i = 0; i < n; i++) {
    if (i < k) names[i] = all[i];
    else free(all[i]);
  }
  return k;
}

/* Renders RUN/surface.ply into DIR/surface_views/run<k>_view_<i>.png (white background);
 * returns the number written, 0 with a reason in `why`. */
static int surface_views(const char *out_dir, int k, const char *run_dir, char *why, size_t why_n) {
  char *ply = mgs_path_join(run_dir, "surface.ply"), *dir = mgs_path_join(out_dir, "surface_views");
  mgs_mesh *m = NULL;
  mgs_image *views[SURFACE_VIEWS] = {0};
  mgs_error err;
  mgs_error_clear(&err);
  int written = 0;
  mgs_status s = ply && dir ? MGS_OK : mgs_error_set(&err, MGS_ERR_NOMEM, "out of memory");
  if (s == MGS_OK && !mgs_path_exists(ply)) s = mgs_error_set(&err, MGS_ERR_IO, "%s: not written (the vdb stage did not run)", ply);
  if (s == MGS_OK) s = mgs_mesh_read(ply, &m, &err);
  if (s == MGS_OK) s = mgs_scene_render_mesh_views(m, SURFACE_VIEWS, SURFACE_SIZE, views, &err);
  if (s == MGS_OK) s = mgs_mkdir_p(dir, &err);
  static const float white[3] = {1, 1, 1};
  for (int i = 0; i < SURFACE_VIEWS && s == MGS_OK; i++) {
    char name[32];
    snprintf(name, sizeof name, "run%d_view_%d.png", k, i);
    char *path = mgs_path_join(dir, name);
    mgs_image *rgb = mgs_image_composite(views[i], white);
    s = path && rgb ? mgs_image_write(path, rgb, &err) : mgs_error_set(&err, MGS_ERR_NOMEM, "out of memory");
    written += s == MGS_OK;
    mgs_image_destroy(rgb);
    free(path);
  }
  if (s != MGS_OK) { snprintf(why, why_n, "%s", err.msg); written = 0; }
  for (int i = 0; i < SURFACE_VIEWS; i++) mgs_image_destroy(views[i]);
  mgs_mesh_destroy(m);
  free(ply);
  free(dir);
  return written;
}

/* PSNR against training wall time, one point per run (the runs evaluate once, at the end). */
static void put_chart(FILE *f, const demo_ctx *ctx, const demo_html_figs *figs) {
  double tmax = 0, pmin = INFINITY, pmax = -INFINITY;
  int n = 0;
  for (int i = 0; i < ctx->n_runs; i++)
    if (isfinite(figs[i].psnr) && isfinite(figs[i].train_s)) {
      n++;
      if (figs[i].train_s > tmax) tmax = figs[i].train_s;
      if (figs[i].psnr < pmin) pmin = figs[i].psnr;
      if (figs[i].psnr > pmax) pmax = figs[i].psnr;
    }
  fputs("<h2>PSNR against training wall time</h2>\n", f);
  if (n == 0) { fputs("<p>No run wrote both results.json (PSNR) and train_stats.json (wall time).</p>\n", f); return; }
  pmin = floor(pmin - 1), pmax = ceil(pmax + 1), tmax = tmax * 1.15 + 1e-9;
  const double W = 480, H = 260, L = 60, B = 40, T = 15, R = 20;
  fprintf(f, "<svg width=\"%.0f\" height=\"%.0f\" viewBox=\"0 0 %.0f %.0f\" role=\"img\">\n", W, H, W, H);
  fprintf(f, "<rect x=\"%g\" y=\"%g\" width=\"%g\" height=\"%g\" fill=\"#f4f6fa\" stroke=\"#888\"/>\n", L, T, W - L - R, H - T - B);
  fprintf(f, "<text x=\"%g\" y=\"%g\" text-anchor=\"middle\" font-size=\"13\">training wall time (s), 0 to %.0f</text>\n",
          (L + W - R) / 2, H - 8, tmax);
  fprintf(f, "<text x=\"14\" y=\"%g\" transform=\"rotate(-90 14 %g)\" text-anchor=\"middle\" font-size=\"13\">PSNR (dB), %.0f to %.0f</text>\n",
          (T + H - B) / 2, (T + H - B) / 2, pmin, pmax);
  static const char *colors[DEMO_RUNS] = {"#1f5fbf", "#c0392b"};
  for (int i = 0; i < ctx->n_runs; i++) {
    if (!isfinite(figs[i].psnr) || !isfinite(figs[i].train_s)) continue;
    double x = L + (W - L - R) * figs[i].train_s / tmax, y = T + (H - T - B) * (pmax - figs[i].psnr) / (pmax - pmin);
    fprintf(f, "<circle cx=\"%.1f\" cy=\"%.1f\" r=\"7\" fill=\"%s\"/>\n", x, y, colors[i]);
    int right = x > (L + W - R) / 2; /* label on the side with room */
    fprintf(f, "<text x=\"%.1f\" y=\"%.1f\" font-size=\"12\" text-anchor=\"%s\">%s: %.2f dB, %.1f s</text>\n",
            right ? x - 10 : x + 10, y - 8, right ? "end" : "start", ctx->runs[i].label, figs[i].psnr, figs[i].train_s);
  }
  fputs("</svg>\n<p>One point per run: the demo evaluates each model once, after training; there are no "
        "intermediate evaluations to draw a curve from.</p>\n", f);
}

static void put_img(FILE *f, const char *subdir, const char *rel, const char *alt, const char *cls) {
  fprintf(f, "<img class=\"%s\" src=\"", cls);
  if (subdir) put_attr(f, subdir), fputc('/', f);
  put_attr(f, rel);
  fprintf(f, "\" alt=\"%s\">\n", alt);
}

static void put_run(FILE *f, const char *out_dir, int k, const demo_run *r) {
  fputs("<h2>", f);
  put_attr(f, r->label);
  fputs(" (<code>", f);
  put_attr(f, r->subdir);
  fputs("/</code>)</h2>\n<h3>Test views: render | ground truth | error (x5)</h3>\n", f);
  char *eval_dir = r->run_dir ? mgs_path_join(r->run_dir, "eval") : NULL, *names[EVAL_VIEWS];
  int n = list_pngs(eval_dir, names, EVAL_VIEWS);
  if (n == 0) fputs("<p>No images in eval/ (the eval stage did not run).</p>\n", f);
  for (int i = 0; i < n; i++) {
    char rel[600];
    snprintf(rel, sizeof rel, "eval/%s", names[i]);
    put_img(f, r->subdir, rel, "render | GT | error", "wide");
    free(names[i]);
  }
  free(eval_dir);
  fputs("<h3>Persistence of the SDF: diagram and barcode</h3>\n", f);
  int any = 0;
  static const char *plots[2] = {"persistence/diagram.png", "persistence/barcode.png"};
  for (int j = 0; j < 2; j++) {
    char *p = r->run_dir ? mgs_path_join(r->run_dir, plots[j]) : NULL;
    if (p && mgs_path_exists(p)) put_img(f, r->subdir, plots[j], plots[j], "plot"), any = 1;
    free(p);
  }
  if (!any) fputs("<p>No plots in persistence/ (the persistence stage did not run).</p>\n", f);
  fputs("<h3>Surface (<code>surface.ply</code>, the α-surface of <code>morsegs vdb --mesh</code>), rendered with Embree</h3>\n", f);
  char why[1100] = "";
  int nv = r->run_dir ? surface_views(out_dir, k, r->run_dir, why, sizeof why) : 0;
  if (nv == 0) { fputs("<p>No pictures: ", f); put_text(f, why, strlen(why)); fputs("</p>\n", f); }
  for (int i = 0; i < nv; i++) {
    char rel[64];
    snprintf(rel, sizeof rel, "surface_views/run%d_view_%d.png", k, i);
    put_img(f, NULL, rel, "surface", "view");
  }
}

int demo_report_html(const demo_ctx *ctx, const char *md, const demo_html_figs figs[DEMO_RUNS]) {
  char *text = NULL;
  size_t len = 0;
  FILE *f = open_memstream(&text, &len);
  if (!f) { fprintf(stderr, "morsegs demo: out of memory for the report\n"); return 1; }
  fputs("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>MorseGS report</title>\n"
        "<style>body{font-family:sans-serif;margin:24px;max-width:1200px;color:#222;background:#fff}"
        "table{border-collapse:collapse;margin:12px 0}td,th{border:1px solid #bbb;padding:4px 8px;text-align:left;"
        "vertical-align:top;font-size:14px}th{background:#dde4f0}tr:nth-child(even) td{background:#f3f5f9}"
        "img.wide{width:576px;image-rendering:pixelated;display:block;margin:4px 0}"
        "img.plot{width:420px;margin:4px}img.view{width:256px;margin:4px;border:1px solid #ccc}"
        "code{background:#eef;padding:0 3px}</style></head><body>\n", f);
  put_markdown(f, md);
  put_chart(f, ctx, figs);
  for (int i = 0; i < ctx->n_runs; i++) put_run(f, ctx->out_dir, i, &ctx->runs[i]);
  fputs("</body></html>\n", f);
  int failed = ferror(f);
  fclose(f);
  mgs_error err;
  mgs_error_clear(&err);
  char *path = mgs_path_join(ctx->out_dir, "REPORT.html");
  mgs_status st = path && !failed && text ? mgs_write_file_atomic(path, text, len, &err)
                                          : mgs_error_set(&err, MGS_ERR_NOMEM, "out of memory");
  if (st == MGS_OK) printf("  wrote %s\n", path);
  free(path);
  free(text);
  return st == MGS_OK ? 0 : mgs_cli_fail(ctx->report_only ? "report" : "demo", &err);
}

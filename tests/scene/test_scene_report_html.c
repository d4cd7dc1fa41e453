/* `morsegs demo`'s REPORT.html, looked at in a real browser: a small demo (few iterations)
 * writes the page, its stdout names the file to open; every <img src> of the page is a
 * relative path to a file in the output folder that decodes as an image (the eval views,
 * persistence plots and Embree pictures of the surface of both runs); headless Chromium
 * (Debian's `chromium`, scripts/setup.sh) loads the page from disk and its screenshot is
 * not blank and shows the pictures (a share of saturated pixels, which text and tables
 * do not have). Then the check is shown to bite: with one image moved away it fails.
 * `morsegs report` of the demo's two runs into another folder links the same images. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include "mgs_test.h"
#include "scene_test_util.h"
#include "core/mgs_fs.h"
#include "core/mgs_image.h"

/* Checks every <img src="..."> of the page: relative (to root), decodes. Returns the
 * number of images that pass, -1 if any fails (reported); *first gets the first src. */
static int check_images(const char *root, const char *html, char *first, size_t first_n) {
  int ok = 0, bad = 0;
  if (first_n) first[0] = 0;
  for (const char *p = html; (p = strstr(p, "<img ")) != NULL;) {
    const char *s = strstr(p, "src=\""), *end = strchr(p, '>');
    p += 5;
    if (!s || (end && s > end)) { fprintf(stderr, "an <img> without src\n"); bad++; continue; }
    s += 5;
    const char *q = strchr(s, '"');
    if (!q || q - s >= 512) { bad++; continue; }
    char src[512], path[2048];
    memcpy(src, s, (size_t)(q - s));
    src[q - s] = 0;
    if (first_n && !first[0]) snprintf(first, first_n, "%s", src);
    if (src[0] == '/' || strstr(src, "://")) { fprintf(stderr, "src not relative: %s\n", src); bad++; continue; }
    snprintf(path, sizeof path, "%s/%s", root, src);
    mgs_image *img = NULL;
    mgs_error err;
    mgs_error_clear(&err);
    if (mgs_image_read(path, &img, &err) != MGS_OK || img->width < 8 || img->height < 8) {
      fprintf(stderr, "image of the page missing or not decodable: %s (%s)\n", path, err.msg);
      bad++;
    } else ok++;
    mgs_image_destroy(img);
  }
  return bad ? -1 : ok;
}

typedef struct { int w, h; double inked, colour, var; } shot_figs;

/* Headless Chromium's screenshot of `page` (1200x2000) into `shot`, and its figures:
 * share of pixels inked (luminance < 0.9: neither white nor the near-white table
 * stripes), share in colour (max - min channel > 0.25: the pictures; text and tables are
 * grey), luminance variance. 0 on success. */
static int screenshot(const char *tmp, const char *page, const char *shot, const char *log, shot_figs *sf) {
  char cmd[4096];
  memset(sf, 0, sizeof *sf);
  remove(shot);
  snprintf(cmd, sizeof cmd, "timeout 180 chromium --headless --no-sandbox --disable-gpu --hide-scrollbars "
           "--user-data-dir='%s/chromium' --screenshot='%s' --window-size=1200,2000 'file://%s'", tmp, shot, page);
  if (run_cmd(cmd, log) != 0 || !mgs_path_exists(shot)) return 1;
  mgs_image *img = NULL;
  mgs_error err;
  mgs_error_clear(&err);
  if (mgs_image_read(shot, &img, &err) != MGS_OK) { fprintf(stderr, "%s\n", err.msg); return 1; }
  size_t n = (size_t)img->width * img->height, inked = 0, colour = 0;
  double sum = 0, sum2 = 0;
  for (size_t i = 0; i < n; i++) {
    const float *px = img->data + i * img->channels;
    double l = (px[0] + px[1] + px[2]) / 3.0;
    sum += l, sum2 += l * l;
    inked += l < 0.9;
    float hi = px[0] > px[1] ? px[0] : px[1], lo = px[0] < px[1] ? px[0] : px[1];
    hi = hi > px[2] ? hi : px[2], lo = lo < px[2] ? lo : px[2];
    colour += hi - lo > 0.25f;
  }
  double mean = sum / n;
  *sf = (shot_figs){img->width, img->height, (double)inked / n, (double)colour / n, sum2 / n - mean * mean};
  mgs_image_destroy(img);
  return 0;
}

int main(void) {
  const char *cli = getenv("MGS_CLI");
  if (!cli) { fprintf(stderr, "MGS_CLI not set\n"); return 1; }
  char cwd[512], tmp[1024], root[1100], log_path[1200], page[1200], shot[1200];
  if (!getcwd(cwd, sizeof cwd)) return 1;
  snprintf(tmp, sizeof tmp, "%s/%s", cwd, mgs_test_tmpdir("scene_report_html"));
  snprintf(root, sizeof root, "%s/out", tmp);
  snprintf(log_path, sizeof log_path, "%s/demo_log.txt", tmp);
  snprintf(page, sizeof page, "%s/REPORT.html", root);
  snprintf(shot, sizeof shot, "%s/shot.png", tmp);
  char cmd[8192];
  snprintf(cmd, sizeof cmd, "'%s' demo -o '%s' --iters 60", cli, root);
  CHECK(run_cmd(cmd, log_path) == 0);
  char open_line[1400];
  snprintf(open_line, sizeof open_line, "open %s\n", page);
  CHECK_MSG(file_contains(log_path, open_line), "the demo's stdout does not say \"%s\"\n", open_line);

  char *html = NULL;
  mgs_error err;
  mgs_error_clear(&err);
  CHECK_OK(mgs_read_file(page, &html, NULL, &err), &err);
  if (!html) return mgs_test_finish();
  CHECK(strstr(html, "<table>") && strstr(html, "PSNR (test views)") && strstr(html, "<svg"));
  CHECK_MSG(!strstr(html, "http://") && !strstr(html, "https://") && !strstr(html, "<script"), "the page reaches out\n");
  char first[512];
  int n_img = check_images(root, html, first, sizeof first);
  /* per run: 3 eval views, diagram and barcode, 3 surface pictures; two runs */
  CHECK_MSG(n_img == 16, "%d images on the page pass (16 expected)\n", n_img);
  CHECK(strstr(html, "run/eval/") && strstr(html, "run-morse/persistence/barcode.png") &&
        strstr(html, "surface_views/run1_view_2.png"));

  /* the browser: the page loads from disk and is not blank */
  shot_figs sf;
  CHECK_MSG(screenshot(tmp, page, shot, log_path, &sf) == 0,
            "headless chromium gave no screenshot (install Debian's chromium: scripts/setup.sh); see %s\n", log_path);
  fprintf(stderr, "screenshot %dx%d: %.1f %% of pixels inked, %.2f %% in colour, luminance variance %.4f\n", sf.w, sf.h,
          100.0 * sf.inked, 100.0 * sf.colour, sf.var);
  CHECK(sf.w == 1200 && sf.h == 2000);
  CHECK_MSG(sf.inked > 0.05, "the screenshot is nearly blank (%.2f %% of pixels inked)\n", 100.0 * sf.inked);
  CHECK_MSG(sf.colour > 0.005, "the screenshot shows no pictures (%.3f %% of pixels in colour)\n", 100.0 * sf.colour);
  CHECK_MSG(sf.var > 0.01, "the screenshot has no contrast (variance %g)\n", sf.var);
  /* the colour share bites: the same page with its <img> turned into <br> (text, tables
     and chart kept) falls under it */
  char bare[1300];
  snprintf(bare, sizeof bare, "%s/bare.html", root);
  char *copy = strdup(html);
  for (char *p = copy; p && (p = strstr(p, "<img ")) != NULL;) memcpy(p, "<br  ", 5);
  CHECK(copy && mgs_write_file_atomic(bare, copy, strlen(copy), &err) == MGS_OK);
  free(copy);
  CHECK(screenshot(tmp, bare, shot, log_path, &sf) == 0);
  fprintf(stderr, "without pictures: %.1f %% inked, %.3f %% in colour\n", 100.0 * sf.inked, 100.0 * sf.colour);
  CHECK_MSG(sf.colour < 0.005, "the page without pictures passes the colour check (%.3f %%)\n", 100.0 * sf.colour);

  /* the check bites: one image of the page moved away -> it fails */
  char from[1700], to[1800];
  snprintf(from, sizeof from, "%s/%s", root, first);
  snprintf(to, sizeof to, "%s.away", from);
  CHECK(first[0] && rename(from, to) == 0);
  fprintf(stderr, "expected failure follows:\n");
  CHECK_MSG(check_images(root, html, first, 0) == -1, "the page check passed with %s missing\n", from);
  CHECK(rename(to, from) == 0);
  /* `morsegs report` of the same two runs into another folder: the page links them there */
  char rep[1200], rep_page[1300];
  snprintf(rep, sizeof rep, "%s/rep", tmp);
  snprintf(rep_page, sizeof rep_page, "%s/REPORT.html", rep);
  snprintf(cmd, sizeof cmd, "'%s' report '%s/run' '%s/run-morse' -o '%s'", cli, root, root, rep);
  CHECK(run_cmd(cmd, log_path) == 0);
  snprintf(open_line, sizeof open_line, "open %s\n", rep_page);
  CHECK_MSG(file_contains(log_path, open_line), "`morsegs report` does not say \"%s\"\n", open_line);
  char *rep_html = NULL;
  CHECK_OK(mgs_read_file(rep_page, &rep_html, NULL, &err), &err);
  if (rep_html) {
    CHECK(strstr(rep_html, "PSNR (test views)") && strstr(rep_html, "src=\"../out/run-morse/eval/"));
    int n_rep = check_images(rep, rep_html, first, 0);
    CHECK_MSG(n_rep == 16, "%d images on the report's page pass (16 expected)\n", n_rep);
  }
  free(rep_html);
  snprintf(cmd, sizeof cmd, "'%s' report '%s/none' -o '%s'", cli, root, rep);
  CHECK(run_cmd(cmd, log_path) == 1);
  snprintf(cmd, sizeof cmd, "'%s' report '%s/run'", cli, root);
  CHECK(run_cmd(cmd, log_path) == 2);
  CHECK(check_images(root, html, first, 0) == n_img);
  free(html);
  return mgs_test_finish();
}

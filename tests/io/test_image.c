/* Image I/O through OIIO (PNG, JPEG, EXR), compositing and downscaling. */
#include <unistd.h>

#include "core/mgs_image.h"
#include "mgs_test.h"

static const char *dir;
static char pbuf[4096];
static const char *tmp_path(const char *name) {
  snprintf(pbuf, sizeof pbuf, "%s/%s", dir, name);
  return pbuf;
}

static mgs_image *pattern(int w, int h, int ch) {
  mgs_image *img = mgs_image_create(w, h, ch);
  for (int y = 0; y < h; y++)
    for (int x = 0; x < w; x++)
      for (int c = 0; c < ch; c++) img->data[((size_t)y * w + x) * ch + c] = (float)((x * 7 + y * 13 + c * 50) % 256) / 255.0f;
  return img;
}

static void test_png_exr_jpg(void) {
  mgs_error err = {0};
  mgs_image *img = pattern(37, 21, 4);
  CHECK_OK(mgs_image_write(tmp_path("a.png"), img, &err), &err);
  mgs_image *back = NULL;
  CHECK_OK(mgs_image_read(tmp_path("a.png"), &back, &err), &err);
  if (back) {
    CHECK(back->width == 37 && back->height == 21 && back->channels == 4);
    double maxd = 0;
    for (size_t i = 0; i < 37 * 21 * 4; i++) maxd = fmax(maxd, fabs(back->data[i] - img->data[i]));
    CHECK_NEAR(maxd, 0, 1e-6); /* k/255 values survive 8 bits exactly */
    /* top row first: pixel (x=3, y=2), channel 1 */
    CHECK_NEAR(back->data[(2 * 37 + 3) * 4 + 1], (float)((3 * 7 + 2 * 13 + 50) % 256) / 255.0f, 1e-6);
    mgs_image_destroy(back);
  }
  int w, h, c;
  CHECK_OK(mgs_image_read_size(tmp_path("a.png"), &w, &h, &c, &err), &err);
  CHECK(w == 37 && h == 21 && c == 4);

  mgs_image *f = pattern(8, 5, 3);
  f->data[0] = 12.345678f;
  f->data[1] = -0.125f;
  CHECK_OK(mgs_image_write(tmp_path("b.exr"), f, &err), &err);
  back = NULL;
  CHECK_OK(mgs_image_read(tmp_path("b.exr"), &back, &err), &err);
  if (back) {
    CHECK(back->channels == 3 && memcmp(back->data, f->data, sizeof(float) * 8 * 5 * 3) == 0);
    mgs_image_destroy(back);
  }
  CHECK_OK(mgs_image_write(tmp_path("c.jpg"), f, &err), &err);
  back = NULL;
  CHECK_OK(mgs_image_read(tmp_path("c.jpg"), &back, &err), &err);
  if (back) {
    CHECK(back->width == 8 && back->height == 5 && back->channels == 3);
    mgs_image_destroy(back);
  }
  /* No temporary files left behind. */
  char cmd[4200];
  snprintf(cmd, sizeof cmd, "ls -A '%s' | grep -q tmp", dir);
  CHECK(system(cmd) != 0);
  mgs_image_destroy(f);
  mgs_image_destroy(img);
}

static void test_bad(void) {
  mgs_error err = {0};
  mgs_image *img = NULL;
  CHECK(mgs_image_read(tmp_path("missing.png"), &img, &err) == MGS_ERR_IO && !img);
  CHECK_MSG(strstr(err.msg, "missing.png") != NULL, "%s", err.msg);
  FILE *fp = fopen(tmp_path("garbage.png"), "wb");
  fputs("this is not a png file at all", fp);
  fclose(fp);
  CHECK(mgs_image_read(tmp_path("garbage.png"), &img, &err) != MGS_OK && !img);
  CHECK_MSG(strstr(err.msg, "garbage.png") != NULL, "%s", err.msg);
  /* A truncated PNG. */
  mgs_image *p = pattern(64, 64, 3);
  CHECK_OK(mgs_image_write(tmp_path("full.png"), p, &err), &err);
  fp = fopen(tmp_path("full.png"), "rb");
  char buf[100000];
  size_t n = fread(buf, 1, sizeof buf, fp);
  fclose(fp);
  fp = fopen(tmp_path("trunc.png"), "wb");
  fwrite(buf, 1, n / 2, fp);
  fclose(fp);
  CHECK(mgs_image_read(tmp_path("trunc.png"), &img, &err) != MGS_OK && !img);
  CHECK_MSG(strstr(err.msg, "trunc.png") != NULL, "%s", err.msg);
  CHECK(mgs_image_write(tmp_path("no_such_dir/x.png"), p, &err) == MGS_ERR_IO);
  CHECK_MSG(strstr(err.msg, "x.png") != NULL, "%s", err.msg);
  mgs_image_destroy(p);
}

static void test_composite_downscale(void) {
  mgs_image *rgba = mgs_image_create(4, 2, 4);
  for (int i = 0; i < 8; i++) {
    rgba->data[i * 4 + 0] = 1.0f;
    rgba->data[i * 4 + 1] = 0.5f;
    rgba->data[i * 4 + 2] = 0.0f;
    rgba->data[i * 4 + 3] = (float)i / 7.0f;
  }
  const float white[3] = {1, 1, 1}, black[3] = {0, 0, 0};
  mgs_image *w = mgs_image_composite(rgba, white), *b = mgs_image_composite(rgba, black);
  CHECK(w && b && w->channels == 3);
  for (int i = 0; i < 8; i++) {
    float a = (float)i / 7.0f;
    CHECK_NEAR(w->data[i * 3 + 0], 1.0, 1e-6);
    CHECK_NEAR(w->data[i * 3 + 1], 0.5 * a + (1 - a), 1e-6);
    CHECK_NEAR(w->data[i * 3 + 2], 1 - a, 1e-6);
    CHECK_NEAR(b->data[i * 3 + 1], 0.5 * a, 1e-6);
    CHECK_NEAR(b->data[i * 3 + 2], 0, 1e-6);
  }
  mgs_image *d = mgs_image_downscale(w, 2);
  CHECK(d && d->width == 2 && d->height == 1);
  if (d) {
    /* block (x 0..1, y 0..1) = pixels 0, 1, 4, 5 */
    double e = 0;
    for (int k = 0; k < 4; k++) { int i = (int[]){0, 1, 4, 5}[k]; e += w->data[i * 3 + 2]; }
    CHECK_NEAR(d->data[2], e / 4, 1e-6);
  }
  mgs_image *odd = mgs_image_create(5, 3, 1);
  mgs_image *d2 = mgs_image_downscale(odd, 2);
  CHECK(d2 && d2->width == 2 && d2->height == 1);
  CHECK(mgs_image_downscale(odd, 4) == NULL); /* smaller than one block */
  mgs_image_destroy(d2);
  mgs_image_destroy(odd);
  mgs_image_destroy(d);
  mgs_image_destroy(w);
  mgs_image_destroy(b);
  mgs_image_destroy(rgba);
  CHECK(mgs_image_create(0, 5, 3) == NULL);
}

int main(void) {
  dir = mgs_test_tmpdir("io_image");
  RUN(test_png_exr_jpg);
  RUN(test_bad);
  RUN(test_composite_downscale);
  return mgs_test_finish();
}

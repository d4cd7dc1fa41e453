/* mgs_image_resize_bicubic against PIL's Image.resize(..., BICUBIC) itself (Debian's
 * python3-pil), which the reference 3DGS uses for every training image: shrinking by
 * integer and non-integer ratios (antialiased kernel), enlarging, one axis only. PIL works
 * in 8 bits with a rounded intermediate, so values agree within ~1/255, not exactly. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>
#include "tests/mgs_test.h"
#include "core/mgs_core.h"

/* Debian's interpreter (where python3-pil lives), unless MGS_PYTHON names another */
static const char *python(void) {
  const char *p = getenv("MGS_PYTHON");
  if (p && *p) return p;
  return access("/usr/bin/python3", X_OK) == 0 ? "/usr/bin/python3" : "python3";
}

static int have_pil(void) {
  char cmd[256];
  snprintf(cmd, sizeof cmd, "%s -c 'import PIL.Image' >/dev/null 2>&1", python());
  return system(cmd) == 0;
}

static void check_against_pil(const mgs_image *src, const char *src_png, int w, int h) {
  char out_png[256], cmd[1024];
  snprintf(out_png, sizeof out_png, "%s.%dx%d.png", src_png, w, h);
  snprintf(cmd, sizeof cmd,
           "%s -c \"import sys; from PIL import Image; "
           "Image.open(sys.argv[1]).convert('RGB').resize((%d, %d), Image.BICUBIC).save(sys.argv[2])\" '%s' '%s'",
           python(), w, h, src_png, out_png);
  CHECK(system(cmd) == 0);
  mgs_image *pil = NULL;
  mgs_error err = {0};
  CHECK_OK(mgs_image_read(out_png, &pil, &err), &err);
  mgs_image *ours = mgs_image_resize_bicubic(src, w, h);
  CHECK(ours && pil && pil->width == w && pil->height == h && pil->channels == 3);
  if (ours && pil && pil->width == w && pil->height == h && pil->channels == 3) {
    double maxd = 0, sum = 0;
    size_t n = (size_t)w * (size_t)h * 3;
    for (size_t i = 0; i < n; i++) {
      double d = fabs(ours->data[i] - pil->data[i]);
      maxd = fmax(maxd, d);
      sum += d;
    }
    printf("  %dx%d -> %dx%d: max |ours - PIL| = %.2f/255, mean %.3f/255\n", src->width, src->height, w, h, maxd * 255,
           sum / (double)n * 255);
    CHECK(maxd <= 2.0 / 255);
    CHECK(sum / (double)n <= 0.5 / 255);
  }
  mgs_image_destroy(ours);
  mgs_image_destroy(pil);
}

static void test_against_pil(void) {
  if (!have_pil()) {
    /* setup.sh installs python3-pil; a machine without it cannot run this comparison */
    CHECK(!"python3-pil is not installed (scripts/setup.sh installs it)");
    return;
  }
  /* a smooth gradient plus sharp edges plus noise: every part of the kernel matters */
  const int W = 57, H = 43;
  mgs_image *img = mgs_image_create(W, H, 3);
  mgs_rng rng;
  mgs_rng_init(&rng, 7, 1);
  for (int y = 0; y < H; y++)
    for (int x = 0; x < W; x++)
      for (int c = 0; c < 3; c++) {
        double v = c == 0 ? (double)x / W : c == 1 ? ((x / 6 + y / 5) % 2) : mgs_rng_uniform(&rng);
        img->data[((size_t)y * W + (size_t)x) * 3 + (size_t)c] = (float)(round(v * 255.0) / 255.0); /* 8-bit exact */
      }
  char png[] = "/tmp/mgs_resize_XXXXXX";
  int fd = mkstemp(png);
  CHECK(fd >= 0);
  if (fd >= 0) close(fd);
  char path[64];
  snprintf(path, sizeof path, "%s.png", png);
  mgs_error err = {0};
  CHECK_OK(mgs_image_write(path, img, &err), &err);
  check_against_pil(img, path, 28, 21);  /* ~2x */
  check_against_pil(img, path, 19, 14);  /* 3x, the kernel three times wider */
  check_against_pil(img, path, 40, 30);  /* non-integer ratio */
  check_against_pil(img, path, 57, 20);  /* one axis */
  check_against_pil(img, path, 80, 61);  /* enlarging: the plain kernel */
  mgs_image_destroy(img);
  remove(png);
}

int main(void) {
  RUN(test_against_pil);
  return mgs_test_finish();
}

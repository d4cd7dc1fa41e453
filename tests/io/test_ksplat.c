/* GaussianSplats3D's .ksplat read as a 3DGS model (core/ksplat_format.h). lever600.l0.ksplat
 * and lever600.l2.ksplat were written by GaussianSplats3D 0.4.7's own SplatBufferGenerator
 * (npm, node; compression levels 0 and 2, SH degree 2, alpha removal threshold 1, block 5,
 * buckets of 256) from lever600.splat-transform.ply: level 0 (float32) is checked against
 * that source, matched splat by splat through the exact positions (the writer drops
 * near-transparent splats and reorders the rest by bucket); level 2 (float16, bucketed 16-bit
 * positions, 8-bit SH) against splat-transform 2.7.1's decoding of the same file
 * (lever600.l2.ksplat.splat-transform.ply). Damaged copies are refused naming the file. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mgs_fs.h"
#include "core/mgs_gaussians.h"
#include "core/mgs_ply.h"
#include "mgs_test.h"

static const char *dir;
static char path_buf[4096], data_buf[4096];
static const char *tmp_path(const char *name) {
  snprintf(path_buf, sizeof path_buf, "%s/%s", dir, name);
  return path_buf;
}
static const char *data_path(const char *name) {
  const char *src = getenv("MGS_SOURCE_DIR");
  snprintf(data_buf, sizeof data_buf, "%s/tests/io/data/%s", src ? src : ".", name);
  return data_buf;
}
static mgs_gaussians *read_ok(const char *path) {
  mgs_error err = {0};
  mgs_gaussians *g = NULL;
  CHECK_OK(mgs_ply_read_gaussians(path, &g, &err), &err);
  return g;
}
static double sigmoid(double x) { return 1.0 / (1.0 + exp(-x)); }

static void test_level2_against_splat_transform(void) {
  mgs_gaussians *g = read_ok(data_path("lever600.l2.ksplat")), *ref = read_ok(data_path("lever600.l2.ksplat.splat-transform.ply"));
  if (!g || !ref) goto done;
  CHECK(g->n == 588 && ref->n == 588 && g->sh_degree == 2 && ref->sh_degree == 2);
  double worst[6] = {0};
  for (size_t i = 0; i < g->n && i < ref->n; i++) {
    for (int k = 0; k < 3; k++) {
      worst[0] = fmax(worst[0], fabs(g->mean[3 * i + k] - ref->mean[3 * i + k]));
      worst[1] = fmax(worst[1], fabs(g->log_scale[3 * i + k] - ref->log_scale[3 * i + k]));
      worst[2] = fmax(worst[2], fabs(g->sh_dc[3 * i + k] - ref->sh_dc[3 * i + k]));
    }
    double len = 0; /* the reference keeps the stored (float16) quaternion as it is */
    for (int k = 0; k < 4; k++) len += (double)ref->rot[4 * i + k] * ref->rot[4 * i + k];
    for (int k = 0; k < 4; k++) worst[3] = fmax(worst[3], fabs(g->rot[4 * i + k] - ref->rot[4 * i + k] / sqrt(len)));
    if (fabs(ref->opacity[i]) < 5.5) worst[4] = fmax(worst[4], fabs(g->opacity[i] - ref->opacity[i]));
    for (int k = 0; k < MGS_SH_REST_MAX; k++)
      worst[5] = fmax(worst[5], fabs(g->sh_rest[i * MGS_SH_REST_MAX + k] - ref->sh_rest[i * MGS_SH_REST_MAX + k]));
  }
  const double tol[6] = {2e-6, 2e-6, 2e-6, 2e-6, 2e-5, 2e-6};
  const char *names[6] = {"mean", "log_scale", "f_dc", "rot", "opacity", "f_rest"};
  for (int q = 0; q < 6; q++) CHECK_MSG(worst[q] <= tol[q], "%s: largest difference to splat-transform %g", names[q], worst[q]);
done:
  mgs_gaussians_destroy(g);
  mgs_gaussians_destroy(ref);
}

static void test_level0_against_source(void) {
  mgs_gaussians *g = read_ok(data_path("lever600.l0.ksplat")), *src = read_ok(data_path("lever600.splat-transform.ply"));
  if (!g || !src) goto done;
  CHECK(g->n == 588 && g->sh_degree == 2 && src->sh_degree == 3);
  size_t matched = 0;
  double worst[6] = {0};
  for (size_t i = 0; i < g->n; i++) {
    size_t j = 0;
    while (j < src->n && memcmp(g->mean + 3 * i, src->mean + 3 * j, 3 * sizeof(float))) j++;
    if (j == src->n) continue;
    matched++;
    for (int k = 0; k < 3; k++) {
      worst[0] = fmax(worst[0], fabs(g->log_scale[3 * i + k] - src->log_scale[3 * j + k]));
      const double dc = src->sh_dc[3 * j + k];
      if (fabs(dc) < 1.7) worst[1] = fmax(worst[1], fabs(g->sh_dc[3 * i + k] - dc)); /* the byte's range */
    }
    double len = 0, dot = 0;
    for (int k = 0; k < 4; k++) len += (double)src->rot[4 * j + k] * src->rot[4 * j + k];
    for (int k = 0; k < 4; k++) dot += g->rot[4 * i + k] * src->rot[4 * j + k] / sqrt(len);
    worst[2] = fmax(worst[2], 1.0 - fabs(dot));
    worst[3] = fmax(worst[3], fabs(sigmoid(g->opacity[i]) - sigmoid(src->opacity[j])));
    /* degrees 1 and 2 (8 coefficients per channel) as stored; degree 3 dropped */
    for (int k = 0; k < 8; k++)
      for (int c = 0; c < 3; c++)
        worst[4] = fmax(worst[4], fabs(g->sh_rest[i * MGS_SH_REST_MAX + 3 * k + c] - src->sh_rest[j * MGS_SH_REST_MAX + 3 * k + c]));
    for (int k = 24; k < MGS_SH_REST_MAX; k++) worst[5] = fmax(worst[5], fabs(g->sh_rest[i * MGS_SH_REST_MAX + k]));
  }
  CHECK_MSG(matched == g->n, "%zu of %zu splats found in the source by position", matched, g->n);
  /* the writer truncates colour and opacity to their byte (measured: up to one whole quantum) */
  const double tol[6] = {1e-6, 1.0 / 255 / 0.28209479177387814 + 1e-5, 1e-6, 1.0 / 255 + 1e-6, 1e-6, 0};
  const char *names[6] = {"log_scale", "f_dc", "rot (1 - |dot|)", "opacity (after the sigmoid)", "f_rest degrees 1-2", "f_rest degree 3"};
  for (int q = 0; q < 6; q++) CHECK_MSG(worst[q] <= tol[q], "%s: largest difference to the source %g", names[q], worst[q]);
done:
  mgs_gaussians_destroy(g);
  mgs_gaussians_destroy(src);
}

/* lever600.l2.ksplat with `len` bytes at `at` replaced (and the file cut at `size` if > 0). */
static const char *damaged(const char *name, size_t at, const void *bytes, size_t len, size_t size) {
  char *data = NULL;
  size_t n = 0;
  mgs_error err = {0};
  CHECK_OK(mgs_read_file(data_path("lever600.l2.ksplat"), &data, &n, &err), &err);
  if (!data) return tmp_path(name);
  if (bytes) memcpy(data + at, bytes, len);
  FILE *f = fopen(tmp_path(name), "wb");
  fwrite(data, 1, size ? size : n, f);
  fclose(f);
  free(data);
  return tmp_path(name);
}

static void expect_refused(const char *path, const char *needle) {
  mgs_error err = {0};
  mgs_gaussians *g = NULL;
  const mgs_status st = mgs_ply_read_gaussians(path, &g, &err);
  CHECK_MSG(st != MGS_OK && g == NULL, "%s: read although damaged", path);
  CHECK_MSG(strstr(err.msg, path) != NULL, "message '%s' does not name %s", err.msg, path);
  /* the needle is looked for after the file name (a folder named like it must not pass) */
  const char *rest = strstr(err.msg, path) ? strstr(err.msg, path) + strlen(path) : err.msg;
  CHECK_MSG(strstr(rest, needle) != NULL, "%s: message '%s' lacks '%s'", path, err.msg, needle);
  mgs_gaussians_destroy(g);
}

static void test_refused(void) {
  const uint8_t v1[2] = {1, 0}, level3[2] = {3, 0}, count[4] = {0x4d, 0x02, 0, 0}, deg[2] = {4, 0}, zero4[4] = {0};
  expect_refused(damaged("version.ksplat", 0, v1, 2, 0), "version 1.0");
  expect_refused(damaged("level.ksplat", 20, level3, 2, 0), "compression level 3");
  expect_refused(damaged("count.ksplat", 16, count, 4, 0), "the sections hold 588 splats, the header counts 589");
  expect_refused(damaged("degree.ksplat", 4096 + 40, deg, 2, 0), "SH degree 4");
  expect_refused(damaged("cut.ksplat", 0, NULL, 0, 20000), "does not fit");
  expect_refused(damaged("header.ksplat", 0, NULL, 0, 4000), "header alone");
  expect_refused(damaged("sections.ksplat", 4, (const uint8_t[4]){0xff, 0xff, 0, 0}, 4, 0), "section headers do not fit");
  expect_refused(damaged("nobuckets.ksplat", 4096 + 12, zero4, 4, 0), "does not fit");
}

int main(void) {
  dir = mgs_test_tmpdir("io_ksplat");
  RUN(test_level2_against_splat_transform);
  RUN(test_level0_against_source);
  RUN(test_refused);
  return mgs_test_finish();
}

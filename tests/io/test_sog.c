/* PlayCanvas's SOG read as a 3DGS model (core/sog_format.h). lever600.sog is `splat-transform
 * -g cpu lever600.splat-transform.ply lever600.sog` (splat-transform 2.7.1 from npm; SH by
 * k-means into a 512-entry palette) and lever600.sog.splat-transform.ply splat-transform's
 * decoding of it back to a .ply: ours must equal it. The bundle unpacked into a folder reads
 * the same through its meta.json; edited copies of that meta.json (other versions, counts,
 * codebooks, file names, palette sizes) and missing textures are refused naming the file. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <unzip.h>

#include "core/mgs_fs.h"
#include "core/mgs_gaussians.h"
#include "core/mgs_ply.h"
#include "mgs_test.h"

static const char *dir;
static char path_buf[4096];
static const char *tmp_path(const char *name) {
  snprintf(path_buf, sizeof path_buf, "%s/%s", dir, name);
  return path_buf;
}
static char data_buf[4096];
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

/* Every entry of the bundle into folder `sub` of the scratch directory. */
static int unpack(const char *bundle, const char *sub) {
  char out[4096];
  snprintf(out, sizeof out, "%s/%s", dir, sub);
  mgs_error err = {0};
  CHECK_OK(mgs_mkdir_p(out, &err), &err);
  unzFile z = unzOpen64(bundle);
  CHECK(z != NULL);
  if (!z) return 0;
  int files = 0;
  for (int r = unzGoToFirstFile(z); r == UNZ_OK; r = unzGoToNextFile(z)) {
    char name[256], p[4400];
    unz_file_info64 info;
    unzGetCurrentFileInfo64(z, &info, name, sizeof name, NULL, 0, NULL, 0);
    char *buf = malloc(info.uncompressed_size + 1);
    unzOpenCurrentFile(z);
    const int got = unzReadCurrentFile(z, buf, (unsigned)info.uncompressed_size);
    unzCloseCurrentFile(z);
    CHECK(got == (int)info.uncompressed_size);
    snprintf(p, sizeof p, "%s/%s", out, name);
    FILE *f = fopen(p, "wb");
    fwrite(buf, 1, info.uncompressed_size, f);
    fclose(f);
    free(buf);
    files++;
  }
  unzClose(z);
  return files;
}

static void compare(const mgs_gaussians *g, const mgs_gaussians *ref, const char *what) {
  CHECK(g->n == ref->n && g->sh_degree == ref->sh_degree);
  double worst[6] = {0};
  for (size_t i = 0; i < g->n && i < ref->n; i++) {
    for (int k = 0; k < 3; k++) {
      worst[0] = fmax(worst[0], fabs(g->mean[3 * i + k] - ref->mean[3 * i + k]));
      worst[1] = fmax(worst[1], fabs(g->log_scale[3 * i + k] - ref->log_scale[3 * i + k]));
      worst[2] = fmax(worst[2], fabs(g->sh_dc[3 * i + k] - ref->sh_dc[3 * i + k]));
    }
    for (int k = 0; k < 4; k++) worst[3] = fmax(worst[3], fabs(g->rot[4 * i + k] - ref->rot[4 * i + k]));
    /* opacity bytes 0 and 255: here half a quantum inside, there 1e-6 (logit +-13.8) */
    if (fabs(ref->opacity[i]) < 5.5) worst[4] = fmax(worst[4], fabs(g->opacity[i] - ref->opacity[i]));
    for (int k = 0; k < MGS_SH_REST_MAX; k++)
      worst[5] = fmax(worst[5], fabs(g->sh_rest[i * MGS_SH_REST_MAX + k] - ref->sh_rest[i * MGS_SH_REST_MAX + k]));
  }
  const double tol[6] = {2e-6, 1e-6, 1e-6, 2e-6, 2e-5, 1e-6};
  const char *names[6] = {"mean", "log_scale", "f_dc", "rot", "opacity", "f_rest"};
  for (int q = 0; q < 6; q++) CHECK_MSG(worst[q] <= tol[q], "%s: %s: largest difference %g", what, names[q], worst[q]);
}

static void test_against_splat_transform(void) {
  mgs_gaussians *g = read_ok(data_path("lever600.sog")), *ref = read_ok(data_path("lever600.sog.splat-transform.ply"));
  if (g && ref) {
    CHECK(g->n == 600 && g->sh_degree == 3 && g->kind == MGS_MODEL_3DGS);
    compare(g, ref, "bundle");
  }
  /* the same files as a folder, through its meta.json */
  CHECK(unpack(data_path("lever600.sog"), "folder") == 8);
  mgs_gaussians *f = read_ok(tmp_path("folder/meta.json"));
  if (f && ref) compare(f, ref, "folder");
  mgs_gaussians_destroy(g);
  mgs_gaussians_destroy(f);
  mgs_gaussians_destroy(ref);
}

/* The unpacked folder's meta.json with `from` replaced by `to` written into folder `sub`. */
static const char *edited(const char *sub, const char *from, const char *to) {
  static char meta[4096];
  char *text = NULL;
  size_t n = 0;
  mgs_error err = {0};
  CHECK_OK(mgs_read_file(tmp_path("folder/meta.json"), &text, &n, &err), &err);
  CHECK(unpack(data_path("lever600.sog"), sub) == 8);
  char *at = text ? strstr(text, from) : NULL;
  CHECK_MSG(at != NULL, "meta.json has no '%s'", from);
  snprintf(meta, sizeof meta, "%s/%s/meta.json", dir, sub);
  FILE *fp = fopen(meta, "wb");
  if (at) {
    fwrite(text, 1, (size_t)(at - text), fp);
    fputs(to, fp);
    fputs(at + strlen(from), fp);
  }
  fclose(fp);
  free(text);
  return meta;
}

static void expect_refused(const char *path, const char *needle) {
  mgs_error err = {0};
  mgs_gaussians *g = NULL;
  const mgs_status st = mgs_ply_read_gaussians(path, &g, &err);
  CHECK_MSG(st != MGS_OK && g == NULL, "%s: read although malformed", path);
  CHECK_MSG(strstr(err.msg, path) != NULL, "message '%s' does not name %s", err.msg, path);
  /* the needle is looked for after the file name (a folder named like it must not pass) */
  const char *rest = strstr(err.msg, path) ? strstr(err.msg, path) + strlen(path) : err.msg;
  CHECK_MSG(strstr(rest, needle) != NULL, "%s: message '%s' lacks '%s'", path, err.msg, needle);
  mgs_gaussians_destroy(g);
}

static void test_refused(void) {
  CHECK(unpack(data_path("lever600.sog"), "folder") == 8);
  expect_refused(edited("v1", "\"version\":2,", ""), "version 1");
  expect_refused(edited("v3", "\"version\":2", "\"version\":3"), "SOG version 3");
  expect_refused(edited("count0", "\"count\":600", "\"count\":0"), "'count'");
  expect_refused(edited("count_big", "\"count\":600", "\"count\":100000"), "texels");
  expect_refused(edited("traversal", "\"quats.webp\"", "\"../folder/quats.webp\""), "plain file name");
  expect_refused(edited("missing", "\"quats.webp\"", "\"nothing.webp\""), "'nothing.webp' is missing");
  expect_refused(edited("codebook", "\"scales\":{\"codebook\":[", "\"scales\":{\"codebook\":[1,"), "'codebook' of 256");
  expect_refused(edited("palette", "\"shN\":{\"count\":512", "\"shN\":{\"count\":1"), "SH palette label");
  expect_refused(edited("rows", "\"shN\":{\"count\":512", "\"shN\":{\"count\":4000"), "60000 Gaussians need that many texels");
  expect_refused(edited("bands", "\"bands\":3", "\"bands\":2"), "texels wide");
  expect_refused(edited("json", "{\"version\"", "[\"version\""), "not valid JSON");
  /* a texture that is not a WebP image */
  const char *m = edited("garbage", "\"count\":600", "\"count\":600");
  (void)m;
  FILE *g = fopen(tmp_path("garbage/quats.webp"), "wb");
  fputs("RIFF....WEBPnothing", g);
  fclose(g);
  expect_refused(tmp_path("garbage/meta.json"), "'quats.webp' is not a WebP image");
  /* a bundle cut short: its directory at the end is gone */
  char *zip = NULL;
  size_t zn = 0;
  mgs_error err = {0};
  CHECK_OK(mgs_read_file(data_path("lever600.sog"), &zip, &zn, &err), &err);
  if (zip) {
    FILE *c = fopen(tmp_path("cut.sog"), "wb");
    fwrite(zip, 1, zn / 2, c);
    fclose(c);
    expect_refused(tmp_path("cut.sog"), "not a zip bundle");
    free(zip);
  }
  /* a bundle that is not a zip, one without meta.json, a missing one */
  FILE *f = fopen(tmp_path("text.sog"), "wb");
  fputs("not a zip", f);
  fclose(f);
  expect_refused(tmp_path("text.sog"), "not a zip bundle");
  expect_refused(tmp_path("none.sog"), "cannot open");
  expect_refused(tmp_path("folder/nothing/meta.json"), "cannot open");
}

int main(void) {
  dir = mgs_test_tmpdir("io_sog");
  RUN(test_against_splat_transform);
  RUN(test_refused);
  return mgs_test_finish();
}

/* SuperSplat / splat-transform's compressed .ply (core/ply_compressed.h) and the web
 * viewers' .splat (core/splat_format.h) read as 3DGS models. The compressed file: against splat-transform's own decompression of the same file (an independent
 * reader: lever600.splat-transform.ply is `splat-transform lever600.compressed.ply
 * lever600.splat-transform.ply`, splat-transform 2.7.1 from npm, of 600 Gaussians of a
 * trained 200² model of gmsh-doc's lever, SH degree 3); hand-packed values at the ends of
 * every range (opacity 0 and 255 stay finite); malformed layouts refused naming the file.
 * The .splat: lever600.splat is lever600.splat-transform.ply written as antimatter15's
 * convert script writes (linear scales; colour, opacity and rotation bytes truncated), read
 * back within those quanta; bad sizes and scales refused naming the file. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core/mgs_gaussians.h"
#include "core/mgs_ply.h"
#include "mgs_test.h"

static const char *dir;
static char path_buf[4096];
static const char *tmp_path(const char *name) {
  snprintf(path_buf, sizeof path_buf, "%s/%s", dir, name);
  return path_buf;
}

/* Reads tests/io/data/NAME and the 3DGS file it is checked against (splat-transform's
 * decompression of the compressed file, which the .splat was also written from). */
static int read_with_reference(const char *name, mgs_gaussians **g, mgs_gaussians **ref) {
  *g = *ref = NULL;
  const char *src = getenv("MGS_SOURCE_DIR");
  CHECK(src != NULL);
  if (!src) return 0;
  char a[4096], b[4096];
  snprintf(a, sizeof a, "%s/tests/io/data/%s", src, name);
  snprintf(b, sizeof b, "%s/tests/io/data/lever600.splat-transform.ply", src);
  mgs_error err = {0};
  CHECK_OK(mgs_ply_read_gaussians(a, g, &err), &err);
  CHECK_OK(mgs_ply_read_gaussians(b, ref, &err), &err);
  return *g && *ref;
}

static void test_against_splat_transform(void) {
  mgs_gaussians *g = NULL, *ref = NULL;
  if (!read_with_reference("lever600.compressed.ply", &g, &ref)) goto done;
  CHECK(g->n == 600 && ref->n == 600);
  CHECK(g->sh_degree == 3 && ref->sh_degree == 3);
  CHECK(g->kind == MGS_MODEL_3DGS);
  double worst[6] = {0};
  for (size_t i = 0; i < g->n && i < ref->n; i++) {
    for (int k = 0; k < 3; k++) {
      worst[0] = fmax(worst[0], fabs(g->mean[3 * i + k] - ref->mean[3 * i + k]));
      worst[1] = fmax(worst[1], fabs(g->log_scale[3 * i + k] - ref->log_scale[3 * i + k]));
      worst[2] = fmax(worst[2], fabs(g->sh_dc[3 * i + k] - ref->sh_dc[3 * i + k]));
    }
    for (int k = 0; k < 4; k++) worst[3] = fmax(worst[3], fabs(g->rot[4 * i + k] - ref->rot[4 * i + k]));
    worst[4] = fmax(worst[4], fabs(g->opacity[i] - ref->opacity[i]));
    for (int k = 0; k < 45; k++) worst[5] = fmax(worst[5], fabs(g->sh_rest[i * MGS_SH_REST_MAX + k] - ref->sh_rest[i * MGS_SH_REST_MAX + k]));
  }
  /* both decode in double and store float: a float ulp or two at these magnitudes */
  const double tol[6] = {1e-6, 2e-6, 2e-6, 1e-6, 2e-6, 1e-6};
  const char *names[6] = {"mean", "log_scale", "f_dc", "rot", "opacity", "f_rest"};
  for (int q = 0; q < 6; q++) CHECK_MSG(worst[q] <= tol[q], "%s: largest difference to splat-transform %g", names[q], worst[q]);
done:
  mgs_gaussians_destroy(g);
  mgs_gaussians_destroy(ref);
}

/* A compressed file by hand: `chunk_props` float columns per chunk, then the vertices'
 * packed words, then (n_sh > 0) n_sh uchar columns per vertex. */
static void write_compressed(const char *path, int n_chunks, int chunk_props, const float *chunks, int n, const uint32_t *packed,
                             int n_sh, const uint8_t *sh, const char *packed_type) {
  static const char *cn[18] = {"min_x", "min_y", "min_z", "max_x", "max_y", "max_z", "min_scale_x", "min_scale_y", "min_scale_z",
                               "max_scale_x", "max_scale_y", "max_scale_z", "min_r", "min_g", "min_b", "max_r", "max_g", "max_b"};
  FILE *f = fopen(path, "wb");
  fprintf(f, "ply\nformat binary_little_endian 1.0\nelement chunk %d\n", n_chunks);
  for (int k = 0; k < chunk_props; k++) fprintf(f, "property float %s\n", cn[k]);
  fprintf(f, "element vertex %d\nproperty %s packed_position\nproperty uint packed_rotation\nproperty uint packed_scale\n"
             "property uint packed_color\n", n, packed_type);
  if (n_sh) {
    fprintf(f, "element sh %d\n", n);
    for (int k = 0; k < n_sh; k++) fprintf(f, "property uchar f_rest_%d\n", k);
  }
  fputs("end_header\n", f);
  fwrite(chunks, sizeof(float), (size_t)(n_chunks * chunk_props), f);
  fwrite(packed, sizeof(uint32_t), (size_t)(4 * n), f);
  if (n_sh) fwrite(sh, 1, (size_t)(n * n_sh), f);
  fclose(f);
}

static double logit(double w) { return -log(1.0 / w - 1.0); }

static void test_hand_packed(void) {
  const float chunk[18] = {-1, -2, -3, 1, 2, 3, -5, -6, -7, -1, -2, -3, 0.1f, 0.2f, 0.3f, 0.9f, 0.8f, 0.7f};
  /* vertex 0: every fraction 0, rotation index 2 with the others at 0 (t = 511/1023, not
     exactly 1/2: the decode's value is checked, not an assumed one), colour 0, alpha 0;
     vertex 1: every fraction 1, rotation index 0, colour 255, alpha 255; vertex 2: mid */
  const uint32_t packed[12] = {
      0u, (2u << 30) | (511u << 20) | (511u << 10) | 511u, 0u, 0u,
      0xffffffffu, (0u << 30) | (1023u << 20) | (0u << 10) | 1023u, 0xffffffffu, 0xffffffffu,
      (1024u << 21) | (512u << 11) | 1024u, (3u << 30) | (600u << 20) | (300u << 10) | 700u, (1024u << 21) | (512u << 11) | 1024u,
      (128u << 24) | (64u << 16) | (32u << 8) | 200u};
  uint8_t sh[3 * 9];
  for (int i = 0; i < 27; i++) sh[i] = i < 9 ? 0 : i < 18 ? 255 : (uint8_t)(100 + i);
  mgs_error err = {0};
  mgs_gaussians *g = NULL;
  for (int colors = 0; colors < 2; colors++) {
    const char *p = tmp_path(colors ? "hand_colors.ply" : "hand.ply");
    write_compressed(p, 1, colors ? 18 : 12, chunk, 3, packed, 9, sh, "uint");
    CHECK_OK(mgs_ply_read_gaussians(p, &g, &err), &err);
    if (!g) continue;
    CHECK(g->n == 3 && g->sh_degree == 1);
    const double C0 = 0.28209479177387814;
    for (int k = 0; k < 3; k++) {
      CHECK_NEAR(g->mean[k], chunk[k], 1e-6);             /* fraction 0: the chunk's min */
      CHECK_NEAR(g->mean[3 + k], chunk[3 + k], 1e-6);     /* fraction 1: its max */
      CHECK_NEAR(g->log_scale[k], chunk[6 + k], 1e-6);
      CHECK_NEAR(g->log_scale[3 + k], chunk[9 + k], 1e-6);
      const double lo = colors ? chunk[12 + k] : 0.0, hi = colors ? chunk[15 + k] : 1.0;
      CHECK_NEAR(g->sh_dc[k], (lo - 0.5) / C0, 1e-5);
      CHECK_NEAR(g->sh_dc[3 + k], (hi - 0.5) / C0, 1e-5);
    }
    CHECK_NEAR(g->mean[6], -1 + 2 * 1024.0 / 2047.0, 1e-6); /* 11 bits */
    CHECK_NEAR(g->mean[7], -2 + 4 * 512.0 / 1023.0, 1e-6);  /* 10 bits */
    /* rotation: the largest component from the unit norm, at the stored index */
    const double t = (511.0 / 1023.0 - 0.5) * sqrt(2.0);
    CHECK_NEAR(g->rot[2], sqrt(1 - 3 * t * t), 1e-6);
    CHECK_NEAR(g->rot[0], t, 1e-6);
    const double q1 = 0.5 * sqrt(2.0); /* 1023 -> +1/sqrt2, 0 -> -1/sqrt2 */
    CHECK_NEAR(g->rot[4 + 1], q1, 1e-6);
    CHECK_NEAR(g->rot[4 + 2], -q1, 1e-6);
    CHECK_NEAR(g->rot[4 + 0], 0.0, 1e-3); /* 1 - 1/2 - 1/2 - 1/2 < 0: clamped to 0 */
    double norm = 0;
    for (int k = 0; k < 4; k++) norm += g->rot[8 + k] * g->rot[8 + k];
    CHECK_NEAR(norm, 1.0, 1e-5);
    /* opacity: alpha 0 and 255 stay finite at half a quantum from 0 and 1 */
    CHECK(isfinite(g->opacity[0]) && isfinite(g->opacity[1]));
    CHECK_NEAR(g->opacity[0], logit(0.5 / 255.0), 1e-4);
    CHECK_NEAR(g->opacity[1], logit(1.0 - 0.5 / 255.0), 1e-4);
    CHECK_NEAR(g->opacity[2], logit(200.0 / 255.0), 1e-5);
    /* SH rest: channel-major in the file, [k][c] in memory; 0 -> -4, 255 -> +4 */
    for (int j = 0; j < 9; j++) {
      const int c = j / 3, k = j % 3;
      CHECK_NEAR(g->sh_rest[0 * MGS_SH_REST_MAX + k * 3 + c], -4.0, 1e-6);
      CHECK_NEAR(g->sh_rest[1 * MGS_SH_REST_MAX + k * 3 + c], 4.0, 1e-6);
      CHECK_NEAR(g->sh_rest[2 * MGS_SH_REST_MAX + k * 3 + c], ((118 + j + 0.5) / 256.0 - 0.5) * 8.0, 1e-6);
    }
    mgs_gaussians_destroy(g);
    g = NULL;
  }
}

static void expect_refused(const char *name, const char *needle) {
  mgs_gaussians *g = NULL;
  mgs_error err = {0};
  const mgs_status st = mgs_ply_read_gaussians(tmp_path(name), &g, &err);
  CHECK_MSG(st != MGS_OK && g == NULL, "%s: read", name);
  CHECK_MSG(strstr(err.msg, name) != NULL, "%s: message '%s' does not name the file", name, err.msg);
  CHECK_MSG(strstr(err.msg, needle) != NULL, "%s: message '%s' lacks '%s'", name, err.msg, needle);
}

static void test_refused(void) {
  float chunks[2 * 18] = {0};
  uint32_t packed[4 * 300] = {0};
  uint8_t sh[300 * 45] = {0};
  write_compressed(tmp_path("two_chunks_for_3.ply"), 2, 12, chunks, 3, packed, 0, sh, "uint");
  expect_refused("two_chunks_for_3.ply", "expected 1");
  write_compressed(tmp_path("one_chunk_for_300.ply"), 1, 12, chunks, 300, packed, 0, sh, "uint");
  expect_refused("one_chunk_for_300.ply", "expected 2");
  write_compressed(tmp_path("float_packed.ply"), 1, 12, chunks, 3, packed, 0, sh, "float");
  expect_refused("float_packed.ply", "packed_position");
  write_compressed(tmp_path("sh10.ply"), 1, 12, chunks, 3, packed, 10, sh, "uint");
  expect_refused("sh10.ply", "expected 9, 24 or 45");
  write_compressed(tmp_path("three_colors.ply"), 1, 15, chunks, 3, packed, 0, sh, "uint");
  expect_refused("three_colors.ply", "colour bounds");
  write_compressed(tmp_path("no_max_z.ply"), 1, 5, chunks, 3, packed, 0, sh, "uint");
  expect_refused("no_max_z.ply", "max_z");
  /* cut short: the vertex rows the header promises are not in the file */
  write_compressed(tmp_path("short.ply"), 2, 12, chunks, 300, packed, 0, sh, "uint");
  FILE *f = fopen(tmp_path("short.ply"), "r+b");
  fseek(f, 0, SEEK_END);
  const long len = ftell(f);
  fclose(f);
  CHECK(truncate(tmp_path("short.ply"), len - 2000) == 0);
  mgs_gaussians *g = NULL;
  mgs_error err = {0};
  CHECK(mgs_ply_read_gaussians(tmp_path("short.ply"), &g, &err) != MGS_OK && g == NULL);
  CHECK_MSG(strstr(err.msg, "short.ply") != NULL, "short: '%s'", err.msg);
}

static double sigmoid(double x) { return 1.0 / (1.0 + exp(-x)); }

static void test_splat(void) {
  mgs_gaussians *g = NULL, *ref = NULL;
  if (!read_with_reference("lever600.splat", &g, &ref)) goto done;
  CHECK(g->n == 600 && g->sh_degree == 0 && g->kind == MGS_MODEL_3DGS);
  const double C0 = 0.28209479177387814;
  double worst[5] = {0};
  size_t compared = 0;
  for (size_t i = 0; i < g->n && i < ref->n; i++) {
    double qn = 0, dot = 0;
    for (int k = 0; k < 4; k++) qn += (double)ref->rot[4 * i + k] * ref->rot[4 * i + k];
    for (int k = 0; k < 4; k++) dot += g->rot[4 * i + k] * ref->rot[4 * i + k] / sqrt(qn);
    worst[3] = fmax(worst[3], 1 - fabs(dot));
    for (int k = 0; k < 3; k++) {
      worst[0] = fmax(worst[0], fabs(g->mean[3 * i + k] - ref->mean[3 * i + k]));
      worst[1] = fmax(worst[1], fabs(g->log_scale[3 * i + k] - ref->log_scale[3 * i + k]));
      const double c = 0.5 + C0 * ref->sh_dc[3 * i + k];
      if (c > 0 && c < 1) worst[2] = fmax(worst[2], fabs(g->sh_dc[3 * i + k] - ref->sh_dc[3 * i + k]) * C0); /* in colour */
    }
    const double al = sigmoid(ref->opacity[i]);
    if (al > 1.0 / 255 && al < 254.0 / 255) worst[4] = fmax(worst[4], fabs(sigmoid(g->opacity[i]) - al)), compared++;
  }
  CHECK_MSG(worst[0] == 0, "positions are float32 in the file: %g", worst[0]);
  CHECK_MSG(worst[1] <= 1e-6, "log scales: %g", worst[1]);
  CHECK_MSG(worst[2] <= 1.0 / 255 + 1e-6, "colour: %g (one byte: %g)", worst[2], 1.0 / 255);
  CHECK_MSG(worst[3] <= 5e-4, "rotation: 1 - |cos| = %g", worst[3]);
  CHECK_MSG(worst[4] <= 1.0 / 255 + 1e-6, "opacity: %g", worst[4]);
  CHECK(compared > 300);
done:
  mgs_gaussians_destroy(g);
  mgs_gaussians_destroy(ref);
  /* refused: not a multiple of 32 bytes, empty, a zero scale */
  unsigned char rec[64] = {0};
  float one = 1.0f;
  for (int k = 0; k < 3; k++) memcpy(rec + 12 + 4 * k, &one, 4);
  rec[28] = 255;
  FILE *f = fopen(tmp_path("odd.splat"), "wb");
  fwrite(rec, 1, 33, f);
  fclose(f);
  expect_refused("odd.splat", "multiple of 32");
  f = fopen(tmp_path("empty.splat"), "wb");
  fclose(f);
  expect_refused("empty.splat", "multiple of 32");
  memcpy(rec + 32, rec, 32);
  memset(rec + 32 + 16, 0, 4); /* splat 1, scale 1 = 0 */
  f = fopen(tmp_path("flat.splat"), "wb");
  fwrite(rec, 1, 64, f);
  fclose(f);
  expect_refused("flat.splat", "splat 1: scale 1");
}

int main(void) {
  dir = mgs_test_tmpdir("io_ply_compressed");
  RUN(test_against_splat_transform);
  RUN(test_hand_packed);
  RUN(test_refused);
  RUN(test_splat);
  return mgs_test_finish();
}

/* Niantic's .spz read as a 3DGS model (core/spz_format.h), against independent writers
 * and readers of the format:
 * - lever600.spz (version 4, zstd) and lever600.v3.spz (version 3, gzip) are
 *   `splat-transform [--spz-version 3] lever600.splat-transform.ply OUT` (splat-transform
 *   2.7.1 from npm, which packs with Niantic's library compiled to WebAssembly);
 *   lever600.spz.splat-transform.ply is splat-transform's decoding of lever600.spz back to
 *   a .ply (the same library unpacking, to the .ply's frame). Ours must equal it.
 * - lever600.spz-js.v2.spz is spz-js 1.2.5's `serializeSpz` of the same .ply (version 2:
 *   the first three quaternion components; no frame conversion, so it reads back rotated
 *   by pi about x): checked against the source .ply within the format's quanta.
 * Then hand-packed files of every version (float16 positions, both quaternion codes, SH
 * degree 4, the coordinate-system extension, the ends of every byte range) and malformed
 * ones, each refused naming the file. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>
#include <zstd.h>

#include "core/mgs_gaussians.h"
#include "core/mgs_ply.h"
#include "mgs_test.h"

static const char *dir;
static char path_buf[4096];
static const char *tmp_path(const char *name) {
  snprintf(path_buf, sizeof path_buf, "%s/%s", dir, name);
  return path_buf;
}

static mgs_gaussians *read_data(const char *name) {
  const char *src = getenv("MGS_SOURCE_DIR");
  CHECK(src != NULL);
  if (!src) return NULL;
  char p[4096];
  snprintf(p, sizeof p, "%s/tests/io/data/%s", src, name);
  mgs_error err = {0};
  mgs_gaussians *g = NULL;
  CHECK_OK(mgs_ply_read_gaussians(p, &g, &err), &err);
  return g;
}

static void test_against_splat_transform(void) {
  mgs_gaussians *g = read_data("lever600.spz"), *v3 = read_data("lever600.v3.spz");
  mgs_gaussians *ref = read_data("lever600.spz.splat-transform.ply");
  if (!g || !v3 || !ref) goto done;
  CHECK(g->n == 600 && ref->n == 600 && v3->n == 600);
  CHECK(g->sh_degree == 3 && ref->sh_degree == 3 && g->kind == MGS_MODEL_3DGS);
  double worst[6] = {0};
  for (size_t i = 0; i < g->n && i < ref->n; i++) {
    for (int k = 0; k < 3; k++) {
      worst[0] = fmax(worst[0], fabs(g->mean[3 * i + k] - ref->mean[3 * i + k]));
      worst[1] = fmax(worst[1], fabs(g->log_scale[3 * i + k] - ref->log_scale[3 * i + k]));
      worst[2] = fmax(worst[2], fabs(g->sh_dc[3 * i + k] - ref->sh_dc[3 * i + k]));
    }
    for (int k = 0; k < 4; k++) worst[3] = fmax(worst[3], fabs(g->rot[4 * i + k] - ref->rot[4 * i + k]));
    worst[4] = fmax(worst[4], fabs(g->opacity[i] - ref->opacity[i]));
    for (int k = 0; k < 45; k++)
      worst[5] = fmax(worst[5], fabs(g->sh_rest[i * MGS_SH_REST_MAX + k] - ref->sh_rest[i * MGS_SH_REST_MAX + k]));
  }
  /* both decode the same bytes; the reference in float, we in double then float */
  const double tol[6] = {1e-6, 2e-6, 2e-6, 2e-6, 2e-5, 1e-6};
  const char *names[6] = {"mean", "log_scale", "f_dc", "rot", "opacity", "f_rest"};
  for (int q = 0; q < 6; q++) CHECK_MSG(worst[q] <= tol[q], "%s: largest difference to splat-transform %g", names[q], worst[q]);
  /* version 3 holds the same packed values as version 4, in one gzip stream */
  if (v3->n == g->n) {
    CHECK(!memcmp(v3->mean, g->mean, g->n * 3 * sizeof(float)));
    CHECK(!memcmp(v3->rot, g->rot, g->n * 4 * sizeof(float)));
    CHECK(!memcmp(v3->sh_rest, g->sh_rest, g->n * MGS_SH_REST_MAX * sizeof(float)));
    CHECK(!memcmp(v3->opacity, g->opacity, g->n * sizeof(float)));
  }
done:
  mgs_gaussians_destroy(g);
  mgs_gaussians_destroy(v3);
  mgs_gaussians_destroy(ref);
}

static double sigmoid(double x) { return 1.0 / (1.0 + exp(-x)); }

/* spz-js wrote the .ply's values unconverted; the reader takes them as RUB, so it returns
 * the source rotated by pi about x: y and z negated, and the SH basis signs with them. */
static void test_spz_js_v2(void) {
  static const double fsh[15] = {-1, -1, 1, -1, 1, 1, -1, 1, -1, 1, -1, -1, 1, -1, 1};
  mgs_gaussians *g = read_data("lever600.spz-js.v2.spz"), *src = read_data("lever600.splat-transform.ply");
  if (!g || !src) goto done;
  CHECK(g->n == 600 && src->n == 600 && g->sh_degree == 3);
  double worst[6] = {0};
  for (size_t i = 0; i < g->n && i < src->n; i++) {
    const double fp[3] = {1, -1, -1};
    for (int k = 0; k < 3; k++) {
      worst[0] = fmax(worst[0], fabs(g->mean[3 * i + k] - fp[k] * src->mean[3 * i + k]));
      const double s = src->log_scale[3 * i + k], dc = src->sh_dc[3 * i + k];
      if (s > -10 && s < 5.9) worst[1] = fmax(worst[1], fabs(g->log_scale[3 * i + k] - s));
      if (fabs(dc) < 3.3) worst[2] = fmax(worst[2], fabs(g->sh_dc[3 * i + k] - dc));
    }
    double q[4], len = 0;
    for (int k = 0; k < 4; k++) len += (double)src->rot[4 * i + k] * src->rot[4 * i + k];
    const double sg = src->rot[4 * i] < 0 ? -1 : 1; /* the writer keeps w >= 0 */
    for (int k = 0; k < 4; k++) q[k] = sg * src->rot[4 * i + k] / sqrt(len) * (k >= 2 ? -1 : 1);
    for (int k = 1; k < 4; k++) worst[3] = fmax(worst[3], fabs(g->rot[4 * i + k] - q[k]));
    if (q[0] > 0.2) worst[3] = fmax(worst[3], fabs(g->rot[4 * i] - q[0]));
    worst[4] = fmax(worst[4], fabs(sigmoid(g->opacity[i]) - sigmoid(src->opacity[i])));
    for (int k = 0; k < 15; k++)
      for (int c = 0; c < 3; c++) {
        const double v = src->sh_rest[i * MGS_SH_REST_MAX + 3 * k + c];
        if (fabs(v) < 0.95) worst[5] = fmax(worst[5], fabs(g->sh_rest[i * MGS_SH_REST_MAX + 3 * k + c] - fsh[k] * v));
      }
  }
  /* the quanta: 1/4096 fixed point, 1/16 log-scale, 0.15*255 colour, 1/255 alpha and
     1/127.5 rotation steps (half each); SH in buckets of 8 and 16 over 128 */
  const double tol[6] = {0.5 / 4096 + 1e-6, 0.5 / 16 + 1e-6, 0.5 / (0.15 * 255) + 1e-5, 0.5 / 127.5 * 1.5, 0.5 / 255 + 1e-6,
                         8.5 / 128};
  const char *names[6] = {"mean", "log_scale", "f_dc", "rot", "opacity (after the sigmoid)", "f_rest"};
  for (int q = 0; q < 6; q++) CHECK_MSG(worst[q] <= tol[q], "%s: largest difference to the source %g (allowed %g)", names[q], worst[q], tol[q]);
done:
  mgs_gaussians_destroy(g);
  mgs_gaussians_destroy(src);
}

/* ---- hand-packed files ---- */

typedef struct spz_file {
  uint32_t version, n;
  int degree, fbits, flags, n_streams_override;
  const uint8_t *attr[6]; /* positions, alphas, colours, scales, rotations, SH */
  const uint8_t *ext;
  size_t ext_len;
} spz_file;

static size_t attr_bytes(const spz_file *s, int a) {
  const size_t n = s->n;
  const int dim = s->degree ? (s->degree + 1) * (s->degree + 1) - 1 : 0;
  const size_t b[6] = {n * (s->version == 1 ? 6 : 9), n, 3 * n, 3 * n, n * (s->version >= 3 ? 4 : 3), n * 3 * (size_t)dim};
  return b[a];
}

static void put32(uint8_t *p, uint32_t v) {
  for (int k = 0; k < 4; k++) p[k] = (uint8_t)(v >> (8 * k));
}
static void put64(uint8_t *p, uint64_t v) {
  for (int k = 0; k < 8; k++) p[k] = (uint8_t)(v >> (8 * k));
}

static void write_bytes(const char *path, const uint8_t *b, size_t n) {
  FILE *f = fopen(path, "wb");
  CHECK(f != NULL);
  if (!f) return;
  CHECK(fwrite(b, 1, n, f) == n);
  fclose(f);
}

/* Versions 1-3: header + attributes (+ extension records) in one gzip stream; the
 * compressed bytes are returned for tests that cut them. */
static size_t write_legacy(const char *path, const spz_file *s, uint8_t **gz_out) {
  size_t raw_n = 16 + s->ext_len;
  for (int a = 0; a < 6; a++) raw_n += attr_bytes(s, a);
  uint8_t *raw = calloc(raw_n, 1);
  put32(raw, 0x5053474eu);
  put32(raw + 4, s->version);
  put32(raw + 8, s->n);
  raw[12] = (uint8_t)s->degree;
  raw[13] = (uint8_t)s->fbits;
  raw[14] = (uint8_t)s->flags;
  size_t o = 16;
  for (int a = 0; a < 6; a++) {
    if (attr_bytes(s, a)) memcpy(raw + o, s->attr[a], attr_bytes(s, a));
    o += attr_bytes(s, a);
  }
  if (s->ext_len) memcpy(raw + o, s->ext, s->ext_len);
  uint8_t *gz = malloc(raw_n + 1024);
  z_stream z;
  memset(&z, 0, sizeof z);
  CHECK(deflateInit2(&z, 9, Z_DEFLATED, 16 + MAX_WBITS, 8, Z_DEFAULT_STRATEGY) == Z_OK);
  z.next_in = raw;
  z.avail_in = (uInt)raw_n;
  z.next_out = gz;
  z.avail_out = (uInt)(raw_n + 1024);
  CHECK(deflate(&z, Z_FINISH) == Z_STREAM_END);
  const size_t gz_n = z.total_out;
  deflateEnd(&z);
  write_bytes(path, gz, gz_n);
  free(raw);
  if (gz_out) *gz_out = gz;
  else free(gz);
  return gz_n;
}

/* Version 4: NGSP header, extension records, table of contents, one zstd stream per
 * non-empty attribute. `toc_bytes` (if not NULL) replaces the uncompressed size of stream 0. */
static size_t write_ngsp(const char *path, const spz_file *s, uint64_t toc_bytes0, uint8_t **out) {
  int ns = 0;
  for (int a = 0; a < 6; a++) ns += attr_bytes(s, a) > 0;
  const int ns_written = s->n_streams_override ? s->n_streams_override : ns;
  size_t cap = 32 + s->ext_len + 16 * (size_t)ns;
  for (int a = 0; a < 6; a++) cap += ZSTD_compressBound(attr_bytes(s, a));
  uint8_t *b = calloc(cap, 1);
  put32(b, 0x5053474eu);
  put32(b + 4, s->version);
  put32(b + 8, s->n);
  b[12] = (uint8_t)s->degree;
  b[13] = (uint8_t)s->fbits;
  b[14] = (uint8_t)s->flags;
  b[15] = (uint8_t)ns_written;
  const uint32_t toc = (uint32_t)(32 + s->ext_len);
  put32(b + 16, toc);
  if (s->ext_len) memcpy(b + 32, s->ext, s->ext_len);
  size_t o = toc + 16 * (size_t)ns;
  int e = 0;
  for (int a = 0; a < 6; a++) {
    const size_t un = attr_bytes(s, a);
    if (!un) continue;
    const size_t zn = ZSTD_compress(b + o, cap - o, s->attr[a], un, 3);
    CHECK(!ZSTD_isError(zn));
    put64(b + toc + 16 * e, zn);
    put64(b + toc + 16 * e + 8, e == 0 && toc_bytes0 ? toc_bytes0 : un);
    o += zn;
    e++;
  }
  write_bytes(path, b, o);
  if (out) *out = b;
  else free(b);
  return o;
}

/* Two Gaussians at SH degree 1 with values at the ends of each range. */
static uint8_t pos9[18], pos6[12], alpha[2] = {0, 255}, colour[6] = {0, 255, 128, 255, 0, 128};
static uint8_t scale[6] = {160, 0, 255, 80, 176, 192}, rot4[8], rot3[6] = {128, 128, 128, 255, 128, 128}, sh1[18];

static void pack_values(void) {
  const int32_t fx[6] = {4096, -8192, 0x7fffff, -0x800000, 1, -1}; /* 1, -2, the ends of 24 bits, +-1 unit */
  for (int i = 0; i < 6; i++)
    for (int b = 0; b < 3; b++) pos9[3 * i + b] = (uint8_t)((uint32_t)fx[i] >> (8 * b));
  const uint16_t h[6] = {0x3c00, 0xc000, 0x3800, 0x0001, 0x7bff, 0x8000}; /* 1 -2 0.5, smallest subnormal, 65504, -0 */
  for (int i = 0; i < 6; i++) {
    pos6[2 * i] = (uint8_t)h[i];
    pos6[2 * i + 1] = (uint8_t)(h[i] >> 8);
  }
  /* Gaussian 0: largest = w (index 3), the others 0: identity. Gaussian 1: largest = x
     (index 0); y at full magnitude 511 (1/sqrt2), z and w 0; written from w down to y */
  put32(rot4, 3u << 30);
  put32(rot4 + 4, (0u << 30) | (511u << 20) | (0u << 10) | 0u);
  for (int k = 0; k < 18; k++) sh1[k] = (uint8_t)(k < 3 ? 0 : k < 6 ? 255 : k < 9 ? 128 : 64 + 8 * k);
}

static spz_file base_file(uint32_t version) {
  spz_file s = {version, 2, 1, 12, 0, 0, {version == 1 ? pos6 : pos9, alpha, colour, scale, version >= 3 ? rot4 : rot3, sh1}, NULL, 0};
  return s;
}

static double logit(double w) { return log(w / (1.0 - w)); }

/* What the two hand-packed Gaussians must decode to, in the .ply frame (RDF) when the
 * file is in RUB (flip = -1 for y and z) or RDF (flip = +1). */
static void check_values(const mgs_gaussians *g, uint32_t version, double flip) {
  CHECK(g->n == 2 && g->sh_degree == 1);
  if (g->n != 2) return;
  const double f[3] = {1, flip, flip};
  const double p24[6] = {1, -2, 0x7fffff / 4096.0, -0x800000 / 4096.0, 1 / 4096.0, -1 / 4096.0};
  const double p16[6] = {1, -2, 0.5, ldexp(1, -24), 65504, 0};
  const double *p = version == 1 ? p16 : p24;
  for (int i = 0; i < 6; i++) CHECK_NEAR(g->mean[i], f[i % 3] * p[i], 1e-6 * fmax(1, fabs(p[i])));
  for (int k = 0; k < 6; k++) CHECK_NEAR(g->log_scale[k], scale[k] / 16.0 - 10.0, 1e-6);
  for (int k = 0; k < 6; k++) CHECK_NEAR(g->sh_dc[k], (colour[k] / 255.0 - 0.5) / 0.15, 1e-5);
  /* opacity: alpha 0 and 255 stay finite at half a quantum from 0 and 1 */
  CHECK(isfinite(g->opacity[0]) && isfinite(g->opacity[1]));
  CHECK_NEAR(g->opacity[0], logit(0.5 / 255), 1e-4);
  CHECK_NEAR(g->opacity[1], logit(1 - 0.5 / 255), 1e-4);
  /* rotations (w x y z); a frame flip negates the quaternion's y and z */
  double q[8];
  if (version >= 3) { /* smallest three: identity; x = y = 1/sqrt2 */
    const double r = sqrt(0.5), v[8] = {1, 0, 0, 0, 0, r, r, 0};
    memcpy(q, v, sizeof q);
  } else { /* first three: bytes 128 -> 0.5/127.5 each, w from the unit norm; (255,128,128) -> w 0 */
    const double e = 0.5 / 127.5, len = sqrt(1 + 2 * e * e);
    const double v[8] = {sqrt(1 - 3 * e * e), e, e, e, 0, 1 / len, e / len, e / len};
    memcpy(q, v, sizeof q);
  }
  for (int i = 0; i < 2; i++)
    for (int k = 0; k < 4; k++) CHECK_NEAR(g->rot[4 * i + k], (k >= 2 ? flip : 1) * q[4 * i + k], 1e-6);
  /* SH: byte 0 -> -1, 255 -> 127/128, 128 -> 0; the y and z basis functions (k = 0, 1) flip */
  const double fsh[3] = {flip, flip, 1};
  for (int i = 0; i < 2; i++)
    for (int k = 0; k < 3; k++)
      for (int c = 0; c < 3; c++)
        CHECK_NEAR(g->sh_rest[i * MGS_SH_REST_MAX + 3 * k + c], fsh[k] * (sh1[9 * i + 3 * k + c] - 128.0) / 128.0, 1e-6);
  for (int k = 9; k < 45; k++) CHECK(g->sh_rest[k] == 0);
}

static mgs_gaussians *read_tmp(const char *name) {
  mgs_error err = {0};
  mgs_gaussians *g = NULL;
  CHECK_OK(mgs_ply_read_gaussians(tmp_path(name), &g, &err), &err);
  return g;
}

static void test_hand_packed(void) {
  pack_values();
  for (uint32_t v = 1; v <= 4; v++) {
    char name[64];
    snprintf(name, sizeof name, "v%u.spz", v);
    spz_file s = base_file(v);
    if (v == 4) write_ngsp(tmp_path(name), &s, 0, NULL);
    else write_legacy(tmp_path(name), &s, NULL);
    mgs_gaussians *g = read_tmp(name);
    if (g) check_values(g, v, -1);
    mgs_gaussians_destroy(g);
  }
  /* the coordinate-system extension: stored in RDF, so nothing flips; an unknown record
     before it is skipped */
  uint8_t ext[24];
  put32(ext, 0x12340001u);
  put32(ext + 4, 4);
  put32(ext + 8, 0xdeadbeefu);
  put32(ext + 12, 0xADBE0003u);
  put32(ext + 16, 4);
  put32(ext + 20, 6); /* RDF */
  spz_file s = base_file(4);
  s.flags = 2;
  s.ext = ext;
  s.ext_len = sizeof ext;
  write_ngsp(tmp_path("rdf.spz"), &s, 0, NULL);
  mgs_gaussians *g = read_tmp("rdf.spz");
  if (g) check_values(g, 4, 1);
  mgs_gaussians_destroy(g);
  s = base_file(3); /* legacy: the records follow the data inside the gzip stream */
  s.flags = 2;
  s.ext = ext;
  s.ext_len = sizeof ext;
  write_legacy(tmp_path("rdf3.spz"), &s, NULL);
  g = read_tmp("rdf3.spz");
  if (g) check_values(g, 3, 1);
  mgs_gaussians_destroy(g);
  /* SH degree 4: degrees 0-3 kept, the 9 coefficients of degree 4 dropped; antialiased */
  uint8_t sh4[2 * 72];
  for (int k = 0; k < 144; k++) sh4[k] = (uint8_t)(k * 7);
  s = base_file(4);
  s.degree = 4;
  s.flags = 1;
  s.attr[5] = sh4;
  write_ngsp(tmp_path("deg4.spz"), &s, 0, NULL);
  g = read_tmp("deg4.spz");
  if (g) {
    CHECK(g->sh_degree == 3);
    /* coefficient 14 (x(x^2-3y^2), even in y and z) of Gaussian 1, channel 2 */
    CHECK_NEAR(g->sh_rest[MGS_SH_REST_MAX + 3 * 14 + 2], (sh4[72 + 3 * 14 + 2] - 128.0) / 128.0, 1e-6);
    /* coefficient 13 (z(x^2-y^2)) flips */
    CHECK_NEAR(g->sh_rest[3 * 13], -(sh4[3 * 13] - 128.0) / 128.0, 1e-6);
  }
  mgs_gaussians_destroy(g);
}

static void expect_refused(const char *name, const char *needle) {
  mgs_error err = {0};
  mgs_gaussians *g = NULL;
  const mgs_status st = mgs_ply_read_gaussians(tmp_path(name), &g, &err);
  CHECK_MSG(st != MGS_OK && g == NULL, "%s: read although malformed", name);
  CHECK_MSG(strstr(err.msg, name) != NULL, "%s: message '%s' does not name the file", name, err.msg);
  /* the needle is looked for after the file name (a folder named like it must not pass) */
  const char *rest = strstr(err.msg, name) ? strstr(err.msg, name) + strlen(name) : err.msg;
  CHECK_MSG(strstr(rest, needle) != NULL, "%s: message '%s' lacks '%s'", name, err.msg, needle);
  mgs_gaussians_destroy(g);
}

static void test_refused(void) {
  pack_values();
  write_bytes(tmp_path("text.spz"), (const uint8_t *)"hello, world", 12);
  expect_refused("text.spz", "not an .spz file");
  write_bytes(tmp_path("empty.spz"), (const uint8_t *)"", 0);
  expect_refused("empty.spz", "not an .spz file");
  expect_refused("missing.spz", "cannot open");
  spz_file s = base_file(3);
  s.version = 7;
  write_legacy(tmp_path("v7.spz"), &s, NULL);
  expect_refused("v7.spz", "version 7");
  s = base_file(3);
  s.n = 0;
  write_legacy(tmp_path("zero.spz"), &s, NULL);
  expect_refused("zero.spz", "claims 0 Gaussians");
  /* a gzip stream that is not an .spz inside */
  spz_file t = base_file(3);
  uint8_t *gz = NULL;
  const size_t gz_n = write_legacy(tmp_path("whole.spz"), &t, &gz);
  write_bytes(tmp_path("cut.spz"), gz, gz_n / 2);
  expect_refused("cut.spz", "truncated");
  gz[gz_n / 2] ^= 0x55;
  gz[gz_n / 2 + 1] ^= 0xaa;
  write_bytes(tmp_path("flipped.spz"), gz, gz_n);
  {
    /* a corrupted deflate block is refused, as corrupt or as short, never read */
    mgs_error err = {0};
    mgs_gaussians *g = NULL;
    const mgs_status st = mgs_ply_read_gaussians(tmp_path("flipped.spz"), &g, &err);
    CHECK_MSG(st != MGS_OK || g != NULL, "flipped.spz: neither read nor refused");
    if (st != MGS_OK) CHECK_MSG(strstr(err.msg, "flipped.spz") != NULL, "flipped: '%s'", err.msg);
    mgs_gaussians_destroy(g);
  }
  free(gz);
  /* a count the data cannot hold */
  s = base_file(3);
  s.n = 1000000000u;
  s.attr[0] = s.attr[1] = s.attr[2] = s.attr[3] = s.attr[4] = s.attr[5] = NULL;
  {
    uint8_t raw[16] = {0};
    put32(raw, 0x5053474eu);
    put32(raw + 4, 3);
    put32(raw + 8, 1000000000u);
    raw[12] = 0;
    uint8_t out[256];
    z_stream z;
    memset(&z, 0, sizeof z);
    deflateInit2(&z, 9, Z_DEFLATED, 16 + MAX_WBITS, 8, Z_DEFAULT_STRATEGY);
    z.next_in = raw;
    z.avail_in = 16;
    z.next_out = out;
    z.avail_out = sizeof out;
    deflate(&z, Z_FINISH);
    write_bytes(tmp_path("billion.spz"), out, z.total_out);
    deflateEnd(&z);
  }
  expect_refused("billion.spz", "cannot hold them");
  /* version 4 */
  s = base_file(4);
  s.version = 5;
  write_ngsp(tmp_path("v5.spz"), &s, 0, NULL);
  expect_refused("v5.spz", "version 5");
  s = base_file(4);
  s.n_streams_override = 5;
  write_ngsp(tmp_path("streams.spz"), &s, 0, NULL);
  expect_refused("streams.spz", "5 streams");
  s = base_file(4);
  write_ngsp(tmp_path("size.spz"), &s, 7, NULL);
  expect_refused("size.spz", "stream 0 holds 7 bytes");
  uint8_t *b = NULL;
  const size_t bn = write_ngsp(tmp_path("good4.spz"), &s, 0, &b);
  write_bytes(tmp_path("cut4.spz"), b, bn - 3);
  expect_refused("cut4.spz", "truncated");
  write_bytes(tmp_path("head4.spz"), b, 20);
  expect_refused("head4.spz", "an NGSP header is 32");
  uint8_t *c = malloc(bn);
  memcpy(c, b, bn);
  put32(c + 16, 100000); /* table of contents past the end */
  write_bytes(tmp_path("toc.spz"), c, bn);
  expect_refused("toc.spz", "table of contents");
  memcpy(c, b, bn);
  for (size_t k = 32 + 16 * 6; k < 32 + 16 * 6 + 8; k++) c[k] ^= 0xff; /* the first stream's zstd frame header */
  write_bytes(tmp_path("zstd.spz"), c, bn);
  expect_refused("zstd.spz", "corrupt zstd");
  free(c);
  free(b);
  /* stored in a frame of the rotated family (LFD) */
  uint8_t ext[12];
  put32(ext, 0xADBE0003u);
  put32(ext + 4, 4);
  put32(ext + 8, 9);
  s = base_file(4);
  s.flags = 2;
  s.ext = ext;
  s.ext_len = sizeof ext;
  write_ngsp(tmp_path("lfd.spz"), &s, 0, NULL);
  expect_refused("lfd.spz", "LFD");
  /* float16 infinity as a position */
  s = base_file(1);
  uint8_t p6[12];
  memcpy(p6, pos6, 12);
  p6[2] = 0x00;
  p6[3] = 0x7c;
  s.attr[0] = p6;
  write_legacy(tmp_path("inf16.spz"), &s, NULL);
  expect_refused("inf16.spz", "not finite");
}

int main(void) {
  dir = mgs_test_tmpdir("io_spz");
  RUN(test_against_splat_transform);
  RUN(test_spz_js_v2);
  RUN(test_hand_packed);
  RUN(test_refused);
  return mgs_test_finish();
}

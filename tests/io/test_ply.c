/* 3DGS .ply and point-cloud I/O: bit-exact round trips, files written by hand in the
 * reference layout (channel-major f_rest), other encodings and orders, and bad input. */
#include <stdint.h>
#include <unistd.h>

#include "core/mgs_gaussians.h"
#include "core/mgs_ply.h"
#include "mgs_test.h"
#include "core/mgs_origin.h"
#include "core/mgs_fs.h"

static const char *dir;
static char path_buf[4096];
static const char *tmp_path(const char *name) {
  snprintf(path_buf, sizeof path_buf, "%s/%s", dir, name);
  return path_buf;
}

static void write_bytes(const char *path, const void *data, size_t n) {
  FILE *f = fopen(path, "wb");
  if (!f) { perror(path); exit(2); }
  if (n) fwrite(data, 1, n, f);
  fclose(f);
}

static uint32_t lcg_state = 12345;
static float rnd(void) {
  lcg_state = lcg_state * 1664525u + 1013904223u;
  return (float)((lcg_state >> 8) & 0xffffff) / 16777216.0f * 2.0f - 1.0f;
}

static int R_of(int deg) { return (deg + 1) * (deg + 1) - 1; }

static mgs_gaussians *random_model(size_t n, int deg) {
  mgs_gaussians *g = mgs_gaussians_create(n, deg);
  size_t first;
  mgs_error err;
  if (mgs_gaussians_append(g, n, &first, &err) != MGS_OK) exit(2);
  for (size_t i = 0; i < n; i++) {
    for (int k = 0; k < 3; k++) g->mean[i * 3 + k] = rnd() * 1e5f;
    for (int k = 0; k < 3; k++) g->log_scale[i * 3 + k] = rnd() * 10;
    for (int k = 0; k < 4; k++) g->rot[i * 4 + k] = rnd();
    g->opacity[i] = rnd() * 20;
    for (int k = 0; k < 3; k++) g->sh_dc[i * 3 + k] = rnd();
    for (int k = 0; k < R_of(deg); k++)
      for (int c = 0; c < 3; c++) g->sh_rest[i * 45 + k * 3 + c] = rnd() * 1e-3f;
  }
  /* Values whose bits must survive: denormal, -0, extremes. */
  if (n > 2) {
    g->mean[0] = 1e-40f;
    g->mean[1] = -0.0f;
    g->opacity[1] = 3.4e38f;
    g->sh_dc[2] = -1.17549435e-38f;
  }
  return g;
}

static int same_model(const mgs_gaussians *a, const mgs_gaussians *b) {
  if (a->n != b->n || a->sh_degree != b->sh_degree) return 0;
  for (int grp = 0; grp < MGS_PARAM_COUNT; grp++) {
    const float *x = mgs_gaussians_group((mgs_gaussians *)a, (mgs_param_group)grp);
    const float *y = mgs_gaussians_group((mgs_gaussians *)b, (mgs_param_group)grp);
    if (a->n && memcmp(x, y, sizeof(float) * a->n * (size_t)mgs_param_dim((mgs_param_group)grp)) != 0) {
      fprintf(stderr, "group %s differs\n", mgs_param_name((mgs_param_group)grp));
      return 0;
    }
  }
  return 1;
}

static void test_round_trip(void) {
  const int degs[] = {0, 1, 2, 3};
  for (int t = 0; t < 4; t++) {
    mgs_gaussians *g = random_model(257, degs[t]);
    mgs_error err = {0};
    const char *p = tmp_path("rt.ply");
    CHECK_OK(mgs_ply_write_gaussians(p, g, &err), &err);
    mgs_gaussians *h = NULL;
    CHECK_OK(mgs_ply_read_gaussians(p, &h, &err), &err);
    CHECK(h && same_model(g, h));
    CHECK(h && h->sh_degree == degs[t]);
    /* The written size is exactly header + n * 4 * (17 + 3R) bytes (the reference's). */
    FILE *f = fopen(p, "rb");
    fseek(f, 0, SEEK_END);
    long sz = ftell(f);
    fclose(f);
    char hdr[8192];
    int len = snprintf(hdr, sizeof hdr, "ply\nformat binary_little_endian 1.0\nelement vertex 257\n");
    const char *fixed1[] = {"x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2"};
    for (int k = 0; k < 9; k++) len += snprintf(hdr + len, sizeof hdr - (size_t)len, "property float %s\n", fixed1[k]);
    for (int k = 0; k < 3 * R_of(degs[t]); k++) len += snprintf(hdr + len, sizeof hdr - (size_t)len, "property float f_rest_%d\n", k);
    const char *fixed2[] = {"opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"};
    for (int k = 0; k < 8; k++) len += snprintf(hdr + len, sizeof hdr - (size_t)len, "property float %s\n", fixed2[k]);
    len += snprintf(hdr + len, sizeof hdr - (size_t)len, "end_header\n");
    CHECK(sz == len + 257L * 4 * (17 + 3 * R_of(degs[t])));
    char *buf = malloc((size_t)len);
    f = fopen(p, "rb");
    CHECK(fread(buf, 1, (size_t)len, f) == (size_t)len);
    fclose(f);
    CHECK(memcmp(buf, hdr, (size_t)len) == 0);
    free(buf);
    mgs_gaussians_destroy(g);
    mgs_gaussians_destroy(h);
  }
  /* Empty model. */
  mgs_gaussians *g = mgs_gaussians_create(0, 3), *h = NULL;
  mgs_error err = {0};
  CHECK_OK(mgs_ply_write_gaussians(tmp_path("empty.ply"), g, &err), &err);
  CHECK_OK(mgs_ply_read_gaussians(tmp_path("empty.ply"), &h, &err), &err);
  CHECK(h && h->n == 0 && h->sh_degree == 3);
  mgs_gaussians_destroy(g);
  mgs_gaussians_destroy(h);
}

/* Value of property j of vertex i in the hand-written files: distinct everywhere. */
static float ref_value(size_t i, int j) { return (float)(i * 1000 + (size_t)j) * 0.25f - 7.0f; }

/* Writes a .ply as the reference's save_ply does (plyfile, binary LE, fixed order). */
static void write_reference_ply(const char *p, size_t n, int deg) {
  int R = R_of(deg);
  char hdr[8192];
  int len = snprintf(hdr, sizeof hdr, "ply\nformat binary_little_endian 1.0\nelement vertex %zu\n", n);
  const char *names1[] = {"x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2"};
  for (int k = 0; k < 9; k++) len += snprintf(hdr + len, sizeof hdr - (size_t)len, "property float %s\n", names1[k]);
  for (int k = 0; k < 3 * R; k++) len += snprintf(hdr + len, sizeof hdr - (size_t)len, "property float f_rest_%d\n", k);
  const char *names2[] = {"opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"};
  for (int k = 0; k < 8; k++) len += snprintf(hdr + len, sizeof hdr - (size_t)len, "property float %s\n", names2[k]);
  len += snprintf(hdr + len, sizeof hdr - (size_t)len, "end_header\n");
  int nf = 17 + 3 * R;
  size_t total = (size_t)len + n * (size_t)nf * 4;
  unsigned char *buf = malloc(total);
  memcpy(buf, hdr, (size_t)len);
  unsigned char *q = buf + len;
  for (size_t i = 0; i < n; i++)
    for (int j = 0; j < nf; j++) {
      float v = ref_value(i, j);
      uint32_t u;
      memcpy(&u, &v, 4);
      for (int b = 0; b < 4; b++) *q++ = (unsigned char)(u >> (8 * b)); /* little-endian */
    }
  write_bytes(p, buf, total);
  free(buf);
}

static void test_reference_layout(void) {
  const int degs[] = {0, 1, 3};
  for (int t = 0; t < 3; t++) {
    int deg = degs[t], R = R_of(deg);
    const char *p = tmp_path("ref.ply");
    write_reference_ply(p, 5, deg);
    mgs_gaussians *g = NULL;
    mgs_error err = {0};
    CHECK_OK(mgs_ply_read_gaussians(p, &g, &err), &err);
    if (!g) continue;
    CHECK(g->n == 5 && g->sh_degree == deg);
    for (size_t i = 0; i < g->n; i++) {
      CHECK(g->mean[i * 3 + 0] == ref_value(i, 0));
      CHECK(g->mean[i * 3 + 2] == ref_value(i, 2));
      CHECK(g->sh_dc[i * 3 + 0] == ref_value(i, 6));
      CHECK(g->sh_dc[i * 3 + 2] == ref_value(i, 8));
      /* f_rest_{c*R+k} (file column 9 + c*R + k) -> sh_rest[i][k][c] */
      for (int c = 0; c < 3; c++)
        for (int k = 0; k < R; k++) CHECK(g->sh_rest[i * 45 + (size_t)(k * 3 + c)] == ref_value(i, 9 + c * R + k));
      for (int k = R; k < 15; k++)
        for (int c = 0; c < 3; c++) CHECK(g->sh_rest[i * 45 + (size_t)(k * 3 + c)] == 0.0f);
      int o = 9 + 3 * R;
      CHECK(g->opacity[i] == ref_value(i, o));
      for (int k = 0; k < 3; k++) CHECK(g->log_scale[i * 3 + (size_t)k] == ref_value(i, o + 1 + k));
      for (int k = 0; k < 4; k++) CHECK(g->rot[i * 4 + (size_t)k] == ref_value(i, o + 4 + k));
    }
    /* Writing it back reproduces the reference file except the normals (written as 0). */
    CHECK_OK(mgs_ply_write_gaussians(tmp_path("ref2.ply"), g, &err), &err);
    mgs_gaussians *h = NULL;
    CHECK_OK(mgs_ply_read_gaussians(tmp_path("ref2.ply"), &h, &err), &err);
    CHECK(h && same_model(g, h));
    mgs_gaussians_destroy(h);
    mgs_gaussians_destroy(g);
  }
}

/* ascii and big-endian files, properties shuffled, extra properties and elements. */
static void test_other_encodings(void) {
  const char *ascii =
      "ply\nformat ascii 1.0\ncomment made by hand\nelement vertex 2\n"
      "property float rot_3\nproperty float rot_2\nproperty float rot_1\nproperty float rot_0\n"
      "property uchar extra\nproperty float scale_2\nproperty float scale_1\nproperty float scale_0\n"
      "property float opacity\nproperty double f_dc_2\nproperty float f_dc_1\nproperty float f_dc_0\n"
      "property float z\nproperty float y\nproperty float x\n"
      "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
      "4 3 2 1 7 -3 -2 -1 0.5 0.3 0.2 0.1 30 20 10\n"
      "-4 -3 -2 -1 8 3 2 1 -0.5 -0.3 -0.2 -0.1 -30 -20 -10\n"
      "3 0 1 2\n";
  write_bytes(tmp_path("ascii.ply"), ascii, strlen(ascii));
  mgs_gaussians *g = NULL;
  mgs_error err = {0};
  CHECK_OK(mgs_ply_read_gaussians(tmp_path("ascii.ply"), &g, &err), &err);
  if (g) {
    CHECK(g->n == 2 && g->sh_degree == 0);
    CHECK(g->mean[0] == 10 && g->mean[1] == 20 && g->mean[2] == 30);
    CHECK(g->mean[3] == -10 && g->mean[5] == -30);
    CHECK(g->sh_dc[0] == 0.1f && g->sh_dc[2] == 0.3f);
    CHECK(g->opacity[0] == 0.5f && g->opacity[1] == -0.5f);
    CHECK(g->log_scale[0] == -1 && g->log_scale[2] == -3);
    CHECK(g->rot[0] == 1 && g->rot[1] == 2 && g->rot[3] == 4 && g->rot[4] == -1);
    mgs_gaussians_destroy(g);
  }
  /* Big-endian, element "face" before "vertex", degree 1, reversed property order. */
  char hdr[4096];
  int len = snprintf(hdr, sizeof hdr, "ply\nformat binary_big_endian 1.0\nelement face 2\nproperty list uchar int vertex_indices\n"
                                      "element vertex 3\n");
  const char *names[17 + 9];
  char rest[9][16];
  int nn = 0;
  const char *fixed[] = {"x", "y", "z", "f_dc_0", "f_dc_1", "f_dc_2", "opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"};
  for (int k = 0; k < 14; k++) names[nn++] = fixed[k];
  for (int k = 0; k < 9; k++) { snprintf(rest[k], sizeof rest[k], "f_rest_%d", k); names[nn++] = rest[k]; }
  for (int k = nn - 1; k >= 0; k--) len += snprintf(hdr + len, sizeof hdr - (size_t)len, "property float %s\n", names[k]);
  len += snprintf(hdr + len, sizeof hdr - (size_t)len, "end_header\n");
  unsigned char body[4096];
  size_t bl = 0;
  for (int f = 0; f < 2; f++) { body[bl++] = 3; for (int k = 0; k < 12; k++) body[bl++] = 0; }
  for (int i = 0; i < 3; i++)
    for (int k = nn - 1; k >= 0; k--) {
      float v = (float)(100 * i + k); /* value = 100*i + index in names[] */
      uint32_t u;
      memcpy(&u, &v, 4);
      for (int b = 3; b >= 0; b--) body[bl++] = (unsigned char)(u >> (8 * b));
    }
  unsigned char *all = malloc((size_t)len + bl);
  memcpy(all, hdr, (size_t)len);
  memcpy(all + len, body, bl);
  write_bytes(tmp_path("be.ply"), all, (size_t)len + bl);
  free(all);
  g = NULL;
  CHECK_OK(mgs_ply_read_gaussians(tmp_path("be.ply"), &g, &err), &err);
  if (g) {
    CHECK(g->n == 3 && g->sh_degree == 1);
    for (int i = 0; i < 3; i++) {
      CHECK(g->mean[i * 3 + 1] == 100 * i + 1);
      CHECK(g->rot[i * 4 + 3] == 100 * i + 13);
      /* f_rest_{c*3+k} = names index 14 + c*3 + k -> sh_rest[i][k][c] */
      for (int c = 0; c < 3; c++)
        for (int k = 0; k < 3; k++) CHECK(g->sh_rest[i * 45 + k * 3 + c] == 100 * i + 14 + c * 3 + k);
    }
    mgs_gaussians_destroy(g);
  }
}

static int msg_has(const mgs_error *e, const char *s) { return strstr(e->msg, s) != NULL; }

static void expect_fail(const char *name, const char *content, size_t n, mgs_status want, const char *msg_part) {
  const char *p = tmp_path(name);
  write_bytes(p, content, n);
  mgs_gaussians *g = NULL;
  mgs_error err = {0};
  mgs_status s = mgs_ply_read_gaussians(p, &g, &err);
  CHECK_MSG(s == want, "%s: status %s (want %s): %s", name, mgs_status_name(s), mgs_status_name(want), err.msg);
  CHECK_MSG(g == NULL, "%s: model returned on failure", name);
  CHECK_MSG(msg_has(&err, name), "%s: message does not name the file: %s", name, err.msg);
  if (msg_part) CHECK_MSG(msg_has(&err, msg_part), "%s: message lacks '%s': %s", name, msg_part, err.msg);
  mgs_gaussians_destroy(g);
}

static char *file_bytes(const char *p, size_t *n) {
  FILE *f = fopen(p, "rb");
  fseek(f, 0, SEEK_END);
  *n = (size_t)ftell(f);
  fseek(f, 0, SEEK_SET);
  char *b = malloc(*n + 1);
  if (fread(b, 1, *n, f) != *n) exit(2);
  fclose(f);
  b[*n] = 0;
  return b;
}

static void test_bad_input(void) {
  write_reference_ply(tmp_path("good.ply"), 4, 1);
  size_t n;
  char *good = file_bytes(tmp_path("good.ply"), &n);
  /* truncated body: one byte short */
  expect_fail("trunc1.ply", good, n - 1, MGS_ERR_FORMAT, "truncated");
  /* truncated in the header */
  expect_fail("trunc_hdr.ply", good, 60, MGS_ERR_FORMAT, "end_header");
  /* counts past the end: 1e12 vertices declared, 4 present */
  {
    char *b = malloc(n + 64);
    char *v = strstr(good, "element vertex 4");
    size_t pre = (size_t)(v - good);
    memcpy(b, good, pre);
    int l = sprintf(b + pre, "element vertex 1000000000000");
    memcpy(b + pre + l, v + 16, n - pre - 16);
    expect_fail("count_past_eof.ply", b, n - 16 + (size_t)l, MGS_ERR_FORMAT, "1000000000000");
    free(b);
  }
  /* wrong type for a required property */
  {
    char *b = malloc(n + 8);
    memcpy(b, good, n);
    char *x = strstr(b, "property float opacity");
    memcpy(x, "property int   opacity", 22);
    expect_fail("wrong_type.ply", b, n, MGS_ERR_FORMAT, "opacity");
    memcpy(x, "property flat  opacity", 22);
    expect_fail("unknown_type.ply", b, n, MGS_ERR_FORMAT, "flat");
    free(b);
  }
  /* missing property: rename opacity */
  {
    char *b = malloc(n);
    memcpy(b, good, n);
    char *x = strstr(b, "property float opacity");
    memcpy(x, "property float opacitx", 22);
    expect_fail("missing_prop.ply", b, n, MGS_ERR_FORMAT, "'opacity'");
    free(b);
  }
  /* NaN at vertex 2, property scale_1 (column 9 + 9 + 1 + 1 = 20); Inf in f_rest_4 of vertex 3 */
  {
    char *b = malloc(n);
    memcpy(b, good, n);
    size_t body = (size_t)(strstr(b, "end_header\n") - b) + 11;
    int nf = 17 + 9;
    float nan = NAN, inf = INFINITY;
    memcpy(b + body + (2 * (size_t)nf + 20) * 4, &nan, 4);
    expect_fail("nan.ply", b, n, MGS_ERR_NUMERIC, "vertex 2");
    mgs_gaussians *g = NULL;
    mgs_error err = {0};
    CHECK(mgs_ply_read_gaussians(tmp_path("nan.ply"), &g, &err) == MGS_ERR_NUMERIC && g == NULL);
    CHECK_MSG(msg_has(&err, "scale_1"), "%s", err.msg);
    memcpy(b, good, n);
    memcpy(b + body + (3 * (size_t)nf + 9 + 4) * 4, &inf, 4);
    expect_fail("inf.ply", b, n, MGS_ERR_NUMERIC, "f_rest_4");
    free(b);
  }
  /* f_rest count not 0/9/24/45 */
  {
    const char *h = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
                    "property float f_dc_0\nproperty float f_dc_1\nproperty float f_dc_2\nproperty float f_rest_0\n"
                    "property float opacity\nproperty float scale_0\nproperty float scale_1\nproperty float scale_2\n"
                    "property float rot_0\nproperty float rot_1\nproperty float rot_2\nproperty float rot_3\nend_header\n"
                    "1 2 3 4 5 6 7 8 9 10 11 12 13 14 15\n";
    expect_fail("rest1.ply", h, strlen(h), MGS_ERR_FORMAT, "1 f_rest");
  }
  /* ascii: a non-number, and too few rows */
  {
    const char *h = "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\n"
                    "property float f_dc_0\nproperty float f_dc_1\nproperty float f_dc_2\n"
                    "property float opacity\nproperty float scale_0\nproperty float scale_1\nproperty float scale_2\n"
                    "property float rot_0\nproperty float rot_1\nproperty float rot_2\nproperty float rot_3\nend_header\n"
                    "1 2 3 4 5 6 7 8 9 10 11 12 13 14\n1 2 3 4 5 6 7 8 9 10 11 12 13 zz\n";
    expect_fail("ascii_nan_token.ply", h, strlen(h), MGS_ERR_FORMAT, "not a number");
    char b[2048];
    snprintf(b, sizeof b, "%.*s", (int)(strstr(h, "end_header\n") - h + 11 + 34), h);
    expect_fail("ascii_short.ply", b, strlen(b), MGS_ERR_FORMAT, NULL);
  }
  /* a huge element without properties holds no data: skipped at once, not looped over */
  {
    const char *h = "ply\nformat ascii 1.0\nelement nothing 1000000000000000\nelement vertex 1\nproperty float x\nproperty float y\n"
                    "property float z\nend_header\n1 2 3\n";
    write_bytes(tmp_path("no_props.ply"), h, strlen(h));
    mgs_point_cloud *pc = NULL;
    mgs_error err = {0};
    CHECK_OK(mgs_ply_read_points(tmp_path("no_props.ply"), &pc, &err), &err);
    CHECK(pc && pc->n == 1 && pc->xyz[2] == 3);
    mgs_point_cloud_destroy(pc);
  }
  expect_fail("empty_file.ply", "", 0, MGS_ERR_FORMAT, "empty");
  expect_fail("not_ply.ply", "hello world\n", 12, MGS_ERR_FORMAT, "not a .ply");
  expect_fail("no_vertex.ply", "ply\nformat ascii 1.0\nelement face 0\nend_header\n", 46, MGS_ERR_FORMAT, "vertex");
  expect_fail("bad_format.ply", "ply\nformat binary_middle_endian 1.0\nend_header\n", 47, MGS_ERR_FORMAT, "binary_middle_endian");
  {
    mgs_gaussians *g = NULL;
    mgs_error err = {0};
    CHECK(mgs_ply_read_gaussians(tmp_path("does_not_exist.ply"), &g, &err) == MGS_ERR_IO);
    CHECK(msg_has(&err, "does_not_exist.ply"));
  }
  free(good);
}

static void test_write_refuses_nan(void) {
  mgs_gaussians *g = random_model(10, 2);
  g->sh_rest[7 * 45 + 4 * 3 + 1] = NAN; /* k = 4, c = 1 -> f_rest_{1*8+4} = f_rest_12 */
  mgs_error err = {0};
  const char *p = tmp_path("nan_out.ply");
  unlink(p);
  CHECK(mgs_ply_write_gaussians(p, g, &err) == MGS_ERR_NUMERIC);
  CHECK_MSG(strstr(err.msg, "nan_out.ply") && strstr(err.msg, "Gaussian 7") && strstr(err.msg, "f_rest_12"), "%s", err.msg);
  CHECK(access(p, F_OK) != 0); /* nothing left behind */
  g->sh_rest[7 * 45 + 4 * 3 + 1] = 0;
  g->rot[3 * 4 + 2] = INFINITY;
  CHECK(mgs_ply_write_gaussians(p, g, &err) == MGS_ERR_NUMERIC);
  CHECK_MSG(strstr(err.msg, "Gaussian 3") && strstr(err.msg, "rot"), "%s", err.msg);
  CHECK(access(p, F_OK) != 0);
  mgs_gaussians_destroy(g);
}

static void test_points(void) {
  mgs_point_cloud pc = {0};
  pc.n = 100;
  pc.xyz = malloc(sizeof(float) * 300);
  pc.rgb = malloc(sizeof(float) * 300);
  for (int i = 0; i < 300; i++) { pc.xyz[i] = rnd() * 5; pc.rgb[i] = (float)((i * 37) % 256) / 255.0f; }
  mgs_error err = {0};
  CHECK_OK(mgs_ply_write_points(tmp_path("pts.ply"), &pc, &err), &err);
  mgs_point_cloud *q = NULL;
  CHECK_OK(mgs_ply_read_points(tmp_path("pts.ply"), &q, &err), &err);
  if (q) {
    CHECK(q->n == 100);
    CHECK(memcmp(q->xyz, pc.xyz, sizeof(float) * 300) == 0);
    for (int i = 0; i < 300; i++) CHECK_NEAR(q->rgb[i], pc.rgb[i], 1e-6);
    mgs_point_cloud_destroy(q);
  }
  /* A 3DGS .ply is also a point cloud (no colours -> grey). */
  write_reference_ply(tmp_path("ref_pts.ply"), 3, 0);
  q = NULL;
  CHECK_OK(mgs_ply_read_points(tmp_path("ref_pts.ply"), &q, &err), &err);
  if (q) {
    CHECK(q->n == 3 && q->xyz[3] == ref_value(1, 0) && q->rgb[4] == 0.5f);
    mgs_point_cloud_destroy(q);
  }
  /* float colours, double positions, ascii */
  const char *a = "ply\nformat ascii 1.0\nelement vertex 2\nproperty double x\nproperty double y\nproperty double z\n"
                  "property float red\nproperty float green\nproperty float blue\nend_header\n1 2 3 0.25 0.5 1\n4 5 6 0 0 0\n";
  write_bytes(tmp_path("fpts.ply"), a, strlen(a));
  q = NULL;
  CHECK_OK(mgs_ply_read_points(tmp_path("fpts.ply"), &q, &err), &err);
  if (q) {
    CHECK(q->n == 2 && q->xyz[5] == 6 && q->rgb[0] == 0.25f && q->rgb[2] == 1.0f);
    mgs_point_cloud_destroy(q);
  }
  const char *bad = "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nend_header\n1 2\n3 4\n";
  write_bytes(tmp_path("noz.ply"), bad, strlen(bad));
  q = NULL;
  CHECK(mgs_ply_read_points(tmp_path("noz.ply"), &q, &err) == MGS_ERR_FORMAT && q == NULL);
  CHECK(strstr(err.msg, "noz.ply") && strstr(err.msg, "'z'"));
  const char *nanp = "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nend_header\n1 2 3\n3 nan 4\n";
  write_bytes(tmp_path("nanpts.ply"), nanp, strlen(nanp));
  CHECK(mgs_ply_read_points(tmp_path("nanpts.ply"), &q, &err) == MGS_ERR_NUMERIC && q == NULL);
  CHECK_MSG(strstr(err.msg, "nanpts.ply") && strstr(err.msg, "vertex 1"), "%s", err.msg);
  free(pc.xyz);
  free(pc.rgb);
}

/* Means equal to within the double rounding of origin + mean (|m| below ~|origin| 2^-29
 * loses bits there: ~1e-10 absolute at 1e6), everything else bit for bit. */
static int same_model_far(const mgs_gaussians *g, mgs_gaussians *h) {
  if (!h || g->n != h->n) return 0;
  double dmax = 0;
  for (size_t i = 0; i < 3 * g->n; i++) dmax = fmax(dmax, fabs((double)g->mean[i] - h->mean[i]));
  if (dmax > 3e-10) { fprintf(stderr, "means differ by %g\n", dmax); return 0; }
  memcpy(h->mean, g->mean, 3 * g->n * sizeof(float));
  return same_model(g, h);
}

/* Issue 28: a model with an origin is written in world coordinates with double x y z and
 * read back into the same local frame (given or chosen origin); a centred model keeps the
 * all-float layout and origin (0,0,0), bit for bit. */
static void test_origin(void) {
  mgs_gaussians *g = random_model(300, 1);
  for (size_t i = 0; i < 3 * g->n; i++) g->mean[i] *= 1e-5f; /* a scene of size ~1 */
  const double o[3] = {1048576.0, -393216.0, 12288.0}; /* as mgs_origin_choose makes them */
  memcpy(g->origin, o, sizeof o);
  mgs_error err = {0};
  const char *p = tmp_path("far.ply");
  CHECK_OK(mgs_ply_write_gaussians(p, g, &err), &err);
  char *text = NULL;
  size_t n = 0;
  CHECK_OK(mgs_read_file(p, &text, &n, &err), &err);
  CHECK(text && strstr(text, "property double x\nproperty double y\nproperty double z\nproperty float nx\n"));
  free(text);
  mgs_gaussians *h = NULL;
  CHECK_OK(mgs_ply_read_gaussians_local(p, o, &h, &err), &err);
  CHECK(h && same_model_far(g, h) && memcmp(h->origin, o, sizeof o) == 0);
  mgs_gaussians_destroy(h);
  h = NULL;
  CHECK_OK(mgs_ply_read_gaussians_local(p, NULL, &h, &err), &err); /* chosen: the same origin */
  CHECK(h && same_model_far(g, h) && memcmp(h->origin, o, sizeof o) == 0);
  mgs_gaussians_destroy(h);
  h = NULL;
  CHECK_OK(mgs_ply_read_gaussians(p, &h, &err), &err); /* world floats */
  CHECK(h && h->origin[0] == 0 && fabs(h->mean[0] - (o[0] + g->mean[0])) <= 0.07);
  mgs_gaussians_destroy(h);
  h = NULL;
  memset(g->origin, 0, sizeof g->origin);
  CHECK_OK(mgs_ply_write_gaussians(p, g, &err), &err);
  CHECK_OK(mgs_ply_read_gaussians_local(p, NULL, &h, &err), &err);
  CHECK(h && same_model(g, h) && mgs_origin_is_zero(h->origin));
  mgs_gaussians_destroy(h);
  mgs_gaussians_destroy(g);
  /* the rule: centred scenes get 0, far ones a power-of-two grid point near their centre */
  double c[3] = {3, -2, 1}, r[3];
  mgs_origin_choose(c, 1.0, r);
  CHECK(mgs_origin_is_zero(r));
  const double far[3] = {100003.2, 5.0, -99999.1};
  mgs_origin_choose(far, 4.4, r);
  CHECK(r[0] == 100000 && r[1] == 8 && r[2] == -100000);
  char b[96];
  mgs_origin_format(r, b, sizeof b);
  double back[3];
  CHECK(mgs_origin_parse(b, back) && memcmp(back, r, sizeof r) == 0);
  CHECK(!mgs_origin_parse("1 2", back) && !mgs_origin_parse("1 2 x", back));
}

int main(void) {
  dir = mgs_test_tmpdir("io_ply");
  RUN(test_round_trip);
  RUN(test_reference_layout);
  RUN(test_other_encodings);
  RUN(test_bad_input);
  RUN(test_write_refuses_nan);
  RUN(test_points);
  RUN(test_origin);
  return mgs_test_finish();
}

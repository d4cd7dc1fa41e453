/* Hostile inputs (issue 13): a binary PLY mesh cut after 20,000 bytes through
 * `morsegs scene` (assimp segfaulted on it), and headers claiming absurd sizes (a PLY with
 * 10^12 vertices in 1 KB, a PNG of 10^6 x 10^6 pixels) refused before any allocation with
 * a message naming the file and the claim. COLMAP's 2^31 points: test_dataset.c. */
#include <dirent.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>
#include "mgs_test.h"
#include "io_test_util.h"
#include "core/mgs_fs.h"
#include "core/mgs_image.h"
#include "core/mgs_mesh.h"
#include "core/mgs_ply.h"

static char root[1024];

static const char *at(const char *name) {
  static char p[4][1400];
  static int k;
  k = (k + 1) & 3;
  snprintf(p[k], sizeof p[k], "%s/%s", root, name);
  return p[k];
}

/* A closed UV sphere with `nt` triangles or close to it. */
static mgs_mesh *sphere(int rings, int segs) {
  size_t nv = (size_t)(rings - 1) * (size_t)segs + 2, nt = (size_t)2 * (size_t)segs * (size_t)(rings - 1);
  mgs_mesh *m = mgs_mesh_create(nv, nt);
  if (!m) return NULL;
  size_t v = 0, t = 0;
  m->v[v * 3] = 0; m->v[v * 3 + 1] = 0; m->v[v * 3 + 2] = 1; v++;
  for (int i = 1; i < rings; i++)
    for (int j = 0; j < segs; j++, v++) {
      double th = M_PI * i / rings, ph = 2 * M_PI * j / segs;
      m->v[v * 3] = (float)(sin(th) * cos(ph)); m->v[v * 3 + 1] = (float)(sin(th) * sin(ph)); m->v[v * 3 + 2] = (float)cos(th);
    }
  m->v[v * 3] = 0; m->v[v * 3 + 1] = 0; m->v[v * 3 + 2] = -1;
  const uint32_t south = (uint32_t)v;
#define RING(i, j) (uint32_t)(1 + (size_t)((i) - 1) * (size_t)segs + (size_t)(((j) % segs + segs) % segs))
  for (int j = 0; j < segs; j++) {
    uint32_t *q = m->t + 3 * t++; q[0] = 0; q[1] = RING(1, j); q[2] = RING(1, j + 1);
    q = m->t + 3 * t++; q[0] = south; q[1] = RING(rings - 1, j + 1); q[2] = RING(rings - 1, j);
  }
  for (int i = 1; i < rings - 1; i++)
    for (int j = 0; j < segs; j++) {
      uint32_t *q = m->t + 3 * t++; q[0] = RING(i, j); q[1] = RING(i + 1, j); q[2] = RING(i + 1, j + 1);
      q = m->t + 3 * t++; q[0] = RING(i, j); q[1] = RING(i + 1, j + 1); q[2] = RING(i, j + 1);
    }
#undef RING
  return m;
}

static int count_lines(const char *path) {
  FILE *f = fopen(path, "r");
  if (!f) return -1;
  int n = 0, c, last = '\n';
  while ((c = fgetc(f)) != EOF) { if (c == '\n') n++; last = c; }
  fclose(f);
  return n + (last != '\n');
}

static int dir_entries(const char *dir) {
  DIR *d = opendir(dir);
  if (!d) return -1;
  int n = 0;
  struct dirent *e;
  while ((e = readdir(d))) n += strcmp(e->d_name, ".") && strcmp(e->d_name, "..");
  closedir(d);
  return n;
}

/* The case: a valid binary PLY of 7,374 triangles cut after 20,000 bytes. */
static void test_truncated_mesh_cli(void) {
  const char *cli = getenv("MGS_CLI");
  CHECK_MSG(cli != NULL, "MGS_CLI not set");
  if (!cli) return;
  mgs_mesh *m = sphere(48, 79); /* 7,426 triangles */
  CHECK(m && m->nt > 7000);
  mgs_error err;
  CHECK_OK(mgs_mesh_write(at("full.ply"), m, &err), &err);
  mgs_mesh_destroy(m);
  char *data = NULL;
  size_t n = 0;
  CHECK_OK(mgs_read_file(at("full.ply"), &data, &n, &err), &err);
  CHECK(n > 100000);
  /* cut in the vertices (the issue), in the faces, and one byte short */
  const size_t cuts[3] = {20000, n - 20000, n - 1};
  for (int k = 0; k < 3; k++) {
    char name[64], out[64], cmd[4096];
    snprintf(name, sizeof name, "truncated%d.ply", k);
    snprintf(out, sizeof out, "out%d", k);
    io_write_bytes(at(name), data, cuts[k]);
    snprintf(cmd, sizeof cmd, "cd '%s' && '%s' scene %s -o %s --views 2 --test-views 1 --width 16 --height 16 > log.txt 2>&1", root, cli,
             name, out);
    int rc = system(cmd);
    CHECK_MSG(WIFEXITED(rc) && WEXITSTATUS(rc) == 1, "%s: exit status %d (signal %d)", name, WIFEXITED(rc) ? WEXITSTATUS(rc) : -1,
              WIFSIGNALED(rc) ? WTERMSIG(rc) : 0);
    char *log = NULL;
    size_t ln = 0;
    CHECK_OK(mgs_read_file(at("log.txt"), &log, &ln, &err), &err);
    CHECK_MSG(log && strstr(log, name) && count_lines(at("log.txt")) == 1, "%s: %s", name, log ? log : "");
    if (k == 0) fprintf(stderr, "  %s", log ? log : "");
    free(log);
    CHECK_MSG(!mgs_path_exists(at(out)), "%s: partial output left", out);
  }
  free(data);
  /* nothing but the inputs and the log: no output folder, no temp files */
  CHECK(dir_entries(root) == 5);
}

/* Appends a PNG chunk (length, type, data, CRC-32 over type and data, as libpng checks). */
static size_t png_chunk(unsigned char *out, size_t n, const char *type, const unsigned char *data, uint32_t len) {
  for (int b = 0; b < 4; b++) out[n++] = (unsigned char)(len >> (24 - 8 * b));
  const size_t start = n;
  memcpy(out + n, type, 4);
  n += 4;
  if (len) memcpy(out + n, data, len);
  n += len;
  uint32_t crc = 0xffffffffu;
  for (size_t i = start; i < n; i++) {
    crc ^= out[i];
    for (int b = 0; b < 8; b++) crc = (crc >> 1) ^ (0xedb88320u & (0u - (crc & 1u)));
  }
  crc ^= 0xffffffffu;
  for (int b = 0; b < 4; b++) out[n++] = (unsigned char)(crc >> (24 - 8 * b));
  return n;
}

static void expect_claim(mgs_status st, const mgs_error *err, const char *name, const char *claim) {
  CHECK_MSG(st == MGS_ERR_FORMAT, "%s: status %s (%s)", name, mgs_status_name(st), err->msg);
  CHECK_MSG(strstr(err->msg, name) && strstr(err->msg, claim), "%s: message lacks the file or '%s': %s", name, claim, err->msg);
}

static void test_absurd_headers(void) {
  mgs_error err;
  /* PLY: 10^12 vertices (and faces) in a 1 KB file, ASCII and binary, as Gaussians, points and mesh */
  const char *fmts[2] = {"ascii", "binary_little_endian"};
  for (int f = 0; f < 2; f++) {
    char text[1100], name[32];
    int len = snprintf(text, sizeof text,
                       "ply\nformat %s 1.0\nelement vertex 1000000000000\nproperty float x\nproperty float y\nproperty float z\n"
                       "property float f_dc_0\nproperty float f_dc_1\nproperty float f_dc_2\nproperty float opacity\n"
                       "property float scale_0\nproperty float scale_1\nproperty float scale_2\n"
                       "property float rot_0\nproperty float rot_1\nproperty float rot_2\nproperty float rot_3\nelement face 1000000000000\nproperty list uchar int vertex_indices\nend_header\n",
                       fmts[f]);
    while (len < 1024) text[len++] = f ? 0 : '0';
    snprintf(name, sizeof name, "huge_%d.ply", f);
    io_write_bytes(at(name), text, 1024);
    mgs_gaussians *g = NULL;
    expect_claim(mgs_ply_read_gaussians(at(name), &g, &err), &err, name, "1000000000000");
    CHECK(g == NULL);
    mgs_point_cloud *pc = NULL;
    expect_claim(mgs_ply_read_points(at(name), &pc, &err), &err, name, "1000000000000");
    CHECK(pc == NULL);
    mgs_mesh *m = NULL;
    expect_claim(mgs_mesh_read(at(name), &m, &err), &err, name, "1000000000000");
    CHECK(m == NULL);
  }
  /* OFF and binary STL claiming 10^9 faces */
  io_write_text(at("huge.off"), "OFF\n1000000000 1000000000 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  mgs_mesh *m = NULL;
  expect_claim(mgs_mesh_read(at("huge.off"), &m, &err), &err, "huge.off", "1000000000 faces");
  unsigned char stl[134] = {0};
  const uint32_t nf = 1000000000u;
  memcpy(stl + 80, &nf, 4);
  io_write_bytes(at("huge.stl"), stl, sizeof stl);
  expect_claim(mgs_mesh_read(at("huge.stl"), &m, &err), &err, "huge.stl", "1000000000 triangles");
  CHECK(m == NULL);
  /* PNG whose header claims 10^6 x 10^6 pixels, then an empty IDAT and IEND */
  unsigned char png[8 + 25 + 12 + 12] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  size_t pn = 8;
  unsigned char ihdr[13] = {0};
  const uint32_t side = 1000000;
  for (int k = 0; k < 2; k++)
    for (int b = 0; b < 4; b++) ihdr[4 * k + b] = (unsigned char)(side >> (24 - 8 * b));
  ihdr[8] = 8; ihdr[9] = 2; /* 8-bit RGB */
  pn = png_chunk(png, pn, "IHDR", ihdr, 13);
  pn = png_chunk(png, pn, "IDAT", NULL, 0);
  pn = png_chunk(png, pn, "IEND", NULL, 0);
  io_write_bytes(at("huge.png"), png, pn);
  mgs_image *img = NULL;
  expect_claim(mgs_image_read(at("huge.png"), &img, &err), &err, "huge.png", "1000000x1000000");
  CHECK(img == NULL);
  int w, h, c;
  expect_claim(mgs_image_read_size(at("huge.png"), &w, &h, &c, &err), &err, "huge.png", "1000000x1000000");
}

int main(void) {
  char cwd[512];
  if (!getcwd(cwd, sizeof cwd)) return 1;
  snprintf(root, sizeof root, "%s/%s", cwd, mgs_test_tmpdir("io_hostile"));
  RUN(test_truncated_mesh_cli);
  RUN(test_absurd_headers);
  return mgs_test_finish();
}

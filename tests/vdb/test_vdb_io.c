/* .vdb files: our round trip, then the independent readers (Debian's python3-openvdb via
 * tests/vdb/check_vdb.py, and vdb_print from libopenvdb-tools for the point grid) must see
 * the grids with the right class, names, voxel size, transform and metadata; bad files
 * give clear errors. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include "core/mgs_fs.h"
#include "mgs_test.h"
#include "vdb_test_util.h"

static const double QI[4] = {1, 0, 0, 0};

static int run(const char *cmd) {
  fprintf(stderr, "  $ %s\n", cmd);
  int rc = system(cmd);
  return rc == -1 ? -1 : WEXITSTATUS(rc);
}

static void test_write_read(void) {
  const char *dir = mgs_test_tmpdir("vdb_io");
  char path[512], cmd[4096];
  snprintf(path, sizeof path, "%s/scene.vdb", dir);
  mgs_gaussians *g = mgs_gaussians_create(4, 0);
  const double s[3] = {0.3, 0.2, 0.25};
  vt_add(g, 1.0, 2.0, -0.5, s, QI, 0.9);
  vt_add(g, 1.3, 2.1, -0.4, s, QI, 0.8);
  mgs_vdb_alpha_params ap;
  mgs_vdb_alpha_params_default(&ap);
  ap.voxel_size = 0.05;
  mgs_vdb_sdf_params sp;
  mgs_vdb_sdf_params_default(&sp);
  sp.tau = 0.4;
  mgs_vdb_grid *a = NULL, *sdf = NULL, *dens = NULL;
  mgs_vdb_points *pts = NULL;
  mgs_error err = {0};
  CHECK_OK(mgs_vdb_alpha_field(g, &ap, &a, NULL, &err), &err);
  if (!a) return;
  CHECK_OK(mgs_vdb_sdf_from_alpha(a, &sp, &sdf, &err), &err);
  CHECK_OK(mgs_vdb_density_from_alpha(a, &dens, &err), &err);
  const float xyz[9] = {1.0f, 2.0f, -0.5f, 1.3f, 2.1f, -0.4f, 0.f, 0.f, 0.f};
  const int32_t idx[3] = {0, 1, 2};
  const float birth[3] = {-0.2f, 0.01f, 0.05f}, death[3] = {INFINITY, 0.03f, 0.06f}, pers[3] = {INFINITY, 0.02f, 0.01f};
  CHECK_OK(mgs_vdb_points_create_critical(3, xyz, idx, birth, death, pers, 0.05, &pts, &err), &err);
  if (!sdf || !dens || !pts) return;
  CHECK(mgs_vdb_points_count(pts) == 3);
  /* density: fog in [0,1] */
  size_t nl = mgs_vdb_leaf_count(dens);
  mgs_vdb_leaf_view *lv = malloc(nl * sizeof *lv);
  mgs_vdb_leaf_views(dens, lv, nl);
  float mx = 0, mn = 1;
  for (size_t l = 0; l < nl; l++)
    for (int k = 0; k < 512; k++) { mx = fmaxf(mx, lv[l].values[k]); mn = fminf(mn, lv[l].values[k]); }
  CHECK(mx <= 1.0f && mn >= 0.0f && mx > 0.9f);
  free(lv);
  mgs_vdb_file_meta meta;
  mgs_vdb_file_meta_default(&meta);
  meta.tau = 0.4;
  meta.voxel_size = 0.05;
  snprintf(meta.source, sizeof meta.source, "two.ply");
  const mgs_vdb_grid *grids[2] = {dens, sdf};
  const mgs_vdb_points *pp[1] = {pts};
  CHECK_OK(mgs_vdb_write(path, grids, 2, pp, 1, &meta, &err), &err);
  /* No temporary left behind. */
  snprintf(cmd, sizeof cmd, "test $(ls -A '%s' | wc -l) -eq 1", dir);
  CHECK(run(cmd) == 0);

  /* Our reader. */
  mgs_vdb_grid *r = NULL;
  CHECK_OK(mgs_vdb_read_grid(path, NULL, &r, &err), &err);
  if (r) {
    CHECK(strcmp(mgs_vdb_grid_name(r), "sdf") == 0);
    CHECK(mgs_vdb_grid_class(r) == MGS_VDB_CLASS_LEVEL_SET);
    CHECK(mgs_vdb_grid_active_voxel_count(r) == mgs_vdb_grid_active_voxel_count(sdf));
    CHECK_NEAR(mgs_vdb_grid_voxel_size(r), 0.05, 1e-12);
    mgs_vdb_leaf_change *ch = NULL;
    size_t n = 1;
    CHECK_OK(mgs_vdb_leaf_changes(sdf, r, 0.0f, &ch, &n, &err), &err);
    CHECK(n == 0);
    free(ch);
    mgs_vdb_grid_destroy(r);
  }
  CHECK_OK(mgs_vdb_read_grid(path, "density", &r, &err), &err);
  if (r) {
    CHECK(mgs_vdb_grid_class(r) == MGS_VDB_CLASS_FOG);
    mgs_vdb_grid_destroy(r);
  }
  mgs_vdb_file_meta m2;
  CHECK_OK(mgs_vdb_read_meta(path, &m2, &err), &err);
  CHECK(!strcmp(m2.tool, "morsegs") && !strcmp(m2.source, "two.ply") && m2.tau == 0.4 && m2.voxel_size == 0.05);
  CHECK(m2.version[0] != 0);

  /* Critical points back through OpenVDB's point attribute API. */
  size_t np = 0;
  float *rx = NULL, *rb = NULL, *rd = NULL, *rp = NULL;
  int32_t *ri = NULL;
  CHECK_OK(mgs_vdb_read_critical(path, NULL, &np, &rx, &ri, &rb, &rd, &rp, &err), &err);
  CHECK(np == 3);
  for (size_t i = 0; i < np && i < 3; i++) {
    int j = ri[i];
    CHECK(j >= 0 && j < 3);
    if (j < 0 || j > 2) continue;
    CHECK_NEAR(rx[3 * i], xyz[3 * j], 1e-5);
    CHECK_NEAR(rx[3 * i + 1], xyz[3 * j + 1], 1e-5);
    CHECK_NEAR(rx[3 * i + 2], xyz[3 * j + 2], 1e-5);
    CHECK(rb[i] == birth[j] && rd[i] == death[j] && rp[i] == pers[j]);
  }
  free(rx); free(ri); free(rb); free(rd); free(rp);
  CHECK(mgs_vdb_read_critical(path, "sdf", &np, &rx, &ri, &rb, &rd, &rp, &err) == MGS_ERR_UNSUPPORTED);

  /* The independent readers. */
  snprintf(cmd, sizeof cmd,
           "/usr/bin/python3 '%s/tests/vdb/check_vdb.py' '%s' --voxel-size 0.05 --tau 0.4 --source two.ply "
           "--sdf-active %zu --density-active %zu --critical 3",
           getenv("MGS_SOURCE_DIR") ? getenv("MGS_SOURCE_DIR") : "../..", path, mgs_vdb_grid_active_voxel_count(sdf),
           mgs_vdb_grid_active_voxel_count(dens));
  CHECK(run(cmd) == 0);

  mgs_vdb_points_destroy(pts);
  mgs_vdb_grid_destroy(a);
  mgs_vdb_grid_destroy(sdf);
  mgs_vdb_grid_destroy(dens);
  mgs_gaussians_destroy(g);
}

static void test_bad_files(void) {
  const char *dir = mgs_test_tmpdir("vdb_bad");
  char path[512], cmd[1024];
  mgs_error err = {0};
  mgs_vdb_grid *r = NULL;
  snprintf(path, sizeof path, "%s/missing.vdb", dir);
  CHECK(mgs_vdb_read_grid(path, NULL, &r, &err) == MGS_ERR_IO && r == NULL);
  CHECK(strstr(err.msg, "missing.vdb") && strstr(err.msg, "no such file"));
  snprintf(path, sizeof path, "%s/text.vdb", dir);
  CHECK_OK(mgs_write_file_atomic(path, "hello, not a vdb\n", 17, &err), &err);
  CHECK(mgs_vdb_read_grid(path, NULL, &r, &err) == MGS_ERR_FORMAT && r == NULL);
  CHECK(strstr(err.msg, "text.vdb") && strstr(err.msg, "not a readable .vdb"));
  /* Truncated real file. */
  mgs_vdb_grid *g = NULL;
  int32_t o[3] = {0, 0, 0}, d[3] = {4, 4, 4};
  float v[64];
  for (int i = 0; i < 64; i++) v[i] = 0.5f;
  CHECK_OK(mgs_vdb_grid_from_dense("density", MGS_VDB_CLASS_FOG, 0.1, NULL, 0.0f, o, d, v, &g, &err), &err);
  snprintf(path, sizeof path, "%s/fog.vdb", dir);
  const mgs_vdb_grid *gs[1] = {g};
  CHECK_OK(mgs_vdb_write(path, gs, 1, NULL, 0, NULL, &err), &err);
  CHECK(mgs_vdb_read_grid(path, "sdf", &r, &err) == MGS_ERR_FORMAT && r == NULL);
  CHECK_MSG(strstr(err.msg, "no grid named 'sdf'") && strstr(err.msg, "density"), "%s", err.msg);
  snprintf(cmd, sizeof cmd, "head -c 200 '%s' > '%s/trunc.vdb'", path, dir);
  CHECK(run(cmd) == 0);
  snprintf(path, sizeof path, "%s/trunc.vdb", dir);
  CHECK(mgs_vdb_read_grid(path, NULL, &r, &err) != MGS_OK && r == NULL);
  fprintf(stderr, "  truncated: %s\n", err.msg);
  /* Write into a missing directory: an error and nothing written. */
  snprintf(path, sizeof path, "%s/no/such/dir/x.vdb", dir);
  CHECK(mgs_vdb_write(path, gs, 1, NULL, 0, NULL, &err) == MGS_ERR_IO);
  CHECK(!mgs_path_exists(path));
  /* A vector grid written by python3-openvdb: refused as non-float. */
  snprintf(path, sizeof path, "%s/vec.vdb", dir);
  snprintf(cmd, sizeof cmd,
           "/usr/bin/python3 -c \"import pyopenvdb as v; g = v.Vec3SGrid(); g.name = 'velocity'; "
           "g.fill((0,0,0),(3,3,3),(1,2,3)); v.write('%s', grids=[g])\"", path);
  CHECK(run(cmd) == 0);
  CHECK(mgs_vdb_read_grid(path, "velocity", &r, &err) == MGS_ERR_UNSUPPORTED && r == NULL);
  CHECK_MSG(strstr(err.msg, "velocity") && strstr(err.msg, "not float"), "%s", err.msg);
  CHECK(mgs_vdb_read_grid(path, NULL, &r, &err) == MGS_ERR_UNSUPPORTED && r == NULL);
  CHECK_MSG(strstr(err.msg, "no float grid"), "%s", err.msg);
  mgs_vdb_grid_destroy(g);
}


/* Reads `path` as `morsegs persistence` does; returns the status, message in err. */
static mgs_status read_any(const char *path, mgs_error *err) {
  mgs_vdb_grid *r = NULL;
  mgs_status st = mgs_vdb_read_grid(path, NULL, &r, err);
  CHECK((st == MGS_OK) == (r != NULL));
  mgs_vdb_grid_destroy(r);
  return st;
}

static unsigned char *load(const char *path, size_t *n) {
  char *d = NULL;
  mgs_error err;
  if (mgs_read_file(path, &d, n, &err) != MGS_OK) return NULL;
  return (unsigned char *)d;
}

static void save(const char *path, const unsigned char *d, size_t n) {
  mgs_error err;
  CHECK_OK(mgs_write_file_atomic(path, d, n, &err), &err);
}

/* Files OpenVDB's own reader took badly (issue 13): truncated anywhere (the same file gave
 * a clean error or grew to 22 GB from run to run), a root claiming 2^31 children or tiles,
 * a zero voxel size, a metadata length of 4 GB. Each must fail with a message naming the
 * file, the same message every time. */
static void test_hostile_files(void) {
  const char *dir = mgs_test_tmpdir("vdb_hostile");
  char path[512], bad[600];
  mgs_error err = {0}, err2 = {0};
  int32_t o[3] = {0, 0, 0}, d[3] = {12, 12, 12};
  float v[12 * 12 * 12];
  for (int i = 0; i < 12 * 12 * 12; i++) v[i] = (float)(i % 7) * 0.3f - 0.9f;
  mgs_vdb_grid *g = NULL;
  CHECK_OK(mgs_vdb_grid_from_dense("sdf", MGS_VDB_CLASS_LEVEL_SET, 0.125, NULL, 3.25f, o, d, v, &g, &err), &err);
  snprintf(path, sizeof path, "%s/ls.vdb", dir);
  const mgs_vdb_grid *gs[1] = {g};
  CHECK_OK(mgs_vdb_write(path, gs, 1, NULL, 0, NULL, &err), &err);
  mgs_vdb_grid_destroy(g);
  CHECK(read_any(path, &err) == MGS_OK);
  size_t n = 0;
  unsigned char *b = load(path, &n);
  CHECK(b != NULL && n > 200);
  if (!b) return;
  snprintf(bad, sizeof bad, "%s/bad.vdb", dir);
  /* Truncated at 40 points through the file, each read three times. */
  for (int k = 0; k < 40; k++) {
    size_t cut = n * (size_t)k / 40 + (size_t)k;
    save(bad, b, cut);
    mgs_status s1 = read_any(bad, &err);
    CHECK_MSG(s1 != MGS_OK && strstr(err.msg, "bad.vdb"), "cut at %zu: %s", cut, err.msg);
    for (int rep = 0; rep < 2; rep++) {
      CHECK(read_any(bad, &err2) == s1);
      CHECK_MSG(!strcmp(err.msg, err2.msg), "cut at %zu: '%s' then '%s'", cut, err.msg, err2.msg);
    }
  }
  fprintf(stderr, "  truncated: %s\n", err.msg);
  /* The root's topology: background 3.25f, tile count, child count. */
  const unsigned char bg[4] = {0x00, 0x00, 0x50, 0x40}; /* 3.25f little-endian */
  size_t at = 0;
  for (size_t i = 0; i + 12 <= n && !at; i++)
    if (!memcmp(b + i, bg, 4) && b[i + 4] == 0 && b[i + 5] == 0 && b[i + 6] == 0 && b[i + 7] == 0 && b[i + 8] >= 1 &&
        b[i + 9] == 0 && b[i + 10] == 0 && b[i + 11] == 0)
      at = i;
  CHECK_MSG(at > 0, "root topology not found");
  for (int field = 0; field < 2 && at; field++) {
    unsigned char *c = malloc(n);
    memcpy(c, b, n);
    const unsigned char big[4] = {0xff, 0xff, 0xff, 0x7f};
    memcpy(c + at + 4 + 4 * field, big, 4);
    save(bad, c, n);
    free(c);
    CHECK_MSG(read_any(bad, &err) != MGS_OK && strstr(err.msg, "bad.vdb"), "2^31 %s: %s", field ? "children" : "tiles", err.msg);
    fprintf(stderr, "  2^31 %s: %s\n", field ? "children" : "tiles", err.msg);
  }
  /* Zero voxel size: every 0.125 (the transform's scale and its inverse's source) to 0. */
  {
    unsigned char *c = malloc(n);
    memcpy(c, b, n);
    const double eighth = 0.125, zero = 0.0;
    int hits = 0;
    for (size_t i = 0; i + 8 <= n; i++)
      if (!memcmp(c + i, &eighth, 8)) { memcpy(c + i, &zero, 8); hits++; }
    CHECK(hits >= 3);
    save(bad, c, n);
    free(c);
    CHECK_MSG(read_any(bad, &err) != MGS_OK && strstr(err.msg, "bad.vdb"), "zero voxel: %s", err.msg);
    fprintf(stderr, "  zero voxel size: %s\n", err.msg);
  }
  /* The first file-metadata name claims 4 GB: refused before anything is allocated. */
  {
    unsigned char *c = malloc(n);
    memcpy(c, b, n);
    const unsigned char huge[4] = {0xf0, 0xff, 0xff, 0xff};
    memcpy(c + 61, huge, 4); /* magic 8, version 4, library 8, flag 1, UUID 36, count 4 */
    save(bad, c, n);
    free(c);
    CHECK_MSG(read_any(bad, &err) == MGS_ERR_FORMAT && strstr(err.msg, "bad.vdb") && strstr(err.msg, "metadata"), "%s", err.msg);
    mgs_vdb_file_meta m;
    CHECK(mgs_vdb_read_meta(bad, &m, &err) == MGS_ERR_FORMAT && strstr(err.msg, "bad.vdb"));
  }
  free(b);
}

int main(void) {
  RUN(test_write_read);
  RUN(test_bad_files);
  RUN(test_hostile_files);
  return mgs_test_finish();
}

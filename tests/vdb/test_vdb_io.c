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

int main(void) {
  RUN(test_write_read);
  RUN(test_bad_files);
  return mgs_test_finish();
}

/* `morsegs vdb` end to end: a .ply of Gaussians on a sphere becomes a .vdb that
 * python3-openvdb reads (grids, classes, metadata), plus a mesh; outputs are not
 * overwritten without --force; bad input (.ply with NaN, zero/negative scale, opacity out
 * of range, an empty scene, a resolution over the memory budget) fails with a clear
 * one-line message and leaves no output. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include "core/mgs_fs.h"
#include "core/mgs_ply.h"
#include "core/mgs_rng.h"
#include "mgs_test.h"
#include "vdb_test_util.h"

static const char *cli(void) { return getenv("MGS_CLI") ? getenv("MGS_CLI") : "../../apps/morsegs"; }
static const char *src(void) { return getenv("MGS_SOURCE_DIR") ? getenv("MGS_SOURCE_DIR") : "../.."; }

static void write_sphere_ply(const char *path, size_t n) {
  mgs_gaussians *g = mgs_gaussians_create(n, 0);
  mgs_rng r;
  mgs_rng_init(&r, 5, 0);
  const double s[3] = {0.06, 0.06, 0.06}, q[4] = {1, 0, 0, 0};
  for (size_t i = 0; i < n; i++) {
    double d[3] = {mgs_rng_normal(&r), mgs_rng_normal(&r), mgs_rng_normal(&r)};
    double len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    vt_add(g, d[0] / len, d[1] / len, d[2] / len, s, q, 0.8);
  }
  mgs_error err = {0};
  CHECK_OK(mgs_ply_write_gaussians(path, g, &err), &err);
  mgs_gaussians_destroy(g);
}

/* An ASCII 3DGS .ply with the given rows "x y z opacity s0 s1 s2" (SH degree 0). */
static void write_ascii_ply(const char *path, const char *const *rows, int nrows) {
  FILE *f = fopen(path, "w");
  fprintf(f, "ply\nformat ascii 1.0\nelement vertex %d\n", nrows);
  const char *props[] = {"x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2", "opacity",
                         "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"};
  for (size_t i = 0; i < sizeof props / sizeof props[0]; i++) fprintf(f, "property float %s\n", props[i]);
  fprintf(f, "end_header\n");
  for (int i = 0; i < nrows; i++) {
    double x, y, z, o, s0, s1, s2;
    char so[32], ss0[32], ss1[32], ss2[32];
    sscanf(rows[i], "%lf %lf %lf %31s %31s %31s %31s", &x, &y, &z, so, ss0, ss1, ss2);
    (void)o; (void)s0; (void)s1; (void)s2;
    fprintf(f, "%g %g %g 0 0 0 0.1 0.2 0.3 %s %s %s %s 1 0 0 0\n", x, y, z, so, ss0, ss1, ss2);
  }
  fclose(f);
}

static void test_cli_ok(void) {
  const char *dir = mgs_test_tmpdir("vdb_cli");
  char ply[512], out[512], mesh[512], cmd[4096], e[4096];
  snprintf(ply, sizeof ply, "%s/sphere.ply", dir);
  snprintf(out, sizeof out, "%s/sphere.vdb", dir);
  snprintf(mesh, sizeof mesh, "%s/sphere_mesh.ply", dir);
  write_sphere_ply(ply, 3000);
  snprintf(cmd, sizeof cmd, "'%s' vdb '%s' -o '%s' --resolution 96 --tau 0.3 --mesh '%s'", cli(), ply, out, mesh);
  CHECK(vt_run(cmd, e, sizeof e) == 0);
  CHECK(mgs_path_exists(out) && mgs_path_exists(mesh));
  mgs_vdb_file_meta m;
  mgs_error err = {0};
  CHECK_OK(mgs_vdb_read_meta(out, &m, &err), &err);
  CHECK(m.voxel_size > 0 && m.tau == 0.3 && strstr(m.source, "sphere.ply"));
  char vs[64];
  snprintf(vs, sizeof vs, "%.17g", m.voxel_size);
  snprintf(cmd, sizeof cmd, "/usr/bin/python3 '%s/tests/vdb/check_vdb.py' '%s' --voxel-size %s --tau 0.3 --source '%s'", src(),
           out, vs, ply);
  CHECK(vt_run(cmd, e, sizeof e) == 0);
  /* Refuses to overwrite; --force overwrites. */
  snprintf(cmd, sizeof cmd, "'%s' vdb '%s' -o '%s' --resolution 64", cli(), ply, out);
  CHECK(vt_run(cmd, e, sizeof e) == 1);
  CHECK(strstr(e, "exists") && strstr(e, "--force"));
  snprintf(cmd, sizeof cmd, "'%s' vdb '%s' -o '%s' --resolution 64 --force --sdf-method sweep", cli(), ply, out);
  CHECK(vt_run(cmd, e, sizeof e) == 0);
  /* Usage errors exit 2. */
  snprintf(cmd, sizeof cmd, "'%s' vdb '%s' -o '%s' --resolution -3", cli(), ply, out);
  CHECK(vt_run(cmd, e, sizeof e) == 2);
  snprintf(cmd, sizeof cmd, "'%s' vdb '%s'", cli(), ply);
  CHECK(vt_run(cmd, e, sizeof e) == 2);
  snprintf(cmd, sizeof cmd, "'%s' vdb --help > /dev/null", cli());
  CHECK(vt_run(cmd, e, sizeof e) == 0);
}

static void expect_fail(const char *dir, const char *name, const char *const *rows, int nrows, const char *extra,
                        const char *needle) {
  char ply[512], out[512], cmd[4096], e[4096];
  snprintf(ply, sizeof ply, "%s/%s.ply", dir, name);
  snprintf(out, sizeof out, "%s/%s.vdb", dir, name);
  write_ascii_ply(ply, rows, nrows);
  snprintf(cmd, sizeof cmd, "'%s' vdb '%s' -o '%s' %s", cli(), ply, out, extra ? extra : "");
  CHECK_MSG(vt_run(cmd, e, sizeof e) == 1, "%s", name);
  CHECK_MSG(strstr(e, needle) != NULL, "%s: '%s' not in: %s", name, needle, e);
  CHECK_MSG(strstr(e, name) != NULL, "%s: the file is not named in: %s", name, e);
  CHECK_MSG(strstr(e, "morsegs vdb: ") != NULL, "%s", e);
  CHECK_MSG(!mgs_path_exists(out), "%s: output written despite the error", name);
}

static void test_cli_bad_input(void) {
  const char *dir = mgs_test_tmpdir("vdb_cli_bad");
  const char *good = "0 0 0 2 -3 -3 -3";
  const char *r_nan[] = {good, "0.5 nan 0 2 -3 -3 -3"};
  expect_fail(dir, "nan_pos", r_nan, 2, NULL, "not finite"); /* the PLY reader catches it */
  const char *r_zero[] = {good, "0.5 0 0 2 -inf -3 -3"};
  expect_fail(dir, "zero_scale", r_zero, 2, NULL, "scale");
  const char *r_nans[] = {good, "0.5 0 0 2 -3 nan -3"};
  expect_fail(dir, "nan_scale", r_nans, 2, NULL, "scale");
  const char *r_op[] = {good, "0.5 0 0 inf -3 -3 -3"};
  expect_fail(dir, "bad_opacity", r_op, 2, NULL, "opacity");
  expect_fail(dir, "empty", NULL, 0, NULL, "no Gaussians");
  const char *r_ok[] = {good, "0.5 0 0 2 -3 -3 -3", "0 0.5 0 2 -3 -3 -3"};
  expect_fail(dir, "budget", r_ok, 3, "--resolution 200000 --mem-budget 0.05", "estimated");
  char cmd[1024], e[4096];
  snprintf(cmd, sizeof cmd, "'%s' vdb '%s/missing.ply' -o '%s/x.vdb'", cli(), dir, dir);
  CHECK(vt_run(cmd, e, sizeof e) == 1 && strstr(e, "missing.ply"));
}

int main(void) {
  RUN(test_cli_ok);
  RUN(test_cli_bad_input);
  return mgs_test_finish();
}

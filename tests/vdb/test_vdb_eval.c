/* Geometry metrics of `morsegs eval` (measure/eval_geometry.c): a torus surface of flat
 * Gaussians against the torus mesh gives a small Chamfer distance and a high F-score; the
 * floater count is exactly the planted low-opacity Gaussians far from the surface (not the
 * low-opacity ones near it, nor the opaque far ones); bad paths fail cleanly. */
#include <cjson/cJSON.h>
#include <math.h>
#include <stdlib.h>
#include "measure/mgs_eval_geometry.h"
#include "core/mgs_log.h"
#include "core/mgs_math.h"
#include "core/mgs_mesh.h"
#include "core/mgs_ply.h"
#include "mgs_test.h"
#include "render/mgs_mesh_distance.h"
#include "vdb_test_util.h"

static void test_eval_torus(void) {
  const char *dir = mgs_test_tmpdir("vdb_eval");
  char gt_path[512], ply_path[512];
  snprintf(gt_path, sizeof gt_path, "%s/gt.ply", dir);
  snprintf(ply_path, sizeof ply_path, "%s/model.ply", dir);
  mgs_mesh *gt = vt_torus_mesh(1.0, 0.4, 192, 64);
  mgs_error err = {0};
  CHECK_OK(mgs_mesh_write(gt_path, gt, &err), &err);
  /* Flat discs on the surface (as test_vdb_mesh), sized for the eval's voxel (diag/256). */
  const size_t n = 12000;
  float *pts = malloc(n * 3 * sizeof(float)), *nrm = malloc(n * 3 * sizeof(float));
  CHECK_OK(mgs_mesh_sample_surface(gt, n, 3, pts, nrm, &err), &err);
  const double area = 4 * M_PI * M_PI * 0.4, sig_t = sqrt(8.0 / (2 * M_PI * n / area)), h = 4.04 / 256;
  mgs_gaussians *g = mgs_gaussians_create(n + 30, 0);
  for (size_t i = 0; i < n; i++) {
    double nz[3] = {nrm[3 * i], nrm[3 * i + 1], nrm[3 * i + 2]}, t1[3], t2[3];
    double a[3] = {fabs(nz[0]) < 0.9 ? 1 : 0, fabs(nz[0]) < 0.9 ? 0 : 1, 0};
    mgs_cross3d(nz, a, t1);
    mgs_normalize3d(t1);
    mgs_cross3d(nz, t1, t2);
    double Rm[9] = {t1[0], t2[0], nz[0], t1[1], t2[1], nz[1], t1[2], t2[2], nz[2]}, q[4];
    mgs_mat3_to_quatd(Rm, q);
    const double s[3] = {sig_t, sig_t, 0.5 * h};
    vt_add(g, pts[3 * i], pts[3 * i + 1], pts[3 * i + 2], s, q, 0.15);
  }
  const double QI[4] = {1, 0, 0, 0}, small[3] = {0.01, 0.01, 0.01};
  /* 7 floaters: opacity 0.005, 0.3 from the surface (> 3σ = 0.03). */
  for (int k = 0; k < 7; k++) vt_add(g, 1.0 + 0.2 * k / 7.0, 0.0, 0.7, small, QI, 0.005);
  /* Not floaters: low opacity on the surface; opaque far away; low opacity but huge σ. */
  for (int k = 0; k < 5; k++) vt_add(g, 1.4 * cos(k), 1.4 * sin(k), 0.0, small, QI, 0.005);
  for (int k = 0; k < 4; k++) vt_add(g, 0.0, 0.0, 1.0 + 0.1 * k, small, QI, 0.5);
  const double big[3] = {0.2, 0.2, 0.2};
  vt_add(g, 1.0, 0.0, 0.7, big, QI, 0.005);
  CHECK_OK(mgs_ply_write_gaussians(ply_path, g, &err), &err);
  cJSON *obj = cJSON_CreateObject();
  char table[4096];
  CHECK(mgs_eval_geometry(ply_path, gt_path, obj, table, sizeof table) == 0);
  fprintf(stderr, "%s", table);
  cJSON *fl = cJSON_GetObjectItem(obj, "floaters"), *ch = cJSON_GetObjectItem(obj, "chamfer"),
        *fs = cJSON_GetObjectItem(obj, "fscore"), *vs = cJSON_GetObjectItem(obj, "surface_voxel_size");
  CHECK(fl && cJSON_IsNumber(fl) && fl->valuedouble == 7);
  CHECK(ch && cJSON_IsNumber(ch) && vs && cJSON_IsNumber(vs));
  if (ch && vs && cJSON_IsNumber(ch)) CHECK_MSG(ch->valuedouble < 1.5 * vs->valuedouble, "chamfer %g voxel %g", ch->valuedouble, vs->valuedouble);
  CHECK(fs && cJSON_IsNumber(fs) && fs->valuedouble > 0.8);
  /* the signed offset: within the accuracy, and |offset| <= accuracy by definition */
  cJSON *of = cJSON_GetObjectItem(obj, "offset"), *ac = cJSON_GetObjectItem(obj, "chamfer_accuracy");
  CHECK(of && cJSON_IsNumber(of) && ac && cJSON_IsNumber(ac));
  if (of && ac && cJSON_IsNumber(of) && cJSON_IsNumber(ac))
    CHECK_MSG(fabs(of->valuedouble) <= ac->valuedouble + 1e-12, "offset %g accuracy %g", of->valuedouble, ac->valuedouble);
  CHECK(strstr(table, "Chamfer") && strstr(table, "floaters") && strstr(table, "offset"));
  cJSON_Delete(obj);
  /* Missing files: non-zero, no crash. */
  obj = cJSON_CreateObject();
  mgs_log_set_level(MGS_LOG_QUIET);
  CHECK(mgs_eval_geometry("no_such.ply", gt_path, obj, table, sizeof table) != 0);
  CHECK(mgs_eval_geometry(ply_path, "no_such_mesh.obj", obj, table, sizeof table) != 0);
  mgs_log_set_level(MGS_LOG_INFO);
  cJSON_Delete(obj);
  mgs_gaussians_destroy(g);
  mgs_mesh_destroy(gt);
  free(pts);
  free(nrm);
}

int main(void) {
  RUN(test_eval_torus);
  return mgs_test_finish();
}

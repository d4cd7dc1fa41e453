/* geometry.sugar of `morsegs eval`: SuGaR's mesh of the run (RUN/mesh/sugar.ply, written by
 * `morsegs vdb RUN --sugar-mesh`) against the ground truth, with the samples and F-score
 * threshold of the α-field's surface (measure/eval_geometry.c), so the rows compare. */
#include "measure/mgs_eval_geometry.h"
#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include "core/mgs_log.h"
#include "core/mgs_mesh.h"
#include "measure/mesh_pieces.h"
#include "render/mgs_mesh_distance.h"

#define EVAL_SAMPLES 100000
#define EVAL_FSCORE_REL 0.01

int mgs_eval_geometry_mesh(const char *mesh_path, const char *gt_mesh_path, void *cjson_object_out, char *table_out,
                           size_t table_len) {
  mgs_error err = {0};
  mgs_mesh *m = NULL, *gt = NULL;
  int rc = 1;
  if (table_out && table_len) table_out[0] = 0;
  if (mgs_mesh_read(mesh_path, &m, &err) != MGS_OK || mgs_mesh_read(gt_mesh_path, &gt, &err) != MGS_OK) {
    mgs_errorf("eval geometry: %s", err.msg);
    goto done;
  }
  double lo[3], hi[3];
  mgs_mesh_bounds(gt, lo, hi);
  const double thr = EVAL_FSCORE_REL * sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                                            (hi[2] - lo[2]) * (hi[2] - lo[2]));
  mgs_geometry_metrics gm;
  if (mgs_mesh_compare(m, gt, EVAL_SAMPLES, thr, 0, &gm, &err) != MGS_OK) {
    mgs_errorf("eval geometry: %s: %s", mesh_path, err.msg);
    goto done;
  }
  long chi = 0;
  size_t pieces = mgs_mesh_pieces(m, &chi);
  cJSON *obj = cjson_object_out;
  if (obj) {
    cJSON_AddStringToObject(obj, "mesh", mesh_path);
    mgs_eval_geometry_add_metrics(obj, &gm);
    cJSON_AddNumberToObject(obj, "triangles", (double)m->nt);
    cJSON_AddNumberToObject(obj, "pieces", (double)pieces);
    cJSON_AddNumberToObject(obj, "euler", (double)chi);
  }
  if (table_out && table_len)
    snprintf(table_out, table_len,
             "  SuGaR mesh            Chamfer %.6g (accuracy %.6g, completeness %.6g; offset %+.3g), F-score %.4f\n"
             "                        (%s, %zu triangles, %zu pieces, Euler characteristic %ld)\n",
             gm.chamfer, gm.accuracy, gm.completeness, gm.offset, gm.fscore, mesh_path, m->nt, pieces, chi);
  rc = 0;
done:
  mgs_mesh_destroy(m);
  mgs_mesh_destroy(gt);
  return rc;
}

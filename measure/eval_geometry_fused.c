/* Geometry of the depth-fused surface for `morsegs eval` (beside the α-field's of
 * measure/eval_geometry.c): the run's model rendered at its cameras.json, fused
 * (measure/mgs_depth_fusion.h, the defaults `morsegs vdb RUN` uses), the zero level set of
 * the rebuilt band against the GT mesh with the same samples and F-score threshold. */
#include "measure/mgs_eval_geometry.h"
#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "measure/mgs_depth_fusion.h"
#include "core/mgs_log.h"
#include "core/mgs_mesh.h"
#include "measure/mesh_pieces.h"
#include "measure/mgs_surface_choice.h"
#include "render/mgs_mesh_distance.h"

#define EVAL_SAMPLES 100000
#define EVAL_FSCORE_REL 0.01

int mgs_eval_geometry_fused(const char *run_dir, const mgs_fusion_opts *opts, const char *gt_mesh_path,
                            void *cjson_object_out, char *table_out, size_t table_len) {
  cJSON *obj = (cJSON *)cjson_object_out;
  mgs_error err = {0};
  mgs_mesh *gt = NULL, *surf = NULL, *asurf = NULL;
  mgs_vdb_grid *sdf = NULL;
  mgs_fusion_opts fo;
  mgs_fusion_opts_default(&fo);
  if (opts) fo = *opts;
  fo.keep_points = MGS_SURFACE_POINTS; /* the no-ground-truth choice `morsegs vdb RUN` makes */
  mgs_fusion_report rep;
  memset(&rep, 0, sizeof rep);
  mgs_geometry_metrics gm;
  int rc = 1;
  const double t0 = mgs_now();
  if (table_out && table_len) table_out[0] = 0;
  if (mgs_mesh_read(gt_mesh_path, &gt, &err) != MGS_OK || mgs_fuse_path(run_dir, &fo, &sdf, NULL, NULL, &rep, &err) != MGS_OK ||
      mgs_vdb_extract_mesh(sdf, 0.0, 0.0, &surf, &err) != MGS_OK) {
    mgs_warn("eval geometry (depth-fused surface): %s", err.msg);
    goto done;
  }
  double lo[3], hi[3];
  mgs_mesh_bounds(gt, lo, hi);
  const double thr = EVAL_FSCORE_REL * sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                                            (hi[2] - lo[2]) * (hi[2] - lo[2]));
  if (mgs_mesh_compare(surf, gt, EVAL_SAMPLES, thr, 0, &gm, &err) != MGS_OK) {
    mgs_warn("eval geometry (depth-fused surface): %s", err.msg);
    goto done;
  }
  long chi = 0;
  size_t pieces = mgs_mesh_pieces(surf, &chi);
  /* which surface `morsegs vdb RUN` makes `sdf` (measure/mgs_surface_choice.h) */
  mgs_surface_agreement af = {0}, aa = {0};
  int pick = -1;
  if (mgs_alpha_surface_mesh(rep.ply, &asurf, &err) == MGS_OK)
    pick = mgs_surface_choose(rep.points, rep.n_points, surf, asurf, MGS_SURFACE_CAP_FP * rep.footprint, &af, &aa, &err);
  if (pick < 0) mgs_warn("eval geometry: the choice between the two surfaces failed: %s", err.msg);
  if (obj) {
    mgs_eval_geometry_add_metrics(obj, &gm);
    cJSON_AddStringToObject(obj, "depth", rep.depth == MGS_DEPTH_MEDIAN ? "median" : "expected");
    cJSON_AddNumberToObject(obj, "views", (double)rep.views);
    cJSON_AddBoolToObject(obj, "virtual_views", rep.virtual_views);
    cJSON_AddNumberToObject(obj, "pixel_footprint", rep.footprint);
    cJSON_AddNumberToObject(obj, "voxel_size", rep.voxel_size);
    cJSON_AddNumberToObject(obj, "truncation", rep.truncation);
    cJSON_AddNumberToObject(obj, "voxel_footprints", rep.voxel_size / rep.footprint);
    cJSON_AddNumberToObject(obj, "truncation_footprints", rep.truncation / rep.footprint);
    cJSON_AddNumberToObject(obj, "truncation_back_footprints", rep.truncation_back / rep.footprint);
    cJSON_AddNumberToObject(obj, "truncation_thin_footprints", rep.truncation_thin / rep.footprint);
    cJSON_AddNumberToObject(obj, "thin_voxels", (double)rep.thin_voxels);
    cJSON_AddNumberToObject(obj, "min_weight", fo.min_weight);
    cJSON_AddNumberToObject(obj, "image_masks", (double)rep.image_masks); /* views masked by their dataset image */
    cJSON_AddNumberToObject(obj, "mask_carve_px", fo.mask_carve_px);     /* -1: off */
    cJSON_AddNumberToObject(obj, "surface_triangles", (double)surf->nt);
    cJSON_AddNumberToObject(obj, "surface_pieces", (double)pieces);
    cJSON_AddNumberToObject(obj, "surface_euler", (double)chi);
    if (pick >= 0) {
      cJSON *ch = cJSON_AddObjectToObject(obj, "surface_choice");
      cJSON_AddStringToObject(ch, "sdf", pick ? "alpha" : "fused");
      cJSON_AddNumberToObject(ch, "fused_agreement", af.score);
      cJSON_AddNumberToObject(ch, "alpha_agreement", aa.score);
      cJSON_AddNumberToObject(ch, "points", (double)rep.n_points);
    }
    cJSON_AddNumberToObject(obj, "seconds", mgs_now() - t0);
  }
  if (table_out && table_len)
    snprintf(table_out, table_len,
             "  depth-fused surface   Chamfer %.6g (accuracy %.6g, completeness %.6g; offset %+.3g), F-score %.4f\n"
             "                        (%zu %sviews, %s depth, voxel %.4g, truncation %.3g footprints, %zu triangles,\n"
             "                        %zu pieces, Euler characteristic %ld)\n",
             gm.chamfer, gm.accuracy, gm.completeness, gm.offset, gm.fscore, rep.views, rep.virtual_views ? "virtual " : "",
             rep.depth == MGS_DEPTH_MEDIAN ? "median" : "expected", rep.voxel_size, rep.truncation / rep.footprint,
             surf->nt, pieces, chi);
  if (table_out && table_len && pick >= 0) {
    size_t used = strlen(table_out);
    snprintf(table_out + used, table_len - used,
             "  default surface (sdf) %s: agreement with the renders fused %.4g, alpha-field %.4g (lower wins)\n",
             pick ? "the alpha-field's" : "the depth-fused one", af.score, aa.score);
  }
  rc = 0;
done:
  free(rep.points);
  mgs_mesh_destroy(surf);
  mgs_mesh_destroy(asurf);
  mgs_mesh_destroy(gt);
  mgs_vdb_grid_destroy(sdf);
  return rc;
}

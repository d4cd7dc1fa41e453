/* Geometry metrics of `morsegs eval` against a ground-truth mesh (SPEC §7):
 *   - the model's surface: α-field (resolution 256 over the means' bounding-box diagonal),
 *     SDF of {A = 0.5} and its zero level set extracted with volumeToMesh;
 *   - Chamfer distance = mean of the two directions' mean closest-point distances between
 *     100k area-uniform samples on each surface (Embree point queries), and F-score at a
 *     threshold of 1 % of the GT mesh's bounding-box diagonal (relative to scene scale);
 *   - floaters (H2): Gaussians with opacity < 0.01 whose centre is farther than 3σ (σ = their
 *     largest std-dev) from the GT surface. */
#include "measure/mgs_eval_geometry.h"
#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "core/mgs_log.h"
#include "core/mgs_mesh.h"
#include "measure/mesh_pieces.h"
#include "core/mgs_ply.h"
#include "render/mgs_mesh_distance.h"
#include "vdb/mgs_vdb.h"

#define EVAL_SAMPLES 100000
#define EVAL_FSCORE_REL 0.01
#define EVAL_TAU 0.5
#define FLOATER_OPACITY 0.01
#define FLOATER_SIGMAS 3.0

/* Floaters of the H2 definition; returns the count, -1 on failure. */
static long count_floaters(const mgs_gaussians *g, const mgs_mesh *gt, size_t *low_opacity, mgs_error *err) {
  mgs_mesh_distance *d = NULL;
  if (mgs_mesh_distance_create(gt, &d, err) != MGS_OK) return -1;
  float *dist = malloc((g->n ? g->n : 1) * sizeof(float));
  if (!dist) { mgs_mesh_distance_destroy(d); return -1; }
  mgs_mesh_distance_query(d, g->n, g->mean, dist, NULL);
  long count = 0;
  *low_opacity = 0;
  for (size_t i = 0; i < g->n; i++) {
    if (!(mgs_gaussian_alpha(g, i) < FLOATER_OPACITY)) continue;
    (*low_opacity)++;
    float s[3];
    mgs_gaussian_scale(g, i, s);
    float smax = fmaxf(s[0], fmaxf(s[1], s[2]));
    if (dist[i] > FLOATER_SIGMAS * smax) count++;
  }
  free(dist);
  mgs_mesh_distance_destroy(d);
  return count;
}

void mgs_eval_geometry_add_metrics(void *cjson_object, const void *metrics) {
  cJSON *obj = cjson_object;
  const mgs_geometry_metrics *gm = metrics;
  cJSON_AddNumberToObject(obj, "chamfer", gm->chamfer);
  cJSON_AddNumberToObject(obj, "chamfer_accuracy", gm->accuracy);
  cJSON_AddNumberToObject(obj, "chamfer_completeness", gm->completeness);
  cJSON_AddNumberToObject(obj, "offset", gm->offset);
  cJSON_AddNumberToObject(obj, "fscore", gm->fscore);
  cJSON_AddNumberToObject(obj, "precision", gm->precision);
  cJSON_AddNumberToObject(obj, "recall", gm->recall);
}

int mgs_eval_geometry(const char *ply_path, const char *gt_mesh_path, void *cjson_object_out, char *table_out,
                      size_t table_len) {
  cJSON *obj = (cJSON *)cjson_object_out;
  mgs_error err = {0};
  mgs_gaussians *g = NULL;
  mgs_mesh *gt = NULL, *surf = NULL;
  mgs_vdb_grid *alpha = NULL, *sdf = NULL;
  int rc = 1;
  const double t0 = mgs_now();
  if (table_out && table_len) table_out[0] = 0;
  if (mgs_ply_read_gaussians_local(ply_path, NULL, &g, &err) != MGS_OK || mgs_vdb_check_gaussians(g, ply_path, &err) != MGS_OK ||
      mgs_mesh_read(gt_mesh_path, &gt, &err) != MGS_OK) {
    mgs_errorf("eval geometry: %s", err.msg);
    goto done;
  }
  mgs_mesh_translate(gt, g->origin, -1); /* the GT mesh (world) into the model's local frame */
  double lo[3], hi[3];
  mgs_mesh_bounds(gt, lo, hi);
  const double diag = sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) + (hi[2] - lo[2]) * (hi[2] - lo[2]));
  const double thr = EVAL_FSCORE_REL * diag;

  size_t low_op = 0;
  long floaters = count_floaters(g, gt, &low_op, &err);
  if (floaters < 0) {
    mgs_errorf("eval geometry: %s: %s", gt_mesh_path, err.msg[0] ? err.msg : "out of memory");
    goto done;
  }

  mgs_vdb_alpha_params ap;
  mgs_vdb_alpha_params_default(&ap);
  mgs_vdb_sdf_params sp;
  mgs_vdb_sdf_params_default(&sp);
  sp.tau = EVAL_TAU;
  mgs_vdb_build_info info;
  mgs_geometry_metrics gm;
  memset(&gm, 0, sizeof gm);
  int have_surface = 0;
  if (mgs_vdb_alpha_field(g, &ap, &alpha, &info, &err) != MGS_OK || mgs_vdb_sdf_from_alpha(alpha, &sp, &sdf, &err) != MGS_OK) {
    mgs_errorf("eval geometry: %s: %s", ply_path, err.msg);
    goto done;
  }
  if (mgs_vdb_grid_active_voxel_count(sdf) > 0 && mgs_vdb_extract_mesh(sdf, 0.0, 0.0, &surf, &err) == MGS_OK) {
    if (mgs_mesh_compare(surf, gt, EVAL_SAMPLES, thr, 0, &gm, &err) != MGS_OK) {
      mgs_errorf("eval geometry: %s", err.msg);
      goto done;
    }
    have_surface = 1;
  } else {
    mgs_warn("eval geometry: %s: the alpha field never reaches tau = %g; no surface to compare", ply_path, EVAL_TAU);
  }

  if (obj) {
    cJSON_AddStringToObject(obj, "gt_mesh", gt_mesh_path);
    if (have_surface) {
      mgs_eval_geometry_add_metrics(obj, &gm);
    } else {
      cJSON_AddNullToObject(obj, "chamfer");
      cJSON_AddNullToObject(obj, "fscore");
    }
    cJSON_AddNumberToObject(obj, "fscore_threshold", thr);
    cJSON_AddNumberToObject(obj, "fscore_threshold_relative", EVAL_FSCORE_REL);
    cJSON_AddNumberToObject(obj, "geometry_samples", EVAL_SAMPLES);
    cJSON_AddNumberToObject(obj, "floaters", (double)floaters);
    cJSON_AddNumberToObject(obj, "floaters_fraction", g->n ? (double)floaters / (double)g->n : 0.0);
    cJSON_AddNumberToObject(obj, "low_opacity_gaussians", (double)low_op);
    cJSON_AddNumberToObject(obj, "surface_tau", EVAL_TAU);
    cJSON_AddNumberToObject(obj, "surface_voxel_size", info.voxel_size);
    cJSON_AddNumberToObject(obj, "surface_triangles", surf ? (double)surf->nt : 0.0);
    if (surf) {
      long chi = 0;
      cJSON_AddNumberToObject(obj, "surface_pieces", (double)mgs_mesh_pieces(surf, &chi));
      cJSON_AddNumberToObject(obj, "surface_euler", (double)chi);
    }
    cJSON_AddNumberToObject(obj, "geometry_seconds", mgs_now() - t0);
  }
  long chi = 0;
  size_t pieces = surf ? mgs_mesh_pieces(surf, &chi) : 0;
  if (table_out && table_len) {
    if (have_surface)
      snprintf(table_out, table_len,
               "  Chamfer distance      %.6g  (accuracy %.6g, completeness %.6g; offset %+.3g)\n"
               "  F-score @ %.4g        %.4f  (precision %.4f, recall %.4f; threshold = 1%% of GT diagonal)\n"
               "  floaters (H2)         %ld of %zu Gaussians (opacity < 0.01 and > 3 sigma from GT)\n"
               "  surface               {A = %.2g} (alpha-field), voxel %.4g, %zu triangles, %zu pieces, Euler characteristic %ld\n",
               gm.chamfer, gm.accuracy, gm.completeness, gm.offset, thr, gm.fscore, gm.precision, gm.recall, floaters, g->n,
               EVAL_TAU, info.voxel_size, surf ? surf->nt : 0, pieces, chi);
    else
      snprintf(table_out, table_len,
               "  Chamfer distance      n/a (no surface: the alpha field never reaches %.2g)\n"
               "  floaters (H2)         %ld of %zu Gaussians (opacity < 0.01 and > 3 sigma from GT)\n",
               EVAL_TAU, floaters, g->n);
  }
  rc = 0;
done:
  mgs_mesh_destroy(surf);
  mgs_mesh_destroy(gt);
  mgs_vdb_grid_destroy(sdf);
  mgs_vdb_grid_destroy(alpha);
  mgs_gaussians_destroy(g);
  return rc;
}

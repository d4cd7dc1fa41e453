/* The no-ground-truth choice between the depth-fused and the α-field's surface
 * (measure/mgs_surface_choice.h). */
#include "measure/mgs_surface_choice.h"
#include <math.h>
#include <stdlib.h>
#include "render/mgs_mesh_distance.h"
#include "core/mgs_ply.h"
#include "train/mgs_lpvi.h"
#include "vdb/mgs_vdb.h"

mgs_status mgs_surface_agreement_measure(const float *points, size_t n_points, const mgs_mesh *surface, double cap,
                                         mgs_surface_agreement *out, mgs_error *err) {
  out->to_surface = out->from_surface = out->score = cap;
  if (!(cap > 0)) return mgs_error_set(err, MGS_ERR_ARG, "surface agreement: cap %g must be positive", cap);
  if (!n_points) return mgs_error_set(err, MGS_ERR_ARG, "surface agreement: no rendered points");
  if (!surface || !surface->nt || !surface->nv) return MGS_OK; /* no surface: everything at the cap */
  mgs_mesh_distance *md = NULL;
  mgs_status st = mgs_mesh_distance_create(surface, &md, err);
  if (st) return st;
  float *dist = malloc(n_points * sizeof(float));
  mgs_kdtree *tree = mgs_kdtree_build(points, n_points);
  if (!dist || !tree) {
    st = mgs_error_set(err, MGS_ERR_NOMEM, "surface agreement: out of memory");
    goto done;
  }
  mgs_mesh_distance_query(md, n_points, points, dist, NULL);
  double s = 0;
  for (size_t i = 0; i < n_points; i++) s += fmin(fabs((double)dist[i]), cap);
  out->to_surface = s / (double)n_points;
  s = 0;
  for (size_t v = 0; v < surface->nv; v++) {
    const double q[3] = {surface->v[3 * v], surface->v[3 * v + 1], surface->v[3 * v + 2]};
    size_t idx;
    double d2 = INFINITY;
    s += mgs_kdtree_knn(tree, q, 1, &idx, &d2) ? fmin(sqrt(d2), cap) : cap;
  }
  out->from_surface = s / (double)surface->nv;
  out->score = 0.5 * (out->to_surface + out->from_surface);
done:
  mgs_kdtree_destroy(tree);
  free(dist);
  mgs_mesh_distance_destroy(md);
  return st;
}

int mgs_surface_choose(const float *points, size_t n_points, const mgs_mesh *fused, const mgs_mesh *alpha, double cap,
                       mgs_surface_agreement *fused_out, mgs_surface_agreement *alpha_out, mgs_error *err) {
  mgs_surface_agreement f, a;
  if (mgs_surface_agreement_measure(points, n_points, fused, cap, &f, err) != MGS_OK ||
      mgs_surface_agreement_measure(points, n_points, alpha, cap, &a, err) != MGS_OK)
    return -1;
  if (fused_out) *fused_out = f;
  if (alpha_out) *alpha_out = a;
  return a.score < f.score;
}

mgs_status mgs_alpha_surface_mesh(const char *ply_path, mgs_mesh **out, mgs_error *err) {
  *out = NULL;
  mgs_gaussians *g = NULL;
  mgs_vdb_grid *alpha = NULL, *sdf = NULL;
  mgs_vdb_alpha_params ap;
  mgs_vdb_alpha_params_default(&ap);
  mgs_vdb_sdf_params sp;
  mgs_vdb_sdf_params_default(&sp);
  mgs_status st;
  if ((st = mgs_ply_read_gaussians_local(ply_path, NULL, &g, err)) || (st = mgs_vdb_check_gaussians(g, ply_path, err)) ||
      (st = mgs_vdb_alpha_field(g, &ap, &alpha, NULL, err)) || (st = mgs_vdb_sdf_from_alpha(alpha, &sp, &sdf, err)))
    goto done;
  mgs_vdb_grid_translate(sdf, g->origin); /* world coordinates */
  if (mgs_vdb_grid_active_voxel_count(sdf)) st = mgs_vdb_extract_mesh(sdf, 0.0, 0.0, out, err);
done:
  mgs_vdb_grid_destroy(alpha);
  mgs_vdb_grid_destroy(sdf);
  mgs_gaussians_destroy(g);
  return st;
}

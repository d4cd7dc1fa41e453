/* A run's SuGaR mesh and its level set (train/mgs_sugar.h, mgs_sugar_export_run). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "train/mgs_sugar.h"
#include "train/mgs_train.h"
#include "core/mgs_core.h"
#include "vdb/mgs_vdb.h"
#include "vdb/mgs_vdb_mesh_sdf.h"

mgs_status mgs_sugar_export_run(const char *run_dir, int iteration, const mgs_sugar_mesh_options *o, int resolution,
                                int force, mgs_sugar_export_report *rep, mgs_error *err) {
  memset(rep, 0, sizeof *rep);
  if (resolution < 8 || resolution > 100000)
    return mgs_error_set(err, MGS_ERR_ARG, "sugar mesh: resolution %d outside [8, 100000]", resolution);
  double t0 = mgs_now();
  int n1 = snprintf(rep->ply, sizeof rep->ply, "%s/mesh/sugar.ply", run_dir);
  int n2 = snprintf(rep->vdb, sizeof rep->vdb, "%s/mesh/sugar.vdb", run_dir);
  if (n1 < 0 || n2 < 0 || (size_t)n1 >= sizeof rep->ply || (size_t)n2 >= sizeof rep->vdb)
    return mgs_error_set(err, MGS_ERR_ARG, "sugar mesh: run folder path too long");
  for (int k = 0; k < 2 && !force; k++)
    if (mgs_path_exists(k ? rep->vdb : rep->ply))
      return mgs_error_set(err, MGS_ERR_EXISTS, "%s exists; use --force to overwrite it", k ? rep->vdb : rep->ply);
  mgs_dataset *ds = NULL;
  mgs_gaussians *g = NULL;
  mgs_mesh *m = NULL;
  mgs_vdb_grid *sdf = NULL;
  mgs_camera *cams = NULL;
  mgs_status st = mgs_run_open(run_dir, iteration, 0, &ds, &g, &rep->iteration, err);
  if (st) goto done;
  size_t nv = ds->n_views[MGS_SPLIT_TRAIN];
  if (!nv) { st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: the dataset has no training views", run_dir); goto done; }
  if (!(cams = malloc(nv * sizeof *cams))) { st = mgs_error_set(err, MGS_ERR_NOMEM, "out of memory"); goto done; }
  for (size_t i = 0; i < nv; i++) cams[i] = ds->views[MGS_SPLIT_TRAIN][i].cam; /* local frame, as g */
  rep->views = nv;
  if ((st = mgs_sugar_mesh(g, cams, nv, o, &m, &rep->mesh, err))) goto done;
  double lo[3], hi[3];
  mgs_mesh_bounds(m, lo, hi);
  double diag = sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) + (hi[2] - lo[2]) * (hi[2] - lo[2]));
  rep->voxel_size = diag / resolution;
  if (!(rep->voxel_size > 0)) { st = mgs_error_set(err, MGS_ERR_NUMERIC, "sugar mesh: degenerate mesh (zero extent)"); goto done; }
  /* the level set in the model's local frame (float grids far from the origin), then moved */
  mgs_mesh_translate(m, g->origin, -1);
  st = mgs_vdb_sdf_from_mesh(m, rep->voxel_size, 3, &sdf, err);
  mgs_mesh_translate(m, g->origin, 1);
  if (st) goto done;
  mgs_vdb_grid_translate(sdf, g->origin);
  rep->active_voxels = mgs_vdb_grid_active_voxel_count(sdf);
  char *dir = mgs_path_join(run_dir, "mesh");
  st = dir ? mgs_mkdir_p(dir, err) : mgs_error_set(err, MGS_ERR_NOMEM, "out of memory");
  free(dir);
  if (st || (st = mgs_mesh_write(rep->ply, m, err))) goto done;
  mgs_vdb_file_meta meta;
  mgs_vdb_file_meta_default(&meta);
  meta.voxel_size = rep->voxel_size;
  snprintf(meta.source, sizeof meta.source, "%s (SuGaR mesh, iteration %d)", run_dir, rep->iteration);
  const mgs_vdb_grid *grids[1] = {sdf};
  st = mgs_vdb_write(rep->vdb, grids, 1, NULL, 0, &meta, err);
done:
  rep->seconds = mgs_now() - t0;
  mgs_vdb_grid_destroy(sdf);
  mgs_mesh_destroy(m);
  free(cams);
  mgs_gaussians_destroy(g);
  mgs_dataset_destroy(ds);
  return st;
}

/* morsegs vdb RUN --sugar-mesh: the report of mgs_sugar_export_run (train/mgs_sugar.h). */
#include <stdio.h>
#include "apps/mgs_cli.h"
#include "core/mgs_log.h"
#include "train/mgs_sugar.h"

int mgs_cmd_vdb_sugar(const char *run, int iteration, const mgs_sugar_mesh_options *o, int resolution, int force) {
  mgs_error err = {0};
  mgs_sugar_export_report r;
  if (mgs_sugar_export_run(run, iteration, o, resolution, force, &r, &err) != MGS_OK) return mgs_cli_fail("vdb", &err);
  mgs_info("sugar mesh: %zu training views, %zu level-%g points -> Poisson %zu vertices %zu triangles, %zu vertices "
           "trimmed", r.views, r.mesh.points, o->level, r.mesh.poisson_vertices, r.mesh.poisson_triangles,
           r.mesh.trimmed_vertices);
  printf("%s: %zu triangles (iteration %d); %s: sdf %zu active voxels, voxel size %g; %.2f s\n", r.ply,
         r.mesh.triangles, r.iteration, r.vdb, r.active_voxels, r.voxel_size, r.seconds);
  return 0;
}

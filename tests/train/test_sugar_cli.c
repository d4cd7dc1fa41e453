/* SuGaR end to end on a built-in scene: `morsegs train --preset sugar` (a short schedule:
 * 3DGS to 100, entropy to 180, prune at 180, SDF and normal losses to 300) records its
 * settings and reports its term; `morsegs vdb RUN --sugar-mesh` writes
 * RUN/mesh/sugar.ply and the level set RUN/mesh/sugar.vdb (grid sdf), refuses to overwrite
 * without --force; `morsegs eval` reports geometry.sugar; bad flags fail cleanly. */
#include <math.h>
#include <string.h>
#include <cjson/cJSON.h>
#include "mgs_test.h"
#include "core/mgs_core.h"
#include "vdb/mgs_vdb.h"

static char *slurp(const char *dir, const char *name) {
  char path[4200], *text = NULL;
  size_t n;
  snprintf(path, sizeof path, "%s/%s", dir, name);
  if (mgs_read_file(path, &text, &n, NULL) != MGS_OK) return NULL;
  return text;
}

int main(void) {
  const char *cli = getenv("MGS_CLI");
  if (!cli) { fprintf(stderr, "MGS_CLI not set\n"); return 2; }
  const char *tmp = mgs_test_tmpdir("sugar_cli");
  char data[4200], run[4200], path[4300];
  snprintf(data, sizeof data, "%s/sphere", tmp);
  snprintf(run, sizeof run, "%s/run", tmp);
  CHECK(mgs_test_sh("%s scene --builtin sphere -o %s --views 16 --test-views 2 --width 64 --height 64 --spp 1 -q", cli, data) == 0);
  CHECK(mgs_test_sh("%s train %s -o %s --preset sugar --iters 300 --densify-from 50 --densify-until 100 --sugar-from 100 "
                    "--sugar-prune-at 180 --sugar-knn-every 60 --sugar-samples 2000 --checkpoint-every 0 --seed 1 --quiet "
                    "--threads 2", cli, data, run) == 0);
  char *cfg = slurp(run, "cfg_args"), *stats = slurp(run, "train_stats.json");
  CHECK(cfg && strstr(cfg, "preset='sugar'") && strstr(cfg, "strategy='sugar'") && strstr(cfg, "sugar_prune_at=180") &&
        strstr(cfg, "sugar_samples=2000"));
  CHECK(stats && strstr(stats, "\"sugar\""));
  free(cfg);
  free(stats);
  /* the mesh and its level set */
  CHECK(mgs_test_sh("%s vdb %s --sugar-mesh --sugar-points 800 --resolution 128", cli, run) == 0);
  snprintf(path, sizeof path, "%s/mesh/sugar.vdb", run);
  mgs_vdb_grid *sdf = NULL;
  mgs_error err;
  CHECK_OK(mgs_vdb_read_grid(path, "sdf", &sdf, &err), &err);
  CHECK(sdf && mgs_vdb_grid_active_voxel_count(sdf) > 1000);
  mgs_vdb_grid_destroy(sdf);
  snprintf(path, sizeof path, "%s/mesh/sugar.ply", run);
  mgs_mesh *m = NULL;
  CHECK_OK(mgs_mesh_read(path, &m, &err), &err);
  CHECK(m && m->nt > 1000);
  mgs_mesh_destroy(m);
  CHECK(mgs_test_sh("%s vdb %s --sugar-mesh 2>/dev/null", cli, run) != 0);         /* exists: needs --force */
  CHECK(mgs_test_sh("%s vdb %s --sugar-mesh -o x.vdb 2>/dev/null", cli, run) != 0); /* no -o with it */
  CHECK(mgs_test_sh("%s vdb %s --sugar-mesh --sugar-level 1.5 2>/dev/null", cli, run) != 0);
  /* eval reports the mesh against the scene's gt_mesh.ply */
  CHECK(mgs_test_sh("%s eval %s --no-images --max-views 2 > /dev/null", cli, run) == 0);
  char *res = slurp(run, "results.json");
  cJSON *j = res ? cJSON_Parse(res) : NULL;
  cJSON *it = j ? cJSON_GetObjectItem(j, "ours_300") : NULL;
  cJSON *geo = it ? cJSON_GetObjectItem(it, "geometry") : NULL;
  cJSON *sg = geo ? cJSON_GetObjectItem(geo, "sugar") : NULL;
  cJSON *ch = sg ? cJSON_GetObjectItem(sg, "chamfer") : NULL;
  CHECK(cJSON_IsNumber(ch));
  if (cJSON_IsNumber(ch)) {
    printf("sugar mesh chamfer %.4f (alpha surface %.4f)\n", ch->valuedouble,
           cJSON_GetObjectItem(geo, "chamfer") ? cJSON_GetObjectItem(geo, "chamfer")->valuedouble : NAN);
    /* the GT sphere fills [-1,1]^3: a mesh of the object, not of noise */
    CHECK(ch->valuedouble < 0.1);
  }
  cJSON_Delete(j);
  free(res);
  /* flags of the stage without the stage; milestones out of order; --mpi refusal is in config */
  CHECK(mgs_test_sh("%s train %s -o %s/bad --iters 10 --sugar-samples 10 2>/dev/null", cli, data, tmp) != 0);
  CHECK(mgs_test_sh("%s train %s -o %s/bad --preset sugar --sugar-from 500 --sugar-prune-at 100 2>/dev/null", cli, data, tmp) != 0);
  snprintf(path, sizeof path, "%s/bad/cfg_args", tmp);
  CHECK(!mgs_path_exists(path));
  return mgs_test_finish();
}

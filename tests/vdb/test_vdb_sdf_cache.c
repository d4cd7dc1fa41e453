/* vdb/'s incremental SDF (mgs_vdb_sdf_from_alpha_cached): after the Gaussians of one
 * corner of a ragged field change (and one elsewhere is removed), the band is computed again
 * only around the α leaves that changed, and the grid equals a whole build voxel for voxel
 * (leaves, masks, values and the signed tiles above them), as does its persistence diagram,
 * for both the closest-point and the fast-sweeping constructions;
 * an unchanged field recomputes nothing; another lattice or τ builds the whole again. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "mgs_test.h"
#include "core/mgs_core.h"
#include "topo/mgs_persistence.h"
#include "vdb/mgs_vdb.h"
#include "vdb/vdb_test_util.h"

/* leaves, masks, values and the tiles above them, bit for bit */
static int same_grid(const mgs_vdb_grid *a, const mgs_vdb_grid *b) {
  if (!vt_same_leaves(a, b)) { fprintf(stderr, "  leaves differ\n"); return 0; }
  int same = 1;
  size_t ta = mgs_vdb_tiles(a, MGS_VDB_TILES_ALL, 1, NULL, 0), tb = mgs_vdb_tiles(b, MGS_VDB_TILES_ALL, 1, NULL, 0);
  if (ta != tb) { fprintf(stderr, "  tiles %zu vs %zu\n", ta, tb); return 0; }
  mgs_vdb_tile *xa = malloc((ta + 1) * sizeof *xa), *xb = malloc((tb + 1) * sizeof *xb);
  mgs_vdb_tiles(a, MGS_VDB_TILES_ALL, 1, xa, ta);
  mgs_vdb_tiles(b, MGS_VDB_TILES_ALL, 1, xb, tb);
  for (size_t i = 0; i < ta && same; i++)
    same = !memcmp(xa[i].origin, xb[i].origin, sizeof xa[i].origin) && xa[i].dim == xb[i].dim &&
           !memcmp(&xa[i].value, &xb[i].value, sizeof xa[i].value) && xa[i].active == xb[i].active;
  free(xa); free(xb);
  return same;
}

static int same_diagram(const mgs_vdb_grid *a, const mgs_vdb_grid *b, double hw) {
  mgs_topo_opts to;
  mgs_topo_opts_default(&to);
  to.half_width = hw;
  mgs_diagram *da = NULL, *db = NULL;
  mgs_error err;
  CHECK_OK(mgs_topo_persistence_vdb(a, &to, &da, &err), &err);
  CHECK_OK(mgs_topo_persistence_vdb(b, &to, &db, &err), &err);
  int same = da && db && da->n == db->n && da->n > 0;
  for (size_t k = 0; same && k < da->n; k++)
    same = da->pairs[k].dim == db->pairs[k].dim && da->pairs[k].birth == db->pairs[k].birth && da->pairs[k].death == db->pairs[k].death;
  if (da) fprintf(stderr, "  diagram: %zu pairs\n", da->n);
  mgs_diagram_destroy(da); mgs_diagram_destroy(db);
  return same;
}

static void run(mgs_vdb_sdf_method method) {
  mgs_gaussians *g = vt_random_gaussians(MGS_TEST_SANITIZED ? 2500 : 6000, 11, 0.06, 0.01, -1, 3);
  mgs_vdb_alpha_params ap;
  mgs_vdb_alpha_params_default(&ap);
  ap.voxel_size = 0.02;
  mgs_vdb_sdf_params sp;
  mgs_vdb_sdf_params_default(&sp);
  sp.half_width = 4;
  sp.method = method;
  mgs_vdb_sdf_cache *c = mgs_vdb_sdf_cache_create();
  CHECK(c != NULL);
  mgs_error err;
  mgs_vdb_sdf_update_info info;
  mgs_vdb_grid *a0 = NULL, *a1 = NULL, *s0 = NULL, *s1 = NULL, *ref = NULL;
  CHECK_OK(mgs_vdb_alpha_field(g, &ap, &a0, NULL, &err), &err);
  CHECK_OK(mgs_vdb_sdf_from_alpha_cached(a0, &sp, c, &s0, &info, &err), &err);
  CHECK(info.whole == 1);
  CHECK_OK(mgs_vdb_sdf_from_alpha(a0, &sp, &ref, &err), &err);
  if (s0 && ref) CHECK_MSG(same_grid(s0, ref), "a first cached build differs from mgs_vdb_sdf_from_alpha");
  mgs_vdb_grid_destroy(ref); ref = NULL;
  /* the same field again: nothing to redo */
  CHECK_OK(mgs_vdb_sdf_from_alpha_cached(a0, &sp, c, &s1, &info, &err), &err);
  CHECK(info.whole == 0 && info.leaves_changed == 0 && info.leaves_recomputed == 0);
  if (s0 && s1) CHECK(same_grid(s0, s1));
  mgs_vdb_grid_destroy(s1); s1 = NULL;
  /* one corner changes; one Gaussian elsewhere goes */
  size_t changed = 0;
  for (size_t i = 2; i < g->n; i++)
    if (g->mean[3 * i] > 0.6f && g->mean[3 * i + 1] > 0.6f && g->mean[3 * i + 2] > 0.6f) {
      g->opacity[i] += 1.0f;
      g->mean[3 * i] -= 0.02f;
      changed++;
    }
  g->opacity[200] = -20.0f;
  CHECK(changed > 0);
  CHECK_OK(mgs_vdb_alpha_field(g, &ap, &a1, NULL, &err), &err);
  CHECK_OK(mgs_vdb_sdf_from_alpha_cached(a1, &sp, c, &s1, &info, &err), &err);
  CHECK_OK(mgs_vdb_sdf_from_alpha(a1, &sp, &ref, &err), &err);
  fprintf(stderr, "  %zu Gaussians changed: %zu alpha leaves differ, %zu of %zu band leaves recomputed\n", changed,
          info.leaves_changed, info.leaves_recomputed, info.leaves_total);
  CHECK(info.whole == 0);
  CHECK_MSG(info.leaves_changed > 0 && info.leaves_recomputed > 0 && info.leaves_recomputed < info.leaves_total / 2,
            "%zu of %zu band leaves recomputed", info.leaves_recomputed, info.leaves_total);
  if (s1 && ref) {
    CHECK_MSG(same_grid(s1, ref), "the incremental SDF differs from a whole build");
    CHECK_MSG(same_diagram(s1, ref, sp.half_width * ap.voxel_size), "the diagrams differ");
  }
  mgs_vdb_grid_destroy(s1); s1 = NULL;
  mgs_vdb_grid_destroy(ref); ref = NULL;
  /* another τ: the whole is built, still right */
  sp.tau = 0.4;
  CHECK_OK(mgs_vdb_sdf_from_alpha_cached(a1, &sp, c, &s1, &info, &err), &err);
  CHECK(info.whole == 1);
  CHECK_OK(mgs_vdb_sdf_from_alpha(a1, &sp, &ref, &err), &err);
  if (s1 && ref) CHECK(same_grid(s1, ref));
  mgs_vdb_grid_destroy(s1); s1 = NULL;
  /* the cache holds its own reference to the α-field it was built from */
  mgs_vdb_grid_destroy(a1); a1 = NULL;
  CHECK_OK(mgs_vdb_alpha_field(g, &ap, &a1, NULL, &err), &err);
  CHECK_OK(mgs_vdb_sdf_from_alpha_cached(a1, &sp, c, &s1, &info, &err), &err);
  CHECK(info.whole == 0 && info.leaves_changed == 0);
  if (s1 && ref) CHECK(same_grid(s1, ref));
  mgs_vdb_grid *none = NULL;
  CHECK(mgs_vdb_sdf_from_alpha_cached(a1, &sp, NULL, &none, NULL, &err) == MGS_ERR_ARG && none == NULL);
  mgs_vdb_grid_destroy(a0); mgs_vdb_grid_destroy(a1); mgs_vdb_grid_destroy(s0); mgs_vdb_grid_destroy(s1);
  mgs_vdb_grid_destroy(ref);
  mgs_vdb_sdf_cache_destroy(c);
  mgs_gaussians_destroy(g);
}

static void test_closest(void) { run(MGS_VDB_SDF_CLOSEST); }
static void test_sweep(void) { run(MGS_VDB_SDF_SWEEP); }

int main(void) {
  RUN(test_closest);
  RUN(test_sweep);
  return mgs_test_finish();
}

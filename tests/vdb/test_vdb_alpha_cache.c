/* vdb/'s incremental α-field (mgs_vdb_alpha_field_cached): after a few Gaussians in one
 * corner change, the cached build copies the untouched leaves and its grid is
 * bit-identical to a build from scratch; a changed voxel size or lattice reuses nothing. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "mgs_test.h"
#include "core/mgs_core.h"
#include "vdb/mgs_vdb.h"
#include "vdb/vdb_test_util.h"

static void test_cache(void) {
  mgs_gaussians *g = vt_random_gaussians(4000, 5, 0.03, 0.03, -1, 2);
  mgs_vdb_alpha_params ap;
  mgs_vdb_alpha_params_default(&ap);
  ap.voxel_size = 0.02;
  mgs_vdb_alpha_cache *c = mgs_vdb_alpha_cache_create();
  CHECK(c != NULL);
  mgs_error err;
  mgs_vdb_build_info info;
  mgs_vdb_grid *a = NULL, *b = NULL, *ref = NULL;
  CHECK_OK(mgs_vdb_alpha_field_cached(g, &ap, c, &a, &info, &err), &err);
  CHECK(info.leaves_reused == 0);
  size_t leaves = info.leaves;
  /* unchanged: every leaf copied, the same grid */
  CHECK_OK(mgs_vdb_alpha_field_cached(g, &ap, c, &b, &info, &err), &err);
  CHECK_MSG(info.leaves_reused == leaves, "unchanged model: %zu of %zu leaves reused", info.leaves_reused, leaves);
  if (a && b) CHECK(vt_same_leaves(a, b));
  mgs_vdb_grid_destroy(b);
  b = NULL;
  /* a few Gaussians in one corner move and change opacity; one is removed (indices shift) */
  size_t changed = 0;
  for (size_t i = 2; i < g->n; i++)
    if (g->mean[3 * i] > 0.7f && g->mean[3 * i + 1] > 0.7f && g->mean[3 * i + 2] > 0.7f) {
      g->opacity[i] += 0.5f;
      g->mean[3 * i] -= 0.01f;
      changed++;
    }
  uint8_t *keep = malloc(g->n);
  memset(keep, 1, g->n);
  keep[100] = 0;
  mgs_gaussians_compact(g, keep);
  free(keep);
  CHECK_OK(mgs_vdb_alpha_field_cached(g, &ap, c, &b, &info, &err), &err);
  CHECK_OK(mgs_vdb_alpha_field(g, &ap, &ref, NULL, &err), &err);
  fprintf(stderr, "  %zu of %zu Gaussians changed, one removed: %zu of %zu leaves reused\n", changed, g->n, info.leaves_reused,
          info.leaves);
  CHECK(changed > 0);
  CHECK_MSG(info.leaves_reused > info.leaves / 2 && info.leaves_reused < info.leaves, "reused %zu of %zu", info.leaves_reused, info.leaves);
  if (b && ref) CHECK_MSG(vt_same_leaves(b, ref), "the cached build differs from a build from scratch");
  mgs_vdb_grid_destroy(b);
  b = NULL;
  /* another voxel size: nothing reused, still right */
  ap.voxel_size = 0.025;
  mgs_vdb_grid_destroy(ref);
  ref = NULL;
  CHECK_OK(mgs_vdb_alpha_field_cached(g, &ap, c, &b, &info, &err), &err);
  CHECK(info.leaves_reused == 0);
  CHECK_OK(mgs_vdb_alpha_field(g, &ap, &ref, NULL, &err), &err);
  if (b && ref) CHECK(vt_same_leaves(b, ref));
  mgs_vdb_grid_destroy(a); mgs_vdb_grid_destroy(b); mgs_vdb_grid_destroy(ref);
  CHECK(mgs_vdb_alpha_field_cached(g, &ap, NULL, &b, NULL, &err) == MGS_ERR_ARG);
  mgs_vdb_alpha_cache_destroy(c);
  mgs_gaussians_destroy(g);
}

int main(void) {
  RUN(test_cache);
  return mgs_test_finish();
}

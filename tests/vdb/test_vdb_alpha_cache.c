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

static mgs_gaussians *scene(size_t n) {
  mgs_gaussians *g = mgs_gaussians_create(n, 0);
  size_t first;
  if (!g || mgs_gaussians_append(g, n, &first, NULL)) exit(2);
  mgs_rng r;
  mgs_rng_init(&r, 5, 1);
  for (size_t i = 0; i < n; i++) {
    for (int k = 0; k < 3; k++) {
      g->mean[3 * i + k] = (float)(2 * mgs_rng_uniform(&r) - 1);
      g->log_scale[3 * i + k] = (float)log(0.01 + 0.03 * mgs_rng_uniform(&r));
    }
    for (int k = 0; k < 4; k++) g->rot[4 * i + k] = (float)mgs_rng_normal(&r);
    g->opacity[i] = (float)(2 * mgs_rng_uniform(&r) - 1);
  }
  /* two fixed corners hold the means' box (so the lattice stays when others move) */
  for (int k = 0; k < 3; k++) { g->mean[k] = -1.2f; g->mean[3 + k] = 1.2f; }
  return g;
}

/* 1 when both grids have the same leaves, masks and values, bit for bit */
static int same_grid(const mgs_vdb_grid *a, const mgs_vdb_grid *b) {
  size_t na = mgs_vdb_leaf_count(a), nb = mgs_vdb_leaf_count(b);
  if (na != nb) return 0;
  mgs_vdb_leaf_view *la = malloc((na + 1) * sizeof *la), *lb = malloc((nb + 1) * sizeof *lb);
  mgs_vdb_leaf_views(a, la, na);
  mgs_vdb_leaf_views(b, lb, nb);
  int same = 1;
  for (size_t i = 0; i < na && same; i++) {
    same = !memcmp(la[i].origin, lb[i].origin, sizeof la[i].origin) && !memcmp(la[i].active_mask, lb[i].active_mask, 64) &&
           !memcmp(la[i].values, lb[i].values, 512 * sizeof(float));
  }
  free(la); free(lb);
  return same;
}

static void test_cache(void) {
  mgs_gaussians *g = scene(4000);
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
  if (a && b) CHECK(same_grid(a, b));
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
  if (b && ref) CHECK_MSG(same_grid(b, ref), "the cached build differs from a build from scratch");
  mgs_vdb_grid_destroy(b);
  b = NULL;
  /* another voxel size: nothing reused, still right */
  ap.voxel_size = 0.025;
  mgs_vdb_grid_destroy(ref);
  ref = NULL;
  CHECK_OK(mgs_vdb_alpha_field_cached(g, &ap, c, &b, &info, &err), &err);
  CHECK(info.leaves_reused == 0);
  CHECK_OK(mgs_vdb_alpha_field(g, &ap, &ref, NULL, &err), &err);
  if (b && ref) CHECK(same_grid(b, ref));
  mgs_vdb_grid_destroy(a); mgs_vdb_grid_destroy(b); mgs_vdb_grid_destroy(ref);
  CHECK(mgs_vdb_alpha_field_cached(g, &ap, NULL, &b, NULL, &err) == MGS_ERR_ARG);
  mgs_vdb_alpha_cache_destroy(c);
  mgs_gaussians_destroy(g);
}

int main(void) {
  RUN(test_cache);
  return mgs_test_finish();
}

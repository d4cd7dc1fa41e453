/* The gradient path's leaf cache (mgs_topo_opts.cache): a ragged SDF of random flat and
 * round Gaussians, analysed, then again after one corner changed. Through the cache the
 * second diagram equals an uncached call's pair for pair, most leaves come from the cache
 * and the changed ones do not; an unchanged field takes every leaf from it; another
 * construction (T) or clamp reuses nothing and is still right. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "mgs_test.h"
#include "core/mgs_core.h"
#include "topo/mgs_persistence.h"
#include "vdb/mgs_vdb.h"
#include "vdb/vdb_test_util.h"

static mgs_vdb_grid *sdf_of(const mgs_gaussians *g) {
  mgs_vdb_alpha_params ap;
  mgs_vdb_alpha_params_default(&ap);
  ap.voxel_size = 0.02;
  mgs_vdb_sdf_params sp;
  mgs_vdb_sdf_params_default(&sp);
  sp.half_width = 4;
  mgs_error err;
  mgs_vdb_grid *a = NULL, *s = NULL;
  CHECK_OK(mgs_vdb_alpha_field(g, &ap, &a, NULL, &err), &err);
  if (a) CHECK_OK(mgs_vdb_sdf_from_alpha(a, &sp, &s, &err), &err);
  mgs_vdb_grid_destroy(a);
  return s;
}

static int same(const mgs_diagram *a, const mgs_diagram *b) {
  if (!a || !b || a->n != b->n || !a->n) return 0;
  for (size_t k = 0; k < a->n; k++)
    if (a->pairs[k].dim != b->pairs[k].dim || a->pairs[k].birth != b->pairs[k].birth || a->pairs[k].death != b->pairs[k].death)
      return 0;
  return 1;
}

static void run(mgs_topo_construction cons) {
  mgs_gaussians *g = vt_random_gaussians(MGS_TEST_SANITIZED ? 2500 : 6000, 13, 0.06, 0.01, -1, 3);
  mgs_vdb_grid *s0 = sdf_of(g);
  for (size_t i = 2; i < g->n; i++)
    if (g->mean[3 * i] > 0.6f && g->mean[3 * i + 1] > 0.6f && g->mean[3 * i + 2] > 0.6f) g->opacity[i] += 1.0f, g->mean[3 * i] -= 0.02f;
  mgs_vdb_grid *s1 = sdf_of(g);
  if (!s0 || !s1) { mgs_vdb_grid_destroy(s0); mgs_vdb_grid_destroy(s1); mgs_gaussians_destroy(g); return; }
  mgs_topo_cache *c = mgs_topo_cache_create();
  CHECK(c != NULL);
  mgs_topo_opts o;
  mgs_topo_opts_default(&o);
  o.construction = cons;
  o.half_width = 4 * 0.02;
  mgs_error err;
  mgs_diagram *d0 = NULL, *d0c = NULL, *d1 = NULL, *d1c = NULL, *again = NULL;
  mgs_topo_stats st;
  CHECK_OK(mgs_topo_persistence_vdb(s0, &o, &d0, &err), &err);
  CHECK_OK(mgs_topo_persistence_vdb(s1, &o, &d1, &err), &err);
  o.cache = c;
  CHECK_OK(mgs_topo_persistence_vdb_stats(s0, &o, &d0c, &st, &err), &err);
  CHECK(st.leaves_reused == 0);
  CHECK_MSG(same(d0, d0c), "first cached call: diagram differs");
  CHECK_OK(mgs_topo_persistence_vdb_stats(s0, &o, &again, &st, &err), &err);
  CHECK_MSG(st.leaves_reused == st.leaves, "unchanged field: %zu of %zu leaves reused", st.leaves_reused, st.leaves);
  CHECK(same(d0, again));
  CHECK_OK(mgs_topo_persistence_vdb_stats(s1, &o, &d1c, &st, &err), &err);
  fprintf(stderr, "  %s: one corner changed: %zu of %zu leaves reused, %zu pairs\n", cons == MGS_TOPO_V ? "V" : "T", st.leaves_reused,
          st.leaves, d1 ? d1->n : 0);
  CHECK_MSG(st.leaves_reused > st.leaves / 2 && st.leaves_reused < st.leaves, "%zu of %zu leaves reused", st.leaves_reused, st.leaves);
  CHECK_MSG(same(d1, d1c), "the cached diagram differs from an uncached one");
  /* another clamp: nothing reused, still right */
  mgs_diagram_destroy(again);
  again = NULL;
  o.half_width = 3 * 0.02;
  mgs_diagram *d1w = NULL;
  o.cache = NULL;
  CHECK_OK(mgs_topo_persistence_vdb(s1, &o, &d1w, &err), &err);
  o.cache = c;
  CHECK_OK(mgs_topo_persistence_vdb_stats(s1, &o, &again, &st, &err), &err);
  CHECK(st.leaves_reused == 0 && same(d1w, again));
  mgs_diagram_destroy(d0); mgs_diagram_destroy(d0c); mgs_diagram_destroy(d1); mgs_diagram_destroy(d1c);
  mgs_diagram_destroy(again); mgs_diagram_destroy(d1w);
  mgs_topo_cache_destroy(c);
  mgs_vdb_grid_destroy(s0); mgs_vdb_grid_destroy(s1);
  mgs_gaussians_destroy(g);
}

static void test_cache_v(void) { run(MGS_TOPO_V); }
static void test_cache_t(void) { run(MGS_TOPO_T); }

int main(void) {
  RUN(test_cache_v);
  RUN(test_cache_t);
  return mgs_test_finish();
}

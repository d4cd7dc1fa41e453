/* The VDB path: a level set built from a dense SDF (band of |d| < background, interior
 * and outside pruned into tiles) gives the same diagram as the dense clamped field, and the
 * Betti numbers of known shapes at t=0; positions follow the grid transform. */
#include "topo_test_util.h"
#include "vdb/mgs_vdb.h"

static void vdb_case(int kind, int N, double bgvox, int e0, int e1, int e2) {
  float *f = tt_field(kind, N, 9);
  float bg = (float)(bgvox / N);
  double h = 1.0 / N, t[3] = {0.25, -1.0, 3.0};
  int32_t origin[3] = {-16, 8, 0}, dims[3] = {N, N, N};
  mgs_vdb_grid *g = NULL;
  mgs_error err = {0};
  CHECK_OK(mgs_vdb_grid_from_dense("sdf", MGS_VDB_CLASS_LEVEL_SET, h, t, bg, origin, dims, f, &g, &err), &err);
  if (!g) { free(f); return; }
  mgs_topo_opts o;
  mgs_topo_opts_default(&o);
  o.half_width = 1e9; /* limited to the band: w = background */
  mgs_diagram *dv = NULL, *dd = NULL;
  mgs_topo_stats st;
  CHECK_OK(mgs_topo_persistence_vdb_stats(g, &o, &dv, &st, &err), &err);
  CHECK_NEAR(st.effective_w, bg, 0);
  o.half_width = bg;
  CHECK_OK(mgs_topo_persistence_dense(f, N, N, N, &o, &dd, &err), &err);
  if (dv && dd) {
    tt_pair *a, *b;
    size_t na = tt_from_diagram(dd, &a), nb = tt_from_diagram(dv, &b);
    char what[96];
    snprintf(what, sizeof what, "%s N=%d vdb vs dense", tt_names[kind], N);
    CHECK_MSG(tt_equal(what, b, nb, a, na), "%s differ", what);
    int bb[3];
    tt_betti(dv, 0.0, bb);
    CHECK_MSG(bb[0] == e0 && bb[1] == e1 && bb[2] == e2, "%s: vdb Betti %d %d %d expected %d %d %d", what, bb[0], bb[1], bb[2], e0, e1, e2);
    /* world positions: voxel ijk (grid index) -> ijk*h + t */
    for (size_t i = 0; i < dv->n; i++) {
      const mgs_pair_end *e = &dv->pairs[i].b;
      int inside = 1;
      for (int k = 0; k < 3; k++) {
        double lo = origin[k] * h + t[k] - h, hi = (origin[k] + N) * h + t[k];
        if (!(e->pos[k] >= lo && e->pos[k] <= hi)) inside = 0;
      }
      CHECK_MSG(inside, "pair %zu birth position (%g %g %g) outside the grid", i, e->pos[0], e->pos[1], e->pos[2]);
      if (!inside) break;
      /* the birth voxel holds the birth value (V construction) */
      int32_t ijk[3] = {e->voxel[0], e->voxel[1], e->voxel[2]};
      float v = mgs_vdb_value(g, ijk, NULL);
      v = v < -bg ? -bg : (v > bg ? bg : v);
      CHECK_MSG(v == (float)dv->pairs[i].birth, "pair %zu: birth voxel value %g != birth %g", i, (double)v, dv->pairs[i].birth);
    }
    fprintf(stderr, "  %s: %zu pairs equal, Betti(0) %d %d %d; active %zu, leaves %zu, tiles %zu, cells %zu of %zu\n", what, nb,
            bb[0], bb[1], bb[2], st.active_voxels, st.leaves, st.tiles, st.cells_built, st.cells_total);
    free(a);
    free(b);
  }
  mgs_diagram_destroy(dv);
  mgs_diagram_destroy(dd);
  mgs_vdb_grid_destroy(g);
  free(f);
}

static void test_vdb_shapes(void) {
  vdb_case(TT_TORUS, 40, 2, 1, 1, 0);
  vdb_case(TT_TORUS_SHELL, 40, 2, 1, 2, 1);
  vdb_case(TT_SPHERE_SHELL, 40, 2, 1, 0, 1);
  vdb_case(TT_TUNNEL_BLOCK, 64, 2, 1, 1, 0);
}

static void test_vdb_bad(void) {
  mgs_vdb_grid *g = NULL;
  mgs_error err = {0};
  CHECK_OK(mgs_vdb_grid_create("sdf", MGS_VDB_CLASS_LEVEL_SET, 0.1, NULL, -1.0f, &g, &err), &err);
  mgs_diagram *d = NULL;
  if (g) {
    CHECK(mgs_topo_persistence_vdb(g, NULL, &d, &err) == MGS_ERR_FORMAT && d == NULL);
    CHECK(strstr(err.msg, "background") != NULL);
    mgs_vdb_grid_destroy(g);
  }
  /* an empty level set: empty diagram, no error */
  CHECK_OK(mgs_vdb_grid_create("sdf", MGS_VDB_CLASS_LEVEL_SET, 0.1, NULL, 0.3f, &g, &err), &err);
  if (g) {
    CHECK_OK(mgs_topo_persistence_vdb(g, NULL, &d, &err), &err);
    CHECK(d && d->n == 0);
    mgs_diagram_destroy(d);
    mgs_vdb_grid_destroy(g);
  }
}

int main(void) {
  RUN(test_vdb_shapes);
  RUN(test_vdb_bad);
  return mgs_test_finish();
}

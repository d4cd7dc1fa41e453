/* The narrow-band (sparse) path: Betti numbers at t=0 of known shapes in the dense and the
 * sparse path, and the sparse result equal to the dense computation of the clamped field
 * (and to PHAT) on fields with large interior regions (constant -w blocks) and outside
 * (+w) regions. Bad input: broken bands, non-finite values, bad options. */
#include "topo_test_util.h"

static mgs_diagram *dense(const float *f, int N, double w, int cons) {
  mgs_topo_opts o;
  mgs_topo_opts_default(&o);
  o.half_width = w;
  o.construction = cons ? MGS_TOPO_T : MGS_TOPO_V;
  mgs_diagram *d = NULL;
  mgs_error err = {0};
  CHECK_OK(mgs_topo_persistence_dense(f, N, N, N, &o, &d, &err), &err);
  return d;
}

static mgs_diagram *sparse(const float *f, int N, double w, int cons, mgs_topo_stats *st) {
  mgs_topo_opts o;
  mgs_topo_opts_default(&o);
  o.half_width = w;
  o.construction = cons ? MGS_TOPO_T : MGS_TOPO_V;
  mgs_topo_sparse *s = NULL;
  mgs_diagram *d = NULL;
  mgs_error err = {0};
  CHECK_OK(mgs_topo_sparse_from_dense(f, N, N, N, (float)w, &s, &err), &err);
  if (s) CHECK_OK(mgs_topo_persistence_sparse(s, &o, &d, st, &err), &err);
  mgs_topo_sparse_destroy(s);
  return d;
}

static void betti_case(int kind, int N, double wvox, int e0, int e1, int e2) {
  float *f = tt_field(kind, N, 3);
  double w = (double)(float)(wvox / N);
  for (int cons = 0; cons < 2; cons++) {
    mgs_diagram *dd = dense(f, N, w, cons);
    mgs_topo_stats st;
    mgs_diagram *ds = sparse(f, N, w, cons, &st);
    int bd[3] = {-1, -1, -1}, bs[3] = {-1, -1, -1};
    if (dd) tt_betti(dd, 0.0, bd);
    if (ds) tt_betti(ds, 0.0, bs);
    CHECK_MSG(bd[0] == e0 && bd[1] == e1 && bd[2] == e2, "%s %c dense Betti %d %d %d, expected %d %d %d",
              tt_names[kind], cons ? 'T' : 'V', bd[0], bd[1], bd[2], e0, e1, e2);
    CHECK_MSG(bs[0] == e0 && bs[1] == e1 && bs[2] == e2, "%s %c sparse Betti %d %d %d, expected %d %d %d",
              tt_names[kind], cons ? 'T' : 'V', bs[0], bs[1], bs[2], e0, e1, e2);
    fprintf(stderr, "  %s N=%d %c: Betti(0) dense %d %d %d, band %d %d %d (band cells %zu of %zu, %zu leaves, %zu tiles)\n",
            tt_names[kind], N, cons ? 'T' : 'V', bd[0], bd[1], bd[2], bs[0], bs[1], bs[2], st.cells_built, st.cells_total,
            st.leaves, st.tiles);
    mgs_diagram_destroy(dd);
    mgs_diagram_destroy(ds);
  }
  free(f);
}

static void test_betti(void) {
  betti_case(TT_TORUS, 32, 3, 1, 1, 0);
  betti_case(TT_TORUS_SHELL, 32, 2, 1, 2, 1);
  betti_case(TT_SPHERE_SHELL, 32, 2, 1, 0, 1);
}

/* sparse == dense (exactly, positions included) and == PHAT */
static void equal_case(int kind, int N, double wvox, int cons, int with_ref) {
  float *f = tt_field(kind, N, 5);
  double w = (double)(float)(wvox / N);
  mgs_diagram *dd = dense(f, N, w, cons);
  mgs_topo_stats st;
  mgs_diagram *ds = sparse(f, N, w, cons, &st);
  if (dd && ds) {
    tt_pair *a, *b;
    size_t na = tt_from_diagram(dd, &a), nb = tt_from_diagram(ds, &b);
    char what[128];
    snprintf(what, sizeof what, "%s N=%d %c band vs dense", tt_names[kind], N, cons ? 'T' : 'V');
    CHECK_MSG(tt_equal(what, b, nb, a, na), "%s differ", what);
    if (kind == TT_TUNNEL_BLOCK) CHECK(st.tiles > 0); /* must exercise constant blocks */
    CHECK(st.cells_built < st.cells_total);
    size_t trunc = 0;
    for (size_t i = 0; i < ds->n; i++) trunc += (size_t)ds->pairs[i].truncated;
    fprintf(stderr, "  %s: %zu pairs (%zu truncated), band cells %zu of %zu, leaves %zu tiles %zu\n", what, nb, trunc,
            st.cells_built, st.cells_total, st.leaves, st.tiles);
    if (with_ref) {
      tt_pair *r;
      long nr = tt_reference(cons ? "gudhi" : "phat", f, N, N, N, cons, 0, w, &r);
      CHECK(nr >= 0);
      if (nr >= 0) {
        snprintf(what, sizeof what, "%s N=%d %c band vs %s", tt_names[kind], N, cons ? 'T' : 'V', cons ? "gudhi" : "phat");
        CHECK_MSG(tt_equal(what, b, nb, r, (size_t)nr), "%s differ", what);
        free(r);
      }
    }
    /* same cells and voxels as the dense path, not only the same values */
    if (na == nb)
      for (size_t i = 0; i < na; i++)
        if (memcmp(dd->pairs[i].b.voxel, ds->pairs[i].b.voxel, sizeof dd->pairs[i].b.voxel) != 0 && dd->pairs[i].birth != ds->pairs[i].birth) {
          CHECK_MSG(0, "pair %zu birth voxel differs", i);
          break;
        }
    free(a);
    free(b);
  }
  mgs_diagram_destroy(dd);
  mgs_diagram_destroy(ds);
  free(f);
}

static int full = 0;

static void test_band_equals_dense(void) {
  equal_case(TT_TUNNEL_BLOCK, 64, 2, 0, 0);
  equal_case(TT_FLOATERS, 32, 3, 0, 0);
  if (!full) return;
  equal_case(TT_TUNNEL_BLOCK, 64, 2, 1, 1);
  equal_case(TT_TUNNEL_BLOCK, 64, 3, 0, 1);
  equal_case(TT_NOISY_TORUS, 40, 3, 0, 1);
  equal_case(TT_FLOATERS, 32, 3, 1, 0);
  equal_case(TT_GENUS2, 32, 2, 0, 0);
  equal_case(TT_SHELLS, 32, 2, 0, 0);
}

/* A fog volume (density, background 0) with the superlevel filtration: the sparse path
 * (top = the background) equals the dense box of the same densities. */
static void test_fog_superlevel(void) {
  const int N = 32;
  float *sdf = tt_field(TT_FLOATERS, N, 4);
  float *rho = malloc((size_t)N * N * N * sizeof *rho);
  for (size_t i = 0; i < (size_t)N * N * N; i++) {
    double v = 0.5 - sdf[i] * N / 4.0;
    rho[i] = (float)(v < 0 ? 0 : (v > 1 ? 1 : v));
  }
  mgs_topo_sparse *s = NULL;
  mgs_error err = {0};
  CHECK_OK(mgs_topo_sparse_create(0.0f, &s, &err), &err);
  float blk[512];
  size_t leaves = 0;
  for (int bx = 0; bx < N / 8; bx++)
    for (int by = 0; by < N / 8; by++)
      for (int bz = 0; bz < N / 8; bz++) {
        int any = 0;
        for (int i = 0; i < 512; i++) {
          int x = bx * 8 + (i >> 6), y = by * 8 + ((i >> 3) & 7), z = bz * 8 + (i & 7);
          blk[i] = rho[((size_t)x * N + y) * N + z];
          any |= blk[i] != 0;
        }
        int32_t o[3] = {bx * 8, by * 8, bz * 8};
        if (any) { CHECK_OK(mgs_topo_sparse_add_leaf(s, o, blk, &err), &err); leaves++; }
      }
  CHECK(leaves > 0 && leaves < (size_t)(N / 8) * (N / 8) * (N / 8));
  mgs_topo_opts o;
  mgs_topo_opts_default(&o);
  o.filtration = MGS_TOPO_SUPERLEVEL;
  mgs_diagram *ds = NULL, *dd = NULL;
  CHECK_OK(mgs_topo_persistence_sparse(s, &o, &ds, NULL, &err), &err);
  CHECK_OK(mgs_topo_persistence_dense(rho, N, N, N, &o, &dd, &err), &err);
  if (ds && dd) {
    tt_pair *a, *b;
    size_t na = tt_from_diagram(dd, &a), nb = tt_from_diagram(ds, &b);
    CHECK_MSG(tt_equal("fog superlevel band vs dense", b, nb, a, na), "fog diagrams differ");
    CHECK(nb > 1);
    tt_pair *r;
    long nr = tt_reference("phat", rho, N, N, N, 0, 1, INFINITY, &r);
    CHECK(nr >= 0);
    if (nr >= 0) { CHECK_MSG(tt_equal("fog superlevel dense vs phat", a, na, r, (size_t)nr), "fog vs phat differ"); free(r); }
    fprintf(stderr, "  fog superlevel: %zu pairs, band == dense == PHAT\n", nb);
    free(a);
    free(b);
  }
  mgs_diagram_destroy(ds);
  mgs_diagram_destroy(dd);
  mgs_topo_sparse_destroy(s);
  free(rho);
  free(sdf);
}

static void test_bad_input(void) {
  mgs_error err = {0};
  mgs_diagram *d = NULL;
  float v[8] = {0, 1, 2, 3, 4, 5, 6, NAN};
  CHECK(mgs_topo_persistence_dense(v, 2, 2, 2, NULL, &d, &err) == MGS_ERR_NUMERIC && d == NULL);
  CHECK(strstr(err.msg, "non-finite") != NULL);
  mgs_topo_opts o;
  mgs_topo_opts_default(&o);
  o.half_width = -1;
  v[7] = 0;
  CHECK(mgs_topo_persistence_dense(v, 2, 2, 2, &o, &d, &err) == MGS_ERR_ARG);
  CHECK(mgs_topo_persistence_dense(v, 0, 2, 2, NULL, &d, &err) == MGS_ERR_ARG);
  /* an interior tile touching the background: broken narrow band */
  mgs_topo_sparse *s = NULL;
  CHECK_OK(mgs_topo_sparse_create(3.0f, &s, &err), &err);
  int32_t o0[3] = {0, 0, 0};
  CHECK_OK(mgs_topo_sparse_add_tile(s, o0, 8, -3.0f, &err), &err);
  mgs_topo_opts_default(&o);
  o.half_width = 3;
  CHECK(mgs_topo_persistence_sparse(s, &o, &d, NULL, &err) == MGS_ERR_FORMAT && d == NULL);
  CHECK(strstr(err.msg, "broken narrow band") != NULL);
  int32_t bad[3] = {1, 0, 0};
  float leaf[512] = {0};
  CHECK(mgs_topo_sparse_add_leaf(s, bad, leaf, &err) == MGS_ERR_ARG);
  CHECK(mgs_topo_sparse_add_tile(s, o0, 8, 1.0f, &err) == MGS_ERR_ARG); /* duplicate block */
  mgs_topo_sparse_destroy(s);
  /* a single voxel: one essential class */
  float one = 0.5f;
  CHECK_OK(mgs_topo_persistence_dense(&one, 1, 1, 1, NULL, &d, &err), &err);
  CHECK(d && d->n == 1 && d->pairs[0].dim == 0 && isinf(d->pairs[0].death));
  mgs_diagram_destroy(d);
}

/* A band built for a persistence threshold keeps every bar alive at 0 with persistence up
 * to it exact (same values, not truncated), as in the unclamped diagram; a band just short
 * of the farthest end of those bars loses one of them. */
static void test_band_for_threshold(void) {
  CHECK(mgs_topo_band_for_threshold(0.0, 0.0, 1.0) == 1);
  CHECK(mgs_topo_band_for_threshold(2.0, 0.0, 1.0) == 3);
  CHECK(mgs_topo_band_for_threshold(2.5, -1.0, 0.5) == 8);
  CHECK(mgs_topo_band_for_threshold(NAN, 0.0, 1.0) == -1 && mgs_topo_band_for_threshold(1.0, 0.0, 0.0) == -1 &&
        mgs_topo_band_for_threshold(-1.0, 0.0, 1.0) == -1 && mgs_topo_band_for_threshold(1.0, INFINITY, 1.0) == -1);
  /* white noise in [-1, 1]: many short bars around 0; h only scales the threshold */
  const int N = full ? 28 : 16;
  const double h = 0.05;
  float *f = tt_field(TT_RANDOM, N, 5);
  mgs_diagram *all = dense(f, N, INFINITY, 0);
  for (int k = 2; all && k <= 4; k += 2) {
    const double eps = k * h;
    const int wv = mgs_topo_band_for_threshold(eps, 0.0, h);
    mgs_diagram *c = dense(f, N, wv * h, 0);
    size_t sel = 0, kept = 0;
    double need = 0;
    for (size_t i = 0; c && i < all->n; i++) {
      const mgs_pair *p = &all->pairs[i];
      if (!(p->birth <= 0 && p->death > 0 && isfinite(p->death) && p->death - p->birth <= eps)) continue;
      sel++;
      need = fmax(need, fmax(-p->birth, p->death));
      for (size_t j = 0; j < c->n; j++)
        if (c->pairs[j].dim == p->dim && c->pairs[j].birth == p->birth && c->pairs[j].death == p->death &&
            !c->pairs[j].truncated) {
          kept++;
          break;
        }
    }
    CHECK_MSG(sel > 0, "no bar alive at 0 below %g: the test would be vacuous", eps);
    CHECK_MSG(kept == sel, "band %d voxels for threshold %g: %zu of %zu bars kept", wv, eps, kept, sel);
    CHECK(need < wv * h);
    printf("  threshold %g voxels: band %d voxels keeps %zu bars alive at 0 (farthest end %.2f voxels)\n", eps / h, wv,
           sel, need / h);
    mgs_diagram_destroy(c);
    /* just short of the farthest end: that bar must change (clamped) or be flagged */
    c = dense(f, N, 0.99 * need, 0);
    size_t kept2 = 0;
    for (size_t i = 0; c && i < all->n; i++) {
      const mgs_pair *p = &all->pairs[i];
      if (!(p->birth <= 0 && p->death > 0 && isfinite(p->death) && p->death - p->birth <= eps)) continue;
      for (size_t j = 0; j < c->n; j++)
        if (c->pairs[j].dim == p->dim && c->pairs[j].birth == p->birth && c->pairs[j].death == p->death &&
            !c->pairs[j].truncated) {
          kept2++;
          break;
        }
    }
    CHECK_MSG(kept2 < sel, "a band narrower than the farthest end kept all %zu bars", sel);
    mgs_diagram_destroy(c);
  }
  mgs_diagram_destroy(all);
  free(f);
}

int main(int argc, char **argv) {
  full = argc > 1 && !strcmp(argv[1], "full");
  RUN(test_betti);
  RUN(test_band_equals_dense);
  RUN(test_band_for_threshold);
  RUN(test_fog_superlevel);
  RUN(test_bad_input);
  return mgs_test_finish();
}

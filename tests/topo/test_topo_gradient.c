/* The discrete-gradient path (V: ProcessLowerStars + Morse complex) against the full
 * reduction of every band cell (opts.full_reduction = 1): identical diagrams on random and
 * structured fields, dense and narrow band, sub- and superlevel, V and T constructions; and a
 * sane reduction ratio (1 - critical / band cells) on a torus band. */
#include "topo_test_util.h"
#include "topo/cubical_internal.h"

static int full = 0;
static void equal_cases(void);

static int cons_t = 0; /* construction of the next compare_case / run calls */

static mgs_diagram *run(const float *f, int N, double w, int sup, int full_red, int sparse, mgs_topo_stats *st) {
  return tt_run(f, N, w, cons_t, sup, full_red, 0, sparse, st);
}

static void compare_case(int kind, int N, double w, int sup, int sparse, uint32_t seed) {
  float *f = tt_field(kind, N, seed);
  mgs_topo_stats sg, sf;
  mgs_diagram *dg = run(f, N, w, sup, 0, sparse, &sg), *df = run(f, N, w, sup, 1, sparse, &sf);
  if (dg && df) {
    tt_pair *a, *b;
    size_t na = tt_from_diagram(dg, &a), nb = tt_from_diagram(df, &b);
    char what[160];
    snprintf(what, sizeof what, "%s N=%d w=%g %c %s %s seed %u: gradient vs full", tt_names[kind], N, w, cons_t ? 'T' : 'V',
             sup ? "super" : "sub", sparse ? "band" : "dense", seed);
    CHECK_MSG(tt_equal(what, a, na, b, nb), "%s differ", what);
    /* the voxels setting each value agree too (values are unique in random fields) */
    if (na == nb && kind == TT_RANDOM && !isfinite(w))
      for (size_t i = 0; i < na; i++)
        if (memcmp(dg->pairs[i].b.voxel, df->pairs[i].b.voxel, sizeof dg->pairs[i].b.voxel) != 0 ||
            (isfinite(dg->pairs[i].death) && memcmp(dg->pairs[i].d.voxel, df->pairs[i].d.voxel, sizeof dg->pairs[i].d.voxel) != 0)) {
          CHECK_MSG(0, "%s: pair %zu voxel differs", what, i);
          break;
        }
    CHECK(sg.critical_cells <= sf.cells_built);
    CHECK(sg.band_cells == sf.cells_built);
    fprintf(stderr, "  %s: %zu pairs, critical %zu of %zu band cells (reduction %.1f %%)\n", what, na, sg.critical_cells,
            sg.band_cells, 100 * sg.reduction_ratio);
    free(a);
    free(b);
  }
  mgs_diagram_destroy(dg);
  mgs_diagram_destroy(df);
  free(f);
}

static void test_equal(void) {
  for (cons_t = 0; cons_t < 2; cons_t++) equal_cases();
  cons_t = 0;
}

static void equal_cases(void) {
  for (uint32_t seed = 1; seed <= (full ? 12u : 4u); seed++) compare_case(TT_RANDOM, 12 + (int)seed % 5, INFINITY, 0, 0, seed);
  compare_case(TT_RANDOM, 16, INFINITY, 1, 0, 21);
  compare_case(TT_RANDOM, 16, 0.5, 0, 0, 22);  /* clamp at +-0.5: plateaus at both ends */
  compare_case(TT_RANDOM, 16, 0.5, 0, 1, 23);
  compare_case(TT_NOISY_TORUS, 32, 3.0 / 32, 0, 1, 5);
  compare_case(TT_FLOATERS, 32, 3.0 / 32, 0, 1, 5);
  compare_case(TT_TUNNEL_BLOCK, 64, 2.0 / 64, 0, 1, 5);
  compare_case(TT_SHELLS, 32, 2.0 / 32, 0, 0, 5);
  if (!full) return;
  compare_case(TT_GENUS2, 40, 3.0 / 40, 0, 1, 7);
  compare_case(TT_NOISY_TORUS, 48, INFINITY, 0, 0, 7);
  compare_case(TT_TORUS_SHELL, 48, 3.0 / 48, 0, 1, 7);
  compare_case(TT_SPHERE_SHELL, 48, 3.0 / 48, 1, 0, 7);
}

/* a smooth torus band: the gradient leaves a few percent of the band cells critical */
static void test_ratio(void) {
  const int N = 64;
  float *f = tt_field(TT_TORUS, N, 1);
  mgs_topo_stats st;
  mgs_diagram *d = run(f, N, 3.0 / N, 0, 0, 1, &st);
  CHECK(d != NULL);
  if (d) {
    int b[3];
    tt_betti(d, 0.0, b);
    CHECK(b[0] == 1 && b[1] == 1 && b[2] == 0);
    fprintf(stderr, "  torus N=%d band: critical %zu of %zu band cells, reduction ratio %.3f\n", N, st.critical_cells,
            st.band_cells, st.reduction_ratio);
    CHECK_MSG(st.reduction_ratio > 0.8 && st.reduction_ratio < 1.0, "reduction ratio %.3f out of (0.8, 1)", st.reduction_ratio);
    CHECK(st.critical_cells == st.cells_built && st.band_cells > st.critical_cells);
  }
  mgs_diagram_destroy(d);
  free(f);
}

/* The regular-vertex filter (acyclic lower link => no critical cell) against ProcessLowerStars
 * itself on random neighbourhoods, with many ties (quantised values) and missing voxels; and
 * the RWS optimality it rests on: the critical cells of L(v) count the reduced Betti numbers
 * of the lower link, so a vertex the filter rejects has at least one critical cell. */
static void test_regular_filter(void) {
  cub_lower_star_tables();
  size_t n = full ? 2000000 : 200000, regular = 0, bad = 0, nonopt = 0;
  for (size_t i = 0; i < n; i++) {
    float nb[27];
    int levels = 2 + (int)(tt_hash((uint32_t)i) % 6);
    for (int u = 0; u < 27; u++) {
      uint32_t h = tt_hash((uint32_t)(i * 27 + u) ^ 0x5bd1e995u);
      nb[u] = (i & 1) ? (float)(h % (uint32_t)levels) : (float)(h & 0xffff);
      if ((i % 7) == 0 && u != 13 && (h >> 20) % 9 == 0) nb[u] = INFINITY;
    }
    size_t nl;
    int maybe = cub_lower_star_count(nb, &nl);
    cub_ls ls;
    cub_lower_star(nb, &ls);
    size_t crit = cub_ls_critical(&ls, 0, 0, 0, 0, nb[13], NULL);
    if (nl != ls.n) bad++;
    if (!maybe) { regular++; if (crit) bad++; }
    else if (!crit) nonopt++;
  }
  fprintf(stderr, "  %zu neighbourhoods: %zu regular, %zu disagreements, %zu rejected without critical cells\n", n, regular,
          bad, nonopt);
  CHECK(bad == 0);
  CHECK(nonopt == 0);
  CHECK(regular > n / 20);
}

int main(int argc, char **argv) {
  full = argc > 1 && !strcmp(argv[1], "full");
  RUN(test_equal);
  RUN(test_ratio);
  RUN(test_regular_filter);
  return mgs_test_finish();
}

/* Dense diagrams equal the independent references exactly (pair for pair, essential classes
 * included): PHAT on the explicit V (and T) complex, GUDHI 3.7 CubicalComplex for T.
 * Argument: "fast" (small grids, also run under ASan) or "full" (up to 48^3). */
#include "topo_test_util.h"

typedef struct { int kind, N, cons, sup; double wvox; const char *ref; } tcase;

static void run_case(const tcase *c) {
  float *f = tt_field(c->kind, c->N, 11u + (uint32_t)c->N);
  mgs_topo_opts o;
  mgs_topo_opts_default(&o);
  o.construction = c->cons ? MGS_TOPO_T : MGS_TOPO_V;
  o.filtration = c->sup ? MGS_TOPO_SUPERLEVEL : MGS_TOPO_SUBLEVEL;
  /* the clamp as a float32 value, so both sides clamp at exactly the same number */
  o.half_width = isfinite(c->wvox) ? (double)(float)(c->kind == TT_RANDOM ? c->wvox : c->wvox / c->N) : INFINITY;
  mgs_diagram *d = NULL;
  mgs_error err = {0};
  mgs_topo_stats st;
  CHECK_OK(mgs_topo_persistence_dense_stats(f, c->N, c->N, c->N, &o, &d, &st, &err), &err);
  tt_pair *ref = NULL, *ours = NULL;
  long nr = tt_reference(c->ref, f, c->N, c->N, c->N, c->cons, c->sup, o.half_width, &ref);
  CHECK_MSG(nr >= 0, "reference %s failed", c->ref);
  if (d && nr >= 0) {
    size_t no = tt_from_diagram(d, &ours);
    char what[160];
    snprintf(what, sizeof what, "%s N=%d %s%s w=%g vs %s", tt_names[c->kind], c->N, c->cons ? "T" : "V",
             c->sup ? " superlevel" : "", o.half_width, c->ref);
    int eq = tt_equal(what, ours, no, ref, (size_t)nr);
    CHECK_MSG(eq, "%s: diagrams differ", what);
    CHECK(no > 0);
    fprintf(stderr, "  %s: %zu pairs equal (cells built %zu of %zu, critical %zu)\n", what, no,
            st.cells_built, st.cells_total, st.critical_cells);
  }
  free(ours);
  free(ref);
  mgs_diagram_destroy(d);
  free(f);
}

int main(int argc, char **argv) {
  int full = argc > 1 && !strcmp(argv[1], "full");
  const double inf = INFINITY;
  static const tcase fast[] = {
    {TT_RANDOM, 9, 0, 0, INFINITY, "phat"},  {TT_RANDOM, 9, 0, 0, 0.5, "phat"},
    {TT_RANDOM, 9, 1, 0, INFINITY, "gudhi"}, {TT_RANDOM, 9, 1, 0, 0.5, "gudhi"},
    {TT_RANDOM, 8, 1, 0, 0.25, "phat"},      {TT_RANDOM, 9, 0, 1, 0.5, "phat"},
    {TT_NOISY_TORUS, 16, 0, 0, 3, "phat"},   {TT_NOISY_TORUS, 16, 1, 0, 3, "gudhi"},
    {TT_SHELLS, 16, 0, 0, 2, "phat"},        {TT_GENUS2, 16, 0, 0, 3, "phat"},
    {TT_FLOATERS, 16, 0, 0, 3, "phat"},      {TT_FLOATERS, 16, 1, 0, 3, "gudhi"},
    {TT_TUNNEL_BLOCK, 16, 0, 0, 2, "phat"},  {TT_TUNNEL_BLOCK, 16, 1, 0, 2, "gudhi"},
  };
  static const tcase slow[] = {
    {TT_RANDOM, 24, 0, 0, INFINITY, "phat"}, {TT_RANDOM, 24, 1, 0, 0.5, "gudhi"},
    {TT_NOISY_TORUS, 48, 0, 0, 3, "phat"},   {TT_NOISY_TORUS, 48, 1, 0, 3, "gudhi"},
    {TT_NOISY_TORUS, 40, 0, 0, INFINITY, "phat"},
    {TT_SHELLS, 48, 0, 0, 3, "phat"},        {TT_SHELLS, 48, 1, 0, 3, "gudhi"},
    {TT_GENUS2, 48, 0, 0, 4, "phat"},        {TT_GENUS2, 40, 1, 0, 4, "gudhi"},
    {TT_FLOATERS, 48, 0, 0, 3, "phat"},      {TT_FLOATERS, 48, 1, 0, 3, "gudhi"},
    {TT_FLOATERS, 32, 1, 1, 3, "gudhi"},     {TT_TUNNEL_BLOCK, 48, 0, 0, 3, "phat"},
  };
  (void)inf;
  const tcase *cs = full ? slow : fast;
  size_t n = full ? sizeof slow / sizeof *slow : sizeof fast / sizeof *fast;
  for (size_t i = 0; i < n; i++) {
    int before = mgs_test_failures;
    run_case(&cs[i]);
    fprintf(stderr, "%s case %zu\n", mgs_test_failures == before ? "ok  " : "FAIL", i);
  }
  return mgs_test_finish();
}

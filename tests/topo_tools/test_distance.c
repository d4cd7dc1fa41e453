/* Bottleneck and Wasserstein distances: hand-computed cases, an independent brute-force
 * reference (explicit augmented graph / all permutations), metric properties on random
 * diagrams, and GUDHI (python3-gudhi + POT) on random diagrams. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "mgs_test.h"
#include "core/mgs_rng.h"
#include "topo/mgs_diagram_tools.h"

static mgs_diagram *make(const double *bd, size_t n, int dim) {
  mgs_diagram *d = mgs_diagram_create();
  for (size_t i = 0; i < n; i++) {
    mgs_pair p;
    memset(&p, 0, sizeof p);
    p.dim = dim; p.birth = bd[2 * i]; p.death = bd[2 * i + 1];
    mgs_diagram_push(d, &p, NULL);
  }
  return d;
}
static void add(mgs_diagram *d, int dim, double b, double de) {
  mgs_pair p;
  memset(&p, 0, sizeof p);
  p.dim = dim; p.birth = b; p.death = de;
  mgs_diagram_push(d, &p, NULL);
}
static double bott(const mgs_diagram *a, const mgs_diagram *b, int dim) {
  double v = NAN;
  mgs_error e;
  CHECK_OK(mgs_diagram_bottleneck(a, b, dim, &v, &e), &e);
  return v;
}
static double wass(const mgs_diagram *a, const mgs_diagram *b, int dim, double p, double q) {
  double v = NAN, bound = -1;
  mgs_error e;
  CHECK_OK(mgs_diagram_wasserstein(a, b, dim, p, q, &v, &bound, &e), &e);
  CHECK(bound == 0.0);
  return v;
}

/* ---- independent references (tiny sizes only) ---- */

/* Explicit augmented bipartite graph (Kuhn's augmenting paths), all candidates in order. */
static int ref_n;
static int ref_adj[32][32];
static int ref_match_r[32], ref_seen[32];
static int kuhn(int u) {
  for (int v = 0; v < ref_n; v++) {
    if (!ref_adj[u][v] || ref_seen[v]) continue;
    ref_seen[v] = 1;
    if (ref_match_r[v] < 0 || kuhn(ref_match_r[v])) { ref_match_r[v] = u; return 1; }
  }
  return 0;
}
static double ref_bottleneck(const double *a, int na, const double *b, int nb) {
  ref_n = na + nb;
  double cand[400];
  int nc = 0;
  cand[nc++] = 0;
  for (int i = 0; i < na; i++) cand[nc++] = (a[2 * i + 1] - a[2 * i]) / 2;
  for (int j = 0; j < nb; j++) cand[nc++] = (b[2 * j + 1] - b[2 * j]) / 2;
  for (int i = 0; i < na; i++)
    for (int j = 0; j < nb; j++)
      cand[nc++] = fmax(fabs(a[2 * i] - b[2 * j]), fabs(a[2 * i + 1] - b[2 * j + 1]));
  double best = INFINITY;
  for (int c = 0; c < nc; c++) {
    double r = cand[c];
    if (r >= best) continue;
    /* left: A (0..na-1), proj(B) (na..); right: B (0..nb-1), proj(A) (nb..) */
    for (int u = 0; u < ref_n; u++)
      for (int v = 0; v < ref_n; v++) {
        int ok = 0;
        if (u < na && v < nb) ok = fmax(fabs(a[2 * u] - b[2 * v]), fabs(a[2 * u + 1] - b[2 * v + 1])) <= r;
        else if (u < na) ok = (v - nb == u) && (a[2 * u + 1] - a[2 * u]) / 2 <= r;
        else if (v < nb) ok = (u - na == v) && (b[2 * v + 1] - b[2 * v]) / 2 <= r;
        else ok = 1;
        ref_adj[u][v] = ok;
      }
    for (int v = 0; v < ref_n; v++) ref_match_r[v] = -1;
    int m = 0;
    for (int u = 0; u < ref_n; u++) { memset(ref_seen, 0, sizeof ref_seen); m += kuhn(u); }
    if (m == ref_n) best = r;
  }
  return best;
}

/* Minimum over all permutations of the augmented cost matrix (L∞ ground metric). */
static double ref_cost[16][16];
static double perm_best;
static int perm_used[16];
static void perm_rec(int n, int row, double acc) {
  if (acc >= perm_best) return;
  if (row == n) { perm_best = acc; return; }
  for (int j = 0; j < n; j++)
    if (!perm_used[j]) { perm_used[j] = 1; perm_rec(n, row + 1, acc + ref_cost[row][j]); perm_used[j] = 0; }
}
static double ref_wasserstein(const double *a, int na, const double *b, int nb, double p) {
  int n = na + nb;
  for (int i = 0; i < n; i++)
    for (int j = 0; j < n; j++) {
      double c;
      if (i < na && j < nb) c = fmax(fabs(a[2 * i] - b[2 * j]), fabs(a[2 * i + 1] - b[2 * j + 1]));
      else if (i < na) c = (j - nb == i) ? (a[2 * i + 1] - a[2 * i]) / 2 : INFINITY;
      else if (j < nb) c = (i - na == j) ? (b[2 * j + 1] - b[2 * j]) / 2 : INFINITY;
      else c = 0;
      ref_cost[i][j] = isinf(c) ? INFINITY : pow(c, p);
    }
  perm_best = INFINITY;
  memset(perm_used, 0, sizeof perm_used);
  perm_rec(n, 0, 0.0);
  return pow(perm_best, 1.0 / p);
}

static void random_points(mgs_rng *r, double *bd, int n, double scale) {
  for (int i = 0; i < n; i++) {
    double b = scale * (mgs_rng_uniform(r) * 2 - 1);
    double l = scale * mgs_rng_uniform(r) * mgs_rng_uniform(r);
    bd[2 * i] = b; bd[2 * i + 1] = b + l;
  }
}

/* ---- tests ---- */

static void test_hand_cases(void) {
  double a1[] = {0, 1}, b1[] = {0, 1.2}, far[] = {3, 4};
  mgs_diagram *A = make(a1, 1, 0), *B = make(b1, 1, 0), *F = make(far, 1, 0), *E = mgs_diagram_create();
  CHECK_NEAR(bott(A, E, 0), 0.5, 1e-15);          /* to the diagonal: half the persistence */
  CHECK_NEAR(bott(E, A, MGS_DIM_ALL), 0.5, 1e-15);
  CHECK_NEAR(bott(A, B, 0), 0.2, 1e-15);
  CHECK_NEAR(bott(A, F, 0), 0.5, 1e-15);          /* both to the diagonal beats 3 */
  CHECK_NEAR(wass(A, F, 0, 1, INFINITY), 1.0, 1e-15);
  CHECK_NEAR(wass(A, F, 0, 2, INFINITY), sqrt(0.5), 1e-15);
  CHECK_NEAR(wass(A, B, 0, 1, INFINITY), 0.2, 1e-15);
  CHECK_NEAR(wass(A, E, 0, 1, 2.0), 1.0 / sqrt(2.0), 1e-15); /* L2 distance to diagonal */
  CHECK_NEAR(wass(A, B, 0, 1, 1.0), 0.2, 1e-15);
  CHECK(bott(E, E, MGS_DIM_ALL) == 0.0);
  CHECK(wass(E, E, MGS_DIM_ALL, 1, INFINITY) == 0.0);
  CHECK(bott(A, A, 0) == 0.0);
  CHECK(bott(A, E, 1) == 0.0); /* nothing in dimension 1 */
  /* GUDHI's documented example: 0.75 */
  double g1[] = {2.7, 3.7, 9.6, 14.0, 34.2, 34.974}, g2[] = {2.8, 4.45, 9.5, 14.1};
  mgs_diagram *G1 = make(g1, 3, 1), *G2 = make(g2, 2, 1);
  CHECK_NEAR(bott(G1, G2, 1), 0.75, 1e-12);
  CHECK_NEAR(bott(G1, G2, MGS_DIM_ALL), 0.75, 1e-12);
  CHECK(bott(G1, G2, 0) == 0.0);
  /* dimensions are never matched across: same point in dim 0 vs dim 1 */
  mgs_diagram *D0 = make(a1, 1, 0), *D1 = make(a1, 1, 1);
  CHECK_NEAR(bott(D0, D1, MGS_DIM_ALL), 0.5, 1e-15);
  CHECK_NEAR(wass(D0, D1, MGS_DIM_ALL, 1, INFINITY), 1.0, 1e-15);
  CHECK_NEAR(wass(D0, D1, MGS_DIM_ALL, 2, INFINITY), sqrt(0.5), 1e-15);
  mgs_diagram_destroy(A); mgs_diagram_destroy(B); mgs_diagram_destroy(F); mgs_diagram_destroy(E);
  mgs_diagram_destroy(G1); mgs_diagram_destroy(G2); mgs_diagram_destroy(D0); mgs_diagram_destroy(D1);
}

static void test_essential(void) {
  mgs_diagram *A = mgs_diagram_create(), *B = mgs_diagram_create();
  add(A, 0, -1.0, INFINITY); add(A, 0, 0.0, 0.1);
  add(B, 0, -0.7, INFINITY);
  CHECK_NEAR(bott(A, B, 0), 0.3, 1e-15);             /* essential births differ by 0.3 */
  CHECK_NEAR(wass(A, B, 0, 1, INFINITY), 0.3 + 0.05, 1e-15);
  add(A, 0, 2.0, INFINITY); add(B, 0, 2.5, INFINITY);
  /* sorted matching: -1↔-0.7, 2↔2.5 */
  CHECK_NEAR(bott(A, B, 0), 0.5, 1e-15);
  CHECK_NEAR(wass(A, B, 0, 1, INFINITY), 0.3 + 0.5 + 0.05, 1e-15);
  add(A, 0, 3.0, INFINITY);
  CHECK(isinf(bott(A, B, 0)));                       /* 3 vs 2 essential classes */
  CHECK(isinf(wass(A, B, 0, 2, INFINITY)));
  CHECK(bott(A, B, 1) == 0.0);
  /* superlevel-style essential (death = -inf) is a different kind */
  mgs_diagram *C = mgs_diagram_create(), *D = mgs_diagram_create();
  add(C, 0, 1.0, -INFINITY); add(D, 0, 1.0, INFINITY);
  CHECK(isinf(bott(C, D, 0)));
  /* NaN is rejected */
  add(C, 0, NAN, 1.0);
  double v; mgs_error e;
  CHECK(mgs_diagram_bottleneck(C, D, 0, &v, &e) == MGS_ERR_NUMERIC);
  CHECK(mgs_diagram_wasserstein(A, B, 0, 0.5, INFINITY, &v, NULL, &e) == MGS_ERR_ARG);
  CHECK(mgs_diagram_bottleneck(A, B, 5, &v, &e) == MGS_ERR_ARG);
  mgs_diagram_destroy(A); mgs_diagram_destroy(B); mgs_diagram_destroy(C); mgs_diagram_destroy(D);
}

static void test_against_bruteforce(void) {
  mgs_rng r; mgs_rng_init(&r, 7, 1);
  int mism_b = 0, mism_w = 0, mism_bis = 0;
  for (int trial = 0; trial < 300; trial++) {
    int na = (int)mgs_rng_below(&r, 5), nb = (int)mgs_rng_below(&r, 5);
    if (na + nb > 8) nb = 8 - na;
    double a[16] = {0}, b[16] = {0};
    random_points(&r, a, na, 1.0);
    random_points(&r, b, nb, 1.0);
    if (trial % 3 == 0 && na && nb) { b[0] = a[0]; b[1] = a[1] + 0.25; } /* ties and near pairs */
    double ba[8], da[8], bb[8], db[8];
    for (int i = 0; i < na; i++) { ba[i] = a[2 * i]; da[i] = a[2 * i + 1]; }
    for (int j = 0; j < nb; j++) { bb[j] = b[2 * j]; db[j] = b[2 * j + 1]; }
    double ref = ref_bottleneck(a, na, b, nb);
    double got = mgs_bottleneck_points(ba, da, (size_t)na, bb, db, (size_t)nb, 0);
    double bis = mgs_bottleneck_points(ba, da, (size_t)na, bb, db, (size_t)nb, 1);
    if (got != ref) mism_b++;
    if (bis != got) mism_bis++;
    for (int pi = 1; pi <= 2; pi++) {
      double wr = ref_wasserstein(a, na, b, nb, pi);
      double wg = mgs_wasserstein_points(ba, da, (size_t)na, bb, db, (size_t)nb, pi, INFINITY, NULL);
      if (!(fabs(wr - wg) <= 1e-12 * (1 + wr))) { mism_w++; fprintf(stderr, "W%d: ref %.17g got %.17g (na %d nb %d)\n", pi, wr, wg, na, nb); }
    }
  }
  CHECK_MSG(mism_b == 0, "%d bottleneck mismatches vs explicit augmented graph", mism_b);
  CHECK_MSG(mism_bis == 0, "%d mismatches between candidate search and bit bisection", mism_bis);
  CHECK_MSG(mism_w == 0, "%d Wasserstein mismatches vs permutation minimum", mism_w);
}

static void test_metric_properties(void) {
  mgs_rng r; mgs_rng_init(&r, 11, 3);
  int bad = 0;
  for (int trial = 0; trial < 40; trial++) {
    mgs_diagram *D[3];
    for (int k = 0; k < 3; k++) {
      D[k] = mgs_diagram_create();
      int n = 5 + (int)mgs_rng_below(&r, 40);
      for (int i = 0; i < n; i++) {
        double b = mgs_rng_uniform(&r), l = 0.5 * mgs_rng_uniform(&r) * mgs_rng_uniform(&r);
        add(D[k], (int)mgs_rng_below(&r, 3), b, b + l);
      }
      add(D[k], 0, -1.0 + 0.1 * mgs_rng_uniform(&r), INFINITY);
    }
    for (int k = 0; k < 3; k++) {
      if (bott(D[k], D[k], MGS_DIM_ALL) != 0.0) bad++;
      if (wass(D[k], D[k], MGS_DIM_ALL, 2, INFINITY) != 0.0) bad++;
    }
    double ab = bott(D[0], D[1], MGS_DIM_ALL), ba = bott(D[1], D[0], MGS_DIM_ALL);
    double bc = bott(D[1], D[2], MGS_DIM_ALL), ac = bott(D[0], D[2], MGS_DIM_ALL);
    if (ab != ba) bad++;
    if (ac > ab + bc + 1e-12) bad++;
    double wab = wass(D[0], D[1], MGS_DIM_ALL, 1, INFINITY), wba = wass(D[1], D[0], MGS_DIM_ALL, 1, INFINITY);
    double wbc = wass(D[1], D[2], MGS_DIM_ALL, 1, INFINITY), wac = wass(D[0], D[2], MGS_DIM_ALL, 1, INFINITY);
    if (fabs(wab - wba) > 1e-12 * (1 + wab)) bad++;
    if (wac > wab + wbc + 1e-12) bad++;
    if (ab > wab + 1e-12) bad++;  /* bottleneck ≤ W_p (L∞ ground) */
    double w2 = wass(D[0], D[1], MGS_DIM_ALL, 2, INFINITY);
    if (w2 > wab + 1e-12 || w2 < ab - 1e-12) bad++; /* W_inf ≤ W_2 ≤ W_1 */
    for (int k = 0; k < 3; k++) mgs_diagram_destroy(D[k]);
  }
  CHECK_MSG(bad == 0, "%d metric-property violations", bad);
}

/* Larger diagrams: the bisection and candidate paths agree, and the approximate
 * Wasserstein beyond the exact limit stays within its stated bound of the exact value. */
static void test_large(void) {
  mgs_rng r; mgs_rng_init(&r, 5, 9);
  size_t n = 1200;
  double *bd = malloc(4 * n * sizeof(double));
  double *ba = bd, *da = bd + n, *bb = bd + 2 * n, *db = bd + 3 * n;
  for (size_t i = 0; i < n; i++) {
    ba[i] = mgs_rng_uniform(&r); da[i] = ba[i] + 0.3 * pow(mgs_rng_uniform(&r), 3);
    bb[i] = ba[i] + 0.01 * (mgs_rng_uniform(&r) - 0.5); db[i] = da[i] + 0.01 * (mgs_rng_uniform(&r) - 0.5);
    if (db[i] < bb[i]) db[i] = bb[i];
  }
  double c = mgs_bottleneck_points(ba, da, n, bb, db, n, 0);
  double b = mgs_bottleneck_points(ba, da, n, bb, db, n, 1);
  CHECK(c == b);
  CHECK(c > 0 && c <= 0.005 + 1e-12);
  /* approximation: 150 + 150 points with an exact limit of 200 vs the exact value */
  size_t m = 150;
  for (int pi = 1; pi <= 2; pi++) {
    double bound = -1, exact_bound = -1;
    double approx = mgs_wasserstein_points_limit(ba, da, m, bb, db, m, pi, INFINITY, 200, &bound);
    double exact = mgs_wasserstein_points_limit(ba, da, m, bb, db, m, pi, INFINITY, 1000, &exact_bound);
    CHECK(bound > 0 && exact_bound == 0);
    CHECK_MSG(fabs(approx - exact) <= bound + 1e-12, "W%d approx %g exact %g bound %g", pi, approx, exact, bound);
  }
  free(bd);
}

static int write_points(const char *path, const double *bd, int n) {
  FILE *f = fopen(path, "w");
  if (!f) return 0;
  for (int i = 0; i < n; i++) fprintf(f, "%.17g %.17g\n", bd[2 * i], bd[2 * i + 1]);
  fclose(f);
  return 1;
}

static void test_against_gudhi(void) {
  const char *src = getenv("MGS_SOURCE_DIR");
  char script[4096];
  snprintf(script, sizeof script, "%s/tests/topo_tools/gudhi_distances.py", src ? src : "../../..");
  const char *dir = mgs_test_tmpdir("gudhi_dist");
  mgs_rng r; mgs_rng_init(&r, 123, 4);
  int compared = 0;
  for (int trial = 0; trial < 6; trial++) {
    int na = 3 + (int)mgs_rng_below(&r, 60), nb = 3 + (int)mgs_rng_below(&r, 60);
    double *a = malloc(2 * (size_t)na * sizeof(double)), *b = malloc(2 * (size_t)nb * sizeof(double));
    random_points(&r, a, na, 1.0);
    random_points(&r, b, nb, 1.0);
    char pa[4200], pb[4200], cmd[13000];
    snprintf(pa, sizeof pa, "%s/a%d.txt", dir, trial);
    snprintf(pb, sizeof pb, "%s/b%d.txt", dir, trial);
    CHECK(write_points(pa, a, na) && write_points(pb, b, nb));
    snprintf(cmd, sizeof cmd, "/usr/bin/python3 '%s' '%s' '%s'", script, pa, pb);
    FILE *p = popen(cmd, "r");
    double g[4] = {NAN, NAN, NAN, NAN};
    int got = p ? fscanf(p, "%lf %lf %lf %lf", &g[0], &g[1], &g[2], &g[3]) : 0;
    int rc = p ? pclose(p) : -1;
    CHECK_MSG(got == 4 && rc == 0, "GUDHI reference failed (rc %d): is python3-gudhi + python3-pot installed?", rc);
    if (got == 4) {
      double *ba = malloc((size_t)na * sizeof(double)), *da = malloc((size_t)na * sizeof(double));
      double *bb = malloc((size_t)nb * sizeof(double)), *db = malloc((size_t)nb * sizeof(double));
      for (int i = 0; i < na; i++) { ba[i] = a[2 * i]; da[i] = a[2 * i + 1]; }
      for (int j = 0; j < nb; j++) { bb[j] = b[2 * j]; db[j] = b[2 * j + 1]; }
      CHECK_NEAR(mgs_bottleneck_points(ba, da, (size_t)na, bb, db, (size_t)nb, 0), g[0], 1e-12);
      CHECK_NEAR(mgs_wasserstein_points(ba, da, (size_t)na, bb, db, (size_t)nb, 1, INFINITY, NULL), g[1], 1e-9);
      CHECK_NEAR(mgs_wasserstein_points(ba, da, (size_t)na, bb, db, (size_t)nb, 2, INFINITY, NULL), g[2], 1e-9);
      CHECK_NEAR(mgs_wasserstein_points(ba, da, (size_t)na, bb, db, (size_t)nb, 1, 2.0, NULL), g[3], 1e-9);
      compared++;
      free(ba); free(da); free(bb); free(db);
    }
    free(a); free(b);
  }
  CHECK(compared == 6);
}

int main(void) {
  RUN(test_hand_cases);
  RUN(test_essential);
  RUN(test_against_bruteforce);
  RUN(test_metric_properties);
  RUN(test_large);
  RUN(test_against_gudhi);
  return mgs_test_finish();
}

/* Point-cloud persistence (topo/mgs_topo_pointcloud.h) equals GUDHI 3.7's (pc_reference.py)
 * on small clouds: Vietoris–Rips up to dimension 2 (H0, H1) and the Delaunay weak-alpha
 * filtration (H0..H2); degenerate clouds (duplicates, coplanar, collinear, one point) give
 * defined diagrams whose H0 still equals GUDHI's; critical edges reproduce the bar ends. */
#include <unistd.h>
#include "mgs_test.h"
#include "core/mgs_rng.h"
#include "topo/mgs_topo_pointcloud.h"

typedef struct { int dim; double b, d; } pr;
static int cmp_pr(const void *x, const void *y) {
  const pr *a = x, *b = y;
  if (a->dim != b->dim) return a->dim - b->dim;
  if (a->b != b->b) return a->b < b->b ? -1 : 1;
  if (a->d != b->d) return a->d < b->d ? -1 : 1;
  return 0;
}

static const char *py(void) { return access("/usr/bin/python3", X_OK) == 0 ? "/usr/bin/python3" : "python3"; }

/* GUDHI's diagram of `pts` (mode "--rips R" or "--weak-alpha"); -1 on failure. */
static long gudhi_ref(const char *mode, const double *pts, size_t n, pr **out) {
  char path[128];
  snprintf(path, sizeof path, "pc_pts_%d.txt", (int)getpid());
  FILE *f = fopen(path, "w");
  if (!f) return -1;
  for (size_t i = 0; i < n; i++) fprintf(f, "%.17g %.17g %.17g\n", pts[3 * i], pts[3 * i + 1], pts[3 * i + 2]);
  fclose(f);
  const char *src = getenv("MGS_SOURCE_DIR");
  char cmd[1024];
  snprintf(cmd, sizeof cmd, "%s '%s/tests/topogs/pc_reference.py' %s '%s'", py(), src ? src : "../..", mode, path);
  FILE *p = popen(cmd, "r");
  if (!p) { remove(path); return -1; }
  size_t cap = 256, m = 0;
  pr *v = malloc(cap * sizeof *v);
  char line[256];
  while (fgets(line, sizeof line, p)) {
    pr q; char ds[64];
    if (sscanf(line, "%d %lf %63s", &q.dim, &q.b, ds) != 3) continue;
    q.d = strcmp(ds, "inf") ? strtod(ds, NULL) : INFINITY;
    if (m == cap) v = realloc(v, (cap *= 2) * sizeof *v);
    v[m++] = q;
  }
  int rc = pclose(p);
  remove(path);
  if (rc) { free(v); return -1; }
  qsort(v, m, sizeof *v, cmp_pr);
  *out = v;
  return (long)m;
}

static size_t ours(const mgs_topo_bars *b, int max_dim, pr **out) {
  pr *v = malloc((b->n + 1) * sizeof *v);
  size_t m = 0;
  for (size_t i = 0; i < b->n; i++)
    if (b->bars[i].dim <= max_dim) v[m++] = (pr){b->bars[i].dim, b->bars[i].birth, b->bars[i].death};
  qsort(v, m, sizeof *v, cmp_pr);
  *out = v;
  return m;
}

static int same(const char *what, const pr *a, size_t na, const pr *b, size_t nb, int only_dim0) {
  size_t ia = 0, ib = 0, bad = 0;
  for (;;) {
    while (only_dim0 && ia < na && a[ia].dim > 0) ia++;
    while (only_dim0 && ib < nb && b[ib].dim > 0) ib++;
    if (ia >= na || ib >= nb) break;
    if (a[ia].dim != b[ib].dim || fabs(a[ia].b - b[ib].b) > 1e-9 ||
        !(a[ia].d == b[ib].d || fabs(a[ia].d - b[ib].d) <= 1e-9)) {
      if (bad++ < 5) fprintf(stderr, "  %s: ours %d %.12g %.12g vs gudhi %d %.12g %.12g\n", what, a[ia].dim, a[ia].b, a[ia].d, b[ib].dim, b[ib].b, b[ib].d);
    }
    ia++; ib++;
  }
  while (only_dim0 && ia < na && a[ia].dim > 0) ia++;
  while (only_dim0 && ib < nb && b[ib].dim > 0) ib++;
  if (ia != na || ib != nb) { fprintf(stderr, "  %s: %zu vs %zu pairs\n", what, na, nb); bad++; }
  return bad == 0;
}

/* Each finite end equals its critical edge's length. */
static void check_edges(const mgs_topo_bars *b, const double *p) {
  for (size_t i = 0; i < b->n; i++) {
    const mgs_topo_bar *x = &b->bars[i];
    if (x->birth_edge[0] >= 0) {
      const double *u = p + 3 * x->birth_edge[0], *v = p + 3 * x->birth_edge[1];
      CHECK_NEAR(sqrt((u[0]-v[0])*(u[0]-v[0]) + (u[1]-v[1])*(u[1]-v[1]) + (u[2]-v[2])*(u[2]-v[2])), x->birth, 1e-12);
    } else CHECK(x->birth == 0.0);
    if (isfinite(x->death)) {
      CHECK(x->death_edge[0] >= 0);
      const double *u = p + 3 * x->death_edge[0], *v = p + 3 * x->death_edge[1];
      CHECK_NEAR(sqrt((u[0]-v[0])*(u[0]-v[0]) + (u[1]-v[1])*(u[1]-v[1]) + (u[2]-v[2])*(u[2]-v[2])), x->death, 1e-12);
    }
  }
}

static void compare(const char *name, int rips, double r, const double *p, size_t n, int only_dim0) {
  mgs_topo_bars b;
  mgs_topo_bars_init(&b);
  mgs_error err = {0};
  if (rips) CHECK_OK(mgs_topo_rips_persistence(p, n, r, &b, &err), &err);
  else CHECK_OK(mgs_topo_weak_alpha_persistence(p, n, &b, &err), &err);
  check_edges(&b, p);
  char mode[64];
  if (rips) snprintf(mode, sizeof mode, "--rips %.17g", r); else snprintf(mode, sizeof mode, "--weak-alpha");
  pr *ref = NULL, *mine = NULL;
  long nr = gudhi_ref(mode, p, n, &ref);
  CHECK_MSG(nr >= 0, "GUDHI reference failed for %s", name);
  size_t nm = ours(&b, rips ? 1 : 2, &mine);
  if (nr >= 0) {
    int eq = same(name, mine, nm, ref, (size_t)nr, only_dim0);
    CHECK_MSG(eq, "%s: diagrams differ from GUDHI", name);
    fprintf(stderr, "  %s: %zu points, %zu bars %s GUDHI%s\n", name, n, nm, eq ? "==" : "!=", only_dim0 ? " (H0)" : "");
  }
  free(ref); free(mine);
  mgs_topo_bars_free(&b);
}

static void random_cloud(double *p, size_t n, uint64_t seed) {
  mgs_rng g;
  mgs_rng_init(&g, seed, 7);
  for (size_t i = 0; i < 3 * n; i++) p[i] = mgs_rng_uniform(&g);
}

static void test_rips_random(void) {
  double p[3 * 60];
  for (int s = 0; s < 3; s++) {
    random_cloud(p, 40 + 10 * (size_t)s, 100u + (uint64_t)s);
    char nm[64];
    snprintf(nm, sizeof nm, "rips seed %d r=0.45", s);
    compare(nm, 1, 0.45, p, 40 + 10 * (size_t)s, 0);
  }
  compare("rips r=0.2 (disconnected)", 1, 0.2, p, 60, 0);
  compare("rips r=2 (complete)", 1, 2.0, p, 30, 0);
}

static void test_weak_alpha_random(void) {
  double p[3 * 300];
  random_cloud(p, 300, 5);
  compare("weak alpha 300", 0, 0, p, 300, 0);
  random_cloud(p, 40, 6);
  compare("weak alpha 40", 0, 0, p, 40, 0);
  /* exact duplicates (an image's equal pixels): 120 distinct points, each 1..4 times */
  random_cloud(p, 120, 9);
  for (size_t i = 120; i < 300; i++) memcpy(p + 3 * i, p + 3 * ((i * 7) % 120), 3 * sizeof *p);
  compare("weak alpha with duplicates", 0, 0, p, 300, 0);
  /* a lattice (quantised colours): the Delaunay triangulation is not unique (GUDHI/CGAL and
     qhull may choose differently), H0 (the MST lengths) is */
  random_cloud(p, 300, 10);
  for (size_t i = 0; i < 3 * 300; i++) p[i] = floor(p[i] * 5) / 5;
  compare("weak alpha lattice", 0, 0, p, 300, 1);
}

static void test_degenerate(void) {
  double p[3 * 64];
  mgs_rng g;
  mgs_rng_init(&g, 3, 1);
  /* collinear (a grey image in RGB) and coplanar: H0 equals GUDHI's (MST edges are
     Delaunay edges of the joggled triangulation too) */
  for (int i = 0; i < 30; i++) { double t = mgs_rng_uniform(&g); p[3*i] = p[3*i+1] = p[3*i+2] = t; }
  compare("weak alpha collinear", 0, 0, p, 30, 1);
  compare("rips collinear", 1, 0.5, p, 30, 0);
  for (int i = 0; i < 30; i++) { p[3*i] = mgs_rng_uniform(&g); p[3*i+1] = mgs_rng_uniform(&g); p[3*i+2] = 0.5; }
  compare("weak alpha coplanar", 0, 0, p, 30, 1);
  compare("rips coplanar", 1, 0.5, p, 30, 0);
  /* one distinct point (a constant image): one essential H0 class */
  for (int i = 0; i < 20; i++) { p[3*i] = 0.2; p[3*i+1] = 0.4; p[3*i+2] = 0.6; }
  mgs_topo_bars b;
  mgs_topo_bars_init(&b);
  mgs_error err = {0};
  CHECK_OK(mgs_topo_weak_alpha_persistence(p, 20, &b, &err), &err);
  CHECK(b.n == 1 && b.bars[0].dim == 0 && isinf(b.bars[0].death));
  mgs_topo_bars_free(&b);
  mgs_topo_bars_init(&b);
  CHECK_OK(mgs_topo_rips_persistence(p, 20, 1.0, &b, &err), &err);
  CHECK(b.n == 1 && b.bars[0].dim == 0 && isinf(b.bars[0].death));
  mgs_topo_bars_free(&b);
  /* 2, 3, 4 points: the complete complex */
  random_cloud(p, 4, 11);
  for (size_t n = 2; n <= 4; n++) { char nm[32]; snprintf(nm, sizeof nm, "weak alpha %zu points", n); compare(nm, 0, 0, p, n, 0); }
  /* non-finite input is an error, not a crash */
  p[4] = NAN;
  mgs_topo_bars_init(&b);
  CHECK(mgs_topo_weak_alpha_persistence(p, 4, &b, &err) == MGS_ERR_NUMERIC);
  CHECK(mgs_topo_rips_persistence(p, 4, 1.0, &b, &err) == MGS_ERR_NUMERIC);
  mgs_topo_bars_free(&b);
}

static void test_voronoi(void) {
  /* the Voronoi vertex of a regular tetrahedron's 4 points plus a far point: the centre
     of the tetrahedron's circumsphere is among the vertices */
  double p[15] = {1, 1, 1, 1, -1, -1, -1, 1, -1, -1, -1, 1, 5, 5, 5};
  double *c = NULL; size_t m = 0;
  mgs_error err = {0};
  CHECK_OK(mgs_topo_voronoi_vertices(p, 5, 3, &c, &m, &err), &err);
  int found = 0;
  for (size_t i = 0; i < m; i++) found |= fabs(c[3*i]) + fabs(c[3*i+1]) + fabs(c[3*i+2]) < 1e-9;
  CHECK(m >= 2 && found);
  free(c);
  /* coplanar 3-D points: no finite 3-D Voronoi vertex, an empty result */
  double q[3 * 8];
  for (int i = 0; i < 8; i++) { q[3*i] = i % 3; q[3*i+1] = i / 3; q[3*i+2] = 0; }
  CHECK_OK(mgs_topo_voronoi_vertices(q, 8, 3, &c, &m, &err), &err);
  free(c);
  /* 2-D: a square's 4 cospherical points share one Voronoi vertex (merged) */
  double s[8] = {0, 0, 1, 0, 1, 1, 0, 1};
  CHECK_OK(mgs_topo_voronoi_vertices(s, 4, 2, &c, &m, &err), &err);
  CHECK(m == 1 && c && fabs(c[0] - 0.5) < 1e-12 && fabs(c[1] - 0.5) < 1e-12);
  free(c);
}

int main(void) {
  RUN(test_rips_random);
  RUN(test_weak_alpha_random);
  RUN(test_degenerate);
  RUN(test_voronoi);
  return mgs_test_finish();
}

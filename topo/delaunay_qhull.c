/* Delaunay triangulations and Voronoi vertices through qhull's reentrant C API
 * (topo/mgs_topo_pointcloud.h). One qhT per call, so calls from parallel loops are safe. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <libqhull_r/qhull_ra.h>
#include "topo/mgs_topo_pointcloud.h"

/* Runs qhull with `flags`; returns qhull's exit code (0 ok). On success the lower
 * Delaunay facets' vertex indices are appended to *out. */
static int run_qhull(const double *pts, size_t n, int d, const char *flags, int32_t **out, size_t *count,
                     int *nomem) {
  coordT *copy = malloc(n * (size_t)d * sizeof *copy); /* qhull may touch its input */
  if (!copy) { *nomem = 1; return 1; }
  memcpy(copy, pts, n * (size_t)d * sizeof *copy);
  /* qhull reports precision problems on its error stream: silence it (the caller retries
     joggled or returns an empty result, which is the documented behaviour) */
  FILE *devnull = fopen("/dev/null", "w");
  qhT qh_qh;
  qhT *qh = &qh_qh;
  QHULL_LIB_CHECK
  qh_zero(qh, devnull);
  char opts[64];
  snprintf(opts, sizeof opts, "qhull %s", flags);
  int code = qh_new_qhull(qh, d, (int)n, copy, False, opts, NULL, devnull);
  if (!code) {
    size_t cap = 0, m = 0;
    int32_t *s = NULL;
    facetT *facet;
    vertexT *vertex, **vertexp;
    FORALLfacets {
      if (facet->upperdelaunay) continue;
      if (qh_setsize(qh, facet->vertices) != d + 1) continue; /* simplicial with Qt/QJ */
      if (m == cap) {
        cap = cap ? 2 * cap : 64;
        int32_t *ns = realloc(s, cap * (size_t)(d + 1) * sizeof *ns);
        if (!ns) { free(s); s = NULL; *nomem = 1; code = 1; break; }
        s = ns;
      }
      int k = 0;
      FOREACHvertex_(facet->vertices) s[m * (size_t)(d + 1) + (size_t)k++] = (int32_t)qh_pointid(qh, vertex->point);
      m++;
    }
    if (!code) { *out = s; *count = m; }
  }
  qh_freeqhull(qh, !qh_ALL);
  int curlong, totlong;
  qh_memfreeshort(qh, &curlong, &totlong);
  if (devnull) fclose(devnull);
  free(copy);
  return code;
}

mgs_status mgs_topo_delaunay(const double *pts, size_t n, int d, int32_t **simplices, size_t *count,
                             int *joggled, mgs_error *err) {
  *simplices = NULL;
  *count = 0;
  if (joggled) *joggled = 0;
  if (d != 2 && d != 3) return mgs_error_set(err, MGS_ERR_ARG, "Delaunay: dimension %d (2 or 3)", d);
  if (n > (size_t)INT32_MAX) return mgs_error_set(err, MGS_ERR_ARG, "Delaunay: %zu points (too many)", n);
  for (size_t i = 0; i < n * (size_t)d; i++)
    if (!isfinite(pts[i])) return mgs_error_set(err, MGS_ERR_NUMERIC, "Delaunay: point %zu is not finite", i / (size_t)d);
  if (n < (size_t)d + 2) return MGS_OK; /* qhull's minimum; no simplex can be certified */
  int nomem = 0;
  int code = run_qhull(pts, n, d, "d Qbb Qc Qz Q12 Qt", simplices, count, &nomem);
  if (code && !nomem) {
    code = run_qhull(pts, n, d, "d Qbb QJ", simplices, count, &nomem);
    if (!code && joggled) *joggled = 1;
  }
  if (nomem) return mgs_error_set(err, MGS_ERR_NOMEM, "Delaunay: out of memory (%zu points)", n);
  if (code) { *simplices = NULL; *count = 0; } /* degenerate even joggled: empty */
  return MGS_OK;
}

/* Circumcentre of a simplex: solves 2 (p_k − p_0)·c' = |p_k − p_0|^2 for c' = c − p_0. */
static int circumcentre(const double *pts, const int32_t *v, int d, double *c) {
  double A[3][3], b[3];
  const double *p0 = pts + (size_t)v[0] * d;
  for (int k = 0; k < d; k++) {
    const double *pk = pts + (size_t)v[k + 1] * d;
    double s = 0;
    for (int a = 0; a < d; a++) { A[k][a] = 2.0 * (pk[a] - p0[a]); s += (pk[a] - p0[a]) * (pk[a] - p0[a]); }
    b[k] = s;
  }
  /* Gaussian elimination with partial pivoting (d <= 3) */
  int piv[3] = {0, 1, 2};
  for (int col = 0; col < d; col++) {
    int best = col;
    for (int r = col + 1; r < d; r++) if (fabs(A[piv[r]][col]) > fabs(A[piv[best]][col])) best = r;
    int t = piv[col]; piv[col] = piv[best]; piv[best] = t;
    double pv = A[piv[col]][col];
    if (pv == 0.0) return 0;
    for (int r = col + 1; r < d; r++) {
      double f = A[piv[r]][col] / pv;
      for (int a = col; a < d; a++) A[piv[r]][a] -= f * A[piv[col]][a];
      b[piv[r]] -= f * b[piv[col]];
    }
  }
  double x[3];
  for (int col = d - 1; col >= 0; col--) {
    double s = b[piv[col]];
    for (int a = col + 1; a < d; a++) s -= A[piv[col]][a] * x[a];
    x[col] = s / A[piv[col]][col];
  }
  for (int a = 0; a < d; a++) {
    c[a] = p0[a] + x[a];
    if (!isfinite(c[a])) return 0;
  }
  return 1;
}

static int cmp_lex3(const void *x, const void *y) {
  const double *a = x, *b = y;
  for (int k = 0; k < 3; k++) if (a[k] != b[k]) return a[k] < b[k] ? -1 : 1;
  return 0;
}
static int cmp_lex2(const void *x, const void *y) {
  const double *a = x, *b = y;
  for (int k = 0; k < 2; k++) if (a[k] != b[k]) return a[k] < b[k] ? -1 : 1;
  return 0;
}

mgs_status mgs_topo_voronoi_vertices(const double *pts, size_t n, int d, double **centres, size_t *count,
                                     mgs_error *err) {
  *centres = NULL;
  *count = 0;
  int32_t *s = NULL;
  size_t m = 0;
  mgs_status st = mgs_topo_delaunay(pts, n, d, &s, &m, NULL, err);
  if (st || m == 0) { free(s); return st; }
  double *c = malloc(m * (size_t)d * sizeof *c);
  if (!c) { free(s); return mgs_error_set(err, MGS_ERR_NOMEM, "Voronoi: out of memory"); }
  size_t k = 0;
  for (size_t i = 0; i < m; i++)
    if (circumcentre(pts, s + i * (size_t)(d + 1), d, c + k * (size_t)d)) k++;
  free(s);
  /* cospherical points split into several simplices by Qt share one Voronoi vertex:
     merge centres equal up to rounding (relative to the cloud's size) */
  double lo = INFINITY, hi = -INFINITY;
  for (size_t i = 0; i < n * (size_t)d; i++) { lo = fmin(lo, pts[i]); hi = fmax(hi, pts[i]); }
  double tol = 1e-9 * fmax(hi - lo, 1e-300);
  qsort(c, k, (size_t)d * sizeof *c, d == 3 ? cmp_lex3 : cmp_lex2);
  size_t u = 0;
  for (size_t i = 0; i < k; i++) {
    int dup = 0;
    /* sorted by the first coordinate: look back while it is within tol */
    for (size_t j = u; j-- > 0;) {
      if (c[i * (size_t)d] - c[j * (size_t)d] > tol) break;
      double m2 = 0;
      for (int a = 0; a < d; a++) m2 = fmax(m2, fabs(c[i * (size_t)d + a] - c[j * (size_t)d + a]));
      if (m2 <= tol) { dup = 1; break; }
    }
    if (!dup) {
      if (u != i) memmove(c + u * (size_t)d, c + i * (size_t)d, (size_t)d * sizeof *c);
      u++;
    }
  }
  *centres = c;
  *count = u;
  return MGS_OK;
}

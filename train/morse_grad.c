/* Point evaluations of the α-field and the SDF derivative w.r.t. the Gaussians
 * (train/mgs_morse_grad.h). Each Gaussian is evaluated in its local frame, where the
 * filtered covariance is diagonal (Σ' = R diag(s² + f) Rᵀ since f·I commutes with R):
 * no matrix inversion, so near-singular Gaussians (s = 1e-7) stay exact in double. */
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include "train/gauss_local.h"
#include "train/mgs_morse_grad.h"

void mgs_morse_field_params_default(mgs_morse_field_params *p) {
  p->k_sigma = 3.0;
  p->filter_var = 0.0;
}

double mgs_morse_filter_var(double voxel_size, int small_mode) {
  if (small_mode == 0) return -1; /* MGS_VDB_SMALL_MASS */
  if (small_mode == 2) return 0;  /* MGS_VDB_SMALL_NONE */
  return 0.25 * voxel_size * voxel_size;
}

static mgs_status check_params(const mgs_morse_field_params *p, mgs_error *err) {
  if (!(p->k_sigma > 0) || p->k_sigma > 10)
    return mgs_error_set(err, MGS_ERR_ARG, "morse field: k-sigma %g outside (0, 10]", p->k_sigma);
  if (!(p->filter_var >= 0) || !isfinite(p->filter_var))
    return mgs_error_set(err, MGS_ERR_UNSUPPORTED,
                         "morse field: filter variance %g invalid (the mass-preserving filter is not supported)",
                         p->filter_var);
  return MGS_OK;
}

/* One Gaussian at x: the local quantities the derivatives need. */
typedef struct eval1 {
  mgs_gauss_local L;
  double d[3];      /* x − μ */
  double u[3];      /* local coordinates rᵀ_k d */
  double v[3];      /* filtered variances s_k² + f */
  double G;         /* α exp(−q/2), 0 outside the support */
  double Pd[3];     /* Σ'⁻¹ d (world) */
} eval1;

/* Returns 1 when x is inside Gaussian i's support (and it is not transparent). */
static int eval_one(const mgs_gaussians *g, size_t i, const mgs_morse_field_params *p, const double x[3], eval1 *e) {
  /* quick reject by the bounding sphere k·σ_max (one exp instead of the full setup) */
  {
    const float *ls = g->log_scale + 3 * i;
    double lmax = fmax(ls[0], fmax(ls[1], ls[2])), r2 = 0;
    for (int a = 0; a < 3; a++) { double t = x[a] - (double)g->mean[3 * i + a]; r2 += t * t; }
    double vmax = exp(2 * fmin(lmax, 300.0)) + p->filter_var;
    if (r2 > p->k_sigma * p->k_sigma * vmax * (1 + 1e-12)) return 0;
  }
  mgs_gauss_local_get(g, i, &e->L);
  if (!(e->L.alpha > 0)) return 0;
  double q = 0;
  for (int a = 0; a < 3; a++) e->d[a] = x[a] - e->L.mu[a];
  for (int k = 0; k < 3; k++) {
    e->u[k] = e->L.R[k] * e->d[0] + e->L.R[3 + k] * e->d[1] + e->L.R[6 + k] * e->d[2];
    e->v[k] = e->L.s2[k] + p->filter_var;
    if (!(e->v[k] > 0)) return 0; /* a zero variance: vdb/ skips it as singular */
    q += e->u[k] * e->u[k] / e->v[k];
  }
  if (!(q <= p->k_sigma * p->k_sigma)) return 0;
  e->G = e->L.alpha * exp(-0.5 * q);
  for (int a = 0; a < 3; a++)
    e->Pd[a] = e->L.R[3 * a] * e->u[0] / e->v[0] + e->L.R[3 * a + 1] * e->u[1] / e->v[1] + e->L.R[3 * a + 2] * e->u[2] / e->v[2];
  return 1;
}

/* ---------------------------------------------------------------- spatial index */
struct mgs_morse_index {
  mgs_morse_field_params p;
  size_t n;
  double origin[3], cell;
  int64_t dims[3];
  uint64_t *keys;     /* sorted cell keys, one per (cell, Gaussian) pair */
  uint32_t *ids;      /* the Gaussian of each pair */
  size_t npairs;
  uint32_t *global;   /* Gaussians too large for the cells: always visited */
  size_t nglobal;
  float *box;         /* n*6: the padded box each Gaussian was indexed with (lo, hi);
                         lo > hi: not indexed (transparent) */
};

/* Boxes are indexed enlarged by this fraction of their half-extent on each side, so the
   index stays exact while Gaussians move or grow by less (mgs_morse_index_update). */
#define INDEX_PAD 0.25

typedef struct pair64 { uint64_t key; uint32_t id; } pair64;
static int cmp_pair(const void *a, const void *b) {
  const pair64 *x = a, *y = b;
  if (x->key != y->key) return x->key < y->key ? -1 : 1;
  return x->id < y->id ? -1 : (x->id > y->id);
}
static int cmp_double(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return x < y ? -1 : (x > y);
}

/* Half-extents of Gaussian i's kσ box (axis a: k sqrt(Σ'_aa)); 0 if it reaches nothing. */
static int support_box(const mgs_gaussians *g, size_t i, const mgs_morse_field_params *p, double lo[3], double hi[3]) {
  mgs_gauss_local L;
  mgs_gauss_local_get(g, i, &L);
  if (!(L.alpha > 0)) return 0;
  for (int a = 0; a < 3; a++) {
    double var = 0;
    for (int k = 0; k < 3; k++) var += L.R[3 * a + k] * L.R[3 * a + k] * (L.s2[k] + p->filter_var);
    double h = p->k_sigma * sqrt(var);
    if (!isfinite(h) || !isfinite(L.mu[a])) return 0;
    lo[a] = L.mu[a] - h;
    hi[a] = L.mu[a] + h;
  }
  return 1;
}

#define KEY_BITS 21
static uint64_t cell_key(const int64_t c[3]) {
  return ((uint64_t)c[0] << (2 * KEY_BITS)) | ((uint64_t)c[1] << KEY_BITS) | (uint64_t)c[2];
}

mgs_status mgs_morse_index_create(const mgs_gaussians *g, const mgs_morse_field_params *pin, mgs_morse_index **out,
                                  mgs_error *err) {
  *out = NULL;
  mgs_morse_field_params p;
  if (pin) p = *pin; else mgs_morse_field_params_default(&p);
  mgs_status st = check_params(&p, err);
  if (st) return st;
  if (g->n > 0xffffffffull) return mgs_error_set(err, MGS_ERR_UNSUPPORTED, "morse index: more than 2^32 Gaussians");
  mgs_morse_index *ix = calloc(1, sizeof *ix);
  double *box = malloc(sizeof(double) * 6 * (g->n ? g->n : 1));
  double *ext = malloc(sizeof(double) * (g->n ? g->n : 1));
  uint8_t *ok = malloc(g->n ? g->n : 1);
  if (!ix || !box || !ext || !ok) {
    free(ix); free(box); free(ext); free(ok);
    return mgs_error_set(err, MGS_ERR_NOMEM, "morse index: out of memory for %zu Gaussians", g->n);
  }
  ix->p = p;
  ix->n = g->n;
  double blo[3] = {DBL_MAX, DBL_MAX, DBL_MAX}, bhi[3] = {-DBL_MAX, -DBL_MAX, -DBL_MAX};
  size_t nok = 0;
  for (size_t i = 0; i < g->n; i++) {
    ok[i] = (uint8_t)support_box(g, i, &p, box + 6 * i, box + 6 * i + 3);
    if (!ok[i]) continue;
    for (int a = 0; a < 3; a++) {
      double pad = INDEX_PAD * 0.5 * (box[6 * i + 3 + a] - box[6 * i + a]);
      box[6 * i + a] -= pad;
      box[6 * i + 3 + a] += pad;
    }
    double e = 0;
    for (int a = 0; a < 3; a++) {
      blo[a] = fmin(blo[a], box[6 * i + a]);
      bhi[a] = fmax(bhi[a], box[6 * i + 3 + a]);
      e = fmax(e, box[6 * i + 3 + a] - box[6 * i + a]);
    }
    ext[nok++] = e;
  }
  if (nok == 0) { /* nothing reaches anywhere: an empty index */
    ix->box = malloc(sizeof(float) * 6 * (g->n ? g->n : 1));
    for (size_t i = 0; ix->box && i < g->n; i++)
      for (int a = 0; a < 6; a++) ix->box[6 * i + a] = a < 3 ? 1.0f : 0.0f;
    free(box); free(ext); free(ok);
    if (!ix->box) { free(ix); return mgs_error_set(err, MGS_ERR_NOMEM, "morse index: out of memory"); }
    *out = ix;
    return MGS_OK;
  }
  /* cell = the median box size (most Gaussians then touch ≤ 8 cells), but never so small
     that the scene needs more than 2^21 cells per axis */
  qsort(ext, nok, sizeof *ext, cmp_double);
  double cell = ext[nok / 2];
  for (int a = 0; a < 3; a++) cell = fmax(cell, (bhi[a] - blo[a]) / (double)((1 << KEY_BITS) - 2));
  if (!(cell > 0)) cell = 1;
  ix->cell = cell;
  for (int a = 0; a < 3; a++) {
    ix->origin[a] = blo[a];
    ix->dims[a] = (int64_t)floor((bhi[a] - blo[a]) / cell) + 1;
  }
  /* count pairs; boxes spanning more than 4 cells along an axis go global */
  size_t npairs = 0, nglobal = 0;
  for (size_t i = 0; i < g->n; i++) {
    if (!ok[i]) continue;
    int64_t span = 1;
    for (int a = 0; a < 3; a++) {
      int64_t c0 = (int64_t)floor((box[6 * i + a] - blo[a]) / cell), c1 = (int64_t)floor((box[6 * i + 3 + a] - blo[a]) / cell);
      span *= c1 - c0 + 1;
      if (c1 - c0 + 1 > 4) span = -1000000;
    }
    if (span <= 0) { ok[i] = 2; nglobal++; } else npairs += (size_t)span;
  }
  pair64 *pairs = malloc(sizeof(pair64) * (npairs ? npairs : 1));
  ix->global = malloc(sizeof(uint32_t) * (nglobal ? nglobal : 1));
  if (!pairs || !ix->global) {
    free(pairs); free(box); free(ext); free(ok);
    mgs_morse_index_destroy(ix);
    return mgs_error_set(err, MGS_ERR_NOMEM, "morse index: out of memory for %zu cell entries", npairs);
  }
  size_t w = 0;
  for (size_t i = 0; i < g->n; i++) {
    if (ok[i] == 2) { ix->global[ix->nglobal++] = (uint32_t)i; continue; }
    if (!ok[i]) continue;
    int64_t c0[3], c1[3], c[3];
    for (int a = 0; a < 3; a++) {
      c0[a] = (int64_t)floor((box[6 * i + a] - blo[a]) / cell);
      c1[a] = (int64_t)floor((box[6 * i + 3 + a] - blo[a]) / cell);
    }
    for (c[0] = c0[0]; c[0] <= c1[0]; c[0]++)
      for (c[1] = c0[1]; c[1] <= c1[1]; c[1]++)
        for (c[2] = c0[2]; c[2] <= c1[2]; c[2]++) pairs[w++] = (pair64){cell_key(c), (uint32_t)i};
  }
  qsort(pairs, npairs, sizeof *pairs, cmp_pair);
  ix->keys = malloc(sizeof(uint64_t) * (npairs ? npairs : 1));
  ix->ids = malloc(sizeof(uint32_t) * (npairs ? npairs : 1));
  if (!ix->keys || !ix->ids) {
    free(pairs); free(box); free(ext); free(ok);
    mgs_morse_index_destroy(ix);
    return mgs_error_set(err, MGS_ERR_NOMEM, "morse index: out of memory for %zu cell entries", npairs);
  }
  for (size_t k = 0; k < npairs; k++) { ix->keys[k] = pairs[k].key; ix->ids[k] = pairs[k].id; }
  ix->npairs = npairs;
  ix->box = malloc(sizeof(float) * 6 * (g->n ? g->n : 1));
  if (!ix->box) {
    free(pairs); free(box); free(ext); free(ok);
    mgs_morse_index_destroy(ix);
    return mgs_error_set(err, MGS_ERR_NOMEM, "morse index: out of memory for %zu boxes", g->n);
  }
  for (size_t i = 0; i < g->n; i++)
    for (int a = 0; a < 6; a++) {
      /* rounded outward so the float box still contains the double one */
      double v = box[6 * i + a];
      float f = (float)v;
      if (a < 3 && (double)f > v) f = nextafterf(f, -INFINITY);
      if (a >= 3 && (double)f < v) f = nextafterf(f, INFINITY);
      ix->box[6 * i + a] = ok[i] ? f : (a < 3 ? 1.0f : 0.0f);
    }
  free(pairs); free(box); free(ext); free(ok);
  *out = ix;
  return MGS_OK;
}

void mgs_morse_index_destroy(mgs_morse_index *ix) {
  if (!ix) return;
  free(ix->box);
  free(ix->keys);
  free(ix->ids);
  free(ix->global);
  free(ix);
}

size_t mgs_morse_index_count(const mgs_morse_index *ix) { return ix ? ix->n : 0; }

mgs_status mgs_morse_index_update(mgs_morse_index **ix, const mgs_gaussians *g, int *rebuilt, mgs_error *err) {
  if (rebuilt) *rebuilt = 0;
  if (!ix || !*ix || !g) return mgs_error_set(err, MGS_ERR_ARG, "morse index update: no index or model");
  int stale = (*ix)->n != g->n;
  for (size_t i = 0; !stale && i < g->n; i++) {
    double lo[3], hi[3];
    if (!support_box(g, i, &(*ix)->p, lo, hi)) continue; /* reaches nothing now: harmless */
    const float *b = (*ix)->box + 6 * i;
    for (int a = 0; a < 3; a++)
      if (!(lo[a] >= (double)b[a] && hi[a] <= (double)b[3 + a])) { stale = 1; break; }
  }
  if (!stale) return MGS_OK;
  mgs_morse_index *fresh = NULL;
  mgs_status st = mgs_morse_index_create(g, &(*ix)->p, &fresh, err);
  if (st) return st;
  mgs_morse_index_destroy(*ix);
  *ix = fresh;
  if (rebuilt) *rebuilt = 1;
  return MGS_OK;
}

/* The candidates at x: the pairs range of x's cell ([*b, *e) into ids), or an empty range. */
static void cell_range(const mgs_morse_index *ix, const double x[3], size_t *b, size_t *e) {
  *b = *e = 0;
  if (ix->npairs == 0) return;
  int64_t c[3];
  for (int a = 0; a < 3; a++) {
    double f = floor((x[a] - ix->origin[a]) / ix->cell);
    if (!(f >= 0) || f >= (double)ix->dims[a]) return;
    c[a] = (int64_t)f;
  }
  uint64_t key = cell_key(c);
  size_t lo = 0, hi = ix->npairs;
  while (lo < hi) { size_t m = lo + (hi - lo) / 2; if (ix->keys[m] < key) lo = m + 1; else hi = m; }
  size_t end = lo;
  while (end < ix->npairs && ix->keys[end] == key) end++;
  *b = lo;
  *e = end;
}

/* Calls fn for every Gaussian whose support reaches x (index or brute force). */
typedef void (*visit_fn)(void *ctx, const eval1 *e, size_t i);
static void visit(const mgs_gaussians *g, const mgs_morse_index *ix, const mgs_morse_field_params *p, const double x[3],
                  visit_fn fn, void *ctx) {
  eval1 e;
  if (!ix) {
    for (size_t i = 0; i < g->n; i++)
      if (eval_one(g, i, p, x, &e)) fn(ctx, &e, i);
    return;
  }
  size_t b, end;
  cell_range(ix, x, &b, &end);
  for (size_t k = b; k < end; k++)
    if (eval_one(g, ix->ids[k], p, x, &e)) fn(ctx, &e, ix->ids[k]);
  for (size_t k = 0; k < ix->nglobal; k++)
    if (eval_one(g, ix->global[k], p, x, &e)) fn(ctx, &e, ix->global[k]);
}

typedef struct field_acc {
  double A, grad[3], sigma_min;
  double H[9]; /* Hessian of A (row-major): Σ G (Pd Pdᵀ − Σ'⁻¹) */
  int count;
} field_acc;

static void acc_field(void *ctx, const eval1 *e, size_t i) {
  (void)i;
  field_acc *f = ctx;
  f->A += e->G;
  for (int a = 0; a < 3; a++) f->grad[a] -= e->G * e->Pd[a];
  for (int a = 0; a < 3; a++)
    for (int b = 0; b < 3; b++) {
      const double P = e->L.R[3 * a] * e->L.R[3 * b] / e->v[0] + e->L.R[3 * a + 1] * e->L.R[3 * b + 1] / e->v[1] +
                       e->L.R[3 * a + 2] * e->L.R[3 * b + 2] / e->v[2];
      f->H[3 * a + b] += e->G * (e->Pd[a] * e->Pd[b] - P);
    }
  double vmax = fmax(e->v[0], fmax(e->v[1], e->v[2]));
  f->sigma_min = fmin(f->sigma_min, sqrt(vmax));
  f->count++;
}

static void field_at(const mgs_gaussians *g, const mgs_morse_index *ix, const mgs_morse_field_params *p, const double x[3],
                     field_acc *f) {
  memset(f, 0, sizeof *f);
  f->sigma_min = INFINITY;
  visit(g, ix, p, x, acc_field, f);
}

static mgs_status resolve(const mgs_gaussians *g, const mgs_morse_index *ix, const mgs_morse_field_params *pin,
                          mgs_morse_field_params *p, mgs_error *err) {
  if (!g) return mgs_error_set(err, MGS_ERR_ARG, "morse field: no model");
  if (ix) {
    if (ix->n != g->n)
      return mgs_error_set(err, MGS_ERR_ARG, "morse field: index built for %zu Gaussians, model has %zu (rebuild it)",
                           ix->n, g->n);
    *p = ix->p;
    return MGS_OK;
  }
  if (pin) *p = *pin; else mgs_morse_field_params_default(p);
  return check_params(p, err);
}

mgs_status mgs_morse_alpha_at(const mgs_gaussians *g, const mgs_morse_index *ix, const mgs_morse_field_params *pin,
                              const double x[3], double *alpha, double grad[3], mgs_error *err) {
  mgs_morse_field_params p;
  mgs_status st = resolve(g, ix, pin, &p, err);
  if (st) return st;
  field_acc f;
  field_at(g, ix, &p, x, &f);
  if (alpha) *alpha = f.A;
  if (grad) for (int a = 0; a < 3; a++) grad[a] = f.grad[a];
  return MGS_OK;
}

/* ---------------------------------------------------------------- closest point */
static double norm3(const double v[3]) { return sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]); }

/* Newton along ∇A from y onto {A = τ}, steps capped at half the local smallest std-dev.
 * Returns 0 on success (|A − τ| tiny), -1 in a flat region. */
static int project(const mgs_gaussians *g, const mgs_morse_index *ix, const mgs_morse_field_params *p, double y[3],
                   double tau, field_acc *f) {
  for (int it = 0; it < 100; it++) {
    field_at(g, ix, p, y, f);
    double gn = norm3(f->grad);
    double r = f->A - tau;
    if (fabs(r) <= 1e-13 * tau) return 0;
    if (f->count == 0 || !(gn > 1e-300)) return -1;
    double step = r / gn; /* along −∇A/|∇A| */
    double cap = 0.5 * f->sigma_min;
    if (fabs(step) > cap) step = step > 0 ? cap : -cap;
    double dy[3];
    for (int a = 0; a < 3; a++) dy[a] = -step * f->grad[a] / gn;
    for (int a = 0; a < 3; a++) y[a] += dy[a];
    /* converged to the last bits of the coordinates */
    if (norm3(dy) <= 1e-15 * (fabs(y[0]) + fabs(y[1]) + fabs(y[2])) + 1e-300) {
      field_at(g, ix, p, y, f);
      return 0;
    }
  }
  return fabs(f->A - tau) <= 1e-9 * tau ? 0 : -1;
}

mgs_status mgs_morse_project(const mgs_gaussians *g, const mgs_morse_index *ix, const mgs_morse_field_params *pin,
                             const double x[3], float tau, double c[3], mgs_error *err) {
  mgs_morse_field_params p;
  mgs_status st = resolve(g, ix, pin, &p, err);
  if (st) return st;
  if (!(tau > 0)) return mgs_error_set(err, MGS_ERR_ARG, "morse projection: tau %g must be positive", (double)tau);
  double y[3] = {x[0], x[1], x[2]};
  field_acc f;
  if (project(g, ix, &p, y, tau, &f))
    return mgs_error_set(err, MGS_ERR_NUMERIC, "morse projection: no surface A = %g reachable from (%g, %g, %g)",
                         (double)tau, x[0], x[1], x[2]);
  for (int a = 0; a < 3; a++) c[a] = y[a];
  return MGS_OK;
}

/* Tangential residual of y as the closest point of x: |(x−y) − ((x−y)·n) n|. */
static double tangential(const double x[3], const double y[3], const double grad[3]) {
  double gn = norm3(grad), r[3], rn = 0, t[3];
  for (int a = 0; a < 3; a++) { r[a] = x[a] - y[a]; rn += r[a] * grad[a] / gn; }
  for (int a = 0; a < 3; a++) t[a] = r[a] - rn * grad[a] / gn;
  return norm3(t);
}

/* Solves the 4x4 system M z = b by elimination with partial pivoting; -1 if singular. */
static int solve4(double M[4][4], double b[4], double z[4]) {
  for (int c = 0; c < 4; c++) {
    int piv = c;
    for (int r = c + 1; r < 4; r++) if (fabs(M[r][c]) > fabs(M[piv][c])) piv = r;
    if (!(fabs(M[piv][c]) > 1e-300)) return -1;
    if (piv != c) {
      for (int k = 0; k < 4; k++) { double t = M[c][k]; M[c][k] = M[piv][k]; M[piv][k] = t; }
      double t = b[c]; b[c] = b[piv]; b[piv] = t;
    }
    for (int r = c + 1; r < 4; r++) {
      double m = M[r][c] / M[c][c];
      for (int k = c; k < 4; k++) M[r][k] -= m * M[c][k];
      b[r] -= m * b[c];
    }
  }
  for (int c = 3; c >= 0; c--) {
    double v = b[c];
    for (int k = c + 1; k < 4; k++) v -= M[c][k] * z[k];
    z[c] = v / M[c][c];
  }
  return 0;
}

static int polish(const mgs_gaussians *g, const mgs_morse_index *ix, const mgs_morse_field_params *p, const double x[3],
                  double tau, double y[3], field_acc *f, double scale) {
  const double tol_abs = 1e-15 * scale + 1e-300;
  double gn = norm3(f->grad);
  double lam = 0; /* y − x = −λ∇A  =>  λ = (x − y)·∇A / |∇A|² */
  for (int a = 0; a < 3; a++) lam += (x[a] - y[a]) * f->grad[a] / (gn * gn);
  for (int it = 0; it < 30; it++) {
    double res = tangential(x, y, f->grad);
    double r0 = norm3((double[3]){x[0] - y[0], x[1] - y[1], x[2] - y[2]});
    if (res <= 1e-12 * (r0 + f->sigma_min) + tol_abs && fabs(f->A - tau) <= 1e-12 * tau) return 0;
    double M[4][4], b[4], z[4];
    for (int a = 0; a < 3; a++) {
      for (int c = 0; c < 3; c++) M[a][c] = (a == c) + lam * f->H[3 * a + c];
      M[a][3] = f->grad[a];
      M[3][a] = f->grad[a];
      b[a] = -(y[a] - x[a] + lam * f->grad[a]);
    }
    M[3][3] = 0;
    b[3] = -(f->A - tau);
    if (solve4(M, b, z)) return -1;
    /* damped: keep steps within half the local scale */
    double st = norm3(z), cap = 0.5 * f->sigma_min, damp = st > cap ? cap / st : 1.0;
    for (int a = 0; a < 3; a++) y[a] += damp * z[a];
    lam += damp * z[3];
    field_at(g, ix, p, y, f);
    if (f->count == 0) return -1;
    if (damp * st <= 1e-14 * (r0 + f->sigma_min) + tol_abs) {
      /* converged to rounding: accept if the residuals are small */
      return tangential(x, y, f->grad) <= 1e-9 * (r0 + f->sigma_min) + 1e3 * tol_abs &&
                     fabs(f->A - tau) <= 1e-9 * tau
                 ? 0
                 : -1;
    }
  }
  double r0 = norm3((double[3]){x[0] - y[0], x[1] - y[1], x[2] - y[2]});
  return tangential(x, y, f->grad) <= 1e-9 * (r0 + f->sigma_min) + 1e3 * tol_abs && fabs(f->A - tau) <= 1e-9 * tau ? 0 : -1;
}

mgs_status mgs_morse_closest_point(const mgs_gaussians *g, const mgs_morse_index *ix, const mgs_morse_field_params *pin,
                                   const double x[3], float tau, double c[3], double *d_out, mgs_error *err) {
  mgs_morse_field_params p;
  mgs_status st = resolve(g, ix, pin, &p, err);
  if (st) return st;
  if (!(tau > 0)) return mgs_error_set(err, MGS_ERR_ARG, "morse closest point: tau %g must be positive", (double)tau);
  field_acc f0;
  field_at(g, ix, &p, x, &f0);
  double y[3] = {x[0], x[1], x[2]};
  field_acc f;
  if (project(g, ix, &p, y, tau, &f))
    return mgs_error_set(err, MGS_ERR_NUMERIC,
                         "morse closest point: no surface A = %g reachable from (%g, %g, %g) (flat field, A = %g)",
                         (double)tau, x[0], x[1], x[2], f0.A);
  /* Chopp: move along the tangent plane toward x, re-project; halve a step that does not
     bring y closer to x */
  const double scale = fabs(x[0]) + fabs(x[1]) + fabs(x[2]);
  int it;
  for (it = 0; it < 60; it++) {
    double gn = norm3(f.grad), n[3], t[3], r[3];
    for (int a = 0; a < 3; a++) { n[a] = f.grad[a] / gn; r[a] = x[a] - y[a]; }
    double rn = r[0] * n[0] + r[1] * n[1] + r[2] * n[2];
    for (int a = 0; a < 3; a++) t[a] = r[a] - rn * n[a];
    double tl = norm3(t);
    if (tl <= 1e-11 * (norm3(r) + f.sigma_min) + 1e-15 * scale) break;
    double dist0 = norm3(r), lam = 1.0;
    int moved = 0;
    for (int h = 0; h < 30; h++, lam *= 0.5) {
      double yy[3] = {y[0] + lam * t[0], y[1] + lam * t[1], y[2] + lam * t[2]};
      field_acc ff;
      if (project(g, ix, &p, yy, tau, &ff)) continue;
      double rr[3] = {x[0] - yy[0], x[1] - yy[1], x[2] - yy[2]};
      if (norm3(rr) <= dist0 + 1e-15 * scale) {
        memcpy(y, yy, sizeof yy);
        f = ff;
        moved = 1;
        break;
      }
    }
    if (!moved) break; /* no closer point along the tangent: y is the local minimum */
  }
  /* Chopp converges linearly, slowly where x is near a centre of curvature: polish with
     Newton on the optimality system  y − x + λ∇A(y) = 0,  A(y) = τ  (quadratic) */
  if (polish(g, ix, &p, x, tau, y, &f, scale))
    return mgs_error_set(err, MGS_ERR_NUMERIC, "morse closest point: no convergence from (%g, %g, %g)", x[0], x[1], x[2]);
  for (int a = 0; a < 3; a++) c[a] = y[a];
  if (d_out) {
    double r[3] = {x[0] - y[0], x[1] - y[1], x[2] - y[2]};
    *d_out = f0.A > tau ? -norm3(r) : norm3(r);
  }
  return MGS_OK;
}

/* ---------------------------------------------------------------- SDF derivative */
typedef struct grad_acc {
  mgs_gaussians *grad;
  double s; /* −weight / |∇A| */
} grad_acc;

static void acc_grad(void *ctx, const eval1 *e, size_t i) {
  grad_acc *acc = ctx;
  mgs_gaussians *gr = acc->grad;
  const double s = acc->s, G = e->G;
  /* opacity logit: ∂G/∂logit = G (1 − α) */
  gr->opacity[i] += (float)(s * G * (1.0 - e->L.alpha));
  /* mean: ∂G/∂μ = G Σ'⁻¹ d */
  for (int k = 0; k < 3; k++) gr->mean[3 * i + k] += (float)(s * G * e->Pd[k]);
  /* log-scale: q = Σ u_k²/v_k, v_k = s_k² + f: ∂G/∂log s_k = G u_k² s_k² / v_k² */
  for (int k = 0; k < 3; k++)
    if (!e->L.ls_clamped[k]) {
      double t = e->u[k] / e->v[k];
      gr->log_scale[3 * i + k] += (float)(s * G * t * t * e->L.s2[k]);
    }
  /* rotation: u_k = Σ_a R[a][k] d_a: ∂G/∂R[a][k] = −G (u_k / v_k) d_a (equal to the
     derivative through Σ' on the rotations' tangent space, all the normalization keeps) */
  double dR[9];
  for (int a = 0; a < 3; a++)
    for (int k = 0; k < 3; k++) dR[3 * a + k] = -G * (e->u[k] / e->v[k]) * e->d[a];
  double dq[4];
  mgs_gauss_local_dq(&e->L, dR, dq);
  for (int k = 0; k < 4; k++) gr->rot[4 * i + k] += (float)(s * dq[k]);
}

static mgs_status point_grad(const mgs_gaussians *g, const mgs_morse_index *ix, const mgs_morse_field_params *p,
                             const double c[3], float tau, double weight, mgs_gaussians *grad, mgs_morse_point *pt,
                             mgs_error *err) {
  /* weight 0 with no gradient model: the value only (A and ∇A at c) */
  if ((grad || weight != 0) && (!grad || grad->n != g->n))
    return mgs_error_set(err, MGS_ERR_ARG, "morse sdf gradient: gradient model has %zu rows, model %zu",
                         grad ? grad->n : 0, g->n);
  if (!(tau > 0)) return mgs_error_set(err, MGS_ERR_ARG, "morse sdf gradient: tau %g must be positive", (double)tau);
  if (!isfinite(weight) || !isfinite(c[0]) || !isfinite(c[1]) || !isfinite(c[2]))
    return mgs_error_set(err, MGS_ERR_NUMERIC, "morse sdf gradient: non-finite point or weight");
  field_acc f;
  field_at(g, ix, p, c, &f);
  mgs_morse_point r;
  memset(&r, 0, sizeof r);
  r.alpha = f.A;
  for (int a = 0; a < 3; a++) r.grad[a] = f.grad[a];
  r.grad_norm = norm3(f.grad);
  r.contributors = f.count;
  if (f.count > 0 && weight != 0) {
    double floor_g = 1e-3 * tau / f.sigma_min, den = r.grad_norm;
    if (!(den >= floor_g)) { den = floor_g; r.floored = 1; }
    grad_acc acc = {grad, -weight / den};
    visit(g, ix, p, c, acc_grad, &acc);
  }
  if (pt) *pt = r;
  return MGS_OK;
}

mgs_status mgs_morse_sdf_point_grad(const mgs_gaussians *g, const double c[3], float tau, double weight,
                                    mgs_gaussians *grad, double *alpha_out, mgs_error *err) {
  mgs_morse_field_params p;
  mgs_morse_field_params_default(&p);
  if (!g) return mgs_error_set(err, MGS_ERR_ARG, "morse sdf gradient: no model");
  mgs_morse_point pt = {0};
  mgs_status st = point_grad(g, NULL, &p, c, tau, weight, grad, &pt, err);
  if (st == MGS_OK && alpha_out) *alpha_out = pt.alpha;
  return st;
}

/* One pass: each candidate's support test and local frame are computed once, A, ∇A and
   σ_min summed, and ∂A/∂θ written (acc_grad's expressions at s = 1) into unit's row. */
mgs_status mgs_morse_sdf_point_unit_grad(const mgs_gaussians *g, const double c[3], float tau, mgs_gaussians *unit,
                                         mgs_morse_point *pt, double *den_out, mgs_error *err) {
  mgs_morse_field_params p;
  mgs_morse_field_params_default(&p);
  if (!g || !unit || unit->n != g->n)
    return mgs_error_set(err, MGS_ERR_ARG, "morse sdf unit gradient: gradient model has %zu rows, model %zu",
                         unit ? unit->n : 0, g ? g->n : 0);
  if (!(tau > 0)) return mgs_error_set(err, MGS_ERR_ARG, "morse sdf gradient: tau %g must be positive", (double)tau);
  if (!isfinite(c[0]) || !isfinite(c[1]) || !isfinite(c[2]))
    return mgs_error_set(err, MGS_ERR_NUMERIC, "morse sdf gradient: non-finite point or weight");
  double A = 0, gA[3] = {0, 0, 0}, sigma_min = INFINITY;
  int count = 0;
  grad_acc acc = {unit, 1.0};
  eval1 e;
  for (size_t i = 0; i < g->n; i++) {
    unit->opacity[i] = 0;
    for (int k = 0; k < 3; k++) unit->mean[3 * i + k] = unit->log_scale[3 * i + k] = 0;
    for (int k = 0; k < 4; k++) unit->rot[4 * i + k] = 0;
    if (!eval_one(g, i, &p, c, &e)) continue;
    A += e.G;
    for (int a = 0; a < 3; a++) gA[a] -= e.G * e.Pd[a];
    double vmax = fmax(e.v[0], fmax(e.v[1], e.v[2]));
    sigma_min = fmin(sigma_min, sqrt(vmax));
    count++;
    acc_grad(&acc, &e, i);
  }
  mgs_morse_point r;
  memset(&r, 0, sizeof r);
  r.alpha = A;
  for (int a = 0; a < 3; a++) r.grad[a] = gA[a];
  r.grad_norm = norm3(gA);
  r.contributors = count;
  double floor_g = 1e-3 * tau / sigma_min, den = r.grad_norm;
  if (count > 0 && !(den >= floor_g)) { den = floor_g; r.floored = 1; }
  if (pt) *pt = r;
  if (den_out) *den_out = den;
  return MGS_OK;
}

mgs_status mgs_morse_sdf_point_grad_ix(const mgs_gaussians *g, const mgs_morse_index *ix, const double c[3], float tau,
                                       double weight, mgs_gaussians *grad, mgs_morse_point *pt, mgs_error *err) {
  mgs_morse_field_params p;
  mgs_status st = resolve(g, ix, NULL, &p, err);
  if (st) return st;
  return point_grad(g, ix, &p, c, tau, weight, grad, pt, err);
}

/* LPVI: persistence-checked Voronoi densification of the initial points (train/mgs_lpvi.h).
 * Delaunay/Voronoi through qhull and Rips persistence through topo/mgs_topo_pointcloud.h;
 * W1 through topo/mgs_diagram_tools.h (exact Hungarian: these diagrams have < 200 points). */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "core/mgs_log.h"
#include "core/mgs_math.h"
#include "core/mgs_parallel.h"
#include "topo/mgs_diagram_tools.h"
#include "topo/mgs_topo_pointcloud.h"
#include "train/mgs_lpvi.h"

void mgs_lpvi_options_default(mgs_lpvi_options *o) {
  o->faithful = 0;
  o->k_max = 16;
  o->k_min = 8;
  o->tau = 0.25;
  o->max_edge = 2.0;
  o->extent = 0.0;
}

/* What one point computes (a function of the input cloud only). */
typedef struct lpvi_result {
  int branch;          /* 0: accepted in 3-D, 1: 2-D tangent branch */
  double w1;
  size_t n_new;
  double *xyz;         /* n_new x 3 */
  float *rgb;          /* n_new x 3 */
  size_t n_visit;
  size_t visit[64];
  mgs_status st;
  mgs_error err;
} lpvi_result;

typedef struct lpvi_ctx {
  const float *xyz, *rgb;
  size_t n;
  const mgs_lpvi_options *o;
  double tau, max_edge;
  const mgs_kdtree *tree;
  const size_t *batch;
  lpvi_result *res;
} lpvi_ctx;

/* W1 (Euclidean ground metric) between two diagrams merged over dimensions 0 and 1 (as the
 * authors' single diagram): finite points by the exact Hungarian matching; essential
 * classes among themselves by sorted birth (optimal in 1-D), INFINITY if their numbers
 * differ (GUDHI's wasserstein_distance with keep_essential_parts). */
static int cmp_d(const void *x, const void *y) {
  double a = *(const double *)x, b = *(const double *)y;
  return a < b ? -1 : a > b;
}
static double w1_merged(const mgs_topo_bars *a, const mgs_topo_bars *b, int *nomem) {
  size_t na = a->n, nb = b->n;
  double *buf = malloc((2 * (na + nb) + 2) * sizeof *buf);
  if (!buf) { *nomem = 1; return NAN; }
  double *ba = buf, *da = ba + na, *bb = da + na + 1, *db = bb + nb;
  double *ea = malloc((na + nb + 2) * sizeof *ea);
  if (!ea) { free(buf); *nomem = 1; return NAN; }
  double *eb = ea + na + 1;
  size_t fa = 0, fb = 0, ka = 0, kb = 0;
  for (size_t i = 0; i < na; i++) {
    if (isinf(a->bars[i].death)) ea[ka++] = a->bars[i].birth;
    else { ba[fa] = a->bars[i].birth; da[fa++] = a->bars[i].death; }
  }
  for (size_t i = 0; i < nb; i++) {
    if (isinf(b->bars[i].death)) eb[kb++] = b->bars[i].birth;
    else { bb[fb] = b->bars[i].birth; db[fb++] = b->bars[i].death; }
  }
  double w;
  if (ka != kb) w = INFINITY;
  else {
    w = mgs_wasserstein_points(ba, da, fa, bb, db, fb, 1.0, 2.0, NULL);
    qsort(ea, ka, sizeof *ea, cmp_d);
    qsort(eb, kb, sizeof *eb, cmp_d);
    for (size_t i = 0; i < ka; i++) w += fabs(ea[i] - eb[i]);
  }
  free(buf);
  free(ea);
  return w;
}

/* Inverse-distance-weighted colour of the neighbourhood at q. */
static void idw_colour(const lpvi_ctx *c, const size_t *nb, size_t m, const double *q, float *out) {
  double s[3] = {0, 0, 0}, ws = 0;
  for (size_t k = 0; k < m; k++) {
    const float *p = c->xyz + 3 * nb[k];
    double d = sqrt((p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]) + (p[2] - q[2]) * (p[2] - q[2]));
    double w = 1.0 / (d + 1e-12);
    for (int a = 0; a < 3; a++) s[a] += w * (c->rgb ? c->rgb[3 * nb[k] + a] : 0.5);
    ws += w;
  }
  for (int a = 0; a < 3; a++) out[a] = (float)(s[a] / ws);
}

/* Mean, PCA (eigenvalues ascending, eigenvectors as columns) and radius of points nb. */
static void pca(const float *xyz, const size_t *nb, size_t m, double mean[3], double w[3], double V[9], double *radius) {
  mean[0] = mean[1] = mean[2] = 0;
  for (size_t k = 0; k < m; k++) for (int a = 0; a < 3; a++) mean[a] += xyz[3 * nb[k] + a];
  for (int a = 0; a < 3; a++) mean[a] /= (double)m;
  double C[9] = {0};
  double r2 = 0;
  for (size_t k = 0; k < m; k++) {
    double d[3];
    for (int a = 0; a < 3; a++) d[a] = xyz[3 * nb[k] + a] - mean[a];
    for (int a = 0; a < 3; a++) for (int b = 0; b < 3; b++) C[3 * a + b] += d[a] * d[b] / (double)m;
    r2 = fmax(r2, d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
  }
  mgs_sym3_eigen(C, w, V);
  *radius = sqrt(r2);
}

static mgs_status eval_point(const lpvi_ctx *c, size_t i, lpvi_result *r) {
  const mgs_lpvi_options *o = c->o;
  mgs_error *err = &r->err;
  size_t kmax = (size_t)o->k_max, nb[64];
  double d2[64];
  size_t m = mgs_kdtree_knn(c->tree, (double[3]){c->xyz[3 * i], c->xyz[3 * i + 1], c->xyz[3 * i + 2]}, kmax, nb, d2);
  /* the point itself first (duplicates of it may tie at distance 0) */
  size_t self = m;
  for (size_t k = 0; k < m; k++) if (nb[k] == i) { self = k; break; }
  if (self == m) { memmove(nb + 1, nb, (m - 1) * sizeof *nb); nb[0] = i; }
  else { for (size_t k = self; k > 0; k--) nb[k] = nb[k - 1]; nb[0] = i; }
  double mean[3], w[3], V[9], radius;
  pca(c->xyz, nb, m, mean, w, V, &radius);
  /* flat to rounding: 3-D Voronoi vertices of coplanar points are not finite (corrected
     mode goes straight to the plane) */
  int flat = !o->faithful && w[0] <= 1e-12 * fmax(w[2], 1e-300);
  double *P = malloc(3 * m * sizeof *P);
  double *cand = NULL;
  size_t nc = 0;
  mgs_topo_bars before, after;
  mgs_topo_bars_init(&before);
  mgs_topo_bars_init(&after);
  mgs_status st = MGS_OK;
  if (!P) return mgs_error_set(err, MGS_ERR_NOMEM, "LPVI: out of memory");
  for (size_t k = 0; k < m; k++) for (int a = 0; a < 3; a++) P[3 * k + a] = c->xyz[3 * nb[k] + a];
  r->branch = 0;
  r->w1 = 0;
  if (!flat) {
    if ((st = mgs_topo_voronoi_vertices(P, m, 3, &cand, &nc, err))) goto out;
    if (!o->faithful) { /* keep candidates inside the neighbourhood's bounding ball */
      size_t u = 0;
      for (size_t k = 0; k < nc; k++) {
        double *q = cand + 3 * k;
        double dd = sqrt((q[0] - mean[0]) * (q[0] - mean[0]) + (q[1] - mean[1]) * (q[1] - mean[1]) + (q[2] - mean[2]) * (q[2] - mean[2]));
        if (dd <= radius) { memmove(cand + 3 * u, q, 3 * sizeof *q); u++; }
      }
      nc = u;
      /* none inside: the 3-D Voronoi vertices of a surface patch lie near its medial
         axis, away from the patch; the tangent plane is where points belong */
      if (nc == 0) flat = 1;
    }
  }
  if (!flat) {
    double *PC = malloc(3 * (m + nc) * sizeof *PC);
    if (!PC) { st = mgs_error_set(err, MGS_ERR_NOMEM, "LPVI: out of memory"); goto out; }
    memcpy(PC, P, 3 * m * sizeof *P);
    if (nc) memcpy(PC + 3 * m, cand, 3 * nc * sizeof *cand);
    st = mgs_topo_rips_persistence(P, m, c->max_edge, &before, err);
    if (!st) st = mgs_topo_rips_persistence(PC, m + nc, c->max_edge, &after, err);
    free(PC);
    if (st) goto out;
    int nomem = 0;
    r->w1 = w1_merged(&before, &after, &nomem);
    if (nomem) { st = mgs_error_set(err, MGS_ERR_NOMEM, "LPVI: out of memory"); goto out; }
  }
  if (!flat && r->w1 < c->tau) {
    r->n_visit = m;
    memcpy(r->visit, nb, m * sizeof *nb);
  } else {
    /* 2-D branch: PCA plane of the point and its first k_min - 1 neighbours */
    free(cand); cand = NULL; nc = 0;
    r->branch = 1;
    size_t q = (size_t)o->k_min < m ? (size_t)o->k_min : m;
    double qm[3], qw[3], QV[9], qr;
    pca(c->xyz, nb, q, qm, qw, QV, &qr);
    double e1[3] = {QV[2], QV[5], QV[8]}, e2[3] = {QV[1], QV[4], QV[7]};
    double uv[2 * 64];
    for (size_t k = 0; k < q; k++) {
      double d[3];
      for (int a = 0; a < 3; a++) d[a] = c->xyz[3 * nb[k] + a] - qm[a];
      uv[2 * k] = d[0] * e1[0] + d[1] * e1[1] + d[2] * e1[2];
      uv[2 * k + 1] = d[0] * e2[0] + d[1] * e2[1] + d[2] * e2[2];
    }
    double *c2 = NULL;
    size_t n2 = 0;
    if ((st = mgs_topo_voronoi_vertices(uv, q, 2, &c2, &n2, err))) goto out;
    cand = malloc((n2 ? n2 : 1) * 3 * sizeof *cand);
    if (!cand) { free(c2); st = mgs_error_set(err, MGS_ERR_NOMEM, "LPVI: out of memory"); goto out; }
    /* the authors lift from the point (coordinates are relative to the mean, so every
       lifted point is shifted by point − mean); corrected: from the mean, inside the disk */
    const double *origin = qm;
    double pt[3] = {c->xyz[3 * i], c->xyz[3 * i + 1], c->xyz[3 * i + 2]};
    if (o->faithful) origin = pt;
    for (size_t k = 0; k < n2; k++) {
      double u = c2[2 * k], v = c2[2 * k + 1];
      if (!o->faithful && u * u + v * v > qr * qr) continue;
      for (int a = 0; a < 3; a++) cand[3 * nc + a] = origin[a] + u * e1[a] + v * e2[a];
      nc++;
    }
    free(c2);
    r->n_visit = q;
    memcpy(r->visit, nb, q * sizeof *nb);
  }
  r->n_new = nc;
  r->xyz = cand;
  cand = NULL;
  r->rgb = malloc((nc ? nc : 1) * 3 * sizeof *r->rgb);
  if (!r->rgb) { st = mgs_error_set(err, MGS_ERR_NOMEM, "LPVI: out of memory"); goto out; }
  for (size_t k = 0; k < nc; k++) idw_colour(c, nb, r->branch ? r->n_visit : m, r->xyz + 3 * k, r->rgb + 3 * k);
out:
  free(P);
  free(cand);
  mgs_topo_bars_free(&before);
  mgs_topo_bars_free(&after);
  return st;
}

static void eval_range(void *ctx, size_t b, size_t e) {
  lpvi_ctx *c = ctx;
  for (size_t k = b; k < e; k++) {
    lpvi_result *r = &c->res[k];
    r->st = eval_point(c, c->batch[k], r);
  }
}

mgs_status mgs_init_lpvi(const float *xyz, const float *rgb, size_t n, const mgs_lpvi_options *o,
                         float **out_xyz, float **out_rgb, size_t *out_n, mgs_lpvi_stats *stats,
                         mgs_error *err) {
  double t0 = mgs_now();
  *out_xyz = NULL; *out_rgb = NULL; *out_n = 0;
  mgs_lpvi_stats sdummy;
  if (!stats) stats = &sdummy;
  memset(stats, 0, sizeof *stats);
  stats->input = n;
  if (o->k_max < 1 || o->k_max > 64 || o->k_min < 3 || o->k_min > o->k_max)
    return mgs_error_set(err, MGS_ERR_ARG, "LPVI: K_max %d / K_min %d (need 3 <= K_min <= K_max <= 64)", o->k_max, o->k_min);
  if (!(o->tau >= 0) || !(o->max_edge > 0))
    return mgs_error_set(err, MGS_ERR_ARG, "LPVI: tau %g and the edge cap %g must be >= 0 and > 0", o->tau, o->max_edge);
  for (size_t i = 0; i < 3 * n; i++)
    if (!isfinite(xyz[i])) return mgs_error_set(err, MGS_ERR_NUMERIC, "LPVI: initial point %zu is not finite", i / 3);
  lpvi_ctx c = {xyz, rgb, n, o, o->tau, o->max_edge, NULL, NULL, NULL};
  if (!o->faithful) {
    double s = (o->extent > 0 ? o->extent : MGS_LPVI_REF_EXTENT) / MGS_LPVI_REF_EXTENT;
    c.tau *= s;
    c.max_edge *= s;
  }
  size_t cap = n + 1024, total = 0;
  float *ox = NULL, *oc = NULL;
  uint8_t *visited = calloc(n ? n : 1, 1);
  mgs_kdtree *tree = n ? mgs_kdtree_build(xyz, n) : NULL;
  int threads = mgs_parallel_max_threads();
  size_t B = (size_t)(threads > 0 ? threads : 1) * 8;
  size_t *batch = malloc(B * sizeof *batch);
  lpvi_result *res = calloc(B, sizeof *res);
  ox = malloc(cap * 3 * sizeof *ox);
  oc = malloc(cap * 3 * sizeof *oc);
  mgs_status st = MGS_OK;
  if (!visited || (n && !tree) || !batch || !res || !ox || !oc) { st = mgs_error_set(err, MGS_ERR_NOMEM, "LPVI: out of memory (%zu points)", n); goto done; }
  c.tree = tree;
  c.batch = batch;
  c.res = res;
  if (!o->faithful) {
    memcpy(ox, xyz, 3 * n * sizeof *ox);
    for (size_t i = 0; i < 3 * n; i++) oc[i] = rgb ? rgb[i] : 0.5f;
    total = n;
  }
  size_t cursor = 0;
  while (cursor < n) {
    size_t nbatch = 0;
    while (cursor < n && nbatch < B) {
      if (!visited[cursor]) batch[nbatch++] = cursor;
      cursor++;
    }
    if (!nbatch) break;
    memset(res, 0, nbatch * sizeof *res);
    mgs_parallel_for(0, nbatch, 1, eval_range, &c);
    for (size_t k = 0; k < nbatch && !st; k++) {
      lpvi_result *r = &res[k];
      if (r->st) { st = r->st; if (err) *err = r->err; break; }
      if (visited[batch[k]]) { stats->discarded++; continue; } /* an earlier commit took it */
      stats->processed++;
      if (r->branch) stats->tangent_2d++; else stats->accepted_3d++;
      for (size_t v = 0; v < r->n_visit; v++) visited[r->visit[v]] = 1;
      if (total + r->n_new > cap) {
        size_t nc2 = (total + r->n_new) * 2;
        float *nx = realloc(ox, nc2 * 3 * sizeof *nx);
        if (nx) ox = nx;
        float *ncol = nx ? realloc(oc, nc2 * 3 * sizeof *ncol) : NULL;
        if (ncol) oc = ncol;
        if (!nx || !ncol) { st = mgs_error_set(err, MGS_ERR_NOMEM, "LPVI: out of memory (%zu points)", total); break; }
        cap = nc2;
      }
      for (size_t q = 0; q < 3 * r->n_new; q++) { ox[3 * total + q] = (float)r->xyz[q]; oc[3 * total + q] = r->rgb[q]; }
      total += r->n_new;
      stats->added += r->n_new;
    }
    for (size_t k = 0; k < nbatch; k++) { free(res[k].xyz); free(res[k].rgb); res[k].xyz = NULL; res[k].rgb = NULL; }
    if (st) break;
  }
  if (!st && total == 0)
    st = mgs_error_set(err, MGS_ERR_NUMERIC, "LPVI: no points out of %zu input points (the faithful mode returns only the new ones)", n);
done:
  free(visited); free(batch); free(res);
  mgs_kdtree_destroy(tree);
  stats->seconds = mgs_now() - t0;
  if (st) { free(ox); free(oc); return st; }
  *out_xyz = ox; *out_rgb = oc; *out_n = total;
  return MGS_OK;
}

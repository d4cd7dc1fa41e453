/* SuGaR's mesh (train/mgs_sugar.h), after sugar_extractors/coarse_mesh.py and
 * compute_level_surface_points_from_camera_fast:
 *  1. Gaussians with α < prune_alpha left out;
 *  2. per training view, the rendered median depth (where T crosses 0.5: this project's
 *     stand-in for the authors' depth of the first splatted triangle) gives a point on
 *     each pixel's ray; along the ray, `range_points` samples within ± range_sigmas σ
 *     (σ: the standard deviation along the ray of the Gaussian nearest to the point) of
 *     the density (factor 1, over the 16 Gaussians nearest to the point); the first
 *     crossing of `level` from below (linear interpolation) is a surface point, −∇d/|∇d|
 *     its normal;
 *  3. Poisson reconstruction of all points (train/mgs_poisson.h, CGAL);
 *  4. trimming: the authors remove the vertices of the lowest 10 % of Open3D's Poisson
 *     density (how many input points support a vertex). CGAL gives no such density; its
 *     proxy here is the distance from a vertex to its 8th nearest input point (low support
 *     = far): vertices in the top `trim_quantile` of that distance go, with their faces;
 *  5. decimation to max_triangles (Garland–Heckbert, as Open3D's).
 * Not done: the authors' statistical outlier removal (20 neighbours, 20 σ: it removes
 * almost nothing) and their foreground/background split of unbounded scenes (objects
 * only here). */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "train/mgs_sugar.h"
#include "train/mgs_poisson.h"
#include "train/mgs_lpvi.h"
#include "train/gauss_local.h"
#include "render/mgs_raster.h"
#include "render/mgs_render_maps.h"
#include "core/mgs_parallel.h"
#include "core/mgs_rng.h"
#include "core/mgs_log.h"

void mgs_sugar_mesh_options_default(mgs_sugar_mesh_options *o) {
  o->level = 0.3;
  o->points_per_view = 0;
  o->range_points = 21;
  o->range_sigmas = 3.0;
  o->prune_alpha = 0.5;
  o->trim_quantile = 0.1;
  o->max_triangles = 200000;
  o->seed = 0;
}

typedef struct ray_job {
  const mgs_gaussians *g;
  const mgs_sugar_mesh_options *o;
  const double *p, *dir; /* m points on the rays (local) and unit ray directions */
  const uint32_t *nb;    /* m * 16 */
  int k;
  double *out_p, *out_n;
  uint8_t *ok;
} ray_job;

static void ray_range(void *ctx, size_t b, size_t e) {
  ray_job *j = ctx;
  int np = j->o->range_points;
  for (size_t i = b; i < e; i++) {
    j->ok[i] = 0;
    const double *p = j->p + 3 * i, *d = j->dir + 3 * i;
    const uint32_t *nb = j->nb + i * (size_t)j->k;
    mgs_gauss_local L;
    mgs_gauss_local_get(j->g, nb[0], &L);
    double sig = 0;
    for (int a = 0; a < 3; a++) {
      double y = L.R[a] * d[0] + L.R[3 + a] * d[1] + L.R[6 + a] * d[2];
      sig += L.s2[a] * y * y;
    }
    sig = sqrt(sig);
    double prev = 0, tprev = 0;
    for (int s = 0; s < np; s++) {
      double t = j->o->range_sigmas * sig * (2.0 * s / (np - 1) - 1);
      double x[3] = {p[0] + t * d[0], p[1] + t * d[1], p[2] + t * d[2]};
      mgs_sugar_value v;
      mgs_sugar_field(j->g, x, nb, j->k, 1.0, &v);
      double dens = v.density < 1 ? v.density : 1; /* the authors' normalization above 1 */
      if (s == 0) {
        if (!(dens < j->o->level)) break; /* starts inside: no crossing seen from outside */
      } else if (dens > j->o->level) {
        double tc = tprev + (j->o->level - prev) / (dens - prev) * (t - tprev);
        double c[3] = {p[0] + tc * d[0], p[1] + tc * d[1], p[2] + tc * d[2]};
        mgs_sugar_field(j->g, c, nb, j->k, 1.0, &v);
        double gn = sqrt(v.grad[0] * v.grad[0] + v.grad[1] * v.grad[1] + v.grad[2] * v.grad[2]);
        if (!(gn > 0) || !isfinite(gn)) break;
        for (int a = 0; a < 3; a++) {
          j->out_p[3 * i + a] = c[a];
          j->out_n[3 * i + a] = -v.grad[a] / gn;
        }
        j->ok[i] = 1;
        break;
      }
      prev = dens;
      tprev = t;
    }
  }
}

static mgs_status grow(void **p, size_t *cap, size_t need, size_t elem, mgs_error *err) {
  if (need <= *cap) return MGS_OK;
  size_t c = *cap ? *cap : 1024;
  while (c < need) c *= 2;
  void *q = realloc(*p, c * elem);
  if (!q) return mgs_error_set(err, MGS_ERR_NOMEM, "sugar mesh: out of memory");
  *p = q;
  *cap = c;
  return MGS_OK;
}

mgs_status mgs_sugar_level_points(const mgs_gaussians *g0, const mgs_camera *views, size_t n_views,
                                  const mgs_sugar_mesh_options *o, double **points, double **normals, size_t *n,
                                  mgs_error *err) {
  *points = *normals = NULL;
  *n = 0;
  if (o->range_points < 2) return mgs_error_set(err, MGS_ERR_ARG, "sugar mesh: at least 2 samples per ray (got %d)", o->range_points);
  /* 1. the Gaussians kept */
  size_t *keep = malloc((g0->n ? g0->n : 1) * sizeof *keep), nk = 0;
  if (!keep) return mgs_error_set(err, MGS_ERR_NOMEM, "sugar mesh: out of memory");
  for (size_t i = 0; i < g0->n; i++)
    if (mgs_gaussian_alpha(g0, i) >= o->prune_alpha) keep[nk++] = i;
  if (nk < 1) {
    free(keep);
    return mgs_error_set(err, MGS_ERR_NUMERIC, "sugar mesh: no Gaussian has alpha >= %g (of %zu)", o->prune_alpha, g0->n);
  }
  mgs_gaussians *g = mgs_gaussians_select(g0, keep, nk);
  free(keep);
  if (!g) return mgs_error_set(err, MGS_ERR_NOMEM, "sugar mesh: out of memory");
  int k = nk < MGS_SUGAR_KNN ? (int)nk : MGS_SUGAR_KNN;
  mgs_raster *r = mgs_raster_create();
  mgs_raster_settings rs;
  mgs_raster_settings_default(&rs);
  rs.sh_degree = 0;
  mgs_rng rng;
  mgs_rng_init(&rng, o->seed, 77);
  double *P = NULL, *Dir = NULL, *OP = NULL, *ON = NULL, *allp = NULL, *alln = NULL;
  uint32_t *NB = NULL;
  uint8_t *OK = NULL;
  size_t cap_px = 0, cap_nb = 0, cap_ok = 0, cap_op = 0, cap_on = 0, cap_all = 0, cap_alln = 0, cap_dir = 0;
  size_t total = 0;
  mgs_status st = r ? MGS_OK : mgs_error_set(err, MGS_ERR_NOMEM, "sugar mesh: out of memory");
  for (size_t vi = 0; vi < n_views && st == MGS_OK; vi++) {
    const mgs_camera *cam = views + vi;
    mgs_raster_output ro;
    mgs_render_maps maps;
    if ((st = mgs_raster_forward(r, g, cam, &rs, &ro, err)) || (st = mgs_raster_maps(r, MGS_MAP_DEPTH_MEDIAN, &maps, err)))
      break;
    size_t npx = (size_t)maps.width * (size_t)maps.height, m = 0;
    double fwd[3] = {cam->c2w[2], cam->c2w[6], cam->c2w[10]}; /* the optical axis in world */
    for (size_t px = 0; px < npx; px++) m += maps.depth_median[px] > 0;
    size_t want = o->points_per_view > 0 && (size_t)o->points_per_view < m ? (size_t)o->points_per_view : m;
    if (!want) continue;
    if ((st = grow((void **)&P, &cap_px, 3 * want, sizeof *P, err)) || (st = grow((void **)&Dir, &cap_dir, 3 * want, sizeof *Dir, err)) ||
        (st = grow((void **)&NB, &cap_nb, want * (size_t)k, sizeof *NB, err)) || (st = grow((void **)&OK, &cap_ok, want, 1, err)) ||
        (st = grow((void **)&OP, &cap_op, 3 * want, sizeof *OP, err)) || (st = grow((void **)&ON, &cap_on, 3 * want, sizeof *ON, err)))
      break;
    /* the pixels: all with a depth, or `want` of them chosen uniformly (selection sampling) */
    size_t got = 0, seen = 0;
    for (size_t px = 0; px < npx && got < want; px++) {
      float z = maps.depth_median[px];
      if (!(z > 0)) continue;
      size_t left = m - seen++;
      if (want < m && mgs_rng_uniform(&rng) * (double)left >= (double)(want - got)) continue;
      double u = (double)(px % (size_t)maps.width) + 0.5, v = (double)(px / (size_t)maps.width) + 0.5, org[3], dir[3];
      mgs_camera_ray(cam, u, v, org, dir);
      double c = dir[0] * fwd[0] + dir[1] * fwd[1] + dir[2] * fwd[2];
      if (!(c > 1e-9)) continue;
      double t = z / c;
      for (int a = 0; a < 3; a++) {
        P[3 * got + a] = org[a] + t * dir[a];
        Dir[3 * got + a] = dir[a];
      }
      got++;
    }
    if ((st = mgs_sugar_knn_points(g, P, got, k, NB, err))) break;
    ray_job j = {g, o, P, Dir, NB, k, OP, ON, OK};
    mgs_parallel_for(0, got, 64, ray_range, &j);
    size_t add = 0;
    for (size_t i = 0; i < got; i++) add += OK[i];
    if ((st = grow((void **)&allp, &cap_all, 3 * (total + add), sizeof *allp, err)) ||
        (st = grow((void **)&alln, &cap_alln, 3 * (total + add), sizeof *alln, err)))
      break;
    for (size_t i = 0; i < got; i++) {
      if (!OK[i]) continue;
      memcpy(allp + 3 * total, OP + 3 * i, 3 * sizeof *allp);
      memcpy(alln + 3 * total, ON + 3 * i, 3 * sizeof *alln);
      total++;
    }
  }
  mgs_raster_destroy(r);
  mgs_gaussians_destroy(g);
  free(P); free(Dir); free(NB); free(OK); free(OP); free(ON);
  if (st) {
    free(allp);
    free(alln);
    return st;
  }
  *points = allp;
  *normals = alln;
  *n = total;
  return MGS_OK;
}

static int cmp_double(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return (x > y) - (x < y);
}

/* Step 4: vertices far from the input points (low support) removed with their faces. */
static mgs_status trim(mgs_mesh *m, const double *pts, size_t np, double q, size_t *removed, mgs_error *err) {
  *removed = 0;
  if (!(q > 0) || !m->nv) return MGS_OK;
  float *fp = malloc(3 * np * sizeof *fp);
  double *dist = malloc(m->nv * sizeof *dist), *sorted = malloc(m->nv * sizeof *sorted);
  uint32_t *map = malloc(m->nv * sizeof *map);
  if (!fp || !dist || !sorted || !map) {
    free(fp); free(dist); free(sorted); free(map);
    return mgs_error_set(err, MGS_ERR_NOMEM, "sugar mesh: out of memory trimming");
  }
  for (size_t i = 0; i < 3 * np; i++) fp[i] = (float)pts[i];
  mgs_kdtree *t = mgs_kdtree_build(fp, np);
  if (!t) {
    free(fp); free(dist); free(sorted); free(map);
    return mgs_error_set(err, MGS_ERR_NOMEM, "sugar mesh: out of memory trimming");
  }
  for (size_t v = 0; v < m->nv; v++) {
    double x[3] = {m->v[3 * v], m->v[3 * v + 1], m->v[3 * v + 2]}, d2[8];
    size_t id[8];
    size_t got = mgs_kdtree_knn(t, x, 8, id, d2);
    dist[v] = got ? sqrt(d2[got - 1]) : 0;
    sorted[v] = dist[v];
  }
  mgs_kdtree_destroy(t);
  free(fp);
  /* the (1 − q) quantile of the distance (nth element by a full sort: meshes are small) */
  qsort(sorted, m->nv, sizeof *sorted, cmp_double);
  size_t at = (size_t)floor((1 - q) * (double)(m->nv - 1));
  double cut = sorted[at];
  size_t nv = 0;
  for (size_t v = 0; v < m->nv; v++) {
    if (dist[v] > cut) { map[v] = UINT32_MAX; continue; }
    map[v] = (uint32_t)nv;
    memmove(m->v + 3 * nv, m->v + 3 * v, 3 * sizeof *m->v);
    nv++;
  }
  size_t nt = 0;
  for (size_t f = 0; f < m->nt; f++) {
    uint32_t a = map[m->t[3 * f]], b = map[m->t[3 * f + 1]], c = map[m->t[3 * f + 2]];
    if (a == UINT32_MAX || b == UINT32_MAX || c == UINT32_MAX) continue;
    m->t[3 * nt] = a; m->t[3 * nt + 1] = b; m->t[3 * nt + 2] = c;
    nt++;
  }
  *removed = m->nv - nv;
  m->nv = nv;
  m->nt = nt;
  free(dist); free(sorted); free(map);
  return MGS_OK;
}

mgs_status mgs_sugar_mesh(const mgs_gaussians *g, const mgs_camera *views, size_t n_views,
                          const mgs_sugar_mesh_options *o, mgs_mesh **out, mgs_sugar_mesh_stats *stats,
                          mgs_error *err) {
  *out = NULL;
  mgs_sugar_mesh_stats s;
  memset(&s, 0, sizeof s);
  double *p, *nrm;
  size_t np;
  mgs_status st = mgs_sugar_level_points(g, views, n_views, o, &p, &nrm, &np, err);
  if (st) return st;
  s.points = np;
  mgs_poisson_options po;
  mgs_poisson_options_default(&po);
  mgs_mesh *m = NULL;
  st = mgs_poisson_reconstruct(p, nrm, np, &po, &m, err);
  if (st == MGS_OK) {
    s.poisson_vertices = m->nv;
    s.poisson_triangles = m->nt;
    st = trim(m, p, np, o->trim_quantile, &s.trimmed_vertices, err);
  }
  free(p);
  free(nrm);
  int dec = 0;
  if (st == MGS_OK && o->max_triangles) st = mgs_mesh_decimate(&m, o->max_triangles, &dec, err);
  if (st == MGS_OK && !m->nt) st = mgs_error_set(err, MGS_ERR_NUMERIC, "sugar mesh: no triangle left after trimming");
  if (st) {
    mgs_mesh_destroy(m);
    return st;
  }
  if (o->max_triangles && m->nt > o->max_triangles && !dec)
    mgs_warn("sugar mesh: not decimated (%zu triangles; the trimmed mesh is not a 2-manifold CGAL can collapse)", m->nt);
  mgs_mesh_translate(m, g->origin, 1);
  s.triangles = m->nt;
  if (stats) *stats = s;
  *out = m;
  return MGS_OK;
}

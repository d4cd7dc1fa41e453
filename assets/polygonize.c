/* Marching tetrahedra over a regular grid. Each cube is split into the six Kuhn
 * tetrahedra (all sharing the main diagonal); this split is the same in every cube, so
 * neighbouring cubes agree on every shared edge and face, and one vertex per sign-
 * changing grid edge (welded through a hash on the edge) makes the surface a closed
 * 2-manifold without the ambiguous cases of marching cubes. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "assets/assets_internal.h"
#include "core/mgs_parallel.h"

static const int kuhn[6][4] = {{0, 1, 3, 7}, {0, 1, 5, 7}, {0, 2, 3, 7}, {0, 2, 6, 7}, {0, 4, 5, 7}, {0, 4, 6, 7}};

typedef struct {
  uint64_t *keys; /* key + 1; 0 = empty */
  uint32_t *vals;
  size_t cap, count;
} edge_map;

static uint64_t mix64(uint64_t x) {
  x ^= x >> 33; x *= 0xff51afd7ed558ccdULL; x ^= x >> 33; x *= 0xc4ceb9fe1a85ec53ULL; x ^= x >> 33;
  return x;
}

static int map_init(edge_map *m, size_t cap) {
  m->cap = cap; m->count = 0;
  m->keys = calloc(cap, sizeof *m->keys);
  m->vals = malloc(cap * sizeof *m->vals);
  return m->keys && m->vals;
}

static void map_free(edge_map *m) { free(m->keys); free(m->vals); memset(m, 0, sizeof *m); }

/* Returns the slot of key (found or empty). */
static size_t map_slot(const edge_map *m, uint64_t key) {
  size_t i = (size_t)mix64(key) & (m->cap - 1);
  while (m->keys[i] && m->keys[i] != key + 1) i = (i + 1) & (m->cap - 1);
  return i;
}

static int map_grow(edge_map *m) {
  edge_map n;
  if (!map_init(&n, m->cap * 2)) { map_free(&n); return 0; }
  for (size_t i = 0; i < m->cap; i++)
    if (m->keys[i]) {
      size_t s = map_slot(&n, m->keys[i] - 1);
      n.keys[s] = m->keys[i];
      n.vals[s] = m->vals[i];
    }
  n.count = m->count;
  map_free(m);
  *m = n;
  return 1;
}

typedef struct {
  mgs_implicit_fn f;
  const void *ctx;
  const double *lo, *h;
  const int *n;
  double *val;
} eval_job;

static void eval_slices(void *vctx, size_t k0, size_t k1) {
  const eval_job *J = vctx;
  size_t sx = (size_t)J->n[0] + 1, sy = (size_t)J->n[1] + 1;
  for (size_t k = k0; k < k1; k++)
    for (size_t j = 0; j < sy; j++)
      for (size_t i = 0; i < sx; i++) {
        double p[3] = {J->lo[0] + J->h[0] * (double)i, J->lo[1] + J->h[1] * (double)j, J->lo[2] + J->h[2] * (double)k};
        double v = J->f(p, J->ctx);
        if (!(v == v)) v = 1.0; /* NaN counts as outside */
        int border = i == 0 || j == 0 || k == 0 || i == sx - 1 || j == sy - 1 || k == (size_t)J->n[2];
        if (border && v <= 0) v = 1e-9; /* closed at the grid's edge */
        if (v == 0) v = 1e-12;          /* no vertex on the surface: keeps it manifold */
        J->val[i + sx * (j + sy * k)] = v;
      }
}

mgs_status mgs_assets_polygonize(mgs_implicit_fn f, const void *ctx, const double lo[3], const double hi[3],
                                 const int n[3], const char *name, mgs_mesh **out, mgs_error *err) {
  *out = NULL;
  if (n[0] < 1 || n[1] < 1 || n[2] < 1 || n[0] > 2048 || n[1] > 2048 || n[2] > 2048)
    return mgs_error_set(err, MGS_ERR_ARG, "builtin %s: grid %dx%dx%d out of range", name, n[0], n[1], n[2]);
  double h[3];
  for (int a = 0; a < 3; a++) h[a] = (hi[a] - lo[a]) / n[a];
  size_t sx = (size_t)n[0] + 1, sy = (size_t)n[1] + 1, sz = (size_t)n[2] + 1;
  double *val = malloc(sx * sy * sz * sizeof(double));
  edge_map map = {0};
  mgs_mesh_builder b = {0};
  if (!val || !map_init(&map, 1u << 16)) {
    free(val); map_free(&map);
    return mgs_error_set(err, MGS_ERR_NOMEM, "builtin %s: out of memory for the grid", name);
  }
  eval_job job = {f, ctx, lo, h, n, val};
  mgs_parallel_for(0, sz, 1, eval_slices, &job);

  for (size_t k = 0; k + 1 < sz && !b.failed; k++)
    for (size_t j = 0; j + 1 < sy; j++)
      for (size_t i = 0; i + 1 < sx; i++) {
        size_t gidx[8];
        double cv[8];
        int any_in = 0, any_out = 0;
        for (int c = 0; c < 8; c++) {
          gidx[c] = (i + (c & 1)) + sx * ((j + ((c >> 1) & 1)) + sy * (k + ((c >> 2) & 1)));
          cv[c] = val[gidx[c]];
          if (cv[c] < 0) any_in = 1; else any_out = 1;
        }
        if (!any_in || !any_out) continue;
        for (int t = 0; t < 6; t++) {
          const int *tc = kuhn[t];
          int in[4], nin = 0, outv[4], nout = 0;
          for (int q = 0; q < 4; q++) { if (cv[tc[q]] < 0) in[nin++] = q; else outv[nout++] = q; }
          if (nin == 0 || nin == 4) continue;
          /* The surface polygon's edges (pairs of tet-local vertices), in cycle order. */
          int edges[4][2], ne;
          if (nin == 1 || nin == 3) {
            int lone = nin == 1 ? in[0] : outv[0];
            int *others = nin == 1 ? outv : in;
            for (int q = 0; q < 3; q++) { edges[q][0] = lone; edges[q][1] = others[q]; }
            ne = 3;
          } else {
            int a = in[0], bb = in[1], c = outv[0], d = outv[1];
            edges[0][0] = a; edges[0][1] = c;
            edges[1][0] = a; edges[1][1] = d;
            edges[2][0] = bb; edges[2][1] = d;
            edges[3][0] = bb; edges[3][1] = c;
            ne = 4;
          }
          uint32_t vid[4];
          double mid[4][3];
          for (int e = 0; e < ne; e++) {
            int ca = tc[edges[e][0]], cb = tc[edges[e][1]];
            if ((ca & cb) != ca) { int tmp = ca; ca = cb; cb = tmp; } /* ca is the lower corner */
            double pa[3] = {lo[0] + h[0] * (double)(i + (ca & 1)), lo[1] + h[1] * (double)(j + ((ca >> 1) & 1)), lo[2] + h[2] * (double)(k + ((ca >> 2) & 1))};
            double pb[3] = {lo[0] + h[0] * (double)(i + (cb & 1)), lo[1] + h[1] * (double)(j + ((cb >> 1) & 1)), lo[2] + h[2] * (double)(k + ((cb >> 2) & 1))};
            for (int a = 0; a < 3; a++) mid[e][a] = 0.5 * (pa[a] + pb[a]);
            uint64_t key = (uint64_t)gidx[ca] * 8u + (uint64_t)(ca ^ cb);
            size_t s = map_slot(&map, key);
            if (!map.keys[s]) {
              double va = cv[ca], vb = cv[cb];
              double tt = va / (va - vb);
              tt = tt < 1e-3 ? 1e-3 : (tt > 1 - 1e-3 ? 1 - 1e-3 : tt);
              map.keys[s] = key + 1;
              map.vals[s] = mgs_mb_vertex(&b, pa[0] + tt * (pb[0] - pa[0]), pa[1] + tt * (pb[1] - pa[1]), pa[2] + tt * (pb[2] - pa[2]));
              if (++map.count * 2 > map.cap && !map_grow(&map)) b.failed = 1;
              vid[e] = map.vals[map_slot(&map, key)];
            } else {
              vid[e] = map.vals[s];
            }
          }
          /* Orientation from grid geometry only (edge midpoints never degenerate):
             the normal must point from the inside corners to the outside ones. */
          double dir[3] = {0, 0, 0};
          for (int q = 0; q < 4; q++) {
            int c = tc[q];
            double w = cv[c] < 0 ? -1.0 / nin : 1.0 / (4 - nin);
            dir[0] += w * (c & 1); dir[1] += w * ((c >> 1) & 1); dir[2] += w * ((c >> 2) & 1);
          }
          for (int tri = 0; tri < ne - 2; tri++) {
            int a = 0, bb = tri + 1, c = tri + 2;
            double e1[3], e2[3], nn[3];
            for (int q = 0; q < 3; q++) { e1[q] = (mid[bb][q] - mid[a][q]) / h[q]; e2[q] = (mid[c][q] - mid[a][q]) / h[q]; }
            nn[0] = e1[1] * e2[2] - e1[2] * e2[1];
            nn[1] = e1[2] * e2[0] - e1[0] * e2[2];
            nn[2] = e1[0] * e2[1] - e1[1] * e2[0];
            if (nn[0] * dir[0] + nn[1] * dir[1] + nn[2] * dir[2] >= 0) mgs_mb_triangle(&b, vid[a], vid[bb], vid[c]);
            else mgs_mb_triangle(&b, vid[a], vid[c], vid[bb]);
          }
        }
      }
  free(val);
  map_free(&map);
  return mgs_mb_finish(&b, name, out, err);
}

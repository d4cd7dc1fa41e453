/* Level-set initialization (train/mgs_init_levelset.h). */
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include "core/mgs_core.h"
#include "core/mgs_math.h"
#include "core/mgs_parallel.h"
#include "render/mgs_mesh_distance.h"
#include "train/mgs_init_levelset.h"
#include "train/mgs_train.h"
#include "vdb/mgs_vdb.h"

void mgs_levelset_options_default(mgs_levelset_options *o) {
  o->count = 0;
  o->resolution = 128;
  o->knn = 32;
  o->levels = 1;
  o->delta = 1.0;
  o->flatness = 0.1;
  o->opacity = 0.1;
  o->seed = 0;
}

/* ---------------------------------------------------------------- k nearest neighbours */
/* Points hashed into cubic cells (sorted keys); a query grows shells of cells until the
 * k-th distance is closer than the next shell. */
typedef struct knn_grid {
  const float *xyz;
  size_t n;
  double lo[3], cell;
  int64_t dims[3];
  uint64_t *keys;
  uint32_t *ids;
} knn_grid;

typedef struct kp { uint64_t key; uint32_t id; } kp;
static int cmp_kp(const void *a, const void *b) {
  const kp *x = a, *y = b;
  if (x->key != y->key) return x->key < y->key ? -1 : 1;
  return x->id < y->id ? -1 : (x->id > y->id);
}
static uint64_t kkey(int64_t x, int64_t y, int64_t z) { return ((uint64_t)x << 42) | ((uint64_t)y << 21) | (uint64_t)z; }

static mgs_status knn_build(knn_grid *k, const float *xyz, size_t n, double cell, mgs_error *err) {
  memset(k, 0, sizeof *k);
  k->xyz = xyz;
  k->n = n;
  double hi[3];
  for (int a = 0; a < 3; a++) { k->lo[a] = DBL_MAX; hi[a] = -DBL_MAX; }
  for (size_t i = 0; i < n; i++)
    for (int a = 0; a < 3; a++) { k->lo[a] = fmin(k->lo[a], xyz[3 * i + a]); hi[a] = fmax(hi[a], xyz[3 * i + a]); }
  for (int a = 0; a < 3; a++) cell = fmax(cell, (hi[a] - k->lo[a]) / 1000000.0);
  if (!(cell > 0)) cell = 1;
  k->cell = cell;
  for (int a = 0; a < 3; a++) k->dims[a] = (int64_t)floor((hi[a] - k->lo[a]) / cell) + 1;
  kp *p = malloc(sizeof(kp) * (n ? n : 1));
  k->keys = malloc(sizeof(uint64_t) * (n ? n : 1));
  k->ids = malloc(sizeof(uint32_t) * (n ? n : 1));
  if (!p || !k->keys || !k->ids) {
    free(p);
    return mgs_error_set(err, MGS_ERR_NOMEM, "level-set init: out of memory for %zu points", n);
  }
  for (size_t i = 0; i < n; i++) {
    int64_t c[3];
    for (int a = 0; a < 3; a++) c[a] = (int64_t)floor((xyz[3 * i + a] - k->lo[a]) / cell);
    p[i] = (kp){kkey(c[0], c[1], c[2]), (uint32_t)i};
  }
  qsort(p, n, sizeof *p, cmp_kp);
  for (size_t i = 0; i < n; i++) { k->keys[i] = p[i].key; k->ids[i] = p[i].id; }
  free(p);
  return MGS_OK;
}
static void knn_free(knn_grid *k) { free(k->keys); free(k->ids); }

/* Up to K nearest points to x (excluding `self` if >= 0), sorted by distance; returns count. */
static int knn_query(const knn_grid *k, const double x[3], long self, int K, uint32_t *idx, double *d2) {
  int cnt = 0;
  int64_t c[3];
  for (int a = 0; a < 3; a++) c[a] = (int64_t)floor((x[a] - k->lo[a]) / k->cell);
  int64_t rmax = 0;
  for (int a = 0; a < 3; a++) {
    int64_t m = c[a] > k->dims[a] - 1 - c[a] ? c[a] : k->dims[a] - 1 - c[a];
    if (m < 0) m = -m;
    if (m > rmax) rmax = m;
  }
  rmax += 1;
  for (int64_t r = 0; r <= rmax; r++) {
    if (cnt == K && (double)(r - 1) * k->cell * (double)(r - 1) * k->cell >= d2[K - 1] && r > 0) break;
    for (int64_t dx = -r; dx <= r; dx++)
      for (int64_t dy = -r; dy <= r; dy++)
        for (int64_t dz = -r; dz <= r; dz++) {
          if (llabs(dx) != r && llabs(dy) != r && llabs(dz) != r) continue;
          int64_t q[3] = {c[0] + dx, c[1] + dy, c[2] + dz};
          if (q[0] < 0 || q[1] < 0 || q[2] < 0 || q[0] >= k->dims[0] || q[1] >= k->dims[1] || q[2] >= k->dims[2]) continue;
          uint64_t key = kkey(q[0], q[1], q[2]);
          size_t lo = 0, hi = k->n;
          while (lo < hi) { size_t m = lo + (hi - lo) / 2; if (k->keys[m] < key) lo = m + 1; else hi = m; }
          for (size_t j = lo; j < k->n && k->keys[j] == key; j++) {
            uint32_t id = k->ids[j];
            if ((long)id == self) continue;
            double e = 0;
            for (int a = 0; a < 3; a++) { double t = k->xyz[3 * id + a] - x[a]; e += t * t; }
            if (cnt == K && e >= d2[K - 1]) continue;
            int p = cnt < K ? cnt++ : K - 1;
            while (p > 0 && d2[p - 1] > e) { d2[p] = d2[p - 1]; idx[p] = idx[p - 1]; p--; }
            d2[p] = e;
            idx[p] = id;
          }
        }
  }
  return cnt;
}

/* ---------------------------------------------------------------- normals */
typedef struct normals_ctx {
  const knn_grid *kg;
  int K;
  float *normals;
  uint32_t *nbr; /* n*K neighbour lists (for the orientation's graph) */
  int *nnbr;
} normals_ctx;

static void normals_range(void *vctx, size_t b, size_t e) {
  normals_ctx *c = vctx;
  uint32_t idx[64];
  double d2[64];
  for (size_t i = b; i < e; i++) {
    double x[3] = {c->kg->xyz[3 * i], c->kg->xyz[3 * i + 1], c->kg->xyz[3 * i + 2]};
    int m = knn_query(c->kg, x, (long)i, c->K, idx, d2);
    c->nnbr[i] = m;
    memcpy(c->nbr + (size_t)c->K * i, idx, (size_t)m * sizeof(uint32_t));
    double mu[3] = {x[0], x[1], x[2]}, C[9] = {0};
    for (int j = 0; j < m; j++)
      for (int a = 0; a < 3; a++) mu[a] += c->kg->xyz[3 * idx[j] + a];
    for (int a = 0; a < 3; a++) mu[a] /= (double)(m + 1);
    for (int j = -1; j < m; j++) {
      const float *p = j < 0 ? c->kg->xyz + 3 * i : c->kg->xyz + 3 * idx[j];
      double d[3] = {p[0] - mu[0], p[1] - mu[1], p[2] - mu[2]};
      for (int a = 0; a < 3; a++)
        for (int bb = 0; bb < 3; bb++) C[3 * a + bb] += d[a] * d[bb];
    }
    double w[3], V[9];
    mgs_sym3_eigen(C, w, V);
    double nn[3] = {V[0], V[3], V[6]}, l = sqrt(nn[0] * nn[0] + nn[1] * nn[1] + nn[2] * nn[2]);
    if (!(l > 0)) { nn[0] = 0; nn[1] = 0; nn[2] = 1; l = 1; }
    for (int a = 0; a < 3; a++) c->normals[3 * i + a] = (float)(nn[a] / l);
  }
}

/* Binary min-heap of (cost, node, parent) for Prim's algorithm (lazy deletion). */
typedef struct hent { float cost; uint32_t node, parent; } hent;
typedef struct heap { hent *a; size_t n, cap; } heap;
static int heap_push(heap *h, hent e) {
  if (h->n == h->cap) {
    size_t cap = h->cap ? 2 * h->cap : 1024;
    hent *a = realloc(h->a, cap * sizeof *a);
    if (!a) return -1;
    h->a = a;
    h->cap = cap;
  }
  size_t i = h->n++;
  while (i > 0 && h->a[(i - 1) / 2].cost > e.cost) { h->a[i] = h->a[(i - 1) / 2]; i = (i - 1) / 2; }
  h->a[i] = e;
  return 0;
}
static hent heap_pop(heap *h) {
  hent top = h->a[0], last = h->a[--h->n];
  size_t i = 0;
  for (;;) {
    size_t c = 2 * i + 1;
    if (c >= h->n) break;
    if (c + 1 < h->n && h->a[c + 1].cost < h->a[c].cost) c++;
    if (h->a[c].cost >= last.cost) break;
    h->a[i] = h->a[c];
    i = c;
  }
  if (h->n) h->a[i] = last;
  return top;
}

mgs_status mgs_point_normals(const float *xyz, size_t n, int knn, float *normals, size_t *flipped, mgs_error *err) {
  if (n < 4) return mgs_error_set(err, MGS_ERR_ARG, "point normals: %zu points are too few", n);
  if (knn < 3 || knn > 64) return mgs_error_set(err, MGS_ERR_ARG, "point normals: k = %d outside [3, 64]", knn);
  if ((size_t)knn > n - 1) knn = (int)(n - 1);
  float *d2 = malloc(n * sizeof(float));
  if (!d2) return mgs_error_set(err, MGS_ERR_NOMEM, "point normals: out of memory");
  mgs_status st = mgs_knn3_mean_sq(xyz, n, d2, err);
  if (st) { free(d2); return st; }
  double ms = 0;
  for (size_t i = 0; i < n; i++) ms += d2[i];
  free(d2);
  double spacing = sqrt(ms / (double)n);
  knn_grid kg;
  if ((st = knn_build(&kg, xyz, n, 2 * spacing, err))) { knn_free(&kg); return st; }
  normals_ctx c = {&kg, knn, normals, malloc(sizeof(uint32_t) * n * (size_t)knn), malloc(sizeof(int) * n)};
  uint8_t *seen = calloc(n, 1);
  heap h = {0};
  if (!c.nbr || !c.nnbr || !seen) {
    free(c.nbr); free(c.nnbr); free(seen); knn_free(&kg);
    return mgs_error_set(err, MGS_ERR_NOMEM, "point normals: out of memory for %zu points", n);
  }
  mgs_parallel_for(0, n, 256, normals_range, &c);
  /* orientation: Prim's MST over the kNN graph, cost 1 − |nᵢ·nⱼ| */
  double ctr[3] = {0, 0, 0};
  for (size_t i = 0; i < n; i++)
    for (int a = 0; a < 3; a++) ctr[a] += xyz[3 * i + a] / (double)n;
  size_t nflip = 0, next = 0;
  /* first root: the point farthest from the centroid (its outward normal is unambiguous) */
  size_t far = 0;
  double fd = -1;
  for (size_t i = 0; i < n; i++) {
    double e = 0;
    for (int a = 0; a < 3; a++) e += (xyz[3 * i + a] - ctr[a]) * (xyz[3 * i + a] - ctr[a]);
    if (e > fd) { fd = e; far = i; }
  }
  size_t root = far;
  for (;;) {
    float *nr = normals + 3 * root;
    double s = 0;
    for (int a = 0; a < 3; a++) s += nr[a] * (xyz[3 * root + a] - ctr[a]);
    if (s < 0) { for (int a = 0; a < 3; a++) nr[a] = -nr[a]; nflip++; }
    seen[root] = 1;
    h.n = 0;
    for (int j = 0; j < c.nnbr[root]; j++) {
      uint32_t v = c.nbr[(size_t)knn * root + j];
      const float *nv = normals + 3 * v;
      float cost = 1.0f - fabsf(nr[0] * nv[0] + nr[1] * nv[1] + nr[2] * nv[2]);
      if (heap_push(&h, (hent){cost, v, (uint32_t)root})) { st = MGS_ERR_NOMEM; break; }
    }
    while (h.n && st == MGS_OK) {
      hent e = heap_pop(&h);
      if (seen[e.node]) continue;
      seen[e.node] = 1;
      float *nu = normals + 3 * e.node;
      const float *np = normals + 3 * e.parent;
      if (nu[0] * np[0] + nu[1] * np[1] + nu[2] * np[2] < 0) { for (int a = 0; a < 3; a++) nu[a] = -nu[a]; nflip++; }
      for (int j = 0; j < c.nnbr[e.node]; j++) {
        uint32_t v = c.nbr[(size_t)knn * e.node + j];
        if (seen[v]) continue;
        const float *nv = normals + 3 * v;
        float cost = 1.0f - fabsf(nu[0] * nv[0] + nu[1] * nv[1] + nu[2] * nv[2]);
        if (heap_push(&h, (hent){cost, v, e.node})) { st = MGS_ERR_NOMEM; break; }
      }
    }
    if (st) break;
    while (next < n && seen[next]) next++;
    if (next == n) break;
    root = next;
  }
  free(h.a);
  free(c.nbr);
  free(c.nnbr);
  free(seen);
  knn_free(&kg);
  if (st) return mgs_error_set(err, MGS_ERR_NOMEM, "point normals: out of memory");
  /* closed objects: outward */
  double vote = 0;
  for (size_t i = 0; i < n; i++) {
    double s = 0;
    for (int a = 0; a < 3; a++) s += normals[3 * i + a] * (xyz[3 * i + a] - ctr[a]);
    vote += s > 0 ? 1 : -1;
  }
  if (vote < 0) {
    for (size_t i = 0; i < 3 * n; i++) normals[i] = -normals[i];
    nflip = n - nflip;
  }
  if (flipped) *flipped = nflip;
  return MGS_OK;
}

/* ---------------------------------------------------------------- the field */
static double mesh_area(const mgs_mesh *m) {
  double A = 0;
  for (size_t t = 0; t < m->nt; t++) {
    const float *a = m->v + 3 * m->t[3 * t], *b = m->v + 3 * m->t[3 * t + 1], *c = m->v + 3 * m->t[3 * t + 2];
    double u[3], v[3];
    for (int k = 0; k < 3; k++) { u[k] = b[k] - a[k]; v[k] = c[k] - a[k]; }
    double x = u[1] * v[2] - u[2] * v[1], y = u[2] * v[0] - u[0] * v[2], z = u[0] * v[1] - u[1] * v[0];
    A += 0.5 * sqrt(x * x + y * y + z * z);
  }
  return A;
}

/* Dense smoothed-Hoppe distance in a padded box (coarse, so dense is small: ~r³/4
 * voxels), signs of unreached voxels by flood fill, then the sparse level set. */
static mgs_status build_field(const float *xyz, const float *nrm, size_t n, double h, double band, double sig_w,
                              mgs_vdb_grid **out, mgs_error *err) {
  double lo[3], hi[3];
  for (int a = 0; a < 3; a++) { lo[a] = DBL_MAX; hi[a] = -DBL_MAX; }
  for (size_t i = 0; i < n; i++)
    for (int a = 0; a < 3; a++) { lo[a] = fmin(lo[a], xyz[3 * i + a]); hi[a] = fmax(hi[a], xyz[3 * i + a]); }
  const double R = band + 2 * h; /* splat radius */
  int32_t dims[3];
  double org[3];
  size_t total = 1;
  for (int a = 0; a < 3; a++) {
    org[a] = h * floor((lo[a] - R - 2 * h) / h);
    double d = ceil((hi[a] + R + 2 * h - org[a]) / h) + 1;
    if (d > 4096) return mgs_error_set(err, MGS_ERR_ARG, "level-set init: grid of %.0f voxels along an axis; lower the resolution", d);
    dims[a] = (int32_t)d;
    total *= (size_t)dims[a];
  }
  if (total > ((size_t)1 << 28)) return mgs_error_set(err, MGS_ERR_NOMEM, "level-set init: %zu voxels are too many; lower the resolution", total);
  float *num = calloc(total, sizeof(float)), *den = calloc(total, sizeof(float));
  if (!num || !den) { free(num); free(den); return mgs_error_set(err, MGS_ERR_NOMEM, "level-set init: out of memory for %zu voxels", total); }
  const int rv = (int)ceil(R / h);
  const double inv2s = 1.0 / (2 * sig_w * sig_w);
  for (size_t i = 0; i < n; i++) {
    const float *p = xyz + 3 * i, *q = nrm + 3 * i;
    int c[3];
    for (int a = 0; a < 3; a++) c[a] = (int)floor((p[a] - org[a]) / h + 0.5);
    for (int x = c[0] - rv; x <= c[0] + rv; x++) {
      if (x < 0 || x >= dims[0]) continue;
      for (int y = c[1] - rv; y <= c[1] + rv; y++) {
        if (y < 0 || y >= dims[1]) continue;
        for (int z = c[2] - rv; z <= c[2] + rv; z++) {
          if (z < 0 || z >= dims[2]) continue;
          double d[3] = {org[0] + x * h - p[0], org[1] + y * h - p[1], org[2] + z * h - p[2]};
          double r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
          if (r2 > R * R) continue;
          double w = exp(-r2 * inv2s) + 1e-30; /* every point in range counts a little */
          size_t off = ((size_t)x * dims[1] + y) * dims[2] + z;
          num[off] += (float)(w * (q[0] * d[0] + q[1] * d[1] + q[2] * d[2]));
          den[off] += (float)w;
        }
      }
    }
  }
  /* flood fill of unreached voxels from the border: outside; the rest: inside */
  uint8_t *outside = calloc(total, 1);
  size_t *stack = malloc(sizeof(size_t) * total);
  if (!outside || !stack) {
    free(num); free(den); free(outside); free(stack);
    return mgs_error_set(err, MGS_ERR_NOMEM, "level-set init: out of memory for the flood fill");
  }
  size_t sp = 0;
  for (int x = 0; x < dims[0]; x++)
    for (int y = 0; y < dims[1]; y++)
      for (int z = 0; z < dims[2]; z++) {
        if (x && y && z && x < dims[0] - 1 && y < dims[1] - 1 && z < dims[2] - 1) continue;
        size_t off = ((size_t)x * dims[1] + y) * dims[2] + z;
        if (den[off] == 0 && !outside[off]) { outside[off] = 1; stack[sp++] = off; }
      }
  while (sp) {
    size_t off = stack[--sp];
    int z = (int)(off % (size_t)dims[2]), y = (int)((off / (size_t)dims[2]) % (size_t)dims[1]), x = (int)(off / ((size_t)dims[2] * dims[1]));
    const int nb[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    for (int k = 0; k < 6; k++) {
      int X = x + nb[k][0], Y = y + nb[k][1], Z = z + nb[k][2];
      if (X < 0 || Y < 0 || Z < 0 || X >= dims[0] || Y >= dims[1] || Z >= dims[2]) continue;
      size_t o2 = ((size_t)X * dims[1] + Y) * dims[2] + Z;
      if (den[o2] == 0 && !outside[o2]) { outside[o2] = 1; stack[sp++] = o2; }
    }
  }
  free(stack);
  const float W = (float)band;
  for (size_t off = 0; off < total; off++) {
    float v = den[off] > 0 ? num[off] / den[off] : (outside[off] ? W : -W);
    num[off] = v > W ? W : (v < -W ? -W : v);
  }
  free(den);
  free(outside);
  const int32_t o0[3] = {0, 0, 0};
  mgs_status st = mgs_vdb_grid_from_dense("levelset_init", MGS_VDB_CLASS_LEVEL_SET, h, org, W, o0, dims, num, out, err);
  free(num);
  return st;
}

/* ---------------------------------------------------------------- the initialization */
/* xyz finite (checked by mgs_init_levelset) */
static mgs_status init_levelset(const float *xyz, const float *rgb, size_t n, int sh_degree, const mgs_levelset_options *oin,
                                mgs_gaussians **out, mgs_levelset_info *info_out, mgs_error *err) {
  const double t0 = mgs_now();
  mgs_levelset_options o;
  if (oin) o = *oin; else mgs_levelset_options_default(&o);
  if (n < 16) return mgs_error_set(err, MGS_ERR_ARG, "--init levelset: needs at least 16 initial points (the dataset has %zu)", n);
  if (o.resolution < 8 || o.resolution > 2048)
    return mgs_error_set(err, MGS_ERR_ARG, "--init levelset: resolution %d outside [8, 2048]", o.resolution);
  if (o.levels < 0 || o.levels > 7) return mgs_error_set(err, MGS_ERR_ARG, "--init levelset: levels %d outside [0, 7]", o.levels);
  if (!(o.delta > 0) || o.delta > 16) return mgs_error_set(err, MGS_ERR_ARG, "--init levelset: delta %g voxels outside (0, 16]", o.delta);
  if (!(o.flatness > 0) || o.flatness > 1) return mgs_error_set(err, MGS_ERR_ARG, "--init levelset: flatness %g outside (0, 1]", o.flatness);
  if (!(o.opacity > 0) || !(o.opacity < 1)) return mgs_error_set(err, MGS_ERR_ARG, "--init levelset: opacity %g outside (0, 1)", o.opacity);
  mgs_levelset_info info;
  memset(&info, 0, sizeof info);
  double lo[3], hi[3];
  for (int a = 0; a < 3; a++) { lo[a] = DBL_MAX; hi[a] = -DBL_MAX; }
  for (size_t i = 0; i < n; i++)
    for (int a = 0; a < 3; a++) { lo[a] = fmin(lo[a], xyz[3 * i + a]); hi[a] = fmax(hi[a], xyz[3 * i + a]); }
  double diag = sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) + (hi[2] - lo[2]) * (hi[2] - lo[2]));
  if (!(diag > 0)) return mgs_error_set(err, MGS_ERR_ARG, "--init levelset: the initial points have zero extent");
  const double h = diag / o.resolution, delta = o.delta * h, band = (o.levels + 1) * delta + h;
  info.voxel_size = h;
  info.delta = delta;
  info.band = band;

  float *nrm = malloc(3 * n * sizeof(float)), *d2 = malloc(n * sizeof(float));
  if (!nrm || !d2) { free(nrm); free(d2); return mgs_error_set(err, MGS_ERR_NOMEM, "--init levelset: out of memory"); }
  mgs_status st = mgs_point_normals(xyz, n, o.knn, nrm, &info.flipped, err);
  if (st == MGS_OK) st = mgs_knn3_mean_sq(xyz, n, d2, err);
  double ms = 0;
  for (size_t i = 0; st == MGS_OK && i < n; i++) ms += d2[i];
  free(d2);
  const double spacing = sqrt(ms / (double)n);
  mgs_vdb_grid *grid = NULL;
  if (st == MGS_OK) st = build_field(xyz, nrm, n, h, band, fmax(1.5 * spacing, h), &grid, err);
  free(nrm);
  if (st) return st;

  /* level sets and their areas */
  const int nl = 2 * o.levels + 1;
  mgs_mesh *meshes[15] = {0};
  double area[15] = {0}, atot = 0;
  for (int l = 0; l < nl && st == MGS_OK; l++) {
    mgs_error e2;
    if (mgs_vdb_extract_mesh(grid, (l - o.levels) * delta, 0.0, &meshes[l], &e2) != MGS_OK) { meshes[l] = NULL; continue; }
    area[l] = mesh_area(meshes[l]);
    atot += area[l];
  }
  mgs_vdb_grid_destroy(grid);
  size_t count = o.count ? o.count : (n > 10000 ? n : 10000);
  float *pts = malloc(3 * count * sizeof(float)), *pn = malloc(3 * count * sizeof(float));
  if (!(atot > 0)) st = mgs_error_set(err, MGS_ERR_FORMAT, "--init levelset: the points' distance field has no surface (are the points on one plane or line?)");
  else if (!pts || !pn) st = mgs_error_set(err, MGS_ERR_NOMEM, "--init levelset: out of memory for %zu Gaussians", count);
  size_t placed = 0;
  for (int l = 0; l < nl && st == MGS_OK; l++) {
    size_t want = l == nl - 1 ? count - placed : (size_t)floor((double)count * area[l] / atot + 0.5);
    if (want > count - placed) want = count - placed;
    if (want && meshes[l] && area[l] > 0)
      st = mgs_mesh_sample_surface(meshes[l], want, o.seed * 31 + (uint64_t)l, pts + 3 * placed, pn + 3 * placed, err);
    else want = 0;
    if (l < 16) { info.area[l] = area[l]; info.per_level[l] = want; }
    placed += want;
  }
  for (int l = 0; l < nl; l++) mgs_mesh_destroy(meshes[l]);
  mgs_gaussians *g = NULL;
  float *gd2 = NULL;
  knn_grid kg;
  memset(&kg, 0, sizeof kg);
  if (st == MGS_OK) {
    g = mgs_gaussians_create(placed, sh_degree);
    gd2 = malloc((placed ? placed : 1) * sizeof(float));
    size_t first;
    if (!g || !gd2) st = mgs_error_set(err, MGS_ERR_NOMEM, "--init levelset: out of memory for %zu Gaussians", placed);
    else st = mgs_gaussians_append(g, placed, &first, err);
  }
  if (st == MGS_OK) st = mgs_knn3_mean_sq(pts, placed, gd2, err);
  if (st == MGS_OK) st = knn_build(&kg, xyz, n, 2 * spacing, err);
  if (st == MGS_OK) {
    const float op = mgs_logitf((float)o.opacity);
    for (size_t i = 0; i < placed; i++) {
      const float *p = pts + 3 * i, *q = pn + 3 * i;
      double nn[3] = {q[0], q[1], q[2]}, l = sqrt(nn[0] * nn[0] + nn[1] * nn[1] + nn[2] * nn[2]);
      if (!(l > 0)) { nn[0] = 0; nn[1] = 0; nn[2] = 1; l = 1; }
      for (int a = 0; a < 3; a++) nn[a] /= l;
      /* frame (t, b, n): local z = the level set's normal */
      double ax[3] = {fabs(nn[0]) < 0.9 ? 1.0 : 0.0, fabs(nn[0]) < 0.9 ? 0.0 : 1.0, 0.0}, t[3], b[3];
      t[0] = ax[1] * nn[2] - ax[2] * nn[1]; t[1] = ax[2] * nn[0] - ax[0] * nn[2]; t[2] = ax[0] * nn[1] - ax[1] * nn[0];
      double tl = sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]);
      for (int a = 0; a < 3; a++) t[a] /= tl;
      b[0] = nn[1] * t[2] - nn[2] * t[1]; b[1] = nn[2] * t[0] - nn[0] * t[2]; b[2] = nn[0] * t[1] - nn[1] * t[0];
      double R[9], qq[4];
      for (int a = 0; a < 3; a++) { R[3 * a] = t[a]; R[3 * a + 1] = b[a]; R[3 * a + 2] = nn[a]; }
      mgs_mat3_to_quatd(R, qq);
      float s = 0.5f * logf(gd2[i] > 1e-7f ? gd2[i] : 1e-7f);
      double x[3] = {p[0], p[1], p[2]}, dd;
      uint32_t near = 0;
      knn_query(&kg, x, -1, 1, &near, &dd);
      for (int a = 0; a < 3; a++) {
        g->mean[3 * i + a] = p[a];
        g->sh_dc[3 * i + a] = rgb ? (rgb[3 * near + a] - 0.5f) / MGS_SH_C0 : 0.0f;
      }
      g->log_scale[3 * i] = g->log_scale[3 * i + 1] = s;
      g->log_scale[3 * i + 2] = s + logf((float)o.flatness);
      for (int a = 0; a < 4; a++) g->rot[4 * i + a] = (float)qq[a];
      g->opacity[i] = op;
      memset(g->sh_rest + (size_t)MGS_SH_REST_MAX * i, 0, MGS_SH_REST_MAX * sizeof(float));
    }
  }
  knn_free(&kg);
  free(gd2);
  free(pts);
  free(pn);
  if (st) { mgs_gaussians_destroy(g); return st; }
  info.seconds = mgs_now() - t0;
  if (info_out) *info_out = info;
  *out = g;
  return MGS_OK;
}

/* Scale and field come from a box far outliers do not stretch (real SfM clouds hold
 * two-view points 10x the object's size away: the voxel was 9x too coarse); the points
 * outside it are left out. */
mgs_status mgs_init_levelset(const float *xyz, const float *rgb, size_t n, int sh_degree, const mgs_levelset_options *o,
                             mgs_gaussians **out, mgs_levelset_info *info_out, mgs_error *err) {
  *out = NULL;
  for (size_t i = 0; i < 3 * n; i++)
    if (!isfinite(xyz[i])) return mgs_error_set(err, MGS_ERR_NUMERIC, "--init levelset: initial point %zu is not finite", i / 3);
  double lo[3], hi[3];
  if (!mgs_points_bounds_robust(xyz, n, lo, hi)) return init_levelset(xyz, rgb, n, sh_degree, o, out, info_out, err);
  float *pin = malloc((3 * n + 3) * sizeof(float)), *cin = rgb ? malloc((3 * n + 3) * sizeof(float)) : NULL;
  if (!pin || (rgb && !cin)) { free(pin); free(cin); return mgs_error_set(err, MGS_ERR_NOMEM, "--init levelset: out of memory"); }
  size_t m = 0;
  for (size_t i = 0; i < n; i++) {
    if (!mgs_point_in_box(xyz + 3 * i, lo, hi)) continue;
    memcpy(pin + 3 * m, xyz + 3 * i, 3 * sizeof(float));
    if (cin) memcpy(cin + 3 * m, rgb + 3 * i, 3 * sizeof(float));
    m++;
  }
  mgs_levelset_info info;
  memset(&info, 0, sizeof info);
  mgs_status st = init_levelset(pin, cin, m, sh_degree, o, out, &info, err);
  info.outliers = n - m;
  if (st == MGS_OK && info_out) *info_out = info;
  free(pin);
  free(cin);
  return st;
}

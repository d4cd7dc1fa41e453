/* Spatial tiles of Gaussians and the per-view conservative tile test (see
 * render/mgs_visibility.h for the bound it rests on). Tiles are runs of the Gaussians
 * sorted by a packed 3 x 21-bit tile key; Gaussians with a non-finite mean or scale go
 * into one extra tile that every view keeps (the rasterizer culls them itself). */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "render/mgs_visibility.h"

#define KEY_BITS 21
#define KEY_HALF (1 << (KEY_BITS - 1))
#define KEY_ALWAYS UINT64_MAX

typedef struct vis_tile {
  float lo[3], hi[3];  /* box of the members' means */
  float smax;          /* largest exp(log_scale) of the members */
  uint32_t first, count;
  int always;          /* non-finite members: kept by every view */
} vis_tile;

struct mgs_visibility {
  double tile_size, tile_size_opt;
  int valid;
  size_t n;                 /* Gaussians binned */
  uint32_t *member;         /* n, grouped by tile */
  uint32_t *tile_of;        /* n: tile of each Gaussian */
  vis_tile *tile;
  size_t n_tiles, cap_tiles;
  size_t cap_n;
  uint64_t *keys;           /* scratch for the sort: key << 32 | index ... see rebin */
  uint64_t *mark;           /* bit per Gaussian of the last query */
  size_t cap_mark;
  uint32_t *list;           /* the last query's Gaussians, increasing */
  uint32_t *vis_tiles;      /* tiles of the last query */
  size_t n_vis_tiles;
  mgs_visibility_stats st;
};

mgs_visibility *mgs_visibility_create(double tile_size) {
  mgs_visibility *v = calloc(1, sizeof *v);
  if (!v) return NULL;
  v->tile_size_opt = tile_size > 0 && isfinite(tile_size) ? tile_size : 0;
  return v;
}

void mgs_visibility_destroy(mgs_visibility *v) {
  if (!v) return;
  free(v->member); free(v->tile_of); free(v->tile); free(v->keys); free(v->mark); free(v->list); free(v->vis_tiles);
  free(v);
}

void mgs_visibility_invalidate(mgs_visibility *v) { v->valid = 0; }

static float max_scale(const mgs_gaussians *g, size_t i) {
  const float *ls = g->log_scale + 3 * i;
  float m = ls[0] > ls[1] ? ls[0] : ls[1];
  m = m > ls[2] ? m : ls[2];
  return expf(m);
}

static int finite_gaussian(const mgs_gaussians *g, size_t i, float *s) {
  const float *p = g->mean + 3 * i;
  *s = max_scale(g, i);
  return isfinite(p[0]) && isfinite(p[1]) && isfinite(p[2]) && isfinite(*s);
}

static uint64_t tile_key(const float p[3], double inv) {
  uint64_t key = 0;
  for (int k = 0; k < 3; k++) {
    double c = floor((double)p[k] * inv);
    if (c < -KEY_HALF) c = -KEY_HALF; /* far out: clamped into the border tiles (bounds stay exact) */
    if (c > KEY_HALF - 1) c = KEY_HALF - 1;
    key = key << KEY_BITS | (uint64_t)((int64_t)c + KEY_HALF);
  }
  return key;
}

static int cmp_u64pair(const void *a, const void *b) {
  const uint64_t *x = a, *y = b;
  if (x[0] != y[0]) return x[0] < y[0] ? -1 : 1;
  return x[1] < y[1] ? -1 : (x[1] > y[1]);
}

static void tile_add(vis_tile *t, const float p[3], float s) {
  for (int k = 0; k < 3; k++) {
    if (p[k] < t->lo[k]) t->lo[k] = p[k];
    if (p[k] > t->hi[k]) t->hi[k] = p[k];
  }
  if (s > t->smax) t->smax = s;
}

mgs_status mgs_visibility_rebin(mgs_visibility *v, const mgs_gaussians *g, mgs_error *err) {
  size_t n = g->n;
  if (n > UINT32_MAX) return mgs_error_set(err, MGS_ERR_ARG, "visibility: %zu Gaussians exceed the 2^32 limit", n);
  if (n > v->cap_n || !v->member) {
    size_t cap = n > 16 ? n : 16;
    uint32_t *m = realloc(v->member, cap * sizeof *m), *to = m ? realloc(v->tile_of, cap * sizeof *to) : NULL;
    if (m) v->member = m;
    if (to) v->tile_of = to;
    uint64_t *k = to ? realloc(v->keys, 2 * cap * sizeof *k) : NULL;
    if (k) v->keys = k;
    if (!m || !to || !k) return mgs_error_set(err, MGS_ERR_NOMEM, "visibility: out of memory for %zu Gaussians", n);
    v->cap_n = cap;
  }
  /* the tile side, once: about 256 Gaussians a tile over the bounding box */
  if (v->tile_size <= 0) {
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    size_t nf = 0;
    for (size_t i = 0; i < n; i++) {
      float s;
      if (!finite_gaussian(g, i, &s)) continue;
      nf++;
      for (int k = 0; k < 3; k++) {
        double x = g->mean[3 * i + k];
        lo[k] = x < lo[k] ? x : lo[k];
        hi[k] = x > hi[k] ? x : hi[k];
      }
    }
    double ext = 0, vol = 1;
    for (int k = 0; k < 3; k++) if (nf && hi[k] - lo[k] > ext) ext = hi[k] - lo[k];
    for (int k = 0; k < 3; k++) vol *= nf ? fmax(hi[k] - lo[k], 1e-3 * ext) : 1.0;
    double ts = v->tile_size_opt > 0 ? v->tile_size_opt : (nf ? cbrt(vol * 256.0 / (double)nf) : 1.0);
    v->tile_size = ts > 1e-9 && isfinite(ts) ? ts : 1.0;
  }
  double inv = 1.0 / v->tile_size;
  for (size_t i = 0; i < n; i++) {
    float s;
    v->keys[2 * i] = finite_gaussian(g, i, &s) ? tile_key(g->mean + 3 * i, inv) : KEY_ALWAYS;
    v->keys[2 * i + 1] = i;
  }
  qsort(v->keys, n, 2 * sizeof(uint64_t), cmp_u64pair);
  v->n_tiles = 0;
  for (size_t j = 0; j < n; j++) {
    uint64_t key = v->keys[2 * j];
    uint32_t i = (uint32_t)v->keys[2 * j + 1];
    if (j == 0 || key != v->keys[2 * (j - 1)]) {
      if (v->n_tiles == v->cap_tiles) {
        size_t cap = v->cap_tiles ? 2 * v->cap_tiles : 256;
        vis_tile *t = realloc(v->tile, cap * sizeof *t);
        uint32_t *vt = t ? realloc(v->vis_tiles, cap * sizeof *vt) : NULL;
        if (t) v->tile = t;
        if (vt) v->vis_tiles = vt;
        if (!t || !vt) return mgs_error_set(err, MGS_ERR_NOMEM, "visibility: out of memory for %zu tiles", cap);
        v->cap_tiles = cap;
      }
      vis_tile *t = &v->tile[v->n_tiles++];
      for (int k = 0; k < 3; k++) { t->lo[k] = INFINITY; t->hi[k] = -INFINITY; }
      t->smax = 0;
      t->first = (uint32_t)j;
      t->count = 0;
      t->always = key == KEY_ALWAYS;
    }
    vis_tile *t = &v->tile[v->n_tiles - 1];
    t->count++;
    v->member[j] = i;
    v->tile_of[i] = (uint32_t)(v->n_tiles - 1);
    if (!t->always) tile_add(t, g->mean + 3 * i, max_scale(g, i));
  }
  if (n > v->cap_mark || !v->mark) {
    size_t cap = n > 64 ? n : 64;
    uint64_t *mk = realloc(v->mark, (cap + 63) / 64 * sizeof *mk);
    if (mk) v->mark = mk;
    uint32_t *li = mk ? realloc(v->list, cap * sizeof *li) : NULL;
    if (li) v->list = li;
    if (!mk || !li) return mgs_error_set(err, MGS_ERR_NOMEM, "visibility: out of memory for %zu Gaussians", n);
    v->cap_mark = cap;
  }
  v->n = n;
  v->n_vis_tiles = 0;
  v->valid = 1;
  v->st.rebins++;
  return MGS_OK;
}

void mgs_visibility_refit(mgs_visibility *v, const mgs_gaussians *g, const int *radii) {
  if (!v->valid || g->n != v->n) { v->valid = 0; return; }
  if (!radii) {
    for (size_t i = 0; i < v->n; i++) {
      vis_tile *t = &v->tile[v->tile_of[i]];
      float s;
      if (t->always) continue;
      if (!finite_gaussian(g, i, &s)) t->always = 1;
      else tile_add(t, g->mean + 3 * i, s);
    }
    return;
  }
  /* only members of the last query's tiles can have radii > 0 */
  for (size_t k = 0; k < v->n_vis_tiles; k++) {
    vis_tile *t = &v->tile[v->vis_tiles[k]];
    if (t->always) continue;
    for (uint32_t j = t->first; j < t->first + t->count; j++) {
      uint32_t i = v->member[j];
      if (radii[i] <= 0) continue;
      float s;
      if (!finite_gaussian(g, i, &s)) { t->always = 1; break; }
      tile_add(t, g->mean + 3 * i, s);
    }
  }
}

/* max over the box of a . p */
static double box_max(const double a[3], const float lo[3], const float hi[3]) {
  double m = 0;
  for (int k = 0; k < 3; k++) m += a[k] > 0 ? a[k] * hi[k] : a[k] * lo[k];
  return m;
}

mgs_status mgs_visibility_query(mgs_visibility *v, const mgs_gaussians *g, const mgs_camera *cam,
                                const mgs_raster_settings *s, const uint32_t **idx, size_t *n_idx,
                                mgs_error *err) {
  *idx = NULL;
  *n_idx = 0;
  if (!v->valid || v->n != g->n) {
    mgs_status st = mgs_visibility_rebin(v, g, err);
    if (st != MGS_OK) return st;
  }
  const double *V = cam->w2c;
  double fx = cam->fx, fy = cam->fy, cx = cam->cx, cy = cam->cy;
  /* the Jacobian clamp's x/z, y/z range (as the projection's) and the bound K */
  double hx = 0.5 * cam->width / fx, hy = 0.5 * cam->height / fy;
  double lx = fmax(fabs(-cx / fx - 0.3 * hx), fabs((cam->width - cx) / fx + 0.3 * hx));
  double ly = fmax(fabs(-cy / fy - 0.3 * hy), fabs((cam->height - cy) / fy + 0.3 * hy));
  double K = 1.01 * sqrt(fx * fx * (1 + lx * lx) + fy * fy * (1 + ly * ly)) * (double)s->scale_modifier;
  /* pixels beyond the image a rectangle may start at and still be binned: the radius'
     constant part, the tile padding of the image, rounding */
  double m = 3.0 * sqrt(2.0 * (double)s->dilation + 0.32) + 1.0 + 4.0;
  double wt = (double)MGS_TILE_SIZE * ((cam->width + MGS_TILE_SIZE - 1) / MGS_TILE_SIZE);
  double ht = (double)MGS_TILE_SIZE * ((cam->height + MGS_TILE_SIZE - 1) / MGS_TILE_SIZE);
  /* planes a . p + b + 3 K s >= 0 (world p); rows of V are the camera axes */
  double pl[4][4];
  double cxl = cx + m, cxr = wt + m - cx, cyt = cy + m, cyb = ht + m - cy;
  for (int k = 0; k < 3; k++) {
    pl[0][k] = fx * V[k] + cxl * V[8 + k];
    pl[1][k] = -fx * V[k] + cxr * V[8 + k];
    pl[2][k] = fy * V[4 + k] + cyt * V[8 + k];
    pl[3][k] = -fy * V[4 + k] + cyb * V[8 + k];
  }
  pl[0][3] = fx * V[3] + cxl * V[11];
  pl[1][3] = -fx * V[3] + cxr * V[11];
  pl[2][3] = fy * V[7] + cyt * V[11];
  pl[3][3] = -fy * V[7] + cyb * V[11];
  const double zaxis[3] = {V[8], V[9], V[10]};
  double near = (double)s->near_plane;
  size_t nw = (v->n + 63) / 64;
  memset(v->mark, 0, nw * sizeof *v->mark);
  v->n_vis_tiles = 0;
  size_t listed = 0;
  for (size_t ti = 0; ti < v->n_tiles; ti++) {
    const vis_tile *t = &v->tile[ti];
    if (!t->always) {
      /* near plane: depth of the farthest corner, with a rounding margin */
      double zmax = box_max(zaxis, t->lo, t->hi) + V[11];
      if (zmax <= near - 1e-6 * (1.0 + fabs(zmax))) continue;
      double rad = 3.0 * K * (double)t->smax;
      int out = 0;
      for (int p = 0; p < 4 && !out; p++) {
        double f = box_max(pl[p], t->lo, t->hi) + pl[p][3] + rad;
        double scale = fabs(pl[p][3]) + rad + 1.0;
        out = f < -1e-6 * scale;
      }
      if (out) continue;
    }
    v->vis_tiles[v->n_vis_tiles++] = (uint32_t)ti;
    listed += t->count;
    for (uint32_t j = t->first; j < t->first + t->count; j++) {
      uint32_t i = v->member[j];
      v->mark[i >> 6] |= 1ull << (i & 63);
    }
  }
  /* the rasterizer wants increasing indices: read them off the bitmap */
  size_t k = 0;
  for (size_t w = 0; w < nw; w++)
    for (uint64_t bits = v->mark[w]; bits; bits &= bits - 1)
      v->list[k++] = (uint32_t)(64 * w + (size_t)__builtin_ctzll(bits));
  v->st.tiles_visible = v->n_vis_tiles;
  v->st.gaussians_listed = listed;
  *idx = v->list;
  *n_idx = k;
  return MGS_OK;
}

void mgs_visibility_get_stats(const mgs_visibility *v, mgs_visibility_stats *st) {
  *st = v->st;
  st->tile_size = v->tile_size;
  st->tiles = v->n_tiles;
}

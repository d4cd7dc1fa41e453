/* Persistence of Rips and weak-alpha complexes of small point clouds
 * (topo/mgs_topo_pointcloud.h).
 *
 * The engine: edges sorted by (length, index); H0 by union-find over them (all vertices
 * are born at 0, so any merge rule gives the same diagram; the merging edge is the death
 * edge). Higher dimensions by the standard column reduction over Z/2 with clearing:
 * tetrahedra first (their pivots are the triangles that create H2 classes, which are then
 * skipped), then triangles (their pivots are the edges that create H1 classes). When there
 * are no tetrahedra (Rips up to dimension 2), H1 comes from the coboundary reduction of the
 * edges that closed a cycle instead (h1_by_cohomology: the same pairs, far less fill-in).
 * A simplex's value is the length of its longest edge, which is its critical edge. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "topo/mgs_topo_pointcloud.h"

void mgs_topo_bars_init(mgs_topo_bars *b) { memset(b, 0, sizeof *b); }
void mgs_topo_bars_free(mgs_topo_bars *b) { free(b->bars); memset(b, 0, sizeof *b); }

static int bars_push(mgs_topo_bars *b, int dim, double birth, double death, int32_t b0, int32_t b1, int32_t d0,
                     int32_t d1) {
  if (b->n == b->capacity) {
    size_t cap = b->capacity ? 2 * b->capacity : 64;
    mgs_topo_bar *nb = realloc(b->bars, cap * sizeof *nb);
    if (!nb) return 0;
    b->bars = nb;
    b->capacity = cap;
  }
  b->bars[b->n++] = (mgs_topo_bar){dim, birth, death, {b0, b1}, {d0, d1}};
  return 1;
}

/* ---------------------------------------------------------------- complex */

typedef struct cx {
  const double *p;
  int32_t nv;
  size_t ne, nt, nq;
  int32_t *ev;     /* 2 per edge (sorted order after build) */
  double *elen;
  int32_t *tri;    /* 3 edge ranks per triangle, ascending (sorted order after build) */
  int32_t *tet;    /* 4 triangle ranks per tetrahedron, ascending */
} cx;

static double dist3(const double *p, int32_t a, int32_t b) {
  double dx = p[3 * a] - p[3 * b], dy = p[3 * a + 1] - p[3 * b + 1], dz = p[3 * a + 2] - p[3 * b + 2];
  return sqrt(dx * dx + dy * dy + dz * dz);
}

/* Sorting keys: (value, index) with ties by index keep the order deterministic. */
typedef struct skey { double v; int64_t a, b, c; size_t i; } skey;
static int cmp_key(const void *x, const void *y) {
  const skey *p = x, *q = y;
  if (p->v != q->v) return p->v < q->v ? -1 : 1;
  if (p->a != q->a) return p->a < q->a ? -1 : 1;
  if (p->b != q->b) return p->b < q->b ? -1 : 1;
  if (p->c != q->c) return p->c < q->c ? -1 : 1;
  return p->i < q->i ? -1 : p->i > q->i;
}

static void sort3(int32_t *v) {
  int32_t t;
  if (v[0] > v[1]) { t = v[0]; v[0] = v[1]; v[1] = t; }
  if (v[1] > v[2]) { t = v[1]; v[1] = v[2]; v[2] = t; }
  if (v[0] > v[1]) { t = v[0]; v[0] = v[1]; v[1] = t; }
}
static int cmp_i32(const void *x, const void *y) {
  int32_t a = *(const int32_t *)x, b = *(const int32_t *)y;
  return a < b ? -1 : a > b;
}

/* Open-addressing map from a 64-bit key to an index. */
typedef struct hmap { uint64_t *k; int64_t *v; size_t mask; } hmap;
static int hmap_init(hmap *h, size_t n) {
  size_t cap = 16;
  while (cap < 2 * n + 16) cap <<= 1;
  h->k = malloc(cap * sizeof *h->k);
  h->v = malloc(cap * sizeof *h->v);
  h->mask = cap - 1;
  if (!h->k || !h->v) return 0;
  memset(h->k, 0xff, cap * sizeof *h->k);
  return 1;
}
static void hmap_free(hmap *h) { free(h->k); free(h->v); }
static size_t hmix(uint64_t x) {
  x ^= x >> 33; x *= 0xff51afd7ed558ccdULL; x ^= x >> 33; x *= 0xc4ceb9fe1a85ec53ULL; x ^= x >> 33;
  return (size_t)x;
}
static void hmap_put(hmap *h, uint64_t kk, int64_t v) {
  size_t i = hmix(kk) & h->mask;
  while (h->k[i] != UINT64_MAX && h->k[i] != kk) i = (i + 1) & h->mask;
  h->k[i] = kk;
  h->v[i] = v;
}
static int64_t hmap_get(const hmap *h, uint64_t kk) {
  size_t i = hmix(kk) & h->mask;
  while (h->k[i] != UINT64_MAX) {
    if (h->k[i] == kk) return h->v[i];
    i = (i + 1) & h->mask;
  }
  return -1;
}

/* Column store: reduced columns (ascending ranks) owned by their pivot. */
typedef struct colstore { int32_t **col; int32_t *len; } colstore;

/* a ^= b (both ascending) into out; returns the length. */
static size_t xor_merge(const int32_t *a, size_t na, const int32_t *b, size_t nb, int32_t *out) {
  size_t i = 0, j = 0, k = 0;
  while (i < na && j < nb) {
    if (a[i] < b[j]) out[k++] = a[i++];
    else if (a[i] > b[j]) out[k++] = b[j++];
    else { i++; j++; }
  }
  while (i < na) out[k++] = a[i++];
  while (j < nb) out[k++] = b[j++];
  return k;
}

/* Reduces the boundary `bd` (ascending ranks of faces, length m) against the store
 * (indexed by face rank). Returns the pivot or -1 for a zero column; the reduced column is
 * left in *buf (resized as needed). skip(face) says whether the face's store slot is empty. */
static int32_t reduce(colstore *cs, int32_t **buf, size_t *bufcap, int32_t **tmp, size_t *tmpcap, size_t *len,
                      int *nomem) {
  for (;;) {
    if (*len == 0) return -1;
    int32_t piv = (*buf)[*len - 1];
    int32_t *other = cs->col[piv];
    if (!other) return piv;
    size_t need = *len + (size_t)cs->len[piv];
    if (need > *tmpcap) {
      size_t cap = need * 2;
      int32_t *nt = realloc(*tmp, cap * sizeof *nt);
      if (!nt) { *nomem = 1; return -1; }
      *tmp = nt; *tmpcap = cap;
    }
    size_t nl = xor_merge(*buf, *len, other, (size_t)cs->len[piv], *tmp);
    int32_t *sw = *buf; *buf = *tmp; *tmp = sw;
    size_t sc = *bufcap; *bufcap = *tmpcap; *tmpcap = sc;
    *len = nl;
  }
}

static int32_t uf_find(int32_t *par, int32_t x) {
  while (par[x] != x) { par[x] = par[par[x]]; x = par[x]; }
  return x;
}

/* H1 of a complex without tetrahedra (Rips up to dimension 2) by the reduction of the
 * coboundary matrix (de Silva, Morozov & Vejdemo-Johansson 2011; Ripser's choice): columns
 * are the edges from the last to the first, each column the ascending ranks of the
 * triangles that contain the edge, its pivot the first of them. It gives the same pairs as
 * the boundary reduction of the triangles, and the edges that killed an H0 class are never
 * columns (clearing), so only the edges that create an H1 class are reduced — on Rips
 * complexes this avoids the fill-in of reducing every triangle (LPVI's neighbourhoods of
 * random points: 65 % of a run in that reduction). The bars are pushed in the boundary
 * reduction's order (by killing triangle, then the essential ones by edge), so the diagram
 * is the same array. ev/elen: edges in filtration order; epos[r]: edge r closed a cycle;
 * tri: 3 ascending edge ranks per triangle, triangles in filtration order. */
static mgs_status h1_by_cohomology(const int32_t *ev, const double *elen, size_t ne, const uint8_t *epos,
                                   const int32_t *tri, size_t nt, const int32_t *vid, mgs_topo_bars *out, mgs_error *err) {
  mgs_status st = MGS_OK;
  size_t *start = calloc(ne + 1, sizeof *start);
  int32_t *cob = malloc((nt ? 3 * nt : 1) * sizeof *cob), *killer = malloc((nt ? nt : 1) * sizeof *killer);
  uint8_t *alive = calloc(ne ? ne : 1, 1); /* edge r's class never dies */
  colstore tcs = {calloc(nt ? nt : 1, sizeof(int32_t *)), calloc(nt ? nt : 1, sizeof(int32_t))};
  size_t bufcap = 64, tmpcap = 64;
  int32_t *buf = malloc(bufcap * sizeof *buf), *tmp = malloc(tmpcap * sizeof *tmp);
  int nomem = 0;
  if (!start || !cob || !killer || !alive || !tcs.col || !tcs.len || !buf || !tmp) goto oom;
  /* cofacets of each edge, ascending (the triangles are visited in rank order) */
  for (size_t t = 0; t < nt; t++)
    for (int k = 0; k < 3; k++) start[tri[3 * t + k] + 1]++;
  for (size_t r = 0; r < ne; r++) start[r + 1] += start[r];
  {
    size_t *fill = malloc((ne ? ne : 1) * sizeof *fill);
    if (!fill) goto oom;
    memcpy(fill, start, ne * sizeof *fill);
    for (size_t t = 0; t < nt; t++)
      for (int k = 0; k < 3; k++) cob[fill[tri[3 * t + k]]++] = (int32_t)t;
    free(fill);
  }
  for (size_t t = 0; t < nt; t++) killer[t] = -1;
  for (size_t r = ne; r-- > 0;) {
    if (!epos[r]) continue; /* killed an H0 class: a pivot of the dimension below */
    size_t len = start[r + 1] - start[r];
    if (len > bufcap) {
      int32_t *nb = realloc(buf, 2 * len * sizeof *nb);
      if (!nb) goto oom;
      buf = nb; bufcap = 2 * len;
    }
    /* in reversed ranks nt - 1 - t, ascending, so that reduce()'s pivot (the last entry) is
       the first cofacet; the store is indexed by reversed rank too */
    for (size_t k = 0; k < len; k++) buf[k] = (int32_t)(nt - 1) - cob[start[r + 1] - 1 - k];
    int32_t piv = reduce(&tcs, &buf, &bufcap, &tmp, &tmpcap, &len, &nomem);
    if (nomem) goto oom;
    if (len == 0) { alive[r] = 1; continue; }
    tcs.col[piv] = malloc(len * sizeof(int32_t));
    if (!tcs.col[piv]) goto oom;
    memcpy(tcs.col[piv], buf, len * sizeof(int32_t));
    tcs.len[piv] = (int32_t)len;
    killer[(int32_t)(nt - 1) - piv] = (int32_t)r;
  }
#define VID(x) (vid ? vid[x] : (x))
  for (size_t t = 0; t < nt; t++) {
    int32_t b = killer[t], d = tri[3 * t + 2];
    if (b >= 0 && elen[d] > elen[b] &&
        !bars_push(out, 1, elen[b], elen[d], VID(ev[2 * b]), VID(ev[2 * b + 1]), VID(ev[2 * d]), VID(ev[2 * d + 1])))
      goto oom;
  }
  for (size_t r = 0; r < ne; r++)
    if (alive[r] && !bars_push(out, 1, elen[r], INFINITY, VID(ev[2 * r]), VID(ev[2 * r + 1]), -1, -1)) goto oom;
#undef VID
  goto done;
oom:
  st = mgs_error_set(err, MGS_ERR_NOMEM, "persistence: out of memory (%zu edges, %zu triangles)", ne, nt);
done:
  if (tcs.col) for (size_t t = 0; t < nt; t++) free(tcs.col[t]);
  free(tcs.col); free(tcs.len); free(start); free(cob); free(killer); free(alive); free(buf); free(tmp);
  return st;
}

/* Persistence of the complex: edges (ev, ne) unsorted; triangles as vertex triples;
 * tetrahedra as vertex quads. want_h2: compute H2 (needs every tetrahedron). */
static mgs_status complex_persistence(const double *p, int32_t nv, const int32_t *edges, size_t ne,
                                      const int32_t *tris_v, size_t nt, const int32_t *tets_v, size_t nq,
                                      const int32_t *vid, mgs_topo_bars *out, mgs_error *err) {
  mgs_status st = MGS_OK;
  skey *ek = malloc((ne ? ne : 1) * sizeof *ek);
  int32_t *ev = malloc((ne ? ne : 1) * 2 * sizeof *ev);
  double *elen = malloc((ne ? ne : 1) * sizeof *elen);
  int32_t *par = malloc((nv ? (size_t)nv : 1) * sizeof *par);
  uint8_t *epos = calloc(ne ? ne : 1, 1); /* 1: edge created an H1 class */
  hmap em = {0};
  skey *tk = NULL, *qk = NULL;
  int32_t *tri = NULL, *tet = NULL, *buf = NULL, *tmp = NULL;
  uint8_t *tri_cleared = NULL;
  colstore tcs = {0}, ecs = {0};
  size_t bufcap = 64, tmpcap = 64;
  int nomem = 0;
  buf = malloc(bufcap * sizeof *buf);
  tmp = malloc(tmpcap * sizeof *tmp);
  if (!ek || !ev || !elen || !par || !epos || !buf || !tmp || !hmap_init(&em, ne)) goto oom;
#define VID(x) (vid ? vid[x] : (x))
  /* edges in filtration order */
  for (size_t e = 0; e < ne; e++) {
    int32_t a = edges[2 * e], b = edges[2 * e + 1];
    if (a > b) { int32_t t = a; a = b; b = t; }
    ek[e] = (skey){dist3(p, a, b), a, b, 0, e};
  }
  qsort(ek, ne, sizeof *ek, cmp_key);
  for (size_t r = 0; r < ne; r++) {
    ev[2 * r] = (int32_t)ek[r].a; ev[2 * r + 1] = (int32_t)ek[r].b; elen[r] = ek[r].v;
    hmap_put(&em, (uint64_t)ek[r].a * (uint64_t)nv + (uint64_t)ek[r].b, (int64_t)r);
  }
  /* H0 */
  for (int32_t v = 0; v < nv; v++) par[v] = v;
  for (size_t r = 0; r < ne; r++) {
    int32_t ra = uf_find(par, ev[2 * r]), rb = uf_find(par, ev[2 * r + 1]);
    if (ra == rb) { epos[r] = 1; continue; }
    par[ra < rb ? rb : ra] = ra < rb ? ra : rb;
    if (elen[r] > 0 && !bars_push(out, 0, 0.0, elen[r], -1, -1, VID(ev[2 * r]), VID(ev[2 * r + 1]))) goto oom;
  }
  for (int32_t v = 0; v < nv; v++)
    if (uf_find(par, v) == v && !bars_push(out, 0, 0.0, INFINITY, -1, -1, -1, -1)) goto oom;

  /* triangles: boundary as ascending edge ranks; sorted by (max rank, mid, min) */
  tk = malloc((nt ? nt : 1) * sizeof *tk);
  tri = malloc((nt ? nt : 1) * 3 * sizeof *tri);
  if (!tk || !tri) goto oom;
  size_t ntv = 0;
  for (size_t t = 0; t < nt; t++) {
    int32_t v[3] = {tris_v[3 * t], tris_v[3 * t + 1], tris_v[3 * t + 2]};
    sort3(v);
    int64_t r0 = hmap_get(&em, (uint64_t)v[0] * (uint64_t)nv + (uint64_t)v[1]);
    int64_t r1 = hmap_get(&em, (uint64_t)v[0] * (uint64_t)nv + (uint64_t)v[2]);
    int64_t r2 = hmap_get(&em, (uint64_t)v[1] * (uint64_t)nv + (uint64_t)v[2]);
    if (r0 < 0 || r1 < 0 || r2 < 0) { st = mgs_error_set(err, MGS_ERR_ARG, "persistence: a triangle's edge is missing"); goto done; }
    int32_t rr[3] = {(int32_t)r0, (int32_t)r1, (int32_t)r2};
    sort3(rr);
    tk[ntv++] = (skey){(double)rr[2], rr[1], rr[0], 0, t};
  }
  {
    /* by the longest edge's rank first (a counting sort), then each group by cmp_key: the
       order of one qsort of all of them, without its cost on 10^5-10^6 Rips triangles */
    size_t *at = calloc(ne + 1, sizeof *at);
    skey *sorted = malloc((ntv ? ntv : 1) * sizeof *sorted);
    if (!at || !sorted) { free(at); free(sorted); goto oom; }
    for (size_t t = 0; t < ntv; t++) at[(size_t)tk[t].v + 1]++;
    for (size_t r = 0; r < ne; r++) at[r + 1] += at[r];
    for (size_t t = 0; t < ntv; t++) sorted[at[(size_t)tk[t].v]++] = tk[t];
    for (size_t r = 0, b = 0; r < ne; b = at[r++])
      if (at[r] - b > 1) qsort(sorted + b, at[r] - b, sizeof *sorted, cmp_key);
    free(at);
    free(tk);
    tk = sorted;
  }
  for (size_t r = 0; r < ntv; r++) { tri[3 * r] = (int32_t)tk[r].b; tri[3 * r + 1] = (int32_t)tk[r].a; tri[3 * r + 2] = (int32_t)tk[r].v; }
  tri_cleared = calloc(ntv ? ntv : 1, 1);
  if (!tri_cleared) goto oom;

  /* tetrahedra: H2 pairs (triangle creates, tetrahedron kills) */
  if (nq && ne >= ((size_t)1 << 21)) {
    st = mgs_error_set(err, MGS_ERR_ARG, "persistence: %zu edges (triangle keys hold edge ranks below 2^21)", ne);
    goto done;
  }
  if (nq) {
    hmap tm;
    if (!hmap_init(&tm, ntv)) goto oom;
    for (size_t r = 0; r < ntv; r++) {
      /* a triangle's key: its three edge ranks packed (ranks < 2^21 for the sizes used) */
      uint64_t kk = ((uint64_t)tri[3 * r] << 42) | ((uint64_t)tri[3 * r + 1] << 21) | (uint64_t)tri[3 * r + 2];
      hmap_put(&tm, kk, (int64_t)r);
    }
    qk = malloc(nq * sizeof *qk);
    tet = malloc(nq * 4 * sizeof *tet);
    tcs.col = calloc(ntv ? ntv : 1, sizeof *tcs.col);
    tcs.len = calloc(ntv ? ntv : 1, sizeof *tcs.len);
    if (!qk || !tet || !tcs.col || !tcs.len) { hmap_free(&tm); goto oom; }
    static const int faces[4][3] = {{0, 1, 2}, {0, 1, 3}, {0, 2, 3}, {1, 2, 3}};
    for (size_t q = 0; q < nq; q++) {
      int32_t f[4];
      for (int k = 0; k < 4; k++) {
        int32_t a = tets_v[4 * q + faces[k][0]], b = tets_v[4 * q + faces[k][1]], c = tets_v[4 * q + faces[k][2]];
        int32_t v[3] = {a, b, c};
        sort3(v);
        int32_t rr[3] = {(int32_t)hmap_get(&em, (uint64_t)v[0] * (uint64_t)nv + (uint64_t)v[1]),
                         (int32_t)hmap_get(&em, (uint64_t)v[0] * (uint64_t)nv + (uint64_t)v[2]),
                         (int32_t)hmap_get(&em, (uint64_t)v[1] * (uint64_t)nv + (uint64_t)v[2])};
        sort3(rr);
        int64_t tr = rr[0] < 0 ? -1 : hmap_get(&tm, ((uint64_t)rr[0] << 42) | ((uint64_t)rr[1] << 21) | (uint64_t)rr[2]);
        if (tr < 0) { hmap_free(&tm); st = mgs_error_set(err, MGS_ERR_ARG, "persistence: a tetrahedron's face is missing"); goto done; }
        f[k] = (int32_t)tr;
      }
      qsort(f, 4, sizeof *f, cmp_i32);
      memcpy(tet + 4 * q, f, sizeof f);
      qk[q] = (skey){(double)f[3], f[2], f[1], f[0], q};
    }
    hmap_free(&tm);
    qsort(qk, nq, sizeof *qk, cmp_key);
    for (size_t r = 0; r < nq; r++) {
      const int32_t *f = tet + 4 * qk[r].i;
      size_t len = 4;
      memcpy(buf, f, 4 * sizeof *buf);
      int32_t piv = reduce(&tcs, &buf, &bufcap, &tmp, &tmpcap, &len, &nomem);
      if (nomem) goto oom;
      if (piv < 0) continue; /* an H3 class: impossible in R^3, ignored */
      tcs.col[piv] = malloc(len * sizeof(int32_t));
      if (!tcs.col[piv]) goto oom;
      memcpy(tcs.col[piv], buf, len * sizeof(int32_t));
      tcs.len[piv] = (int32_t)len;
      tri_cleared[piv] = 1;
      int32_t be = tri[3 * piv + 2]; /* critical edges: the longest of each simplex */
      /* the tetrahedron's longest edge is the longest edge of its last face */
      int32_t dedge = tri[3 * (size_t)qk[r].v + 2];
      if (elen[dedge] > elen[be] &&
          !bars_push(out, 2, elen[be], elen[dedge], VID(ev[2 * be]), VID(ev[2 * be + 1]), VID(ev[2 * dedge]), VID(ev[2 * dedge + 1])))
        goto oom;
    }
  }

  if (!nq) {
    st = h1_by_cohomology(ev, elen, ne, epos, tri, ntv, vid, out, err);
    goto done;
  }
  /* triangles: H1 pairs (edge creates, triangle kills) */
  ecs.col = calloc(ne ? ne : 1, sizeof *ecs.col);
  ecs.len = calloc(ne ? ne : 1, sizeof *ecs.len);
  if (!ecs.col || !ecs.len) goto oom;
  for (size_t r = 0; r < ntv; r++) { /* only with tetrahedra: h1_by_cohomology otherwise */
    if (tri_cleared[r]) continue;
    size_t len = 3;
    memcpy(buf, tri + 3 * r, 3 * sizeof *buf);
    int32_t piv = reduce(&ecs, &buf, &bufcap, &tmp, &tmpcap, &len, &nomem);
    if (nomem) goto oom;
    if (piv < 0) continue; /* creates an H2 class (not computed without tetrahedra) */
    ecs.col[piv] = malloc(len * sizeof(int32_t));
    if (!ecs.col[piv]) goto oom;
    memcpy(ecs.col[piv], buf, len * sizeof(int32_t));
    ecs.len[piv] = (int32_t)len;
    int32_t dedge = tri[3 * r + 2];
    if (elen[dedge] > elen[piv] &&
        !bars_push(out, 1, elen[piv], elen[dedge], VID(ev[2 * piv]), VID(ev[2 * piv + 1]), VID(ev[2 * dedge]), VID(ev[2 * dedge + 1])))
      goto oom;
  }
  for (size_t r = 0; r < ne; r++)
    if (epos[r] && !ecs.col[r] && !bars_push(out, 1, elen[r], INFINITY, VID(ev[2 * r]), VID(ev[2 * r + 1]), -1, -1)) goto oom;
  goto done;
#undef VID
oom:
  st = mgs_error_set(err, MGS_ERR_NOMEM, "persistence: out of memory (%d points, %zu edges, %zu triangles)", (int)nv, ne, nt);
done:
  if (tcs.col) for (size_t r = 0; r < nt; r++) free(tcs.col[r]);
  if (ecs.col) for (size_t r = 0; r < ne; r++) free(ecs.col[r]);
  free(tcs.col); free(tcs.len); free(ecs.col); free(ecs.len);
  free(ek); free(ev); free(elen); free(par); free(epos); hmap_free(&em);
  free(tk); free(qk); free(tri); free(tet); free(buf); free(tmp); free(tri_cleared);
  return st;
}

/* ---------------------------------------------------------------- Rips */

mgs_status mgs_topo_rips_persistence(const double *pts, size_t n, double max_edge, mgs_topo_bars *out,
                                     mgs_error *err) {
  if (n == 0) return MGS_OK;
  if (n > 4096) return mgs_error_set(err, MGS_ERR_ARG, "Rips persistence: %zu points (at most 4096: the complex is cubic in them)", n);
  for (size_t i = 0; i < 3 * n; i++)
    if (!isfinite(pts[i])) return mgs_error_set(err, MGS_ERR_NUMERIC, "Rips persistence: point %zu is not finite", i / 3);
  int32_t nv = (int32_t)n;
  uint8_t *adj = calloc(n * n, 1);
  size_t ne = 0, cap = 256;
  int32_t *edges = malloc(cap * 2 * sizeof *edges);
  if (!adj || !edges) { free(adj); free(edges); return mgs_error_set(err, MGS_ERR_NOMEM, "Rips persistence: out of memory"); }
  for (int32_t a = 0; a < nv; a++)
    for (int32_t b = a + 1; b < nv; b++)
      if (dist3(pts, a, b) <= max_edge) {
        if (ne == cap) {
          cap *= 2;
          int32_t *ne2 = realloc(edges, cap * 2 * sizeof *ne2);
          if (!ne2) { free(adj); free(edges); return mgs_error_set(err, MGS_ERR_NOMEM, "Rips persistence: out of memory"); }
          edges = ne2;
        }
        edges[2 * ne] = a; edges[2 * ne + 1] = b; ne++;
        adj[(size_t)a * n + (size_t)b] = adj[(size_t)b * n + (size_t)a] = 1;
      }
  size_t nt = 0, tcap = 1024;
  int32_t *tris = malloc(tcap * 3 * sizeof *tris);
  mgs_status st = MGS_OK;
  if (!tris) st = mgs_error_set(err, MGS_ERR_NOMEM, "Rips persistence: out of memory");
  for (int32_t a = 0; a < nv && !st; a++)
    for (int32_t b = a + 1; b < nv && !st; b++) {
      if (!adj[(size_t)a * n + (size_t)b]) continue;
      for (int32_t c = b + 1; c < nv; c++) {
        if (!adj[(size_t)a * n + (size_t)c] || !adj[(size_t)b * n + (size_t)c]) continue;
        if (nt == tcap) {
          tcap *= 2;
          int32_t *t2 = realloc(tris, tcap * 3 * sizeof *t2);
          if (!t2) { st = mgs_error_set(err, MGS_ERR_NOMEM, "Rips persistence: out of memory (%zu triangles)", nt); break; }
          tris = t2;
        }
        tris[3 * nt] = a; tris[3 * nt + 1] = b; tris[3 * nt + 2] = c; nt++;
      }
    }
  free(adj);
  if (!st) st = complex_persistence(pts, nv, edges, ne, tris, nt, NULL, 0, NULL, out, err);
  free(edges); free(tris);
  return st;
}

/* ---------------------------------------------------------------- weak alpha */

/* qsort has no context argument: merge sort with one instead (thread safe). */
static int pt_less(const double *p, int32_t i, int32_t j) {
  const double *a = p + 3 * (size_t)i, *b = p + 3 * (size_t)j;
  for (int k = 0; k < 3; k++) if (a[k] != b[k]) return a[k] < b[k];
  return i < j;
}
static void msort(const double *p, int32_t *v, int32_t *t, size_t n) {
  if (n < 2) return;
  size_t h = n / 2;
  msort(p, v, t, h);
  msort(p, v + h, t, n - h);
  size_t i = 0, j = h, k = 0;
  while (i < h && j < n) t[k++] = pt_less(p, v[j], v[i]) ? v[j++] : v[i++];
  while (i < h) t[k++] = v[i++];
  while (j < n) t[k++] = v[j++];
  memcpy(v, t, n * sizeof *v);
}

mgs_status mgs_topo_weak_alpha_persistence(const double *pts, size_t n, mgs_topo_bars *out, mgs_error *err) {
  if (n == 0) return MGS_OK;
  if (n > (1u << 20)) return mgs_error_set(err, MGS_ERR_ARG, "weak-alpha persistence: %zu points (at most 2^20)", n);
  for (size_t i = 0; i < 3 * n; i++)
    if (!isfinite(pts[i])) return mgs_error_set(err, MGS_ERR_NUMERIC, "weak-alpha persistence: point %zu is not finite", i / 3);
  /* merge exact duplicates: vertex u of the complex is original point vid[u] */
  int32_t *ord = malloc(n * sizeof *ord), *tmp = malloc(n * sizeof *tmp), *vid = malloc(n * sizeof *vid);
  double *up = malloc(n * 3 * sizeof *up);
  int32_t *simp = NULL, *edges = NULL, *tris = NULL;
  mgs_status st = MGS_OK;
  if (!ord || !tmp || !vid || !up) { st = mgs_error_set(err, MGS_ERR_NOMEM, "weak-alpha persistence: out of memory"); goto done; }
  for (size_t i = 0; i < n; i++) ord[i] = (int32_t)i;
  msort(pts, ord, tmp, n);
  size_t nu = 0;
  for (size_t i = 0; i < n; i++) {
    const double *q = pts + 3 * (size_t)ord[i];
    if (nu && !memcmp(up + 3 * (nu - 1), q, 3 * sizeof *q)) continue;
    memcpy(up + 3 * nu, q, 3 * sizeof *q);
    vid[nu++] = ord[i];
  }
  size_t nq = 0;
  if (nu >= 5) {
    if ((st = mgs_topo_delaunay(up, nu, 3, &simp, &nq, NULL, err))) goto done;
  }
  if (nq == 0 && nu >= 2) {
    if (nu > 4) { st = mgs_error_set(err, MGS_ERR_NUMERIC, "weak-alpha persistence: qhull could not triangulate %zu distinct points", nu); goto done; }
    /* the complete complex on <= 4 points */
    free(simp);
    simp = malloc(4 * sizeof *simp);
    if (!simp) { st = mgs_error_set(err, MGS_ERR_NOMEM, "weak-alpha persistence: out of memory"); goto done; }
    for (int k = 0; k < 4; k++) simp[k] = k;
    nq = nu == 4 ? 1 : 0;
    size_t ne = nu * (nu - 1) / 2, nt = nu >= 3 ? (nu == 3 ? 1 : 4) : 0;
    edges = malloc(12 * sizeof *edges); tris = malloc(12 * sizeof *tris);
    if (!edges || !tris) { st = mgs_error_set(err, MGS_ERR_NOMEM, "weak-alpha persistence: out of memory"); goto done; }
    size_t k = 0;
    for (int32_t a = 0; a < (int32_t)nu; a++) for (int32_t b = a + 1; b < (int32_t)nu; b++) { edges[2 * k] = a; edges[2 * k + 1] = b; k++; }
    k = 0;
    for (int32_t a = 0; a < (int32_t)nu; a++) for (int32_t b = a + 1; b < (int32_t)nu; b++) for (int32_t c = b + 1; c < (int32_t)nu; c++) {
      tris[3 * k] = a; tris[3 * k + 1] = b; tris[3 * k + 2] = c; k++;
    }
    st = complex_persistence(up, (int32_t)nu, edges, ne, tris, nt, simp, nq, vid, out, err);
    goto done;
  }
  if (nu < 2) {
    if (!bars_push(out, 0, 0.0, INFINITY, -1, -1, -1, -1)) st = mgs_error_set(err, MGS_ERR_NOMEM, "weak-alpha persistence: out of memory");
    goto done;
  }
  {
    /* faces of the tetrahedra, deduplicated through a hash of sorted vertex triples/pairs */
    hmap hm_e = {0}, hm_t = {0};
    if (!hmap_init(&hm_e, 8 * nq) || !hmap_init(&hm_t, 4 * nq)) {
      hmap_free(&hm_e); hmap_free(&hm_t);
      st = mgs_error_set(err, MGS_ERR_NOMEM, "weak-alpha persistence: out of memory"); goto done;
    }
    size_t ne = 0, nt = 0;
    edges = malloc(6 * nq * 2 * sizeof *edges);
    tris = malloc(4 * nq * 3 * sizeof *tris);
    if (!edges || !tris) { hmap_free(&hm_e); hmap_free(&hm_t); st = mgs_error_set(err, MGS_ERR_NOMEM, "weak-alpha persistence: out of memory"); goto done; }
    for (size_t q = 0; q < nq; q++) {
      int32_t v[4];
      memcpy(v, simp + 4 * q, sizeof v);
      qsort(v, 4, sizeof *v, cmp_i32);
      for (int a = 0; a < 4; a++)
        for (int b = a + 1; b < 4; b++) {
          uint64_t kk = (uint64_t)v[a] * (uint64_t)nu + (uint64_t)v[b];
          if (hmap_get(&hm_e, kk) < 0) { hmap_put(&hm_e, kk, (int64_t)ne); edges[2 * ne] = v[a]; edges[2 * ne + 1] = v[b]; ne++; }
          for (int c = b + 1; c < 4; c++) {
            uint64_t kt = ((uint64_t)v[a] << 42) | ((uint64_t)v[b] << 21) | (uint64_t)v[c];
            if (hmap_get(&hm_t, kt) < 0) { hmap_put(&hm_t, kt, (int64_t)nt); tris[3 * nt] = v[a]; tris[3 * nt + 1] = v[b]; tris[3 * nt + 2] = v[c]; nt++; }
          }
        }
    }
    hmap_free(&hm_e); hmap_free(&hm_t);
    /* points qhull left out (coplanar with Qc: never for distinct points in general
       position; possible after joggling) are isolated vertices: attach each to its nearest
       triangulated point so they are in the complex, as in a Delaunay triangulation */
    uint8_t *used = calloc(nu, 1);
    if (!used) { st = mgs_error_set(err, MGS_ERR_NOMEM, "weak-alpha persistence: out of memory"); goto done; }
    for (size_t e = 0; e < ne; e++) used[edges[2 * e]] = used[edges[2 * e + 1]] = 1;
    size_t extra = 0;
    for (size_t u = 0; u < nu; u++) extra += !used[u];
    if (extra) {
      int32_t *e2 = realloc(edges, (ne + extra) * 2 * sizeof *e2);
      if (!e2) { free(used); st = mgs_error_set(err, MGS_ERR_NOMEM, "weak-alpha persistence: out of memory"); goto done; }
      edges = e2;
      for (size_t u = 0; u < nu; u++) {
        if (used[u]) continue;
        double best = INFINITY; int32_t bi = -1;
        for (size_t w = 0; w < nu; w++) {
          if (!used[w]) continue;
          double dd = dist3(up, (int32_t)u, (int32_t)w);
          if (dd < best) { best = dd; bi = (int32_t)w; }
        }
        if (bi >= 0) { edges[2 * ne] = (int32_t)u; edges[2 * ne + 1] = bi; ne++; }
      }
    }
    free(used);
    st = complex_persistence(up, (int32_t)nu, edges, ne, tris, nt, simp, nq, vid, out, err);
  }
done:
  free(ord); free(tmp); free(vid); free(up); free(simp); free(edges); free(tris);
  return st;
}

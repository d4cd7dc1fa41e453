/* A static k-d tree for k-nearest-neighbour queries over the initial points (train/mgs_lpvi.h):
 * SfM clouds are far from uniform, so a tree rather than the uniform grid of init.c. */
#include <stdlib.h>
#include <string.h>
#include "train/mgs_lpvi.h"

#define LEAF 8

struct mgs_kdtree {
  const float *xyz;
  size_t n;
  size_t *idx;   /* points permuted so every node is a contiguous range */
  /* node for range [b, e): split axis and value stored at the median position m = (b+e)/2 */
  unsigned char *axis;
};

static double coord(const mgs_kdtree *t, size_t i, int a) { return t->xyz[3 * t->idx[i] + a]; }

/* Node ranges are sorted along their split axis (n log^2 n over the whole build; the tree
 * is built once per LPVI run). qsort has no context argument: a thread-local one. */
static _Thread_local const float *g_xyz;
static _Thread_local int g_axis;
static int cmp_axis(const void *x, const void *y) {
  size_t i = *(const size_t *)x, j = *(const size_t *)y;
  float a = g_xyz[3 * i + g_axis], b = g_xyz[3 * j + g_axis];
  if (a != b) return a < b ? -1 : 1;
  return i < j ? -1 : i > j;
}
static void select_median(mgs_kdtree *t, size_t b, size_t e, size_t m, int a) {
  (void)m;
  g_xyz = t->xyz;
  g_axis = a;
  qsort(t->idx + b, e - b, sizeof *t->idx, cmp_axis);
}

static void build(mgs_kdtree *t, size_t b, size_t e) {
  if (e - b <= LEAF) return;
  double lo[3], hi[3];
  for (int a = 0; a < 3; a++) { lo[a] = hi[a] = coord(t, b, a); }
  for (size_t i = b + 1; i < e; i++)
    for (int a = 0; a < 3; a++) {
      double v = coord(t, i, a);
      if (v < lo[a]) lo[a] = v;
      if (v > hi[a]) hi[a] = v;
    }
  int ax = 0;
  for (int a = 1; a < 3; a++) if (hi[a] - lo[a] > hi[ax] - lo[ax]) ax = a;
  size_t m = b + (e - b) / 2;
  select_median(t, b, e, m, ax);
  t->axis[m] = (unsigned char)ax;
  build(t, b, m);
  build(t, m + 1, e);
}

mgs_kdtree *mgs_kdtree_build(const float *xyz, size_t n) {
  mgs_kdtree *t = calloc(1, sizeof *t);
  if (!t) return NULL;
  t->xyz = xyz;
  t->n = n;
  t->idx = malloc((n ? n : 1) * sizeof *t->idx);
  t->axis = calloc(n ? n : 1, 1);
  if (!t->idx || !t->axis) { mgs_kdtree_destroy(t); return NULL; }
  for (size_t i = 0; i < n; i++) t->idx[i] = i;
  build(t, 0, n);
  return t;
}

void mgs_kdtree_destroy(mgs_kdtree *t) {
  if (!t) return;
  free(t->idx);
  free(t->axis);
  free(t);
}

typedef struct knn_q { const double *q; size_t k, m; size_t *idx; double *d2; } knn_q;

static void offer(knn_q *s, size_t id, double d) {
  if (s->m == s->k && (d > s->d2[s->m - 1] || (d == s->d2[s->m - 1] && id > s->idx[s->m - 1]))) return;
  size_t p = s->m < s->k ? s->m++ : s->m - 1;
  while (p > 0 && (s->d2[p - 1] > d || (s->d2[p - 1] == d && s->idx[p - 1] > id))) {
    s->d2[p] = s->d2[p - 1]; s->idx[p] = s->idx[p - 1]; p--;
  }
  s->d2[p] = d; s->idx[p] = id;
}

static void search(const mgs_kdtree *t, size_t b, size_t e, knn_q *s) {
  if (e - b <= LEAF) {
    for (size_t i = b; i < e; i++) {
      double d = 0;
      for (int a = 0; a < 3; a++) { double x = coord(t, i, a) - s->q[a]; d += x * x; }
      offer(s, t->idx[i], d);
    }
    return;
  }
  size_t m = b + (e - b) / 2;
  int ax = t->axis[m];
  double diff = s->q[ax] - coord(t, m, ax);
  double d = 0;
  for (int a = 0; a < 3; a++) { double x = coord(t, m, a) - s->q[a]; d += x * x; }
  offer(s, t->idx[m], d);
  size_t nb = diff < 0 ? b : m + 1, ne = diff < 0 ? m : e;
  size_t fb = diff < 0 ? m + 1 : b, fe = diff < 0 ? e : m;
  search(t, nb, ne, s);
  if (s->m < s->k || diff * diff <= s->d2[s->m - 1]) search(t, fb, fe, s);
}

size_t mgs_kdtree_knn(const mgs_kdtree *t, const double q[3], size_t k, size_t *idx, double *d2) {
  if (!t || k == 0 || t->n == 0) return 0;
  knn_q s = {q, k < t->n ? k : t->n, 0, idx, d2};
  search(t, 0, t->n, &s);
  return s.m;
}

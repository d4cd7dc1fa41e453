/* Growable triangle lists and closed primitives (box, capped cylinder, UV sphere,
 * torus), each an outward-oriented closed 2-manifold, for assembling builtin scenes. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "assets/assets_internal.h"
#include "core/mgs_math.h"

static int grow(void **p, size_t *cap, size_t need, size_t elem) {
  if (need <= *cap) return 1;
  size_t nc = *cap ? *cap * 2 : 1024;
  while (nc < need) nc *= 2;
  void *q = realloc(*p, nc * elem);
  if (!q) return 0;
  *p = q;
  *cap = nc;
  return 1;
}

uint32_t mgs_mb_vertex(mgs_mesh_builder *b, double x, double y, double z) {
  if (b->failed || !grow((void **)&b->v, &b->cap_v, b->nv + 1, 3 * sizeof(float))) { b->failed = 1; return 0; }
  float *p = b->v + 3 * b->nv;
  p[0] = (float)x; p[1] = (float)y; p[2] = (float)z;
  return (uint32_t)b->nv++;
}

void mgs_mb_triangle(mgs_mesh_builder *b, uint32_t a, uint32_t c, uint32_t d) {
  if (b->failed || !grow((void **)&b->t, &b->cap_t, b->nt + 1, 3 * sizeof(uint32_t))) { b->failed = 1; return; }
  uint32_t *t = b->t + 3 * b->nt++;
  t[0] = a; t[1] = c; t[2] = d;
}

static void quad(mgs_mesh_builder *b, uint32_t a, uint32_t c, uint32_t d, uint32_t e) {
  mgs_mb_triangle(b, a, c, d);
  mgs_mb_triangle(b, a, d, e);
}

void mgs_mb_box(mgs_mesh_builder *b, const double lo[3], const double hi[3]) {
  uint32_t v[8];
  for (int i = 0; i < 8; i++) v[i] = mgs_mb_vertex(b, (i & 1) ? hi[0] : lo[0], (i & 2) ? hi[1] : lo[1], (i & 4) ? hi[2] : lo[2]);
  quad(b, v[0], v[2], v[3], v[1]); /* -z */
  quad(b, v[4], v[5], v[7], v[6]); /* +z */
  quad(b, v[0], v[1], v[5], v[4]); /* -y */
  quad(b, v[2], v[6], v[7], v[3]); /* +y */
  quad(b, v[0], v[4], v[6], v[2]); /* -x */
  quad(b, v[1], v[3], v[7], v[5]); /* +x */
}

/* e1, e2 with e1 x e2 = axis (unit). */
static void basis(const double axis[3], double e1[3], double e2[3]) {
  double h[3] = {1, 0, 0};
  if (fabs(axis[0]) > 0.9) { h[0] = 0; h[1] = 1; }
  mgs_cross3d(h, axis, e1);
  mgs_normalize3d(e1);
  mgs_cross3d(axis, e1, e2);
}

void mgs_mb_cylinder(mgs_mesh_builder *b, const double a[3], const double c[3], double radius, int segments) {
  double u[3];
  mgs_sub3d(c, a, u);
  if (mgs_normalize3d(u) <= 0 || segments < 3) return;
  double e1[3], e2[3];
  basis(u, e1, e2);
  uint32_t base = (uint32_t)b->nv;
  for (int end = 0; end < 2; end++) {
    const double *o = end ? c : a;
    for (int i = 0; i < segments; i++) {
      double th = 2 * MGS_PI * i / segments, cs = cos(th) * radius, sn = sin(th) * radius;
      mgs_mb_vertex(b, o[0] + cs * e1[0] + sn * e2[0], o[1] + cs * e1[1] + sn * e2[1], o[2] + cs * e1[2] + sn * e2[2]);
    }
  }
  uint32_t ca = mgs_mb_vertex(b, a[0], a[1], a[2]), cc = mgs_mb_vertex(b, c[0], c[1], c[2]);
  for (int i = 0; i < segments; i++) {
    uint32_t i0 = base + (uint32_t)i, i1 = base + (uint32_t)((i + 1) % segments);
    uint32_t t0 = i0 + (uint32_t)segments, t1 = i1 + (uint32_t)segments;
    quad(b, i0, i1, t1, t0);
    mgs_mb_triangle(b, ca, i1, i0);
    mgs_mb_triangle(b, cc, t0, t1);
  }
}

void mgs_mb_sphere(mgs_mesh_builder *b, const double c[3], double radius, int rings, int segments) {
  if (rings < 2 || segments < 3) return;
  uint32_t north = mgs_mb_vertex(b, c[0], c[1], c[2] + radius);
  uint32_t first = (uint32_t)b->nv;
  for (int k = 1; k < rings; k++) {
    double th = MGS_PI * k / rings;
    for (int j = 0; j < segments; j++) {
      double ph = 2 * MGS_PI * j / segments;
      mgs_mb_vertex(b, c[0] + radius * sin(th) * cos(ph), c[1] + radius * sin(th) * sin(ph), c[2] + radius * cos(th));
    }
  }
  uint32_t south = mgs_mb_vertex(b, c[0], c[1], c[2] - radius);
#define RV(k, j) (first + (uint32_t)((k) * segments + ((j) % segments)))
  for (int j = 0; j < segments; j++) {
    mgs_mb_triangle(b, north, RV(0, j), RV(0, j + 1));
    for (int k = 0; k + 1 < rings - 1; k++) quad(b, RV(k, j), RV(k + 1, j), RV(k + 1, j + 1), RV(k, j + 1));
    mgs_mb_triangle(b, south, RV(rings - 2, j + 1), RV(rings - 2, j));
  }
#undef RV
}

void mgs_mb_torus(mgs_mesh_builder *b, const double c[3], const double axis[3], double R, double r, int major_seg, int minor_seg) {
  if (major_seg < 3 || minor_seg < 3) return;
  double a[3] = {axis[0], axis[1], axis[2]};
  if (mgs_normalize3d(a) <= 0) return;
  double e1[3], e2[3];
  basis(a, e1, e2);
  uint32_t first = (uint32_t)b->nv;
  for (int i = 0; i < major_seg; i++) {
    double ph = 2 * MGS_PI * i / major_seg;
    double d[3] = {cos(ph) * e1[0] + sin(ph) * e2[0], cos(ph) * e1[1] + sin(ph) * e2[1], cos(ph) * e1[2] + sin(ph) * e2[2]};
    for (int j = 0; j < minor_seg; j++) {
      double th = 2 * MGS_PI * j / minor_seg, rr = R + r * cos(th), h = r * sin(th);
      mgs_mb_vertex(b, c[0] + rr * d[0] + h * a[0], c[1] + rr * d[1] + h * a[1], c[2] + rr * d[2] + h * a[2]);
    }
  }
#define TV(i, j) (first + (uint32_t)(((i) % major_seg) * minor_seg + ((j) % minor_seg)))
  for (int i = 0; i < major_seg; i++)
    for (int j = 0; j < minor_seg; j++) quad(b, TV(i, j), TV(i + 1, j), TV(i + 1, j + 1), TV(i, j + 1));
#undef TV
}

void mgs_mb_free(mgs_mesh_builder *b) {
  free(b->v);
  free(b->t);
  memset(b, 0, sizeof *b);
}

mgs_status mgs_mb_finish(mgs_mesh_builder *b, const char *name, mgs_mesh **out, mgs_error *err) {
  *out = NULL;
  if (b->failed) { mgs_mb_free(b); return mgs_error_set(err, MGS_ERR_NOMEM, "builtin %s: out of memory", name); }
  if (b->nt == 0) { mgs_mb_free(b); return mgs_error_set(err, MGS_ERR_FORMAT, "builtin %s: produced no triangles", name); }
  mgs_mesh *m = mgs_mesh_create(b->nv, b->nt);
  if (!m) { mgs_mb_free(b); return mgs_error_set(err, MGS_ERR_NOMEM, "builtin %s: out of memory", name); }
  memcpy(m->v, b->v, b->nv * 3 * sizeof(float));
  memcpy(m->t, b->t, b->nt * 3 * sizeof(uint32_t));
  mgs_mb_free(b);
  *out = m;
  return MGS_OK;
}

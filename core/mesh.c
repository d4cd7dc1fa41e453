/* Triangle meshes: allocation, writing (binary PLY, OBJ or OFF by extension, atomically)
 * and measures. Reading (through assimp) is in mesh_assimp.c. */
#include <ctype.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mgs_fs.h"
#include "core/mgs_mesh.h"
#include "core/ply_format.h"

mgs_mesh *mgs_mesh_create(size_t nv, size_t nt) {
  mgs_mesh *m = calloc(1, sizeof *m);
  if (!m) return NULL;
  m->v = malloc(sizeof(float) * 3 * (nv ? nv : 1));
  m->t = malloc(sizeof(uint32_t) * 3 * (nt ? nt : 1));
  if (!m->v || !m->t) { mgs_mesh_destroy(m); return NULL; }
  m->nv = nv;
  m->nt = nt;
  return m;
}

void mgs_mesh_destroy(mgs_mesh *m) {
  if (!m) return;
  free(m->v);
  free(m->t);
  free(m->uv);
  free(m->rgb);
  free(m->texture);
  free(m);
}

mgs_mesh *mgs_mesh_clone(const mgs_mesh *m) {
  if (!m) return NULL;
  mgs_mesh *c = mgs_mesh_create(m->nv, m->nt);
  if (!c) return NULL;
  memcpy(c->v, m->v, sizeof(float) * 3 * m->nv);
  memcpy(c->t, m->t, sizeof(uint32_t) * 3 * m->nt);
  int ok = 1;
  if (m->uv && (c->uv = malloc(sizeof(float) * 6 * m->nt))) memcpy(c->uv, m->uv, sizeof(float) * 6 * m->nt);
  else ok = !m->uv;
  if (ok && m->rgb && (c->rgb = malloc(sizeof(float) * 9 * m->nt))) memcpy(c->rgb, m->rgb, sizeof(float) * 9 * m->nt);
  else ok = ok && !m->rgb;
  if (ok && m->texture && !(c->texture = mgs_strdup(m->texture))) ok = 0;
  if (!ok) { mgs_mesh_destroy(c); return NULL; }
  return c;
}

static const char *ext_of(const char *path) {
  const char *s = strrchr(path, '/');
  const char *dot = strrchr(s ? s : path, '.');
  return dot ? dot + 1 : "";
}

static int ext_is(const char *path, const char *e) {
  const char *x = ext_of(path);
  if (strlen(x) != strlen(e)) return 0;
  for (size_t i = 0; x[i]; i++)
    if (tolower((unsigned char)x[i]) != e[i]) return 0;
  return 1;
}

mgs_status mgs_mesh_write(const char *path, const mgs_mesh *m, mgs_error *err) {
  if (!m) return mgs_error_set(err, MGS_ERR_ARG, "%s: no mesh to write", path);
  const int ply = ext_is(path, "ply"), obj = ext_is(path, "obj"), off = ext_is(path, "off");
  if (!ply && !obj && !off) return mgs_error_set(err, MGS_ERR_ARG, "%s: mesh extension must be .ply, .obj or .off", path);
  for (size_t i = 0; i < m->nv * 3; i++)
    if (!isfinite(m->v[i])) return mgs_error_set(err, MGS_ERR_NUMERIC, "%s: refusing to write: vertex %zu is not finite", path, i / 3);
  for (size_t i = 0; i < m->nt * 3; i++)
    if (m->t[i] >= m->nv) return mgs_error_set(err, MGS_ERR_ARG, "%s: refusing to write: triangle %zu has an index out of range", path, i / 3);
  mgs_atomic_file *af = NULL;
  FILE *fp = NULL;
  mgs_status st = mgs_atomic_open(path, &af, &fp, err);
  if (st != MGS_OK) return st;
  int ok = 1;
  if (ply) {
    fprintf(fp, "ply\nformat binary_little_endian 1.0\ncomment written by morsegs\nelement vertex %zu\n"
                "property float x\nproperty float y\nproperty float z\nelement face %zu\n"
                "property list uchar int vertex_indices\nend_header\n", m->nv, m->nt);
    for (size_t i = 0; i < m->nv && ok; i++) {
      unsigned char b[12];
      for (int k = 0; k < 3; k++) ply_put_f32le(b + 4 * k, m->v[i * 3 + (size_t)k]);
      ok = fwrite(b, 1, 12, fp) == 12;
    }
    for (size_t i = 0; i < m->nt && ok; i++) {
      unsigned char b[13];
      b[0] = 3;
      for (int k = 0; k < 3; k++) {
        uint32_t u = m->t[i * 3 + (size_t)k];
        for (int j = 0; j < 4; j++) b[1 + 4 * k + j] = (unsigned char)(u >> (8 * j));
      }
      ok = fwrite(b, 1, 13, fp) == 13;
    }
  } else if (obj) {
    fprintf(fp, "# written by morsegs\n");
    for (size_t i = 0; i < m->nv && ok; i++)
      ok = fprintf(fp, "v %.9g %.9g %.9g\n", m->v[i * 3], m->v[i * 3 + 1], m->v[i * 3 + 2]) > 0;
    for (size_t i = 0; i < m->nt && ok; i++)
      ok = fprintf(fp, "f %u %u %u\n", m->t[i * 3] + 1, m->t[i * 3 + 1] + 1, m->t[i * 3 + 2] + 1) > 0;
  } else {
    fprintf(fp, "OFF\n%zu %zu 0\n", m->nv, m->nt);
    for (size_t i = 0; i < m->nv && ok; i++)
      ok = fprintf(fp, "%.9g %.9g %.9g\n", m->v[i * 3], m->v[i * 3 + 1], m->v[i * 3 + 2]) > 0;
    for (size_t i = 0; i < m->nt && ok; i++) ok = fprintf(fp, "3 %u %u %u\n", m->t[i * 3], m->t[i * 3 + 1], m->t[i * 3 + 2]) > 0;
  }
  if (!ok) {
    mgs_atomic_abort(af);
    return mgs_error_set(err, MGS_ERR_IO, "%s: write failed (disk full?)", path);
  }
  return mgs_atomic_commit(af, err);
}

void mgs_mesh_bounds(const mgs_mesh *m, double lo[3], double hi[3]) {
  for (int k = 0; k < 3; k++) { lo[k] = INFINITY; hi[k] = -INFINITY; }
  for (size_t i = 0; i < m->nv; i++)
    for (int k = 0; k < 3; k++) {
      double x = m->v[i * 3 + (size_t)k];
      if (x < lo[k]) lo[k] = x;
      if (x > hi[k]) hi[k] = x;
    }
  if (m->nv == 0)
    for (int k = 0; k < 3; k++) lo[k] = hi[k] = 0;
}

double mgs_mesh_normalize(mgs_mesh *m, double size, double center_out[3]) {
  double lo[3], hi[3], c[3], ext = 0;
  mgs_mesh_bounds(m, lo, hi);
  for (int k = 0; k < 3; k++) {
    c[k] = 0.5 * (lo[k] + hi[k]);
    if (hi[k] - lo[k] > ext) ext = hi[k] - lo[k];
  }
  double s = ext > 0 ? size / ext : 1.0;
  for (size_t i = 0; i < m->nv; i++)
    for (int k = 0; k < 3; k++) m->v[i * 3 + (size_t)k] = (float)((m->v[i * 3 + (size_t)k] - c[k]) * s);
  if (center_out) memcpy(center_out, c, sizeof c);
  return s;
}

double mgs_mesh_area(const mgs_mesh *m) {
  double a = 0;
  for (size_t t = 0; t < m->nt; t++) {
    const float *p0 = m->v + 3 * (size_t)m->t[t * 3], *p1 = m->v + 3 * (size_t)m->t[t * 3 + 1], *p2 = m->v + 3 * (size_t)m->t[t * 3 + 2];
    double e1[3], e2[3];
    for (int k = 0; k < 3; k++) { e1[k] = (double)p1[k] - p0[k]; e2[k] = (double)p2[k] - p0[k]; }
    double cx = e1[1] * e2[2] - e1[2] * e2[1], cy = e1[2] * e2[0] - e1[0] * e2[2], cz = e1[0] * e2[1] - e1[1] * e2[0];
    a += 0.5 * sqrt(cx * cx + cy * cy + cz * cz);
  }
  return a;
}

double mgs_mesh_signed_volume(const mgs_mesh *m) {
  double v = 0;
  for (size_t t = 0; t < m->nt; t++) {
    const float *a = m->v + 3 * (size_t)m->t[3 * t], *b = m->v + 3 * (size_t)m->t[3 * t + 1], *c = m->v + 3 * (size_t)m->t[3 * t + 2];
    v += (double)a[0] * ((double)b[1] * c[2] - (double)b[2] * c[1]) - (double)a[1] * ((double)b[0] * c[2] - (double)b[2] * c[0]) +
         (double)a[2] * ((double)b[0] * c[1] - (double)b[1] * c[0]);
  }
  return v / 6.0;
}

static int edge_cmp(const void *a, const void *b) {
  uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
  return x < y ? -1 : x > y;
}

size_t mgs_mesh_count_boundary_or_nonmanifold_edges(const mgs_mesh *m) {
  if (m->nt == 0) return 0;
  uint64_t *e = malloc(sizeof *e * m->nt * 3);
  if (!e) return (size_t)-1;
  for (size_t t = 0; t < m->nt; t++)
    for (int k = 0; k < 3; k++) {
      uint64_t a = m->t[t * 3 + (size_t)k], b = m->t[t * 3 + (size_t)((k + 1) % 3)];
      e[t * 3 + (size_t)k] = a < b ? (a << 32 | b) : (b << 32 | a);
    }
  qsort(e, m->nt * 3, sizeof *e, edge_cmp);
  size_t bad = 0;
  for (size_t i = 0; i < m->nt * 3;) {
    size_t j = i;
    while (j < m->nt * 3 && e[j] == e[i]) j++;
    if (j - i != 2) bad++;
    i = j;
  }
  free(e);
  return bad;
}

void mgs_mesh_translate(mgs_mesh *m, const double offset[3], int sign) {
  if (!m || (offset[0] == 0 && offset[1] == 0 && offset[2] == 0)) return;
  for (size_t i = 0; i < m->nv; i++)
    for (int k = 0; k < 3; k++) m->v[3 * i + (size_t)k] = (float)((double)m->v[3 * i + (size_t)k] + sign * offset[k]);
}

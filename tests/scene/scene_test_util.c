#include "scene_test_util.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>

uint8_t *silhouette_probes(const mgs_mesh *m, const mgs_camera *cam) {
  int PW = 2 * cam->width + 1, PH = 2 * cam->height + 1;
  uint8_t *pr = calloc((size_t)PW * PH, 1);
  if (!pr) return NULL;
  for (size_t t = 0; t < m->nt; t++) {
    double u[3], v[3];
    int ok = 1;
    for (int k = 0; k < 3; k++) {
      const float *p = m->v + 3 * m->t[3 * t + k];
      double pd[3] = {p[0], p[1], p[2]}, depth;
      ok &= mgs_camera_project(cam, pd, &u[k], &v[k], &depth);
    }
    if (!ok) continue;
    double area = (u[1] - u[0]) * (v[2] - v[0]) - (u[2] - u[0]) * (v[1] - v[0]);
    if (area == 0) continue;
    double umin = fmin(u[0], fmin(u[1], u[2])), umax = fmax(u[0], fmax(u[1], u[2]));
    double vmin = fmin(v[0], fmin(v[1], v[2])), vmax = fmax(v[0], fmax(v[1], v[2]));
    int i0 = (int)ceil(umin * 2), i1 = (int)floor(umax * 2), j0 = (int)ceil(vmin * 2), j1 = (int)floor(vmax * 2);
    if (i0 < 0) i0 = 0;
    if (j0 < 0) j0 = 0;
    if (i1 > PW - 1) i1 = PW - 1;
    if (j1 > PH - 1) j1 = PH - 1;
    for (int j = j0; j <= j1; j++)
      for (int i = i0; i <= i1; i++) {
        double x = i * 0.5, y = j * 0.5;
        double w0 = (u[1] - x) * (v[2] - y) - (u[2] - x) * (v[1] - y);
        double w1 = (u[2] - x) * (v[0] - y) - (u[0] - x) * (v[2] - y);
        double w2 = (u[0] - x) * (v[1] - y) - (u[1] - x) * (v[0] - y);
        if (area < 0) { w0 = -w0; w1 = -w1; w2 = -w2; }
        if (w0 >= 0 && w1 >= 0 && w2 >= 0) pr[(size_t)j * PW + i] = 1;
      }
  }
  return pr;
}

mask_compare compare_silhouette(const float *alpha, int stride, const uint8_t *probes, int W, int H) {
  mask_compare c = {0, 0, 0, 0};
  int PW = 2 * W + 1;
  for (int y = 0; y < H; y++)
    for (int x = 0; x < W; x++) {
      int centre = probes[(size_t)(2 * y + 1) * PW + 2 * x + 1], all_same = 1;
      for (int dj = 0; dj <= 2; dj++)
        for (int di = 0; di <= 2; di++)
          if (probes[(size_t)(2 * y + dj) * PW + 2 * x + di] != centre) all_same = 0;
      int rendered = alpha[((size_t)y * W + x) * stride] > 0.5f;
      c.inside += centre;
      if (!all_same) c.boundary++;
      if (rendered != centre) {
        if (all_same) c.interior_mismatch++;
        else c.boundary_mismatch++;
      }
    }
  return c;
}

static size_t find(size_t *p, size_t x) {
  while (p[x] != x) { p[x] = p[p[x]]; x = p[x]; }
  return x;
}

size_t mesh_components(const mgs_mesh *m) {
  size_t *p = malloc(m->nv * sizeof *p);
  char *used = calloc(m->nv, 1);
  for (size_t i = 0; i < m->nv; i++) p[i] = i;
  for (size_t t = 0; t < m->nt; t++)
    for (int k = 0; k < 3; k++) {
      used[m->t[3 * t + k]] = 1;
      size_t a = find(p, m->t[3 * t + k]), b = find(p, m->t[3 * t + (k + 1) % 3]);
      if (a != b) p[a] = b;
    }
  size_t n = 0;
  for (size_t i = 0; i < m->nv; i++) n += used[i] && find(p, i) == i;
  free(p);
  free(used);
  return n;
}

static int cmp_u64(const void *a, const void *b) {
  uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
  return x < y ? -1 : x > y;
}

long mesh_euler(const mgs_mesh *m) {
  uint64_t *e = malloc(m->nt * 3 * sizeof *e);
  char *used = calloc(m->nv, 1);
  for (size_t t = 0; t < m->nt; t++)
    for (int k = 0; k < 3; k++) {
      uint64_t a = m->t[3 * t + k], b = m->t[3 * t + (k + 1) % 3];
      e[3 * t + k] = a < b ? (a << 32) | b : (b << 32) | a;
      used[a] = 1;
    }
  qsort(e, m->nt * 3, sizeof *e, cmp_u64);
  long E = 0, V = 0;
  for (size_t i = 0; i < m->nt * 3; i++) E += i == 0 || e[i] != e[i - 1];
  for (size_t i = 0; i < m->nv; i++) V += used[i];
  free(e);
  free(used);
  return V - E + (long)m->nt;
}

int files_equal(const char *a, const char *b) {
  FILE *fa = fopen(a, "rb"), *fb = fopen(b, "rb");
  int eq = fa && fb;
  while (eq) {
    int ca = fgetc(fa), cb = fgetc(fb);
    if (ca != cb) eq = 0;
    if (ca == EOF || cb == EOF) break;
  }
  if (fa) fclose(fa);
  if (fb) fclose(fb);
  return eq;
}

int run_cmd(const char *cmd, const char *log) {
  size_t n = strlen(cmd) + strlen(log) + 16;
  char *buf = malloc(n);
  if (!buf) return -1;
  snprintf(buf, n, "%s > '%s' 2>&1", cmd, log);
  int st = system(buf);
  free(buf);
  if (st == -1 || !WIFEXITED(st)) return -1;
  return WEXITSTATUS(st);
}

int file_contains(const char *path, const char *needle) {
  FILE *f = fopen(path, "rb");
  if (!f) return 0;
  char buf[65536];
  size_t n = fread(buf, 1, sizeof buf - 1, f);
  fclose(f);
  buf[n] = 0;
  return strstr(buf, needle) != NULL;
}

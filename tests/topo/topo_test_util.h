/* Shared by the tests/topo programs: test fields (dense, voxel (i,j,k) at ((i+.5)/N, ...) in
 * the unit box), the reference runner (tests/topo/reference.py: PHAT / GUDHI) and exact
 * diagram comparison (sorted multisets of (dim, birth, death), persistence > 0). */
#ifndef TOPO_TEST_UTIL_H
#define TOPO_TEST_UTIL_H
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include "mgs_test.h"
#include "topo/mgs_persistence.h"

typedef struct { int dim; double b, d; } tt_pair;

static inline uint32_t tt_hash(uint32_t x) {
  x ^= x >> 16; x *= 0x7feb352dU; x ^= x >> 15; x *= 0x846ca68bU; x ^= x >> 16;
  return x;
}
static inline double tt_noise(uint32_t seed, size_t i) { return (tt_hash(seed * 2654435761U ^ (uint32_t)i * 0x9e3779b9U) & 0xffffff) / 16777216.0 * 2 - 1; }

static inline double tt_torus(double x, double y, double z, double cx, double cy, double cz, double R, double r) {
  double q = sqrt((x - cx) * (x - cx) + (y - cy) * (y - cy)) - R;
  return sqrt(q * q + (z - cz) * (z - cz)) - r;
}
static inline double tt_sphere(double x, double y, double z, double cx, double cy, double cz, double r) {
  return sqrt((x - cx) * (x - cx) + (y - cy) * (y - cy) + (z - cz) * (z - cz)) - r;
}

enum { TT_RANDOM, TT_NOISY_TORUS, TT_SHELLS, TT_GENUS2, TT_FLOATERS, TT_TORUS, TT_TORUS_SHELL,
       TT_SPHERE_SHELL, TT_TUNNEL_BLOCK };
static const char *tt_names[] = {"random", "noisy-torus", "nested-shells", "genus-2", "floaters",
                                 "torus", "torus-shell", "sphere-shell", "tunnel-block"};

/* A dense field of kind `kind` at N^3 (values float). */
static inline float *tt_field(int kind, int N, uint32_t seed) {
  float *f = malloc((size_t)N * N * N * sizeof *f);
  for (int i = 0; i < N; i++)
    for (int j = 0; j < N; j++)
      for (int k = 0; k < N; k++) {
        size_t id = ((size_t)i * N + j) * N + k;
        double x = (i + .5) / N, y = (j + .5) / N, z = (k + .5) / N, v = 0;
        switch (kind) {
        case TT_RANDOM: v = tt_noise(seed, id); break;
        case TT_NOISY_TORUS:
          v = tt_torus(x, y, z, .5, .5, .5, .3, .1) + 0.02 * sin(17 * x + 3 * y) * cos(13 * z) + 0.4 / N * tt_noise(seed, id);
          break;
        case TT_SHELLS: {
          double s = tt_sphere(x, y, z, .5, .5, .5, 0);
          double d1 = fabs(s - .15) - .03, d2 = fabs(s - .3) - .03, d3 = fabs(s - .42) - .025;
          v = fmin(d1, fmin(d2, d3)) + 0.2 / N * tt_noise(seed, id);
          break;
        }
        case TT_GENUS2:
          v = fmin(tt_torus(x, y, z, .32, .5, .5, .18, .07), tt_torus(x, y, z, .68, .5, .5, .18, .07)) + 0.3 / N * tt_noise(seed, id);
          break;
        case TT_FLOATERS: {
          v = tt_torus(x, y, z, .5, .5, .5, .3, .08);
          for (int b = 0; b < 12; b++) {
            double bx = .1 + .8 * (tt_noise(seed + 7, (size_t)b * 3) * .5 + .5), by = .1 + .8 * (tt_noise(seed + 7, (size_t)b * 3 + 1) * .5 + .5),
                   bz = .1 + .8 * (tt_noise(seed + 7, (size_t)b * 3 + 2) * .5 + .5);
            v = fmin(v, tt_sphere(x, y, z, bx, by, bz, 1.2 / N));
          }
          v += 0.3 / N * tt_noise(seed, id);
          break;
        }
        case TT_TORUS: v = tt_torus(x, y, z, .5, .5, .5, .3, .12); break;
        case TT_TORUS_SHELL: v = fabs(tt_torus(x, y, z, .5, .5, .5, .3, .12)) - .04; break;
        case TT_SPHERE_SHELL: v = fabs(tt_sphere(x, y, z, .5, .5, .5, .3)) - .04; break;
        case TT_TUNNEL_BLOCK: {
          /* a thick box [.17,.83]^3 with a tunnel of radius .1 along z: at 64^3 its interior
           * holds whole 8^3 blocks far deeper than a 2-voxel band, and so does the outside */
          double bx = fmax(fabs(x - .5), fmax(fabs(y - .5), fabs(z - .5))) - .33;
          double tun = .1 - sqrt((x - .5) * (x - .5) + (y - .5) * (y - .5));
          v = fmax(bx, tun);
          break;
        }
        }
        f[id] = (float)v;
      }
  return f;
}

/* Persistence of a dense test field through the dense or the sparse (band) path, with the
 * engine's reference switches (full reduction, dimension 2 by reduction). */
static inline mgs_diagram *tt_run(const float *f, int N, double w, int cons_t, int sup, int full_red, int d2_red,
                                  int sparse, mgs_topo_stats *st) {
  mgs_topo_opts o;
  mgs_topo_opts_default(&o);
  o.construction = cons_t ? MGS_TOPO_T : MGS_TOPO_V;
  o.filtration = sup ? MGS_TOPO_SUPERLEVEL : MGS_TOPO_SUBLEVEL;
  o.half_width = w;
  o.full_reduction = full_red;
  o.d2_reduction = d2_red;
  mgs_diagram *d = NULL;
  mgs_error err = {0};
  if (!sparse) {
    CHECK_OK(mgs_topo_persistence_dense_stats(f, N, N, N, &o, &d, st, &err), &err);
  } else {
    mgs_topo_sparse *s = NULL;
    CHECK_OK(mgs_topo_sparse_from_dense(f, N, N, N, (float)w, &s, &err), &err);
    if (s) CHECK_OK(mgs_topo_persistence_sparse(s, &o, &d, st, &err), &err);
    mgs_topo_sparse_destroy(s);
  }
  return d;
}

static inline const char *tt_python(void) {
  const char *p = getenv("MGS_PYTHON");
  if (p && *p) return p;
  return access("/usr/bin/python3", X_OK) == 0 ? "/usr/bin/python3" : "python3";
}

static inline int tt_cmp(const void *pa, const void *pb) {
  const tt_pair *a = pa, *b = pb;
  if (a->dim != b->dim) return a->dim - b->dim;
  if (a->b != b->b) return a->b < b->b ? -1 : 1;
  if (a->d != b->d) return a->d < b->d ? -1 : 1;
  return 0;
}

/* Reference diagram from reference.py; returns count (or -1 on failure). */
static inline long tt_reference(const char *ref, const float *f, int nx, int ny, int nz, int cons, int sup,
                         double w, tt_pair **out) {
  static int counter = 0;
  char path[256];
  snprintf(path, sizeof path, "tt_field_%d_%d.bin", (int)getpid(), counter++);
  FILE *fp = fopen(path, "wb");
  if (!fp) return -1;
  int32_t hdr[5] = {nx, ny, nz, cons, sup};
  fwrite("MGSF", 1, 4, fp);
  fwrite(hdr, sizeof hdr, 1, fp);
  fwrite(&w, sizeof w, 1, fp);
  fwrite(f, sizeof *f, (size_t)nx * ny * nz, fp);
  fclose(fp);
  const char *src = getenv("MGS_SOURCE_DIR");
  char cmd[1024];
  snprintf(cmd, sizeof cmd, "%s '%s/tests/topo/reference.py' --ref %s '%s'", tt_python(), src ? src : "../..", ref, path);
  FILE *p = popen(cmd, "r");
  if (!p) { remove(path); return -1; }
  size_t cap = 1024, n = 0;
  tt_pair *v = malloc(cap * sizeof *v);
  char line[256];
  while (fgets(line, sizeof line, p)) {
    tt_pair q;
    char ds[64];
    if (sscanf(line, "%d %lf %63s", &q.dim, &q.b, ds) != 3) continue;
    q.d = strcmp(ds, "inf") ? strtod(ds, NULL) : INFINITY;
    if (n == cap) v = realloc(v, (cap *= 2) * sizeof *v);
    v[n++] = q;
  }
  int rc = pclose(p);
  remove(path);
  if (rc != 0) { free(v); fprintf(stderr, "reference.py failed (%s)\n", cmd); return -1; }
  qsort(v, n, sizeof *v, tt_cmp);
  *out = v;
  return (long)n;
}

static inline size_t tt_from_diagram(const mgs_diagram *d, tt_pair **out) {
  tt_pair *v = malloc((d->n + 1) * sizeof *v);
  for (size_t i = 0; i < d->n; i++) {
    v[i].dim = d->pairs[i].dim;
    v[i].b = d->pairs[i].birth;
    v[i].d = d->pairs[i].death;
  }
  qsort(v, d->n, sizeof *v, tt_cmp);
  *out = v;
  return d->n;
}

/* Exact equality of two sorted pair lists; prints the first differences. */
static inline int tt_equal(const char *what, const tt_pair *a, size_t na, const tt_pair *b, size_t nb) {
  int ok = na == nb;
  size_t shown = 0;
  for (size_t i = 0; i < (na < nb ? na : nb) && shown < 5; i++)
    if (tt_cmp(&a[i], &b[i]) != 0) {
      ok = 0;
      fprintf(stderr, "  %s: #%zu ours (%d %.9g %.9g) ref (%d %.9g %.9g)\n", what, i, a[i].dim, a[i].b, a[i].d, b[i].dim, b[i].b, b[i].d);
      shown++;
    }
  if (na != nb) fprintf(stderr, "  %s: %zu pairs vs %zu in the reference\n", what, na, nb);
  return ok;
}

/* Betti numbers at level t from a diagram (birth <= t < death). */
static inline void tt_betti(const mgs_diagram *d, double t, int b[3]) {
  b[0] = b[1] = b[2] = 0;
  for (size_t i = 0; i < d->n; i++)
    if (d->pairs[i].birth <= t && t < d->pairs[i].death) b[d->pairs[i].dim]++;
}
#endif

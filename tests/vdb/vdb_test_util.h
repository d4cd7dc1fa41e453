/* Shared helpers of the vdb tests: small Gaussian scenes and ray/zero-crossing search. */
#ifndef VDB_TEST_UTIL_H
#define VDB_TEST_UTIL_H
#include <math.h>
#include <stdio.h>
#include <sys/wait.h>
#include <stdlib.h>
#include <string.h>
#include "core/mgs_gaussians.h"
#include "core/mgs_math.h"
#include "core/mgs_mesh.h"
#include "core/mgs_rng.h"
#include "vdb/mgs_vdb.h"

/* A closed torus mesh around z (radii R, r; nu x nv quads, two triangles each), wound
 * consistently (its signed volume's sign is the tests' to check). */
static inline mgs_mesh *vt_torus_mesh(double R, double r, int nu, int nv) {
  mgs_mesh *m = mgs_mesh_create((size_t)nu * nv, (size_t)2 * nu * nv);
  for (int i = 0; i < nu; i++)
    for (int j = 0; j < nv; j++) {
      double u = 2 * M_PI * i / nu, v = 2 * M_PI * j / nv;
      float *p = m->v + 3 * ((size_t)i * nv + j);
      p[0] = (float)((R + r * cos(v)) * cos(u));
      p[1] = (float)((R + r * cos(v)) * sin(u));
      p[2] = (float)(r * sin(v));
    }
  size_t t = 0;
  for (int i = 0; i < nu; i++)
    for (int j = 0; j < nv; j++) {
      uint32_t a = (uint32_t)(i * nv + j), b = (uint32_t)(((i + 1) % nu) * nv + j);
      uint32_t c = (uint32_t)(((i + 1) % nu) * nv + (j + 1) % nv), d = (uint32_t)(i * nv + (j + 1) % nv);
      uint32_t *T = m->t + 3 * t;
      T[0] = a; T[1] = b; T[2] = c; T[3] = a; T[4] = c; T[5] = d;
      t += 2;
    }
  return m;
}

/* Appends a Gaussian with std-devs s, rotation q (w,x,y,z), opacity alpha. */
/* Runs a CLI command with stdout into cli_out.txt and stderr into cli_stderr.txt (also
 * copied into errbuf, and echoed); returns the exit code. */
static inline int vt_run(const char *cmd, char *errbuf, size_t len) {
  char full[8192];
  snprintf(full, sizeof full, "%s > cli_out.txt 2> cli_stderr.txt", cmd);
  fprintf(stderr, "  $ %s\n", cmd);
  int rc = system(full);
  errbuf[0] = 0;
  FILE *f = fopen("cli_stderr.txt", "r");
  if (f) {
    size_t n = fread(errbuf, 1, len - 1, f);
    errbuf[n] = 0;
    fclose(f);
  }
  if (errbuf[0]) fprintf(stderr, "    stderr: %s", errbuf);
  return rc == -1 ? -1 : WEXITSTATUS(rc);
}

static inline void vt_add(mgs_gaussians *g, double x, double y, double z, const double s[3], const double q[4],
                          double alpha) {
  size_t i = 0;
  mgs_gaussians_append(g, 1, &i, NULL);
  g->mean[3 * i] = (float)x; g->mean[3 * i + 1] = (float)y; g->mean[3 * i + 2] = (float)z;
  for (int k = 0; k < 3; k++) g->log_scale[3 * i + k] = (float)log(s[k]);
  for (int k = 0; k < 4; k++) g->rot[4 * i + k] = (float)q[k];
  g->opacity[i] = (float)log(alpha / (1 - alpha));
}

/* Zero crossing of the trilinearly sampled SDF along origin + t·dir, t in [t0, t1],
 * where the sign changes once (bisection). Returns NAN if there is no sign change. */
static inline double vt_ray_zero(const mgs_vdb_grid *sdf, const double o[3], const double d[3], double t0, double t1) {
  float p[3], v0, v1;
  for (int k = 0; k < 3; k++) p[k] = (float)(o[k] + t0 * d[k]);
  mgs_vdb_sample(sdf, 1, p, &v0);
  for (int k = 0; k < 3; k++) p[k] = (float)(o[k] + t1 * d[k]);
  mgs_vdb_sample(sdf, 1, p, &v1);
  if ((v0 < 0) == (v1 < 0)) return NAN;
  for (int it = 0; it < 60; it++) {
    double tm = 0.5 * (t0 + t1);
    float vm;
    for (int k = 0; k < 3; k++) p[k] = (float)(o[k] + tm * d[k]);
    mgs_vdb_sample(sdf, 1, p, &vm);
    if ((vm < 0) == (v0 < 0)) { t0 = tm; v0 = vm; } else { t1 = tm; }
  }
  return 0.5 * (t0 + t1);
}

/* n random Gaussians in [-1, 1]^3 (seed): std-devs 0.01 + scale_xy (x, y) or scale_z (z)
 * times a uniform draw, random rotations, opacity logits opacity_lo + opacity_span x a
 * uniform draw: floaters, overlaps and thin sheets, the kind of field a trained model
 * gives. Two fixed corners (+-1.2) hold the means' box, so the lattice stays when others
 * move. Exits on allocation failure. */
static inline mgs_gaussians *vt_random_gaussians(size_t n, uint64_t seed, double scale_xy, double scale_z, double opacity_lo,
                                                 double opacity_span) {
  mgs_gaussians *g = mgs_gaussians_create(n, 0);
  size_t first;
  if (!g || mgs_gaussians_append(g, n, &first, NULL)) exit(2);
  mgs_rng r;
  mgs_rng_init(&r, seed, 1);
  for (size_t i = 0; i < n; i++) {
    for (int k = 0; k < 3; k++) {
      g->mean[3 * i + k] = (float)(2 * mgs_rng_uniform(&r) - 1);
      g->log_scale[3 * i + k] = (float)log(0.01 + (k == 2 ? scale_z : scale_xy) * mgs_rng_uniform(&r));
    }
    for (int k = 0; k < 4; k++) g->rot[4 * i + k] = (float)mgs_rng_normal(&r);
    g->opacity[i] = (float)(opacity_span * mgs_rng_uniform(&r) + opacity_lo);
  }
  for (int k = 0; k < 3; k++) { g->mean[k] = -1.2f; g->mean[3 + k] = 1.2f; }
  return g;
}

/* 1 when both grids have the same leaves, masks and values, bit for bit */
static inline int vt_same_leaves(const mgs_vdb_grid *a, const mgs_vdb_grid *b) {
  size_t na = mgs_vdb_leaf_count(a), nb = mgs_vdb_leaf_count(b);
  if (na != nb) return 0;
  mgs_vdb_leaf_view *la = malloc((na + 1) * sizeof *la), *lb = malloc((nb + 1) * sizeof *lb);
  if (!la || !lb) exit(2);
  mgs_vdb_leaf_views(a, la, na);
  mgs_vdb_leaf_views(b, lb, nb);
  int same = 1;
  for (size_t i = 0; i < na && same; i++)
    same = !memcmp(la[i].origin, lb[i].origin, sizeof la[i].origin) && !memcmp(la[i].active_mask, lb[i].active_mask, 64) &&
           !memcmp(la[i].values, lb[i].values, 512 * sizeof(float));
  free(la); free(lb);
  return same;
}
#endif

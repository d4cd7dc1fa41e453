/* Spawn/prune sets: positions of selected pairs (birth vs death placement), components of
 * {d ≤ 0} on a hand-made field with one big component and two small blobs, the floater
 * rule, and the Gaussians whose kσ support touches a component. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "mgs_test.h"
#include "core/mgs_gaussians.h"
#include "topo/mgs_topo_select.h"
#include "vdb/mgs_vdb.h"

#define N 40
static float field[N * N * N], dens[N * N * N];
static const double H = 0.05, T[3] = {-1.0, -0.5, 2.0};
/* shapes in index coordinates: a big ball and two small blobs */
static const double big_c[3] = {14, 20, 20}, big_r = 9;
static const double b1_c[3] = {33, 8, 8}, b1_r = 1.6;
static const double b2_c[3] = {33, 32, 30}, b2_r = 2.2;

static double ball(const double c[3], double r, int x, int y, int z) {
  return sqrt((x - c[0]) * (x - c[0]) + (y - c[1]) * (y - c[1]) + (z - c[2]) * (z - c[2])) - r;
}

static void build_field(void) {
  for (int x = 0; x < N; x++)
    for (int y = 0; y < N; y++)
      for (int z = 0; z < N; z++) {
        double a = ball(big_c, big_r, x, y, z), b = ball(b1_c, b1_r, x, y, z), c = ball(b2_c, b2_r, x, y, z);
        double d = fmin(a, fmin(b, c));
        size_t i = ((size_t)x * N + y) * N + z;
        field[i] = (float)(d * H); /* world units */
        dens[i] = d <= 0 ? (a <= 0 ? 1.0f : 0.2f) : 0.0f;
      }
}

static mgs_topo_field make_field(void) {
  mgs_topo_field f;
  memset(&f, 0, sizeof f);
  f.values = field; f.density = dens;
  f.origin[0] = 10; f.origin[1] = -5; f.origin[2] = 0;
  f.dims[0] = f.dims[1] = f.dims[2] = N;
  f.voxel_size = H;
  memcpy(f.translation, T, sizeof f.translation);
  return f;
}

static size_t count_inside(const double c[3], double r) {
  size_t n = 0;
  for (int x = 0; x < N; x++)
    for (int y = 0; y < N; y++)
      for (int z = 0; z < N; z++) n += ball(c, r, x, y, z) <= 0 && field[((size_t)x * N + y) * N + z] <= 0;
  return n;
}

static void test_components(void) {
  build_field();
  mgs_topo_field f = make_field();
  mgs_topo_components *c = NULL;
  mgs_error e;
  CHECK_OK(mgs_topo_components_dense(&f, 0.0, 6, &c, &e), &e);
  if (!c) return;
  CHECK(c->n == 3);
  size_t nbig = count_inside(big_c, big_r), n1 = count_inside(b1_c, b1_r), n2 = count_inside(b2_c, b2_r);
  CHECK(c->comp[0].n_voxels == nbig);
  CHECK(c->comp[1].n_voxels == n2 && c->comp[2].n_voxels == n1); /* sorted by size */
  CHECK_NEAR(c->comp[0].volume, nbig * H * H * H, 1e-15);
  CHECK_NEAR(c->comp[1].mass, 0.2 * n2 * H * H * H, 1e-9);
  CHECK_NEAR(c->comp[0].mass, 1.0 * nbig * H * H * H, 1e-12);
  /* deepest voxel of the big ball is its centre; the centroid is the centre in world */
  CHECK(c->comp[0].min_voxel[0] == 14 + 10 && c->comp[0].min_voxel[1] == 20 - 5 && c->comp[0].min_voxel[2] == 20);
  CHECK_NEAR(c->comp[0].centroid[0], (14 + 10) * H + T[0], 1e-9);
  CHECK_NEAR(c->comp[0].centroid[1], (20 - 5) * H + T[1], 1e-9);
  CHECK(c->comp[2].lo[0] >= 31 + 10 && c->comp[2].hi[0] <= 35 + 10);
  int32_t at[3] = {33 + 10, 8 - 5, 8};
  CHECK(mgs_topo_component_at(c, at) == 2);
  int32_t out[3] = {0, 0, 0};
  CHECK(mgs_topo_component_at(c, out) == -1);
  /* floater rule: by volume, by mass */
  int32_t ids[3];
  double vsmall = 200 * H * H * H;
  CHECK(mgs_topo_floater_components(c, vsmall, 0, ids) == 2 && ids[0] == 1 && ids[1] == 2);
  CHECK(n1 < n2);
  CHECK(mgs_topo_floater_components(c, 0, 0.2 * H * H * H * 0.5 * (double)(n1 + n2), ids) == 1 && ids[0] == 2);
  CHECK(mgs_topo_floater_components(c, 0, 0, ids) == 0);
  /* 26-connectivity joins nothing here (the blobs are far apart) */
  mgs_topo_components *c26 = NULL;
  CHECK_OK(mgs_topo_components_dense(&f, 0.0, 26, &c26, &e), &e);
  CHECK(c26 && c26->n == 3);
  mgs_topo_components_destroy(c26);
  /* a higher level merges blob 2 into the big ball? distance between surfaces ≈ 24-9-2.2
   * voxels; level 8 voxels = 0.4 → still 3; level 12 voxels → merge */
  CHECK_OK(mgs_topo_components_dense(&f, 12 * H, 6, &c26, &e), &e);
  CHECK(c26 && c26->n <= 2);
  mgs_topo_components_destroy(c26);
  CHECK(mgs_topo_components_dense(&f, 0.0, 8, &c26, &e) == MGS_ERR_ARG);

  /* prune candidates */
  mgs_gaussians *g = mgs_gaussians_create(8, 0);
  size_t first;
  CHECK_OK(mgs_gaussians_append(g, 6, &first, &e), &e);
  double pos[6][3] = {
    {33, 8, 8},     /* 0: inside blob 1 */
    {33, 8, 12.5},  /* 1: 4.5 voxels from blob 1's centre, σ reaches with k=3 */
    {33, 8, 14},    /* 2: too far for k=3 */
    {14, 20, 20},   /* 3: big ball */
    {33, 32, 30},   /* 4: blob 2 */
    {2, 2, 37},     /* 5: nowhere */
  };
  double sig[6] = {0.3, 1.1, 1.1, 2, 0.5, 50};
  for (int i = 0; i < 6; i++) {
    for (int k = 0; k < 3; k++) {
      g->mean[3 * i + k] = (float)((pos[i][k] + f.origin[k]) * H + T[k]);
      g->log_scale[3 * i + k] = (float)log(k == 1 ? sig[i] * H : 0.1 * sig[i] * H); /* max axis = sig */
    }
  }
  /* Gaussian 5 is huge (50 voxels σ): its support covers everything */
  size_t *idx, n;
  int32_t one = 2; /* blob 1 */
  CHECK_OK(mgs_topo_gaussians_touching(c, &one, 1, g, 3.0, &idx, &n, &e), &e);
  /* 1: blob 1's top voxel is z = 9, its cube face at 9.5, 3.0 voxels from the mean:
   * inside 3σ = 3.3, outside 1σ; 2 is 4.5 away */
  int hit[6] = {0};
  for (size_t i = 0; i < n; i++) hit[idx[i]] = 1;
  CHECK(hit[0] && !hit[2] && !hit[3] && !hit[4] && hit[5]);
  CHECK(hit[1]);
  free(idx);
  CHECK_OK(mgs_topo_gaussians_touching(c, &one, 1, g, 1.0, &idx, &n, &e), &e);
  CHECK(n == 2 && idx[0] == 0 && idx[1] == 5);
  free(idx);
  int32_t both[2] = {1, 2};
  CHECK_OK(mgs_topo_gaussians_touching(c, both, 2, g, 1.0, &idx, &n, &e), &e);
  CHECK(n == 3 && idx[0] == 0 && idx[1] == 4 && idx[2] == 5);
  free(idx);
  /* one Gaussian's answer reads nothing of the others (so a caller may ask only some
     rows, e.g. the first answer's): every subset of rows, asked as a
     model of its own, gets the full model's answers for those rows */
  for (int k3 = 0; k3 < 2; k3++) {
    int32_t big = 0, *q = k3 ? both : &big;
    size_t nq = k3 ? 2 : 1, *full = NULL, nfull = 0;
    CHECK_OK(mgs_topo_gaussians_touching(c, q, nq, g, 3.0, &full, &nfull, &e), &e);
    int in_full[6] = {0};
    for (size_t i = 0; i < nfull; i++) in_full[full[i]] = 1;
    for (unsigned mask = 1; mask < 64; mask++) {
      size_t rows[6], nr = 0, *sub_idx = NULL, nsub = 0;
      for (size_t i = 0; i < 6; i++) if (mask & (1u << i)) rows[nr++] = i;
      mgs_gaussians *sub = mgs_gaussians_select(g, rows, nr);
      CHECK(sub != NULL);
      if (!sub) break;
      CHECK_OK(mgs_topo_gaussians_touching(c, q, nq, sub, 3.0, &sub_idx, &nsub, &e), &e);
      int in_sub[6] = {0};
      for (size_t i = 0; i < nsub; i++) in_sub[rows[sub_idx[i]]] = 1;
      for (size_t i = 0; i < nr; i++) CHECK(in_sub[rows[i]] == in_full[rows[i]]);
      free(sub_idx);
      mgs_gaussians_destroy(sub);
    }
    free(full);
  }
  int32_t bad = 7;
  CHECK(mgs_topo_gaussians_touching(c, &bad, 1, g, 1.0, &idx, &n, &e) == MGS_ERR_ARG);
  mgs_gaussians_destroy(g);
  mgs_topo_components_destroy(c);
}

/* The ball-vs-cube test is exact: a Gaussian whose support radius is just below / above
 * the distance to the nearest voxel cube. */
static void test_touch_boundary(void) {
  float v[27];
  for (int i = 0; i < 27; i++) v[i] = 1;
  v[13] = -1; /* the centre voxel (1,1,1) alone */
  mgs_topo_field f;
  memset(&f, 0, sizeof f);
  f.values = v; f.dims[0] = f.dims[1] = f.dims[2] = 3; f.voxel_size = 1;
  mgs_topo_components *c; mgs_error e;
  CHECK_OK(mgs_topo_components_dense(&f, 0, 6, &c, &e), &e);
  CHECK(c->n == 1 && c->comp[0].n_voxels == 1);
  mgs_gaussians *g = mgs_gaussians_create(2, 0);
  size_t first;
  mgs_gaussians_append(g, 2, &first, &e);
  /* mean at x = 1 + 0.5 + 0.75 (cube face at 1.5): distance 0.75 */
  for (int i = 0; i < 2; i++) {
    g->mean[3 * i] = 2.25f; g->mean[3 * i + 1] = 1; g->mean[3 * i + 2] = 1;
    for (int k = 0; k < 3; k++) g->log_scale[3 * i + k] = (float)log(i == 0 ? 0.74 : 0.76);
  }
  int32_t id = 0; size_t *idx, n;
  CHECK_OK(mgs_topo_gaussians_touching(c, &id, 1, g, 1.0, &idx, &n, &e), &e);
  CHECK(n == 1 && idx[0] == 1);
  free(idx);
  mgs_gaussians_destroy(g);
  mgs_topo_components_destroy(c);
}

static void test_positions(void) {
  mgs_diagram *d = mgs_diagram_create();
  mgs_pair p;
  for (int i = 0; i < 5; i++) {
    memset(&p, 0, sizeof p);
    p.dim = i < 2 ? 0 : 1;
    p.birth = -0.1 * i; p.death = i == 0 ? INFINITY : 0.02 * i;
    for (int k = 0; k < 3; k++) { p.b.pos[k] = i + 0.1 * k; p.d.pos[k] = -i - 0.1 * k; }
    mgs_diagram_push(d, &p, NULL);
  }
  /* pairs: 0 H0 essential; 1 H0 (-0.1, 0.02); 2 H1 (-0.2, 0.04); 3 H1 (-0.3, 0.06); 4 H1 (-0.4, 0.08) */
  mgs_diagram_filter f;
  mgs_topo_filter_surface_gaps(&f, 0.25, 0.07);
  double *xyz; size_t *idx, n; mgs_error e;
  CHECK_OK(mgs_topo_select_positions(d, &f, MGS_TOPO_PLACE_DEATH, &xyz, &idx, &n, &e), &e);
  CHECK(n == 1 && idx[0] == 3 && xyz[0] == -3 && xyz[1] == -3.1 && xyz[2] == -3.2);
  free(xyz); free(idx);
  mgs_topo_filter_literal_minima(&f, 0.0);
  CHECK_OK(mgs_topo_select_positions(d, &f, MGS_TOPO_PLACE_BIRTH, &xyz, &idx, &n, &e), &e);
  CHECK(n == 1 && idx[0] == 1 && xyz[0] == 1);
  free(xyz); free(idx);
  mgs_diagram_filter_init(&f);
  f.dim = 0;
  CHECK_OK(mgs_topo_select_positions(d, &f, MGS_TOPO_PLACE_DEATH, &xyz, NULL, &n, &e), &e);
  CHECK(n == 1 && xyz[0] == -1); /* the essential class has no death cell */
  free(xyz);
  CHECK_OK(mgs_topo_select_positions(d, &f, MGS_TOPO_PLACE_BIRTH, &xyz, NULL, &n, &e), &e);
  CHECK(n == 2 && xyz[0] == 0 && xyz[3] == 1);
  free(xyz);
  f.dim = 2;
  CHECK_OK(mgs_topo_select_positions(d, &f, MGS_TOPO_PLACE_BIRTH, &xyz, &idx, &n, &e), &e);
  CHECK(n == 0 && xyz == NULL && idx == NULL);
  mgs_diagram_destroy(d);
}

/* Same components through a VDB level set built from the dense field. */
static void test_components_vdb(void) {
  build_field();
  mgs_topo_field f = make_field();
  mgs_error e;
  mgs_vdb_grid *sdf = NULL, *fog = NULL;
  float bg = (float)(3 * H);
  float *clamped = malloc(sizeof field);
  for (size_t i = 0; i < (size_t)N * N * N; i++) clamped[i] = fminf(fmaxf(field[i], -bg), bg);
  CHECK_OK(mgs_vdb_grid_from_dense("sdf", MGS_VDB_CLASS_LEVEL_SET, H, T, bg, f.origin, f.dims, clamped, &sdf, &e), &e);
  CHECK_OK(mgs_vdb_grid_from_dense("density", MGS_VDB_CLASS_FOG, H, T, 0.0f, f.origin, f.dims, dens, &fog, &e), &e);
  mgs_topo_components *c = NULL, *cd = NULL;
  CHECK_OK(mgs_topo_components_vdb(sdf, fog, 0.0, 6, 0, &c, &e), &e);
  f.values = clamped; /* the grid holds the clamped field */
  CHECK_OK(mgs_topo_components_dense(&f, 0.0, 6, &cd, &e), &e);
  if (c && cd) {
    CHECK(c->n == cd->n);
    for (size_t i = 0; i < c->n && i < cd->n; i++) {
      CHECK(c->comp[i].n_voxels == cd->comp[i].n_voxels);
      CHECK_NEAR(c->comp[i].mass, cd->comp[i].mass, 1e-9);
      CHECK_NEAR(c->comp[i].centroid[0], cd->comp[i].centroid[0], 1e-9);
      CHECK(c->comp[i].min_value == cd->comp[i].min_value);
    }
  }
  mgs_topo_components *none = NULL;
  CHECK(mgs_topo_components_vdb(sdf, NULL, 0.0, 6, 1000, &none, &e) == MGS_ERR_NOMEM && none == NULL);
  mgs_topo_components_destroy(c); mgs_topo_components_destroy(cd);
  mgs_vdb_grid_destroy(sdf); mgs_vdb_grid_destroy(fog);
  free(clamped);
}

int main(void) {
  RUN(test_components);
  RUN(test_touch_boundary);
  RUN(test_positions);
  RUN(test_components_vdb);
  return mgs_test_finish();
}

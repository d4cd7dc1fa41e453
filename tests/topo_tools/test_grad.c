/* Topological losses (eliminate, literal) against finite differences on hand-made
 * diagrams, and the Brüel-Gabrielsson map of end gradients to voxels. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "mgs_test.h"
#include "topo/mgs_topo_grad.h"

static void add(mgs_diagram *d, int dim, double b, double de, int32_t bx, int32_t dx) {
  mgs_pair p;
  memset(&p, 0, sizeof p);
  p.dim = dim; p.birth = b; p.death = de;
  p.b.voxel[0] = bx; p.b.voxel[1] = 1; p.b.voxel[2] = 2;
  p.d.voxel[0] = dx; p.d.voxel[1] = 1; p.d.voxel[2] = 2;
  mgs_diagram_push(d, &p, NULL);
}

/* Pairs away from the kinks (p = ε) so central differences are valid. */
static mgs_diagram *sample(void) {
  mgs_diagram *d = mgs_diagram_create();
  add(d, 0, -0.30, INFINITY, 0, 0);  /* essential: no term */
  add(d, 0, -0.10, -0.07, 1, 2);     /* p 0.03 < ε */
  add(d, 1, 0.02, 0.09, 3, 4);       /* p 0.07 < ε */
  add(d, 1, -0.2, 0.3, 5, 6);        /* p 0.5 > ε */
  add(d, 2, 0.11, 0.12, 7, 8);       /* p 0.01 */
  add(d, 2, 0.4, 0.4, 9, 10);        /* p 0: a zero-length bar */
  return d;
}

static void check_fd(mgs_topo_loss_kind kind, unsigned mask) {
  const double eps = 0.1, h = 1e-6;
  mgs_diagram *d = sample();
  size_t n = d->n;
  double *gb = malloc(n * sizeof *gb), *gd = malloc(n * sizeof *gd);
  mgs_topo_loss(d, kind, eps, mask, gb, gd);
  int bad = 0;
  for (size_t i = 0; i < n; i++)
    for (int end = 0; end < 2; end++) {
      double *v = end ? &d->pairs[i].death : &d->pairs[i].birth;
      if (!isfinite(*v)) { if ((end ? gd : gb)[i] != 0) bad++; continue; }
      double v0 = *v;
      *v = v0 + h; double lp = mgs_topo_loss(d, kind, eps, mask, NULL, NULL);
      *v = v0 - h; double lm = mgs_topo_loss(d, kind, eps, mask, NULL, NULL);
      *v = v0;
      double fd = (lp - lm) / (2 * h), an = (end ? gd : gb)[i];
      if (fabs(fd - an) > 1e-6) { bad++; fprintf(stderr, "pair %zu end %d: fd %.9g analytic %.9g\n", i, end, fd, an); }
    }
  CHECK_MSG(bad == 0, "%d gradient mismatches (kind %d, mask %u)", bad, (int)kind, mask);
  free(gb); free(gd);
  mgs_diagram_destroy(d);
}

static void test_fd(void) {
  check_fd(MGS_TOPO_LOSS_ELIMINATE, 7);
  check_fd(MGS_TOPO_LOSS_LITERAL, 7);
  check_fd(MGS_TOPO_LOSS_ELIMINATE, 2);
  check_fd(MGS_TOPO_LOSS_LITERAL, 5);
}

static void test_values_and_signs(void) {
  mgs_diagram *d = sample();
  double gb[6], gd[6];
  double e = mgs_topo_loss(d, MGS_TOPO_LOSS_ELIMINATE, 0.1, 7, gb, gd);
  CHECK_NEAR(e, 0.03 * 0.03 + 0.07 * 0.07 + 0.01 * 0.01, 1e-15);
  /* eliminate shortens short bars: gradient descent raises the birth, lowers the death */
  CHECK(gd[1] > 0 && gb[1] < 0 && gd[3] == 0 && gb[3] == 0 && gd[0] == 0 && gb[0] == 0);
  CHECK(gd[5] == 0 && gb[5] == 0); /* p = 0: nothing left to shorten */
  double l = mgs_topo_loss(d, MGS_TOPO_LOSS_LITERAL, 0.1, 7, gb, gd);
  CHECK_NEAR(l, 0.07 * 0.07 + 0.03 * 0.03 + 0.09 * 0.09 + 0.1 * 0.1, 1e-15);
  /* literal (as printed) lengthens them: the opposite sign, largest for the shortest */
  CHECK(gd[1] < 0 && gb[1] > 0 && gd[3] == 0);
  CHECK(fabs(gd[5]) > fabs(gd[4]) && fabs(gd[4]) > fabs(gd[1]) && fabs(gd[1]) > fabs(gd[2]));
  /* dimension mask: only H1 */
  CHECK_NEAR(mgs_topo_loss(d, MGS_TOPO_LOSS_ELIMINATE, 0.1, 2, gb, gd), 0.0049, 1e-15);
  CHECK(gb[1] == 0 && gd[4] == 0 && gd[2] != 0);
  /* at the kink p == ε the eliminate term is outside (p < ε strict) */
  mgs_diagram *k = mgs_diagram_create();
  add(k, 0, 0.0, 0.1, 0, 0);
  CHECK(mgs_topo_loss(k, MGS_TOPO_LOSS_ELIMINATE, 0.1, 7, NULL, NULL) == 0.0);
  CHECK(mgs_topo_loss(k, MGS_TOPO_LOSS_LITERAL, 0.1, 7, NULL, NULL) == 0.0);
  mgs_diagram_destroy(k);
  mgs_diagram_destroy(d);
}

static void test_voxel_map(void) {
  mgs_diagram *d = sample();
  size_t n = d->n;
  double gb[6], gd[6];
  for (size_t i = 0; i < n; i++) { gb[i] = 1.0 + (double)i; gd[i] = -10.0 * (1.0 + (double)i); }
  /* a shared voxel: pair 2's death voxel = pair 3's birth voxel */
  d->pairs[2].d.voxel[0] = 5;
  mgs_voxel_grad *v;
  size_t m;
  mgs_error e;
  CHECK_OK(mgs_topo_grad_to_voxels(d, gb, gd, INFINITY, &v, &m, &e), &e);
  /* ends: birth voxels x=0,1,3,5,7,9 ; death voxels 2,5(shared),6,8,10 (essential none) */
  CHECK(m == 10);
  double expect[11] = {0};
  for (size_t i = 0; i < n; i++) {
    expect[d->pairs[i].b.voxel[0]] += gb[i];
    if (isfinite(d->pairs[i].death)) expect[d->pairs[i].d.voxel[0]] += gd[i];
  }
  int bad = 0;
  for (size_t i = 0; i < m; i++) {
    if (v[i].ijk[1] != 1 || v[i].ijk[2] != 2) bad++;
    if (v[i].grad != expect[v[i].ijk[0]]) bad++;
    if (i && v[i].ijk[0] <= v[i - 1].ijk[0]) bad++; /* sorted, unique */
  }
  CHECK(bad == 0);
  CHECK(v[4].ijk[0] == 5 && v[4].grad == gb[3] + gd[2]);
  free(v);
  /* clamp: ends at |value| ≥ w get nothing */
  CHECK_OK(mgs_topo_grad_to_voxels(d, gb, gd, 0.3, &v, &m, &e), &e);
  for (size_t i = 0; i < m; i++) CHECK(v[i].ijk[0] != 0 && v[i].ijk[0] != 9 && v[i].ijk[0] != 10 && v[i].ijk[0] != 6);
  CHECK(m == 6);
  free(v);
  /* dense accumulation into a box */
  int32_t origin[3] = {-1, 0, 0}, dims[3] = {13, 2, 3};
  double *g = calloc(13 * 2 * 3, sizeof *g);
  for (size_t i = 0; i < 13 * 2 * 3; i++) g[i] = 0.5; /* += semantics */
  CHECK_OK(mgs_topo_grad_to_dense(d, gb, gd, INFINITY, origin, dims, g, &e), &e);
  bad = 0;
  for (int x = 0; x < 13; x++)
    for (int y = 0; y < 2; y++)
      for (int z = 0; z < 3; z++) {
        double want = 0.5 + ((y == 1 && z == 2 && x - 1 >= 0 && x - 1 <= 10) ? expect[x - 1] : 0);
        if (g[(x * 2 + y) * 3 + z] != want) bad++;
      }
  CHECK(bad == 0);
  /* an end outside the box: error, array untouched */
  int32_t small[3] = {4, 1, 1};
  double before = g[0];
  CHECK(mgs_topo_grad_to_dense(d, gb, gd, INFINITY, origin, small, g, &e) == MGS_ERR_ARG);
  CHECK(strstr(e.msg, "outside") != NULL && g[0] == before);
  free(g);
  /* NULL gradients: nothing */
  CHECK_OK(mgs_topo_grad_to_voxels(d, NULL, NULL, INFINITY, &v, &m, &e), &e);
  CHECK(m == 0 && v == NULL);
  mgs_diagram_destroy(d);
}

/* The whole hook on a tiny 1D-like field: loss(field) through the diagram's ends equals
 * a finite difference of the loss wrt a voxel value when the pairing does not change. */
static void test_chain_fd(void) {
  /* field values at voxels 0..4; pair (birth at voxel 1, death at voxel 2) */
  double f[5] = {0.3, -0.05, 0.02, 0.5, 0.6};
  const double eps = 0.1, h = 1e-7;
  for (int kind = 0; kind < 2; kind++) {
    mgs_diagram *d = mgs_diagram_create();
    add(d, 0, f[1], f[2], 1, 2);
    double gb[1], gd[1];
    mgs_topo_loss(d, (mgs_topo_loss_kind)kind, eps, 7, gb, gd);
    mgs_voxel_grad *v; size_t m; mgs_error e;
    CHECK_OK(mgs_topo_grad_to_voxels(d, gb, gd, INFINITY, &v, &m, &e), &e);
    CHECK(m == 2);
    for (size_t i = 0; i < m; i++) {
      int x = v[i].ijk[0];
      double save = f[x];
      f[x] = save + h; d->pairs[0].birth = f[1]; d->pairs[0].death = f[2];
      double lp = mgs_topo_loss(d, (mgs_topo_loss_kind)kind, eps, 7, NULL, NULL);
      f[x] = save - h; d->pairs[0].birth = f[1]; d->pairs[0].death = f[2];
      double lm = mgs_topo_loss(d, (mgs_topo_loss_kind)kind, eps, 7, NULL, NULL);
      f[x] = save; d->pairs[0].birth = f[1]; d->pairs[0].death = f[2];
      CHECK_NEAR(v[i].grad, (lp - lm) / (2 * h), 1e-6);
    }
    free(v);
    mgs_diagram_destroy(d);
  }
}

int main(void) {
  RUN(test_fd);
  RUN(test_values_and_signs);
  RUN(test_voxel_map);
  RUN(test_chain_fd);
  return mgs_test_finish();
}

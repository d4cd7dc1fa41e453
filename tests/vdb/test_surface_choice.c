/* The no-ground-truth choice between two surfaces (measure/mgs_surface_choice.h) on shapes
 * with known distances: points on the unit sphere against the sphere itself (score ~ the
 * mesh's chord error), the sphere grown by 0.05 (a surface displaced from what the views see:
 * both directions ~0.05), and the sphere plus an inner sheet of radius 0.5 (nothing sees it:
 * from-surface ~ half the vertices at the cap). The exact sphere wins against either, in
 * either argument order; distances beyond the cap count as the cap; an empty surface scores
 * the cap and loses; no points is an error. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "core/mgs_mesh.h"
#include "measure/mgs_surface_choice.h"
#include "mgs_test.h"

/* A UV sphere of radius r, plus (inner > 0) a second one of radius inner. */
static mgs_mesh *spheres(double r, double inner) {
  enum { NU = 128, NV = 64 };
  const int shells = inner > 0 ? 2 : 1;
  const size_t nv1 = (size_t)NU * (NV - 1) + 2, nt1 = (size_t)2 * NU * (NV - 1);
  mgs_mesh *m = mgs_mesh_create(shells * nv1, shells * nt1);
  size_t t = 0;
  for (int s = 0; s < shells; s++) {
    const double rad = s ? inner : r;
    const uint32_t b0 = (uint32_t)(s * nv1);
    size_t k = b0;
    for (int j = 1; j < NV; j++)
      for (int i = 0; i < NU; i++, k++) {
        const double th = M_PI * j / NV, ph = 2 * M_PI * i / NU;
        m->v[3 * k] = (float)(rad * sin(th) * cos(ph));
        m->v[3 * k + 1] = (float)(rad * sin(th) * sin(ph));
        m->v[3 * k + 2] = (float)(rad * cos(th));
      }
    const uint32_t top = (uint32_t)k, bot = (uint32_t)k + 1;
    m->v[3 * top] = m->v[3 * top + 1] = m->v[3 * bot] = m->v[3 * bot + 1] = 0;
    m->v[3 * top + 2] = (float)rad;
    m->v[3 * bot + 2] = (float)-rad;
    for (int i = 0; i < NU; i++) {
      const uint32_t a = b0 + (uint32_t)i, b = b0 + (uint32_t)((i + 1) % NU), o = (uint32_t)((NV - 2) * NU);
      m->t[3 * t] = top; m->t[3 * t + 1] = a; m->t[3 * t + 2] = b; t++;
      m->t[3 * t] = bot; m->t[3 * t + 1] = o + b; m->t[3 * t + 2] = o + a; t++;
    }
    for (int j = 0; j < NV - 2; j++)
      for (int i = 0; i < NU; i++) {
        const uint32_t a = b0 + (uint32_t)(j * NU + i), b = b0 + (uint32_t)(j * NU + (i + 1) % NU), c = a + NU, d = b + NU;
        m->t[3 * t] = a; m->t[3 * t + 1] = c; m->t[3 * t + 2] = b; t++;
        m->t[3 * t] = b; m->t[3 * t + 1] = c; m->t[3 * t + 2] = d; t++;
      }
  }
  m->nt = t;
  return m;
}

int main(void) {
  enum { N = 20000 };
  float *pts = malloc(3 * N * sizeof(float));
  const double golden = M_PI * (3.0 - sqrt(5.0));
  for (int i = 0; i < N; i++) { /* Fibonacci points on the unit sphere: "the rendered surface" */
    const double z = 1 - 2 * (i + 0.5) / N, rr = sqrt(1 - z * z), ph = golden * i;
    pts[3 * i] = (float)(rr * cos(ph)); pts[3 * i + 1] = (float)(rr * sin(ph)); pts[3 * i + 2] = (float)z;
  }
  mgs_mesh *exact = spheres(1.0, 0), *grown = spheres(1.05, 0), *sheet = spheres(1.0, 0.5);
  const double cap = 0.2;
  mgs_error err = {0};
  mgs_surface_agreement a, b, c;
  CHECK_OK(mgs_surface_agreement_measure(pts, N, exact, cap, &a, &err), &err);
  CHECK_OK(mgs_surface_agreement_measure(pts, N, grown, cap, &b, &err), &err);
  CHECK_OK(mgs_surface_agreement_measure(pts, N, sheet, cap, &c, &err), &err);
  fprintf(stderr, "exact %.5f/%.5f grown %.5f/%.5f sheet %.5f/%.5f\n", a.to_surface, a.from_surface, b.to_surface,
          b.from_surface, c.to_surface, c.from_surface);
  /* exact: points -> surface is the chord error (< 1 - cos(pi/64) ~ 1.2e-3); vertices ->
   * points the Fibonacci spacing (~sqrt(4 pi / N) / 2 ~ 0.0125 at most) */
  CHECK(a.to_surface < 1.3e-3);
  CHECK(a.from_surface < 0.0125);
  CHECK(fabs(a.score - 0.5 * (a.to_surface + a.from_surface)) < 1e-12);
  /* grown by 0.05: both directions about 0.05 */
  CHECK(fabs(b.to_surface - 0.05) < 2e-3);
  CHECK(b.from_surface > 0.049 && b.from_surface < 0.056);
  /* the inner sheet: to_surface as exact; half of the vertices (the inner sphere's) at the
   * cap: 0.5 from every point, counted as 0.2 */
  CHECK(fabs(c.to_surface - a.to_surface) < 1e-6);
  CHECK(fabs(c.from_surface - 0.5 * (a.from_surface + cap)) < 2e-3);
  /* the choice, both argument orders (1 = the second, "alpha", wins) */
  CHECK(mgs_surface_choose(pts, N, exact, grown, cap, NULL, NULL, &err) == 0);
  CHECK(mgs_surface_choose(pts, N, grown, exact, cap, NULL, NULL, &err) == 1);
  CHECK(mgs_surface_choose(pts, N, sheet, exact, cap, NULL, NULL, &err) == 1);
  CHECK(mgs_surface_choose(pts, N, exact, sheet, cap, NULL, NULL, &err) == 0);
  /* the cap: a tiny cap bounds both directions */
  CHECK_OK(mgs_surface_agreement_measure(pts, N, grown, 0.01, &b, &err), &err);
  CHECK(fabs(b.to_surface - 0.01) < 1e-9 && fabs(b.from_surface - 0.01) < 1e-9);
  /* an empty surface: the cap, and it loses */
  mgs_mesh *empty = mgs_mesh_create(0, 0);
  CHECK_OK(mgs_surface_agreement_measure(pts, N, empty, cap, &b, &err), &err);
  CHECK(b.score == cap);
  CHECK(mgs_surface_choose(pts, N, empty, grown, cap, NULL, NULL, &err) == 1);
  CHECK(mgs_surface_choose(pts, N, grown, NULL, cap, NULL, NULL, &err) == 0);
  /* no points, or no cap: errors */
  CHECK(mgs_surface_agreement_measure(pts, 0, exact, cap, &b, &err) == MGS_ERR_ARG);
  CHECK(mgs_surface_agreement_measure(pts, N, exact, 0, &b, &err) == MGS_ERR_ARG);
  CHECK(mgs_surface_choose(pts, 0, exact, grown, cap, NULL, NULL, &err) == -1);
  mgs_mesh_destroy(empty);
  mgs_mesh_destroy(exact);
  mgs_mesh_destroy(grown);
  mgs_mesh_destroy(sheet);
  free(pts);
  return mgs_test_finish();
}

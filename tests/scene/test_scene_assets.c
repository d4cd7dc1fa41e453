/* Builtin scenes: each is closed and manifold, faces outward, and has the topology its
 * name promises (sphere: genus 0; genus2: Euler characteristic -2 in one part; thin:
 * many parts including small floaters). Also: determinism and an unknown name. */
#include <string.h>
#include "mgs_test.h"
#include "scene_test_util.h"
#include "assets/mgs_assets.h"

static mgs_mesh *make(const char *name) {
  mgs_error err;
  mgs_mesh *m = NULL;
  CHECK_OK(mgs_assets_builtin(name, &m, &err), &err);
  return m;
}

static void test_sphere(void) {
  mgs_mesh *m = make("sphere");
  if (!m) return;
  CHECK(m->nt > 1000);
  CHECK(mgs_mesh_count_boundary_or_nonmanifold_edges(m) == 0);
  CHECK(mesh_components(m) == 1);
  CHECK(mesh_euler(m) == 2);
  CHECK(mgs_mesh_signed_volume(m) > 1.0); /* ~ 4/3 pi 0.8^3 = 2.1, outward */
  mgs_mesh_destroy(m);
}

static void test_genus2(void) {
  mgs_mesh *m = make("genus2");
  if (!m) return;
  CHECK(mgs_mesh_count_boundary_or_nonmanifold_edges(m) == 0);
  CHECK(mesh_components(m) == 1);
  long chi = mesh_euler(m);
  CHECK_MSG(chi == -2, "Euler characteristic %ld, want -2 (genus 2)", chi);
  CHECK(mgs_mesh_signed_volume(m) > 0.1);
  mgs_mesh_destroy(m);
}

static void test_thin(void) {
  mgs_mesh *m = make("thin");
  if (!m) return;
  CHECK(mgs_mesh_count_boundary_or_nonmanifold_edges(m) == 0);
  size_t parts = mesh_components(m);
  CHECK_MSG(parts >= 3, "%zu parts", parts);
  CHECK(parts == 14);
  /* Each part is a sphere or a torus: chi = 2 * (spheres) + 0 * (tori) = 2 * 13. */
  CHECK(mesh_euler(m) == 26);
  CHECK(mgs_mesh_signed_volume(m) > 0);
  /* Thin: the bounding box is big but the volume is tiny. */
  double lo[3], hi[3];
  mgs_mesh_bounds(m, lo, hi);
  double box = (hi[0] - lo[0]) * (hi[1] - lo[1]) * (hi[2] - lo[2]);
  CHECK(mgs_mesh_signed_volume(m) < 0.1 * box);
  mgs_mesh_destroy(m);
}

static void test_detail_and_determinism(void) {
  mgs_error err;
  for (size_t i = 0; i < mgs_assets_builtin_count(); i++) {
    const char *name = mgs_assets_builtin_name(i);
    mgs_mesh *a = NULL, *b = NULL, *fine = NULL;
    CHECK_OK(mgs_assets_builtin(name, &a, &err), &err);
    CHECK_OK(mgs_assets_builtin(name, &b, &err), &err);
    CHECK_OK(mgs_assets_builtin_detail(name, 2, &fine, &err), &err);
    if (a && b && fine) {
      CHECK(a->nv == b->nv && a->nt == b->nt);
      CHECK(!memcmp(a->v, b->v, a->nv * 12) && !memcmp(a->t, b->t, a->nt * 12));
      CHECK_MSG(fine->nt > 3 * a->nt, "%s: detail 2 has %zu triangles vs %zu", name, fine->nt, a->nt);
      CHECK(mgs_mesh_count_boundary_or_nonmanifold_edges(fine) == 0);
      CHECK(mesh_euler(fine) == mesh_euler(a));
    }
    mgs_mesh_destroy(a);
    mgs_mesh_destroy(b);
    mgs_mesh_destroy(fine);
  }
  CHECK(mgs_assets_builtin_count() >= 3);
  CHECK(mgs_assets_builtin_name(mgs_assets_builtin_count()) == NULL);
}

static void test_unknown(void) {
  mgs_error err;
  mgs_mesh *m = (mgs_mesh *)1;
  CHECK(mgs_assets_builtin("teapot", &m, &err) == MGS_ERR_ARG);
  CHECK(m == NULL);
  CHECK(strstr(err.msg, "teapot") != NULL);
  CHECK(mgs_assets_builtin_detail("sphere", 0, &m, &err) == MGS_ERR_ARG);
}

int main(void) {
  RUN(test_sphere);
  RUN(test_genus2);
  RUN(test_thin);
  RUN(test_detail_and_determinism);
  RUN(test_unknown);
  return mgs_test_finish();
}

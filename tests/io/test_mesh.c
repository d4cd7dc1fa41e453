/* Mesh I/O (assimp reader; PLY/OBJ/OFF writer) and measures. */
#include <unistd.h>

#include "core/mgs_mesh.h"
#include "io_test_util.h"
#include "mgs_test.h"

static const char *dir;
static char pbuf[4096];
static const char *tmp_path(const char *name) {
  snprintf(pbuf, sizeof pbuf, "%s/%s", dir, name);
  return pbuf;
}

static mgs_mesh *octahedron(void) {
  static const float v[] = {1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1};
  static const uint32_t t[] = {0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5};
  mgs_mesh *m = mgs_mesh_create(6, 8);
  memcpy(m->v, v, sizeof v);
  memcpy(m->t, t, sizeof t);
  return m;
}

/* Canonical text of a triangle: its three corner positions rotated so the smallest comes
 * first (orientation kept); a mesh's triangles compared as a sorted list of these. */
typedef struct { float c[9]; } tri_key;
static int key_cmp(const void *a, const void *b) { return memcmp(a, b, sizeof(tri_key)); }
static tri_key *tri_keys(const mgs_mesh *m) {
  tri_key *k = calloc(m->nt, sizeof *k);
  for (size_t t = 0; t < m->nt; t++) {
    int best = 0;
    for (int j = 1; j < 3; j++)
      if (memcmp(m->v + 3 * m->t[t * 3 + j], m->v + 3 * m->t[t * 3 + best], 12) < 0) best = j;
    for (int j = 0; j < 3; j++) memcpy(k[t].c + 3 * j, m->v + 3 * m->t[t * 3 + (best + j) % 3], 12);
  }
  qsort(k, m->nt, sizeof *k, key_cmp);
  return k;
}

static void test_round_trip(void) {
  mgs_mesh *m = octahedron();
  CHECK(mgs_mesh_count_boundary_or_nonmanifold_edges(m) == 0);
  CHECK_NEAR(mgs_mesh_area(m), 8 * sqrt(3.0) / 2, 1e-6); /* 8 equilateral triangles of side sqrt 2 */
  const char *names[] = {"o.ply", "o.obj", "o.off", "O.PLY"};
  for (int i = 0; i < 4; i++) {
    mgs_error err = {0};
    CHECK_OK(mgs_mesh_write(tmp_path(names[i]), m, &err), &err);
    mgs_mesh *r = NULL;
    CHECK_OK(mgs_mesh_read(tmp_path(names[i]), &r, &err), &err);
    if (!r) continue;
    CHECK_MSG(r->nv == 6 && r->nt == 8, "%s: %zu vertices %zu triangles", names[i], r->nv, r->nt);
    if (r->nt == 8) {
      tri_key *a = tri_keys(m), *b = tri_keys(r);
      CHECK_MSG(memcmp(a, b, sizeof *a * 8) == 0, "%s: triangles differ (order/orientation)", names[i]);
      free(a);
      free(b);
    }
    CHECK(mgs_mesh_count_boundary_or_nonmanifold_edges(r) == 0);
    mgs_mesh_destroy(r);
  }
  mgs_mesh_destroy(m);
}

static void test_obj_quads_and_measures(void) {
  /* a unit cube of quads with per-face normals: triangulated, welded, closed */
  const char *obj =
      "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
      "vn 0 0 -1\nvn 0 0 1\nvn 0 -1 0\nvn 0 1 0\nvn -1 0 0\nvn 1 0 0\n"
      "f 1//1 4//1 3//1 2//1\nf 5//2 6//2 7//2 8//2\nf 1//3 2//3 6//3 5//3\nf 4//4 8//4 7//4 3//4\n"
      "f 1//5 5//5 8//5 4//5\nf 2//6 3//6 7//6 6//6\n";
  io_write_text(tmp_path("cube.obj"), obj);
  mgs_mesh *m = NULL;
  mgs_error err = {0};
  CHECK_OK(mgs_mesh_read(tmp_path("cube.obj"), &m, &err), &err);
  if (!m) return;
  CHECK(m->nt == 12 && m->nv == 8);
  CHECK_NEAR(mgs_mesh_area(m), 6, 1e-6);
  CHECK(mgs_mesh_count_boundary_or_nonmanifold_edges(m) == 0);
  double lo[3], hi[3], c[3];
  mgs_mesh_bounds(m, lo, hi);
  CHECK(lo[0] == 0 && hi[2] == 1);
  double s = mgs_mesh_normalize(m, 2.0, c);
  CHECK_NEAR(s, 2, 1e-12);
  CHECK_NEAR(c[1], 0.5, 1e-12);
  mgs_mesh_bounds(m, lo, hi);
  CHECK_NEAR(lo[0], -1, 1e-6);
  CHECK_NEAR(hi[1], 1, 1e-6);
  CHECK_NEAR(mgs_mesh_area(m), 24, 1e-5);
  /* drop two triangles: an open box has 4 boundary edges... plus none non-manifold */
  m->nt -= 2;
  CHECK(mgs_mesh_count_boundary_or_nonmanifold_edges(m) == 4);
  mgs_mesh_destroy(m);
  /* three triangles on one edge: non-manifold */
  const char *off = "OFF\n5 3 0\n0 0 0\n1 0 0\n0 1 0\n0 -1 0\n0 0 1\n3 0 1 2\n3 1 0 3\n3 0 1 4\n";
  io_write_text(tmp_path("fan.off"), off);
  m = NULL;
  CHECK_OK(mgs_mesh_read(tmp_path("fan.off"), &m, &err), &err);
  if (m) {
    CHECK(m->nv == 5 && m->nt == 3);
    CHECK(mgs_mesh_count_boundary_or_nonmanifold_edges(m) == 7); /* 6 boundary + 1 shared by three */
    mgs_mesh_destroy(m);
  }
}

static void expect_fail(const char *name, const char *content, mgs_status want) {
  io_write_text(tmp_path(name), content);
  mgs_mesh *m = NULL;
  mgs_error err = {0};
  mgs_status s = mgs_mesh_read(tmp_path(name), &m, &err);
  CHECK_MSG(s == want, "%s: status %s (%s)", name, mgs_status_name(s), err.msg);
  CHECK(m == NULL);
  CHECK_MSG(strstr(err.msg, name) != NULL, "message does not name the file: %s", err.msg);
  mgs_mesh_destroy(m);
}

static void test_bad(void) {
  expect_fail("empty.obj", "# nothing here\n", MGS_ERR_FORMAT);
  expect_fail("points_only.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n", MGS_ERR_FORMAT);
  expect_fail("bad_index.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n", MGS_ERR_FORMAT);
  expect_fail("garbage.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nend_header\n1\n", MGS_ERR_FORMAT);
  expect_fail("empty.off", "", MGS_ERR_FORMAT);
  mgs_mesh *m = NULL;
  mgs_error err = {0};
  CHECK(mgs_mesh_read(tmp_path("missing.obj"), &m, &err) == MGS_ERR_IO && strstr(err.msg, "missing.obj"));
  /* writer refuses bad meshes and leaves nothing behind */
  mgs_mesh *o = octahedron();
  o->t[5] = 99;
  CHECK(mgs_mesh_write(tmp_path("bad_out.ply"), o, &err) == MGS_ERR_ARG && access(tmp_path("bad_out.ply"), F_OK) != 0);
  o->t[5] = 1;
  o->v[4] = NAN;
  CHECK(mgs_mesh_write(tmp_path("bad_out.obj"), o, &err) == MGS_ERR_NUMERIC && access(tmp_path("bad_out.obj"), F_OK) != 0);
  CHECK(strstr(err.msg, "bad_out.obj") && strstr(err.msg, "vertex 1"));
  o->v[4] = 0;
  CHECK(mgs_mesh_write(tmp_path("x.stl"), o, &err) == MGS_ERR_ARG);
  mgs_mesh_destroy(o);
}

int main(void) {
  dir = mgs_test_tmpdir("io_mesh");
  RUN(test_round_trip);
  RUN(test_obj_quads_and_measures);
  RUN(test_bad);
  return mgs_test_finish();
}

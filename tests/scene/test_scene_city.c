/* The city builtin and its camera rig: content grows as N^2 while what one view sees
 * does not (the property the scale benchmark rests on). */
#include "tests/mgs_test.h"
#include "assets/mgs_assets.h"
#include "render/mgs_scene.h"
#include "core/mgs_mesh.h"

static void test_city_mesh(void) {
  mgs_error err;
  mgs_mesh *m1 = NULL, *m2 = NULL;
  CHECK_OK(mgs_assets_city(1, 1, &m1, &err), &err);
  CHECK_OK(mgs_assets_city(2, 1, &m2, &err), &err);
  if (!m1 || !m2) return;
  /* closed parts (each instance copied whole), 4x the triangles (ground box aside) */
  CHECK(mgs_mesh_count_boundary_or_nonmanifold_edges(m1) == 0);
  CHECK(mgs_mesh_count_boundary_or_nonmanifold_edges(m2) == 0);
  CHECK(m2->nt - 12 > 3 * (m1->nt - 12) && m2->nt - 12 < 5 * (m1->nt - 12));
  /* world units: the city spans [-N, N]^2, ground top at 0, nothing much higher than 1 */
  float lo[3] = {1e9f, 1e9f, 1e9f}, hi[3] = {-1e9f, -1e9f, -1e9f};
  for (size_t i = 0; i < m2->nv; i++)
    for (int k = 0; k < 3; k++) {
      float v = m2->v[3 * i + k];
      lo[k] = v < lo[k] ? v : lo[k];
      hi[k] = v > hi[k] ? v : hi[k];
    }
  CHECK_NEAR(lo[0], -2.0, 1e-6); CHECK_NEAR(hi[0], 2.0, 1e-6);
  CHECK_NEAR(lo[1], -2.0, 1e-6); CHECK_NEAR(hi[1], 2.0, 1e-6);
  CHECK_NEAR(lo[2], -0.1, 1e-6);
  CHECK(hi[2] > 0.3 && hi[2] < 1.0);
  mgs_status s = mgs_assets_city(0, 1, &m1 /* left NULL on error */, &err);
  CHECK(s == MGS_ERR_ARG && m1 == NULL && strstr(err.msg, "--size"));
  mgs_mesh_destroy(m2);
}

/* Every corner ray of every view points down steeply enough to meet the ground within
 * a few units of its eye: views see a bounded patch whatever the city size. */
static void test_city_cameras(void) {
  mgs_scene_options o;
  mgs_scene_options_default(&o);
  for (int size = 1; size <= 4; size *= 2) {
    o.city_size = size;
    mgs_camera cams[40];
    mgs_scene_city_cameras(&o, 0, 40, cams);
    double worst = 0;
    int inside = 1;
    for (int i = 0; i < 40; i++) {
      double c[3];
      mgs_camera_center(&cams[i], c);
      inside &= c[0] > -size && c[0] < size && c[1] > -size && c[1] < size && c[2] > 0.2;
      for (int k = 0; k < 4; k++) {
        double org[3], dir[3];
        mgs_camera_ray(&cams[i], (k & 1) ? cams[i].width : 0, (k & 2) ? cams[i].height : 0, org, dir);
        CHECK(dir[2] < -0.2 * sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]));
        double t = -org[2] / dir[2], dx = t * dir[0], dy = t * dir[1];
        double d = sqrt(dx * dx + dy * dy);
        if (d > worst) worst = d;
      }
    }
    CHECK(inside);
    CHECK_MSG(worst < 5.0, "size %d: a view reaches %.2f units", size, worst);
  }
}

int main(void) {
  RUN(test_city_mesh);
  RUN(test_city_cameras);
  return mgs_test_finish();
}

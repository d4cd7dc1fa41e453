/* Cameras: projection against hand-computed pixels, OpenGL<->OpenCV conversion, rays. */
#include "core/mgs_core.h"
#include "mgs_test.h"

static void test_projection_by_hand(void) {
  mgs_camera c;
  mgs_camera_init(&c, 200, 100, 100, 120, 100, 50);
  double p[3] = {0.5, -0.25, 2.0}, u, v, z;
  CHECK(mgs_camera_project(&c, p, &u, &v, &z));
  CHECK_NEAR(u, 100 * 0.25 + 100, 1e-12);
  CHECK_NEAR(v, 120 * -0.125 + 50, 1e-12);
  CHECK_NEAR(z, 2.0, 0);
  double behind[3] = {0, 0, -1};
  CHECK(!mgs_camera_project(&c, behind, &u, &v, &z));
}

/* A Blender/NeRF camera at (0,0,4) looking down -z (identity rotation in OpenGL) sees the
 * world origin at the image centre, and world +y appears upward (smaller v). */
static void test_opengl_convention(void) {
  mgs_camera c;
  mgs_camera_init_fovx(&c, 100, 100, 0.6911112070083618);
  double gl[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 4, 0, 0, 0, 1};
  mgs_camera_set_c2w_opengl(&c, gl);
  double o[3] = {0, 0, 0}, up[3] = {0, 0.5, 0}, right[3] = {0.5, 0, 0}, u, v, z;
  CHECK(mgs_camera_project(&c, o, &u, &v, &z));
  CHECK_NEAR(u, 50, 1e-9); CHECK_NEAR(v, 50, 1e-9); CHECK_NEAR(z, 4, 1e-12);
  CHECK(mgs_camera_project(&c, up, &u, &v, &z)); CHECK(v < 50);
  CHECK(mgs_camera_project(&c, right, &u, &v, &z)); CHECK(u > 50);
  double back[16];
  mgs_camera_get_c2w_opengl(&c, back);
  for (int i = 0; i < 16; i++) CHECK_NEAR(back[i], gl[i], 1e-15);
  CHECK_NEAR(mgs_camera_fovx(&c), 0.6911112070083618, 1e-12);
}

static void test_look_at_and_rays(void) {
  mgs_camera c;
  mgs_camera_init_fovx(&c, 64, 48, 0.8);
  double eye[3] = {3, 2, 1}, target[3] = {0.1, -0.2, 0.3}, up[3] = {0, 0, 1};
  mgs_camera_look_at(&c, eye, target, up);
  double u, v, z;
  CHECK(mgs_camera_project(&c, target, &u, &v, &z));
  CHECK_NEAR(u, 32, 1e-9); CHECK_NEAR(v, 24, 1e-9);
  /* world up projects upward */
  double above[3] = {target[0], target[1], target[2] + 0.2};
  CHECK(mgs_camera_project(&c, above, &u, &v, &z)); CHECK(v < 24);
  /* a point on the ray through a pixel projects back to that pixel */
  double o[3], d[3];
  mgs_camera_ray(&c, 10.25, 40.5, o, d);
  double p[3] = {o[0] + 2.5 * d[0], o[1] + 2.5 * d[1], o[2] + 2.5 * d[2]};
  CHECK(mgs_camera_project(&c, p, &u, &v, &z));
  CHECK_NEAR(u, 10.25, 1e-9); CHECK_NEAR(v, 40.5, 1e-9);
  /* far from the origin the double-precision pose still projects exactly */
  double eye2[3] = {1e5 + 3, 1e5, 1e5}, t2[3] = {1e5, 1e5, 1e5};
  mgs_camera_look_at(&c, eye2, t2, up);
  double q[3] = {1e5 + 0.001, 1e5, 1e5 + 0.001};
  CHECK(mgs_camera_project(&c, q, &u, &v, &z));
  CHECK_NEAR(z, 2.999, 1e-9);
  CHECK(v < 24);
}

static void test_downscale(void) {
  mgs_camera c;
  mgs_camera_init(&c, 800, 600, 1000, 1000, 400, 300);
  mgs_camera_downscale(&c, 4);
  CHECK(c.width == 200 && c.height == 150);
  CHECK_NEAR(c.fx, 250, 0); CHECK_NEAR(c.cx, 100, 0);
}

int main(void) {
  RUN(test_projection_by_hand);
  RUN(test_opengl_convention);
  RUN(test_look_at_and_rays);
  RUN(test_downscale);
  return mgs_test_finish();
}

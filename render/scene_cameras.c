/* The camera rig of a ground-truth dataset: a Fibonacci spiral on the sphere (or the
 * upper hemisphere), each split rotated by its own seeded offset and each view jittered
 * a little, so the rig is even, deterministic for a seed, and train/test never repeat a
 * pose. Every camera looks at the origin with +z up. */
#include <math.h>
#include "render/mgs_scene.h"
#include "core/mgs_math.h"
#include "core/mgs_rng.h"

double mgs_scene_camera_radius(const mgs_scene_options *o, double bound_radius) {
  if (o->radius > 0) return o->radius;
  double fovy = 2.0 * atan(tan(o->fovx * 0.5) * (double)o->height / (double)o->width);
  double half = 0.5 * (o->fovx < fovy ? o->fovx : fovy);
  /* The sphere of radius R at distance d subtends asin(R/d); leave a 5 % margin. */
  return 1.05 * bound_radius / sin(half);
}

void mgs_scene_make_cameras(const mgs_scene_options *o, int split, int n, double radius, mgs_camera *cams) {
  const double golden = MGS_PI * (3.0 - sqrt(5.0));
  mgs_rng rng;
  mgs_rng_init(&rng, o->seed, 0x5ce7e000u + (uint64_t)split);
  double offset = 2.0 * MGS_PI * mgs_rng_uniform(&rng);
  double zspan = o->hemisphere ? 1.0 : 2.0;
  double zlo = o->hemisphere ? 0.02 : -0.995, zhi = 0.995;
  for (int i = 0; i < n; i++) {
    double jz = (mgs_rng_uniform(&rng) - 0.5) * 0.5 * zspan / n;
    double jphi = (mgs_rng_uniform(&rng) - 0.5) * 0.3;
    double z = 1.0 - zspan * (i + 0.5) / n + jz;
    z = mgs_clampd(z, zlo, zhi);
    double r = sqrt(1.0 - z * z), phi = offset + golden * i + jphi;
    double eye[3] = {radius * r * cos(phi), radius * r * sin(phi), radius * z};
    double target[3] = {0, 0, 0}, up[3] = {0, 0, 1};
    if (fabs(z) > 0.999) { up[0] = 0; up[1] = 1; up[2] = 0; }
    mgs_camera_init_fovx(&cams[i], o->width, o->height, o->fovx);
    mgs_camera_look_at(&cams[i], eye, target, up);
  }
}

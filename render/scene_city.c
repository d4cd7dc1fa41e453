/* The camera rig of the city builtin (mgs_assets_city): cameras that each see a small part
 * of the city, the same amount at every city size. Half of the views are street-level
 * (eye 0.45 above the ground on a street, pitched 36 degrees down), half low aerial (eye
 * 2.0 up, pitched 62 degrees down); a random heading. Every ray of a view then points
 * down by more than the pitch minus half the vertical field of view and meets the ground
 * within a few units: no view sees the horizon, so the content (and the Gaussians) a view
 * covers does not grow with the city. Deterministic for (seed, split). */
#include <math.h>
#include "render/mgs_scene.h"
#include "core/mgs_math.h"
#include "core/mgs_rng.h"

void mgs_scene_city_cameras(const mgs_scene_options *o, int split, int n, mgs_camera *cams) {
  mgs_rng rng;
  mgs_rng_init(&rng, o->seed, 0xc17e0000u + (uint64_t)split);
  double half = o->city_size;
  double fovy = 2.0 * atan(tan(o->fovx * 0.5) * (double)o->height / (double)o->width);
  for (int i = 0; i < n; i++) {
    int street = (i & 1) == 0;
    double heading = 2.0 * MGS_PI * mgs_rng_uniform(&rng);
    double eye[3];
    if (street) {
      /* on a street line: x = -half + k (block edges at even k, centres at odd k) */
      int along_x = mgs_rng_uniform(&rng) < 0.5;
      int k = (int)(mgs_rng_uniform(&rng) * (2 * o->city_size - 1)) + 1; /* interior lines */
      double line = -half + k, t = (mgs_rng_uniform(&rng) * 2.0 - 1.0) * (half - 0.3);
      eye[0] = along_x ? t : line;
      eye[1] = along_x ? line : t;
      eye[2] = 0.45;
      /* look along the street towards the middle of the city (outward views would see
         past its edge), give or take 17 degrees */
      double base = (along_x ? 0.0 : 0.5 * MGS_PI) + (t > 0 ? MGS_PI : 0.0);
      heading = base + (mgs_rng_uniform(&rng) - 0.5) * 0.6;
    } else {
      eye[0] = (mgs_rng_uniform(&rng) * 2.0 - 1.0) * (half - 0.5);
      eye[1] = (mgs_rng_uniform(&rng) * 2.0 - 1.0) * (half - 0.5);
      eye[2] = 2.0;
      /* facing the middle of the city, within +-90 degrees */
      double c = atan2(-eye[1], -eye[0]);
      heading = (fabs(eye[0]) + fabs(eye[1]) > 0.25 ? c : heading) + (mgs_rng_uniform(&rng) - 0.5) * MGS_PI;
    }
    /* the pitch keeps the top edge of the view at least 14 degrees below the horizon */
    double pitch = (street ? 36.0 : 62.0) * MGS_PI / 180.0;
    if (pitch - 0.5 * fovy < 14.0 * MGS_PI / 180.0) pitch = 0.5 * fovy + 14.0 * MGS_PI / 180.0;
    if (pitch > 0.49 * MGS_PI) pitch = 0.49 * MGS_PI;
    double dir[3] = {cos(heading) * cos(pitch), sin(heading) * cos(pitch), -sin(pitch)};
    double target[3] = {eye[0] + dir[0], eye[1] + dir[1], eye[2] + dir[2]}, up[3] = {0, 0, 1};
    mgs_camera_init_fovx(&cams[i], o->width, o->height, o->fovx);
    mgs_camera_look_at(&cams[i], eye, target, up);
  }
}

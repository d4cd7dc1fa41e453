/* GaussianPro's propagation step (train/mgs_gaussianpro.h) on a shell of flat Gaussians
 * (the unit sphere, random colours as texture), its training images rendered from the
 * whole shell: after a cap facing view 0 is cut out, one step on view 0 adds Gaussians in
 * the cap and nowhere else, on the sphere; on the intact shell it adds none. Also: the
 * strategy's state survives a save/load. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "tests/mgs_test.h"
#include "core/mgs_rng.h"
#include "render/mgs_raster.h"
#include "train/mgs_gaussianpro.h"
#include "train/mgs_strategy.h"

#define NV 13
#define SIZE 88
#define CAP_DEG 30.0

static mgs_gaussians *shell(size_t n) {
  mgs_gaussians *g = mgs_gaussians_create(n, 0);
  size_t first;
  mgs_error err = {0};
  if (mgs_gaussians_append(g, n, &first, &err)) return NULL;
  mgs_rng rng;
  mgs_rng_init(&rng, 7, 1);
  double spacing = sqrt(4 * M_PI / (double)n);
  for (size_t i = 0; i < n; i++) { /* Fibonacci sphere */
    double z = 1 - (2.0 * i + 1) / (double)n, r = sqrt(1 - z * z), ph = (double)i * M_PI * (3 - sqrt(5.0));
    double p[3] = {r * cos(ph), r * sin(ph), z};
    for (int k = 0; k < 3; k++) g->mean[3 * i + k] = (float)p[k];
    /* local z onto the radial direction */
    float q[4] = {(float)(1 + p[2]), (float)-p[1], (float)p[0], 0};
    if (p[2] < -0.9999) { q[0] = 0; q[1] = 1; q[2] = 0; }
    float l = sqrtf(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    for (int k = 0; k < 4; k++) g->rot[4 * i + k] = q[k] / l;
    /* opaque also where the shell is seen edge-on (flat, thin Gaussians would leave a
       semi-transparent silhouette that GaussianPro rightly fills) */
    g->log_scale[3 * i] = g->log_scale[3 * i + 1] = (float)log(0.8 * spacing);
    g->log_scale[3 * i + 2] = (float)log(0.3 * spacing);
    g->opacity[i] = (float)log(0.99 / 0.01);
    for (int k = 0; k < 3; k++) g->sh_dc[3 * i + k] = (float)((0.1 + 0.8 * mgs_rng_uniform(&rng) - 0.5) / MGS_SH_C0);
  }
  return g;
}

static void setup_views(mgs_view *v, const mgs_gaussians *g) {
  mgs_raster *r = mgs_raster_create();
  mgs_raster_settings rs;
  mgs_raster_settings_default(&rs);
  rs.sh_degree = 0;
  rs.background[0] = rs.background[1] = rs.background[2] = 1;
  mgs_error err = {0};
  /* view 0 on the z axis, the others on rings 12 and 24 degrees around it (neighbours
     with parallax, as a capture around an object has) */
  for (int i = 0; i < NV; i++) {
    double tilt = i == 0 ? 0 : (i <= 6 ? 12 : 24) * M_PI / 180, az = (i % 6) * M_PI / 3 + (i > 6 ? M_PI / 6 : 0);
    double dir[3] = {sin(tilt) * cos(az), sin(tilt) * sin(az), cos(tilt)};
    double eye[3] = {3.5 * dir[0], 3.5 * dir[1], 3.5 * dir[2]}, target[3] = {0, 0, 0}, up[3] = {0, 1, 0};
    memset(&v[i], 0, sizeof v[i]);
    mgs_camera_init_fovx(&v[i].cam, SIZE, SIZE, 45.0 * M_PI / 180.0);
    mgs_camera_look_at(&v[i].cam, eye, target, up);
    mgs_raster_output ro;
    CHECK_OK(mgs_raster_forward(r, g, &v[i].cam, &rs, &ro, &err), &err);
    v[i].image = mgs_image_create(SIZE, SIZE, 3);
    memcpy(v[i].image->data, ro.color, sizeof(float) * SIZE * SIZE * 3);
    v[i].alpha = mgs_image_create(SIZE, SIZE, 1); /* as an RGBA file's */
    memcpy(v[i].alpha->data, ro.alpha, sizeof(float) * SIZE * SIZE);
  }
  mgs_raster_destroy(r);
}

static void view_dir(const mgs_view *v, double d[3]) {
  double c[3];
  mgs_camera_center(&v->cam, c);
  double l = sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
  for (int k = 0; k < 3; k++) d[k] = c[k] / l;
}

static void options(mgs_gpro_options *o) {
  mgs_gpro_options_default(o);
  o->patch_size = 11;
  o->pm_iterations = 6;
  o->neighbors = 4;
  o->stride = 3;
  o->error_max = 1.0; /* the authors' */
  o->error_min = 0.8;
  o->min_pixels = 20;
  o->depth_min = 0.5;
  o->depth_max = 8;
  o->seed = 3;
}

static void test_fills_cut_cap(void) {
  mgs_gaussians *full = shell(3000);
  mgs_view v[NV];
  setup_views(v, full);
  double d0[3];
  view_dir(&v[0], d0);
  /* the intact shell: nothing to add */
  mgs_gpro_options o;
  options(&o);
  mgs_gpro *p = NULL;
  mgs_error err = {0};
  mgs_gpro_report r;
  CHECK_OK(mgs_gpro_create(&o, v, NV, 3.5, &p, &err), &err);
  mgs_gaussians *g = mgs_gaussians_clone(full);
  CHECK_OK(mgs_gpro_propagate(p, g, NULL, 0, 1.0, &r, &err), &err);
  fprintf(stderr, "  intact: %zu neighbours, %zu consistent px, %zu disagree, %zu added (%.2f s)\n", r.neighbors,
          r.consistent, r.accepted, r.added, r.seconds);
  CHECK(r.neighbors == 4);
  CHECK(r.consistent > 1500); /* the shell covers ~3100 px */
  CHECK(r.added == 0 && g->n == full->n);
  mgs_gaussians_destroy(g);
  mgs_gpro_destroy(p);
  /* cut the cap facing view 0 */
  uint8_t *keep = malloc(full->n);
  size_t cut = 0;
  for (size_t i = 0; i < full->n; i++) {
    const float *m = full->mean + 3 * i;
    /* and the opposite cap: a tunnel onto the background, the holes the authors' depth
       error threshold (> 80 %: the render shows nothing there) is made for */
    keep[i] = fabs(m[0] * d0[0] + m[1] * d0[1] + m[2] * d0[2]) <= cos(CAP_DEG * M_PI / 180);
    cut += !keep[i];
  }
  g = mgs_gaussians_clone(full);
  mgs_gaussians_compact(g, keep);
  size_t n0 = g->n;
  CHECK_OK(mgs_gpro_create(&o, v, NV, 3.5, &p, &err), &err);
  CHECK_OK(mgs_gpro_propagate(p, g, NULL, 0, 1.0, &r, &err), &err);
  fprintf(stderr, "  cap of %zu Gaussians cut: %zu consistent px, %zu disagree, %zu added (%.2f s)\n", cut, r.consistent,
          r.accepted, r.added, r.seconds);
  CHECK(g->n == n0 + r.added);
  /* the cap shows ~ pi (0.5 * 116 / 2.6)^2 ~ 150 px / 16 per stride-4 sample */
  CHECK_MSG(r.added >= 10, "%zu added", r.added);
  size_t outside = 0, off_surface = 0;
  double worst_angle = 0;
  for (size_t i = n0; i < g->n; i++) {
    const float *m = g->mean + 3 * i;
    double l = sqrt((double)m[0] * m[0] + (double)m[1] * m[1] + (double)m[2] * m[2]);
    double a = acos((m[0] * d0[0] + m[1] * d0[1] + m[2] * d0[2]) / l) * 180 / M_PI;
    if (a > worst_angle) worst_angle = a;
    outside += a > CAP_DEG + 5; /* the rim: a few degrees of tolerance */
    /* planes propagated in from the rim are the sphere's tangent planes there, outside it
       by up to 1 / cos(cap) at the centre; six sweeps of +-2 % refinement do not undo all */
    off_surface += l < 0.95 || l > 1.0 / cos(CAP_DEG * M_PI / 180) + 0.01;
    /* flat, facing outwards (within 60 degrees: normals inside the hole come from the
       random-normal refinement of planes propagated in from the rim) */
    float R[9];
    const float *q = g->rot + 4 * i;
    float w = q[0], x = q[1], y = q[2], z = q[3];
    R[2] = 2 * (x * z + w * y); R[5] = 2 * (y * z - w * x); R[8] = 1 - 2 * (x * x + y * y);
    double cosn = fabs((R[2] * m[0] + R[5] * m[1] + R[8] * m[2]) / l);
    CHECK_MSG(cosn > 0.5, "new Gaussian %zu: normal %.1f deg off the radial direction", i, acos(cosn) * 180 / M_PI);
    CHECK(g->log_scale[3 * i + 2] < g->log_scale[3 * i]);
  }
  fprintf(stderr, "  new Gaussians: farthest %.1f deg from the cap centre (cap %.0f)\n", worst_angle, CAP_DEG);
  CHECK_MSG(outside == 0, "%zu new Gaussians outside the cap", outside);
  CHECK_MSG(off_surface == 0, "%zu new Gaussians off the sphere beyond the tangent planes of the rim", off_surface);
  CHECK(mgs_gpro_cached_depth(p, 0) != NULL);

  /* the kept depths round-trip through the checkpoint state */
  FILE *f = tmpfile();
  CHECK_OK(mgs_gpro_save(p, f, &err), &err);
  mgs_gpro *q = NULL;
  CHECK_OK(mgs_gpro_create(&o, v, NV, 3.5, &q, &err), &err);
  rewind(f);
  CHECK_OK(mgs_gpro_load(q, f, &err), &err);
  int same = 1, n_cached = 0;
  for (int i = 0; i < NV; i++) {
    const float *a = mgs_gpro_cached_depth(p, (size_t)i), *b = mgs_gpro_cached_depth(q, (size_t)i);
    n_cached += a != NULL;
    if ((a == NULL) != (b == NULL) || (a && memcmp(a, b, sizeof(float) * SIZE * SIZE))) same = 0;
  }
  CHECK(same && n_cached == 5);
  /* a damaged state is an error */
  rewind(f);
  fputc('x', f);
  rewind(f);
  CHECK(mgs_gpro_load(q, f, &err) != MGS_OK);
  fclose(f);
  mgs_gpro_destroy(q);
  mgs_gpro_destroy(p);
  for (int i = 0; i < NV; i++) { mgs_image_destroy(v[i].image); mgs_image_destroy(v[i].alpha); }
  mgs_gaussians_destroy(g);
  mgs_gaussians_destroy(full);
  free(keep);
}

int main(void) {
  RUN(test_fills_cut_cap);
  return mgs_test_finish();
}

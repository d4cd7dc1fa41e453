/* A synthetic multi-view dataset for the trainer's tests, made with our own rasterizer
 * from a known random Gaussian model (needs no other tool): cameras on a sphere looking
 * at the origin, RGB images on a black background. Header-only (static functions). */
#ifndef MGS_TEST_SYNTH_H
#define MGS_TEST_SYNTH_H
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "core/mgs_core.h"
#include "render/mgs_raster.h"

/* n Gaussians in a ball of radius 0.7 with random colours, scales, rotations. */
static inline mgs_gaussians *synth_model(size_t n, uint64_t seed) {
  mgs_rng r;
  mgs_rng_init(&r, seed, 11);
  mgs_gaussians *g = mgs_gaussians_create(n, 3);
  size_t first;
  if (!g || mgs_gaussians_append(g, n, &first, NULL) != MGS_OK) exit(2);
  for (size_t i = 0; i < n; i++) {
    double p[3], l2;
    do {
      l2 = 0;
      for (int k = 0; k < 3; k++) { p[k] = 2 * mgs_rng_uniform(&r) - 1; l2 += p[k] * p[k]; }
    } while (l2 > 1);
    for (int k = 0; k < 3; k++) {
      g->mean[3 * i + k] = (float)(0.7 * p[k]);
      g->log_scale[3 * i + k] = logf((float)(0.04 + 0.14 * mgs_rng_uniform(&r)));
      g->sh_dc[3 * i + k] = (float)((0.1 + 0.8 * mgs_rng_uniform(&r) - 0.5) / MGS_SH_C0);
    }
    for (int k = 0; k < 4; k++) g->rot[4 * i + k] = (float)mgs_rng_normal(&r);
    g->opacity[i] = mgs_logitf((float)(0.5 + 0.45 * mgs_rng_uniform(&r)));
  }
  return g;
}

static inline void synth_camera(mgs_camera *cam, int W, int H, size_t i, size_t n, double phase) {
  mgs_camera_init_fovx(cam, W, H, 0.75);
  double az = 2 * MGS_PI * ((double)i + phase) / (double)n;
  double el = 0.8 * sin(2.3 * (double)i + phase * 5.0);
  double eye[3] = {3 * cos(el) * cos(az), 3 * cos(el) * sin(az), 3 * sin(el)};
  double target[3] = {0, 0, 0}, up[3] = {0, 0, 1};
  mgs_camera_look_at(cam, eye, target, up);
}

/* An in-memory dataset (destroy with mgs_dataset_destroy) whose images are renders of gt. */
static inline mgs_dataset *synth_dataset(const mgs_gaussians *gt, size_t n_train, size_t n_test, int W, int H) {
  mgs_dataset *d = calloc(1, sizeof *d);
  mgs_raster *r = mgs_raster_create();
  mgs_raster_settings rs;
  mgs_raster_settings_default(&rs);
  rs.background[0] = rs.background[1] = rs.background[2] = 0;
  rs.sh_degree = 0;
  d->format = MGS_DATASET_NERF_SYNTHETIC;
  d->root = mgs_strdup("synthetic");
  size_t counts[MGS_SPLIT_COUNT] = {n_train, 0, n_test};
  double sum[3] = {0, 0, 0}, rmax = 0;
  for (int s = 0; s < MGS_SPLIT_COUNT; s++) {
    d->n_views[s] = counts[s];
    d->views[s] = calloc(counts[s] ? counts[s] : 1, sizeof(mgs_view));
    for (size_t i = 0; i < counts[s]; i++) {
      mgs_view *v = &d->views[s][i];
      char name[64];
      snprintf(name, sizeof name, "r_%zu", i);
      v->name = mgs_strdup(name);
      snprintf(name, sizeof name, "./%s/r_%zu.png", mgs_split_name((mgs_split)s), i);
      v->image_path = mgs_strdup(name);
      synth_camera(&v->cam, W, H, i, counts[s], s == MGS_SPLIT_TEST ? 0.5 : 0.0);
      mgs_raster_output o;
      mgs_error err;
      if (mgs_raster_forward(r, gt, &v->cam, &rs, &o, &err) != MGS_OK) { fprintf(stderr, "synth: %s\n", err.msg); exit(2); }
      v->image = mgs_image_create(W, H, 3);
      for (size_t k = 0; k < (size_t)W * H * 3; k++) v->image->data[k] = mgs_clampf(o.color[k], 0, 1);
      if (s == MGS_SPLIT_TRAIN) {
        double c[3];
        mgs_camera_center(&v->cam, c);
        for (int k = 0; k < 3; k++) sum[k] += c[k];
      }
    }
  }
  for (int k = 0; k < 3; k++) d->center[k] = sum[k] / (double)n_train;
  for (size_t i = 0; i < n_train; i++) {
    double c[3], dd[3];
    mgs_camera_center(&d->views[0][i].cam, c);
    mgs_sub3d(c, d->center, dd);
    rmax = fmax(rmax, mgs_norm3d(dd));
  }
  d->extent = 1.1 * rmax;
  mgs_raster_destroy(r);
  return d;
}

/* Writes d as a NeRF-synthetic folder (transforms_{train,test}.json + PNGs). */
static inline int synth_write_nerf(const mgs_dataset *d, const char *dir) {
  mgs_error err;
  for (int s = 0; s < MGS_SPLIT_COUNT; s++) {
    if (s == MGS_SPLIT_VAL) continue;
    char path[8192];
    snprintf(path, sizeof path, "%s/%s", dir, mgs_split_name((mgs_split)s));
    if (mgs_mkdir_p(path, &err) != MGS_OK) return 0;
    snprintf(path, sizeof path, "%s/transforms_%s.json", dir, mgs_split_name((mgs_split)s));
    FILE *f = fopen(path, "w");
    if (!f) return 0;
    fprintf(f, "{\"camera_angle_x\": %.17g, \"frames\": [", mgs_camera_fovx(&d->views[s][0].cam));
    for (size_t i = 0; i < d->n_views[s]; i++) {
      const mgs_view *v = &d->views[s][i];
      double m[16];
      mgs_camera_get_c2w_opengl(&v->cam, m);
      fprintf(f, "%s{\"file_path\": \"./%s/%s\", \"transform_matrix\": [", i ? ", " : "", mgs_split_name((mgs_split)s), v->name);
      for (int rr = 0; rr < 4; rr++)
        fprintf(f, "%s[%.17g, %.17g, %.17g, %.17g]", rr ? ", " : "", m[4 * rr], m[4 * rr + 1], m[4 * rr + 2], m[4 * rr + 3]);
      fprintf(f, "]}");
      char ip[8192];
      snprintf(ip, sizeof ip, "%s/%s/%s.png", dir, mgs_split_name((mgs_split)s), v->name);
      if (mgs_image_write(ip, v->image, &err) != MGS_OK) { fprintf(stderr, "synth: %s\n", err.msg); fclose(f); return 0; }
    }
    fprintf(f, "]}\n");
    fclose(f);
  }
  return 1;
}
#endif

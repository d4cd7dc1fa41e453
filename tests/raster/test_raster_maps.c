/* The rasterizer's geometry maps (mgs_raster_maps) against the brute-force reference of
 * raster_test_util.h extended by the same definitions written out again: expected depth
 * sum w z / alpha, median depth (z where T first drops below 0.5), normal sum w n with n
 * the smallest-scale axis facing the camera. Also: the forward's outputs are unchanged by
 * a maps call (nothing costs or changes unless asked). */
#include "mgs_test.h"
#include "raster/raster_test_util.h"

/* Brute force in double, as bf_render, plus median and normal. */
static void bf_maps(const mgs_gaussians *g, const mgs_camera *cam, const mgs_raster_settings *s, double *med,
                    double *nrm, unsigned char *ambig) {
  size_t n = g->n;
  int W = cam->width, H = cam->height;
  double *color = malloc(sizeof(double) * 3 * W * H), *alpha = malloc(sizeof(double) * W * H),
         *depth = malloc(sizeof(double) * W * H);
  bf_gauss *all = NULL;
  bf_render(g, cam, s, color, alpha, depth, ambig, &all);
  bf_gauss *vis = calloc(n ? n : 1, sizeof(bf_gauss));
  size_t nv = 0;
  for (size_t i = 0; i < n; i++) if (all[i].visible) vis[nv++] = all[i];
  qsort(vis, nv, sizeof(bf_gauss), bf_cmp);
  double cc[3];
  mgs_camera_center(cam, cc);
  for (int y = 0; y < H; y++)
    for (int x = 0; x < W; x++) {
      size_t p = (size_t)y * W + x;
      double T = 1, N[3] = {0, 0, 0}, M = 0;
      int tx = x / 16, ty = y / 16;
      for (size_t k = 0; k < nv; k++) {
        const bf_gauss *q = &vis[k];
        double dx = x + 0.5 - q->u, dy = y + 0.5 - q->v;
        double power = -0.5 * (q->A * dx * dx + q->C * dy * dy) - q->B * dx * dy;
        double raw = q->op * exp(power);
        if (!(tx >= q->rect[0] && tx < q->rect[2] && ty >= q->rect[1] && ty < q->rect[3]) || power > 0) continue;
        double al = raw < 0.99 ? raw : 0.99;
        if (al < 1.0 / 255) continue;
        double testT = T * (1 - al);
        if (testT < 1e-4) break;
        if (fabs(testT - 0.5) < 1e-5) ambig[p] = 1;
        if (T >= 0.5 && testT < 0.5) M = q->z;
        size_t i = q->idx;
        double qq[4] = {g->rot[4 * i], g->rot[4 * i + 1], g->rot[4 * i + 2], g->rot[4 * i + 3]}, R[9];
        mgs_quat_to_mat3d(qq, R);
        const float *ls = g->log_scale + 3 * i;
        int a = 0;
        for (int c = 1; c < 3; c++) if (ls[c] < ls[a]) a = c;
        double ax[3] = {R[a], R[3 + a], R[6 + a]}, dot = 0;
        for (int c = 0; c < 3; c++) dot += ax[c] * (cc[c] - g->mean[3 * i + c]);
        for (int c = 0; c < 3; c++) N[c] += al * T * (dot < 0 ? -ax[c] : ax[c]);
        T = testT;
      }
      med[p] = M;
      for (int c = 0; c < 3; c++) nrm[3 * p + c] = N[c];
    }
  free(all); free(vis); free(color); free(alpha); free(depth);
}

static void check_case(uint64_t seed, int w, int h) {
  scene_opts o = {300, 1.0, 0.02, 0.3, 0.5, 1.5, 0.3};
  mgs_gaussians *g = rt_random_scene(seed, &o);
  mgs_camera cam;
  double target[3] = {0, 0, 0};
  rt_camera(&cam, w, h, 0.9, 3.5, target, seed);
  mgs_raster_settings s;
  mgs_raster_settings_default(&s);
  mgs_raster *r = mgs_raster_create();
  mgs_error err = {0};
  mgs_raster_output ro;
  CHECK_OK(mgs_raster_forward(r, g, &cam, &s, &ro, &err), &err);
  size_t np = (size_t)w * h;
  float *col = malloc(np * 3 * sizeof(float)), *dep = malloc(np * sizeof(float));
  memcpy(col, ro.color, np * 3 * sizeof(float));
  memcpy(dep, ro.depth, np * sizeof(float));
  mgs_render_maps m;
  CHECK_OK(mgs_raster_maps(r, MGS_MAP_ALL, &m, &err), &err);
  CHECK(!memcmp(col, ro.color, np * 3 * sizeof(float)) && !memcmp(dep, ro.depth, np * sizeof(float)));
  double *med = malloc(np * sizeof(double)), *nrm = malloc(3 * np * sizeof(double));
  unsigned char *amb = calloc(np, 1);
  bf_maps(g, &cam, &s, med, nrm, amb);
  size_t bad_m = 0, bad_n = 0, bad_e = 0, covered = 0, checked = 0;
  for (size_t p = 0; p < np; p++) {
    if (amb[p]) continue;
    checked++;
    covered += m.depth_median[p] > 0;
    if (fabs(m.depth_median[p] - med[p]) > 1e-4 * (1 + med[p])) bad_m++;
    for (int c = 0; c < 3; c++) if (fabs(m.normal[3 * p + c] - nrm[3 * p + c]) > 2e-4) { bad_n++; break; }
    double e = m.alpha[p] > 0 ? ro.depth[p] / m.alpha[p] : 0;
    if (fabs(m.depth_expected[p] - e) > 1e-5 * (1 + e)) bad_e++;
  }
  CHECK_MSG(bad_m == 0 && bad_n == 0 && bad_e == 0 && covered > checked / 10,
            "seed %llu: %zu/%zu pixels with a wrong median depth, %zu wrong normals, %zu wrong expected depth, %zu covered",
            (unsigned long long)seed, bad_m, checked, bad_n, bad_e, covered);
  /* a subset of maps leaves the others NULL */
  CHECK_OK(mgs_raster_maps(r, MGS_MAP_DEPTH_MEDIAN, &m, &err), &err);
  CHECK(m.depth_median && !m.normal && !m.depth_expected && m.alpha);
  CHECK(mgs_raster_maps(r, 1u << 7, &m, &err) == MGS_ERR_ARG);
  free(col); free(dep); free(med); free(nrm); free(amb);
  mgs_raster_destroy(r);
  mgs_gaussians_destroy(g);
}

static void test_maps_random(void) {
  check_case(1, 61, 47);
  check_case(2, 32, 32);
  check_case(3, 80, 50);
}

/* One flat Gaussian facing the camera: normal = alpha * (direction to the camera). */
static void test_maps_flat(void) {
  mgs_gaussians *g = mgs_gaussians_create(1, 0);
  size_t first;
  mgs_error err = {0};
  CHECK_OK(mgs_gaussians_append(g, 1, &first, &err), &err);
  g->mean[0] = g->mean[1] = g->mean[2] = 0;
  g->log_scale[0] = g->log_scale[1] = logf(0.5f); g->log_scale[2] = logf(0.01f); /* normal: local z */
  g->rot[0] = 1; g->rot[1] = g->rot[2] = g->rot[3] = 0;
  g->opacity[0] = 3;
  mgs_camera cam;
  mgs_camera_init_fovx(&cam, 32, 32, 0.8);
  double eye[3] = {0, 0, -4}, tgt[3] = {0, 0, 0}, up[3] = {0, 1, 0};
  mgs_camera_look_at(&cam, eye, tgt, up);
  mgs_raster_settings s;
  mgs_raster_settings_default(&s);
  mgs_raster *r = mgs_raster_create();
  mgs_raster_output ro;
  mgs_render_maps m;
  CHECK_OK(mgs_raster_forward(r, g, &cam, &s, &ro, &err), &err);
  CHECK_OK(mgs_raster_maps(r, MGS_MAP_ALL, &m, &err), &err);
  size_t c = 16 * 32 + 16;
  CHECK_NEAR(m.normal[3 * c + 2], -m.alpha[c], 1e-6); /* facing the camera at z = -4 */
  CHECK_NEAR(m.normal[3 * c], 0, 1e-6);
  CHECK_NEAR(m.depth_expected[c], 4.0, 1e-4);
  CHECK_NEAR(m.depth_median[c], 4.0, 1e-4);
  CHECK(m.alpha[0] < 0.5 && m.depth_median[0] == 0);
  mgs_raster_destroy(r);
  mgs_gaussians_destroy(g);
}

int main(void) {
  RUN(test_maps_random);
  RUN(test_maps_flat);
  return mgs_test_finish();
}

/* The blending statistics of a 2DGS forward (mgs_raster_blend_stats on a surfel model,
 * render/raster_2dgs_tiles.c) against a brute-force recomputation written out here in
 * double: per pixel every surfel's ray-plane intersection (u, v), rho = min(u^2 + v^2,
 * 2 |pixel - centre of the projected 3-sigma box|^2), alpha = min(0.99, o e^(-rho/2)) on
 * the tiles of that box, skipped below 1/255 or at a hit depth < 0.2, composited front to
 * back in the order of the centres' depths, stopping before T would fall under 1e-4; the
 * max-weight surfel (the first with the largest alpha T), the final T, each surfel's summed
 * weight and the pixels where it is the max-weight one.
 *  - a random scene of overlapping surfels, tilted every way (some nearly edge-on), with
 *    an opaque stack that triggers the early stop: the maps agree at every pixel that is
 *    not on a threshold (printed), importance and area_max per surfel;
 *  - one face-on surfel covering many pixels: area_max = the pixels of the ellipse
 *    rho <= 2 ln(255 o), within its rim, and importance = sum of alpha;
 *  - the statistics leave the forward's outputs and its backward as they were. */
#include <stdio.h>
#include "mgs_test.h"
#include "raster_test_util.h"

enum { W = 96, H = 80 };

typedef struct ref_surfel {
  double R[9], s0, s1, op, zc;  /* zc: camera depth of the centre */
  double cu, cv;                /* filter centre: the projected 3-sigma box's centre */
  int tx0, ty0, tx1, ty1;       /* its tiles [x0, x1) x [y0, y1) */
  double mu[3];
} ref_surfel;

static void ref_setup(const mgs_gaussians *g, size_t i, const mgs_camera *cam, ref_surfel *s) {
  float Rf[9];
  mgs_quat_to_mat3f(g->rot + 4 * i, Rf);
  for (int k = 0; k < 9; k++) s->R[k] = Rf[k];
  for (int k = 0; k < 3; k++) s->mu[k] = g->mean[3 * i + k];
  s->s0 = exp((double)g->log_scale[3 * i]);
  s->s1 = exp((double)g->log_scale[3 * i + 1]);
  s->op = 1.0 / (1.0 + exp(-(double)g->opacity[i]));
  double pc[3];
  mgs_camera_world_to_cam(cam, s->mu, pc);
  s->zc = pc[2];
  double xmin = 1e30, xmax = -1e30, ymin = 1e30, ymax = -1e30;
  for (int k = 0; k < 4000; k++) {
    double th = 2 * M_PI * k / 4000.0, pt[3], u, v, dd;
    for (int a = 0; a < 3; a++) pt[a] = s->mu[a] + 3 * s->s0 * cos(th) * s->R[3 * a] + 3 * s->s1 * sin(th) * s->R[3 * a + 1];
    mgs_camera_project(cam, pt, &u, &v, &dd);
    xmin = fmin(xmin, u); xmax = fmax(xmax, u); ymin = fmin(ymin, v); ymax = fmax(ymax, v);
  }
  s->cu = 0.5 * (xmin + xmax);
  s->cv = 0.5 * (ymin + ymax);
  double rad = ceil(fmax(fmax(0.5 * (xmax - xmin), 0.5 * (ymax - ymin)), 3 * 0.707106));
  s->tx0 = (int)fmax(0, floor((s->cu - 0.5 - rad) / 16));
  s->ty0 = (int)fmax(0, floor((s->cv - 0.5 - rad) / 16));
  s->tx1 = (int)floor((s->cu - 0.5 + rad + 15) / 16);
  s->ty1 = (int)floor((s->cv - 0.5 + rad + 15) / 16);
}

/* alpha of surfel s at pixel (x, y) (0 where skipped); *edge: within a hair of a threshold */
static double ref_alpha(const ref_surfel *s, const mgs_camera *cam, int x, int y, int *edge) {
  if (x / 16 < s->tx0 || x / 16 >= s->tx1 || y / 16 < s->ty0 || y / 16 >= s->ty1) return 0;
  double o[3], d[3];
  mgs_camera_ray(cam, x + 0.5, y + 0.5, o, d);
  const double *R = s->R;
  double nd = d[0] * R[2] + d[1] * R[5] + d[2] * R[8];
  double t = ((s->mu[0] - o[0]) * R[2] + (s->mu[1] - o[1]) * R[5] + (s->mu[2] - o[2]) * R[8]) / nd;
  double h[3] = {o[0] + t * d[0] - s->mu[0], o[1] + t * d[1] - s->mu[1], o[2] + t * d[2] - s->mu[2]};
  double u = (h[0] * R[0] + h[1] * R[3] + h[2] * R[6]) / s->s0;
  double v = (h[0] * R[1] + h[1] * R[4] + h[2] * R[7]) / s->s1;
  double r3 = u * u + v * v;
  if (!isfinite(r3)) r3 = INFINITY;
  double dx = x + 0.5 - s->cu, dy = y + 0.5 - s->cv, r2 = 2.0 * (dx * dx + dy * dy);
  double hit[3] = {o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]}, hc[3];
  mgs_camera_world_to_cam(cam, hit, hc);
  double z = r3 <= r2 ? hc[2] : s->zc;
  double a = fmin(0.99, s->op * exp(-0.5 * fmin(r3, r2)));
  if (fabs(a * 255.0 - 1.0) < 2e-3) *edge = 1;
  if (a < 1.0 / 255 || z < 0.2) return 0;
  return a;
}

typedef struct ref_out {
  int32_t *max_index;
  double *final_T, *importance;
  uint32_t *area_max;
  uint8_t *edge; /* the pixel sits on a threshold or a near tie: float may decide otherwise */
} ref_out;

static const ref_surfel *sort_surfels; /* qsort has no context argument in C17 */
static int by_depth(const void *a, const void *b) {
  const ref_surfel *s = sort_surfels;
  uint32_t i = *(const uint32_t *)a, j = *(const uint32_t *)b;
  float zi = (float)s[i].zc, zj = (float)s[j].zc;
  return zi < zj ? -1 : zi > zj ? 1 : (i > j) - (i < j);
}

static void brute_force(const mgs_gaussians *g, const mgs_camera *cam, ref_out *o) {
  size_t n = g->n;
  ref_surfel *s = malloc(n * sizeof *s);
  uint32_t *order = malloc(n * sizeof *order);
  for (size_t i = 0; i < n; i++) { ref_setup(g, i, cam, &s[i]); order[i] = (uint32_t)i; }
  sort_surfels = s;
  qsort(order, n, sizeof *order, by_depth);
  memset(o->importance, 0, n * sizeof(double));
  memset(o->area_max, 0, n * sizeof(uint32_t));
  for (int y = 0; y < H; y++)
    for (int x = 0; x < W; x++) {
      size_t p = (size_t)y * W + x;
      double T = 1, wmax = 0, w2 = 0;
      int32_t best = -1;
      int edge = 0;
      for (size_t k = 0; k < n; k++) {
        const ref_surfel *sf = &s[order[k]];
        if (sf->zc <= 0.2) continue;
        double a = ref_alpha(sf, cam, x, y, &edge);
        if (a == 0) continue;
        double tn = T * (1 - a);
        if (fabs(tn / 1e-4 - 1) < 1e-3) edge = 1;
        if (tn < 1e-4) break;
        double w = a * T;
        o->importance[order[k]] += w;
        if (w > wmax) { w2 = wmax; wmax = w; best = (int32_t)order[k]; }
        else if (w > w2) w2 = w;
        T = tn;
      }
      if (wmax > 0 && w2 > wmax * (1 - 1e-4)) edge = 1;
      o->max_index[p] = best;
      o->final_T[p] = T;
      o->edge[p] = (uint8_t)edge;
      if (best >= 0) o->area_max[best]++;
    }
  free(s);
  free(order);
}

static mgs_gaussians *surfels(size_t n) {
  mgs_gaussians *g = mgs_gaussians_create(n, 0);
  size_t first;
  if (!g || mgs_gaussians_append(g, n, &first, NULL) != MGS_OK) exit(2);
  g->kind = MGS_MODEL_2DGS;
  for (size_t i = 0; i < n; i++) g->log_scale[3 * i + 2] = MGS_SURFEL_LOG_SCALE2;
  return g;
}

static void front_camera(mgs_camera *cam) {
  mgs_camera_init_fovx(cam, W, H, 0.8);
  double eye[3] = {0.1, -0.2, 3}, target[3] = {0, 0, 0}, up[3] = {0, 1, 0};
  mgs_camera_look_at(cam, eye, target, up);
}

static void compare(const char *name, const mgs_gaussians *g, const mgs_camera *cam, size_t min_covered) {
  mgs_raster *r = mgs_raster_create();
  mgs_raster_settings rs;
  mgs_raster_settings_default(&rs);
  rs.sh_degree = 0;
  mgs_raster_output ro;
  mgs_raster_blend b;
  mgs_error err;
  CHECK_OK(mgs_raster_forward(r, g, cam, &rs, &ro, &err), &err);
  CHECK_OK(mgs_raster_blend_stats(r, &b, &err), &err);
  CHECK(b.n == g->n && b.width == W && b.height == H);
  size_t n = g->n, npix = (size_t)W * H;
  ref_out o = {malloc(npix * sizeof(int32_t)), malloc(npix * sizeof(double)), malloc(n * sizeof(double)),
               malloc(n * sizeof(uint32_t)), malloc(npix)};
  brute_force(g, cam, &o);
  size_t edges = 0, covered = 0, idx_bad = 0, area = 0;
  double t_bad = 0, t_fwd = 0, imp_sum = 0, alpha_sum = 0;
  for (size_t p = 0; p < npix; p++) {
    /* the forward's own alpha is 1 - the statistics' T, bit for bit */
    t_fwd = fmax(t_fwd, fabs((double)(1.0f - b.final_T[p]) - ro.alpha[p]));
    alpha_sum += 1.0 - b.final_T[p];
    covered += o.max_index[p] >= 0;
    if (o.edge[p]) { edges++; continue; }
    idx_bad += b.max_index[p] != o.max_index[p];
    t_bad = fmax(t_bad, fabs(b.final_T[p] - o.final_T[p]));
  }
  double imp_bad = 0;
  long area_bad = 0;
  for (size_t i = 0; i < n; i++) {
    imp_sum += b.importance[i];
    area += b.area_max[i];
    imp_bad = fmax(imp_bad, fabs(b.importance[i] - o.importance[i]) / (1 + o.importance[i]));
    long d = labs((long)b.area_max[i] - (long)o.area_max[i]);
    if (d > area_bad) area_bad = d;
  }
  fprintf(stderr, "  %s: %zu surfels, %zu covered pixels, %zu on a threshold; max_index differs at %zu, "
          "max |T - T_ref| %.2g, max importance rel. diff %.2g, max |area_max - ref| %ld\n",
          name, n, covered, edges, idx_bad, t_bad, imp_bad, area_bad);
  CHECK(covered >= min_covered);
  CHECK_MSG(edges * 50 < npix, "%zu pixels on a threshold", edges);
  CHECK(t_fwd == 0);
  CHECK_MSG(idx_bad == 0, "%zu pixels with another max-weight surfel", idx_bad);
  CHECK_MSG(t_bad < 1e-4, "final T off by %g", t_bad);
  CHECK_MSG(imp_bad < 1e-3, "importance off by %g (relative)", imp_bad);
  CHECK_MSG((size_t)area_bad <= edges, "area_max off by %ld", area_bad);
  CHECK(area == covered || (size_t)labs((long)area - (long)covered) <= edges);
  CHECK_NEAR(imp_sum, alpha_sum, 1e-4 * alpha_sum + 1e-3); /* weights of a pixel sum to 1 - T */
  free(o.max_index); free(o.final_T); free(o.importance); free(o.area_max); free(o.edge);
  mgs_raster_destroy(r);
}

static void random_scene(void) {
  mgs_rng rng;
  mgs_rng_init(&rng, 23, 5);
  size_t n = 40;
  mgs_gaussians *g = surfels(n);
  for (size_t i = 0; i < n; i++) {
    for (int k = 0; k < 3; k++) g->mean[3 * i + k] = (float)rt_uniform(&rng, -0.7, 0.7);
    g->log_scale[3 * i] = (float)log(rt_uniform(&rng, 0.04, 0.35));
    g->log_scale[3 * i + 1] = (float)log(rt_uniform(&rng, 0.04, 0.35));
    for (int k = 0; k < 4; k++) g->rot[4 * i + k] = (float)mgs_rng_normal(&rng); /* any tilt, unnormalized */
    g->opacity[i] = (float)rt_uniform(&rng, -2.0, 4.0);
    for (int k = 0; k < 3; k++) g->sh_dc[3 * i + k] = (float)mgs_rng_normal(&rng);
  }
  /* an opaque face-on stack at the centre: T falls under 1e-4 at its third layer */
  for (size_t i = 0; i < 4; i++) {
    g->mean[3 * i] = 0.05f; g->mean[3 * i + 1] = 0.0f; g->mean[3 * i + 2] = 1.0f - 0.2f * (float)i;
    g->log_scale[3 * i] = g->log_scale[3 * i + 1] = logf(0.15f);
    g->rot[4 * i] = 1; g->rot[4 * i + 1] = g->rot[4 * i + 2] = g->rot[4 * i + 3] = 0;
    g->opacity[i] = 8.0f;
  }
  mgs_camera cam;
  front_camera(&cam);
  compare("random scene", g, &cam, W * H / 3);
  mgs_gaussians_destroy(g);
}

static void one_large_surfel(void) {
  /* face-on at depth 3 (the camera on its normal): rho3 = |x - mu|^2 / s^2 in the plane,
     alpha >= 1/255 on the disc of radius s sqrt(2 ln(255 o)) */
  mgs_gaussians *g = surfels(1);
  const double s = 0.3, op = 0.8;
  g->log_scale[0] = g->log_scale[1] = (float)log(s);
  g->rot[0] = 1;
  g->opacity[0] = (float)log(op / (1 - op));
  mgs_camera cam;
  mgs_camera_init_fovx(&cam, W, H, 0.8);
  double eye[3] = {0, 0, 3}, target[3] = {0, 0, 0}, up[3] = {0, 1, 0};
  mgs_camera_look_at(&cam, eye, target, up);
  mgs_raster *r = mgs_raster_create();
  mgs_raster_settings rs;
  mgs_raster_settings_default(&rs);
  rs.sh_degree = 0;
  mgs_raster_output ro;
  mgs_raster_blend b;
  mgs_error err;
  CHECK_OK(mgs_raster_forward(r, g, &cam, &rs, &ro, &err), &err);
  CHECK_OK(mgs_raster_blend_stats(r, &b, &err), &err);
  double rad_px = s * sqrt(2 * log(255 * op)) * cam.fx / 3.0;
  double expect = M_PI * rad_px * rad_px, asum = 0;
  for (size_t p = 0; p < (size_t)W * H; p++) asum += ro.alpha[p];
  fprintf(stderr, "  one surfel: area_max %u, the alpha >= 1/255 disc %.1f px (radius %.1f px), importance %.3f, "
          "sum of alpha %.3f\n", b.area_max[0], expect, rad_px, b.importance[0], asum);
  CHECK(expect > 1000);
  /* pixels whose centres lie in the disc: the area within the rim's length */
  CHECK_MSG(fabs(b.area_max[0] - expect) <= 2 * M_PI * rad_px * 0.5, "area_max %u, expected %.1f", b.area_max[0], expect);
  CHECK_NEAR(b.importance[0], asum, 1e-4 * asum);
  mgs_raster_destroy(r);
  compare("one surfel", g, &cam, 1000);
  mgs_gaussians_destroy(g);
}

static void leaves_forward_alone(void) {
  /* the statistics between a forward and its backward change neither */
  mgs_rng rng;
  mgs_rng_init(&rng, 5, 9);
  size_t n = 30;
  mgs_gaussians *g = surfels(n);
  for (size_t i = 0; i < n; i++) {
    for (int k = 0; k < 3; k++) g->mean[3 * i + k] = (float)rt_uniform(&rng, -0.6, 0.6);
    g->log_scale[3 * i] = g->log_scale[3 * i + 1] = (float)log(rt_uniform(&rng, 0.05, 0.3));
    for (int k = 0; k < 4; k++) g->rot[4 * i + k] = (float)mgs_rng_normal(&rng);
    g->opacity[i] = (float)rt_uniform(&rng, -1, 3);
  }
  mgs_camera cam;
  front_camera(&cam);
  mgs_raster_settings rs;
  mgs_raster_settings_default(&rs);
  rs.sh_degree = 0;
  size_t npix = (size_t)W * H;
  float *dc = malloc(3 * npix * sizeof(float)), *col = malloc(3 * npix * sizeof(float));
  for (size_t p = 0; p < 3 * npix; p++) dc[p] = (float)mgs_rng_normal(&rng);
  mgs_gaussians *ga = surfels(n), *gb = surfels(n);
  for (int k = 0; k < MGS_PARAM_COUNT; k++) {
    size_t bytes = n * (size_t)mgs_param_dim((mgs_param_group)k) * sizeof(float);
    memset(mgs_gaussians_group(ga, (mgs_param_group)k), 0, bytes);
    memset(mgs_gaussians_group(gb, (mgs_param_group)k), 0, bytes);
  }
  mgs_raster *r = mgs_raster_create();
  mgs_raster_output ro;
  mgs_raster_blend b;
  mgs_error err;
  CHECK_OK(mgs_raster_forward(r, g, &cam, &rs, &ro, &err), &err);
  CHECK_OK(mgs_raster_backward(r, dc, NULL, NULL, ga, NULL, &err), &err);
  CHECK_OK(mgs_raster_forward(r, g, &cam, &rs, &ro, &err), &err);
  memcpy(col, ro.color, 3 * npix * sizeof(float));
  CHECK_OK(mgs_raster_blend_stats(r, &b, &err), &err);
  CHECK(memcmp(col, ro.color, 3 * npix * sizeof(float)) == 0);
  CHECK_OK(mgs_raster_backward(r, dc, NULL, NULL, gb, NULL, &err), &err);
  int same = 1;
  for (int k = 0; k < MGS_PARAM_COUNT; k++)
    same &= memcmp(mgs_gaussians_group(ga, (mgs_param_group)k), mgs_gaussians_group(gb, (mgs_param_group)k),
                   n * (size_t)mgs_param_dim((mgs_param_group)k) * sizeof(float)) == 0;
  CHECK_MSG(same, "the backward after the statistics differs");
  free(dc); free(col);
  mgs_gaussians_destroy(ga); mgs_gaussians_destroy(gb); mgs_gaussians_destroy(g);
  mgs_raster_destroy(r);
}

int main(void) {
  RUN(random_scene);
  RUN(one_large_surfel);
  RUN(leaves_forward_alone);
  return mgs_test_finish();
}

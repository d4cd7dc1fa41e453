/* The 2DGS losses (train/mgs_term_2dgs.h). */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "render/mgs_raster.h"
#include "train/mgs_term_2dgs.h"

void mgs_2dgs_term_options_default(mgs_2dgs_term_options *o) {
  o->lambda_dist = 0;
  o->lambda_normal = 0.05;
  o->dist_from = 3000;
  o->normal_from = 7000;
  o->alpha_weight = 1;
}

typedef struct t2d {
  mgs_2dgs_term_options o;
  float *pts; /* back-projected median depth, 3 per pixel */
  size_t cap;
} t2d;

static unsigned t2d_active(void *self, int it) {
  const t2d *t = self;
  int on = (t->o.lambda_dist > 0 && it >= t->o.dist_from) || (t->o.lambda_normal > 0 && it >= t->o.normal_from);
  return on ? MGS_TERM_IMAGE | MGS_TERM_MAPS : 0u;
}

/* The normal of the depth's surface at interior pixel p and its backward: c = dx x dy with
 * dx = P(y+1) - P(y-1), dy = P(x+1) - P(x-1) (the authors' depth_to_normal), Nd = c/|c|;
 * g = dL/dNd, adds dL/dz into gz at the four neighbours. */
static void depth_normal(const float *P, int W, size_t p, float nd[3], float *c_len) {
  const float *a1 = P + 3 * (p + W), *a0 = P + 3 * (p - W), *b1 = P + 3 * (p + 1), *b0 = P + 3 * (p - 1);
  float dx[3] = {a1[0] - a0[0], a1[1] - a0[1], a1[2] - a0[2]}, dy[3] = {b1[0] - b0[0], b1[1] - b0[1], b1[2] - b0[2]};
  float c[3] = {dx[1] * dy[2] - dx[2] * dy[1], dx[2] * dy[0] - dx[0] * dy[2], dx[0] * dy[1] - dx[1] * dy[0]};
  float l = sqrtf(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
  *c_len = l;
  for (int k = 0; k < 3; k++) nd[k] = l > 0 ? c[k] / l : 0.0f;
}

static mgs_status t2d_image(void *self, mgs_term_step *s, mgs_error *err) {
  t2d *t = self;
  if (!s->raster) return mgs_error_set(err, MGS_ERR_ARG, "2DGS losses: no rasterizer context in this iteration");
  mgs_render_maps mp;
  mgs_raster_map_grad mg;
  mgs_status st = mgs_raster_maps(s->raster, MGS_MAP_DEPTH_MEDIAN | MGS_MAP_NORMAL | MGS_MAP_DISTORTION, &mp, err);
  if (st == MGS_OK) st = mgs_raster_map_grads(s->raster, &mg, err);
  if (st) return st;
  const int W = mp.width, H = mp.height;
  const size_t np = (size_t)W * H;
  double value = 0;
  if (t->o.lambda_dist > 0 && s->iteration >= t->o.dist_from) {
    const float g = (float)(t->o.lambda_dist / (double)np);
    double sum = 0;
    for (size_t p = 0; p < np; p++) { sum += mp.distortion[p]; mg.distortion[p] += g; }
    value += t->o.lambda_dist * sum / (double)np;
  }
  if (t->o.lambda_normal > 0 && s->iteration >= t->o.normal_from) {
    if (np > t->cap) {
      float *q = realloc(t->pts, 3 * np * sizeof(float));
      if (!q) return mgs_error_set(err, MGS_ERR_NOMEM, "2DGS losses: out of memory for %zu pixels", np);
      t->pts = q;
      t->cap = np;
    }
    /* points in the camera's frame rotated to world axes (the translation cancels in the
       differences): z (R^T K^-1 (x + 1/2, y + 1/2, 1)) */
    const mgs_camera *cam = &s->view->cam;
    const double *C = cam->c2w;
    for (int y = 0; y < H; y++)
      for (int x = 0; x < W; x++) {
        size_t p = (size_t)y * W + x;
        double d[3] = {(x + 0.5 - cam->cx) / cam->fx, (y + 0.5 - cam->cy) / cam->fy, 1.0};
        float z = mp.depth_median[p];
        for (int k = 0; k < 3; k++) t->pts[3 * p + k] = (float)(z * (C[4 * k] * d[0] + C[4 * k + 1] * d[1] + C[4 * k + 2] * d[2]));
      }
    const double lam = t->o.lambda_normal / (double)np;
    double err_sum = 0;
    for (int y = 0; y < H; y++)
      for (int x = 0; x < W; x++) {
        size_t p = (size_t)y * W + x;
        const float *N = mp.normal + 3 * p;
        int ok = x > 0 && y > 0 && x < W - 1 && y < H - 1 && mp.depth_median[p] > 0 && mp.depth_median[p - 1] > 0 &&
                 mp.depth_median[p + 1] > 0 && mp.depth_median[p - W] > 0 && mp.depth_median[p + W] > 0;
        if (!ok) { err_sum += 1.0; continue; } /* Nd = 0: error 1, no gradient */
        float nd[3], cl;
        depth_normal(t->pts, W, p, nd, &cl);
        float a = t->o.alpha_weight ? mp.alpha[p] : 1.0f;
        err_sum += 1.0 - a * (N[0] * nd[0] + N[1] * nd[1] + N[2] * nd[2]);
        for (int k = 0; k < 3; k++) mg.normal[3 * p + k] += (float)(-lam * a * nd[k]);
        if (!(cl > 0)) continue;
        /* dL/dNd = -lam a N; through the normalization and the cross product */
        float gn[3] = {(float)(-lam * a) * N[0], (float)(-lam * a) * N[1], (float)(-lam * a) * N[2]};
        float gd = gn[0] * nd[0] + gn[1] * nd[1] + gn[2] * nd[2];
        float gc[3] = {(gn[0] - gd * nd[0]) / cl, (gn[1] - gd * nd[1]) / cl, (gn[2] - gd * nd[2]) / cl};
        const float *a1 = t->pts + 3 * (p + W), *a0 = t->pts + 3 * (p - W), *b1 = t->pts + 3 * (p + 1), *b0 = t->pts + 3 * (p - 1);
        float dx[3] = {a1[0] - a0[0], a1[1] - a0[1], a1[2] - a0[2]}, dy[3] = {b1[0] - b0[0], b1[1] - b0[1], b1[2] - b0[2]};
        /* c = dx x dy: dL/ddx = dy x gc, dL/ddy = gc x dx */
        float gx[3] = {dy[1] * gc[2] - dy[2] * gc[1], dy[2] * gc[0] - dy[0] * gc[2], dy[0] * gc[1] - dy[1] * gc[0]};
        float gy[3] = {gc[1] * dx[2] - gc[2] * dx[1], gc[2] * dx[0] - gc[0] * dx[2], gc[0] * dx[1] - gc[1] * dx[0]};
        /* dP/dz at a pixel = P / z */
        const size_t q[4] = {p + W, p - W, p + 1, p - 1};
        const float sg[4] = {1, -1, 1, -1};
        for (int e = 0; e < 4; e++) {
          const float *g3 = e < 2 ? gx : gy;
          const float *P = t->pts + 3 * q[e];
          float z = mp.depth_median[q[e]];
          mg.depth_median[q[e]] += sg[e] * (g3[0] * P[0] + g3[1] * P[1] + g3[2] * P[2]) / z;
        }
      }
    value += t->o.lambda_normal * err_sum / (double)np;
  }
  s->value = value;
  return MGS_OK;
}

static void t2d_destroy(void *self) {
  t2d *t = self;
  if (t) free(t->pts);
  free(t);
}

static const mgs_term_ops t2d_ops = {"2dgs", t2d_active, t2d_image, NULL, NULL, NULL, t2d_destroy, NULL};

mgs_status mgs_term_2dgs_create(const mgs_2dgs_term_options *o, mgs_term **out, mgs_error *err) {
  *out = NULL;
  if (!(o->lambda_dist >= 0) || !(o->lambda_normal >= 0))
    return mgs_error_set(err, MGS_ERR_ARG, "2DGS losses: negative weight (dist %g, normal %g)", o->lambda_dist, o->lambda_normal);
  if (o->lambda_dist == 0 && o->lambda_normal == 0) return MGS_OK;
  t2d *t = calloc(1, sizeof *t);
  if (!t) return mgs_error_set(err, MGS_ERR_NOMEM, "2DGS losses: out of memory");
  t->o = *o;
  *out = mgs_term_create(&t2d_ops, t);
  return *out ? MGS_OK : mgs_error_set(err, MGS_ERR_NOMEM, "2DGS losses: out of memory");
}

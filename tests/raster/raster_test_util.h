/* Shared helpers of the rasterizer tests: random scenes, cameras, and an independent
 * brute-force reference renderer in double (no tiles, no binning: every pixel against
 * every Gaussian in one global depth order, the reference 3DGS rules written out again
 * from the paper's code, not from render/). */
#ifndef RASTER_TEST_UTIL_H
#define RASTER_TEST_UTIL_H
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "core/mgs_camera.h"
#include "core/mgs_gaussians.h"
#include "core/mgs_math.h"
#include "core/mgs_rng.h"
#include "render/mgs_raster.h"

typedef struct scene_opts {
  size_t n;
  double spread;          /* means uniform in [-spread, spread]^3 */
  double scale_lo, scale_hi; /* scales log-uniform */
  double logit_mu, logit_sigma;
  double sh_sigma;        /* std of SH rest coefficients */
} scene_opts;

static inline double rt_uniform(mgs_rng *r, double a, double b) { return a + (b - a) * mgs_rng_uniform(r); }

static inline mgs_gaussians *rt_random_scene(uint64_t seed, const scene_opts *o) {
  mgs_rng rng;
  mgs_rng_init(&rng, seed, 7);
  mgs_gaussians *g = mgs_gaussians_create(o->n, 3);
  size_t first;
  if (!g || mgs_gaussians_append(g, o->n, &first, NULL) != MGS_OK) return NULL;
  for (size_t i = 0; i < o->n; i++) {
    for (int k = 0; k < 3; k++) {
      g->mean[3 * i + k] = (float)rt_uniform(&rng, -o->spread, o->spread);
      g->log_scale[3 * i + k] = (float)rt_uniform(&rng, log(o->scale_lo), log(o->scale_hi)); /* log-uniform scale */
      g->sh_dc[3 * i + k] = (float)(0.8 * mgs_rng_normal(&rng));
    }
    double qs = rt_uniform(&rng, 0.5, 2.0); /* unnormalized on purpose */
    for (int k = 0; k < 4; k++) g->rot[4 * i + k] = (float)(qs * mgs_rng_normal(&rng));
    g->opacity[i] = (float)(o->logit_mu + o->logit_sigma * mgs_rng_normal(&rng));
    for (int k = 0; k < MGS_SH_REST_MAX; k++) g->sh_rest[MGS_SH_REST_MAX * i + k] = (float)(o->sh_sigma * mgs_rng_normal(&rng));
  }
  return g;
}

/* Camera at distance `dist` on a direction given by seed, looking at `target`. */
static inline void rt_camera(mgs_camera *cam, int w, int h, double fovx, double dist, const double target[3], uint64_t seed) {
  mgs_rng rng;
  mgs_rng_init(&rng, seed, 11);
  mgs_camera_init_fovx(cam, w, h, fovx);
  double d[3] = {mgs_rng_normal(&rng), mgs_rng_normal(&rng), mgs_rng_normal(&rng)};
  mgs_normalize3d(d);
  double eye[3] = {target[0] + dist * d[0], target[1] + dist * d[1], target[2] + dist * d[2]};
  double up[3] = {0, 0, 1};
  if (fabs(d[2]) > 0.95) { up[0] = 1; up[2] = 0; }
  mgs_camera_look_at(cam, eye, target, up);
}

/* ---------------- brute-force reference renderer (double) ---------------- */

typedef struct bf_gauss {
  int visible;
  double u, v, A, B, C, op, rgb[3], z;
  int rect[4];          /* tile rect x0, y0, x1, y1 */
  int radius;
  int ambiguous;        /* a rect/radius decision within rounding of its threshold */
  size_t idx;
} bf_gauss;

static inline void bf_sh(int deg, const float *dc, const float *rest, const double d[3], double rgb[3]) {
  const double C0 = 0.28209479177387814, C1 = 0.4886025119029199;
  const double C2[5] = {1.0925484305920792, -1.0925484305920792, 0.31539156525252005, -1.0925484305920792, 0.5462742152960396};
  const double C3[7] = {-0.5900435899266435, 2.890611442640554, -0.4570457994644658, 0.3731763325901154,
                        -0.4570457994644658, 1.445305721320277, -0.5900435899266435};
  double x = d[0], y = d[1], z = d[2];
  for (int c = 0; c < 3; c++) {
    const float *sh = rest + c; /* sh(k) = rest[3*(k-1) + c] */
#define SH(k) ((double)sh[3 * ((k) - 1)])
    double res = C0 * dc[c];
    if (deg > 0) {
      res = res - C1 * y * SH(1) + C1 * z * SH(2) - C1 * x * SH(3);
      if (deg > 1) {
        double xx = x * x, yy = y * y, zz = z * z, xy = x * y, yz = y * z, xz = x * z;
        res += C2[0] * xy * SH(4) + C2[1] * yz * SH(5) + C2[2] * (2.0 * zz - xx - yy) * SH(6) +
               C2[3] * xz * SH(7) + C2[4] * (xx - yy) * SH(8);
        if (deg > 2) {
          res += C3[0] * y * (3.0 * xx - yy) * SH(9) + C3[1] * xy * z * SH(10) +
                 C3[2] * y * (4.0 * zz - xx - yy) * SH(11) + C3[3] * z * (2.0 * zz - 3.0 * xx - 3.0 * yy) * SH(12) +
                 C3[4] * x * (4.0 * zz - xx - yy) * SH(13) + C3[5] * z * (xx - yy) * SH(14) +
                 C3[6] * x * (xx - 3.0 * yy) * SH(15);
        }
      }
    }
#undef SH
    res += 0.5;
    rgb[c] = res < 0 ? 0 : res;
  }
}

static inline int bf_near_int(double x, double tol) { return fabs(x - floor(x + 0.5)) < tol; }

static inline void bf_project(const mgs_gaussians *g, size_t i, const mgs_camera *cam, const mgs_raster_settings *s,
                              bf_gauss *o) {
  memset(o, 0, sizeof *o);
  o->idx = i;
  double m[3] = {g->mean[3 * i], g->mean[3 * i + 1], g->mean[3 * i + 2]}, t[3];
  mgs_camera_world_to_cam(cam, m, t);
  if (!(t[2] > s->near_plane)) return;
  double q[4] = {g->rot[4 * i], g->rot[4 * i + 1], g->rot[4 * i + 2], g->rot[4 * i + 3]}, R[9];
  mgs_quat_to_mat3d(q, R);
  double sc[3];
  for (int k = 0; k < 3; k++) sc[k] = s->scale_modifier * exp((double)g->log_scale[3 * i + k]);
  double Sig[9];
  for (int a = 0; a < 3; a++)
    for (int b = 0; b < 3; b++) {
      double acc = 0;
      for (int k = 0; k < 3; k++) acc += R[3 * a + k] * sc[k] * sc[k] * R[3 * b + k];
      Sig[3 * a + b] = acc;
    }
  double limx_lo = -cam->cx / cam->fx - 0.3 * 0.5 * cam->width / cam->fx;
  double limx_hi = (cam->width - cam->cx) / cam->fx + 0.3 * 0.5 * cam->width / cam->fx;
  double limy_lo = -cam->cy / cam->fy - 0.3 * 0.5 * cam->height / cam->fy;
  double limy_hi = (cam->height - cam->cy) / cam->fy + 0.3 * 0.5 * cam->height / cam->fy;
  double tx = mgs_clampd(t[0] / t[2], limx_lo, limx_hi) * t[2];
  double ty = mgs_clampd(t[1] / t[2], limy_lo, limy_hi) * t[2];
  double J[6] = {cam->fx / t[2], 0, -cam->fx * tx / (t[2] * t[2]), 0, cam->fy / t[2], -cam->fy * ty / (t[2] * t[2])};
  double Wr[9];
  for (int a = 0; a < 3; a++)
    for (int b = 0; b < 3; b++) Wr[3 * a + b] = cam->w2c[4 * a + b];
  double T[6];
  for (int a = 0; a < 2; a++)
    for (int b = 0; b < 3; b++) T[3 * a + b] = J[3 * a] * Wr[b] + J[3 * a + 1] * Wr[3 + b] + J[3 * a + 2] * Wr[6 + b];
  double cv[4];
  for (int a = 0; a < 2; a++)
    for (int b = 0; b < 2; b++) {
      double acc = 0;
      for (int k = 0; k < 3; k++)
        for (int l = 0; l < 3; l++) acc += T[3 * a + k] * Sig[3 * k + l] * T[3 * b + l];
      cv[2 * a + b] = acc;
    }
  double a = cv[0] + s->dilation, b = cv[1], c = cv[3] + s->dilation;
  double det = a * c - b * b;
  if (!(det > 0)) return;
  double mid = 0.5 * (a + c);
  double l1 = mid + sqrt(fmax(0.1, mid * mid - det));
  double r3 = 3.0 * sqrt(l1);
  int radius = (int)ceil(r3);
  double u = cam->fx * t[0] / t[2] + cam->cx, v = cam->fy * t[1] / t[2] + cam->cy;
  int tiles_x = (cam->width + 15) / 16, tiles_y = (cam->height + 15) / 16;
  double px = u - 0.5, py = v - 0.5;
  double args[4] = {(px - radius) / 16, (py - radius) / 16, (px + radius + 15) / 16, (py + radius + 15) / 16};
  int lim[4] = {tiles_x, tiles_y, tiles_x, tiles_y};
  for (int k = 0; k < 4; k++) {
    double x = args[k];
    o->rect[k] = x <= 0 ? 0 : (x >= lim[k] ? lim[k] : (int)x);
    if (bf_near_int(x, 2e-6) && x > -1e-3 && x < lim[k] + 1e-3) o->ambiguous = 1;
  }
  if (bf_near_int(r3, 3e-5)) o->ambiguous = 1;
  if ((o->rect[2] - o->rect[0]) * (o->rect[3] - o->rect[1]) == 0) return;
  o->visible = 1;
  o->radius = radius;
  o->u = u; o->v = v;
  o->A = c / det; o->B = -b / det; o->C = a / det;
  o->op = 1.0 / (1.0 + exp(-(double)g->opacity[i]));
  o->z = t[2];
  double cc[3];
  mgs_camera_center(cam, cc);
  double d[3] = {m[0] - cc[0], m[1] - cc[1], m[2] - cc[2]};
  mgs_normalize3d(d);
  bf_sh(s->sh_degree, g->sh_dc + 3 * i, g->sh_rest + MGS_SH_REST_MAX * i, d, o->rgb);
}

static int bf_cmp(const void *pa, const void *pb) {
  const bf_gauss *a = pa, *b = pb;
  float za = (float)a->z, zb = (float)b->z; /* the renderer sorts float depths */
  if (za != zb) return za < zb ? -1 : 1;
  return a->idx < b->idx ? -1 : (a->idx > b->idx ? 1 : 0);
}

/* Renders color (h*w*3), alpha, depth; marks pixels whose result hinges on a threshold
 * decision within float rounding (ambig[p] = 1). Returns the projected Gaussians (caller
 * frees) in index order in *proj if non-NULL. */
static inline void bf_render(const mgs_gaussians *g, const mgs_camera *cam, const mgs_raster_settings *s,
                             double *color, double *alpha, double *depth, unsigned char *ambig, bf_gauss **proj) {
  size_t n = g->n;
  bf_gauss *all = calloc(n ? n : 1, sizeof(bf_gauss));
  bf_gauss *vis = calloc(n ? n : 1, sizeof(bf_gauss));
  size_t nv = 0;
  for (size_t i = 0; i < n; i++) {
    bf_project(g, i, cam, s, &all[i]);
    if (all[i].visible) vis[nv++] = all[i];
  }
  qsort(vis, nv, sizeof(bf_gauss), bf_cmp);
  int W = cam->width, H = cam->height;
  for (int y = 0; y < H; y++)
    for (int x = 0; x < W; x++) {
      size_t p = (size_t)y * W + x;
      double T = 1, C[3] = {0, 0, 0}, D = 0;
      int amb = 0;
      int tx = x / 16, ty = y / 16;
      for (size_t k = 0; k < nv; k++) {
        const bf_gauss *q = &vis[k];
        double dx = x + 0.5 - q->u, dy = y + 0.5 - q->v;
        double power = -0.5 * (q->A * dx * dx + q->C * dy * dy) - q->B * dx * dy;
        double raw = q->op * exp(power);
        int inrect = tx >= q->rect[0] && tx < q->rect[2] && ty >= q->rect[1] && ty < q->rect[3];
        if (q->ambiguous && raw > 0.5 / 255) amb = 1;
        if (!inrect) continue;
        if (power > 0) continue;
        if (fabs(power) < 1e-5) amb = 1;
        double al = raw < 0.99 ? raw : 0.99;
        if (fabs(al - 1.0 / 255) < 5e-5 / 255) amb = 1;
        if (al < 1.0 / 255) continue;
        double testT = T * (1 - al);
        if (fabs(testT - 1e-4) < 1e-4 * 1e-4) amb = 1;
        if (testT < 1e-4) break;
        for (int c = 0; c < 3; c++) C[c] += q->rgb[c] * al * T;
        D += q->z * al * T;
        T = testT;
      }
      for (int c = 0; c < 3; c++) color[3 * p + c] = C[c] + T * s->background[c];
      alpha[p] = 1 - T;
      depth[p] = D;
      ambig[p] = (unsigned char)amb;
    }
  free(vis);
  if (proj) *proj = all; else free(all);
}
#endif

/* The reference for test_patchmatch.c's bit-identity test: render/patchmatch.c's
 * mgs_pm_run as it was before its speed-up (commit bab0493, the straightforward
 * per-hypothesis bilateral NCC), verbatim but for the entry's name (pm_ref_run) and
 * without mgs_pm_options_default. mgs_pm_run must give the same depth, normal and cost
 * maps, bit for bit, for the same inputs (the training runs of an experiment compare
 * across the change). Do not "fix" this copy: it is the definition of the old output. */
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "core/mgs_parallel.h"
#include "render/mgs_patchmatch.h"

mgs_status pm_ref_run(const mgs_pm_view *ref, const mgs_pm_view *src, int n_src, const float *init_depth,
                      const float *init_normal, const mgs_pm_options *o, float *depth, float *normal,
                      float *cost, mgs_error *err);

#define PM_COST_MAX 2.0f
#define PM_MAX_SRC 32
#define PM_LUT 1024 /* colour-weight table: |dc| in quarter grey levels */

/* Reference camera frame -> source pixel: X_src = R X_ref + t, then K_src. */
typedef struct pm_src {
  const float *gray;
  int w, h;
  float R[9], t[3];
  float fx, fy, cx, cy;
} pm_src;

typedef struct pm_ctx {
  const mgs_pm_options *o;
  const float *ref;
  int W, H;
  float fx, fy, cx, cy;
  pm_src src[PM_MAX_SRC];
  int n_src;
  float *plane; /* 4 per pixel: n (camera frame, unit, facing the camera), d: n.X + d = 0 */
  float *cost;
  uint8_t *flat; /* the reference window has (almost) no variance: no hypothesis can match */
  float wspatial[64 * 64]; /* per window offset, exp(-dist / (2 sigma_s^2)) as the authors */
  float wcolor[PM_LUT];
  int radius, step, iter, colour;
  int groups[8][11][2], gn[8]; /* neighbourhood groups (offsets), see pm_groups */
} pm_ctx;

/* ---- small helpers ------------------------------------------------------------------ */

static uint64_t pm_mix(uint64_t z) {
  z += 0x9E3779B97F4A7C15ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}
static float pm_uniform(uint64_t *s) { /* [0, 1) */
  *s = pm_mix(*s);
  return (float)((*s >> 40) * (1.0 / 16777216.0));
}

static void pm_ray(const pm_ctx *c, int x, int y, float r[3]) {
  r[0] = ((float)x + 0.5f - c->cx) / c->fx;
  r[1] = ((float)y + 0.5f - c->cy) / c->fy;
  r[2] = 1.0f;
}

/* Depth of the plane along pixel (x, y)'s ray; -1 where the ray misses it. */
static float pm_plane_depth(const pm_ctx *c, const float *pl, int x, int y) {
  float r[3];
  pm_ray(c, x, y, r);
  float nr = pl[0] * r[0] + pl[1] * r[1] + pl[2] * r[2];
  if (!(fabsf(nr) > 1e-8f)) return -1.0f;
  float z = -pl[3] / nr;
  return isfinite(z) ? z : -1.0f;
}

static void pm_set_d(const pm_ctx *c, float *pl, int x, int y, float depth) {
  float r[3];
  pm_ray(c, x, y, r);
  pl[3] = -(pl[0] * r[0] + pl[1] * r[1] + pl[2] * r[2]) * depth;
}

static void pm_normalize(float n[3]) {
  float l = sqrtf(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
  if (l > 0) for (int k = 0; k < 3; k++) n[k] /= l;
}

/* A uniformly random unit normal turned towards the camera (as the authors'). */
static void pm_random_normal(const pm_ctx *c, int x, int y, uint64_t *s, float n[3]) {
  float q1, q2, q;
  do {
    q1 = 2.0f * pm_uniform(s) - 1.0f;
    q2 = 2.0f * pm_uniform(s) - 1.0f;
    q = q1 * q1 + q2 * q2;
  } while (q >= 1.0f);
  float sq = sqrtf(1.0f - q);
  n[0] = 2.0f * q1 * sq; n[1] = 2.0f * q2 * sq; n[2] = 1.0f - 2.0f * q;
  float r[3];
  pm_ray(c, x, y, r);
  if (n[0] * r[0] + n[1] * r[1] + n[2] * r[2] > 0) for (int k = 0; k < 3; k++) n[k] = -n[k];
  pm_normalize(n);
}

/* The normal rotated by random angles in +-amp/2 about the three axes; the original if
 * the rotated one faces away from the camera. */
static void pm_perturb_normal(const pm_ctx *c, int x, int y, const float n[3], float amp, uint64_t *s, float out[3]) {
  float a1 = (pm_uniform(s) - 0.5f) * amp, a2 = (pm_uniform(s) - 0.5f) * amp, a3 = (pm_uniform(s) - 0.5f) * amp;
  float s1 = sinf(a1), s2 = sinf(a2), s3 = sinf(a3), c1 = cosf(a1), c2 = cosf(a2), c3 = cosf(a3);
  float R[9] = {c2 * c3, c3 * s1 * s2 - c1 * s3, s1 * s3 + c1 * c3 * s2,
                c2 * s3, c1 * c3 + s1 * s2 * s3, c1 * s2 * s3 - c3 * s1,
                -s2,     c2 * s1,                c1 * c2};
  for (int k = 0; k < 3; k++) out[k] = R[3 * k] * n[0] + R[3 * k + 1] * n[1] + R[3 * k + 2] * n[2];
  float r[3];
  pm_ray(c, x, y, r);
  if (out[0] * r[0] + out[1] * r[1] + out[2] * r[2] >= 0) memcpy(out, n, 3 * sizeof(float));
  pm_normalize(out);
}

static float pm_bilinear(const float *img, int w, int h, float u, float v) {
  /* u, v continuous with pixel centres at +0.5; clamped at the border (texture clamp) */
  float fx = u - 0.5f, fy = v - 0.5f;
  if (!(fx >= 0)) fx = 0; /* also NaN (a near-degenerate homography) */
  if (!(fy >= 0)) fy = 0;
  if (!(fx <= (float)(w - 1))) fx = (float)(w - 1);
  if (!(fy <= (float)(h - 1))) fy = (float)(h - 1);
  int x0 = (int)fx, y0 = (int)fy;
  int x1 = x0 + 1 < w ? x0 + 1 : x0, y1 = y0 + 1 < h ? y0 + 1 : y0;
  float ax = fx - (float)x0, ay = fy - (float)y0;
  const float *r0 = img + (size_t)y0 * (size_t)w, *r1 = img + (size_t)y1 * (size_t)w;
  return (1 - ay) * ((1 - ax) * r0[x0] + ax * r0[x1]) + ay * ((1 - ax) * r1[x0] + ax * r1[x1]);
}

/* ---- cost ----------------------------------------------------------------------------- */

/* Homography of the plane from reference pixels to source pixels: K_s (R - t n^T / d) K_r^-1. */
static int pm_homography(const pm_ctx *c, const pm_src *s, const float *pl, float Hm[9]) {
  if (!(fabsf(pl[3]) > 1e-12f)) return 0;
  float A[9];
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++) A[3 * i + j] = s->R[3 * i + j] - s->t[i] * pl[j] / pl[3];
  /* times K_r^-1 = [1/fx 0 -cx/fx; 0 1/fy -cy/fy; 0 0 1] */
  float B[9];
  for (int i = 0; i < 3; i++) {
    B[3 * i] = A[3 * i] / c->fx;
    B[3 * i + 1] = A[3 * i + 1] / c->fy;
    B[3 * i + 2] = -A[3 * i] * c->cx / c->fx - A[3 * i + 1] * c->cy / c->fy + A[3 * i + 2];
  }
  for (int j = 0; j < 3; j++) {
    Hm[j] = s->fx * B[j] + s->cx * B[6 + j];
    Hm[3 + j] = s->fy * B[3 + j] + s->cy * B[6 + j];
    Hm[6 + j] = B[6 + j];
  }
  return 1;
}

/* The authors' bilateral NCC of the window around (x, y) against one source: 1 - ncc in
 * [0, 2]; PM_COST_MAX when the centre leaves the source image, the plane is behind it, or
 * either window is flat. */
static float pm_ncc(const pm_ctx *c, const pm_src *s, const float *pl, int x, int y) {
  float Hm[9];
  if (!pm_homography(c, s, pl, Hm)) return PM_COST_MAX;
  float u0 = (float)x + 0.5f, v0 = (float)y + 0.5f;
  float zc = Hm[6] * u0 + Hm[7] * v0 + Hm[8];
  if (!(zc > 1e-8f)) return PM_COST_MAX;
  float uc = (Hm[0] * u0 + Hm[1] * v0 + Hm[2]) / zc, vc = (Hm[3] * u0 + Hm[4] * v0 + Hm[5]) / zc;
  if (!(uc >= 0 && uc < (float)s->w && vc >= 0 && vc < (float)s->h)) return PM_COST_MAX;
  const int W = c->W, Hh = c->H, r = c->radius, st = c->step, side = 2 * r + 1;
  const float centre = c->ref[(size_t)y * (size_t)W + (size_t)x];
  double sw = 0, sr = 0, srr = 0, ss = 0, sss = 0, srs = 0;
  for (int j = -r; j <= r; j += st) {
    int yy = y + j;
    if (yy < 0 || yy >= Hh) continue;
    const float *row = c->ref + (size_t)yy * (size_t)W;
    float v = (float)yy + 0.5f;
    for (int i = -r; i <= r; i += st) {
      int xx = x + i;
      if (xx < 0 || xx >= W) continue;
      float rp = row[xx];
      float u = (float)xx + 0.5f;
      float z = Hm[6] * u + Hm[7] * v + Hm[8];
      if (!(z > 1e-8f)) return PM_COST_MAX;
      float sp = pm_bilinear(s->gray, s->w, s->h, (Hm[0] * u + Hm[1] * v + Hm[2]) / z, (Hm[3] * u + Hm[4] * v + Hm[5]) / z);
      float q = fabsf(rp - centre) * 4.0f;
      int li = q < (float)PM_LUT ? (int)q : PM_LUT;
      float wgt = c->wspatial[(j + r) * side + (i + r)] * (li < PM_LUT ? c->wcolor[li] : 0.0f);
      sw += wgt; sr += wgt * rp; srr += wgt * rp * rp; ss += wgt * sp; sss += wgt * sp * sp; srs += wgt * rp * sp;
    }
  }
  if (!(sw > 0)) return PM_COST_MAX;
  sr /= sw; srr /= sw; ss /= sw; sss /= sw; srs /= sw;
  double vr = srr - sr * sr, vs = sss - ss * ss;
  if (vr < 1e-5 || vs < 1e-5) return PM_COST_MAX;
  double cst = 1.0 - (srs - sr * ss) / sqrt(vr * vs);
  return (float)(cst < 0 ? 0 : cst > PM_COST_MAX ? PM_COST_MAX : cst);
}

/* The reference window's weighted variance is below the NCC's minimum: every hypothesis
 * costs the maximum there (plain background), so the pixel is skipped. */
static int pm_ref_flat(const pm_ctx *c, int x, int y) {
  const int W = c->W, Hh = c->H, r = c->radius, st = c->step, side = 2 * r + 1;
  const float centre = c->ref[(size_t)y * (size_t)W + (size_t)x];
  double sw = 0, sr = 0, srr = 0;
  for (int j = -r; j <= r; j += st) {
    int yy = y + j;
    if (yy < 0 || yy >= Hh) continue;
    for (int i = -r; i <= r; i += st) {
      int xx = x + i;
      if (xx < 0 || xx >= W) continue;
      float rp = c->ref[(size_t)yy * (size_t)W + (size_t)xx];
      float q = fabsf(rp - centre) * 4.0f;
      int li = q < (float)PM_LUT ? (int)q : PM_LUT;
      float wgt = c->wspatial[(j + r) * side + (i + r)] * (li < PM_LUT ? c->wcolor[li] : 0.0f);
      sw += wgt; sr += wgt * rp; srr += wgt * rp * rp;
    }
  }
  if (!(sw > 0)) return 1;
  sr /= sw; srr /= sw;
  return srr - sr * sr < 1e-5;
}

/* Multi-view cost: the mean of the best top_k view costs below the maximum. */
static float pm_cost(const pm_ctx *c, const float *pl, int x, int y) {
  float v[PM_MAX_SRC];
  int nv = 0;
  for (int j = 0; j < c->n_src; j++) {
    float q = pm_ncc(c, &c->src[j], pl, x, y);
    if (q < PM_COST_MAX) {
      int k = nv++;
      while (k > 0 && v[k - 1] > q) { v[k] = v[k - 1]; k--; }
      v[k] = q;
    }
  }
  int k = nv < c->o->top_k ? nv : c->o->top_k;
  if (k <= 0) return PM_COST_MAX;
  float sum = 0;
  for (int i = 0; i < k; i++) sum += v[i];
  return sum / (float)k;
}

static int pm_depth_ok(const pm_ctx *c, float z) { return z >= c->o->depth_min && z <= c->o->depth_max; }

/* ---- initialisation --------------------------------------------------------------------- */

typedef struct pm_init_args {
  pm_ctx *c;
  const float *depth, *normal; /* normal: camera frame, 3 per pixel, or NULL */
} pm_init_args;

static void pm_init_rows(void *vctx, size_t b, size_t e) {
  pm_init_args *a = vctx;
  pm_ctx *c = a->c;
  for (size_t y = b; y < e; y++)
    for (int x = 0; x < c->W; x++) {
      size_t p = y * (size_t)c->W + (size_t)x;
      uint64_t s = c->o->seed * 0x2545F4914F6CDD1Dull ^ (uint64_t)p * 0x9E3779B97F4A7C15ull;
      float *pl = c->plane + 4 * p;
      float z = a->depth[p];
      if (!(z >= c->o->depth_min && z <= c->o->depth_max)) z = c->o->depth_min + pm_uniform(&s) * (c->o->depth_max - c->o->depth_min);
      int have_n = 0;
      if (a->normal) {
        const float *n = a->normal + 3 * p;
        float r[3];
        pm_ray(c, x, (int)y, r);
        float l = sqrtf(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        if (l > 0.5f && n[0] * r[0] + n[1] * r[1] + n[2] * r[2] < 0) {
          for (int k = 0; k < 3; k++) pl[k] = n[k] / l;
          have_n = 1;
        }
      }
      if (!have_n) pm_random_normal(c, x, (int)y, &s, pl);
      pm_set_d(c, pl, x, (int)y, z);
      c->flat[p] = pm_ref_flat(c, x, (int)y);
      c->cost[p] = c->flat[p] ? PM_COST_MAX : pm_cost(c, pl, x, (int)y);
    }
}

/* ---- one half-sweep ------------------------------------------------------------------------ */

/* The cheapest of the listed other-colour pixels (offsets dx, dy), -1 if none in bounds. */
static long pm_best_of(const pm_ctx *c, int x, int y, const int (*off)[2], int n) {
  long best = -1;
  float bc = FLT_MAX;
  for (int i = 0; i < n; i++) {
    int xx = x + off[i][0], yy = y + off[i][1];
    if (xx < 0 || yy < 0 || xx >= c->W || yy >= c->H) continue;
    long q = (long)yy * c->W + xx;
    if (c->cost[q] < bc) { bc = c->cost[q]; best = q; }
  }
  return best;
}

/* Tries plane `cand` at (x, y); keeps it if cheaper and its depth is in range. */
static void pm_try(const pm_ctx *c, int x, int y, const float cand[4], float *pl, float *cost) {
  float z = pm_plane_depth(c, cand, x, y);
  if (!pm_depth_ok(c, z)) return;
  float q = pm_cost(c, cand, x, y);
  if (q < *cost) { memcpy(pl, cand, 4 * sizeof(float)); *cost = q; }
}

/* ACMH's neighbourhood groups: 4 "V"s of near pixels and 4 far lines, every offset an odd
 * step away (the other colour). */
static void pm_groups(pm_ctx *c) {
  static const int dir[4][2] = {{0, -1}, {0, 1}, {-1, 0}, {1, 0}};
  for (int d = 0; d < 4; d++) {
    int ax = dir[d][0], ay = dir[d][1], px = ay, py = ax; /* along, across */
    int k = 0;
    c->groups[d][k][0] = ax; c->groups[d][k][1] = ay; k++;
    for (int i = 1; i <= 2; i++)
      for (int sgn = -1; sgn <= 1; sgn += 2) {
        c->groups[d][k][0] = ax * (1 + i) + sgn * i * px;
        c->groups[d][k][1] = ay * (1 + i) + sgn * i * py;
        k++;
      }
    c->gn[d] = k;
    for (int i = 0; i < 11; i++) { c->groups[4 + d][i][0] = ax * (3 + 2 * i); c->groups[4 + d][i][1] = ay * (3 + 2 * i); }
    c->gn[4 + d] = 11;
  }
}

static void pm_update(const pm_ctx *c, int x, int y) {
  size_t p = (size_t)y * (size_t)c->W + (size_t)x;
  if (c->flat[p]) return;
  float *pl = c->plane + 4 * p;
  float cost = c->cost[p];
  for (int g = 0; g < 8; g++) {
    long q = pm_best_of(c, x, y, (const int (*)[2])c->groups[g], c->gn[g]);
    if (q < 0) continue;
    float cand[4];
    memcpy(cand, c->plane + 4 * q, sizeof cand);
    pm_try(c, x, y, cand, pl, &cost);
  }
  /* refinement: the authors' five (depth, normal) pairs from random, current, perturbed */
  uint64_t s = (c->o->seed + 0x632BE59BD9B4E019ull * (uint64_t)(c->iter + 1)) ^ (uint64_t)p * 0xD1B54A32D192ED03ull;
  const mgs_pm_options *o = c->o;
  float z_now = pm_plane_depth(c, pl, x, y);
  if (!pm_depth_ok(c, z_now)) z_now = o->depth_min + pm_uniform(&s) * (o->depth_max - o->depth_min);
  float z_rand = o->depth_min + pm_uniform(&s) * (o->depth_max - o->depth_min);
  float z_pert = z_now * (1.0f - o->perturbation + 2.0f * o->perturbation * pm_uniform(&s));
  float n_now[3] = {pl[0], pl[1], pl[2]}, n_rand[3], n_pert[3];
  pm_random_normal(c, x, y, &s, n_rand);
  pm_perturb_normal(c, x, y, n_now, o->perturbation * (float)M_PI, &s, n_pert);
  const float *zs[5] = {&z_rand, &z_now, &z_rand, &z_now, &z_pert};
  const float *ns[5] = {n_now, n_rand, n_rand, n_pert, n_now};
  for (int h = 0; h < 5; h++) {
    float cand[4] = {ns[h][0], ns[h][1], ns[h][2], 0};
    pm_set_d(c, cand, x, y, *zs[h]);
    pm_try(c, x, y, cand, pl, &cost);
  }
  c->cost[p] = cost;
}

static void pm_sweep_rows(void *vctx, size_t b, size_t e) {
  pm_ctx *c = vctx;
  for (size_t y = b; y < e; y++)
    for (int x = (int)((y + (size_t)c->colour) & 1u); x < c->W; x += 2) pm_update(c, x, (int)y);
}

/* ---- entry ------------------------------------------------------------------------------- */

static void rigid_parts(const double m[16], double R[9], double t[3]) {
  for (int i = 0; i < 3; i++) {
    for (int j = 0; j < 3; j++) R[3 * i + j] = m[4 * i + j];
    t[i] = m[4 * i + 3];
  }
}

mgs_status pm_ref_run(const mgs_pm_view *ref, const mgs_pm_view *src, int n_src, const float *init_depth,
                      const float *init_normal, const mgs_pm_options *o, float *depth, float *normal,
                      float *cost, mgs_error *err) {
  if (!ref || !ref->cam || !ref->gray || !init_depth || !o)
    return mgs_error_set(err, MGS_ERR_ARG, "patch match: missing reference view or initial depth");
  if (n_src < 1 || n_src > PM_MAX_SRC || !src)
    return mgs_error_set(err, MGS_ERR_ARG, "patch match: %d source views (1..%d)", n_src, PM_MAX_SRC);
  if (o->patch_size < 1 || o->patch_size > 62 || o->patch_step < 1 || o->iterations < 0 || o->top_k < 1 ||
      !(o->sigma_spatial > 0) || !(o->sigma_color > 0) || !(o->depth_min > 0) || !(o->depth_max > o->depth_min) ||
      !(o->perturbation >= 0 && o->perturbation < 1))
    return mgs_error_set(err, MGS_ERR_ARG, "patch match: invalid options (patch %d step %d, depth range [%g, %g])",
                         o->patch_size, o->patch_step, (double)o->depth_min, (double)o->depth_max);
  pm_ctx *c = calloc(1, sizeof *c);
  if (!c) return mgs_error_set(err, MGS_ERR_NOMEM, "patch match: out of memory");
  const mgs_camera *rc = ref->cam;
  c->o = o;
  c->ref = ref->gray;
  c->W = rc->width;
  c->H = rc->height;
  c->fx = (float)rc->fx; c->fy = (float)rc->fy; c->cx = (float)rc->cx; c->cy = (float)rc->cy;
  c->n_src = n_src;
  c->radius = o->patch_size / 2;
  c->step = o->patch_step;
  pm_groups(c);
  double Rr[9], tr[3];
  rigid_parts(rc->c2w, Rr, tr); /* reference camera -> world */
  for (int j = 0; j < n_src; j++) {
    const mgs_camera *sc = src[j].cam;
    if (!sc || !src[j].gray) { free(c); return mgs_error_set(err, MGS_ERR_ARG, "patch match: source view %d has no image", j); }
    double Rs[9], ts[3];
    rigid_parts(sc->w2c, Rs, ts);
    pm_src *s = &c->src[j];
    /* in double: far-from-origin scenes cancel their large translations here */
    for (int i = 0; i < 3; i++) {
      double ti = ts[i];
      for (int k = 0; k < 3; k++) {
        double rik = 0;
        for (int m = 0; m < 3; m++) rik += Rs[3 * i + m] * Rr[3 * m + k];
        s->R[3 * i + k] = (float)rik;
        ti += Rs[3 * i + k] * tr[k];
      }
      s->t[i] = (float)ti;
    }
    s->gray = src[j].gray;
    s->w = sc->width; s->h = sc->height;
    s->fx = (float)sc->fx; s->fy = (float)sc->fy; s->cx = (float)sc->cx; s->cy = (float)sc->cy;
  }
  const int r = c->radius, side = 2 * r + 1;
  for (int j = -r; j <= r; j++)
    for (int i = -r; i <= r; i++)
      c->wspatial[(j + r) * side + (i + r)] = expf(-sqrtf((float)(i * i + j * j)) / (2.0f * o->sigma_spatial * o->sigma_spatial));
  for (int l = 0; l < PM_LUT; l++) c->wcolor[l] = expf(-((float)l + 0.5f) * 0.25f / (2.0f * o->sigma_color * o->sigma_color));
  size_t np = (size_t)c->W * (size_t)c->H;
  c->plane = malloc(4 * np * sizeof(float));
  c->cost = malloc(np * sizeof(float));
  c->flat = malloc(np);
  float *ncam = init_normal ? malloc(3 * np * sizeof(float)) : NULL;
  if (!c->plane || !c->cost || !c->flat || (init_normal && !ncam)) {
    free(c->plane); free(c->cost); free(c->flat); free(ncam); free(c);
    return mgs_error_set(err, MGS_ERR_NOMEM, "patch match: out of memory (%dx%d)", rc->width, rc->height);
  }
  if (ncam) /* world -> reference camera frame: R_w2c n */
    for (size_t p = 0; p < np; p++)
      for (int i = 0; i < 3; i++)
        ncam[3 * p + i] = (float)(rc->w2c[4 * i] * init_normal[3 * p] + rc->w2c[4 * i + 1] * init_normal[3 * p + 1] +
                                  rc->w2c[4 * i + 2] * init_normal[3 * p + 2]);
  pm_init_args ia = {c, init_depth, ncam};
  mgs_parallel_for(0, (size_t)c->H, 1, pm_init_rows, &ia);
  free(ncam);
  for (int it = 0; it < o->iterations; it++)
    for (int colour = 0; colour < 2; colour++) {
      c->iter = 2 * it + colour;
      c->colour = colour;
      mgs_parallel_for(0, (size_t)c->H, 1, pm_sweep_rows, c);
    }
  for (size_t p = 0; p < np; p++) {
    const float *pl = c->plane + 4 * p;
    int x = (int)(p % (size_t)c->W), y = (int)(p / (size_t)c->W);
    if (depth) {
      float z = pm_plane_depth(c, pl, x, y);
      depth[p] = z > 0 ? z : 0.0f;
    }
    if (normal)
      for (int i = 0; i < 3; i++)
        normal[3 * p + i] = (float)(Rr[3 * i] * pl[0] + Rr[3 * i + 1] * pl[1] + Rr[3 * i + 2] * pl[2]);
    if (cost) cost[p] = c->cost[p];
  }
  free(c->plane);
  free(c->cost);
  free(c->flat);
  free(c);
  return MGS_OK;
}

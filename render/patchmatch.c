/* Plane patch matching of one reference view (render/mgs_patchmatch.h), after the
 * authors' CUDA kernel (GaussianPro's Propagation.cu, itself ACMH): bilateral-weighted NCC
 * through the plane-induced homography, red/black checkerboard propagation from 8
 * neighbourhood groups (4 near "V" groups, 4 far lines, each represented by its cheapest
 * member), then a refinement among random and perturbed depths and normals.
 *
 * Deliberate differences, each said where it is made:
 *  - a hypothesis' multi-view cost is the mean of its best top_k view costs (the
 *    authors' initial cost) everywhere; ACMH's Monte-Carlo view weighting from the
 *    neighbours' costs is left out (with the 2-4 views GaussianPro passes it picks nearly
 *    the same views);
 *  - neighbours are read from the other colour only, so a half-sweep never reads what it
 *    writes (the authors' near groups also touch same-colour pixels being updated
 *    concurrently, a race);
 *  - the final median filter of the depth is left out (the geometric consistency check
 *    that follows in GaussianPro removes what it would).
 *
 * Speed (docs/notes/gaussianpro.md, "Faster patch matching"): the reference window's
 * weights and moments are computed once per pixel and sweep, not per hypothesis and
 * source; a source's samples go through vectorisable passes; four sources' double sums
 * run side by side. Every float and double operation is the one of the straightforward
 * loop, in the same order, so the maps are bit-identical to it (tests/raster/
 * patchmatch_ref.c keeps that loop; render_patchmatch compares). */
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "core/mgs_parallel.h"
#include "render/mgs_patchmatch.h"

#define PM_COST_MAX 2.0f
#define PM_MAX_SRC 32
#define PM_LUT 1024 /* colour-weight table: |dc| in quarter grey levels */

void mgs_pm_options_default(mgs_pm_options *o) {
  o->patch_size = 20;
  o->patch_step = 2;
  o->sigma_spatial = 5.0f;
  o->sigma_color = 3.0f;
  o->iterations = 6;
  o->top_k = 4;
  o->perturbation = 0.02f;
  o->depth_min = 0.01f;
  o->depth_max = 1e4f;
  o->seed = 1;
}

/* Reference camera frame -> source pixel: X_src = R X_ref + t, then K_src. */
typedef struct pm_src {
  const float *gray;
  float *pad; /* gray with its last column and row repeated once, (w + 1) x (h + 1) */
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
  float *scratch; /* per thread: PM_SCRATCH_ARRAYS arrays of win_cap floats / ints (pm_scratch) */
  size_t win_cap;  /* window samples at most */
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

/* The reference side of one pixel's window, the same for every hypothesis and source
 * (computed once per pixel and sweep instead of once per hypothesis and source): the
 * in-bounds samples in the order the authors' loop visits them (rows, then columns),
 * their pixel centres, bilateral weights and weight x grey, and the weighted moments.
 * Each value is the same float / double expression as when it was summed per source, so
 * the costs are bit-identical. */
typedef struct pm_win {
  int n;
  float *u, *v, *w, *wr;  /* n each, from pm_scratch */
  double sw, mr, vr;      /* sum of weights; weighted mean and variance (valid if sw > 0) */
} pm_win;

/* Per-thread work arrays of win_cap entries (11 + 3 x PM_LANES, ~11 KB at the authors'
 * 11 x 11 samples): the window, one source's samples, and the NCC's three summands of
 * PM_LANES sources (source `lane`'s at lane x win_cap). */
#define PM_LANES 4
typedef struct pm_scratch {
  float *u, *v, *w, *wr;    /* the window (pm_win) */
  float *pu, *pv, *top, *bot; /* one source's samples (top, bot: 2 x win_cap) */
  int32_t *idx;
  float *pss, *psss, *psrs; /* PM_LANES x win_cap each */
} pm_scratch;
#define PM_SCRATCH_ARRAYS (11 + 3 * PM_LANES)

static void pm_window(const pm_ctx *c, int x, int y, const pm_scratch *sc, pm_win *win) {
  const int W = c->W, Hh = c->H, r = c->radius, st = c->step, side = 2 * r + 1;
  const float centre = c->ref[(size_t)y * (size_t)W + (size_t)x];
  double sw = 0, sr = 0, srr = 0;
  int n = 0;
  win->u = sc->u; win->v = sc->v; win->w = sc->w; win->wr = sc->wr;
  for (int j = -r; j <= r; j += st) {
    int yy = y + j;
    if (yy < 0 || yy >= Hh) continue;
    const float *row = c->ref + (size_t)yy * (size_t)W;
    float v = (float)yy + 0.5f;
    for (int i = -r; i <= r; i += st) {
      int xx = x + i;
      if (xx < 0 || xx >= W) continue;
      float rp = row[xx];
      float q = fabsf(rp - centre) * 4.0f;
      int li = q < (float)PM_LUT ? (int)q : PM_LUT;
      float wgt = c->wspatial[(j + r) * side + (i + r)] * (li < PM_LUT ? c->wcolor[li] : 0.0f);
      float wrp = wgt * rp;
      sw += wgt; sr += wrp; srr += wrp * rp;
      win->u[n] = (float)xx + 0.5f; win->v[n] = v; win->w[n] = wgt; win->wr[n] = wrp;
      n++;
    }
  }
  win->n = n;
  win->sw = sw;
  win->mr = win->vr = 0;
  if (sw > 0) {
    sr /= sw; srr /= sw;
    win->mr = sr;
    win->vr = srr - sr * sr;
  }
}

/* The reference window's weighted variance is below the NCC's minimum: every hypothesis
 * costs the maximum there (plain background), so the pixel is skipped. */
static int pm_win_flat(const pm_win *win) { return !(win->sw > 0) || win->vr < 1e-5; }

/* The passes of one source's NCC samples, each a loop the compiler vectorises (restrict
 * parameters: no aliasing checks), in the authors' float expressions. */

/* Window samples through the homography; nonzero if one lands behind the source (the
 * authors' loop rejects the plane there). */
static int pm_project(int n, const float *restrict u, const float *restrict v, const float *Hm, float *restrict pu,
                      float *restrict pv) {
  const float h0 = Hm[0], h1 = Hm[1], h2 = Hm[2], h3 = Hm[3], h4 = Hm[4], h5 = Hm[5], h6 = Hm[6], h7 = Hm[7], h8 = Hm[8];
  int behind = 0;
  for (int k = 0; k < n; k++) {
    float z = h6 * u[k] + h7 * v[k] + h8;
    behind |= !(z > 1e-8f);
    pu[k] = (h0 * u[k] + h1 * v[k] + h2) / z;
    pv[k] = (h3 * u[k] + h4 * v[k] + h5) / z;
  }
  return behind;
}

/* Bilinear sampling of the source at the projected samples (texture clamp: u, v with pixel
 * centres at +0.5 clamped to the outer centres, NaN to the first), in three passes. The
 * clamp: per sample the top-left texel's index in the padded image and the fractions (in
 * place of pu, pv). The padding repeats the last column and row, so the right / lower
 * neighbour read there is the texel itself, as the clamp to x0 / y0 did. */
static void pm_texels(int n, int w, int h, float *restrict fu, float *restrict fv, int32_t *restrict idx) {
  const float wm1 = (float)(w - 1), hm1 = (float)(h - 1);
  for (int k = 0; k < n; k++) {
    float fx = fu[k] - 0.5f, fy = fv[k] - 0.5f;
    fx = fx >= 0 ? fx : 0.0f; /* also NaN */
    fy = fy >= 0 ? fy : 0.0f;
    fx = fx <= wm1 ? fx : wm1;
    fy = fy <= hm1 ? fy : hm1;
    int32_t x0 = (int32_t)fx, y0 = (int32_t)fy;
    fu[k] = fx - (float)x0;
    fv[k] = fy - (float)y0;
    idx[k] = y0 * (w + 1) + x0;
  }
}

/* The texel pairs (x0, x0 + 1) of rows y0 and y0 + 1. Deliberately without restrict: GCC
 * then keeps scalar loads instead of AVX2 gathers, which made the whole patch match 1.25x
 * slower on the AMD EPYC measured. */
static void pm_fetch(int n, const float *pad, int pitch, const int32_t *idx, float *top, float *bot) {
  for (int k = 0; k < n; k++) {
    memcpy(top + 2 * k, pad + idx[k], 2 * sizeof(float));
    memcpy(bot + 2 * k, pad + idx[k] + pitch, 2 * sizeof(float));
  }
}

/* The blend (the authors' expression), then the NCC's summands w*sp, w*sp*sp, (w*rp)*sp. */
static void pm_blend(int n, const float *restrict fu, const float *restrict fv, const float *restrict top,
                     const float *restrict bot, const float *restrict w, const float *restrict wr, float *restrict pss,
                     float *restrict psss, float *restrict psrs) {
  for (int k = 0; k < n; k++) {
    float ax = fu[k], ay = fv[k];
    float sp = (1 - ay) * ((1 - ax) * top[2 * k] + ax * top[2 * k + 1]) + ay * ((1 - ax) * bot[2 * k] + ax * bot[2 * k + 1]);
    float ws = w[k] * sp;
    pss[k] = ws; psss[k] = ws * sp; psrs[k] = wr[k] * sp;
  }
}

/* One source's share of the authors' bilateral NCC of the window around (x, y): the
 * summands of its samples into `lane`; 0 (cost PM_COST_MAX) when the centre leaves the
 * source image or the plane is behind it at any window sample. */
static int pm_ncc_samples(const pm_ctx *c, const pm_src *s, const float *pl, int x, int y, const pm_win *win,
                          const pm_scratch *sc, int lane) {
  float Hm[9];
  if (!pm_homography(c, s, pl, Hm)) return 0;
  float u0 = (float)x + 0.5f, v0 = (float)y + 0.5f;
  float zc = Hm[6] * u0 + Hm[7] * v0 + Hm[8];
  if (!(zc > 1e-8f)) return 0;
  float uc = (Hm[0] * u0 + Hm[1] * v0 + Hm[2]) / zc, vc = (Hm[3] * u0 + Hm[4] * v0 + Hm[5]) / zc;
  if (!(uc >= 0 && uc < (float)s->w && vc >= 0 && vc < (float)s->h)) return 0;
  const int n = win->n;
  if (pm_project(n, win->u, win->v, Hm, sc->pu, sc->pv)) return 0;
  pm_texels(n, s->w, s->h, sc->pu, sc->pv, sc->idx);
  pm_fetch(n, s->pad, s->w + 1, sc->idx, sc->top, sc->bot);
  const size_t m = c->win_cap * (size_t)lane;
  pm_blend(n, sc->pu, sc->pv, sc->top, sc->bot, win->w, win->wr, sc->pss + m, sc->psss + m, sc->psrs + m);
  return 1;
}

/* The NCC of each live lane from its summands. Each lane's three double sums take its
 * samples in the authors' order, so they are the same sums; one vector lane per source
 * (GCC/Clang vector extension) runs four such sequences side by side instead of one
 * addition latency after another. Dead lanes add stale numbers that are never read. */
typedef double pm_v4d __attribute__((vector_size(4 * sizeof(double))));
static void pm_ncc_lanes(const pm_ctx *c, const pm_win *win, const pm_scratch *sc, const int live[PM_LANES],
                         float q[PM_LANES]) {
  const size_t m = c->win_cap;
  const float *restrict a = sc->pss, *restrict b = sc->psss, *restrict d = sc->psrs;
  pm_v4d ss = {0, 0, 0, 0}, sss = ss, srs = ss;
  for (int k = 0; k < win->n; k++) {
    ss += (pm_v4d){a[k], a[m + k], a[2 * m + k], a[3 * m + k]};
    sss += (pm_v4d){b[k], b[m + k], b[2 * m + k], b[3 * m + k]};
    srs += (pm_v4d){d[k], d[m + k], d[2 * m + k], d[3 * m + k]};
  }
  for (int l = 0; l < PM_LANES; l++) {
    q[l] = PM_COST_MAX;
    double sw = win->sw;
    if (!live[l] || !(sw > 0)) continue;
    double mss = ss[l] / sw, msss = sss[l] / sw, msrs = srs[l] / sw;
    double sr = win->mr, vr = win->vr, vs = msss - mss * mss;
    if (vr < 1e-5 || vs < 1e-5) continue;
    double cst = 1.0 - (msrs - sr * mss) / sqrt(vr * vs);
    q[l] = (float)(cst < 0 ? 0 : cst > PM_COST_MAX ? PM_COST_MAX : cst);
  }
}

/* Multi-view cost: the mean of the best top_k view costs below the maximum. */
static float pm_cost(const pm_ctx *c, const float *pl, int x, int y, const pm_win *win, const pm_scratch *sc) {
  float qs[PM_MAX_SRC + PM_LANES];
  for (int j0 = 0; j0 < c->n_src; j0 += PM_LANES) {
    int live[PM_LANES], any = 0;
    for (int l = 0; l < PM_LANES; l++) {
      live[l] = j0 + l < c->n_src && pm_ncc_samples(c, &c->src[j0 + l], pl, x, y, win, sc, l);
      any |= live[l];
    }
    if (any) pm_ncc_lanes(c, win, sc, live, qs + j0);
    else for (int l = 0; l < PM_LANES; l++) qs[j0 + l] = PM_COST_MAX;
  }
  float v[PM_MAX_SRC];
  int nv = 0;
  for (int j = 0; j < c->n_src; j++) {
    float q = qs[j];
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

static pm_scratch pm_thread_scratch(const pm_ctx *c) {
  const size_t m = c->win_cap;
  float *b = c->scratch + (size_t)mgs_parallel_thread_index() * PM_SCRATCH_ARRAYS * m;
  int32_t *ib = (int32_t *)(b + 10 * m);
  float *pb = b + 11 * m;
  pm_scratch sc = {b,         b + m, b + 2 * m,         b + 3 * m,  b + 4 * m, b + 5 * m, b + 6 * m, b + 8 * m,
                   ib,        pb,    pb + PM_LANES * m, pb + 2 * PM_LANES * m};
  return sc;
}

static void pm_init_rows(void *vctx, size_t b, size_t e) {
  pm_init_args *a = vctx;
  pm_ctx *c = a->c;
  const pm_scratch sc = pm_thread_scratch(c);
  pm_win win;
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
      pm_window(c, x, (int)y, &sc, &win);
      c->flat[p] = (uint8_t)pm_win_flat(&win);
      c->cost[p] = c->flat[p] ? PM_COST_MAX : pm_cost(c, pl, x, (int)y, &win, &sc);
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
static void pm_try(const pm_ctx *c, int x, int y, const float cand[4], float *pl, float *cost, const pm_win *win,
                   const pm_scratch *sc) {
  float z = pm_plane_depth(c, cand, x, y);
  if (!pm_depth_ok(c, z)) return;
  float q = pm_cost(c, cand, x, y, win, sc);
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

static void pm_update(const pm_ctx *c, int x, int y, const pm_scratch *sc) {
  size_t p = (size_t)y * (size_t)c->W + (size_t)x;
  if (c->flat[p]) return;
  pm_win win;
  pm_window(c, x, y, sc, &win);
  float *pl = c->plane + 4 * p;
  float cost = c->cost[p];
  for (int g = 0; g < 8; g++) {
    long q = pm_best_of(c, x, y, (const int (*)[2])c->groups[g], c->gn[g]);
    if (q < 0) continue;
    float cand[4];
    memcpy(cand, c->plane + 4 * q, sizeof cand);
    pm_try(c, x, y, cand, pl, &cost, &win, sc);
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
    pm_try(c, x, y, cand, pl, &cost, &win, sc);
  }
  c->cost[p] = cost;
}

static void pm_sweep_rows(void *vctx, size_t b, size_t e) {
  pm_ctx *c = vctx;
  const pm_scratch sc = pm_thread_scratch(c);
  for (size_t y = b; y < e; y++)
    for (int x = (int)((y + (size_t)c->colour) & 1u); x < c->W; x += 2) pm_update(c, x, (int)y, &sc);
}

/* ---- entry ------------------------------------------------------------------------------- */

static void rigid_parts(const double m[16], double R[9], double t[3]) {
  for (int i = 0; i < 3; i++) {
    for (int j = 0; j < 3; j++) R[3 * i + j] = m[4 * i + j];
    t[i] = m[4 * i + 3];
  }
}

static void pm_free(pm_ctx *c) {
  for (int j = 0; j < c->n_src; j++) free(c->src[j].pad);
  free(c->plane);
  free(c->cost);
  free(c->flat);
  free(c->scratch);
  free(c);
}

mgs_status mgs_pm_run(const mgs_pm_view *ref, const mgs_pm_view *src, int n_src, const float *init_depth,
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
    if (sc->width < 1 || sc->height < 1 || (int64_t)(sc->width + 1) * (sc->height + 1) > INT32_MAX) {
      free(c); /* the sampling indexes the padded image with int32 */
      return mgs_error_set(err, MGS_ERR_ARG, "patch match: source view %d is %dx%d", j, sc->width, sc->height);
    }
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
  c->win_cap = (size_t)(2 * r / c->step + 1) * (size_t)(2 * r / c->step + 1);
  c->scratch = calloc((size_t)mgs_parallel_max_threads() * PM_SCRATCH_ARRAYS * c->win_cap, sizeof(float));
  int pads_ok = 1;
  for (int j = 0; j < n_src; j++) {
    pm_src *s = &c->src[j];
    s->pad = malloc((size_t)(s->w + 1) * (size_t)(s->h + 1) * sizeof(float));
    if (!s->pad) { pads_ok = 0; continue; }
    for (int y = 0; y <= s->h; y++) {
      const float *in = s->gray + (size_t)(y < s->h ? y : s->h - 1) * (size_t)s->w;
      float *out = s->pad + (size_t)y * (size_t)(s->w + 1);
      memcpy(out, in, (size_t)s->w * sizeof(float));
      out[s->w] = in[s->w - 1];
    }
  }
  float *ncam = init_normal ? malloc(3 * np * sizeof(float)) : NULL;
  if (!c->plane || !c->cost || !c->flat || !c->scratch || !pads_ok || (init_normal && !ncam)) {
    free(ncam);
    pm_free(c);
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
  pm_free(c);
  return MGS_OK;
}

/* Per-surfel preprocessing of the 2DGS forward (the splat-to-pixel map T, culling, the
 * 3-sigma box, SH colour, tile rectangle) and its backward (T, the box centre, the normal
 * and the colour back to mean, scales, quaternion, opacity and SH), as the authors'
 * compute_transmat / compute_aabb / compute_transmat_aabb. T's centre column (the camera-
 * space centre) is computed in double (scenes far from the origin), the rest in float.
 * Both directions take 16 surfels at a time (as the 3DGS projection): float algebra in
 * 16-wide vectors, the double parts in two 8-wide ones. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#if defined(__AVX512F__)
#include <immintrin.h>
#endif
#include "core/mgs_math.h"
#include "core/mgs_parallel.h"
#include "render/raster_2dgs.h"
#include "render/raster_simd.h"

#define CUTOFF 3.0f
#define FILTER_SIZE 0.707106f

/* What the projection needs of the camera. */
typedef struct cam_par {
  float M[9];      /* rows fx W0 + cx W2, fy W1 + cy W2, W2: camera rotation then pixels */
  double campos[3];
} cam_par;

static void cam_par_init(const mgs_raster *r, cam_par *cp) {
  const mgs_camera *c = &r->cam;
  for (int k = 0; k < 3; k++) {
    cp->M[k] = (float)(c->fx * c->w2c[k] + c->cx * c->w2c[8 + k]);
    cp->M[3 + k] = (float)(c->fy * c->w2c[4 + k] + c->cy * c->w2c[8 + k]);
    cp->M[6 + k] = (float)c->w2c[8 + k];
  }
  mgs_camera_center(c, cp->campos);
}

/* 8 doubles (the double-precision parts, 8 lanes of a block at a time). */
typedef double v8d2 __attribute__((vector_size(64)));
typedef int64_t v8l2 __attribute__((vector_size(64)));
static inline v8d2 d8_set1(double x) { return (v8d2){x, x, x, x, x, x, x, x}; }
static inline v8d2 d8_sel(v8l2 m, v8d2 a, v8d2 b) { return (v8d2)((m & (v8l2)a) | (~m & (v8l2)b)); }
static inline v8d2 d8_sqrt(v8d2 x) {
#if defined(__AVX512F__)
  return (v8d2)_mm512_sqrt_pd((__m512d)x);
#else
  for (int i = 0; i < 8; i++) x[i] = sqrt(x[i]);
  return x;
#endif
}
static inline v8d2 d8_abs(v8d2 x) { return (v8d2)((v8l2)x & (v8l2){INT64_MAX, INT64_MAX, INT64_MAX, INT64_MAX, INT64_MAX, INT64_MAX, INT64_MAX, INT64_MAX}); }
static inline v8d2 d8_load(const double *p) { v8d2 v; memcpy(&v, p, sizeof v); return v; }
static inline void d8_store(double *p, v8d2 v) { memcpy(p, &v, sizeof v); }
static inline void v8i_store8(int *p, v8i v) { memcpy(p, &v, sizeof v); }

static inline v8d2 d8_from_float(const float *p) { v8f v; memcpy(&v, p, sizeof v); return __builtin_convertvector(v, v8d2); }
static inline void d8_to_float(float *p, v8d2 v) { v8f f = __builtin_convertvector(v, v8f); memcpy(p, &f, sizeof f); }
static inline v8i d8_clamp_tile(v8d2 v, double hi) { /* clamp_tile, 8 lanes */
  v8d2 c = d8_sel(v > d8_set1(hi), d8_set1(hi), d8_sel(v > d8_set1(0.0), v, d8_set1(0.0)));
  return __builtin_convertvector(c, v8i);
}


/* The world and camera-space centres of surfels ids[0..nl) (lanes past nl: ids[0]'s), in
 * double (scenes far from the origin). */
static void centres16(const mgs_raster *r, const size_t *ids, int nl, double md[3][16], double td[3][16]) {
  const double *V = r->cam.w2c;
  for (int l = 0; l < 16; l++)
    for (int k = 0; k < 3; k++) md[k][l] = r->g->mean[3 * ids[l < nl ? l : 0] + k];
  for (int h = 0; h < 16; h += 8) {
    v8d2 m0 = d8_load(md[0] + h), m1 = d8_load(md[1] + h), m2 = d8_load(md[2] + h);
    for (int k = 0; k < 3; k++)
      d8_store(td[k] + h, d8_set1(V[4 * k]) * m0 + d8_set1(V[4 * k + 1]) * m1 + d8_set1(V[4 * k + 2]) * m2 + d8_set1(V[4 * k + 3]));
  }
}

/* Rotation (mgs_quat_to_mat3f's operations: identity for a zero quaternion), scales and
 * T = (Tu, Tv, Tw) of 16 surfels from their quaternions q, first two log-scales ls and
 * camera-space centres td: Tc[a][0..1] = M_a (s0 R e0, s1 R e1), Tc[a][2] the
 * pixel-homogeneous centre. The projection and the backward both take T from here: the
 * same T bit for bit. */
MGS_VINLINE void surfel_T16(const mgs_raster *r, const cam_par *cp, const float q[4][16], const float ls[2][16],
                            const double td[3][16], v16f R[9], v16f s[2], v16f Tc[3][3]) {
  const v16f zero = v16f_set1(0.0f), one = v16f_set1(1.0f), two = v16f_set1(2.0f);
  v16f w = v16f_load(q[0]), x = v16f_load(q[1]), y = v16f_load(q[2]), z = v16f_load(q[3]);
  v16f qn = v16f_sqrt(w * w + x * x + y * y + z * z);
  v16i nz = v16f_gt(qn, zero);
  v16f qd = v16f_select(nz, qn, one);
  w = v16f_select(nz, w / qd, one); x = v16f_and(nz, x / qd); y = v16f_and(nz, y / qd); z = v16f_and(nz, z / qd);
  R[0] = one - two * (y * y + z * z); R[1] = two * (x * y - w * z); R[2] = two * (x * z + w * y);
  R[3] = two * (x * y + w * z); R[4] = one - two * (x * x + z * z); R[5] = two * (y * z - w * x);
  R[6] = two * (x * z - w * y); R[7] = two * (y * z + w * x); R[8] = one - two * (x * x + y * y);
  v16f smod = v16f_set1(r->s.scale_modifier);
  s[0] = smod * v16f_exp(v16f_load(ls[0]));
  s[1] = smod * v16f_exp(v16f_load(ls[1]));
  for (int a = 0; a < 3; a++) {
    const float *m = cp->M + 3 * a;
    v16f m0 = v16f_set1(m[0]), m1 = v16f_set1(m[1]), m2 = v16f_set1(m[2]);
    Tc[a][0] = s[0] * (m0 * R[0] + m1 * R[3] + m2 * R[6]);
    Tc[a][1] = s[1] * (m0 * R[1] + m1 * R[4] + m2 * R[7]);
  }
  const mgs_camera *c = &r->cam;
  float t2[3][16];
  for (int h = 0; h < 16; h += 8) {
    v8d2 t0 = d8_load(td[0] + h), t1 = d8_load(td[1] + h), tz = d8_load(td[2] + h);
    d8_to_float(t2[0] + h, d8_set1(c->fx) * t0 + d8_set1(c->cx) * tz);
    d8_to_float(t2[1] + h, d8_set1(c->fy) * t1 + d8_set1(c->cy) * tz);
    d8_to_float(t2[2] + h, tz);
  }
  for (int a = 0; a < 3; a++) Tc[a][2] = v16f_load(t2[a]);
}

static void cull(mgs_raster *r, size_t i) {
  r->radii[i] = 0;
  r->count[i] = 0;
}

static int clamp_tile(double v, int hi) { return v <= 0 || v != v ? 0 : (v >= hi ? hi : (int)v); }

typedef struct proj_ctx {
  mgs_raster *r;
  cam_par cp;
  const uint32_t *idx;
} proj_ctx;

/* Where alpha >= 1/255 can hold, i.e. rho = min(rho3, rho2) <= rmax: the ellipse
 * {rho3 <= rmax} and the filter's disc {rho2 <= rmax} (raster_2dgs.h). With p affine in the
 * pixel, rho3 <= r is the conic |p.xy|^2 - r p.z^2 <= 0, an ellipse when its quadratic
 * part is positive definite (p.z keeps one sign inside: p = 0 has no pixel); otherwise (a
 * surfel seen nearly edge-on) it bounds nothing. Enlarged (r 1 % above rmax, which already
 * has 0.1 %, and the margins) so that the float per-pixel rho3 of every pixel it leaves out
 * is above rmax: skipping those pixels changes no value. Tiles of the authors' rect that
 * miss it are not binned (the same result, as 3DGS's binning). For the binned surfels
 * blk[0..nl) (project_block stored rmax in rf), in double, 16 lanes in branch-free loops. */
static void surfel_bounds(mgs_raster *r, const size_t *blk, int nl) {
  mgs_surf2d *surf = mgs_raster2d_surf(r);
  double A[3][16], B[3][16], C[3][16], rmx[16];
  for (int l = 0; l < 16; l++) {
    const mgs_surf2d *sf = surf + blk[l < nl ? l : 0];
    for (int k = 0; k < 3; k++) { A[k][l] = sf->c0[k]; B[k][l] = sf->c1[k]; C[k][l] = sf->c2[k]; }
    rmx[l] = sf->rf;
  }
  double yc[16], xc[16], sl[16], h0[16], kq[16], rf[16], xlo[16], xhi[16], ylo[16], yhi[16];
  int64_t bnd[16];
  for (int h = 0; h < 16; h += 8) {
    const v8d2 zero = d8_set1(0.0);
    v8d2 a0 = d8_load(A[0] + h), a1 = d8_load(A[1] + h), a2 = d8_load(A[2] + h);
    v8d2 b0 = d8_load(B[0] + h), b1 = d8_load(B[1] + h), b2 = d8_load(B[2] + h);
    v8d2 c0 = d8_load(C[0] + h), c1 = d8_load(C[1] + h), c2 = d8_load(C[2] + h), rm = d8_load(rmx + h);
    v8d2 rfl = d8_sqrt(rm * (1.0 / MGS_2DGS_FILTER_INV2)) * 1.001 + 0.02, rb = rm * 1.01 + 1e-3;
    v8d2 M0 = a0 * a0 + a1 * a1 - rb * a2 * a2, M1 = a0 * b0 + a1 * b1 - rb * a2 * b2;
    v8d2 M2 = b0 * b0 + b1 * b1 - rb * b2 * b2, M3 = a0 * c0 + a1 * c1 - rb * a2 * c2;
    v8d2 M4 = b0 * c0 + b1 * c1 - rb * b2 * c2, M5 = c0 * c0 + c1 * c1 - rb * c2 * c2;
    v8d2 det2 = M0 * M2 - M1 * M1, idet = 1.0 / det2, im0 = 1.0 / M0;
    v8d2 xcl = (M4 * M1 - M3 * M2) * idet, ycl = (M3 * M1 - M4 * M0) * idet;
    v8d2 qc = M5 + M3 * xcl + M4 * ycl;
    v8l2 pd = (M0 > zero) & (det2 > zero), el = pd & (qc < zero);
    v8d2 ex = d8_sqrt(d8_sel(el, zero - qc * M2 * idet, zero)), ey = d8_sqrt(d8_sel(el, zero - qc * M0 * idet, zero));
    v8d2 hh = d8_sel(el, zero - qc * im0, d8_set1(-1.0)), kk = d8_sel(el, det2 * im0 * im0, zero);
    v8d2 ss = d8_sel(el, zero - M1 * im0, zero), x_c = d8_sel(el, xcl, zero), y_c = d8_sel(el, ycl, zero);
    v8d2 nrf = zero - rfl, t;
    t = xcl - ex; v8d2 xl = d8_sel(el & (t < nrf), t, nrf);
    t = xcl + ex; v8d2 xh = d8_sel(el & (t > rfl), t, rfl);
    t = ycl - ey; v8d2 yl = d8_sel(el & (t < nrf), t, nrf);
    t = ycl + ey; v8d2 yh = d8_sel(el & (t > rfl), t, rfl);
    v8d2 chk = x_c + y_c + hh + kk + ss + xl + xh + yl + yh;
    v8l2 ok = pd & (chk - chk == zero) & (d8_abs(xl) + d8_abs(xh) + d8_abs(yl) + d8_abs(yh) < d8_set1(1e7));
    d8_store(yc + h, d8_sel(ok, y_c, zero)); d8_store(xc + h, d8_sel(ok, x_c, zero));
    d8_store(sl + h, d8_sel(ok, ss, zero)); d8_store(kq + h, d8_sel(ok, kk, zero));
    d8_store(h0 + h, d8_sel(ok, hh, d8_set1(INFINITY)));
    d8_store(rf + h, rfl);
    d8_store(xlo + h, xl); d8_store(xhi + h, xh); d8_store(ylo + h, yl); d8_store(yhi + h, yh);
    memcpy(bnd + h, &ok, sizeof ok);
  }
  for (int l = 0; l < nl; l++) {
    size_t i = blk[l];
    mgs_surf2d *sf = surf + i;
    sf->yc = (float)yc[l]; sf->xc = (float)xc[l]; sf->sl = (float)sl[l]; sf->h0 = (float)h0[l]; sf->kq = (float)kq[l];
    sf->rf = (float)rf[l];
    sf->pad = 0;
    if (!bnd[l] || !r->count[i]) continue; /* unbounded, or culled by its colour meanwhile */
    uint16_t *rc = r->rect + 4 * i;
    double mx = 0.05 + 1e-3 * (xhi[l] - xlo[l]), my = 0.05 + 1e-3 * (yhi[l] - ylo[l]), ts = 1.0 / MGS_TILE_SIZE;
    int x0 = clamp_tile(floor((sf->ox + xlo[l] - mx - 0.5) * ts), r->tiles_x);
    int x1 = clamp_tile(floor((sf->ox + xhi[l] + mx - 0.5) * ts) + 1, r->tiles_x);
    int y0 = clamp_tile(floor((sf->oy + ylo[l] - my - 0.5) * ts), r->tiles_y);
    int y1 = clamp_tile(floor((sf->oy + yhi[l] + my - 0.5) * ts) + 1, r->tiles_y);
    if (x0 < rc[0]) x0 = rc[0];
    if (x1 > rc[2]) x1 = rc[2];
    if (y0 < rc[1]) y0 = rc[1];
    if (y1 > rc[3]) y1 = rc[3];
    if (x1 <= x0 || y1 <= y0) { r->count[i] = 0; continue; }
    rc[0] = (uint16_t)x0; rc[1] = (uint16_t)y0; rc[2] = (uint16_t)x1; rc[3] = (uint16_t)y1;
    r->count[i] = (uint32_t)((x1 - x0) * (y1 - y0));
  }
}

#if defined(__AVX512F__)
/* A block's view directions and row offsets from its first surfel, lane by lane (lanes
 * past nl repeat the first surfel at offset 0). */
static void block_lanes(const mgs_raster *r, const size_t *blk, int nl, float dirl[3][16], int32_t lane[16]) {
  for (int l = 0; l < 16; l++) {
    int ok = l < nl;
    const mgs_proj_aux *ax = &r->aux[blk[ok ? l : 0]];
    lane[l] = ok ? (int32_t)(blk[l] - blk[0]) : 0;
    for (int k = 0; k < 3; k++) dirl[k][l] = ax->dir[k];
  }
}
#endif

/* The SH colours of the surfels blk[0..nl) (project_block passed them; spread below 2^24),
 * 16 at once; a non-finite colour culls its surfel. */
static void surfel_colours(mgs_raster *r, const size_t *blk, int nl) {
  const mgs_gaussians *g = r->g;
  mgs_surf2d *surf = mgs_raster2d_surf(r);
  float rgbl[3][16];
#if defined(__AVX512F__)
  float dirl[3][16];
  int32_t lane[16];
  block_lanes(r, blk, nl, dirl, lane);
  mgs_sh_eval16(r->s.sh_degree, g->sh_dc + 3 * blk[0], g->sh_rest + (size_t)MGS_SH_REST_MAX * blk[0], lane,
                (uint16_t)((1u << nl) - 1), dirl, rgbl);
#else
  for (int l = 0; l < nl; l++) {
    size_t i = blk[l];
    float c3[3];
    mgs_sh_eval(r->s.sh_degree, g->sh_dc + 3 * i, g->sh_rest + (size_t)MGS_SH_REST_MAX * i, r->aux[i].dir, c3);
    for (int k = 0; k < 3; k++) rgbl[k][l] = c3[k];
  }
#endif
  for (int l = 0; l < nl; l++) {
    size_t i = blk[l];
    mgs_proj_aux *ax = &r->aux[i];
    mgs_surf2d *sf = surf + i;
    float rgb[3] = {rgbl[0][l], rgbl[1][l], rgbl[2][l]};
    if (!isfinite(rgb[0]) || !isfinite(rgb[1]) || !isfinite(rgb[2])) { cull(r, i); continue; }
    for (int k = 0; k < 3; k++) {
      ax->clamped[k] = rgb[k] < 0;
      sf->rgb[k] = rgb[k] < 0 ? 0 : rgb[k];
    }
  }
}

/* A block of up to 16 surfels projected at once (lanes past nl, and culled lanes, hold
 * benign values and are ignored). The float algebra (rotation, T, the 3-sigma box) runs as
 * 16-wide vectors, the double parts (camera-space centre, T's centre column, the affine
 * coefficients, the tile rect, the view direction) as two 8-wide ones. */

static void project_block(const proj_ctx *pc, const size_t *ids, int nl) {
  mgs_raster *r = pc->r;
  const mgs_gaussians *g = r->g;
  const cam_par *cp = &pc->cp;
  double md[3][16], td[3][16];
  centres16(r, ids, nl, md, td);
  /* lane set-up: the early culls, parameters (dead lanes: identity, centre (0, 0, 1)) */
  int alive[16];
  float q[4][16], ls[2][16], logit[16];
  for (int l = 0; l < 16; l++) {
    int ok = 0;
    if (l < nl) {
      size_t i = ids[l];
      cull(r, i);
      const float *qq = g->rot + 4 * i;
      ok = td[2][l] > r->s.near_plane && isfinite(td[0][l]) && isfinite(td[1][l]) && isfinite(td[2][l]) &&
           isfinite(qq[0] + qq[1] + qq[2] + qq[3]) && isfinite(g->opacity[i]);
    }
    alive[l] = ok;
    size_t i = ids[l < nl ? l : 0];
    if (!ok) { td[0][l] = td[1][l] = 0; td[2][l] = 1; }
    for (int k = 0; k < 4; k++) q[k][l] = ok ? g->rot[4 * i + k] : (float)(k == 0);
    for (int k = 0; k < 2; k++) ls[k][l] = ok ? g->log_scale[3 * i + k] : 0.0f;
    logit[l] = ok ? g->opacity[i] : 0.0f;
  }
  const v16f zero = v16f_set1(0.0f), one = v16f_set1(1.0f);
  v16f R[9], sc[2], Tc[3][3];
  surfel_T16(r, cp, q, ls, td, R, sc, Tc);
  /* the normal's side, the view direction (double) */
  float dirl[3][16], distl[16], r2[3][16];
  double cosv[16];
  for (int k = 0; k < 3; k++) v16f_store(r2[k], R[3 * k + 2]);
  for (int h = 0; h < 16; h += 8) {
    v8d2 dd[3], cv = d8_set1(0.0);
    for (int k = 0; k < 3; k++) {
      v8d2 pk = d8_load(md[k] + h);
      cv = cv + (d8_set1(cp->campos[k]) - pk) * d8_from_float(r2[k] + h);
      dd[k] = pk - d8_set1(cp->campos[k]);
    }
    d8_store(cosv + h, cv);
    v8d2 dist = d8_sqrt(dd[0] * dd[0] + dd[1] * dd[1] + dd[2] * dd[2]);
    v8l2 pos = dist > d8_set1(0.0);
    v8d2 dq = d8_sel(pos, dist, d8_set1(1.0));
    for (int k = 0; k < 3; k++) d8_to_float(dirl[k] + h, d8_sel(pos, dd[k] / dq, d8_set1(0.0)));
    d8_to_float(distl + h, dist);
  }
  /* the 3-sigma box of the ellipse {rho3d = 9} (compute_aabb) */
  v16f *Tu = Tc[0], *Tv = Tc[1], *Tw = Tc[2];
  const v16f t0 = v16f_set1(CUTOFF * CUTOFF), t2 = v16f_set1(-1.0f);
  v16f d = t0 * Tw[0] * Tw[0] + t0 * Tw[1] * Tw[1] + t2 * Tw[2] * Tw[2];
  v16i dok = v16f_ne(d, zero) & v16f_eq(d - d, zero);
  v16f dq2 = v16f_select(dok, d, one);
  v16f f0 = t0 / dq2, f2 = t2 / dq2;
  v16f cx = f0 * Tu[0] * Tw[0] + f0 * Tu[1] * Tw[1] + f2 * Tu[2] * Tw[2];
  v16f cy = f0 * Tv[0] * Tw[0] + f0 * Tv[1] * Tw[1] + f2 * Tv[2] * Tw[2];
  v16f hx0 = cx * cx - (f0 * Tu[0] * Tu[0] + f0 * Tu[1] * Tu[1] + f2 * Tu[2] * Tu[2]);
  v16f hy0 = cy * cy - (f0 * Tv[0] * Tv[0] + f0 * Tv[1] * Tv[1] + f2 * Tv[2] * Tv[2]);
  const v16f hmin = v16f_set1(1e-4f), rmin = v16f_set1(CUTOFF * FILTER_SIZE);
  v16f hx = v16f_sqrt(v16f_max(hx0, hmin)), hy = v16f_sqrt(v16f_max(hy0, hmin));
  v16f ext = v16f_max(hx, hy);
  v16f radius = v16f_ceil(v16f_max(ext, rmin));
  v16f op = one / (one + v16f_exp(zero - v16f_load(logit)));
  v16i bok = dok & v16f_eq(cx - cx, zero) & v16f_eq(cy - cy, zero) & v16f_eq(radius - radius, zero) &
             v16f_le(radius, v16f_set1(1e7f));
  float cxl[16], cyl[16], radl[16], opl[16], T9[9][16];
  v16f_store(cxl, cx); v16f_store(cyl, cy); v16f_store(radl, radius); v16f_store(opl, op);
  for (int k = 0; k < 3; k++) { v16f_store(T9[k], Tu[k]); v16f_store(T9[3 + k], Tv[k]); v16f_store(T9[6 + k], Tw[k]); }
  int32_t boxok[16];
  v16i_store(boxok, bok);
  /* the affine p and det T of raster_2dgs.h about (ox, oy), in double from the float T; the
     reference's getRect */
  float cf[10][16];
  int rect[4][16];
  for (int h = 0; h < 16; h += 8) {
    v8d2 ox = d8_from_float(cxl + h), oy = d8_from_float(cyl + h), wv[3], u[3], v[3];
    for (int k = 0; k < 3; k++) {
      wv[k] = d8_from_float(T9[6 + k] + h);
      u[k] = d8_from_float(T9[k] + h) - ox * wv[k];
      v[k] = d8_from_float(T9[3 + k] + h) - oy * wv[k];
    }
    v8d2 c[10];
    c[0] = v[1] * wv[2] - v[2] * wv[1]; c[1] = v[2] * wv[0] - v[0] * wv[2]; c[2] = v[0] * wv[1] - v[1] * wv[0];
    c[3] = wv[1] * u[2] - wv[2] * u[1]; c[4] = wv[2] * u[0] - wv[0] * u[2]; c[5] = wv[0] * u[1] - wv[1] * u[0];
    c[6] = u[1] * v[2] - u[2] * v[1]; c[7] = u[2] * v[0] - u[0] * v[2]; c[8] = u[0] * v[1] - u[1] * v[0];
    c[9] = wv[0] * c[6] + wv[1] * c[7] + wv[2] * c[8];
    for (int k = 0; k < 10; k++) d8_to_float(cf[k] + h, c[k]);
    v8d2 rad = d8_from_float(radl + h), px = ox - d8_set1(0.5), py = oy - d8_set1(0.5), ts = d8_set1(1.0 / MGS_TILE_SIZE);
    v8d2 tm = d8_set1(MGS_TILE_SIZE - 1);
    v8i_store8(rect[0] + h, d8_clamp_tile((px - rad) * ts, r->tiles_x));
    v8i_store8(rect[1] + h, d8_clamp_tile((py - rad) * ts, r->tiles_y));
    v8i_store8(rect[2] + h, d8_clamp_tile((px + rad + tm) * ts, r->tiles_x));
    v8i_store8(rect[3] + h, d8_clamp_tile((py + rad + tm) * ts, r->tiles_y));
  }
  /* per lane: the remaining culls and the stores */
  size_t blk[16], bb[16];
  int na = 0, nb = 0;
  mgs_surf2d *surf = mgs_raster2d_surf(r);
  mgs_surf2d_cold *cold = mgs_raster2d_cold(r);
  for (int l = 0; l < nl; l++) {
    if (!alive[l]) continue;
    size_t i = ids[l];
    /* normal towards the camera; a surfel seen exactly edge-on through its centre is culled */
    if (cosv[l] == 0 || !isfinite(cosv[l]) || !boxok[l]) continue;
    if ((rect[2][l] - rect[0][l]) * (rect[3][l] - rect[1][l]) == 0) continue;
    mgs_surf2d_cold *cd = cold + i;
    cd->nsign = cosv[l] > 0 ? 1.0f : -1.0f;
    for (int k = 0; k < 3; k++) cd->n[k] = cd->nsign * r2[k][l];
    mgs_surf2d *sf = surf + i;
    sf->ox = cxl[l];
    sf->oy = cyl[l];
    sf->zc = T9[8][l];
    for (int k = 0; k < 3; k++) { sf->c0[k] = cf[k][l]; sf->c1[k] = cf[3 + k][l]; sf->c2[k] = cf[6 + k][l]; }
    sf->det = cf[9][l];
    mgs_proj_aux *ax = &r->aux[i];
    for (int k = 0; k < 3; k++) { ax->dir[k] = dirl[k][l]; ax->t[k] = (float)td[k][l]; }
    ax->dist = distl[l];
    float o = opl[l];
    sf->opacity = o;
    mgs_splat *sp = &r->splat[i];
    memset(sp, 0, sizeof *sp);
    sp->u = cxl[l]; sp->v = cyl[l]; sp->z = ax->t[2]; sp->opacity = o;
    r->radii[i] = (int)radl[l];
    blk[na++] = i;
    if (o < MGS_ALPHA_MIN) continue; /* alpha < 1/255 everywhere: nothing to bin */
    sf->rf = 2.0f * logf(o / MGS_ALPHA_MIN) * 1.001f + 1e-4f; /* rmax, until surfel_bounds */
    uint16_t *rc = r->rect + 4 * i;
    for (int k = 0; k < 4; k++) rc[k] = (uint16_t)rect[k][l];
    r->count[i] = (uint32_t)((rect[2][l] - rect[0][l]) * (rect[3][l] - rect[1][l]));
    bb[nb++] = i;
  }
  if (na) surfel_colours(r, blk, na);
  int nb2 = 0;
  for (int l = 0; l < nb; l++)
    if (r->count[bb[l]]) bb[nb2++] = bb[l];
  if (nb2) surfel_bounds(r, bb, nb2);
}

static void project_range(void *vctx, size_t b, size_t e) {
  const proj_ctx *pc = vctx;
  size_t ids[16];
  int nl = 0;
  for (size_t k = b; k < e; k++) {
    size_t i = pc->idx ? pc->idx[k] : k;
    if (nl && (nl == 16 || i - ids[0] >= (1u << 24))) { project_block(pc, ids, nl); nl = 0; }
    ids[nl++] = i;
  }
  if (nl) project_block(pc, ids, nl);
}

void mgs_raster2d_project(mgs_raster *r, const uint32_t *idx, size_t m) {
  proj_ctx pc = {r, {{0}, {0}}, idx};
  cam_par_init(r, &pc.cp);
  if (idx) {
    memset(r->radii, 0, r->n * sizeof *r->radii);
    memset(r->count, 0, r->n * sizeof *r->count);
  }
  mgs_parallel_for(0, idx ? m : r->n, 256, project_range, &pc);
}

/* The backward of the binned surfels blk[0..nl) (spread below 2^24) but their colours, 16
 * at once: gsl[c][l] = lane l's summed slots (S2 layout; lanes past nl: 0). T comes from
 * surfel_T16 as in the projection; the double parts (dL/dT from the affine coefficients)
 * run 8 lanes at a time. Out: dL/d(unclamped colour) and the mean gradient so far. */
static void backward_block(mgs_raster *r, const cam_par *cp, const size_t *blk, int nl, float gsl[S2_COUNT][16],
                           mgs_gaussians *grad, size_t gbase, float *grad_mean2d, float drgb[3][16], float dmean[3][16]) {
  const mgs_gaussians *g = r->g;
  const mgs_surf2d *surf = mgs_raster2d_surf(r);
  const mgs_surf2d_cold *cold = mgs_raster2d_cold(r);
  double md[3][16], td[3][16];
  centres16(r, blk, nl, md, td);
  float q[4][16], ls[2][16], oxl[16], oyl[16], opl[16], nsl[16];
  for (int l = 0; l < 16; l++) {
    size_t i = blk[l < nl ? l : 0];
    for (int k = 0; k < 4; k++) q[k][l] = g->rot[4 * i + k];
    for (int k = 0; k < 2; k++) ls[k][l] = g->log_scale[3 * i + k];
    const mgs_surf2d *sf = surf + i;
    oxl[l] = sf->ox; oyl[l] = sf->oy; opl[l] = sf->opacity; nsl[l] = cold[i].nsign;
  }
  v16f R[9], s[2], Tc[3][3];
  surfel_T16(r, cp, q, ls, td, R, s, Tc);
  /* dL/d(c0, c1, c2, det) to dL/d(Tu, Tv, Tw): c0 = v x w, c1 = w x u, c2 = u x v with
     u = Tu - ox Tw, v = Tv - oy Tw, w = Tw, det = w.c2 ((ox, oy) only moves the origin p
     is written about: a constant) */
  float T9[9][16], dT[9][16]; /* Tu, Tv, Tw rows */
  for (int a = 0; a < 3; a++)
    for (int k = 0; k < 3; k++) v16f_store(T9[3 * a + k], Tc[a][k]);
  for (int h = 0; h < 16; h += 8) {
    v8d2 ox = d8_from_float(oxl + h), oy = d8_from_float(oyl + h), u[3], v[3], w[3], g0[3], g1[3], g2[3];
    v8d2 gdet = d8_from_float(gsl[S2_DET] + h);
    for (int k = 0; k < 3; k++) {
      w[k] = d8_from_float(T9[6 + k] + h);
      u[k] = d8_from_float(T9[k] + h) - ox * w[k];
      v[k] = d8_from_float(T9[3 + k] + h) - oy * w[k];
      g0[k] = d8_from_float(gsl[S2_C0 + k] + h);
      g1[k] = d8_from_float(gsl[S2_C1 + k] + h);
      g2[k] = d8_from_float(gsl[S2_C2 + k] + h) + gdet * w[k];
    }
#define CROSS(o, a, b)                       \
  do {                                       \
    o[0] = a[1] * b[2] - a[2] * b[1];        \
    o[1] = a[2] * b[0] - a[0] * b[2];        \
    o[2] = a[0] * b[1] - a[1] * b[0];        \
  } while (0)
    v8d2 c2[3], du[3], dv[3], dw[3], t[3];
    CROSS(c2, u, v);
    for (int k = 0; k < 3; k++) dw[k] = gdet * c2[k];
    CROSS(du, v, g2);
    CROSS(dv, g2, u);
    CROSS(t, w, g0); for (int k = 0; k < 3; k++) dv[k] = dv[k] + t[k];
    CROSS(t, g0, v); for (int k = 0; k < 3; k++) dw[k] = dw[k] + t[k];
    CROSS(t, u, g1); for (int k = 0; k < 3; k++) dw[k] = dw[k] + t[k];
    CROSS(t, g1, w); for (int k = 0; k < 3; k++) du[k] = du[k] + t[k];
#undef CROSS
    for (int k = 0; k < 3; k++) {
      d8_to_float(dT[k] + h, du[k]);
      d8_to_float(dT[3 + k] + h, dv[k]);
      d8_to_float(dT[6 + k] + h, dw[k] - ox * du[k] - oy * dv[k]);
    }
  }
  const v16f zero = v16f_set1(0.0f), one = v16f_set1(1.0f), two = v16f_set1(2.0f);
  v16f dTu[3], dTv[3], dTw[3];
  for (int k = 0; k < 3; k++) { dTu[k] = v16f_load(dT[k]); dTv[k] = v16f_load(dT[3 + k]); dTw[k] = v16f_load(dT[6 + k]); }
  dTw[2] += v16f_load(gsl[S2_ZC]); /* the filter's depth is Tw2 */
  v16f *Tu = Tc[0], *Tv = Tc[1], *Tw = Tc[2];
  /* the authors' densification signal: dL/dT's centre column times the depth, in NDC */
  float gm2[16];
  if (grad_mean2d) {
    v16f gx = dTu[2] * Tw[2] * v16f_set1(0.5f) * v16f_set1((float)r->width);
    v16f gy = dTv[2] * Tw[2] * v16f_set1(0.5f) * v16f_set1((float)r->height);
    v16f_store(gm2, v16f_sqrt(gx * gx + gy * gy));
  }
  /* box centre c = (f.(Tu o Tw), f.(Tv o Tw)), f = t / (t.(Tw o Tw)) */
  {
    v16f gcx = v16f_load(gsl[S2_OX]), gcy = v16f_load(gsl[S2_OY]), ox = v16f_load(oxl), oy = v16f_load(oyl);
    v16i live = v16f_ne(gcx, zero) | v16f_ne(gcy, zero);
    const float t[3] = {CUTOFF * CUTOFF, CUTOFF * CUTOFF, -1.0f};
    v16f d = v16f_set1(t[0]) * Tw[0] * Tw[0] + v16f_set1(t[1]) * Tw[1] * Tw[1] + v16f_set1(t[2]) * Tw[2] * Tw[2];
    d = v16f_select(live, d, one);
    v16f gd = zero - (gcx * ox + gcy * oy) / d;
    for (int k = 0; k < 3; k++) {
      v16f f = v16f_set1(t[k]) / d;
      dTu[k] = v16f_select(live, dTu[k] + gcx * f * Tw[k], dTu[k]);
      dTv[k] = v16f_select(live, dTv[k] + gcy * f * Tw[k], dTv[k]);
      dTw[k] = v16f_select(live, dTw[k] + (gcx * f * Tu[k] + gcy * f * Tv[k] + gd * two * v16f_set1(t[k]) * Tw[k]), dTw[k]);
    }
  }
  /* gv = M^T (dTu, dTv, dTw)[column c]; T's columns: M (s0 R e0), M (s1 R e1), the centre
     (d/dmean = M^T its column: fx t0 + cx t2, fy t1 + cy t2, t2 with t = W p + t) */
  v16f gv[3][3];
  for (int c = 0; c < 3; c++)
    for (int k = 0; k < 3; k++)
      gv[c][k] = v16f_set1(cp->M[k]) * dTu[c] + v16f_set1(cp->M[3 + k]) * dTv[c] + v16f_set1(cp->M[6 + k]) * dTw[c];
  v16f dR[9], ns = v16f_load(nsl);
  for (int a = 0; a < 3; a++) {
    dR[3 * a] = s[0] * gv[0][a];
    dR[3 * a + 1] = s[1] * gv[1][a];
    dR[3 * a + 2] = ns * v16f_load(gsl[S2_N + a]);
  }
  v16f ds0 = gv[0][0] * R[0] + gv[0][1] * R[3] + gv[0][2] * R[6];
  v16f ds1 = gv[1][0] * R[1] + gv[1][1] * R[4] + gv[1][2] * R[7];
  float gls[2][16], gq[4][16], gop[16];
  v16f_store(gls[0], ds0 * s[0]);
  v16f_store(gls[1], ds1 * s[1]);
  /* quaternion (normalized inside R; a zero one gets no gradient) */
  {
    v16f w = v16f_load(q[0]), x = v16f_load(q[1]), y = v16f_load(q[2]), z = v16f_load(q[3]);
    v16f qn2 = w * w + x * x + y * y + z * z;
    v16i pos = v16f_gt(qn2, zero);
    v16f qn = v16f_sqrt(v16f_select(pos, qn2, one));
    w = w / qn; x = x / qn; y = y / qn; z = z / qn;
    v16f g4[4];
    g4[0] = two * (zero - z * dR[1] + y * dR[2] + z * dR[3] - x * dR[5] - y * dR[6] + x * dR[7]);
    g4[1] = two * (y * dR[1] + z * dR[2] + y * dR[3] - two * x * dR[4] - w * dR[5] + z * dR[6] + w * dR[7] - two * x * dR[8]);
    g4[2] = two * (zero - two * y * dR[0] + x * dR[1] + w * dR[2] + x * dR[3] + z * dR[5] - w * dR[6] + z * dR[7] - two * y * dR[8]);
    g4[3] = two * (zero - two * z * dR[0] - w * dR[1] + x * dR[2] + w * dR[3] - two * z * dR[4] + y * dR[5] + x * dR[6] + y * dR[7]);
    v16f qd = w * g4[0] + x * g4[1] + y * g4[2] + z * g4[3];
    v16f qv[4] = {w, x, y, z};
    for (int k = 0; k < 4; k++) v16f_store(gq[k], v16f_and(pos, (g4[k] - qv[k] * qd) / qn));
  }
  v16f op = v16f_load(opl);
  v16f_store(gop, v16f_load(gsl[S2_OP]) * op * (one - op));
  for (int k = 0; k < 3; k++) v16f_store(dmean[k], gv[2][k]);
  for (int l = 0; l < nl; l++) {
    size_t i = blk[l], gi = i - gbase;
    if (grad_mean2d) grad_mean2d[i] = gm2[l];
    grad->log_scale[3 * gi] += gls[0][l];
    grad->log_scale[3 * gi + 1] += gls[1][l];
    for (int k = 0; k < 4; k++) grad->rot[4 * gi + k] += gq[k][l];
    grad->opacity[gi] += gop[l];
    const mgs_proj_aux *ax = &r->aux[i];
    for (int k = 0; k < 3; k++) drgb[k][l] = ax->clamped[k] ? 0.0f : gsl[S2_R + k][l];
  }
}

/* The SH backward of the surfels blk[0..nl) (spread below 2^24), 16 at once, and their
 * view-direction part of the mean gradient; then the mean gradients. */
static void surfel_colours_backward(mgs_raster *r, const size_t *blk, int nl, float drgb[3][16], float dmean[3][16],
                                    mgs_gaussians *grad, size_t gbase) {
  const mgs_gaussians *g = r->g;
  float ddir[3][16];
#if defined(__AVX512F__)
  float dirl[3][16];
  int32_t lane[16];
  block_lanes(r, blk, nl, dirl, lane);
  for (int l = nl; l < 16; l++)
    for (int k = 0; k < 3; k++) drgb[k][l] = 0.0f;
  mgs_sh_backward16(r->s.sh_degree, g->sh_rest + (size_t)MGS_SH_REST_MAX * blk[0], lane, (uint16_t)((1u << nl) - 1), dirl,
                    (const float(*)[16])drgb, grad->sh_dc + 3 * (blk[0] - gbase),
                    grad->sh_rest + (size_t)MGS_SH_REST_MAX * (blk[0] - gbase), ddir);
#else
  for (int l = 0; l < nl; l++) {
    size_t i = blk[l], gi = i - gbase;
    float g3[3] = {drgb[0][l], drgb[1][l], drgb[2][l]}, o3[3];
    mgs_sh_backward(r->s.sh_degree, g->sh_dc + 3 * i, g->sh_rest + (size_t)MGS_SH_REST_MAX * i, r->aux[i].dir, g3,
                    grad->sh_dc + 3 * gi, grad->sh_rest + (size_t)MGS_SH_REST_MAX * gi, o3);
    for (int k = 0; k < 3; k++) ddir[k][l] = o3[k];
  }
#endif
  for (int l = 0; l < nl; l++) {
    size_t i = blk[l], gi = i - gbase;
    const mgs_proj_aux *ax = &r->aux[i];
    float dm[3] = {dmean[0][l], dmean[1][l], dmean[2][l]};
    if (ax->dist > 0) {
      float dd = ax->dir[0] * ddir[0][l] + ax->dir[1] * ddir[1][l] + ax->dir[2] * ddir[2][l];
      for (int k = 0; k < 3; k++) dm[k] += (ddir[k][l] - ax->dir[k] * dd) / ax->dist;
    }
    for (int k = 0; k < 3; k++) grad->mean[3 * gi + k] += dm[k];
  }
}

/* The backward of the surfels blk[0..nl) with the summed slots gsl: geometry, then colour. */
static void flush_block(mgs_raster *r, const cam_par *cp, const size_t *blk, int nl, float gsl[S2_COUNT][16],
                        mgs_gaussians *grad, size_t gbase, float *grad_mean2d, float drgb[3][16], float dmean[3][16]) {
  for (int l = nl; l < 16; l++)
    for (int c = 0; c < S2_COUNT; c++) gsl[c][l] = 0.0f;
  backward_block(r, cp, blk, nl, gsl, grad, gbase, grad_mean2d, drgb, dmean);
  surfel_colours_backward(r, blk, nl, drgb, dmean, grad, gbase);
}

void mgs_raster2d_reduce_span(mgs_raster *r, size_t b, size_t e, mgs_gaussians *grad, size_t gbase, float *grad_mean2d) {
  cam_par cp;
  cam_par_init(r, &cp);
  size_t blk[16];
  float drgb[3][16], dmean[3][16], gsl[S2_COUNT][16];
  int nl = 0, st = mgs_raster2d_slot_stride(r), nc = mgs_raster2d_slot_count(r);
  for (size_t i = b; i < e; i++) {
    uint32_t cnt = r->count[i];
    if (!cnt) continue;
    float gs[S2_COUNT] = {0};
    const float *q = r->sgrad + (size_t)r->gauss_off[i] * (size_t)st;
    int any = 0;
    if (nc == 16) { /* one line a slot, zc from the side array */
      int nz = mgs_sum_rows16(q, cnt, (size_t)st, gs);
      const float *zs = mgs_raster2d_zc_side(r) + r->gauss_off[i];
      for (uint32_t k = 0; k < cnt; k++) gs[S2_ZC] += zs[k];
      any = nz || gs[S2_ZC] != 0; /* +-0 is no gradient */
    } else {
      for (uint32_t k = 0; k < cnt; k++, q += st)
        for (int c = 0; c < nc; c++) gs[c] += q[c];
      for (int c = 0; c < nc; c++) any |= gs[c] != 0;
    }
    if (!any) continue;
    if (nl && i - blk[0] >= (1u << 24)) {
      flush_block(r, &cp, blk, nl, gsl, grad, gbase, grad_mean2d, drgb, dmean);
      nl = 0;
    }
    for (int c = 0; c < S2_COUNT; c++) gsl[c][nl] = gs[c];
    blk[nl++] = i;
    if (nl == 16) {
      flush_block(r, &cp, blk, nl, gsl, grad, gbase, grad_mean2d, drgb, dmean);
      nl = 0;
    }
  }
  if (nl) flush_block(r, &cp, blk, nl, gsl, grad, gbase, grad_mean2d, drgb, dmean);
}

static int grow(void **p, size_t n, size_t sz) {
  if (n == 0) n = 1;
  void *q = realloc(*p, n * sz);
  if (!q) return 0;
  *p = q;
  return 1;
}

mgs_status mgs_raster2d_reserve(mgs_raster *r, size_t n, size_t pix, mgs_error *err) {
  if (n > r->cap_surf) {
    size_t c = n + n / 4;
    if (!grow((void **)&r->surf, c, sizeof(mgs_surf2d) + sizeof(mgs_surf2d_cold)))
      return mgs_error_set(err, MGS_ERR_NOMEM, "render/raster_2dgs_project.c: out of memory for %zu surfels", n);
    r->cap_surf = c;
  }
  if (pix > r->cap_spix) {
    if (!grow((void **)&r->s_normal, 3 * pix, sizeof(float)) || !grow((void **)&r->s_median, pix, sizeof(float)) ||
        !grow((void **)&r->s_dist, pix, sizeof(float)) || !grow((void **)&r->s_m1, pix, sizeof(float)) ||
        !grow((void **)&r->s_m2, pix, sizeof(float)) || !grow((void **)&r->s_m0, pix, sizeof(float)) || !grow((void **)&r->s_medid, pix, sizeof(int32_t)) ||
        !grow((void **)&r->s_gmed, pix, sizeof(float)) || !grow((void **)&r->s_gnormal, 3 * pix, sizeof(float)) ||
        !grow((void **)&r->s_gdist, pix, sizeof(float)))
      return mgs_error_set(err, MGS_ERR_NOMEM, "render/raster_2dgs_project.c: out of memory for %zu pixels", pix);
    r->cap_spix = pix;
  }
  return MGS_OK;
}

void mgs_raster2d_free(mgs_raster *r) {
  free(r->surf); free(r->sgrad); free(r->s_rows); free(r->s_normal); free(r->s_median); free(r->s_dist); free(r->s_m1);
  free(r->s_m2); free(r->s_m0); free(r->s_medid); free(r->s_gmed); free(r->s_gnormal); free(r->s_gdist);
}

/* Per-Gaussian preprocessing of the forward (EWA projection, culling, SH colour, tile
 * rectangle) and its backward, as the reference 3DGS preprocessCUDA/computeCov2D/
 * computeCov3D. The world->camera transform is done in double (scenes far from the
 * origin), everything after it in float. */
#include <math.h>
#include <string.h>
#include "core/mgs_math.h"
#include "core/mgs_parallel.h"
#include "render/raster_internal.h"
#include "render/raster_simd.h"

/* The x/z and y/z range the Jacobian is evaluated in: the reference clamps to
 * +-1.3*tan(fov/2); written here for a principal point anywhere (reduces to the
 * reference's when it is the image centre). */
static void jacobian_limits(const mgs_camera *cam, float lx[2], float ly[2]) {
  double hx = 0.5 * cam->width / cam->fx, hy = 0.5 * cam->height / cam->fy;
  lx[0] = (float)(-cam->cx / cam->fx - 0.3 * hx);
  lx[1] = (float)((cam->width - cam->cx) / cam->fx + 0.3 * hx);
  ly[0] = (float)(-cam->cy / cam->fy - 0.3 * hy);
  ly[1] = (float)((cam->height - cam->cy) / cam->fy + 0.3 * hy);
}

/* 8 doubles (the projection's double-precision parts, 8 lanes of a block at a time). */
typedef double v8d __attribute__((vector_size(64)));
typedef int64_t v8l __attribute__((vector_size(64)));
MGS_VINLINE v8d v8d_set1(double x) { return (v8d){x, x, x, x, x, x, x, x}; }
MGS_VINLINE v8d v8d_load(const double *p) { v8d v; memcpy(&v, p, sizeof v); return v; }
MGS_VINLINE void v8d_store(double *p, v8d v) { memcpy(p, &v, sizeof v); }
MGS_VINLINE v8d v8d_from_float(const float *p) { v8f v; memcpy(&v, p, sizeof v); return __builtin_convertvector(v, v8d); }
MGS_VINLINE void v8d_to_float(float *p, v8d v) { v8f f = __builtin_convertvector(v, v8f); memcpy(p, &f, sizeof f); }
MGS_VINLINE void v8i_store(int *p, v8i v) { memcpy(p, &v, sizeof v); }
MGS_VINLINE v8d v8d_select(v8l m, v8d a, v8d b) { return (v8d)((m & (v8l)a) | (~m & (v8l)b)); }
MGS_VINLINE v8d v8d_and(v8l m, v8d a) { return (v8d)(m & (v8l)a); }
MGS_VINLINE v8l v8d_finite(v8d x) { return (x - x) == v8d_set1(0.0); }
MGS_VINLINE v8d v8d_sqrt(v8d x) {
#if defined(__AVX512F__)
  return (v8d)_mm512_sqrt_pd((__m512d)x);
#else
  v8d r;
  for (int i = 0; i < 8; i++) r[i] = sqrt(x[i]);
  return r;
#endif
}
MGS_VINLINE v8d v8d_floor(v8d x) {
#if defined(__AVX512F__)
  return (v8d)_mm512_roundscale_pd((__m512d)x, _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC);
#else
  v8d r;
  for (int i = 0; i < 8; i++) r[i] = floor(x[i]);
  return r;
#endif
}
/* A tile coordinate: 0 below (and for NaN), hi above, else truncated; 8 lanes. */
MGS_VINLINE v8i clamp_tile8(v8d v, v8d hi) {
  v8d c = v8d_select(v > hi, hi, v8d_and(v > v8d_set1(0.0), v));
  return __builtin_convertvector(c, v8i);
}

/* What the geometric part of the projection needs of the camera and settings. */
typedef struct geom_par {
  float W[9];          /* world->camera rotation */
  float lx[2], ly[2];  /* the Jacobian's x/z, y/z clamp */
  float fx, fy, smod;
} geom_par;

static void geom_par_init(const mgs_raster *r, geom_par *gp) {
  for (int a = 0; a < 3; a++)
    for (int b = 0; b < 3; b++) gp->W[3 * a + b] = (float)r->cam.w2c[4 * a + b];
  jacobian_limits(&r->cam, gp->lx, gp->ly);
  gp->fx = (float)r->cam.fx; gp->fy = (float)r->cam.fy;
  gp->smod = r->s.scale_modifier;
}

/* Rotation, scales and the 2x3 EWA map J W of 16 lanes. */
typedef struct proj_geom {
  float R[9][16], s[3][16], T0[3][16], T1[3][16], txc[16], tyc[16];
  int32_t clx[16], cly[16];  /* the Jacobian's x/z, y/z clamp was active */
} proj_geom;

/* proj_geom of 16 lanes from their quaternions, log-scales and camera-space means. Not
 * inlined: the backward recomputes the forward's exact values through this same code
 * rather than the forward storing them (80 bytes a Gaussian written and read back). */
__attribute__((noinline)) static void proj_geom16(const geom_par *gp, const float q[4][16], const float ls[3][16],
                                                  const float tx_[16], const float ty_[16], const float tz_[16],
                                                  proj_geom *o) {
  const v16f zero = v16f_set1(0.0f), one = v16f_set1(1.0f);
  /* rotation of the normalized quaternion (identity for a zero one, as mgs_quat_to_mat3f) */
  v16f w = v16f_load(q[0]), x = v16f_load(q[1]), y = v16f_load(q[2]), z = v16f_load(q[3]);
  v16f n2 = w * w + x * x + y * y + z * z;
  v16i nz = v16f_gt(n2, zero);
  v16f inv = one / v16f_sqrt(v16f_select(nz, n2, one));
  w = v16f_select(nz, w * inv, one); x = v16f_and(nz, x * inv); y = v16f_and(nz, y * inv); z = v16f_and(nz, z * inv);
  v16f two = v16f_set1(2.0f);
  v16f R[9];
  R[0] = one - two * (y * y + z * z); R[1] = two * (x * y - w * z); R[2] = two * (x * z + w * y);
  R[3] = two * (x * y + w * z); R[4] = one - two * (x * x + z * z); R[5] = two * (y * z - w * x);
  R[6] = two * (x * z - w * y); R[7] = two * (y * z + w * x); R[8] = one - two * (x * x + y * y);
  for (int k = 0; k < 9; k++) v16f_store(o->R[k], R[k]);
  for (int k = 0; k < 3; k++) v16f_store(o->s[k], v16f_set1(gp->smod) * v16f_exp(v16f_load(ls[k])));
  /* Jacobian with the reference's clamp */
  v16f fx = v16f_set1(gp->fx), fy = v16f_set1(gp->fy);
  v16f tx = v16f_load(tx_), ty = v16f_load(ty_), tz = v16f_load(tz_);
  v16f iz = one / tz;
  v16f txtz = tx * iz, tytz = ty * iz;
  v16f lx0 = v16f_set1(gp->lx[0]), lx1 = v16f_set1(gp->lx[1]), ly0 = v16f_set1(gp->ly[0]), ly1 = v16f_set1(gp->ly[1]);
  v16i_store(o->clx, v16f_lt(txtz, lx0) | v16f_gt(txtz, lx1));
  v16i_store(o->cly, v16f_lt(tytz, ly0) | v16f_gt(tytz, ly1));
  v16f txc = v16f_min(v16f_max(txtz, lx0), lx1) * tz, tyc = v16f_min(v16f_max(tytz, ly0), ly1) * tz;
  v16f J00 = fx * iz, J02 = v16f_set1(-1.0f) * fx * txc * iz * iz, J11 = fy * iz, J12 = v16f_set1(-1.0f) * fy * tyc * iz * iz;
  const float *W = gp->W;
  for (int j = 0; j < 3; j++) {
    v16f_store(o->T0[j], J00 * v16f_set1(W[j]) + J02 * v16f_set1(W[6 + j]));
    v16f_store(o->T1[j], J11 * v16f_set1(W[3 + j]) + J12 * v16f_set1(W[6 + j]));
  }
  v16f_store(o->txc, txc); v16f_store(o->tyc, tyc);
}

typedef struct proj_ctx {
  mgs_raster *r;
  geom_par gp;
  double campos[3];
} proj_ctx;

static void cull(mgs_raster *r, size_t i) {
  r->radii[i] = 0;
  r->count[i] = 0;
}

/* Gaussians are projected 16 at a time: the float covariance algebra and SH run as 16-wide
 * vectors, the double-precision parts (screen position, tile rectangles, view direction)
 * as two 8-wide ones; per lane remain the double world->camera transform, the culling
 * decisions and the stores. */
typedef struct proj_block {
  int n;                                  /* lanes in use */
  int alive[16];
  double td[3][16];                       /* camera-space mean, double */
  float q[4][16], ls[3][16], logit[16];   /* parameters */
  float tx[16], ty[16], tz[16];
  /* results of the vector part */
  proj_geom geo;
  float a[16], b[16], c[16], det[16], A[16], B[16], C[16], radius[16], op[16];
} proj_block;

static void block_vector_part(const proj_ctx *pc, proj_block *pb) {
  const v16f zero = v16f_set1(0.0f), one = v16f_set1(1.0f);
  proj_geom16(&pc->gp, pb->q, pb->ls, pb->tx, pb->ty, pb->tz, &pb->geo);
  v16f R[9], sv[3], T0[3], T1[3];
  for (int k = 0; k < 9; k++) R[k] = v16f_load(pb->geo.R[k]);
  for (int k = 0; k < 3; k++) {
    sv[k] = v16f_load(pb->geo.s[k]); T0[k] = v16f_load(pb->geo.T0[k]); T1[k] = v16f_load(pb->geo.T1[k]);
  }
  v16f M[9];
  for (int a = 0; a < 3; a++)
    for (int k = 0; k < 3; k++) M[3 * a + k] = R[3 * a + k] * sv[k];
  v16f S0 = M[0] * M[0] + M[1] * M[1] + M[2] * M[2];
  v16f S1 = M[0] * M[3] + M[1] * M[4] + M[2] * M[5];
  v16f S2 = M[0] * M[6] + M[1] * M[7] + M[2] * M[8];
  v16f S3 = M[3] * M[3] + M[4] * M[4] + M[5] * M[5];
  v16f S4 = M[3] * M[6] + M[4] * M[7] + M[5] * M[8];
  v16f S5 = M[6] * M[6] + M[7] * M[7] + M[8] * M[8];
  v16f ST00 = S0 * T0[0] + S1 * T0[1] + S2 * T0[2];
  v16f ST01 = S1 * T0[0] + S3 * T0[1] + S4 * T0[2];
  v16f ST02 = S2 * T0[0] + S4 * T0[1] + S5 * T0[2];
  v16f ST10 = S0 * T1[0] + S1 * T1[1] + S2 * T1[2];
  v16f ST11 = S1 * T1[0] + S3 * T1[1] + S4 * T1[2];
  v16f ST12 = S2 * T1[0] + S4 * T1[1] + S5 * T1[2];
  v16f dil = v16f_set1(pc->r->s.dilation);
  v16f a = T0[0] * ST00 + T0[1] * ST01 + T0[2] * ST02 + dil;
  v16f b = T0[0] * ST10 + T0[1] * ST11 + T0[2] * ST12;
  v16f c = T1[0] * ST10 + T1[1] * ST11 + T1[2] * ST12 + dil;
  v16f det = a * c - b * b;
  v16f idet = one / det;
  v16f mid = v16f_set1(0.5f) * (a + c);
  v16f l1 = mid + v16f_sqrt(v16f_max(v16f_set1(0.1f), mid * mid - det));
  v16f radius = v16f_ceil(v16f_set1(3.0f) * v16f_sqrt(v16f_max(l1, zero)));
  v16f op = one / (one + v16f_exp(zero - v16f_load(pb->logit)));
  v16f_store(pb->a, a); v16f_store(pb->b, b); v16f_store(pb->c, c); v16f_store(pb->det, det);
  v16f_store(pb->A, c * idet); v16f_store(pb->B, zero - b * idet); v16f_store(pb->C, a * idet);
  v16f_store(pb->radius, radius); v16f_store(pb->op, op);
}

/* Lanes are Gaussians i0 .. i0+nl-1, or idx[0..nl) (increasing, spread below 2^24: the
 * SH kernel addresses lanes by 32-bit offsets from the first) when idx is not NULL. */
#define GI(l) (idx ? (size_t)idx[l] : i0 + (size_t)(l))
static void project_block(const proj_ctx *pc, size_t i0, int nl, const uint32_t *idx) {
  if (idx) i0 = idx[0];
  mgs_raster *r = pc->r;
  const mgs_gaussians *g = r->g;
  const mgs_camera *cam = &r->cam;
  const double *V = cam->w2c;
  proj_block pb;
  pb.n = nl;
  /* the double world->camera transform, 8 lanes at a time (unused lanes: the mean at the
     camera centre) */
  double md[3][16], tdl[3][16];
  for (int l = 0; l < 16; l++)
    for (int k = 0; k < 3; k++) md[k][l] = l < nl ? (double)g->mean[3 * GI(l) + k] : pc->campos[k];
  for (int h = 0; h < 16; h += 8) {
    v8d m0 = v8d_load(md[0] + h), m1 = v8d_load(md[1] + h), m2 = v8d_load(md[2] + h);
    for (int k = 0; k < 3; k++)
      v8d_store(tdl[k] + h, v8d_set1(V[4 * k]) * m0 + v8d_set1(V[4 * k + 1]) * m1 + v8d_set1(V[4 * k + 2]) * m2 + v8d_set1(V[4 * k + 3]));
  }
  /* lane setup: early culling, parameters (unused lanes benign) */
  for (int l = 0; l < 16; l++) {
    size_t i = l < nl ? GI(l) : 0; /* a listed block's idx has only nl entries */
    int ok = l < nl;
    double td[3] = {0, 0, 1};
    if (ok) {
      for (int k = 0; k < 3; k++) td[k] = tdl[k][l];
      const float *qq = g->rot + 4 * i;
      /* a diverged parameter culls the Gaussian (scales and SH are caught below) */
      ok = td[2] > r->s.near_plane && isfinite(td[0]) && isfinite(td[1]) && isfinite(td[2]) &&
           isfinite(qq[0] + qq[1] + qq[2] + qq[3]) && isfinite(g->opacity[i]);
      if (!ok) { cull(r, i); td[0] = td[1] = 0; td[2] = 1; }
    }
    pb.alive[l] = ok;
    for (int k = 0; k < 3; k++) pb.td[k][l] = td[k];
    pb.tx[l] = (float)td[0]; pb.ty[l] = (float)td[1]; pb.tz[l] = (float)td[2];
    for (int k = 0; k < 4; k++) pb.q[k][l] = ok ? g->rot[4 * i + k] : (k == 0);
    for (int k = 0; k < 3; k++) pb.ls[k][l] = ok ? g->log_scale[3 * i + k] : 0.0f;
    pb.logit[l] = ok ? g->opacity[i] : 0.0f;
  }
  block_vector_part(pc, &pb);
  /* per lane, part 1: culling, screen position, reference tile rect, view direction */
  double udl[16], vdl[16];
  int rect[4][16];
  float dirl[3][16], distl[16], rgbl[3][16];
  int32_t lane[16];
  uint16_t shmask = 0;
  for (int l = 0; l < 16; l++) lane[l] = 0;
  /* the double-precision parts 8 lanes at a time (unused and dead lanes hold benign
     values: camera-space mean (0, 0, 1), mean at the camera centre) */
  int32_t finite[16];
  for (int h = 0; h < 16; h += 8) {
    const v8d fx = v8d_set1(cam->fx), fy = v8d_set1(cam->fy), cx = v8d_set1(cam->cx), cy = v8d_set1(cam->cy);
    v8d izd = v8d_set1(1.0) / v8d_load(pb.td[2] + h);
    v8d ud = fx * v8d_load(pb.td[0] + h) * izd + cx, vd = fy * v8d_load(pb.td[1] + h) * izd + cy;
    v8d rad = v8d_from_float(pb.radius + h);
    v8l fin = v8d_finite(ud) & v8d_finite(vd) & v8d_finite(rad) & v8d_finite(v8d_from_float(pb.A + h)) &
              v8d_finite(v8d_from_float(pb.B + h)) & v8d_finite(v8d_from_float(pb.C + h));
    for (int l = 0; l < 8; l++) finite[h + l] = fin[l] != 0;
    v8d_store(udl + h, ud); v8d_store(vdl + h, vd);
    /* the reference's getRect, in its pixel coordinates (centres at integers) */
    v8d px = ud - v8d_set1(0.5), py = vd - v8d_set1(0.5), ts = v8d_set1(1.0 / MGS_TILE_SIZE);
    v8d tsz = v8d_set1(MGS_TILE_SIZE), one = v8d_set1(1.0), tx = v8d_set1(r->tiles_x), ty = v8d_set1(r->tiles_y);
    v8i_store(rect[0] + h, clamp_tile8((px - rad) * ts, tx));
    v8i_store(rect[1] + h, clamp_tile8((py - rad) * ts, ty));
    v8i_store(rect[2] + h, clamp_tile8((px + rad + tsz - one) * ts, tx));
    v8i_store(rect[3] + h, clamp_tile8((py + rad + tsz - one) * ts, ty));
    /* view direction in double (far-from-origin scenes) */
    v8d dd[3];
    for (int k = 0; k < 3; k++) dd[k] = v8d_load(md[k] + h) - v8d_set1(pc->campos[k]);
    v8d dist = v8d_sqrt(dd[0] * dd[0] + dd[1] * dd[1] + dd[2] * dd[2]);
    v8l pos = dist > v8d_set1(0.0);
    v8d id = v8d_set1(1.0) / v8d_select(pos, dist, v8d_set1(1.0));
    for (int k = 0; k < 3; k++) v8d_to_float(dirl[k] + h, v8d_and(pos, dd[k] * id));
    v8d_to_float(distl + h, dist);
  }
  for (int l = 0; l < nl; l++) {
    if (!pb.alive[l]) continue;
    size_t i = GI(l);
    float det = pb.det[l];
    if (!(det > 0) || !isfinite(det) || !finite[l]) { cull(r, i); continue; }
    if ((rect[2][l] - rect[0][l]) * (rect[3][l] - rect[1][l]) == 0) { cull(r, i); continue; }
    lane[l] = (int32_t)(GI(l) - i0);
    shmask |= (uint16_t)(1u << l);
  }
  /* colour from SH, 16 lanes at once */
#if defined(__AVX512F__)
  if (shmask)
    mgs_sh_eval16(r->s.sh_degree, g->sh_dc + 3 * i0, g->sh_rest + (size_t)MGS_SH_REST_MAX * i0, lane, shmask, dirl, rgbl);
#else
  (void)lane;
  for (int l = 0; l < nl; l++) {
    if (!(shmask & (1u << l))) continue;
    size_t i = GI(l);
    float d3[3] = {dirl[0][l], dirl[1][l], dirl[2][l]}, c3[3];
    mgs_sh_eval(r->s.sh_degree, g->sh_dc + 3 * i, g->sh_rest + (size_t)MGS_SH_REST_MAX * i, d3, c3);
    for (int k = 0; k < 3; k++) rgbl[k][l] = c3[k];
  }
#endif
  /* per lane, part 2: splat and aux; which lanes are binned */
  float r2l[16];
  uint16_t binmask = 0;
  for (int l = 0; l < 16; l++) r2l[l] = 0;
  for (int l = 0; l < nl; l++) {
    if (!(shmask & (1u << l))) continue;
    size_t i = GI(l);
    float op = pb.op[l];
    mgs_proj_aux *ax = &r->aux[i];
    mgs_splat *sp = &r->splat[i];
    float rgb[3] = {rgbl[0][l], rgbl[1][l], rgbl[2][l]};
    for (int k = 0; k < 3; k++) {
      ax->clamped[k] = rgb[k] < 0;
      sp->rgb[k] = rgb[k] < 0 ? 0 : rgb[k];
      ax->dir[k] = dirl[k][l];
    }
    if (!isfinite(sp->rgb[0]) || !isfinite(sp->rgb[1]) || !isfinite(sp->rgb[2])) { cull(r, i); continue; }
    ax->dist = distl[l];
    ax->t[0] = pb.tx[l]; ax->t[1] = pb.ty[l]; ax->t[2] = pb.tz[l];
    sp->u = (float)udl[l]; sp->v = (float)vdl[l];
    sp->A = pb.A[l]; sp->B = pb.B[l]; sp->C = pb.C[l];
    sp->opacity = op;
    sp->z = pb.tz[l];
    r->radii[i] = (int)pb.radius[l];
    if (op < MGS_ALPHA_MIN) { r->count[i] = 0; sp->ry = sp->rx = 0; continue; }
    r2l[l] = 2.0f * logf(op / MGS_ALPHA_MIN);
    binmask |= (uint16_t)(1u << l);
  }
  if (!binmask) return;
  /* Tighter, equivalent binning: outside the ellipse where opacity*G >= 1/255 nothing is
   * drawn, so tiles of the reference rect that miss its bounding box are dropped.
   * Conservative margins keep the result identical to evaluating the whole rect. */
  float hxl[16], mxl[16], hyl[16], myl[16];
  int brect[4][16];
  {
    v16f r2 = v16f_load(r2l);
    v16f hx = v16f_sqrt(r2 * v16f_load(pb.a)), hy = v16f_sqrt(r2 * v16f_load(pb.c));
    v16f mx = v16f_set1(1e-3f) * hx + v16f_set1(0.02f), my = v16f_set1(1e-3f) * hy + v16f_set1(0.02f);
    v16f_store(hxl, hx); v16f_store(hyl, hy); v16f_store(mxl, mx); v16f_store(myl, my);
    for (int h = 0; h < 16; h += 8) {
      v8d ud = v8d_load(udl + h), vd = v8d_load(vdl + h), half = v8d_set1(0.5), one = v8d_set1(1.0);
      v8d hxd = v8d_from_float(hxl + h), hyd = v8d_from_float(hyl + h), mxd = v8d_from_float(mxl + h), myd = v8d_from_float(myl + h);
      v8d ts = v8d_set1(1.0 / MGS_TILE_SIZE), tx = v8d_set1(r->tiles_x), ty = v8d_set1(r->tiles_y);
      v8i_store(brect[0] + h, clamp_tile8(v8d_floor((ud - hxd - half - mxd) * ts), tx));
      v8i_store(brect[2] + h, clamp_tile8(v8d_floor((ud + hxd - half + mxd) * ts) + one, tx));
      v8i_store(brect[1] + h, clamp_tile8(v8d_floor((vd - hyd - half - myd) * ts), ty));
      v8i_store(brect[3] + h, clamp_tile8(v8d_floor((vd + hyd - half + myd) * ts) + one, ty));
    }
  }
  for (int l = 0; l < nl; l++) {
    if (!(binmask & (1u << l))) continue;
    size_t i = GI(l);
    int x0 = rect[0][l], y0 = rect[1][l], x1 = rect[2][l], y1 = rect[3][l];
    if (brect[0][l] > x0) x0 = brect[0][l];
    if (brect[2][l] < x1) x1 = brect[2][l];
    if (brect[1][l] > y0) y0 = brect[1][l];
    if (brect[3][l] < y1) y1 = brect[3][l];
    r->splat[i].ry = hyl[l] + myl[l];
    r->splat[i].rx = hxl[l] + mxl[l];
    if (x1 <= x0 || y1 <= y0) { r->count[i] = 0; continue; }
    uint16_t *rc = r->rect + 4 * i;
    rc[0] = (uint16_t)x0; rc[1] = (uint16_t)y0; rc[2] = (uint16_t)x1; rc[3] = (uint16_t)y1;
    r->count[i] = (uint32_t)((x1 - x0) * (y1 - y0));
  }
}

static void project_range(void *ctx, size_t b, size_t e) {
  const proj_ctx *pc = ctx;
  for (size_t i = b * 16; i < e * 16 && i < pc->r->n; i += 16) {
    size_t left = pc->r->n - i;
    project_block(pc, i, left < 16 ? (int)left : 16, NULL);
  }
}

typedef struct list_ctx {
  proj_ctx pc;
  const uint32_t *idx;
  size_t m;
} list_ctx;

static void project_listed(void *ctx, size_t b, size_t e) {
  const list_ctx *lc = ctx;
  for (size_t k = b; k < e; k++) {
    size_t j = 16 * k, end = j + 16 < lc->m ? j + 16 : lc->m;
    while (j < end) { /* lanes of one call stay within 2^24 of its first */
      size_t j1 = j + 1;
      while (j1 < end && lc->idx[j1] - lc->idx[j] < (1u << 24)) j1++;
      project_block(&lc->pc, 0, (int)(j1 - j), lc->idx + j);
      j = j1;
    }
  }
}

void mgs_raster_project_list(mgs_raster *r, const uint32_t *idx, size_t m) {
  /* every Gaussian not listed is culled, as the projection would have */
  memset(r->radii, 0, r->n * sizeof *r->radii);
  memset(r->count, 0, r->n * sizeof *r->count);
  list_ctx lc;
  lc.pc.r = r;
  geom_par_init(r, &lc.pc.gp);
  mgs_camera_center(&r->cam, lc.pc.campos);
  lc.idx = idx;
  lc.m = m;
  mgs_parallel_for(0, (m + 15) / 16, 4, project_listed, &lc);
}

void mgs_raster_project_all(mgs_raster *r) {
  proj_ctx pc;
  pc.r = r;
  geom_par_init(r, &pc.gp);
  mgs_camera_center(&r->cam, pc.campos);
  mgs_parallel_for(0, (r->n + 15) / 16, 64, project_range, &pc); /* blocks of 16 */
}

/* Backward of the projection for up to 16 binned Gaussians at once: idx[0..nl) their
 * indices, gsum[c][l] the tile kernels' summed gradient c of lane l. The geometric chain
 * (conic -> 2D covariance -> Sigma, J, camera-space mean -> scales, quaternion, mean) runs
 * 16-wide; the SH backward and the additions into grad run per lane. Adds into grad, whose
 * row 0 is Gaussian gbase (a block's gradients, or the whole model's with gbase 0). */
void mgs_raster_project_backward16(mgs_raster *r, const uint32_t *idx, int nl, float gsum[GS_N][16],
                                   mgs_gaussians *grad, size_t gbase, float *grad_mean2d) {
  const mgs_gaussians *g = r->g;
  const mgs_camera *cam = &r->cam;
  float tl[3][16], Kl[3][16], ql[4][16], lsl[3][16];
  for (int l = 0; l < 16; l++) {
    int ok = l < nl;
    size_t i = ok ? idx[l] : idx[0];
    const mgs_proj_aux *ax = &r->aux[i];
    const mgs_splat *sp = &r->splat[i];
    for (int k = 0; k < 3; k++) { tl[k][l] = ax->t[k]; lsl[k][l] = g->log_scale[3 * i + k]; }
    Kl[0][l] = sp->A; Kl[1][l] = sp->B; Kl[2][l] = sp->C;
    for (int k = 0; k < 4; k++) ql[k][l] = g->rot[4 * i + k];
    if (!ok) for (int c = 0; c < GS_N; c++) gsum[c][l] = 0;
  }
  /* the forward's R, s, J W exactly, recomputed (binned Gaussians were projected with
     their own parameters, as here) */
  geom_par gp;
  geom_par_init(r, &gp);
  proj_geom geo;
  proj_geom16(&gp, ql, lsl, tl[0], tl[1], tl[2], &geo);
  const float *W = gp.W;
  const float fx = gp.fx, fy = gp.fy;
  const v16f zero = v16f_set1(0.0f);

  /* conic -> 2D covariance: dL/dcov = -K G K */
  v16f K00 = v16f_load(Kl[0]), K01 = v16f_load(Kl[1]), K11 = v16f_load(Kl[2]);
  v16f G00 = v16f_load(gsum[GS_A]), G01 = 0.5f * v16f_load(gsum[GS_B2]), G11 = v16f_load(gsum[GS_C]);
  v16f KG00 = K00 * G00 + K01 * G01, KG01 = K00 * G01 + K01 * G11;
  v16f KG10 = K01 * G00 + K11 * G01, KG11 = K01 * G01 + K11 * G11;
  v16f C00 = zero - (KG00 * K00 + KG01 * K01);
  v16f C01 = zero - (KG00 * K01 + KG01 * K11);
  v16f C11 = zero - (KG10 * K01 + KG11 * K11);
  v16f T0[3], T1[3], R[9], s[3], M[9];
  for (int k = 0; k < 3; k++) { T0[k] = v16f_load(geo.T0[k]); T1[k] = v16f_load(geo.T1[k]); s[k] = v16f_load(geo.s[k]); }
  for (int k = 0; k < 9; k++) R[k] = v16f_load(geo.R[k]);
  for (int a = 0; a < 3; a++)
    for (int k = 0; k < 3; k++) M[3 * a + k] = R[3 * a + k] * s[k];
  v16f Sg[9];
  for (int a = 0; a < 3; a++)
    for (int b = 0; b < 3; b++) Sg[3 * a + b] = M[3 * a] * M[3 * b] + M[3 * a + 1] * M[3 * b + 1] + M[3 * a + 2] * M[3 * b + 2];
  v16f dS[9];
  for (int a = 0; a < 3; a++)
    for (int b = 0; b < 3; b++)
      dS[3 * a + b] = T0[a] * (C00 * T0[b] + C01 * T1[b]) + T1[a] * (C01 * T0[b] + C11 * T1[b]);
  v16f TS0[3], TS1[3];
  for (int b = 0; b < 3; b++) {
    TS0[b] = T0[0] * Sg[b] + T0[1] * Sg[3 + b] + T0[2] * Sg[6 + b];
    TS1[b] = T1[0] * Sg[b] + T1[1] * Sg[3 + b] + T1[2] * Sg[6 + b];
  }
  v16f dT0[3], dT1[3];
  for (int b = 0; b < 3; b++) {
    dT0[b] = 2.0f * (C00 * TS0[b] + C01 * TS1[b]);
    dT1[b] = 2.0f * (C01 * TS0[b] + C11 * TS1[b]);
  }
  v16f dJ00 = dT0[0] * W[0] + dT0[1] * W[1] + dT0[2] * W[2];
  v16f dJ02 = dT0[0] * W[6] + dT0[1] * W[7] + dT0[2] * W[8];
  v16f dJ11 = dT1[0] * W[3] + dT1[1] * W[4] + dT1[2] * W[5];
  v16f dJ12 = dT1[0] * W[6] + dT1[1] * W[7] + dT1[2] * W[8];
  v16f tx = v16f_load(tl[0]), ty = v16f_load(tl[1]), tz = v16f_load(tl[2]);
  v16f txc = v16f_load(geo.txc), tyc = v16f_load(geo.tyc);
  v16i clx = v16i_load(geo.clx), cly = v16i_load(geo.cly);
  v16f iz = 1.0f / tz, iz2 = iz * iz, iz3 = iz2 * iz;
  v16f dt0 = zero, dt1 = zero, dt2 = zero - fx * iz2 * dJ00 - fy * iz2 * dJ11;
  /* J02 = -fx*txc/z^2 with txc = x (free) or lim*z (clamped) */
  dt2 += v16f_select(clx, fx * txc * iz3 * dJ02, 2.0f * fx * txc * iz3 * dJ02);
  dt0 += v16f_and(~clx, zero - fx * iz2 * dJ02);
  dt2 += v16f_select(cly, fy * tyc * iz3 * dJ12, 2.0f * fy * tyc * iz3 * dJ12);
  dt1 += v16f_and(~cly, zero - fy * iz2 * dJ12);
  v16f gu = v16f_load(gsum[GS_U]), gv = v16f_load(gsum[GS_V]);
  dt0 += gu * fx * iz;
  dt1 += gv * fy * iz;
  dt2 += zero - gu * fx * tx * iz2 - gv * fy * ty * iz2;
  dt2 += v16f_load(gsum[GS_Z]);
  float dm[3][16];
  for (int k = 0; k < 3; k++) v16f_store(dm[k], W[k] * dt0 + W[3 + k] * dt1 + W[6 + k] * dt2);
  /* Sigma = M M^T, M = R S */
  v16f dM[9];
  for (int a = 0; a < 3; a++)
    for (int k = 0; k < 3; k++)
      dM[3 * a + k] = 2.0f * (dS[3 * a] * M[k] + dS[3 * a + 1] * M[3 + k] + dS[3 * a + 2] * M[6 + k]);
  v16f dR[9];
  float dls[3][16];
  for (int k = 0; k < 3; k++) {
    v16f dsk = dM[k] * R[k] + dM[3 + k] * R[3 + k] + dM[6 + k] * R[6 + k];
    v16f_store(dls[k], dsk * s[k]);
    for (int a = 0; a < 3; a++) dR[3 * a + k] = dM[3 * a + k] * s[k];
  }
  v16f q0 = v16f_load(ql[0]), q1 = v16f_load(ql[1]), q2 = v16f_load(ql[2]), q3 = v16f_load(ql[3]);
  v16f qn2 = q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3;
  v16i qok = v16f_gt(qn2, zero);
  v16f qn = v16f_sqrt(v16f_select(qok, qn2, v16f_set1(1.0f)));
  v16f iqn = 1.0f / qn;
  v16f w = q0 * iqn, x = q1 * iqn, y = q2 * iqn, z = q3 * iqn;
  v16f gq[4];
  gq[0] = 2.0f * (zero - z * dR[1] + y * dR[2] + z * dR[3] - x * dR[5] - y * dR[6] + x * dR[7]);
  gq[1] = 2.0f * (y * dR[1] + z * dR[2] + y * dR[3] - 2.0f * x * dR[4] - w * dR[5] + z * dR[6] + w * dR[7] - 2.0f * x * dR[8]);
  gq[2] = 2.0f * (zero - 2.0f * y * dR[0] + x * dR[1] + w * dR[2] + x * dR[3] + z * dR[5] - w * dR[6] + z * dR[7] - 2.0f * y * dR[8]);
  gq[3] = 2.0f * (zero - 2.0f * z * dR[0] - w * dR[1] + x * dR[2] + w * dR[3] - 2.0f * z * dR[4] + y * dR[5] + x * dR[6] + y * dR[7]);
  v16f qd = w * gq[0] + x * gq[1] + y * gq[2] + z * gq[3];
  v16f qv[4] = {w, x, y, z};
  float dq[4][16];
  for (int k = 0; k < 4; k++) v16f_store(dq[k], v16f_and(qok, (gq[k] - qv[k] * qd) * iqn));
  float gm[16];
  {
    v16f nx = gu * (0.5f * (float)cam->width), ny = gv * (0.5f * (float)cam->height);
    v16f_store(gm, v16f_sqrt(nx * nx + ny * ny));
  }
  /* SH backward, 16 lanes at once */
  float dirl[3][16], drgb[3][16], ddir[3][16];
  int32_t lane[16];
  for (int l = 0; l < 16; l++) {
    int ok = l < nl;
    const mgs_proj_aux *ax = &r->aux[ok ? idx[l] : idx[0]];
    lane[l] = ok ? (int32_t)(idx[l] - idx[0]) : 0;
    for (int k = 0; k < 3; k++) {
      dirl[k][l] = ax->dir[k];
      drgb[k][l] = (!ok || ax->clamped[k]) ? 0.0f : gsum[GS_R + k][l];
    }
  }
#if defined(__AVX512F__)
  /* lanes are relative to idx[0] (the caller keeps the spread below 2^31 / 45) */
  mgs_sh_backward16(r->s.sh_degree, g->sh_rest + (size_t)MGS_SH_REST_MAX * idx[0], lane, (uint16_t)((1u << nl) - 1), dirl, drgb,
                    grad->sh_dc + 3 * (idx[0] - gbase), grad->sh_rest + (size_t)MGS_SH_REST_MAX * (idx[0] - gbase), ddir);
#else
  (void)lane;
  for (int l = 0; l < nl; l++) {
    size_t i = idx[l];
    float d3[3] = {dirl[0][l], dirl[1][l], dirl[2][l]}, g3[3] = {drgb[0][l], drgb[1][l], drgb[2][l]}, o3[3];
    mgs_sh_backward(r->s.sh_degree, g->sh_dc + 3 * i, g->sh_rest + (size_t)MGS_SH_REST_MAX * i, d3, g3,
                    grad->sh_dc + 3 * (i - gbase), grad->sh_rest + (size_t)MGS_SH_REST_MAX * (i - gbase), o3);
    for (int k = 0; k < 3; k++) ddir[k][l] = o3[k];
  }
#endif
  /* per lane: the view-direction part of the mean, the additions */
  for (int l = 0; l < nl; l++) {
    size_t i = idx[l];
    const mgs_proj_aux *ax = &r->aux[i];
    const mgs_splat *sp = &r->splat[i];
    float dmean[3] = {dm[0][l], dm[1][l], dm[2][l]};
    if (ax->dist > 0) {
      float dd = ax->dir[0] * ddir[0][l] + ax->dir[1] * ddir[1][l] + ax->dir[2] * ddir[2][l];
      for (int k = 0; k < 3; k++) dmean[k] += (ddir[k][l] - ax->dir[k] * dd) / ax->dist;
    }
    size_t gi = i - gbase;
    for (int k = 0; k < 3; k++) grad->mean[3 * gi + k] += dmean[k];
    grad->opacity[gi] += gsum[GS_OP][l] * sp->opacity * (1.0f - sp->opacity);
    for (int k = 0; k < 3; k++) grad->log_scale[3 * gi + k] += dls[k][l];
    for (int k = 0; k < 4; k++) grad->rot[4 * gi + k] += dq[k][l];
    if (grad_mean2d) grad_mean2d[i] = gm[l];
  }
}

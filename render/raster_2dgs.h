/* What the 2DGS projection hands the 2DGS tile kernels (raster_2dgs_*.c), per surfel and
 * per (surfel, tile) gradient slot. Internal.
 *
 * The ray-splat intersection of the authors (k = x Tw - Tu, l = y Tw - Tv, p = k x l,
 * (u, v) = p.xy / p.z) is affine before the division: Tw x Tw = 0 leaves
 *   p = x (Tv x Tw) + y (Tw x Tu) + Tu x Tv,
 * and the depth of the hit, u Tw0 + v Tw1 + Tw2 = Tw.p / p.z, has the numerator
 * Tw.(Tu x Tv) = det T. So per pixel: three adds, one reciprocal, rho3 = |p.xy|^2 / p.z^2
 * and z = det T / p.z. The coefficients are taken about the filter centre (ox, oy), where
 * they are small (no cancellation of x Tw2 against Tu2 ~ cx Tw2). */
#ifndef MGS_RASTER_2DGS_H
#define MGS_RASTER_2DGS_H
#include "render/raster_internal.h"

typedef struct mgs_surf2d {
  float c0[3], c1[3], c2[3]; /* p = c0 (x - ox) + c1 (y - oy) + c2 */
  float ox, oy;              /* centre of the 3-sigma box: the screen-space filter's centre */
  float det;                 /* det T: hit depth = det / p.z */
  float opacity;             /* sigmoid(logit) */
  float rgb[3];              /* SH colour, clamped at 0 */
  /* Where alpha >= 1/255 can hold, about (ox, oy): the ellipse {rho3 <= rmax} (slightly
     enlarged) has on the row y - oy = yc + d the columns xc + sl d +- sqrt(h0 - kq d^2)
     (h0 < 0: no pixel; h0 = inf, kq = 0: an unbounded conic, every column); the filter's
     disc {rho2 <= rmax} lies in the square |x - ox|, |y - oy| <= rf. */
  float yc, xc, sl, h0, kq, rf;
  float zc;                  /* the centre's depth (Tw2): the depth where the filter wins */
  float pad;
} mgs_surf2d;

/* What only the maps pass and the per-surfel backward read. */
typedef struct mgs_surf2d_cold {
  float n[3];  /* world normal (third axis of R) turned towards the camera */
  float nsign; /* n = nsign * R e3 */
} mgs_surf2d_cold;

/* The records live in r->surf: cap_surf hot ones, then cap_surf cold ones (allocated by
 * raster_2dgs_project.c; no other file reads them). */
static inline mgs_surf2d *mgs_raster2d_surf(const mgs_raster *r) { return (mgs_surf2d *)(void *)r->surf; }
static inline mgs_surf2d_cold *mgs_raster2d_cold(const mgs_raster *r) {
  return (mgs_surf2d_cold *)(void *)(mgs_raster2d_surf(r) + r->cap_surf);
}

/* Slot of one (surfel, tile) intersection: the tile's pixel sums of dL/d(c0, c1, c2, det,
 * ox, oy as the filter centre, opacity, rgb, zc, n); n's only while the map gradients are
 * live (all 0 otherwise). */
enum { S2_C0 = 0, S2_C1 = 3, S2_C2 = 6, S2_DET = 9, S2_OX, S2_OY, S2_OP, S2_R, S2_G, S2_B, S2_ZC, S2_N, S2_COUNT = S2_N + 3 };
#define S2_STRIDE_MAX 32
/* Without live map gradients a slot is its first 16 floats (one 64-byte line: the slots are
 * written in random order) and the zc sums sit in a side array of one float a slot (the
 * upper half of the allocation; 4 bytes a slot stay in cache). */
static inline int mgs_raster2d_slot_stride(const mgs_raster *r) { return r->s_grad_live ? S2_STRIDE_MAX : 16; }
static inline int mgs_raster2d_slot_count(const mgs_raster *r) { return r->s_grad_live ? S2_COUNT : 16; }
static inline float *mgs_raster2d_zc_side(const mgs_raster *r) { return r->sgrad + (size_t)r->cap_sgrad * 16; }
#endif

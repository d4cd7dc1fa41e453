/* The per-pixel Gaussian evaluation shared by the forward and backward tile kernels (one
 * 16-pixel tile row at a time), so that both take the same alpha decisions bit for bit.
 * Internal. */
#ifndef MGS_RASTER_KERNEL_H
#define MGS_RASTER_KERNEL_H
#include <math.h>
#include "render/raster_internal.h"
#include "render/raster_simd.h"

/* power = -(A dx^2 + C dy^2)/2 - B dx dy, dx = pixel centre - u (the reference's
 * formula; its d is mean - pixel, the sign cancels in every term). */
MGS_VINLINE v16f mgs_row_power(const mgs_splat *sp, v16f dx, float dy) {
  /* (-A/2 dx - B dy) dx - C/2 dy^2 */
  float hc = -0.5f * sp->C * dy * dy, bdy = -sp->B * dy;
  return v16f_fma(v16f_fma(v16f_set1(-0.5f * sp->A), dx, v16f_set1(bdy)), dx, v16f_set1(hc));
}

/* Rows [*lo, *hi] of a tile starting at pixel row y0 (nrows rows) that can hold
 * contributions of sp (|pixel centre - v| <= ry); empty when *lo > *hi. */
MGS_VINLINE void mgs_row_range(const mgs_splat *sp, int y0, int nrows, int *lo, int *hi) {
  float a = sp->v - sp->ry - 0.5f - (float)y0, b = sp->v + sp->ry - 0.5f - (float)y0;
  int l = a <= 0 ? 0 : (a >= (float)nrows ? nrows : (int)ceilf(a));
  int h = b < 0 ? -1 : (b >= (float)(nrows - 1) ? nrows - 1 : (int)floorf(b));
  *lo = l; *hi = h;
}
/* One 16-pixel row of a tile blended with sp as the forward blends it: *m gets the pixels
 * sp contributes to, *alpha its alpha there and the return value the transmittance after
 * it (the caller stores it where *m is set); pixels whose transmittance would fall under
 * MGS_T_MIN are marked done (and *rowdone set when the whole row is). For the passes that
 * repeat the forward's decisions (blend statistics, normal/median maps). */
MGS_VINLINE v16f mgs_row_step(const mgs_splat *sp, v16f dx, float dy, v16f T, v16i *done, int *rowdone, v16i *m,
                              v16f *alpha) {
  const v16f zero = v16f_set1(0.0f);
  v16f power = mgs_row_power(sp, dx, dy);
  v16f a = v16f_min(v16f_set1(MGS_ALPHA_MAX), v16f_set1(sp->opacity) * v16f_exp_neg(power));
  v16i mm = v16f_le(power, zero) & v16f_ge(a, v16f_set1(MGS_ALPHA_MIN)) & ~*done;
  v16f testT = T * (v16f_set1(1.0f) - a);
  v16i nd = mm & v16f_lt(testT, v16f_set1(MGS_T_MIN));
  *done |= nd;
  if (v16i_any(nd)) *rowdone = !v16i_any(~*done);
  *m = mm & ~nd;
  *alpha = a;
  return testT;
}

/* Blending statistics (raster_blend.c for splats, raster_2dgs_tiles.c for surfels): one
 * Gaussian's step on a tile row — its weight alpha*T added to *wsum, the row's first
 * largest weight and its index kept (strictly greater, as the authors' `weight_max <
 * alpha*T`), the transmittance advanced where m is set. */
MGS_VINLINE void mgs_blend_stat_step(v16i m, v16f alpha, v16f testT, v16i gidx, v16f *T, v16f *wmax, v16i *imax,
                                     v16f *wsum) {
  v16f w = v16f_and(m, alpha * *T);
  *wsum += w;
  v16i better = m & v16f_gt(w, *wmax);
  *wmax = v16f_select(better, w, *wmax);
  *imax = (better & gidx) | (~better & *imax);
  *T = v16f_select(m, testT, *T);
}

/* Every pixel of the tile's nrows rows done (the tile's early stop). */
MGS_VINLINE int mgs_blend_tile_done(const v16i *done, int nrows) {
  v16i all = done[0];
  for (int y = 1; y < nrows; y++) all &= done[y];
  return !v16i_any(~all);
}

/* A tile's per-pixel statistics written out: final transmittance and max-weight index. */
MGS_VINLINE void mgs_blend_tile_store(const v16f *T, const v16i *imax, int x0, int y0, int nrows, int ncols, int W,
                                      float *final_T, int32_t *max_index) {
  for (int y = 0; y < nrows; y++) {
    size_t p = (size_t)(y0 + y) * W + x0;
    for (int x = 0; x < ncols; x++) {
      final_T[p + x] = T[y][x];
      max_index[p + x] = imax[y][x];
    }
  }
}

#if defined(MGS_HALF_ROWS) || defined(MGS_ROWS8)
MGS_VINLINE v8f mgs_row_power8(const mgs_splat *sp, v8f dx, float dy) {
  float hc = -0.5f * sp->C * dy * dy, bdy = -sp->B * dy;
  return v8f_fma(v8f_fma(v8f_set1(-0.5f * sp->A), dx, v8f_set1(bdy)), dx, v8f_set1(hc));
}
#endif

#if defined(MGS_ROWS8)
/* A power below this gives opacity * exp_neg(power) < 1/255 for certain, so a pixel there
 * takes nothing from the Gaussian: at most log((1/255) / opacity) = -log(255 opacity), less
 * a margin (0.02) far above the rounding of the bound, the exp and the product (~1e-6).
 * The kernels skip a half row whose every pixel is below it before any exp(). For
 * opacities in [1/255, 256/255) log(x = 255 opacity) is bounded above inline (no libm call
 * in the tile loops, whose vector registers it would spill): x = 2^e (1 + t), t in [0, 1),
 * log x <= e log 2 + t - t^2/2 + t^3/3 (the series alternates), at most 0.14 too high, a
 * slightly lower floor. Else the log itself (NaN: no power is below it, nothing skipped). */
MGS_VINLINE float mgs_power_floor(float opacity) {
  float x = opacity * 255.0f;
  if (!(x >= 1.0f && x < 256.0f)) return logf(MGS_ALPHA_MIN / opacity) - 0.02f;
  uint32_t b;
  memcpy(&b, &x, sizeof b);
  uint32_t mb = (b & 0x7fffffu) | 0x3f800000u;
  float m;
  memcpy(&m, &mb, sizeof m);
  float t = m - 1.0f, e = (float)((int)(b >> 23) - 127);
  return -(e * 0.693147182f + t * (1.0f + t * (-0.5f + t * (1.0f / 3.0f)))) - 0.02f;
}
/* Every lane of a 16-lane mask row set (two halves: no 64-byte compare on AVX2). */
MGS_VINLINE int mgs_row_all8(const v16i *row) { return !v8i_any(~(v8i_half(row, 0) & v8i_half(row, 8))); }
#endif

/* The half of a tile (first column 0 or 8) holding every column of the tile starting at
 * pixel column x0 that can hold contributions of sp (|pixel centre - u| <= rx), or -1. */
MGS_VINLINE int mgs_col_half(const mgs_splat *sp, int x0) {
#if defined(MGS_HALF_ROWS)
  float a = sp->u - sp->rx - 0.5f - (float)x0, b = sp->u + sp->rx - 0.5f - (float)x0;
  if (b < 8.0f) return 0;
  if (a > 7.0f) return 8;
#else
  (void)sp; (void)x0;
#endif
  return -1;
}
#endif

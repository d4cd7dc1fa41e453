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
  v16i mm = (power <= zero) & (a >= v16f_set1(MGS_ALPHA_MIN)) & ~*done;
  v16f testT = T * (v16f_set1(1.0f) - a);
  v16i nd = mm & (testT < v16f_set1(MGS_T_MIN));
  *done |= nd;
  if (v16i_any(nd)) *rowdone = !v16i_any(~*done);
  *m = mm & ~nd;
  *alpha = a;
  return testT;
}

#if defined(MGS_HALF_ROWS)
MGS_VINLINE v8f mgs_row_power8(const mgs_splat *sp, v8f dx, float dy) {
  float hc = -0.5f * sp->C * dy * dy, bdy = -sp->B * dy;
  return v8f_fma(v8f_fma(v8f_set1(-0.5f * sp->A), dx, v8f_set1(bdy)), dx, v8f_set1(hc));
}
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

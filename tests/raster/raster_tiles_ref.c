/* The reference for test_raster_tiles_ref.c's bit-identity test: the 3DGS tile kernels of
 * render/raster_forward.c (render_tile) and render/raster_backward.c (backward_tile_impl)
 * as they were before the 8-lane rows (commit e4ee57a), verbatim but for the entry points
 * below (ref_render_tiles, ref_backward_tiles: every tile in turn, on one thread). The
 * forward and backward must give the same images, alpha, depth, transmittance, contributor
 * counts, row counts and intersection gradient slots, bit for bit, for the same binned
 * forward (the training runs of an experiment compare across the change). Do not "fix"
 * this copy: it is the definition of the old output. */
#include <math.h>
#include <string.h>
#include "core/mgs_log.h"
#include "core/mgs_parallel.h"
#include "render/raster_kernel.h"

void ref_render_tiles(mgs_raster *r);
void ref_backward_tiles(mgs_raster *r, const float *dL_dcolor, const float *dL_dalpha, const float *dL_ddepth,
                        const float *dL_dnormal);

/* ---- render/raster_forward.c ---- */

/* One tile row against one Gaussian: front-to-back blend with the reference's rules. */
static inline __attribute__((always_inline)) int fwd_row(const mgs_splat *sp, v16f dx, v16f op, v16f cr, v16f cg,
                                                          v16f cb, v16f cz, v16i jid, int y0, int y, v16f *T, v16f *C0,
                                                          v16f *C1, v16f *C2, v16f *D, v16i *NC, v16i *DONE,
                                                          int *rowdone) {
  if (rowdone[y]) return 0; /* every pixel of the row has terminated */
  const v16f amax = v16f_set1(MGS_ALPHA_MAX), amin = v16f_set1(MGS_ALPHA_MIN), tmin = v16f_set1(MGS_T_MIN);
  const v16f one = v16f_set1(1.0f), zero = v16f_set1(0.0f);
  float dy = (float)(y0 + y) + 0.5f - sp->v;
  v16f power = mgs_row_power(sp, dx, dy);
  v16f alpha = v16f_min(amax, op * v16f_exp_neg(power));
  v16i m = (power <= zero) & (alpha >= amin) & ~DONE[y];
  v16f testT = T[y] * (one - alpha);
  v16i nd = m & (testT < tmin);
  DONE[y] |= nd;
  if (v16i_any(nd)) rowdone[y] = !v16i_any(~DONE[y]);
  m &= ~nd;
  v16f w = v16f_and(m, alpha * T[y]);
  C0[y] = v16f_fma(w, cr, C0[y]); C1[y] = v16f_fma(w, cg, C1[y]);
  C2[y] = v16f_fma(w, cb, C2[y]); D[y] = v16f_fma(w, cz, D[y]);
  T[y] = v16f_select(m, testT, T[y]);
  NC[y] = (m & jid) | (~m & NC[y]);
  return 1;
}

#if defined(MGS_HALF_ROWS)
/* fwd_row on half h of the row (the other half gets nothing from this Gaussian). */
static inline __attribute__((always_inline)) int fwd_row8(const mgs_splat *sp, v8f dx, v8f op, v8f cr, v8f cg, v8f cb,
                                                           v8f cz, v8i jid, int y0, int y, int h, v16f *T, v16f *C0,
                                                           v16f *C1, v16f *C2, v16f *D, v16i *NC, v16i *DONE,
                                                           int *rowdone) {
  if (rowdone[y]) return 0;
  const v8f amax = v8f_set1(MGS_ALPHA_MAX), amin = v8f_set1(MGS_ALPHA_MIN), tmin = v8f_set1(MGS_T_MIN);
  const v8f one = v8f_set1(1.0f), zero = v8f_set1(0.0f);
  float dy = (float)(y0 + y) + 0.5f - sp->v;
  v8f power = mgs_row_power8(sp, dx, dy);
  v8f alpha = v8f_min(amax, op * v8f_exp_neg(power));
  v8i done = v8i_half(&DONE[y], h);
  v8i m = (power <= zero) & (alpha >= amin) & ~done;
  v8f Ty = v8f_half(&T[y], h);
  v8f testT = Ty * (one - alpha);
  v8i nd = m & (testT < tmin);
  if (v8i_any(nd)) {
    v8i_put(&DONE[y], h, done | nd);
    rowdone[y] = !v16i_any(~DONE[y]);
  }
  m &= ~nd;
  v8f w = v8f_and(m, alpha * Ty);
  v8f_put(&C0[y], h, v8f_fma(w, cr, v8f_half(&C0[y], h)));
  v8f_put(&C1[y], h, v8f_fma(w, cg, v8f_half(&C1[y], h)));
  v8f_put(&C2[y], h, v8f_fma(w, cb, v8f_half(&C2[y], h)));
  v8f_put(&D[y], h, v8f_fma(w, cz, v8f_half(&D[y], h)));
  v8f_put(&T[y], h, v8f_select(m, testT, Ty));
  v8i_put(&NC[y], h, (m & jid) | (~m & v8i_half(&NC[y], h)));
  return 1;
}
#endif

static void render_tile(mgs_raster *r, size_t tile) {
  const int W = r->width, H = r->height;
  int tx = (int)(tile % (size_t)r->tiles_x), ty = (int)(tile / (size_t)r->tiles_x);
  int x0 = tx * MGS_TILE_SIZE, y0 = ty * MGS_TILE_SIZE;
  int nrows = H - y0 < MGS_TILE_SIZE ? H - y0 : MGS_TILE_SIZE;
  int ncols = W - x0 < MGS_TILE_SIZE ? W - x0 : MGS_TILE_SIZE;
  v16f T[MGS_TILE_SIZE], C0[MGS_TILE_SIZE], C1[MGS_TILE_SIZE], C2[MGS_TILE_SIZE], D[MGS_TILE_SIZE];
  v16i NC[MGS_TILE_SIZE], DONE[MGS_TILE_SIZE];
  for (int y = 0; y < MGS_TILE_SIZE; y++) {
    T[y] = v16f_set1(1.0f);
    C0[y] = C1[y] = C2[y] = D[y] = v16f_set1(0.0f);
    NC[y] = DONE[y] = v16i_set1(0);
  }
  v16f xs;
  v16i outside;
  for (int i = 0; i < 16; i++) { xs[i] = (float)(x0 + i) + 0.5f; outside[i] = i < ncols ? 0 : -1; }
  /* pixels right of the image count as terminated, so partial tiles can stop early */
  int rowdone[MGS_TILE_SIZE];
  for (int y = 0; y < MGS_TILE_SIZE; y++) { DONE[y] = outside; rowdone[y] = 0; }
  uint32_t start = r->tile_start[tile], end = r->tile_start[tile + 1];
  uint32_t evals = 0, j = start;
  for (; j < end; j++) {
    if (j + 8 < end) { /* the splats are gathered: fetch ahead */
      const char *nx = (const char *)&r->splat[r->isect_idx[j + 8]];
      __builtin_prefetch(nx); __builtin_prefetch(nx + sizeof(mgs_splat) - 1);
    }
    const mgs_splat *sp = &r->splat[r->isect_idx[j]];
    int lo, hi;
    mgs_row_range(sp, y0, nrows, &lo, &hi);
    int y = lo;
#if defined(MGS_HALF_ROWS)
    int h = mgs_col_half(sp, x0);
    if (h >= 0) { /* every pixel it can reach is in one half of the tile */
      v8f dx = v8f_half(&xs, h) - v8f_set1(sp->u);
      v8f op = v8f_set1(sp->opacity);
      v8f cr = v8f_set1(sp->rgb[0]), cg = v8f_set1(sp->rgb[1]), cb = v8f_set1(sp->rgb[2]), cz = v8f_set1(sp->z);
      v8i jid = v8i_set1((int32_t)(j - start + 1));
      for (; y < hi; y += 2) {
        evals += (uint32_t)fwd_row8(sp, dx, op, cr, cg, cb, cz, jid, y0, y, h, T, C0, C1, C2, D, NC, DONE, rowdone);
        evals += (uint32_t)fwd_row8(sp, dx, op, cr, cg, cb, cz, jid, y0, y + 1, h, T, C0, C1, C2, D, NC, DONE, rowdone);
      }
      if (y == hi) evals += (uint32_t)fwd_row8(sp, dx, op, cr, cg, cb, cz, jid, y0, y, h, T, C0, C1, C2, D, NC, DONE, rowdone);
    } else
#endif
    {
      v16f dx = xs - v16f_set1(sp->u);
      v16f op = v16f_set1(sp->opacity);
      v16f cr = v16f_set1(sp->rgb[0]), cg = v16f_set1(sp->rgb[1]), cb = v16f_set1(sp->rgb[2]), cz = v16f_set1(sp->z);
      v16i jid = v16i_set1((int32_t)(j - start + 1));
      /* two rows per step: their exp() chains are independent and overlap */
      for (; y < hi; y += 2) {
        evals += (uint32_t)fwd_row(sp, dx, op, cr, cg, cb, cz, jid, y0, y, T, C0, C1, C2, D, NC, DONE, rowdone);
        evals += (uint32_t)fwd_row(sp, dx, op, cr, cg, cb, cz, jid, y0, y + 1, T, C0, C1, C2, D, NC, DONE, rowdone);
      }
      if (y == hi) evals += (uint32_t)fwd_row(sp, dx, op, cr, cg, cb, cz, jid, y0, y, T, C0, C1, C2, D, NC, DONE, rowdone);
    }
    /* every 32 Gaussians: stop when every pixel of the tile has terminated */
    if (((j - start) & 31) == 31) {
      v16i all = DONE[0];
      for (int yy = 1; yy < nrows; yy++) all &= DONE[yy];
      if (!v16i_any(~all)) { j++; break; }
    }
  }
  r->tile_evals[tile] = evals;
  r->tile_visit[2 * tile] = j - start;
  const float *bg = r->s.background;
  for (int y = 0; y < nrows; y++) {
    float t[16], c0[16], c1[16], c2[16], d[16];
    int32_t nc[16];
    v16f_store(t, T[y]); v16f_store(c0, C0[y]); v16f_store(c1, C1[y]); v16f_store(c2, C2[y]);
    v16f_store(d, D[y]); v16i_store(nc, NC[y]);
    size_t p = (size_t)(y0 + y) * W + x0;
    for (int x = 0; x < ncols; x++) {
      float *col = r->out_color + 3 * (p + x);
      col[0] = c0[x] + t[x] * bg[0];
      col[1] = c1[x] + t[x] * bg[1];
      col[2] = c2[x] + t[x] * bg[2];
      r->out_alpha[p + x] = 1.0f - t[x];
      r->out_depth[p + x] = d[x];
      r->final_T[p + x] = t[x];
      r->n_contrib[p + x] = nc[x];
    }
  }
}

static void render_range(void *ctx, size_t b, size_t e) {
  for (size_t t = b; t < e; t++) render_tile(ctx, t);
}


/* ---- render/raster_backward.c ---- */

typedef struct bwd_ctx {
  mgs_raster *r;
  const float *dL_dcolor, *dL_dalpha, *dL_ddepth;
  const float *dL_dnormal; /* 3 per pixel (the normal map's gradient, raster_maps_backward.c) or NULL */
  mgs_gaussians *grad;
  float *grad_mean2d;
} bwd_ctx;

/* Per pixel, with val_i = c_i.dL/dcolor + z_i dL/ddepth (the Gaussian's value seen through
 * the pixel's output gradient) and S_i = sum_{j>i} val_j alpha_j T_j (what lies behind i):
 *   dL/dalpha_i = T_i val_i - (S_i + T_final (bg.dL/dcolor - dL/dalpha_out)) / (1 - alpha_i)
 * the reference's recurrence (accum_rec, last_alpha, last_color) folded into one scalar
 * state S, so a pixel carries only T and S back to front. With a normal-map gradient
 * (nrm), val_i also holds n_i.dL/dN and the slot's GS_NX.. lanes sum w dL/dN (a separate
 * instance of the kernel: the training iteration's is unchanged). */
static inline __attribute__((always_inline)) void backward_tile_impl(const bwd_ctx *bc, size_t tile, const int nrm) {
  mgs_raster *r = bc->r;
  const int W = r->width, H = r->height;
  int tx = (int)(tile % (size_t)r->tiles_x), ty = (int)(tile / (size_t)r->tiles_x);
  int x0 = tx * MGS_TILE_SIZE, y0 = ty * MGS_TILE_SIZE;
  int nrows = H - y0 < MGS_TILE_SIZE ? H - y0 : MGS_TILE_SIZE;
  int ncols = W - x0 < MGS_TILE_SIZE ? W - x0 : MGS_TILE_SIZE;
  uint32_t start = r->tile_start[tile], end = r->tile_start[tile + 1];
  r->tile_visit[2 * tile + 1] = 0;
  if (start == end) { r->tile_evals[tile] = 0; return; }

  v16f T[MGS_TILE_SIZE], S[MGS_TILE_SIZE], K[MGS_TILE_SIZE];
  v16f G0[MGS_TILE_SIZE], G1[MGS_TILE_SIZE], G2[MGS_TILE_SIZE], GD[MGS_TILE_SIZE];
  v16f GN0[MGS_TILE_SIZE], GN1[MGS_TILE_SIZE], GN2[MGS_TILE_SIZE]; /* dL/dN (nrm only) */
  v16i NC[MGS_TILE_SIZE];
  const float *bg = r->s.background;
  int32_t maxn = 0, rowmax[MGS_TILE_SIZE];
  for (int y = 0; y < MGS_TILE_SIZE; y++) {
    float tf[16], g0[16], g1[16], g2[16], gd[16], k[16], gn[3][16];
    int32_t nc[16];
    for (int x = 0; x < 16; x++) {
      tf[x] = 1; g0[x] = g1[x] = g2[x] = gd[x] = k[x] = 0; nc[x] = 0;
      if (nrm) gn[0][x] = gn[1][x] = gn[2][x] = 0;
    }
    if (y < nrows) {
      size_t p = (size_t)(y0 + y) * W + x0;
      for (int x = 0; x < ncols; x++) {
        const float *dc = bc->dL_dcolor + 3 * (p + x);
        tf[x] = r->final_T[p + x];
        nc[x] = r->n_contrib[p + x];
        if (nc[x] > maxn) maxn = nc[x];
        g0[x] = dc[0]; g1[x] = dc[1]; g2[x] = dc[2];
        gd[x] = bc->dL_ddepth ? bc->dL_ddepth[p + x] : 0.0f;
        if (nrm)
          for (int c = 0; c < 3; c++) gn[c][x] = bc->dL_dnormal[3 * (p + x) + c];
        /* colour = ... + T_final bg, alpha_out = 1 - T_final: both through T_final */
        k[x] = tf[x] * (bg[0] * dc[0] + bg[1] * dc[1] + bg[2] * dc[2] - (bc->dL_dalpha ? bc->dL_dalpha[p + x] : 0.0f));
      }
    }
    T[y] = v16f_load(tf);
    S[y] = v16f_set1(0.0f);
    K[y] = v16f_load(k);
    G0[y] = v16f_load(g0); G1[y] = v16f_load(g1); G2[y] = v16f_load(g2); GD[y] = v16f_load(gd);
    if (nrm) { GN0[y] = v16f_load(gn[0]); GN1[y] = v16f_load(gn[1]); GN2[y] = v16f_load(gn[2]); }
    NC[y] = v16i_load(nc);
    rowmax[y] = 0;
    for (int x = 0; x < 16; x++) rowmax[y] = nc[x] > rowmax[y] ? nc[x] : rowmax[y];
  }
  v16f xs;
  for (int i = 0; i < 16; i++) xs[i] = (float)(x0 + i) + 0.5f;
  const v16f amax = v16f_set1(MGS_ALPHA_MAX), amin = v16f_set1(MGS_ALPHA_MIN);
  const v16f one = v16f_set1(1.0f), zero = v16f_set1(0.0f);
  v16f fac = one;
  fac[GS_A] = -0.5f; fac[GS_B2] = -1.0f; fac[GS_C] = -0.5f;
  r->tile_visit[2 * tile + 1] = (uint32_t)maxn;
  /* Gaussians behind every pixel's last contributor get zero slots */
  for (uint32_t j = start + (uint32_t)maxn; j < end; j++) v16f_store(r->isect_grad + (size_t)r->isect_slot[j] * GS_STRIDE, zero);
  uint32_t evals = 0;
  for (uint32_t j = start + (uint32_t)maxn; j-- > start;) {
    if (j >= start + 8) { /* random slot and splat: fetch ahead */
      __builtin_prefetch(r->isect_grad + (size_t)r->isect_slot[j - 8] * GS_STRIDE, 1);
      const char *nx = (const char *)&r->splat[r->isect_idx[j - 8]];
      __builtin_prefetch(nx); __builtin_prefetch(nx + sizeof(mgs_splat) - 1);
    }
    const mgs_splat *sp = &r->splat[r->isect_idx[j]];
    float *out = r->isect_grad + (size_t)r->isect_slot[j] * GS_STRIDE;
    int lo, hi;
    mgs_row_range(sp, y0, nrows, &lo, &hi);
    if (hi < lo) { v16f_store(out, zero); continue; }
    v16f dx = xs - v16f_set1(sp->u);
    v16f op = v16f_set1(sp->opacity);
    v16f A = v16f_set1(sp->A), B = v16f_set1(sp->B), C = v16f_set1(sp->C);
    v16f Adx = A * dx, Bdx = B * dx, dx2 = dx * dx;
    v16f cr = v16f_set1(sp->rgb[0]), cg = v16f_set1(sp->rgb[1]), cb = v16f_set1(sp->rgb[2]), cz = v16f_set1(sp->z);
    v16f nx = zero, ny = zero, nz = zero; /* the Gaussian's normal (nrm only) */
    if (nrm) {
      const float *gnv = r->map_gnormal + 3 * (size_t)r->isect_idx[j];
      nx = v16f_set1(gnv[0]); ny = v16f_set1(gnv[1]); nz = v16f_set1(gnv[2]);
    }
    v16i jid = v16i_set1((int32_t)(j - start));
    v16f ac[GS_NZ + 1];
    for (int c = 0; c < (nrm ? GS_NZ + 1 : GS_N); c++) ac[c] = zero;
    for (int y = lo; y <= hi; y++) {
      if ((int32_t)(j - start) >= rowmax[y]) continue; /* behind every last contributor of the row */
      evals++;
      float dyf = (float)(y0 + y) + 0.5f - sp->v;
      v16f power = mgs_row_power(sp, dx, dyf);
      v16f G = v16f_exp_neg(power);
      v16f raw = op * G;
      v16f alpha = v16f_min(amax, raw);
      v16i m = (power <= zero) & (alpha >= amin) & (jid < NC[y]);
      if (!v16i_any(m)) continue;
      v16f inv = v16f_rcp(one - alpha);
      v16f Tn = v16f_select(m, T[y] * inv, T[y]);
      T[y] = Tn;
      v16f wgt = v16f_and(m, alpha * Tn);
      ac[GS_R] = v16f_fma(wgt, G0[y], ac[GS_R]); ac[GS_G] = v16f_fma(wgt, G1[y], ac[GS_G]);
      ac[GS_B] = v16f_fma(wgt, G2[y], ac[GS_B]); ac[GS_Z] = v16f_fma(wgt, GD[y], ac[GS_Z]);
      v16f val = v16f_fma(cr, G0[y], v16f_fma(cg, G1[y], v16f_fma(cb, G2[y], cz * GD[y])));
      if (nrm) {
        val = v16f_fma(nx, GN0[y], v16f_fma(ny, GN1[y], v16f_fma(nz, GN2[y], val)));
        ac[GS_NX] = v16f_fma(wgt, GN0[y], ac[GS_NX]); ac[GS_NY] = v16f_fma(wgt, GN1[y], ac[GS_NY]);
        ac[GS_NZ] = v16f_fma(wgt, GN2[y], ac[GS_NZ]);
      }
      v16f Sy = S[y];
      v16f dLda = Tn * val - (Sy + K[y]) * inv;
      S[y] = v16f_fma(val, wgt, Sy);
      /* alpha = min(0.99, op*G): no gradient through a clamped alpha */
      dLda = v16f_and(m & (raw < amax), dLda);
      ac[GS_OP] = v16f_fma(G, dLda, ac[GS_OP]);
      v16f gG = op * dLda * G;
      v16f dy = v16f_set1(dyf);
      ac[GS_U] = v16f_fma(gG, v16f_fma(B, dy, Adx), ac[GS_U]);
      ac[GS_V] = v16f_fma(gG, v16f_fma(C, dy, Bdx), ac[GS_V]);
      ac[GS_A] = v16f_fma(gG, dx2, ac[GS_A]);
      ac[GS_B2] = v16f_fma(gG, dx * dy, ac[GS_B2]);
      ac[GS_C] = v16f_fma(gG, dy * dy, ac[GS_C]);
    }
    /* one horizontal sum each (a transposing reduction tree would be cheaper but rounds
       differently, and training is chaotic enough to amplify that into other results) */
    v16f sums = zero;
    for (int c = 0; c < (nrm ? GS_NZ + 1 : GS_N); c++) sums[c] = v16f_sum(ac[c]);
    /* dG/dA = -G dx^2/2, dG/dB = -G dx dy, dG/dC = -G dy^2/2 */
    v16f_store(out, sums * fac); /* lanes from GS_N (GS_NZ + 1 with nrm) on are 0 */
  }
  r->tile_evals[tile] = evals;
}

static void backward_range(void *ctx, size_t b, size_t e) {
  for (size_t t = b; t < e; t++) backward_tile_impl(ctx, t, 0);
}
static void backward_range_normal(void *ctx, size_t b, size_t e) {
  for (size_t t = b; t < e; t++) backward_tile_impl(ctx, t, 1);
}


void ref_render_tiles(mgs_raster *r) {
  size_t nt = (size_t)r->tiles_x * r->tiles_y;
  render_range(r, 0, nt);
  double ev = 0;
  for (size_t t = 0; t < nt; t++) ev += r->tile_evals[t];
  r->evals_fwd = ev * 16.0;
}

void ref_backward_tiles(mgs_raster *r, const float *dL_dcolor, const float *dL_dalpha, const float *dL_ddepth,
                        const float *dL_dnormal) {
  bwd_ctx bc = {r, dL_dcolor, dL_dalpha, dL_ddepth, dL_dnormal, NULL, NULL};
  size_t nt = (size_t)r->tiles_x * r->tiles_y;
  if (dL_dnormal) backward_range_normal(&bc, 0, nt);
  else backward_range(&bc, 0, nt);
}

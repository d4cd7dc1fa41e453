/* The backward: per tile, back to front from each pixel's last contributor (as the
 * reference renderCUDA backward: T recovered by division, the colour behind accumulated),
 * each (Gaussian, tile) intersection's summed gradients written to its own slot (no
 * atomics), then per Gaussian the slots are summed and pushed through the projection. */
#include <math.h>
#include <string.h>
#include "core/mgs_log.h"
#include "core/mgs_parallel.h"
#include "render/raster_kernel.h"

typedef struct bwd_ctx {
  mgs_raster *r;
  const float *dL_dcolor, *dL_dalpha, *dL_ddepth;
  const float *dL_dnormal; /* 3 per pixel (the normal map's gradient, raster_maps_backward.c) or NULL */
  mgs_gaussians *grad;
  float *grad_mean2d;
} bwd_ctx;

/* |x| <= 1e15 (not NaN). With every pixel input and splat value that small, every product
 * the backward forms on a pixel that takes no weight from a Gaussian is finite, so that
 * pixel adds exactly zero to every sum and skipping it changes no bit; otherwise the
 * backward evaluates every half row as before (MGS_ROWS8). */
static inline int bwd_tame(float x) { return fabsf(x) <= 1e15f; }
#if defined(MGS_ROWS8)
static inline int bwd_splat_tame(const mgs_splat *sp, const float *gn) {
  v8f a = v8f_half(&sp->u, 0), b = v8f_half(&sp->u, 4); /* u .. rgb[1], C .. rx */
  v8i big = (v8f_max(a, -a) > v8f_set1(1e15f)) | (v8f_max(b, -b) > v8f_set1(1e15f)) | (a != a) | (b != b);
  if (v8i_any(big)) return 0;
  return !gn || (bwd_tame(gn[0]) && bwd_tame(gn[1]) && bwd_tame(gn[2]));
}

/* One Gaussian (tile-list position jj) over rows [lo, hi] of its tile, as the 16-lane loop
 * of backward_tile_impl does it, in 8-lane halves. A half is skipped where each pixel is
 * below the power floor (mgs_power_floor) or behind its last contributor with a power < 64
 * (exp() finite there): those pixels take no weight, and with tame inputs add exact zeros
 * in the 16-lane loop (without them every half is evaluated). A row is skipped when no
 * pixel takes weight (as before). Each lane sums its rows in the same order, and the
 * horizontal sums add lanes 0..15 in order as v16f_sum does (a half never evaluated holds
 * +0s, which leave the sum unchanged: no sum here is ever -0). gn: the Gaussian's normal
 * (nrm) or NULL. Writes the slot; returns the rows evaluated. */
static inline __attribute__((always_inline)) uint32_t bwd_splat8(
    const mgs_splat *sp, const float *gn, int32_t jj, const v16f *xs, int y0, int lo, int hi, int tame,
    const int32_t *rowmax, v16f *T, v16f *S, const v16f *K, const v16f *G0, const v16f *G1, const v16f *G2,
    const v16f *GD, const v16f *GN0, const v16f *GN1, const v16f *GN2, const v16i *NC, float *out) {
  enum { NCH = GS_NZ + 1 };
  const int nch = gn ? GS_NZ + 1 : GS_N;
  const v8f amax = v8f_set1(MGS_ALPHA_MAX), amin = v8f_set1(MGS_ALPHA_MIN);
  const v8f one = v8f_set1(1.0f), zero = v8f_set1(0.0f);
  const int skip = tame && bwd_splat_tame(sp, gn);
  /* -inf: nothing compares below, every half is evaluated */
  const v8f floor = v8f_set1(skip ? mgs_power_floor(sp->opacity) : -INFINITY);
  const v8f pmax = v8f_set1(skip ? 64.0f : -INFINITY);
  v8f dx[2], Adx[2], Bdx[2], dx2[2];
  v8f op = v8f_set1(sp->opacity);
  v8f A = v8f_set1(sp->A), B = v8f_set1(sp->B), C = v8f_set1(sp->C);
  for (int h = 0; h < 2; h++) {
    dx[h] = v8f_half(xs, 8 * h) - v8f_set1(sp->u);
    Adx[h] = A * dx[h]; Bdx[h] = B * dx[h]; dx2[h] = dx[h] * dx[h];
  }
  v8f cr = v8f_set1(sp->rgb[0]), cg = v8f_set1(sp->rgb[1]), cb = v8f_set1(sp->rgb[2]), cz = v8f_set1(sp->z);
  v8f nx = zero, ny = zero, nz = zero;
  if (gn) { nx = v8f_set1(gn[0]); ny = v8f_set1(gn[1]); nz = v8f_set1(gn[2]); }
  v8i jid = v8i_set1(jj);
  v8f ac[2][NCH];
  for (int h = 0; h < 2; h++)
    for (int c = 0; c < NCH; c++) ac[h][c] = zero;
  int used[2] = {0, 0};
  uint32_t evals = 0;
  for (int y = lo; y <= hi; y++) {
    if (jj >= rowmax[y]) continue; /* behind every last contributor of the row */
    evals++;
    float dyf = (float)(y0 + y) + 0.5f - sp->v;
    v8f G[2] = {zero, zero}, raw[2] = {zero, zero}, alpha[2] = {zero, zero};
    v8i m[2] = {v8i_set1(0), v8i_set1(0)};
    int go[2], anym = 0;
    for (int h = 0; h < 2; h++) {
      v8f power = mgs_row_power8(sp, dx[h], dyf);
      v8i live = jid < v8i_half(&NC[y], 8 * h);
      go[h] = v8i_any(~((power < floor) | (~live & (power < pmax))));
      if (!go[h]) continue;
      G[h] = v8f_exp_neg(power);
      raw[h] = op * G[h];
      alpha[h] = v8f_min(amax, raw[h]);
      m[h] = (power <= zero) & (alpha[h] >= amin) & live;
      anym |= v8i_any(m[h]);
    }
    if (!anym) continue;
    v8f dy = v8f_set1(dyf);
    for (int h = 0; h < 2; h++) {
      if (!go[h]) continue;
      const int o = 8 * h;
      used[h] = 1;
      v8f *a = ac[h];
      v8f inv = v8f_rcp(one - alpha[h]);
      v8f Ty = v8f_half(&T[y], o);
      v8f Tn = v8f_select(m[h], Ty * inv, Ty);
      v8f_put(&T[y], o, Tn);
      v8f wgt = v8f_and(m[h], alpha[h] * Tn);
      v8f g0 = v8f_half(&G0[y], o), g1 = v8f_half(&G1[y], o), g2 = v8f_half(&G2[y], o), gd = v8f_half(&GD[y], o);
      a[GS_R] = v8f_fma(wgt, g0, a[GS_R]); a[GS_G] = v8f_fma(wgt, g1, a[GS_G]);
      a[GS_B] = v8f_fma(wgt, g2, a[GS_B]); a[GS_Z] = v8f_fma(wgt, gd, a[GS_Z]);
      v8f val = v8f_fma(cr, g0, v8f_fma(cg, g1, v8f_fma(cb, g2, cz * gd)));
      if (gn) {
        v8f n0 = v8f_half(&GN0[y], o), n1 = v8f_half(&GN1[y], o), n2 = v8f_half(&GN2[y], o);
        val = v8f_fma(nx, n0, v8f_fma(ny, n1, v8f_fma(nz, n2, val)));
        a[GS_NX] = v8f_fma(wgt, n0, a[GS_NX]); a[GS_NY] = v8f_fma(wgt, n1, a[GS_NY]);
        a[GS_NZ] = v8f_fma(wgt, n2, a[GS_NZ]);
      }
      v8f Sy = v8f_half(&S[y], o);
      v8f dLda = Tn * val - (Sy + v8f_half(&K[y], o)) * inv;
      v8f_put(&S[y], o, v8f_fma(val, wgt, Sy));
      dLda = v8f_and(m[h] & (raw[h] < amax), dLda);
      a[GS_OP] = v8f_fma(G[h], dLda, a[GS_OP]);
      v8f gG = op * dLda * G[h];
      a[GS_U] = v8f_fma(gG, v8f_fma(B, dy, Adx[h]), a[GS_U]);
      a[GS_V] = v8f_fma(gG, v8f_fma(C, dy, Bdx[h]), a[GS_V]);
      a[GS_A] = v8f_fma(gG, dx2[h], a[GS_A]);
      a[GS_B2] = v8f_fma(gG, dx[h] * dy, a[GS_B2]);
      a[GS_C] = v8f_fma(gG, dy * dy, a[GS_C]);
    }
  }
  /* v16f_sum's order: lane 0 to 15 */
  float sums[16] = {0};
  for (int c = 0; c < nch; c++) {
    float s = 0.0f;
    for (int h = 0; h < 2; h++) {
      if (!used[h]) continue;
      float t[8];
      memcpy(t, &ac[h][c], sizeof t);
      for (int i = 0; i < 8; i++) s += t[i];
    }
    sums[c] = s;
  }
  /* dG/dA = -G dx^2/2, dG/dB = -G dx dy, dG/dC = -G dy^2/2 */
  v8f fac = one;
  fac[GS_A] = -0.5f;
  v8f fac1 = one;
  fac1[GS_B2 - 8] = -1.0f; fac1[GS_C - 8] = -0.5f;
  v8f_put(out, 0, v8f_half(sums, 0) * fac);
  v8f_put(out, 8, v8f_half(sums, 8) * fac1);
  return evals;
}
#endif

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
  int tame = 1; /* every pixel's output gradient of modest size (bwd_tame) */
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
        tame &= bwd_tame(g0[x]) & bwd_tame(g1[x]) & bwd_tame(g2[x]) & bwd_tame(gd[x]);
        if (nrm) tame &= bwd_tame(gn[0][x]) & bwd_tame(gn[1][x]) & bwd_tame(gn[2][x]);
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
  (void)tame;
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
#if defined(MGS_ROWS8)
    evals += bwd_splat8(sp, nrm ? r->map_gnormal + 3 * (size_t)r->isect_idx[j] : NULL, (int32_t)(j - start), &xs,
                        y0, lo, hi, tame, rowmax, T, S, K, G0, G1, G2, GD, GN0, GN1, GN2, NC, out);
    continue;
#endif
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

void mgs_raster_backward_tiles(mgs_raster *r, const float *dL_dcolor, const float *dL_dalpha,
                               const float *dL_ddepth) {
  bwd_ctx bc = {r, dL_dcolor, dL_dalpha, dL_ddepth, r->map_grad_live ? r->map_gnormal_grad : NULL, NULL, NULL};
  size_t nt = (size_t)r->tiles_x * r->tiles_y;
  mgs_parallel_for(0, nt, 1, bc.dL_dnormal ? backward_range_normal : backward_range, &bc);
  double ev = 0;
  for (size_t t = 0; t < nt; t++) ev += r->tile_evals[t];
  r->evals_bwd = ev * 16.0;
}

/* Per binned Gaussian of [b, e), in index order (sequential over the model arrays): sum its
 * intersection slots, then the projection backward into grad (row 0 = Gaussian gbase).
 * Each Gaussian is touched by one call only, so no atomics. */
static void reduce_span(const bwd_ctx *bc, size_t b, size_t e, mgs_gaussians *grad, size_t gbase) {
  mgs_raster *r = bc->r;
  if (r->surfel) { mgs_raster2d_reduce_span(r, b, e, grad, gbase, bc->grad_mean2d); return; }
  uint32_t idx[16];
  float gsum[GS_N][16];
  int nl = 0;
  const int ngrad = r->map_grad_live; /* the slots hold the normal's lanes too */
  for (size_t i = b; i < e; i++) {
    uint32_t cnt = r->count[i];
    if (!cnt) continue;
    /* the SH backward addresses lanes relative to the first: keep the spread small */
    if (nl && i - idx[0] >= (1u << 24)) {
      mgs_raster_project_backward16(r, idx, nl, gsum, grad, gbase, bc->grad_mean2d);
      nl = 0;
    }
    float gs[16];
    const float *q = r->isect_grad + (size_t)r->gauss_off[i] * GS_STRIDE;
    /* hidden behind every pixel's last contributor or too faint everywhere: the chain
     * would only push zeros (its gradients stay 0, as its 2D-mean gradient norm) */
    if (!mgs_sum_rows16(q, cnt, GS_STRIDE, gs)) continue;
    if (ngrad) mgs_raster_normal_rot_grad(r, i, gs + GS_NX, grad->rot + 4 * (i - gbase));
    idx[nl] = (uint32_t)i;
    for (int c = 0; c < GS_N; c++) gsum[c][nl] = gs[c];
    if (++nl == 16) {
      mgs_raster_project_backward16(r, idx, nl, gsum, grad, gbase, bc->grad_mean2d);
      nl = 0;
    }
  }
  if (nl) mgs_raster_project_backward16(r, idx, nl, gsum, grad, gbase, bc->grad_mean2d);
}

static void reduce_range(void *ctx, size_t b, size_t e) {
  const bwd_ctx *bc = ctx;
  reduce_span(bc, b, e, bc->grad, 0);
}

/* Gaussians per block handed to a sink: the block's gradients (59 floats a Gaussian,
 * 15 KB) stay in L1 between the backward writing and the sink reading them. */
#define SINK_BLOCK 64
enum { SINK_FLOATS = 3 + 3 + 4 + 1 + 3 + MGS_SH_REST_MAX };

typedef struct sink_run {
  bwd_ctx bc;
  mgs_raster_grad_sink sink;
  void *sink_ctx;
  int visible_only;  /* skip blocks without a Gaussian of radius > 0 */
} sink_run;

static void sink_range(void *ctx, size_t bb, size_t be) {
  const sink_run *sc = ctx;
  const mgs_raster *r = sc->bc.r;
  _Alignas(64) float buf[SINK_BLOCK * SINK_FLOATS];
  mgs_gaussians blk;
  memset(&blk, 0, sizeof blk);
  blk.capacity = SINK_BLOCK;
  blk.sh_degree = r->g->sh_degree;
  blk.mean = buf;
  blk.log_scale = blk.mean + 3 * SINK_BLOCK;
  blk.rot = blk.log_scale + 3 * SINK_BLOCK;
  blk.opacity = blk.rot + 4 * SINK_BLOCK;
  blk.sh_dc = blk.opacity + SINK_BLOCK;
  blk.sh_rest = blk.sh_dc + 3 * SINK_BLOCK;
  for (size_t k = bb; k < be; k++) {
    size_t b = k * SINK_BLOCK, e = b + SINK_BLOCK < r->n ? b + SINK_BLOCK : r->n;
    if (sc->visible_only) {
      size_t i = b;
      while (i < e && r->radii[i] <= 0) i++;
      if (i == e) continue;
    }
    blk.n = e - b;
    memset(buf, 0, sizeof buf);
    reduce_span(&sc->bc, b, e, &blk, b);
    sc->sink(sc->sink_ctx, b, e - b, &blk);
  }
}

static mgs_status backward_check(const mgs_raster *r, const float *dL_dcolor, mgs_error *err) {
  if (!r || !dL_dcolor)
    return mgs_error_set(err, MGS_ERR_ARG, "render/raster_backward.c: NULL argument");
  if (!r->have_forward)
    return mgs_error_set(err, MGS_ERR_ARG, "render/raster_backward.c: backward called without a successful forward");
  return MGS_OK;
}

/* The per-tile part, then the per-Gaussian part (fn over work items [0, units)), both
 * timed. */
static mgs_status backward_run(mgs_raster *r, const float *dL_dcolor, const float *dL_dalpha, const float *dL_ddepth,
                               float *grad_mean2d, size_t units, size_t grain, mgs_range_fn fn, void *ctx,
                               mgs_error *err) {
  if (grad_mean2d) memset(grad_mean2d, 0, r->n * sizeof(float));
  r->bwd_alpha = dL_dalpha != NULL;
  r->bwd_depth = dL_ddepth != NULL;
  r->bwd_mean2d = grad_mean2d != NULL;
  double c0 = mgs_raster_cpu_now(), t0 = mgs_now();
  if (!r->surfel) mgs_raster_backward_tiles(r, dL_dcolor, dL_dalpha, dL_ddepth);
  else {
    mgs_status st = mgs_raster2d_backward_tiles(r, dL_dcolor, dL_dalpha, dL_ddepth, err);
    if (st != MGS_OK) return st;
  }
  double t1 = mgs_now(), c1 = mgs_raster_cpu_now();
  mgs_parallel_for(0, units, grain, fn, ctx);
  r->prof.tiles_ms = (t1 - t0) * 1e3;
  r->prof.reduce_ms = (mgs_now() - t1) * 1e3;
  r->prof.tiles_cpu = (c1 - c0) * 1e3;
  r->prof.reduce_cpu = (mgs_raster_cpu_now() - c1) * 1e3;
  return MGS_OK;
}

mgs_status mgs_raster_backward(mgs_raster *r, const float *dL_dcolor, const float *dL_dalpha,
                               const float *dL_ddepth, mgs_gaussians *grad, float *grad_mean2d,
                               mgs_error *err) {
  mgs_status st = backward_check(r, dL_dcolor, err);
  if (st != MGS_OK) return st;
  if (!grad) return mgs_error_set(err, MGS_ERR_ARG, "render/raster_backward.c: NULL argument");
  if (grad->n != r->n || grad->sh_degree < r->s.sh_degree)
    return mgs_error_set(err, MGS_ERR_ARG, "render/raster_backward.c: gradient model has %zu Gaussians (SH %d), "
                         "the forward had %zu (SH %d)", grad->n, grad->sh_degree, r->n, r->s.sh_degree);
  bwd_ctx bc = {r, dL_dcolor, dL_dalpha, dL_ddepth, NULL, grad, grad_mean2d};
  r->bwd_kind = 1;
  r->bwd_visible_only = 0;
  return backward_run(r, dL_dcolor, dL_dalpha, dL_ddepth, grad_mean2d, r->n, 1024, reduce_range, &bc, err);
}

static mgs_status backward_sink(mgs_raster *r, mgs_gaussians *model, const float *dL_dcolor,
                                const float *dL_dalpha, const float *dL_ddepth, float *grad_mean2d,
                                mgs_raster_grad_sink sink, void *sink_ctx, int visible_only, mgs_error *err);

mgs_status mgs_raster_backward_sink(mgs_raster *r, mgs_gaussians *model, const float *dL_dcolor,
                                    const float *dL_dalpha, const float *dL_ddepth, float *grad_mean2d,
                                    mgs_raster_grad_sink sink, void *sink_ctx, mgs_error *err) {
  return backward_sink(r, model, dL_dcolor, dL_dalpha, dL_ddepth, grad_mean2d, sink, sink_ctx, 0, err);
}

mgs_status mgs_raster_backward_sink_visible(mgs_raster *r, mgs_gaussians *model, const float *dL_dcolor,
                                            const float *dL_dalpha, const float *dL_ddepth, float *grad_mean2d,
                                            mgs_raster_grad_sink sink, void *sink_ctx, mgs_error *err) {
  return backward_sink(r, model, dL_dcolor, dL_dalpha, dL_ddepth, grad_mean2d, sink, sink_ctx, 1, err);
}

static mgs_status backward_sink(mgs_raster *r, mgs_gaussians *model, const float *dL_dcolor,
                                const float *dL_dalpha, const float *dL_ddepth, float *grad_mean2d,
                                mgs_raster_grad_sink sink, void *sink_ctx, int visible_only, mgs_error *err) {
  mgs_status st = backward_check(r, dL_dcolor, err);
  if (st != MGS_OK) return st;
  if (!sink || !model) return mgs_error_set(err, MGS_ERR_ARG, "render/raster_backward.c: NULL argument");
  if (model != r->g || model->n != r->n)
    return mgs_error_set(err, MGS_ERR_ARG, "render/raster_backward.c: the model is not the forward's (%zu Gaussians, "
                         "the forward had %zu)", model->n, r->n);
  sink_run sc = {{r, dL_dcolor, dL_dalpha, dL_ddepth, NULL, NULL, grad_mean2d}, sink, sink_ctx, visible_only};
  r->bwd_kind = 2;
  r->bwd_visible_only = visible_only;
  st = backward_run(r, dL_dcolor, dL_dalpha, dL_ddepth, grad_mean2d, (r->n + SINK_BLOCK - 1) / SINK_BLOCK, 16, sink_range,
                    &sc, err);
  r->have_forward = 0; /* the sink may have changed the model: another backward needs a new forward */
  return st;
}

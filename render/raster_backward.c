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
  mgs_gaussians *grad;
  float *grad_mean2d;
} bwd_ctx;

/* Per pixel, with val_i = c_i.dL/dcolor + z_i dL/ddepth (the Gaussian's value seen through
 * the pixel's output gradient) and S_i = sum_{j>i} val_j alpha_j T_j (what lies behind i):
 *   dL/dalpha_i = T_i val_i - (S_i + T_final (bg.dL/dcolor - dL/dalpha_out)) / (1 - alpha_i)
 * the reference's recurrence (accum_rec, last_alpha, last_color) folded into one scalar
 * state S, so a pixel carries only T and S back to front. */
static void backward_tile(const bwd_ctx *bc, size_t tile) {
  mgs_raster *r = bc->r;
  const int W = r->width, H = r->height;
  int tx = (int)(tile % (size_t)r->tiles_x), ty = (int)(tile / (size_t)r->tiles_x);
  int x0 = tx * MGS_TILE_SIZE, y0 = ty * MGS_TILE_SIZE;
  int nrows = H - y0 < MGS_TILE_SIZE ? H - y0 : MGS_TILE_SIZE;
  int ncols = W - x0 < MGS_TILE_SIZE ? W - x0 : MGS_TILE_SIZE;
  uint32_t start = r->tile_start[tile], end = r->tile_start[tile + 1];
  if (start == end) { r->tile_evals[tile] = 0; return; }

  v16f T[MGS_TILE_SIZE], S[MGS_TILE_SIZE], K[MGS_TILE_SIZE];
  v16f G0[MGS_TILE_SIZE], G1[MGS_TILE_SIZE], G2[MGS_TILE_SIZE], GD[MGS_TILE_SIZE];
  v16i NC[MGS_TILE_SIZE];
  const float *bg = r->s.background;
  int32_t maxn = 0, rowmax[MGS_TILE_SIZE];
  for (int y = 0; y < MGS_TILE_SIZE; y++) {
    float tf[16], g0[16], g1[16], g2[16], gd[16], k[16];
    int32_t nc[16];
    for (int x = 0; x < 16; x++) {
      tf[x] = 1; g0[x] = g1[x] = g2[x] = gd[x] = k[x] = 0; nc[x] = 0;
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
        /* colour = ... + T_final bg, alpha_out = 1 - T_final: both through T_final */
        k[x] = tf[x] * (bg[0] * dc[0] + bg[1] * dc[1] + bg[2] * dc[2] - (bc->dL_dalpha ? bc->dL_dalpha[p + x] : 0.0f));
      }
    }
    T[y] = v16f_load(tf);
    S[y] = v16f_set1(0.0f);
    K[y] = v16f_load(k);
    G0[y] = v16f_load(g0); G1[y] = v16f_load(g1); G2[y] = v16f_load(g2); GD[y] = v16f_load(gd);
    NC[y] = v16i_load(nc);
    rowmax[y] = 0;
    for (int x = 0; x < 16; x++) rowmax[y] = nc[x] > rowmax[y] ? nc[x] : rowmax[y];
  }
  v16f xs;
  for (int i = 0; i < 16; i++) xs[i] = (float)(x0 + i) + 0.5f;
  const v16f amax = v16f_set1(MGS_ALPHA_MAX), amin = v16f_set1(MGS_ALPHA_MIN);
  const v16f one = v16f_set1(1.0f), zero = v16f_set1(0.0f);
  /* Gaussians behind every pixel's last contributor get zero slots */
  for (uint32_t j = start + (uint32_t)maxn; j < end; j++) memset(r->isect_grad + (size_t)r->isect_slot[j] * GS_N, 0, GS_N * sizeof(float));
  uint32_t evals = 0;
  for (uint32_t j = start + (uint32_t)maxn; j-- > start;) {
    if (j >= start + 8) __builtin_prefetch(r->isect_grad + (size_t)r->isect_slot[j - 8] * GS_N, 1); /* random slot */
    const mgs_splat *sp = &r->isect_splat[j];
    float *out = r->isect_grad + (size_t)r->isect_slot[j] * GS_N;
    int lo, hi;
    mgs_row_range(sp, y0, nrows, &lo, &hi);
    if (hi < lo) { memset(out, 0, GS_N * sizeof(float)); continue; }
    v16f dx = xs - v16f_set1(sp->u);
    v16f op = v16f_set1(sp->opacity);
    v16f A = v16f_set1(sp->A), B = v16f_set1(sp->B), C = v16f_set1(sp->C);
    v16f Adx = A * dx, Bdx = B * dx, dx2 = dx * dx;
    v16f cr = v16f_set1(sp->rgb[0]), cg = v16f_set1(sp->rgb[1]), cb = v16f_set1(sp->rgb[2]), cz = v16f_set1(sp->z);
    v16i jid = v16i_set1((int32_t)(j - start));
    v16f ac[GS_N];
    for (int c = 0; c < GS_N; c++) ac[c] = zero;
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
    for (int c = 0; c < GS_N; c++) out[c] = v16f_sum(ac[c]);
    /* dG/dA = -G dx^2/2, dG/dB = -G dx dy, dG/dC = -G dy^2/2 */
    out[GS_A] *= -0.5f; out[GS_B2] = -out[GS_B2]; out[GS_C] *= -0.5f;
  }
  r->tile_evals[tile] = evals;
}

static void backward_range(void *ctx, size_t b, size_t e) {
  for (size_t t = b; t < e; t++) backward_tile(ctx, t);
}

void mgs_raster_backward_tiles(mgs_raster *r, const float *dL_dcolor, const float *dL_dalpha,
                               const float *dL_ddepth) {
  bwd_ctx bc = {r, dL_dcolor, dL_dalpha, dL_ddepth, NULL, NULL};
  size_t nt = (size_t)r->tiles_x * r->tiles_y;
  mgs_parallel_for(0, nt, 1, backward_range, &bc);
  double ev = 0;
  for (size_t t = 0; t < nt; t++) ev += r->tile_evals[t];
  r->evals_bwd = ev * 16.0;
}

/* Per binned Gaussian, in index order (sequential over the model arrays): sum its
 * intersection slots, then the projection backward. Each Gaussian is touched by one call
 * only, so no atomics. */
static void reduce_range(void *ctx, size_t b, size_t e) {
  const bwd_ctx *bc = ctx;
  mgs_raster *r = bc->r;
  uint32_t idx[16];
  float gsum[GS_N][16];
  int nl = 0;
  for (size_t i = b; i < e; i++) {
    uint32_t cnt = r->count[i];
    if (!cnt) continue;
    /* the SH backward addresses lanes relative to the first: keep the spread small */
    if (nl && i - idx[0] >= (1u << 24)) {
      mgs_raster_project_backward16(r, idx, nl, gsum, bc->grad, bc->grad_mean2d);
      nl = 0;
    }
    float gs[GS_N] = {0};
    const float *q = r->isect_grad + (size_t)r->gauss_off[i] * GS_N;
    for (uint32_t s = 0; s < cnt; s++, q += GS_N)
      for (int c = 0; c < GS_N; c++) gs[c] += q[c];
    idx[nl] = (uint32_t)i;
    for (int c = 0; c < GS_N; c++) gsum[c][nl] = gs[c];
    if (++nl == 16) {
      mgs_raster_project_backward16(r, idx, nl, gsum, bc->grad, bc->grad_mean2d);
      nl = 0;
    }
  }
  if (nl) mgs_raster_project_backward16(r, idx, nl, gsum, bc->grad, bc->grad_mean2d);
}

mgs_status mgs_raster_backward(mgs_raster *r, const float *dL_dcolor, const float *dL_dalpha,
                               const float *dL_ddepth, mgs_gaussians *grad, float *grad_mean2d,
                               mgs_error *err) {
  if (!r || !dL_dcolor || !grad)
    return mgs_error_set(err, MGS_ERR_ARG, "render/raster_backward.c: NULL argument");
  if (!r->have_forward)
    return mgs_error_set(err, MGS_ERR_ARG, "render/raster_backward.c: backward called without a successful forward");
  if (grad->n != r->n || grad->sh_degree < r->s.sh_degree)
    return mgs_error_set(err, MGS_ERR_ARG, "render/raster_backward.c: gradient model has %zu Gaussians (SH %d), "
                         "the forward had %zu (SH %d)", grad->n, grad->sh_degree, r->n, r->s.sh_degree);
  if (grad_mean2d) memset(grad_mean2d, 0, r->n * sizeof(float));
  double c0 = mgs_raster_cpu_now(), t0 = mgs_now();
  mgs_raster_backward_tiles(r, dL_dcolor, dL_dalpha, dL_ddepth);
  double t1 = mgs_now(), c1 = mgs_raster_cpu_now();
  bwd_ctx bc = {r, dL_dcolor, dL_dalpha, dL_ddepth, grad, grad_mean2d};
  mgs_parallel_for(0, r->n, 1024, reduce_range, &bc);
  r->prof.tiles_ms = (t1 - t0) * 1e3;
  r->prof.reduce_ms = (mgs_now() - t1) * 1e3;
  r->prof.tiles_cpu = (c1 - c0) * 1e3;
  r->prof.reduce_cpu = (mgs_raster_cpu_now() - c1) * 1e3;
  return MGS_OK;
}

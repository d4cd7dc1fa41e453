/* The 2DGS tile kernels: per tile, front-to-back compositing of the ray-splat
 * intersections (colour, alpha, sum w z; the normal, median depth and distortion in a
 * second pass of the same compositing, run only when maps or their gradients are asked for),
 * and the backward, back to front from each pixel's last contributor, each intersection's
 * summed gradients written to its own slot (no atomics). A tile row of 16 pixels is one
 * vector: along a row, k = x Tw - Tu varies and l = y Tw - Tv is constant. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "core/mgs_log.h"
#include "core/mgs_parallel.h"
#include "render/raster_kernel.h"
#include "render/raster_2dgs.h"

/* The per-pixel evaluation both kernels share bit for bit (raster_2dgs.h): along a tile
 * row p = c0 (x - ox) + row constants, so the column parts (isect_cols) are made once per
 * surfel and tile and a row costs three adds before the reciprocal. */
typedef struct isect_cols {
  v16f xp;         /* pixel centre x - ox */
  v16f qx, qy, qz; /* c0 xp */
  v16f rx2;        /* rho2's x part */
} isect_cols;

MGS_VINLINE void isect_cols_init(const mgs_surf2d *sf, v16f X, isect_cols *c) {
  c->xp = X - sf->ox;
  c->qx = c->xp * sf->c0[0];
  c->qy = c->xp * sf->c0[1];
  c->qz = c->xp * sf->c0[2];
  c->rx2 = MGS_2DGS_FILTER_INV2 * (c->xp * c->xp);
}

typedef struct isect_row {
  v16f ipz, sx, sy, rho3, rho2, z, G, raw, alpha;
  v16i use3;  /* rho3 <= rho2: the ray-splat distance wins (else the filter, depth zc) */
  float yp;   /* pixel centre y - oy */
  v16i m;     /* valid: p.z != 0, z >= near, alpha >= 1/255 */
} isect_row;

MGS_VINLINE void isect_eval(const mgs_surf2d *sf, const isect_cols *c, float Y, isect_row *o) {
  const v16f one = v16f_set1(1.0f);
  float yp = Y - sf->oy;
  o->yp = yp;
  v16f px = c->qx + (sf->c1[0] * yp + sf->c2[0]);
  v16f py = c->qy + (sf->c1[1] * yp + sf->c2[1]);
  v16f pz = c->qz + (sf->c1[2] * yp + sf->c2[2]);
  v16i pok = v16f_ne(pz, v16f_set1(0.0f));
  o->ipz = v16f_rcp(v16f_select(pok, pz, one));
  o->sx = px * o->ipz;
  o->sy = py * o->ipz;
  o->rho3 = v16f_fma(o->sx, o->sx, o->sy * o->sy);
  o->rho2 = c->rx2 + MGS_2DGS_FILTER_INV2 * (yp * yp);
  v16f rho = v16f_min(o->rho3, o->rho2);
  o->use3 = v16f_le(o->rho3, o->rho2);
  /* where the screen-space filter wins the depth is the centre's (as the authors': an
     edge-on surfel's ray-plane intersection lies arbitrarily far away) */
  o->z = v16f_select(o->use3, sf->det * o->ipz, v16f_set1(sf->zc));
  o->G = v16f_exp_neg(v16f_set1(-0.5f) * rho);
  o->raw = v16f_set1(sf->opacity) * o->G;
  o->alpha = v16f_min(v16f_set1(MGS_ALPHA_MAX), o->raw);
  o->m = pok & v16f_ge(o->z, v16f_set1(MGS_2DGS_NEAR)) & v16f_ge(o->alpha, v16f_set1(MGS_ALPHA_MIN));
}

MGS_VINLINE v16f zero_minus(v16f a) { return v16f_set1(0.0f) - a; }
MGS_VINLINE v16f v16f_abs(v16f a) { return (v16f)((v16i)a & v16i_set1(0x7fffffff)); }

/* out[i] = sum of y[i]'s lanes, for 16 vectors at once (a transposing tree: 30 shuffles
 * and 15 adds instead of 16 horizontal sums). */
MGS_VINLINE v16f v16f_sum16(const v16f *y) {
#if defined(__AVX512F__)
  __m512 x[16], s[8], r[4], w[2];
  /* the tree leaves source c + 4 j in lane 4 c + j */
  for (int S = 0; S < 16; S++) x[S] = (__m512)y[4 * (S % 4) + S / 4];
  for (int k = 0; k < 8; k++)
    s[k] = _mm512_add_ps(_mm512_shuffle_f32x4(x[2 * k], x[2 * k + 1], 0x44), _mm512_shuffle_f32x4(x[2 * k], x[2 * k + 1], 0xEE));
  for (int m = 0; m < 4; m++)
    r[m] = _mm512_add_ps(_mm512_shuffle_f32x4(s[2 * m], s[2 * m + 1], 0x88), _mm512_shuffle_f32x4(s[2 * m], s[2 * m + 1], 0xDD));
  for (int m = 0; m < 2; m++)
    w[m] = _mm512_add_ps(_mm512_shuffle_ps(r[2 * m], r[2 * m + 1], 0x44), _mm512_shuffle_ps(r[2 * m], r[2 * m + 1], 0xEE));
  return (v16f)_mm512_add_ps(_mm512_shuffle_ps(w[0], w[1], 0x88), _mm512_shuffle_ps(w[0], w[1], 0xDD));
#else
  v16f o;
  for (int i = 0; i < 16; i++) o[i] = v16f_sum(y[i]);
  return o;
#endif
}

/* Bit y set: row y of the tile at (x0, y0) (nrows x ncols) has pixel centres where the
 * surfel can reach alpha >= 1/255 (the region of raster_2dgs.h), one lane per row. */
MGS_VINLINE uint32_t row_bits(const mgs_surf2d *sf, int x0, int y0, int nrows, int ncols) {
  const v16f lanes = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15};
  const v16f inf = v16f_set1(INFINITY), rf = v16f_set1(sf->rf);
  v16f yl = lanes + ((float)y0 + 0.5f - sf->oy);
  v16f d = yl - sf->yc;
  v16f hw2 = sf->h0 - sf->kq * (d * d);
  v16i cv = v16f_ge(hw2, v16f_set1(0.0f));
  v16f hw = v16f_sqrt(v16f_and(cv, hw2));
  v16f xm = sf->xc + sf->sl * d;
  v16f lo = v16f_select(cv, xm - hw, inf), hi = v16f_select(cv, xm + hw, zero_minus(inf));
  v16i dv = v16f_le(yl, rf) & v16f_ge(yl, zero_minus(rf));
  lo = v16f_select(dv, v16f_min(lo, zero_minus(rf)), lo);
  hi = v16f_select(dv, v16f_max(hi, rf), hi);
  float xmin = (float)x0 + 0.5f - sf->ox - 0.05f, xmax = (float)(x0 + ncols) - 0.5f - sf->ox + 0.05f;
  v16i hit = v16f_le(lo - v16f_set1(1e-3f) * v16f_abs(lo), v16f_set1(xmax)) &
             v16f_ge(hi + v16f_set1(1e-3f) * v16f_abs(hi), v16f_set1(xmin));
  return v16i_bits(hit) & ((1u << nrows) - 1u);
}

MGS_VINLINE v16f depth_map(v16f z) {
  const float F = MGS_2DGS_FAR, N = MGS_2DGS_NEAR;
  return v16f_set1(F / (F - N)) * (v16f_set1(1.0f) - v16f_set1(N) / z);
}

/* geo: also the normal, median depth and distortion (the maps pass); without, what the
 * 3DGS forward composites (colour, alpha, sum w z), so that a training forward that needs
 * no geometry costs no more. Both take the same alpha decisions. */
static inline __attribute__((always_inline)) void render_tile_impl(mgs_raster *r, size_t tile, const int geo) {
  const int W = r->width, H = r->height;
  int tx = (int)(tile % (size_t)r->tiles_x), ty = (int)(tile / (size_t)r->tiles_x);
  int x0 = tx * MGS_TILE_SIZE, y0 = ty * MGS_TILE_SIZE;
  int nrows = H - y0 < MGS_TILE_SIZE ? H - y0 : MGS_TILE_SIZE;
  int ncols = W - x0 < MGS_TILE_SIZE ? W - x0 : MGS_TILE_SIZE;
  /* distortion sums of m - m0, m0 the pixel's first contributor's m: the same value
     (shift-invariant), without the cancellation of m ~ 0.9 squared (float) */
  enum { CR, CG, CB, DZ, N0, N1, N2, M1, M2, DI, MED, M0, NACC };
  v16f T[MGS_TILE_SIZE], A[NACC][MGS_TILE_SIZE];
  v16i NC[MGS_TILE_SIZE], MID[MGS_TILE_SIZE], DONE[MGS_TILE_SIZE];
  v16f X;
  v16i outside;
  for (int i = 0; i < 16; i++) { X[i] = (float)(x0 + i) + 0.5f; outside[i] = i < ncols ? 0 : -1; }
  uint32_t rowdone = 0; /* bit y: every pixel of row y has terminated */
  for (int y = 0; y < MGS_TILE_SIZE; y++) {
    T[y] = v16f_set1(1.0f);
    for (int a = 0; a < NACC; a++) A[a][y] = v16f_set1(0.0f);
    NC[y] = MID[y] = v16i_set1(0);
    DONE[y] = outside;
  }
  const mgs_surf2d_cold *cold = mgs_raster2d_cold(r);
  const v16f one = v16f_set1(1.0f), half = v16f_set1(0.5f), tmin = v16f_set1(MGS_T_MIN);
  uint32_t start = r->tile_start[tile], end = r->tile_start[tile + 1], evals = 0;
  const mgs_surf2d *surf = mgs_raster2d_surf(r);
  for (uint32_t j = start; j < end; j++) {
    if (j + 8 < end) { /* the records are gathered: fetch ahead */
      const char *nx = (const char *)&surf[r->isect_idx[j + 8]];
      __builtin_prefetch(nx); __builtin_prefetch(nx + sizeof(mgs_surf2d) - 1);
    }
    const mgs_surf2d *sf = &surf[r->isect_idx[j]];
    v16i jid = v16i_set1((int32_t)(j - start + 1));
    uint32_t rb = row_bits(sf, x0, y0, nrows, ncols);
    if (r->s_rows) r->s_rows[j] = (uint16_t)rb;
    uint32_t rows = rb & ~rowdone;
    if (!rows) continue;
    isect_cols ic;
    isect_cols_init(sf, X, &ic);
    const mgs_surf2d_cold *cd = geo ? &cold[r->isect_idx[j]] : NULL;
    for (; rows; rows &= rows - 1) {
      int y = __builtin_ctz(rows);
      evals++;
      isect_row e;
      isect_eval(sf, &ic, (float)(y0 + y) + 0.5f, &e);
      v16i m = e.m & ~DONE[y];
      v16f testT = T[y] * (one - e.alpha);
      v16i nd = m & v16f_lt(testT, tmin);
      DONE[y] |= nd;
      if (v16i_any(nd) && !v16i_any(~DONE[y])) rowdone |= 1u << y;
      m &= ~nd;
      if (!v16i_any(m)) continue;
      v16f w = v16f_and(m, e.alpha * T[y]);
      if (geo) {
        v16f mz = depth_map(e.z);
        A[M0][y] = v16f_select(m & v16f_eq(T[y], one), mz, A[M0][y]);
        v16f md = v16f_select(m, mz - A[M0][y], v16f_set1(0.0f));
        A[DI][y] += w * (md * md * (one - T[y]) + A[M2][y] - 2.0f * md * A[M1][y]);
        A[M1][y] += w * md;
        A[M2][y] += w * md * md;
        v16i med = m & v16f_gt(T[y], half);
        A[MED][y] = v16f_select(med, e.z, A[MED][y]);
        MID[y] = (med & jid) | (~med & MID[y]);
        A[N0][y] += w * cd->n[0]; A[N1][y] += w * cd->n[1]; A[N2][y] += w * cd->n[2];
      }
      /* (-std=c17 contracts nothing: the fused multiply-adds are explicit) */
      A[DZ][y] = v16f_fma(w, e.z, A[DZ][y]);
      A[CR][y] = v16f_fma(w, v16f_set1(sf->rgb[0]), A[CR][y]);
      A[CG][y] = v16f_fma(w, v16f_set1(sf->rgb[1]), A[CG][y]);
      A[CB][y] = v16f_fma(w, v16f_set1(sf->rgb[2]), A[CB][y]);
      T[y] = v16f_select(m, testT, T[y]);
      NC[y] = (m & jid) | (~m & NC[y]);
    }
    if (((j - start) & 31) == 31) {
      v16i all = DONE[0];
      for (int yy = 1; yy < nrows; yy++) all &= DONE[yy];
      if (!v16i_any(~all)) break;
    }
  }
  r->tile_evals[tile] = evals;
  const float *bg = r->s.background;
  for (int y = 0; y < nrows; y++) {
    size_t p = (size_t)(y0 + y) * W + x0;
    for (int x = 0; x < ncols; x++) {
      float t = T[y][x];
      float *col = r->out_color + 3 * (p + x);
      col[0] = A[CR][y][x] + t * bg[0];
      col[1] = A[CG][y][x] + t * bg[1];
      col[2] = A[CB][y][x] + t * bg[2];
      r->out_alpha[p + x] = 1.0f - t;
      r->out_depth[p + x] = A[DZ][y][x];
      r->final_T[p + x] = t;
      r->n_contrib[p + x] = NC[y][x];
      if (!geo) continue;
      float *n = r->s_normal + 3 * (p + x);
      n[0] = A[N0][y][x]; n[1] = A[N1][y][x]; n[2] = A[N2][y][x];
      r->s_median[p + x] = A[MED][y][x];
      r->s_medid[p + x] = MID[y][x];
      r->s_m1[p + x] = A[M1][y][x];
      r->s_m2[p + x] = A[M2][y][x];
      r->s_m0[p + x] = A[M0][y][x];
      r->s_dist[p + x] = A[DI][y][x];
    }
  }
}

static void render_range(void *ctx, size_t b, size_t e) {
  for (size_t t = b; t < e; t++) render_tile_impl(ctx, t, 0);
}
static void render_range_geo(void *ctx, size_t b, size_t e) {
  for (size_t t = b; t < e; t++) render_tile_impl(ctx, t, 1);
}

void mgs_raster2d_render_tiles(mgs_raster *r, int geo) {
  size_t nt = (size_t)r->tiles_x * r->tiles_y;
  /* the row masks for the backward (every intersection it visits, the forward visited);
     without the memory the backward recomputes them */
  if (r->n_isect > r->cap_srows) {
    size_t c = r->n_isect + r->n_isect / 4;
    uint16_t *q = realloc(r->s_rows, c * sizeof(uint16_t));
    if (!q) free(r->s_rows);
    r->s_rows = q;
    r->cap_srows = q ? c : 0;
  }
  /* with geo the one pass also writes the maps: the same alpha decisions and sums, so
     colour, alpha and depth are bit for bit those of the pass without, and the maps those
     of mgs_raster2d_geometry's second pass, which is then skipped */
  mgs_parallel_for(0, nt, 1, geo ? render_range_geo : render_range, r);
  double ev = 0;
  for (size_t t = 0; t < nt; t++) ev += r->tile_evals[t];
  r->evals_fwd = ev * 16.0;
  r->s_grad_live = 0;
  r->s_geo = geo;
}

void mgs_raster2d_geometry(mgs_raster *r) {
  if (r->s_geo) return;
  size_t nt = (size_t)r->tiles_x * r->tiles_y;
  double ev = r->evals_fwd;
  mgs_parallel_for(0, nt, 1, render_range_geo, r); /* the same compositing, rewritten bit for bit */
  r->evals_fwd = ev;
  r->s_geo = 1;
}

/* The blending statistics (raster_blend.c) of a surfel forward: its compositing again,
 * with its alpha decisions (row masks, rho = min(rho3, rho2), the depth, 1/255 and
 * T < 1e-4 rules, the row and tile early stops), keeping per pixel the first surfel with
 * the largest w = alpha T and the final T, per intersection the tile's sum of w. Run only
 * when asked: the training forward is untouched. */
typedef struct blend_ctx {
  mgs_raster *r;
  int32_t *max_index;
  float *final_T, *slot_w;
} blend_ctx;

static void blend_tile(const blend_ctx *bc, size_t tile) {
  mgs_raster *r = bc->r;
  const int W = r->width, H = r->height;
  int tx = (int)(tile % (size_t)r->tiles_x), ty = (int)(tile / (size_t)r->tiles_x);
  int x0 = tx * MGS_TILE_SIZE, y0 = ty * MGS_TILE_SIZE;
  int nrows = H - y0 < MGS_TILE_SIZE ? H - y0 : MGS_TILE_SIZE;
  int ncols = W - x0 < MGS_TILE_SIZE ? W - x0 : MGS_TILE_SIZE;
  v16f T[MGS_TILE_SIZE], WMAX[MGS_TILE_SIZE];
  v16i IMAX[MGS_TILE_SIZE], DONE[MGS_TILE_SIZE];
  v16f X;
  v16i outside;
  for (int i = 0; i < 16; i++) { X[i] = (float)(x0 + i) + 0.5f; outside[i] = i < ncols ? 0 : -1; }
  uint32_t rowdone = 0;
  for (int y = 0; y < MGS_TILE_SIZE; y++) {
    T[y] = v16f_set1(1.0f);
    WMAX[y] = v16f_set1(0.0f);
    IMAX[y] = v16i_set1(-1);
    DONE[y] = outside;
  }
  const v16f one = v16f_set1(1.0f), tmin = v16f_set1(MGS_T_MIN);
  const mgs_surf2d *surf = mgs_raster2d_surf(r);
  uint32_t start = r->tile_start[tile], end = r->tile_start[tile + 1], j = start;
  for (; j < end; j++) {
    const mgs_surf2d *sf = &surf[r->isect_idx[j]];
    const v16i gidx = v16i_set1((int32_t)r->isect_idx[j]);
    uint32_t rows = row_bits(sf, x0, y0, nrows, ncols) & ~rowdone;
    v16f wsum = v16f_set1(0.0f);
    if (rows) {
      isect_cols ic;
      isect_cols_init(sf, X, &ic);
      for (; rows; rows &= rows - 1) {
        int y = __builtin_ctz(rows);
        isect_row e;
        isect_eval(sf, &ic, (float)(y0 + y) + 0.5f, &e);
        v16i m = e.m & ~DONE[y];
        v16f testT = T[y] * (one - e.alpha);
        v16i nd = m & v16f_lt(testT, tmin);
        DONE[y] |= nd;
        if (v16i_any(nd) && !v16i_any(~DONE[y])) rowdone |= 1u << y;
        m &= ~nd;
        if (!v16i_any(m)) continue;
        mgs_blend_stat_step(m, e.alpha, testT, gidx, &T[y], &WMAX[y], &IMAX[y], &wsum);
      }
    }
    bc->slot_w[r->isect_slot[j]] = v16f_sum(wsum);
    if (((j - start) & 31) == 31 && mgs_blend_tile_done(DONE, nrows)) { j++; break; }
  }
  for (; j < end; j++) bc->slot_w[r->isect_slot[j]] = 0; /* after the tile's early stop */
  mgs_blend_tile_store(T, IMAX, x0, y0, nrows, ncols, W, bc->final_T, bc->max_index);
}

static void blend_range(void *ctx, size_t b, size_t e) {
  for (size_t t = b; t < e; t++) blend_tile(ctx, t);
}

void mgs_raster2d_blend_tiles(mgs_raster *r, int32_t *max_index, float *final_T, float *slot_w) {
  blend_ctx bc = {r, max_index, final_T, slot_w};
  mgs_parallel_for(0, (size_t)r->tiles_x * r->tiles_y, 1, blend_range, &bc);
}

typedef struct bwd_ctx {
  mgs_raster *r;
  const float *dL_dcolor, *dL_dalpha, *dL_ddepth;
  const float *gmed, *gnormal, *gdist; /* NULL: no map gradients */
} bwd_ctx;

/* Per pixel, with val_i = dL/dw_i (colour, sum w z, normal, and the distortion's
 * m_i^2 A - 2 m_i M1 + M2 at the final sums) and S_i = sum_{j>i} val_j w_j:
 *   dL/dalpha_i = T_i val_i - (S_i + T_final (bg.dL/dcolor - dL/dalpha_out)) / (1 - alpha_i)
 * and dL/dz_i = w_i dL/ddepth + [i is the median] dL/dmedian + 2 w_i (m_i A - M1) dm/dz. */
static inline __attribute__((always_inline)) void backward_tile_impl(const bwd_ctx *bc, size_t tile, const int geo) {
  mgs_raster *r = bc->r;
  const int W = r->width, H = r->height;
  int tx = (int)(tile % (size_t)r->tiles_x), ty = (int)(tile / (size_t)r->tiles_x);
  int x0 = tx * MGS_TILE_SIZE, y0 = ty * MGS_TILE_SIZE;
  int nrows = H - y0 < MGS_TILE_SIZE ? H - y0 : MGS_TILE_SIZE;
  int ncols = W - x0 < MGS_TILE_SIZE ? W - x0 : MGS_TILE_SIZE;
  uint32_t start = r->tile_start[tile], end = r->tile_start[tile + 1];
  const int st = mgs_raster2d_slot_stride(r); /* S2_STRIDE_MAX exactly when geo */
  float *zside = mgs_raster2d_zc_side(r);
  if (start == end) { r->tile_evals[tile] = 0; return; }
  enum { GR, GG, GB, GD, GN0, GN1, GN2, GM, GDI, FM1, FM2, FA, K, FM0, NIN };
  v16f T[MGS_TILE_SIZE], S[MGS_TILE_SIZE], I[NIN][MGS_TILE_SIZE];
  v16i NC[MGS_TILE_SIZE], MID[MGS_TILE_SIZE];
  const float *bg = r->s.background;
  int32_t maxn = 0, rowmax[MGS_TILE_SIZE];
  for (int y = 0; y < MGS_TILE_SIZE; y++) {
    T[y] = v16f_set1(1.0f);
    S[y] = v16f_set1(0.0f);
    for (int a = 0; a < NIN; a++) I[a][y] = v16f_set1(0.0f);
    NC[y] = MID[y] = v16i_set1(0);
    rowmax[y] = 0;
    if (y >= nrows) continue;
    size_t p = (size_t)(y0 + y) * W + x0;
    for (int x = 0; x < ncols; x++) {
      size_t q = p + x;
      const float *dc = bc->dL_dcolor + 3 * q;
      float tf = r->final_T[q];
      T[y][x] = tf;
      NC[y][x] = r->n_contrib[q];
      if (NC[y][x] > rowmax[y]) rowmax[y] = NC[y][x];
      I[GR][y][x] = dc[0]; I[GG][y][x] = dc[1]; I[GB][y][x] = dc[2];
      I[GD][y][x] = bc->dL_ddepth ? bc->dL_ddepth[q] : 0.0f;
      I[K][y][x] = tf * (bg[0] * dc[0] + bg[1] * dc[1] + bg[2] * dc[2] - (bc->dL_dalpha ? bc->dL_dalpha[q] : 0.0f));
      if (geo) {
        const float *gn = bc->gnormal + 3 * q;
        I[GN0][y][x] = gn[0]; I[GN1][y][x] = gn[1]; I[GN2][y][x] = gn[2];
        /* the median map is 0 (no gradient) where alpha < 0.5 */
        I[GM][y][x] = tf < 0.5f ? bc->gmed[q] : 0.0f;
        I[GDI][y][x] = bc->gdist[q];
        MID[y][x] = r->s_medid[q];
      }
      if (geo) {
        I[FM1][y][x] = r->s_m1[q];
        I[FM2][y][x] = r->s_m2[q];
        I[FM0][y][x] = r->s_m0[q];
        I[FA][y][x] = 1.0f - tf;
      }
    }
    if (rowmax[y] > maxn) maxn = rowmax[y];
  }
  v16f X;
  for (int i = 0; i < 16; i++) X[i] = (float)(x0 + i) + 0.5f;
  const v16f one = v16f_set1(1.0f), zero = v16f_set1(0.0f), amax = v16f_set1(MGS_ALPHA_MAX);
  const float F = MGS_2DGS_FAR, N = MGS_2DGS_NEAR;
  const v16f dmdz_c = v16f_set1(F * N / (F - N));
  /* rho2 = F |pixel - o|^2: dL/do = -F/2 (-2) sum q (pixel - o) = F sum q (pixel - o) */
  v16f slot_fac = one;
  slot_fac[S2_OX] = slot_fac[S2_OY] = MGS_2DGS_FILTER_INV2;
  for (uint32_t j = start + (uint32_t)maxn; j < end; j++) {
    memset(r->sgrad + (size_t)r->isect_slot[j] * st, 0, (size_t)(geo ? S2_COUNT : 16) * sizeof(float));
    if (!geo) zside[r->isect_slot[j]] = 0;
  }
  const mgs_surf2d *surf = mgs_raster2d_surf(r);
  uint32_t evals = 0;
  for (uint32_t j = start + (uint32_t)maxn; j-- > start;) {
    if (j >= start + 8) { /* random slot and record: fetch ahead */
      __builtin_prefetch(r->sgrad + (size_t)r->isect_slot[j - 8] * st, 1);
      const char *nx = (const char *)&surf[r->isect_idx[j - 8]];
      __builtin_prefetch(nx); __builtin_prefetch(nx + sizeof(mgs_surf2d) - 1);
    }
    const mgs_surf2d *sf = &surf[r->isect_idx[j]];
    float *out = r->sgrad + (size_t)r->isect_slot[j] * st;
    v16i jid = v16i_set1((int32_t)(j - start));
    v16i jid1 = v16i_set1((int32_t)(j - start + 1));
    /* per lane, summed over rows: dL/dp (P*), dL/dp times the row's y - oy (PY*), dL/ddet,
       dL/drho2 (times -1/2: Q2) and Q2 (y - oy); the column factor x - ox is the same in
       every row, applied once at the end */
    v16f PX = zero, PY = zero, PZ = zero, PXY = zero, PYY = zero, PZY = zero, AD = zero, Q2 = zero, Q2Y = zero;
    v16f AOP = zero, AR = zero, AG = zero, AB = zero, AZC = zero, AN0 = zero, AN1 = zero, AN2 = zero;
    const v16f cr = v16f_set1(sf->rgb[0]), cg = v16f_set1(sf->rgb[1]), cb = v16f_set1(sf->rgb[2]);
    const mgs_surf2d_cold *cd = geo ? &mgs_raster2d_cold(r)[r->isect_idx[j]] : NULL;
    const v16f n0 = v16f_set1(geo ? cd->n[0] : 0.0f), n1 = v16f_set1(geo ? cd->n[1] : 0.0f), n2 = v16f_set1(geo ? cd->n[2] : 0.0f);
    isect_cols ic;
    isect_cols_init(sf, X, &ic);
    int touched = 0;
    uint32_t rows0 = r->s_rows ? r->s_rows[j] : row_bits(sf, x0, y0, nrows, ncols);
    for (uint32_t rows = rows0; rows; rows &= rows - 1) {
      int y = __builtin_ctz(rows);
      if ((int32_t)(j - start) >= rowmax[y]) continue;
      evals++;
      float Y = (float)(y0 + y) + 0.5f;
      isect_row e;
      isect_eval(sf, &ic, Y, &e);
      v16i m = e.m & v16i_lt(jid, NC[y]);
      if (!v16i_any(m)) continue;
      touched = 1;
      v16f inv = v16f_rcp(one - e.alpha);
      v16f Tn = v16f_select(m, T[y] * inv, T[y]);
      T[y] = Tn;
      v16f w = v16f_and(m, e.alpha * Tn);
      v16f zm = v16f_and(m, e.z);
      v16f val = v16f_fma(cr, I[GR][y], v16f_fma(cg, I[GG][y], v16f_fma(cb, I[GB][y], zm * I[GD][y])));
      v16f md = zero;
      if (geo) {
        md = v16f_select(m, depth_map(e.z) - I[FM0][y], zero);
        val += n0 * I[GN0][y] + n1 * I[GN1][y] + n2 * I[GN2][y] +
               I[GDI][y] * (md * md * I[FA][y] - 2.0f * md * I[FM1][y] + I[FM2][y]);
        AN0 = v16f_fma(w, I[GN0][y], AN0); AN1 = v16f_fma(w, I[GN1][y], AN1); AN2 = v16f_fma(w, I[GN2][y], AN2);
      }
      AR = v16f_fma(w, I[GR][y], AR); AG = v16f_fma(w, I[GG][y], AG); AB = v16f_fma(w, I[GB][y], AB);
      v16f Sy = S[y];
      v16f dLda = v16f_fma(zero - (Sy + I[K][y]), inv, Tn * val);
      S[y] = v16f_fma(val, w, Sy);
      dLda = v16f_and(m & v16f_lt(e.raw, amax), dLda);
      AOP = v16f_fma(e.G, dLda, AOP);
      v16f q = e.raw * dLda; /* dL/drho = -q/2 */
      /* depth of the intersection */
      v16f dLdz = w * I[GD][y];
      if (geo) {
        v16f iz = one / v16f_select(m, e.z, one);
        dLdz += v16f_and(m & v16i_eq(MID[y], jid1), I[GM][y]) + 2.0f * w * (md * I[FA][y] - I[FM1][y]) * I[GDI][y] * dmdz_c * iz * iz;
        dLdz = v16f_and(m, dLdz);
      }
      v16i use3 = m & e.use3;
      /* rho3 = |p.xy|^2 / p.z^2, z = det / p.z */
      v16f a = zero - q * e.ipz;
      v16f gpx = v16f_and(use3, a * e.sx), gpy = v16f_and(use3, a * e.sy);
      v16f gz = v16f_and(use3, dLdz * e.ipz); /* the filter's depth zc: no path through p */
      AZC += v16f_and(m & ~use3, dLdz);
      v16f gpz = zero - v16f_fma(gz, zm, v16f_and(use3, a * e.rho3));
      v16f yp = v16f_set1(e.yp);
      PX += gpx; PY += gpy; PZ += gpz;
      PXY = v16f_fma(gpx, yp, PXY); PYY = v16f_fma(gpy, yp, PYY); PZY = v16f_fma(gpz, yp, PZY);
      AD += gz;
      v16f q2 = v16f_and(m & ~use3, q);
      Q2 += q2;
      Q2Y = v16f_fma(q2, yp, Q2Y);
    }
    if (!touched) { /* no pixel: a zero slot */
      memset(out, 0, (size_t)(geo ? S2_COUNT : 16) * sizeof(float));
      if (!geo) zside[r->isect_slot[j]] = 0;
      continue;
    }
    /* the 16 sums in slot order, one transposing reduction */
    v16f acc[16] = {PX * ic.xp, PY * ic.xp, PZ * ic.xp, PXY, PYY, PZY, PX, PY, PZ, AD, Q2 * ic.xp, Q2Y, AOP, AR, AG, AB};
    v16f_store(out, v16f_sum16(acc) * slot_fac);
    if (geo) out[S2_ZC] = v16f_sum(AZC);
    else zside[r->isect_slot[j]] = v16f_sum(AZC);
    if (geo) {
      out[S2_N] = v16f_sum(AN0); out[S2_N + 1] = v16f_sum(AN1); out[S2_N + 2] = v16f_sum(AN2);

    }
  }
  r->tile_evals[tile] = evals;
}

static void backward_range(void *ctx, size_t b, size_t e) {
  const bwd_ctx *bc = ctx;
  if (bc->gnormal) for (size_t t = b; t < e; t++) backward_tile_impl(bc, t, 1);
  else for (size_t t = b; t < e; t++) backward_tile_impl(bc, t, 0);
}

mgs_status mgs_raster2d_backward_tiles(mgs_raster *r, const float *dL_dcolor, const float *dL_dalpha,
                                       const float *dL_ddepth, mgs_error *err) {
  if (r->n_isect > r->cap_sgrad) {
    size_t c = r->n_isect + r->n_isect / 4;
    free(r->sgrad);
    r->sgrad = aligned_alloc(64, (c ? c : 1) * S2_STRIDE_MAX * sizeof(float));
    r->cap_sgrad = r->sgrad ? c : 0;
    if (!r->sgrad)
      return mgs_error_set(err, MGS_ERR_NOMEM, "render/raster_2dgs_tiles.c: out of memory for %zu intersections", r->n_isect);
  }
  bwd_ctx bc = {r, dL_dcolor, dL_dalpha, dL_ddepth, NULL, NULL, NULL};
  if (r->s_grad_live) { bc.gmed = r->s_gmed; bc.gnormal = r->s_gnormal; bc.gdist = r->s_gdist; }
  size_t nt = (size_t)r->tiles_x * r->tiles_y;
  mgs_parallel_for(0, nt, 1, backward_range, &bc);
  double ev = 0;
  for (size_t t = 0; t < nt; t++) ev += r->tile_evals[t];
  r->evals_bwd = ev * 16.0;
  return MGS_OK;
}

mgs_status mgs_raster_map_grads(mgs_raster *r, mgs_raster_map_grad *out, mgs_error *err) {
  if (!r || !out) return mgs_error_set(err, MGS_ERR_ARG, "render/raster_2dgs_tiles.c: NULL argument");
  if (!r->have_forward)
    return mgs_error_set(err, MGS_ERR_ARG, "render/raster_2dgs_tiles.c: map gradients need a forward on this context");
  if (!r->surfel) return mgs_raster3d_map_grads(r, out, err); /* 3DGS: the normal only */
  size_t npix = (size_t)r->width * r->height;
  mgs_raster2d_geometry(r); /* their backward reads the geometry pass's sums */
  if (!r->s_grad_live) {
    memset(r->s_gmed, 0, npix * sizeof(float));
    memset(r->s_gnormal, 0, 3 * npix * sizeof(float));
    memset(r->s_gdist, 0, npix * sizeof(float));
    r->s_grad_live = 1;
  }
  out->depth_median = r->s_gmed;
  out->normal = r->s_gnormal;
  out->distortion = r->s_gdist;
  return MGS_OK;
}

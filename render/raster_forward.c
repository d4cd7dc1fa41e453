/* The forward: projection, binning, then per-tile front-to-back compositing, parallel
 * over tiles. Inside a tile the 256 pixels are 16 rows of 16-wide vectors (8-wide half rows
 * for a Gaussian whose pixels all lie in one half of the tile); each Gaussian
 * of the tile's depth-sorted list is evaluated only on the rows its alpha >= 1/255
 * ellipse reaches and whose pixels have not all terminated, and the tile stops when all
 * have (identical result to evaluating everything, as the reference does). */
#include <math.h>
#include <string.h>
#include "core/mgs_log.h"
#include "core/mgs_parallel.h"
#include "render/raster_kernel.h"

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

#if defined(MGS_ROWS8)
/* fwd_row on half o (0 or 8) of row y, its power given. */
static inline __attribute__((always_inline)) void fwd_half(v8f power, v8f op, v8f cr, v8f cg, v8f cb, v8f cz, v8i jid,
                                                           int y, int o, v16f *T, v16f *C0, v16f *C1, v16f *C2,
                                                           v16f *D, v16i *NC, v16i *DONE, int *rowdone) {
  const v8f amax = v8f_set1(MGS_ALPHA_MAX), amin = v8f_set1(MGS_ALPHA_MIN), tmin = v8f_set1(MGS_T_MIN);
  const v8f one = v8f_set1(1.0f), zero = v8f_set1(0.0f);
  v8f alpha = v8f_min(amax, op * v8f_exp_neg(power));
  v8i done = v8i_half(&DONE[y], o);
  v8i m = (power <= zero) & (alpha >= amin) & ~done;
  v8f Ty = v8f_half(&T[y], o);
  v8f testT = Ty * (one - alpha);
  v8i nd = m & (testT < tmin);
  if (v8i_any(nd)) {
    v8i_put(&DONE[y], o, done | nd);
    rowdone[y] = mgs_row_all8(&DONE[y]);
  }
  m &= ~nd;
  v8f w = v8f_and(m, alpha * Ty);
  v8f_put(&C0[y], o, v8f_fma(w, cr, v8f_half(&C0[y], o)));
  v8f_put(&C1[y], o, v8f_fma(w, cg, v8f_half(&C1[y], o)));
  v8f_put(&C2[y], o, v8f_fma(w, cb, v8f_half(&C2[y], o)));
  v8f_put(&D[y], o, v8f_fma(w, cz, v8f_half(&D[y], o)));
  v8f_put(&T[y], o, v8f_select(m, testT, Ty));
  v8i_put(&NC[y], o, (m & jid) | (~m & v8i_half(&NC[y], o)));
}

/* Rows [lo, hi] of the tile blended with sp, as fwd_row does them, in 8-lane halves; a
 * half whose pixels are all terminated or below the power floor is skipped (nothing there
 * changes: its pixels take no weight). Returns the rows evaluated (as fwd_row counts). */
static inline __attribute__((always_inline)) uint32_t fwd_rows8(const mgs_splat *sp, const v16f *xs, int32_t jid1,
                                                                int y0, int lo, int hi, v16f *T, v16f *C0, v16f *C1,
                                                                v16f *C2, v16f *D, v16i *NC, v16i *DONE,
                                                                int *rowdone) {
  v8f dx0 = v8f_half(xs, 0) - v8f_set1(sp->u), dx1 = v8f_half(xs, 8) - v8f_set1(sp->u);
  v8f op = v8f_set1(sp->opacity), floor = v8f_set1(mgs_power_floor(sp->opacity));
  v8f cr = v8f_set1(sp->rgb[0]), cg = v8f_set1(sp->rgb[1]), cb = v8f_set1(sp->rgb[2]), cz = v8f_set1(sp->z);
  v8i jid = v8i_set1(jid1);
  uint32_t evals = 0;
  for (int y = lo; y <= hi; y++) {
    if (rowdone[y]) continue;
    evals++;
    float dy = (float)(y0 + y) + 0.5f - sp->v;
    v8f p0 = mgs_row_power8(sp, dx0, dy), p1 = mgs_row_power8(sp, dx1, dy);
    if (v8i_any(~((p0 < floor) | v8i_half(&DONE[y], 0))))
      fwd_half(p0, op, cr, cg, cb, cz, jid, y, 0, T, C0, C1, C2, D, NC, DONE, rowdone);
    if (v8i_any(~((p1 < floor) | v8i_half(&DONE[y], 8))))
      fwd_half(p1, op, cr, cg, cb, cz, jid, y, 8, T, C0, C1, C2, D, NC, DONE, rowdone);
  }
  return evals;
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
#if defined(MGS_ROWS8)
    evals += fwd_rows8(sp, &xs, (int32_t)(j - start + 1), y0, lo, hi, T, C0, C1, C2, D, NC, DONE, rowdone);
#else
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
#endif
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

void mgs_raster_render_tiles(mgs_raster *r) {
  size_t nt = (size_t)r->tiles_x * r->tiles_y;
  mgs_parallel_for(0, nt, 1, render_range, r);
  double ev = 0;
  for (size_t t = 0; t < nt; t++) ev += r->tile_evals[t];
  r->evals_fwd = ev * 16.0;
}

static mgs_status forward(mgs_raster *r, const mgs_gaussians *g, const mgs_camera *cam, const mgs_raster_settings *s,
                          const uint32_t *idx, size_t n_idx, mgs_raster_output *out, mgs_error *err);

mgs_status mgs_raster_forward(mgs_raster *r, const mgs_gaussians *g, const mgs_camera *cam,
                              const mgs_raster_settings *s, mgs_raster_output *out, mgs_error *err) {
  return forward(r, g, cam, s, NULL, 0, out, err);
}

mgs_status mgs_raster_forward_list(mgs_raster *r, const mgs_gaussians *g, const mgs_camera *cam,
                                     const mgs_raster_settings *s, const uint32_t *idx, size_t n_idx,
                                     mgs_raster_output *out, mgs_error *err) {
  if (!idx && n_idx) return mgs_error_set(err, MGS_ERR_ARG, "render/raster_forward.c: NULL index list");
  for (size_t k = 0; k < n_idx; k++)
    if (idx[k] >= g->n || (k && idx[k] <= idx[k - 1]))
      return mgs_error_set(err, MGS_ERR_ARG, "render/raster_forward.c: index list entry %zu (%u) not increasing below %zu",
                           k, idx[k], g->n);
  static const uint32_t none = 0;
  return forward(r, g, cam, s, idx ? idx : &none, n_idx, out, err);
}

static mgs_status forward(mgs_raster *r, const mgs_gaussians *g, const mgs_camera *cam, const mgs_raster_settings *s,
                          const uint32_t *idx, size_t n_idx, mgs_raster_output *out, mgs_error *err) {
  if (!r || !g || !cam || !s || !out)
    return mgs_error_set(err, MGS_ERR_ARG, "render/raster_forward.c: NULL argument");
  if (cam->width <= 0 || cam->height <= 0 || cam->width > 32768 || cam->height > 32768)
    return mgs_error_set(err, MGS_ERR_ARG, "render/raster_forward.c: image size %dx%d out of range (1..32768)",
                         cam->width, cam->height);
  if (!(cam->fx > 0) || !(cam->fy > 0) || !isfinite(cam->cx) || !isfinite(cam->cy))
    return mgs_error_set(err, MGS_ERR_ARG, "render/raster_forward.c: invalid intrinsics fx=%g fy=%g", cam->fx, cam->fy);
  if (s->sh_degree < 0 || s->sh_degree > 3 || s->sh_degree > g->sh_degree)
    return mgs_error_set(err, MGS_ERR_ARG, "render/raster_forward.c: SH degree %d not in 0..%d (the model's)",
                         s->sh_degree, g->sh_degree);
  if (g->n > UINT32_MAX - 1)
    return mgs_error_set(err, MGS_ERR_ARG, "render/raster_forward.c: %zu Gaussians exceed the 2^32 limit", g->n);
  /* a hint is for this forward only (mgs_raster_hint_maps) */
  const int geo = (r->hint_maps & (MGS_MAP_DEPTH_MEDIAN | MGS_MAP_NORMAL | MGS_MAP_DISTORTION)) != 0;
  r->hint_maps = 0;
  r->have_forward = 0;
  r->bwd_kind = 0;
  r->map_gn_valid = 0;
  r->map_grad_live = 0;
  r->g = g;
  r->cam = *cam;
  r->s = *s;
  r->width = cam->width;
  r->height = cam->height;
  r->tiles_x = (cam->width + MGS_TILE_SIZE - 1) / MGS_TILE_SIZE;
  r->tiles_y = (cam->height + MGS_TILE_SIZE - 1) / MGS_TILE_SIZE;
  r->n = g->n;
  size_t nt = (size_t)r->tiles_x * r->tiles_y, npix = (size_t)cam->width * cam->height;
  mgs_status st = mgs_raster_reserve(r, g->n, nt, npix, err);
  if (st != MGS_OK) return st;
  r->surfel = g->kind == MGS_MODEL_2DGS;
  if (r->surfel && (st = mgs_raster2d_reserve(r, g->n, npix, err)) != MGS_OK) return st;
  double c0 = mgs_raster_cpu_now(), t0 = mgs_now();
  if (r->surfel) mgs_raster2d_project(r, idx, n_idx);
  else if (idx) mgs_raster_project_list(r, idx, n_idx);
  else mgs_raster_project_all(r);
  double t1 = mgs_now(), c1 = mgs_raster_cpu_now();
  st = mgs_raster_bin(r, err);
  if (st != MGS_OK) return st;
  double t2 = mgs_now(), c2 = mgs_raster_cpu_now();
  if (r->surfel) mgs_raster2d_render_tiles(r, geo);
  else mgs_raster_render_tiles(r);
  double t3 = mgs_now(), c3 = mgs_raster_cpu_now();
  r->prof.project_ms = (t1 - t0) * 1e3;
  r->prof.bin_ms = (t2 - t1) * 1e3;
  r->prof.render_ms = (t3 - t2) * 1e3;
  r->prof.project_cpu = (c1 - c0) * 1e3;
  r->prof.bin_cpu = (c2 - c1) * 1e3;
  r->prof.render_cpu = (c3 - c2) * 1e3;
  r->evals_bwd = 0;
  size_t nvis = 0;
  for (size_t i = 0; i < g->n; i++) nvis += r->radii[i] > 0;
  out->width = cam->width;
  out->height = cam->height;
  out->color = r->out_color;
  out->alpha = r->out_alpha;
  out->depth = r->out_depth;
  out->radii = r->radii;
  out->n_visible = nvis;
  out->n_intersections = r->n_isect;
  r->have_forward = 1;
  return MGS_OK;
}

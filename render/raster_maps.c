/* The geometry maps of the last forward (render/mgs_render_maps.h), on request: the
 * expected depth from the forward's own sum of w z, and, for the median depth and the
 * normals, one more pass over the forward's depth-sorted tile lists with its alpha rules
 * (same power, exp and clamp, same 1/255 skip and T < 1e-4 stop), so that the forward the
 * training loop runs keeps its cost. 3DGS normal: the axis of the smallest scale of each
 * Gaussian, turned towards the camera. */
#include <math.h>
#include <string.h>
#include "core/mgs_math.h"
#include "core/mgs_parallel.h"
#include "render/raster_kernel.h"

typedef struct maps_ctx {
  mgs_raster *r;
  unsigned which;
} maps_ctx;

static void gauss_normals(void *vctx, size_t b, size_t e) {
  mgs_raster *r = vctx;
  const mgs_gaussians *g = r->g;
  const double cc[3] = {r->cam.c2w[3], r->cam.c2w[7], r->cam.c2w[11]};
  for (size_t i = b; i < e; i++) {
    float *n = r->map_gnormal + 3 * i;
    if (r->radii[i] <= 0) { n[0] = n[1] = n[2] = 0; continue; }
    float R[9];
    mgs_quat_to_mat3f(g->rot + 4 * i, R);
    const float *ls = g->log_scale + 3 * i;
    int k = ls[0] <= ls[1] ? (ls[0] <= ls[2] ? 0 : 2) : (ls[1] <= ls[2] ? 1 : 2);
    /* column k of R is the local axis k in world space */
    float a[3] = {R[k], R[3 + k], R[6 + k]};
    double dot = 0;
    for (int c = 0; c < 3; c++) dot += a[c] * (cc[c] - (double)g->mean[3 * i + c]);
    float s = dot < 0 ? -1.0f : 1.0f;
    for (int c = 0; c < 3; c++) n[c] = s * a[c];
  }
}

void mgs_raster_gauss_normals(mgs_raster *r) {
  if (r->map_gn_valid) return;
  mgs_parallel_for(0, r->n, 1024, gauss_normals, r);
  r->map_gn_valid = 1;
}

/* One tile: the forward's compositing, accumulating the median depth and w n. */
static void maps_tile(mgs_raster *r, size_t tile, int want_n, int want_m) {
  const int W = r->width, H = r->height;
  int tx = (int)(tile % (size_t)r->tiles_x), ty = (int)(tile / (size_t)r->tiles_x);
  int x0 = tx * MGS_TILE_SIZE, y0 = ty * MGS_TILE_SIZE;
  int nrows = H - y0 < MGS_TILE_SIZE ? H - y0 : MGS_TILE_SIZE;
  int ncols = W - x0 < MGS_TILE_SIZE ? W - x0 : MGS_TILE_SIZE;
  v16f T[MGS_TILE_SIZE], N0[MGS_TILE_SIZE], N1[MGS_TILE_SIZE], N2[MGS_TILE_SIZE], MED[MGS_TILE_SIZE];
  v16i DONE[MGS_TILE_SIZE];
  v16f xs;
  v16i outside;
  for (int i = 0; i < 16; i++) { xs[i] = (float)(x0 + i) + 0.5f; outside[i] = i < ncols ? 0 : -1; }
  int rowdone[MGS_TILE_SIZE];
  for (int y = 0; y < MGS_TILE_SIZE; y++) {
    T[y] = v16f_set1(1.0f);
    N0[y] = N1[y] = N2[y] = MED[y] = v16f_set1(0.0f);
    DONE[y] = outside;
    rowdone[y] = 0;
  }
  const v16f half = v16f_set1(0.5f);
  uint32_t start = r->tile_start[tile], end = r->tile_start[tile + 1];
  for (uint32_t j = start; j < end; j++) {
    uint32_t gi = r->isect_idx[j];
    const mgs_splat *sp = &r->splat[gi];
    int lo, hi;
    mgs_row_range(sp, y0, nrows, &lo, &hi);
    v16f dx = xs - v16f_set1(sp->u), cz = v16f_set1(sp->z);
    const float *gn = want_n ? r->map_gnormal + 3 * (size_t)gi : NULL;
    for (int y = lo; y <= hi; y++) {
      if (rowdone[y]) continue;
      v16i m;
      v16f alpha, testT = mgs_row_step(sp, dx, (float)(y0 + y) + 0.5f - sp->v, T[y], &DONE[y], &rowdone[y], &m, &alpha);
      if (want_m) MED[y] = v16f_select(m & v16f_ge(T[y], half) & v16f_lt(testT, half), cz, MED[y]);
      if (want_n) {
        v16f w = v16f_and(m, alpha * T[y]);
        N0[y] = v16f_fma(w, v16f_set1(gn[0]), N0[y]);
        N1[y] = v16f_fma(w, v16f_set1(gn[1]), N1[y]);
        N2[y] = v16f_fma(w, v16f_set1(gn[2]), N2[y]);
      }
      T[y] = v16f_select(m, testT, T[y]);
    }
    if (((j - start) & 31) == 31) {
      v16i all = DONE[0];
      for (int yy = 1; yy < nrows; yy++) all &= DONE[yy];
      if (!v16i_any(~all)) break;
    }
  }
  for (int y = 0; y < nrows; y++) {
    float n0[16], n1[16], n2[16], md[16];
    v16f_store(n0, N0[y]); v16f_store(n1, N1[y]); v16f_store(n2, N2[y]); v16f_store(md, MED[y]);
    size_t p = (size_t)(y0 + y) * W + x0;
    for (int x = 0; x < ncols; x++) {
      if (want_m) r->map_median[p + x] = md[x];
      if (want_n) {
        float *n = r->map_normal + 3 * (p + x);
        n[0] = n0[x]; n[1] = n1[x]; n[2] = n2[x];
      }
    }
  }
}

static void maps_range(void *vctx, size_t b, size_t e) {
  maps_ctx *c = vctx;
  for (size_t t = b; t < e; t++) maps_tile(c->r, t, !!(c->which & MGS_MAP_NORMAL), !!(c->which & MGS_MAP_DEPTH_MEDIAN));
}

void mgs_raster_hint_maps(mgs_raster *r, unsigned which) {
  if (r) r->hint_maps = which;
}

mgs_status mgs_raster_maps(mgs_raster *r, unsigned which, mgs_render_maps *out, mgs_error *err) {
  if (!r || !out) return mgs_error_set(err, MGS_ERR_ARG, "render/raster_maps.c: NULL argument");
  if (!r->have_forward) return mgs_error_set(err, MGS_ERR_ARG, "render/raster_maps.c: no forward pass on this context");
  if (which & ~(unsigned)(MGS_MAP_ALL | MGS_MAP_DISTORTION))
    return mgs_error_set(err, MGS_ERR_ARG, "render/raster_maps.c: unknown map flags 0x%x", which);
  if ((which & MGS_MAP_DISTORTION) && !r->surfel)
    return mgs_error_set(err, MGS_ERR_ARG, "render/raster_maps.c: the distortion map needs a 2DGS model");
  size_t npix = (size_t)r->width * r->height;
  mgs_status st = mgs_raster_reserve_maps(r, which & MGS_MAP_NORMAL ? r->n : 0, npix, err);
  if (st != MGS_OK) return st;
  memset(out, 0, sizeof *out);
  out->width = r->width;
  out->height = r->height;
  out->alpha = r->out_alpha;
  if (which & MGS_MAP_DEPTH_EXPECTED) {
    for (size_t p = 0; p < npix; p++) r->map_expected[p] = r->out_alpha[p] > 0 ? r->out_depth[p] / r->out_alpha[p] : 0.0f;
    out->depth_expected = r->map_expected;
  }
  if (r->surfel) { /* the 2DGS geometry pass (raster_2dgs_tiles.c) */
    if (which & (MGS_MAP_DEPTH_MEDIAN | MGS_MAP_NORMAL | MGS_MAP_DISTORTION)) mgs_raster2d_geometry(r);
    if (which & MGS_MAP_DEPTH_MEDIAN) {
      for (size_t p = 0; p < npix; p++) r->map_median[p] = r->final_T[p] < 0.5f ? r->s_median[p] : 0.0f;
      out->depth_median = r->map_median;
    }
    if (which & MGS_MAP_NORMAL) out->normal = r->s_normal;
    if (which & MGS_MAP_DISTORTION) out->distortion = r->s_dist;
    return MGS_OK;
  }
  maps_ctx c = {r, which};
  if (which & MGS_MAP_NORMAL) mgs_raster_gauss_normals(r);
  if (which & (MGS_MAP_NORMAL | MGS_MAP_DEPTH_MEDIAN))
    mgs_parallel_for(0, (size_t)r->tiles_x * r->tiles_y, 1, maps_range, &c);
  if (which & MGS_MAP_DEPTH_MEDIAN) out->depth_median = r->map_median;
  if (which & MGS_MAP_NORMAL) out->normal = r->map_normal;
  return MGS_OK;
}

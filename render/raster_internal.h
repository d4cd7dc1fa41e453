/* Internal state of the tile rasterizer shared by its files (raster_*.c). Not public:
 * render/mgs_raster.h is the contract. */
#ifndef MGS_RASTER_INTERNAL_H
#define MGS_RASTER_INTERNAL_H
#include <stddef.h>
#include <stdint.h>
#include "render/mgs_raster.h"

/* What the tile kernels need of one projected Gaussian (48 bytes; gathered through the
 * tile lists' Gaussian indices). */
typedef struct mgs_splat {
  float u, v;          /* screen mean, pixels (pixel centres at +0.5) */
  float A, B, C;       /* conic = inverse 2D covariance: power = -(A dx^2 + 2B dx dy + C dy^2)/2 */
  float opacity;       /* sigmoid(logit) */
  float rgb[3];        /* SH colour, clamped at 0 */
  float z;             /* camera depth */
  float ry;            /* half height (px) of the region where opacity*G >= 1/255 */
  float rx;            /* its half width */
} mgs_splat;

/* Per-Gaussian data the backward needs beyond the splat and the parameters (what the
 * double-precision parts of the forward computed; the float rotation, scales and Jacobian
 * are recomputed bit for bit by the same code instead, cheaper than 80 more bytes a
 * Gaussian written and read back). */
typedef struct mgs_proj_aux {
  float t[3];          /* camera-space mean (float, after the double transform) */
  float dir[3];        /* unit view direction (world), for the SH backward */
  float dist;          /* |mean - camera centre| */
  uint8_t clamped[3];  /* colour channel clamped at 0 */
} mgs_proj_aux;

#define MGS_2DGS_NEAR 0.2f        /* ray-splat depths below are skipped (the authors' near_n) */
#define MGS_2DGS_FAR 100.0f       /* far_n of the distortion's depth mapping */
#define MGS_2DGS_FILTER_INV2 2.0f /* rho2d = 2 |pixel - centre|^2: a sqrt(2)/2 px filter */

/* Sum over one tile's pixels of the gradient w.r.t. one splat's values. */
enum { GS_R, GS_G, GS_B, GS_Z, GS_OP, GS_U, GS_V, GS_A, GS_B2, GS_C, GS_N };
/* With a normal-map gradient (raster_maps_backward.c): sum over the tile of w dL/dN, the
 * gradient w.r.t. the Gaussian's unit normal, in the slot's lanes after GS_N. */
enum { GS_NX = GS_N, GS_NY, GS_NZ };
/* Floats per intersection gradient slot: one aligned cache line (the slots are written in
 * random order; a 44-byte slot would straddle two lines most of the time). */
#define GS_STRIDE 16

struct mgs_raster {
  /* the forward this context belongs to */
  const mgs_gaussians *g;
  mgs_camera cam;
  mgs_raster_settings s;
  int width, height, tiles_x, tiles_y;
  size_t n;
  int have_forward;

  /* per Gaussian (capacity cap_n) */
  size_t cap_n;
  mgs_splat *splat;
  mgs_proj_aux *aux;
  int *radii;
  uint16_t *rect;          /* tile rect x0, y0, x1, y1 (exclusive) */
  uint32_t *count;         /* tiles touched, 0 when culled */

  /* visible Gaussians, depth-sorted (capacity cap_n) */
  size_t n_visible;
  uint32_t *vis_key, *vis_idx, *tmp_key, *tmp_idx;
  uint32_t *gauss_off;     /* per Gaussian: first of its count[i] gradient slots (index order) */

  /* intersections (capacity cap_isect) */
  size_t n_isect, cap_isect;
  uint32_t *isect_idx;     /* Gaussian of each (tile, depth)-sorted intersection (the tile
                              kernels gather its splat with prefetching: cheaper than copying
                              48 bytes into every tile list, a scattered write) */
  uint32_t *isect_slot;    /* per intersection: its gradient slot, gauss_off[i] + (j-th tile of
                              Gaussian i), so the per-Gaussian pass reads its slots in order */
  float *isect_grad;       /* GS_STRIDE floats per intersection (backward), 64-byte aligned */

  /* per tile */
  size_t cap_tiles;
  uint32_t *tile_start;    /* tiles+1 */
  uint32_t *chunk_cnt;     /* per (chunk, tile) counts of the binning */
  uint32_t *tile_evals;    /* tile rows evaluated per tile (statistics) */
  uint32_t *tile_visit;    /* per tile: intersections the forward visited [2t], the backward [2t+1]
                              (byte accounting, raster_bytes.c) */
  size_t cap_chunk_cnt;

  /* per pixel */
  size_t cap_pix;
  float *out_color, *out_alpha, *out_depth, *final_T;
  int32_t *n_contrib;

  /* geometry maps (raster_maps.c), allocated on the first request only */
  size_t cap_map_n, cap_map_pix;
  float *map_gnormal;      /* per Gaussian: unit normal facing the camera (3) */
  float *map_expected, *map_median, *map_normal;
  float *map_gnormal_grad; /* 3DGS: dL/d(normal map), 3 per pixel, handed out by mgs_raster_map_grads */
  int map_gn_valid;        /* map_gnormal holds this forward's normals */
  int map_grad_live;       /* 3DGS: the normal-map gradient was handed out since the forward */

  /* 2DGS (raster_2dgs_*.c): set when the forward's model is MGS_MODEL_2DGS */
  int surfel;
  size_t cap_surf, cap_sgrad, cap_spix;
  void *surf;              /* the surfel records (render/raster_2dgs.h) */
  float *sgrad;            /* the backward's per-intersection slots (render/raster_2dgs.h) */
  uint16_t *s_rows;        /* per intersection: the forward's row mask (the backward reuses it) */
  size_t cap_srows;
  float *s_normal, *s_median, *s_dist, *s_m1, *s_m2, *s_m0; /* per pixel (normal: 3) */
  int32_t *s_medid;        /* 1-based tile-list position of the median contributor, 0: none */
  float *s_gmed, *s_gnormal, *s_gdist; /* dL/d(maps), handed out by mgs_raster_map_grads */
  int s_grad_live;         /* the map gradients were handed out since the forward */
  unsigned hint_maps;      /* maps the caller will ask of the next forward (mgs_raster_hint_maps) */
  int s_geo;               /* the geometry pass (normal, median, distortion) ran since the forward */
  /* blending statistics (raster_blend.c), allocated on the first request only */
  struct mgs_raster_blend_buf *blend;

  /* statistics of the last calls (benchmark) */
  int sort_passes, bin_chunks; /* radix passes run, chunks of the tile count/scatter */
  int bwd_kind;                /* 0 none, 1 into gradient arrays, 2 into a sink's block scratch */
  int bwd_alpha, bwd_depth, bwd_mean2d, bwd_visible_only; /* what the last backward was given */
  double evals_fwd, evals_bwd; /* pixel rows (x16) evaluated */
  mgs_raster_profile prof;
};

/* raster_project.c */
void mgs_raster_project_all(mgs_raster *r);
/* Only the listed Gaussians (increasing indices); all others culled (radius 0, no tiles). */
void mgs_raster_project_list(mgs_raster *r, const uint32_t *idx, size_t m);
void mgs_raster_project_backward16(mgs_raster *r, const uint32_t *idx, int nl, float gsum[GS_N][16],
                                   mgs_gaussians *grad, size_t gbase, float *grad_mean2d);
/* raster_sh.c */
void mgs_sh_eval(int deg, const float *dc, const float *rest, const float dir[3], float rgb[3]);
/* dL_drgb: gradient w.r.t. the unclamped colour. Adds into dc, rest, returns dL/ddir. */
void mgs_sh_backward(int deg, const float *dc, const float *rest, const float dir[3],
                     const float dL_drgb[3], float *g_dc, float *g_rest, float dL_ddir[3]);
#if defined(__AVX512F__)
/* The same for 16 Gaussians at once: lane[l] is lane l's Gaussian index relative to the
 * arrays passed (dc: 3 floats per Gaussian, rest: MGS_SH_REST_MAX), lanes outside `mask`
 * are neither read nor written. Results identical to the scalar functions. */
void mgs_sh_eval16(int deg, const float *dc, const float *rest, const int32_t *lane, uint16_t mask,
                   const float dir[3][16], float rgb[3][16]);
void mgs_sh_backward16(int deg, const float *rest, const int32_t *lane, uint16_t mask, const float dir[3][16],
                       const float dL_drgb[3][16], float *g_dc, float *g_rest, float dL_ddir[3][16]);
#endif
/* raster_bin.c */
mgs_status mgs_raster_bin(mgs_raster *r, mgs_error *err);
/* raster_forward.c / raster_backward.c */
void mgs_raster_render_tiles(mgs_raster *r);
void mgs_raster_backward_tiles(mgs_raster *r, const float *dL_dcolor, const float *dL_dalpha,
                               const float *dL_ddepth);
/* raster_context.c */
double mgs_raster_cpu_now(void); /* process CPU time, seconds */
mgs_status mgs_raster_reserve(mgs_raster *r, size_t n, size_t tiles, size_t pix, mgs_error *err);
mgs_status mgs_raster_reserve_isect(mgs_raster *r, size_t n_isect, mgs_error *err);
mgs_status mgs_raster_reserve_maps(mgs_raster *r, size_t n, size_t pix, mgs_error *err);
/* raster_maps.c: each Gaussian's unit normal facing the camera into map_gnormal (once per forward) */
void mgs_raster_gauss_normals(mgs_raster *r);
/* raster_maps_backward.c: the 3DGS normal map's gradient w.r.t. Gaussian i's quaternion,
 * from gn = sum over pixels of w dL/dN (the slot's GS_NX..GS_NZ), added into dq */
void mgs_raster_normal_rot_grad(const mgs_raster *r, size_t i, const float gn[3], float *dq);
mgs_status mgs_raster3d_map_grads(mgs_raster *r, mgs_raster_map_grad *out, mgs_error *err);
/* raster_blend.c */
void mgs_raster_blend_free(mgs_raster *r);

/* raster_2dgs_project.c / raster_2dgs_tiles.c: the surfel model's projection (idx NULL:
 * all), compositing, backward and maps */
mgs_status mgs_raster2d_reserve(mgs_raster *r, size_t n, size_t pix, mgs_error *err);
void mgs_raster2d_project(mgs_raster *r, const uint32_t *idx, size_t m);
void mgs_raster2d_render_tiles(mgs_raster *r, int geo); /* geo: also the geometry maps (s_geo) */
void mgs_raster2d_geometry(mgs_raster *r); /* the normal/median/distortion pass, once per forward */
mgs_status mgs_raster2d_backward_tiles(mgs_raster *r, const float *dL_dcolor, const float *dL_dalpha,
                                       const float *dL_ddepth, mgs_error *err);
/* per Gaussian [b, e): sum its slots, chain into grad (row 0 = Gaussian gbase) */
void mgs_raster2d_reduce_span(mgs_raster *r, size_t b, size_t e, mgs_gaussians *grad, size_t gbase, float *grad_mean2d);
void mgs_raster2d_free(mgs_raster *r);
/* the blending statistics' pass over the last surfel forward (raster_blend.c) */
void mgs_raster2d_blend_tiles(mgs_raster *r, int32_t *max_index, float *final_T, float *slot_w);

/* The forward's per-pixel evaluation, shared so forward and backward agree bit for bit. */
#define MGS_ALPHA_MIN (1.0f / 255.0f)
#define MGS_ALPHA_MAX 0.99f
#define MGS_T_MIN 1e-4f
#endif

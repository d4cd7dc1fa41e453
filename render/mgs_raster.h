/* The differentiable tile rasterizer of 3D Gaussians (the 3DGS forward/backward on CPU).
 *
 * Forward: EWA projection (perspective Jacobian, 0.3 px low-pass dilation), near-plane and
 * frustum culling, 3-sigma screen radius, SH colour up to degree 3 from the view
 * direction, 16x16 tiles, sort by (tile, depth), per-tile front-to-back compositing with
 * alpha <= 0.99, contributions below 1/255 skipped, early stop at T < 1e-4.
 * Backward: gradients for every parameter group of the model plus the per-Gaussian norm
 * of the view-space (NDC) 2D-mean gradient that adaptive density control uses.
 *
 * Deliberate differences from the reference (diff-gaussian-rasterization), none of which
 * changes the forward image:
 *  - gradients are the exact derivatives of the forward: none flows through an alpha
 *    clamped at 0.99 (the reference passes it), the Jacobian's x/z, y/z clamp also halves
 *    the depth derivative of J (the reference keeps the unclamped formula), the conic and
 *    screen-mean derivatives omit the reference's 1e-7 guards;
 *  - the principal point may be anywhere (the reference assumes the image centre; the
 *    Jacobian clamp is generalized so that it reduces to +-1.3 tan(fov/2) there);
 *  - binning drops tiles of the 3-sigma rectangle that the alpha >= 1/255 ellipse misses
 *    (they receive nothing either way), and Gaussians with opacity < 1/255 are not binned
 *    (radii still reported as the reference's);
 *  - Gaussians with a non-finite parameter, projection or colour are culled (radius 0).
 * Sorting is by float depth, ties by index, as the reference's stable 64-bit key sort.
 *
 * The model's kind chooses the rasterizer (one interface for every caller):
 * MGS_MODEL_2DGS models (surfels, core/mgs_gaussians.h) go through the 2DGS rasterizer of
 * hbb1/diff-surfel-rasterization, render/raster_2dgs_*.c: per pixel the ray meets the
 * surfel's plane through the homogeneous splat-to-pixel map T, rho = min(u^2 + v^2,
 * 2 |pixel - centre|^2) (screen-space fallback, a sqrt(2)/2 px filter around the centre of
 * the 3-sigma box), alpha = min(0.99, o e^(-rho/2)), ray-splat depths < 0.2 skipped, the
 * same 1/255 skip, T < 1e-4 stop, 16x16 tiles, binning and depth sort (by the centre's
 * depth); every pixel of the tiles of the 3-sigma box is evaluated, as the authors'. It
 * also composites the normal (world, turned to the camera), the median depth and the
 * depth distortion sum_i sum_j<i w_i w_j (m_i - m_j)^2, m = f/(f-n) (1 - n/z), n 0.2,
 * f 100, in the same pass; their gradients enter through mgs_raster_map_grads. The
 * depth output is sum_i w_i z_i with z_i the ray-splat depth; the 2D-mean gradient norm is
 * the authors' (dL/dT's centre column times the depth, in NDC). Deliberate differences
 * from the authors': exact derivatives everywhere (the depth's dependence on the
 * intersection also in the fallback case, none through a clamped alpha).
 *
 * A context keeps the buffers of the last forward pass (reused between calls, so steady-
 * state training allocates nothing); backward uses them and must follow the forward it
 * belongs to with the same model and camera unchanged. Not thread-safe per context; the
 * work inside is parallel (mgs_parallel_for). */
#ifndef MGS_RASTER_H
#define MGS_RASTER_H
#include <stddef.h>
#include <stdint.h>
#include "core/mgs_error.h"
#include "core/mgs_gaussians.h"
#include "core/mgs_camera.h"
#include "render/mgs_render_maps.h"

#ifdef __cplusplus
extern "C" {
#endif

#define MGS_TILE_SIZE 16

typedef struct mgs_raster_settings {
  float background[3];   /* composited behind the Gaussians */
  int sh_degree;         /* active SH degree, <= model's sh_degree */
  float scale_modifier;  /* multiplies all scales (1) */
  float dilation;        /* low-pass added to the 2D covariance diagonal, px^2 (0.3) */
  float near_plane;      /* Gaussians with camera depth z <= this are culled (0.2, the
                            reference's fixed value; the camera's znear is not used so that
                            training matches the reference) */
} mgs_raster_settings;

void mgs_raster_settings_default(mgs_raster_settings *s);

typedef struct mgs_raster_output {
  int width, height;
  const float *color;   /* height*width*3, composited over the background */
  const float *alpha;   /* height*width, 1 - final transmittance */
  const float *depth;   /* height*width, sum_i w_i z_i (alpha-weighted camera depth; divide
                           by alpha for the expected depth of the covered part) */
  const int *radii;     /* per Gaussian screen radius in px, 0 when culled */
  size_t n_visible;     /* Gaussians that survived culling */
  size_t n_intersections; /* (Gaussian, tile) pairs */
} mgs_raster_output;

typedef struct mgs_raster mgs_raster;
mgs_raster *mgs_raster_create(void);
void mgs_raster_destroy(mgs_raster *r);

/* Statistics of the last forward/backward on this context (for the benchmark): number of
 * Gaussian x pixel evaluations performed (counted per 16-pixel tile row). */
void mgs_raster_last_evals(const mgs_raster *r, double *forward, double *backward);
/* Wall time (ms) of the phases of the last forward/backward on this context, and the
 * process CPU time (ms, all threads) over the same intervals. */
typedef struct mgs_raster_profile {
  double project_ms, bin_ms, render_ms;    /* forward */
  double tiles_ms, reduce_ms;              /* backward: per-tile gradients, per-Gaussian chain */
  double project_cpu, bin_cpu, render_cpu, tiles_cpu, reduce_cpu;
} mgs_raster_profile;
void mgs_raster_last_profile(const mgs_raster *r, mgs_raster_profile *p);

/* Bytes each phase of the last forward/backward read and wrote, counted from the data
 * layout (render/raster_bytes.c): for every array a phase sweeps, its element size times
 * the Gaussians, binned Gaussians, intersections, tiles or pixels it touched. Logical
 * bytes: a gathered 48-byte splat counts 48 whatever cache lines it spans, each sweep of
 * an array counts (a second sweep may hit the cache), per-thread scratch that stays in L1
 * (a sink's 64-Gaussian gradient block, tile registers) does not. 3DGS only (a 2DGS
 * forward leaves everything 0); a listed forward (mgs_raster_forward_list) is counted as
 * the whole model's. */
typedef struct mgs_raster_counts {
  size_t n;           /* Gaussians of the model */
  size_t n_front;     /* passed the near plane and finiteness test (scales read) */
  size_t n_shaded;    /* reached the SH colour (radius > 0) */
  size_t n_binned;    /* touch >= 1 tile */
  size_t n_isect;     /* tile intersections */
  size_t n_tiles, n_pix;
  size_t n_pix_listed;/* pixels of tiles with a non-empty list (the backward reads only those) */
  size_t fwd_visit;   /* intersections the forward tiles visited (early stop) */
  size_t bwd_visit;   /* intersections the backward tiles evaluated (up to each tile's last contributor) */
  size_t n_live;      /* binned Gaussians with a nonzero summed gradient (the chain ran) */
  size_t n_vis_blocks;/* sink backward on visible blocks: 64-Gaussian blocks with one of radius > 0 */
  int sh_degree, sort_passes, bin_chunks;
  int bwd_kind;       /* 0 no backward, 1 into gradient arrays (+=), 2 into a sink's block */
  int bwd_alpha, bwd_depth, bwd_mean2d, bwd_visible_only;
} mgs_raster_counts;
typedef struct mgs_raster_bytes {
  double project[2], bin[2], render[2]; /* [0] read, [1] written */
  double tiles[2], reduce[2];           /* backward tiles, per-Gaussian chain (sink excluded) */
} mgs_raster_bytes;
/* The layout's bytes for the given counts (pure arithmetic). */
void mgs_raster_bytes_of(const mgs_raster_counts *c, mgs_raster_bytes *b);
/* The counts of the last forward (and backward, if one followed) on r, and their bytes
 * (either pointer may be NULL). Walks the context's per-Gaussian arrays: call it outside
 * timed regions. */
void mgs_raster_last_bytes(const mgs_raster *r, mgs_raster_counts *c, mgs_raster_bytes *b);

/* Output pointers stay valid until the next forward on this context or its destruction. */
mgs_status mgs_raster_forward(mgs_raster *r, const mgs_gaussians *g, const mgs_camera *cam,
                              const mgs_raster_settings *s, mgs_raster_output *out, mgs_error *err);

/* The same forward projecting only the listed Gaussians (idx: strictly increasing
 * indices < g->n); all others are treated as culled. The result equals
 * mgs_raster_forward's when every Gaussian the latter keeps is listed:
 * render/mgs_visibility.h computes such lists from spatial tiles. */
mgs_status mgs_raster_forward_list(mgs_raster *r, const mgs_gaussians *g, const mgs_camera *cam,
                                   const mgs_raster_settings *s, const uint32_t *idx, size_t n_idx,
                                   mgs_raster_output *out, mgs_error *err);

/* The geometry maps (render/mgs_render_maps.h) of the last forward on this context, those
 * in `which` (MGS_MAP_* flags; alpha always): expected depth from the forward's own sum
 * of w z; median depth and normals by one more pass over the forward's tile lists with
 * its alpha decisions, so a forward that is not followed by this call costs nothing more.
 * The forward's model must be unchanged. Valid until the next forward on this context. */
mgs_status mgs_raster_maps(mgs_raster *r, unsigned which, mgs_render_maps *out, mgs_error *err);

/* Gradient arrays of the loss w.r.t. the last forward's geometry maps (height*width each;
 * normal 3 per pixel, world space), zeroed at the first call after a forward; loss terms
 * add into them, and the backward of that forward reads them. depth_median: dL/d(the
 * median depth map of mgs_raster_maps, 0 where alpha < 0.5: no gradient there); normal:
 * dL/d(sum_i w_i n_i); distortion: dL/d(distortion). A 3DGS forward hands out the normal
 * only (depth_median and distortion NULL): its gradient reaches opacity, means, scales and
 * rotations through the blending weights and the rotations through n_i (the smallest
 * axis: no derivative w.r.t. the scales that choose it nor the mean that turns it, see
 * render/raster_maps_backward.c); a backward not preceded by this call costs what it did. */
/* Tells the context that the next forward will be followed by mgs_raster_maps(which): a
 * surfel (2DGS) forward then writes its median depth, normal and distortion maps in its own
 * pass instead of a second one (the same values, bit for bit; colour, alpha, depth and
 * gradients unchanged). For that forward only; a 3DGS forward ignores it (its maps pass
 * stays separate). Without the hint mgs_raster_maps still works, at one more pass. */
void mgs_raster_hint_maps(mgs_raster *r, unsigned which);

typedef struct mgs_raster_map_grad {
  float *depth_median, *normal, *distortion;
} mgs_raster_map_grad;
mgs_status mgs_raster_map_grads(mgs_raster *r, mgs_raster_map_grad *out, mgs_error *err);
/* Blending statistics of the last forward on this context (what Mini-Splatting reads), by
 * one more pass over its tile lists with its alpha decisions (a forward not followed by
 * this call costs nothing more); w = alpha*T is a Gaussian's blending weight in a pixel.
 * Both models: a surfel forward's pass takes its rules (ray-splat rho, depth < 0.2 skip).
 * The forward's model must be unchanged; valid until the next forward on this context. */
typedef struct mgs_raster_blend {
  int width, height;
  size_t n;                 /* Gaussians of the forward */
  const int32_t *max_index; /* per pixel: the first Gaussian (depth order) with the largest w; -1 none */
  const float *final_T;     /* per pixel: transmittance after the last contribution */
  const uint32_t *area_max; /* per Gaussian: pixels where it is max_index */
  const float *importance;  /* per Gaussian: sum of its w over the view's pixels */
} mgs_raster_blend;
mgs_status mgs_raster_blend_stats(mgs_raster *r, mgs_raster_blend *out, mgs_error *err);

/* dL_dcolor: height*width*3 (required); dL_dalpha, dL_ddepth: height*width or NULL.
 * Gradients are ADDED into `grad` (a model with the same n; its groups are used as
 * gradient arrays of the same shapes). grad_mean2d (n floats, may be NULL) receives the
 * norm of dL/d(mean2d) in NDC units (pixel gradient times half the image size, as the
 * reference), 0 for culled Gaussians. */
mgs_status mgs_raster_backward(mgs_raster *r, const float *dL_dcolor, const float *dL_dalpha,
                               const float *dL_ddepth, mgs_gaussians *grad, float *grad_mean2d,
                               mgs_error *err);

/* The same backward with the per-Gaussian gradients handed out block by block instead of
 * added into a gradient model (so that an optimizer step can consume them while they are
 * in cache: they never reach memory). `sink` is called once for each block [first,
 * first + count) of a partition of the n Gaussians, concurrently from worker threads and
 * in no particular order, with the block's gradients as rows 0..count-1 of `block`
 * (SH-rest coefficients beyond the forward's degree and all of culled Gaussians are zero;
 * valid during the call only). `model` must be the forward's model. Nothing reads a block's rows of the forward's model after
 * its sink call, so the sink may update them; another backward then needs a new forward.
 * Values identical to mgs_raster_backward into zeroed gradients. */
typedef void (*mgs_raster_grad_sink)(void *ctx, size_t first, size_t count, const mgs_gaussians *block);
mgs_status mgs_raster_backward_sink(mgs_raster *r, mgs_gaussians *model, const float *dL_dcolor,
                                    const float *dL_dalpha, const float *dL_ddepth, float *grad_mean2d,
                                    mgs_raster_grad_sink sink, void *sink_ctx, mgs_error *err);

/* The same, calling the sink only for blocks holding a Gaussian with radius > 0 (culled
 * Gaussians have zero gradients: a consumer that leaves them alone, as sparse Adam, needs
 * no call; the cost then follows what the view saw). */
mgs_status mgs_raster_backward_sink_visible(mgs_raster *r, mgs_gaussians *model, const float *dL_dcolor,
                                            const float *dL_dalpha, const float *dL_ddepth, float *grad_mean2d,
                                            mgs_raster_grad_sink sink, void *sink_ctx, mgs_error *err);

#ifdef __cplusplus
}
#endif
#endif

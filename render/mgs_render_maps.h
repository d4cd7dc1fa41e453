/* Per-pixel geometry maps of a rendered view, model-neutral: what depth fusion, the
 * render command and (later) geometry losses read, whichever splat model (3DGS, 2DGS)
 * rendered them. A model's rasterizer fills them on request after its forward, so a
 * forward that is not asked for them costs nothing extra.
 *
 * Conventions (all height*width, row-major; camera depth z along the optical axis):
 *   alpha          1 - final transmittance
 *   depth_expected sum_i w_i z_i / alpha (w_i = alpha_i T_i); 0 where alpha == 0
 *   depth_median   z of the primitive at which T first drops below 0.5; 0 where T never
 *                  does (alpha < 0.5: such pixels count as background)
 *   normal         3 per pixel: sum_i w_i n_i, world space, n_i unit and facing the
 *                  camera (not renormalized: its length is the covered fraction)
 * A map that was not requested is NULL. 0 means "no depth" in both depth maps (the
 * convention of depth images and Open3D). */
#ifndef MGS_RENDER_MAPS_H
#define MGS_RENDER_MAPS_H

#ifdef __cplusplus
extern "C" {
#endif

enum {
  MGS_MAP_DEPTH_EXPECTED = 1u << 0,
  MGS_MAP_DEPTH_MEDIAN = 1u << 1,
  MGS_MAP_NORMAL = 1u << 2,
  MGS_MAP_ALL = 7u,
  MGS_MAP_DISTORTION = 1u << 3 /* 2DGS only: sum_i sum_j<i w_i w_j (m_i - m_j)^2 (raster.h) */
};

typedef struct mgs_render_maps {
  int width, height;
  const float *alpha;
  const float *depth_expected;
  const float *depth_median;
  const float *normal;
  const float *distortion;
} mgs_render_maps;

/* Which depth a consumer uses (depth fusion: per model, measured). */
typedef enum mgs_depth_kind { MGS_DEPTH_MEDIAN = 0, MGS_DEPTH_EXPECTED = 1 } mgs_depth_kind;

#ifdef __cplusplus
}
#endif
#endif

/* Multi-view patch matching of planes (the ACMH-style propagation GaussianPro runs on
 * rendered depth, Cheng et al. 2024, kcheng1021/GaussianPro submodules/Propagation):
 *
 *   mgs_pm_select_neighbors ... which views to match a reference view against, by camera
 *                               overlap of the reference's depth (views are unordered)
 *   mgs_pm_run ................ per-pixel plane hypotheses (depth + normal) of one
 *                               reference view refined by bilateral-weighted NCC against
 *                               its neighbours, red/black checkerboard propagation
 *   mgs_pm_geometric_consistency  how many neighbours' depth maps agree with a pixel's
 *                               depth (forward-backward reprojection, < 2 px, < 1 %)
 *
 * Cameras are core/mgs_camera.h's (OpenCV, pixel centres at +0.5); images are one grey
 * channel on the 0..255 scale the authors' colour sigma assumes. Work is parallel over
 * image rows through mgs_parallel_for; results depend only on the inputs and the seed. */
#ifndef MGS_PATCHMATCH_H
#define MGS_PATCHMATCH_H
#include <stddef.h>
#include <stdint.h>
#include "core/mgs_error.h"
#include "core/mgs_camera.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct mgs_pm_view {
  const mgs_camera *cam;
  const float *gray; /* cam->height x cam->width, row-major, 0..255 */
} mgs_pm_view;

typedef struct mgs_pm_options {
  int patch_size;      /* window side in px (authors' --patch_size 20; radius = size / 2) */
  int patch_step;      /* stride inside the window (authors' radius_increment 2) */
  float sigma_spatial; /* bilateral weights (authors 5 px, 3 grey levels) */
  float sigma_color;
  int iterations;      /* red + black sweeps (authors' max_iterations 6) */
  int top_k;           /* a hypothesis' cost: mean of its best top_k view costs (4) */
  float perturbation;  /* refinement: depth +-perturbation, normal +-perturbation*pi/2 (0.02) */
  float depth_min, depth_max; /* accepted depth range of a hypothesis */
  uint64_t seed;
} mgs_pm_options;

void mgs_pm_options_default(mgs_pm_options *o);

/* Refines one plane per pixel of `ref` against `src[0..n_src)` (1 <= n_src <= 32).
 * init_depth (required): the starting depth per pixel (outside [depth_min, depth_max], e.g.
 * 0 where unknown: a random depth in that range); init_normal (world, 3 per pixel, may be NULL): the
 * starting normal where its length exceeds 0.5 and it faces the camera, a random
 * camera-facing normal elsewhere. Outputs (each may be NULL): depth (camera z), normal
 * (world, unit, facing the camera), cost (0 perfect .. 2 no match). All maps have the
 * reference camera's size; each source image has its own camera's size (at least 1 x 1,
 * (w + 1)(h + 1) < 2^31). */
mgs_status mgs_pm_run(const mgs_pm_view *ref, const mgs_pm_view *src, int n_src, const float *init_depth,
                      const float *init_normal, const mgs_pm_options *o, float *depth, float *normal,
                      float *cost, mgs_error *err);

/* The (at most k) views among cams[0..n) other than `ref` that overlap it best, best
 * first, into out; returns how many. Score of view j: sum over the reference's depth
 * (every `stride`-th pixel with depth > 0) of the points j sees in its image of the
 * MVSNet/COLMAP baseline-angle weight (peak at 5 degrees, sigma 1 below, 10 above), so
 * near-identical viewpoints (no parallax) and views of other parts score low. */
size_t mgs_pm_select_neighbors(const mgs_camera *cams, size_t n, size_t ref, const float *ref_depth, int stride,
                               size_t k, size_t *out);

/* Per reference pixel with depth > 0, the number of source depth maps (each of its own
 * camera's size, 0 = none) that agree: the pixel's point, projected into the source,
 * lifted again with the source's depth there and projected back, lands within max_px of
 * the pixel with a depth within max_rel of the pixel's (authors: 2 px, 0.01). */
void mgs_pm_geometric_consistency(const mgs_camera *ref, const float *ref_depth, const mgs_camera *const *src,
                                  const float *const *src_depth, int n_src, float max_px, float max_rel,
                                  uint8_t *count);

#ifdef __cplusplus
}
#endif
#endif

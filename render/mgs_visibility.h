/* View-dependent culling of whole regions (render/visibility.c): Gaussians binned by
 * spatial tiles (cubes of a fixed side, keyed by integer coordinates as the VDB tiles of
 * the grids), each tile with the bounding box of its Gaussians' means and their largest
 * scale. A view keeps the tiles whose box can hold a Gaussian the rasterizer would not
 * cull, and hands the rasterizer their members (mgs_raster_forward_list): the projection then costs what the view sees.
 *
 * The test is conservative by construction, so the image, radii and gradients are
 * identical to projecting everything: with J's clamp the screen radius of a Gaussian at
 * depth z is at most 3 K s / z + 3 sqrt(2 dilation + 0.32) + 1 px (K the Frobenius bound
 * of the clamped Jacobian times z, s its largest scale), so "its rectangle meets the
 * image" becomes four half-spaces linear in the camera-space mean, offset by 3 K s, plus
 * the near plane; a tile is dropped only when its box lies outside one of them.
 *
 * Bounds must cover the current model: after parameters change, mgs_visibility_refit
 * grows the bounds of the tiles of the changed Gaussians (cheap, exact); after Gaussians
 * are added, removed or replaced, mgs_visibility_invalidate (the next query re-bins).
 * Re-binning (mgs_visibility_rebin) also tightens bounds grown by moving Gaussians. */
#ifndef MGS_VISIBILITY_H
#define MGS_VISIBILITY_H
#include <stddef.h>
#include <stdint.h>
#include "core/mgs_error.h"
#include "core/mgs_gaussians.h"
#include "core/mgs_camera.h"
#include "render/mgs_raster.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct mgs_visibility mgs_visibility;

/* tile_size: side of a tile in world units; 0 = chosen at the first binning so that a
 * tile holds about 256 Gaussians on average over the means' bounding box. */
mgs_visibility *mgs_visibility_create(double tile_size);
void mgs_visibility_destroy(mgs_visibility *v);

/* Bins g from scratch (tight bounds). */
mgs_status mgs_visibility_rebin(mgs_visibility *v, const mgs_gaussians *g, mgs_error *err);
/* The next query re-bins (Gaussians were added, removed or replaced). */
void mgs_visibility_invalidate(mgs_visibility *v);
/* Grows the bounds to cover the current means and scales of the Gaussians whose
 * radii[i] > 0 in the last query's view (those are the ones a sparse step changes), or of
 * all Gaussians when radii is NULL. g must have the binned count. */
void mgs_visibility_refit(mgs_visibility *v, const mgs_gaussians *g, const int *radii);

/* The Gaussians a view must project (members of its tiles), in increasing order, for
 * mgs_raster_forward_list; re-bins first when invalidated or when g's count changed. The
 * list is owned by v and valid until the next call. */
mgs_status mgs_visibility_query(mgs_visibility *v, const mgs_gaussians *g, const mgs_camera *cam,
                                const mgs_raster_settings *s, const uint32_t **idx, size_t *n_idx,
                                mgs_error *err);

typedef struct mgs_visibility_stats {
  double tile_size;
  size_t tiles;            /* occupied tiles */
  size_t tiles_visible;    /* of the last query */
  size_t gaussians_listed; /* members of the last query's visible tiles */
  size_t rebins;           /* since creation */
} mgs_visibility_stats;
void mgs_visibility_get_stats(const mgs_visibility *v, mgs_visibility_stats *st);

#ifdef __cplusplus
}
#endif
#endif

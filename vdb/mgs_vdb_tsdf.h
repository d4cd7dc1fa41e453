/* TSDF fusion of depth maps into a sparse OpenVDB grid, and the narrow-band level set of
 * its zero crossing (vdb/tsdf.cpp). Any renderer's depth maps: camera z along the optical
 * axis, 0 = no depth (nothing known: no update), as render/mgs_render_maps.h gives them;
 * a negative value marks a background pixel whose whole ray is free space: voxels of
 * allocated blocks that project there take +t (space carving: the silhouettes remove the
 * projective TSDF's blobs behind grazing surfaces; Open3D has no such value).
 *
 * Fusion follows the field's standard (KinectFusion; Open3D's ScalableTSDFVolume, which a
 * slow test compares with): only the 8^3 blocks that some pixel's ray passes within the
 * truncation t of its depth are allocated; a voxel at camera depth z that projects onto
 * pixel (u, v) with depth d > 0 and d - z > -t_back along the ray (d - z times the ray's
 * length per unit z; t_back = t unless set) takes min(d - z, t) into a running average with weight 1 per view. Values
 * are world units. Integration is parallel over blocks (each loops over the views). */
#ifndef MGS_VDB_TSDF_H
#define MGS_VDB_TSDF_H
#include <stddef.h>
#include "core/mgs_camera.h"
#include "core/mgs_error.h"
#include "vdb/mgs_vdb.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct mgs_vdb_tsdf_params {
  double voxel_size;   /* world units (> 0) */
  double truncation;   /* world units, >= voxel_size */
  double origin[3];    /* the grid's translation (a point near the scene: precision) */
  double truncation_back; /* behind the surface, world units, in [voxel_size, truncation]; 0: the
                             same as truncation (symmetric). A voxel further behind a view's depth
                             than this takes no update from that view */
  /* Thin parts (0: off). A truncation wider than a part fuses the views of its two sides
   * into one slab as wide as the truncation (docs/notes/depth-fusion.md). With
   * truncation_thin > 0 a second fusion at that (narrow) truncation runs in the same pass,
   * and each voxel counts the views that see it as free space by more than twice it. Where
   * the wide fusion calls a voxel inside although at least thin_free_views views (and a
   * share thin_free_share of its views) see it as clearly free, the wide fusion has merged
   * two sides: around such voxels (within the wide truncation) the level set takes the
   * narrow fusion instead. */
  double truncation_thin;  /* world units, in [voxel_size, truncation] or 0 */
  double thin_free_views;  /* >= 1 (2 when 0) */
  double thin_free_share;  /* in [0, 1] (0.5 when 0) */
} mgs_vdb_tsdf_params;

typedef struct mgs_vdb_tsdf mgs_vdb_tsdf;

mgs_status mgs_vdb_tsdf_create(const mgs_vdb_tsdf_params *p, mgs_vdb_tsdf **out, mgs_error *err);
void mgs_vdb_tsdf_destroy(mgs_vdb_tsdf *t);

/* What an integration did (any pointer argument taking it may be NULL). */
typedef struct mgs_vdb_tsdf_info {
  size_t views_used;      /* views with at least one valid depth or background (< 0) pixel */
  size_t pixels_used;     /* valid depth pixels */
  size_t blocks;          /* allocated 8^3 blocks after the call */
  size_t voxels_observed; /* voxels with weight > 0 after the call */
} mgs_vdb_tsdf_info;

/* Fuses n views (depth[k]: cams[k].height * width floats). May be called repeatedly
 * (batches of views). Views without any valid or background (< 0) pixel are skipped (counted in info). */
mgs_status mgs_vdb_tsdf_integrate(mgs_vdb_tsdf *t, size_t n, const mgs_camera *cams, const float *const *depth,
                                  mgs_vdb_tsdf_info *info, mgs_error *err);

/* Copies of the fused grids: "tsdf" (class UNKNOWN: truncated, projective, not a distance
 * field; observed voxels active, others +t) and "tsdf_weight" (views per voxel). */
mgs_status mgs_vdb_tsdf_grids(const mgs_vdb_tsdf *t, mgs_vdb_grid **tsdf, mgs_vdb_grid **weight, mgs_error *err);

/* The level set "sdf" of the fused zero crossing, valid as the α-field's (mgs_vdb.h,
 * CLOSEST: every neighbour pair within one voxel). Voxels seen by at least min_weight
 * views keep their fused value D; the unobserved inside behind the truncation is filled
 * from the observed inside through unobserved voxels only, within the observed box, per
 * connected region (a region the observed outside encloses, a closed surface's inside, is
 * filled whole; one that reaches the box's margin, an open shell or a floater's fragment,
 * only w + 9 voxels from its observed inside: no global flood fill, which leaks to all of
 * space; a warning when such regions hold over a tenth of the observed inside); the field
 * 1/2 - D/(2t) (1 on the filled inside, 0 elsewhere) goes through the CLOSEST construction
 * at tau = 1/2, so the band holds distances to the fused zero crossing (and to the edge
 * of an open shell's limited fill, which then is a surface too: never a sign flip
 * without a distance). Empty fused volume or no
 * surface: MGS_ERR_FORMAT. */
mgs_status mgs_vdb_tsdf_to_sdf(const mgs_vdb_tsdf *t, int half_width, float min_weight, mgs_vdb_grid **out,
                               mgs_error *err);

/* Voxels the last mgs_vdb_tsdf_to_sdf took from the thin-part (narrow) fusion. */
size_t mgs_vdb_tsdf_thin_voxels(const mgs_vdb_tsdf *t);

#ifdef __cplusplus
}
#endif
#endif

/* The SDF of any splat model from its renders (issue 22, item 4): render depth and alpha
 * at a run's cameras (RUN/cameras.json) or at virtual views around the model, mask
 * background (alpha < 0.5, and the training images' own alpha where the run's dataset
 * has one), fuse into a sparse TSDF (vdb/mgs_vdb_tsdf.h) and rebuild a valid narrow-band
 * level set of its zero crossing. Sizes default to multiples of the views' pixel
 * footprint (depth / focal length at the surface, median over the views): the
 * truncation that works depends on it, not on scene units (docs/notes/depth-fusion.md).
 * Models plug in as a depth source, so 2DGS can provide its own depth. */
#ifndef MGS_DEPTH_FUSION_H
#define MGS_DEPTH_FUSION_H
#include <stddef.h>
#include "core/mgs_camera.h"
#include "core/mgs_error.h"
#include "core/mgs_gaussians.h"
#include "core/mgs_image.h"
#include "render/mgs_render_maps.h"
#include "vdb/mgs_vdb.h"

/* Renders one view's depth (of `kind`, 0 = none) and alpha, height*width each. */
typedef struct mgs_depth_source {
  mgs_status (*render)(void *ctx, const mgs_camera *cam, mgs_depth_kind kind, float *depth, float *alpha,
                       mgs_error *err);
  void *ctx;
  mgs_depth_kind preferred; /* the model's default depth (measured per model) */
} mgs_depth_source;

/* The 3DGS rasterizer as a depth source (black background, SH degree of the model). */
typedef struct mgs_depth_3dgs mgs_depth_3dgs;
mgs_depth_3dgs *mgs_depth_3dgs_create(const mgs_gaussians *g, mgs_depth_source *out);
void mgs_depth_3dgs_destroy(mgs_depth_3dgs *s);

#define MGS_FUSION_VOXEL_FP 1.0  /* voxel size, pixel footprints */
#define MGS_FUSION_TRUNC_FP 9.0  /* truncation, pixel footprints */
#define MGS_FUSION_THIN_FP 2.0   /* thin-part truncation, pixel footprints */

typedef struct mgs_fusion_opts {
  int depth;                 /* mgs_depth_kind, or -1: the source's preferred */
  double voxel_fp, trunc_fp; /* in pixel footprints */
  double trunc_back_fp;      /* behind the surface, pixel footprints (0: = trunc_fp) */
  double thin_fp;            /* thin-part truncation, pixel footprints (0: off; mgs_vdb_tsdf_params) */
  double voxel_size, truncation; /* world units, override the footprint multiples when > 0 */
  int half_width;            /* band of the level set, voxels (3) */
  float min_weight;          /* views a voxel needs to count as observed (1) */
  float alpha_mask;          /* pixels with rendered alpha below this are background (0.5) */
  int views;                 /* virtual views when there are no cameras (64) */
  int view_size;             /* their image side, px (256) */
  int iteration;             /* run folder: point_cloud/iteration_N (-1: latest) */
  int image_alpha;           /* use the dataset images' alpha as masks when available (1) */
  int carve;                 /* every background pixel carves free space (0: it erodes; docs/notes/depth-fusion.md) */
  int mask_carve_px;         /* pixels whose image mask is background within this many pixels carve free
                                space (4; -1: off): the images' silhouettes remove fragments fused from
                                floaters seen through a semi-transparent model (docs/notes/depth-fusion.md) */
  size_t keep_points;        /* > 0: keep up to this many of the views' surface points in the report (0) */
} mgs_fusion_opts;
void mgs_fusion_opts_default(mgs_fusion_opts *o);

typedef struct mgs_fusion_report {
  size_t views, views_empty;  /* cameras rendered; those with no foreground pixel */
  size_t image_masks;         /* views masked by their image's alpha too */
  int virtual_views;          /* 1 if the views were virtual */
  int depth;                  /* the depth kind used */
  double footprint, voxel_size, truncation, truncation_back, truncation_thin;
  size_t thin_voxels;        /* level-set voxels taken from the thin-part fusion */
  size_t blocks, observed, band_voxels;
  double seconds;
  char ply[1024];             /* the model fused */
  float *points;              /* opts.keep_points: foreground pixels back-projected at their depth, world
                                 xyz, an even subsample of every view's (malloc'd: the caller frees) */
  size_t n_points;
} mgs_fusion_report;

/* Virtual cameras on a sphere (Fibonacci) around the model's opaque core, looking at its
 * centre, fov 40 degrees, size x size pixels. */
mgs_status mgs_virtual_views(const mgs_gaussians *g, int n, int size, mgs_camera **out, mgs_error *err);

/* Fuses given cameras (masks[k] may be NULL or a 1-channel image of the camera's size:
 * its alpha < 0.5 is background). sdf (required), tsdf/weight (may be NULL). */
mgs_status mgs_fuse_depth(const mgs_depth_source *src, size_t n, const mgs_camera *cams, const mgs_image *const *masks,
                          const mgs_fusion_opts *o, mgs_vdb_grid **sdf, mgs_vdb_grid **tsdf, mgs_vdb_grid **weight,
                          mgs_fusion_report *rep, mgs_error *err);

/* A run folder (cameras.json, latest or o->iteration .ply, dataset alpha if cfg_args
 * leads to it) or a bare 3DGS .ply (virtual views), fused with the 3DGS source. */
mgs_status mgs_fuse_path(const char *path, const mgs_fusion_opts *o, mgs_vdb_grid **sdf, mgs_vdb_grid **tsdf,
                         mgs_vdb_grid **weight, mgs_fusion_report *rep, mgs_error *err);
/* The model file a path stands for (run folder -> its .ply of `iteration`), malloc'd. */
char *mgs_fusion_model_path(const char *path, int iteration, mgs_error *err);
#endif

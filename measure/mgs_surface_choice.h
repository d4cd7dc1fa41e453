/* Which surface of a model to export when there is no ground truth: the depth-fused one
 * or the α-field's (issue 22: the fused surface is ~4x better on solid shapes, the
 * α-surface on parts a few pixels thick, where a wide truncation merges two faces into one
 * slab). Each is scored against the model's own renders: the views' foreground pixels
 * back-projected at their depth (mgs_fusion_opts.keep_points). The score is a Chamfer
 * distance to those points, both directions capped: points -> surface (exact, Embree point
 * queries) penalises a surface displaced from what the views see (the slab), surface ->
 * points (its vertices to the nearest point) a surface where nothing is seen (the α-field's
 * interior sheets). The lower score wins (docs/notes/depth-fusion.md, "Choosing"). */
#ifndef MGS_SURFACE_CHOICE_H
#define MGS_SURFACE_CHOICE_H
#include <stddef.h>
#include "core/mgs_error.h"
#include "core/mgs_mesh.h"

typedef struct mgs_surface_agreement {
  double to_surface;   /* mean over the points of min(distance to the surface, cap) */
  double from_surface; /* mean over the surface's vertices of min(distance to the nearest point, cap) */
  double score;        /* (to_surface + from_surface) / 2 */
} mgs_surface_agreement;

/* cap: distances beyond it count as cap (a few pixel footprints: MGS_SURFACE_CAP_FP). */
#define MGS_SURFACE_CAP_FP 4.0
#define MGS_SURFACE_POINTS 200000 /* rendered points kept for the choice (mgs_fusion_opts.keep_points) */
mgs_status mgs_surface_agreement_measure(const float *points, size_t n_points, const mgs_mesh *surface, double cap,
                                         mgs_surface_agreement *out, mgs_error *err);

/* Both surfaces scored; returns 1 when the α-surface agrees better (strictly), 0 for the
 * fused one, -1 on error. Either mesh may be NULL (empty surface): the other wins. */
int mgs_surface_choose(const float *points, size_t n_points, const mgs_mesh *fused, const mgs_mesh *alpha, double cap,
                       mgs_surface_agreement *fused_out, mgs_surface_agreement *alpha_out, mgs_error *err);

/* The α-field's surface of a 3DGS .ply as `morsegs vdb` makes it by default (resolution 256,
 * τ = 0.5, the closest-point SDF), in world coordinates; *out NULL when it is empty. */
mgs_status mgs_alpha_surface_mesh(const char *ply_path, mgs_mesh **out, mgs_error *err);
#endif

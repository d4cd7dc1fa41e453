/* Internal to core/: PlayCanvas/SuperSplat's compressed 3DGS .ply (what SuperSplat and
 * splat-transform export as *.compressed.ply): element `chunk` (per 256 splats: position and
 * log-scale bounds, optionally colour bounds), element `vertex` (packed_position,
 * packed_rotation, packed_scale, packed_color: uint32 each) and an optional element `sh`
 * (uchar f_rest_0..8|23|44). mgs_ply_read_gaussians reads it as a 3DGS model. */
#ifndef MGS_PLY_COMPRESSED_H
#define MGS_PLY_COMPRESSED_H
#include "core/mgs_gaussians.h"
#include "core/ply_format.h"

/* 1 if the vertex element has the packed_* properties (the compressed layout). */
int ply_is_compressed_gaussians(const ply_file *pf);
/* Decodes it: *g with everything but the means (left 0), and the means in double
 * (*xyz64, 3n, malloc'd), so the caller places them in its local frame. Errors name the
 * file and the property or element that does not fit the layout. */
mgs_status ply_read_compressed_gaussians(ply_file *pf, mgs_gaussians **g, double **xyz64, mgs_error *err);
#endif

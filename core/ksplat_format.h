/* Internal to core/: the `.ksplat` of mkkellogg's GaussianSplats3D (the three.js viewer's own
 * format): a 4096-byte header, 1024-byte section headers, then per section its spatial
 * buckets (centres, partial sizes) and fixed-size splat records at compression level 0
 * (float32), 1 (float16, positions as 16-bit offsets from their bucket's centre) or 2 (as 1,
 * with 8-bit SH between the header's bounds). Scales are linear, colour and opacity bytes,
 * SH up to degree 2 written (3 read). Values in the .ply's frame. mgs_ply_read_gaussians
 * reads a file named *.ksplat with it, as a 3DGS model. */
#ifndef MGS_KSPLAT_FORMAT_H
#define MGS_KSPLAT_FORMAT_H
#include "core/mgs_gaussians.h"

int ksplat_is_path(const char *path); /* the name ends in .ksplat */
/* Decodes it: *g with everything but the means, and the means in double (*xyz64, 3n).
 * Refused naming the file: an unknown version or compression level, sections or buckets
 * that do not fit the file, splat counts that do not add up, a bucket index out of range,
 * a non-finite value. */
mgs_status ksplat_read_gaussians(const char *path, mgs_gaussians **g, double **xyz64, mgs_error *err);
#endif

/* Internal to core/: PlayCanvas's SOG (what SuperSplat and splat-transform publish for the
 * web), version 2: a `meta.json` (count, position bounds, 256-entry codebooks) beside
 * lossless WebP textures, one texel per Gaussian — positions as 16 bits in two textures
 * (log-transformed, between the bounds), the rotation's smallest three at 8 bits with the
 * largest's index in alpha, scale and DC-colour codebook indices with the opacity in sh0's
 * alpha, and the higher SH as labels into a k-means palette of codebook indices. Read as
 * the folder (a path named meta.json) or the `.sog` zip bundle of the same files. The
 * values are in the .ply's frame (no axis conversion). mgs_ply_read_gaussians reads such
 * paths with it, as a 3DGS model. */
#ifndef MGS_SOG_FORMAT_H
#define MGS_SOG_FORMAT_H
#include "core/mgs_gaussians.h"

int sog_is_path(const char *path); /* ends in .sog, or its file name is meta.json */
/* Decodes it: *g with everything but the means, and the means in double (*xyz64, 3n).
 * Refused naming the file: a meta.json that is not SOG version 2 (version 1 is named as
 * such), a missing or ill-formed field, a texture missing from the folder or bundle or
 * smaller than the count, a file name that leaves the folder, a palette label out of range. */
mgs_status sog_read_gaussians(const char *path, mgs_gaussians **g, double **xyz64, mgs_error *err);
#endif

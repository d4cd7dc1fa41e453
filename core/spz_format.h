/* Internal to core/: Niantic's `.spz` (nianticlabs/spz; what Scaniverse exports and what
 * glTF's compressed splats carry): versions 1-3 one gzip stream (16-byte header, then
 * positions, alphas, colours, scales, rotations, SH), version 4 a 32-byte "NGSP" header, a
 * table of contents and one zstd stream per attribute. Positions are 24-bit fixed point
 * (float16 in version 1), rotations three 8-bit components (versions 1-2) or the smallest
 * three at 10 bits (3-4); SH degree up to 4.
 *
 * Frame: the format stores RUB (x right, y up, z back) unless the file carries the
 * SPZ_ADOBE_coordinate_system extension; the reader converts to RDF, the frame of the
 * reference 3DGS .ply, as Niantic's library and splat-transform do when they read to PLY
 * (y and z negated: a rotation by pi about x, so shapes are unchanged). Files written
 * without the conversion (spz-js, Niantic's library before it had coordinate systems)
 * come out rotated by pi about x against the .ply they were made from.
 * mgs_ply_read_gaussians reads a file named *.spz with it, as a 3DGS model. */
#ifndef MGS_SPZ_FORMAT_H
#define MGS_SPZ_FORMAT_H
#include "core/mgs_gaussians.h"

int spz_is_path(const char *path); /* the name ends in .spz */
/* Decodes it: *g with everything but the means, and the means in double (*xyz64, 3n).
 * SH degree 4 keeps degrees 0-3 (warning); the antialiasing flag is reported (warning).
 * Refused naming the file: neither gzip nor NGSP, an unknown version, a count the data
 * cannot hold, streams of the wrong size, corrupt compression, a coordinate system of
 * the rotated family (convert it to RUB first). */
mgs_status spz_read_gaussians(const char *path, mgs_gaussians **g, double **xyz64, mgs_error *err);
#endif

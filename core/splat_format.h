/* Internal to core/: the antimatter15 `.splat` file (the web viewers' format: no header, 32
 * bytes a splat: float32 x y z, float32 linear scales, uint8 RGBA (the DC colour 0.5 +
 * SH_C0 f_dc and the opacity after the sigmoid, x 255), uint8 rotation (q / |q| x 128 +
 * 128, in rot_0..3 order); no SH rest). mgs_ply_read_gaussians reads a file named *.splat
 * with it, as a 3DGS model of SH degree 0. */
#ifndef MGS_SPLAT_FORMAT_H
#define MGS_SPLAT_FORMAT_H
#include "core/mgs_gaussians.h"

int splat_is_path(const char *path); /* the name ends in .splat */
/* Decodes it: *g with everything but the means, and the means in double (*xyz64, 3n). A
 * size that is not a positive multiple of 32 bytes, or a scale that is not positive and
 * finite, is refused naming the file (and the splat). */
mgs_status splat_read_gaussians(const char *path, mgs_gaussians **g, double **xyz64, mgs_error *err);
#endif

/* Scene origins: the double-precision point a scene's local float32 frame is centred on.
 * Coordinates as users have them can be georeferenced (UTM eastings ~1e5..1e6 m), where a
 * float32 resolves only ~0.008..0.06 units; everything that computes in float (training,
 * rasterizer, grids, Morse analysis) works relative to an origin chosen here, and every
 * output adds it back in double.
 *
 * The rule (mgs_origin_choose): a scene whose centre lies within MGS_ORIGIN_FAR extents of
 * (0,0,0) keeps the origin (0,0,0) — a centred scene is computed exactly as before — and a
 * far one gets its centre snapped to a power-of-two grid no finer than its extent. The
 * snap makes the origin a short binary number, so origin + local is exact in double for
 * any float local coordinate of the scene (outputs lose nothing), and a scene translated
 * by a multiple of that grid gets the very same local coordinates (same training). */
#ifndef MGS_ORIGIN_H
#define MGS_ORIGIN_H
#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Far means |centre| (largest axis) > MGS_ORIGIN_FAR * extent: there float32 has lost
 * about 1e-6 of the extent, so below it nothing is gained by moving the frame. */
#define MGS_ORIGIN_FAR 16.0

/* (0,0,0) for a centred scene, else the centre snapped to the power-of-two grid
 * 2^ceil(log2(extent)). extent <= 0 or non-finite counts as 1; a non-finite centre
 * gives (0,0,0). */
void mgs_origin_choose(const double centre[3], double extent, double origin[3]);
int mgs_origin_is_zero(const double origin[3]);
/* "x y z" with round-trip precision (%.17g), as recorded in cfg_args (scene_origin). */
void mgs_origin_format(const double origin[3], char *buf, size_t len);
/* Parses mgs_origin_format's text; 1 on success (three finite numbers), else 0. */
int mgs_origin_parse(const char *text, double origin[3]);

#ifdef __cplusplus
}
#endif
#endif

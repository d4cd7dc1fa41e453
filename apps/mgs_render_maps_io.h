/* Files of the geometry maps (apps/render_maps_io.c) for `morsegs render`. */
#ifndef MGS_RENDER_MAPS_IO_H
#define MGS_RENDER_MAPS_IO_H
#include "core/mgs_error.h"
#include "render/mgs_render_maps.h"

typedef struct mgs_maps_io_opts {
  int depth, normal, alpha; /* which to write */
  int png16;                /* depth as 16-bit PNG of depth * depth_scale (else float EXR) */
  double depth_scale;       /* (1000: millimetres for metre scenes, the depth-image convention) */
} mgs_maps_io_opts;

/* DIR/NAME_depth_expected.exr, NAME_depth_median.exr (or .png), NAME_depth.png (turbo),
 * NAME_normal.exr, NAME_normal.png, NAME_alpha.png (16-bit), those asked for. */
mgs_status mgs_write_render_maps(const char *dir, const char *name, const mgs_render_maps *m, const mgs_maps_io_opts *o,
                                 mgs_error *err);
#endif

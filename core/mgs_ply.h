/* The 3DGS .ply layout every splat viewer reads (SPEC §4): binary little-endian, per vertex
 * float x y z nx ny nz f_dc_0..2 f_rest_0..(3*R-1) opacity scale_0..2 rot_0..3, with
 * R = (deg+1)^2-1 rest coefficients per channel, stored channel-major
 * (f_rest_{c*R + k}). Reading infers the SH degree from the f_rest count, accepts extra
 * properties, any property order and ascii / binary_little_endian / binary_big_endian,
 * and rejects anything malformed with a message naming the file (MGS_ERR_FORMAT; a
 * NaN/Inf value is MGS_ERR_NUMERIC naming the vertex index and property). Element counts
 * are checked against the file size before anything is allocated. Also reads plain point
 * clouds (x y z [red green blue] as uchar, ushort or float) for initial points and writes
 * them in the reference's storePly layout (x y z nx ny nz red green blue). The Gaussian
 * readers also take SuperSplat's *.compressed.ply (core/ply_compressed.h) and, by its name,
 * the web viewers' *.splat (core/splat_format.h), Niantic's *.spz (core/spz_format.h) and
 * PlayCanvas's *.sog or its meta.json (core/sog_format.h) and GaussianSplats3D's *.ksplat
 * (core/ksplat_format.h). */
#ifndef MGS_PLY_H
#define MGS_PLY_H
#include <stddef.h>
#include "core/mgs_error.h"
#include "core/mgs_gaussians.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Either model kind: a file with scale_0 and scale_1 but no scale_2 is a 2DGS model
 * (kind MGS_MODEL_2DGS, log_scale[2] = MGS_SURFEL_LOG_SCALE2), and a 2DGS model is
 * written with those two columns, as hbb1/2d-gaussian-splatting does. */
/* Means as stored (world), origin (0,0,0). */
mgs_status mgs_ply_read_gaussians(const char *path, mgs_gaussians **out, mgs_error *err);
/* Means relative to `origin` (subtracted in double before they become float; sets
 * g->origin); origin NULL: chosen from the means (their mean against their RMS spread,
 * core/mgs_origin.h: (0,0,0) for a centred model). */
mgs_status mgs_ply_read_gaussians_local(const char *path, const double *origin, mgs_gaussians **out, mgs_error *err);
/* Writes the model at its sh_degree; refuses non-finite values (MGS_ERR_NUMERIC);
 * atomic (temp + rename). A model with a non-zero origin is written in world coordinates
 * with double x y z (origin + mean in double); otherwise the reference's all-float layout. */
mgs_status mgs_ply_write_gaussians(const char *path, const mgs_gaussians *g, mgs_error *err);

/* mgs_ply_read_gaussians_local, failing (MGS_ERR_FORMAT, naming the file and both kinds)
 * when the file holds the other kind of model. */
mgs_status mgs_ply_read_gaussians_kind(const char *path, mgs_model_kind kind, const double *origin, mgs_gaussians **out,
                                       mgs_error *err);

typedef struct mgs_point_cloud {
  size_t n;
  float *xyz;    /* n*3 */
  float *rgb;    /* n*3 in [0,1]; grey 0.5 when the file has no colours */
  double *xyz64; /* n*3: the positions as the file holds them (float or double), from
                    which a dataset makes xyz relative to its origin; NULL after that */
} mgs_point_cloud;

void mgs_point_cloud_destroy(mgs_point_cloud *pc);
mgs_status mgs_ply_read_points(const char *path, mgs_point_cloud **out, mgs_error *err);
mgs_status mgs_ply_write_points(const char *path, const mgs_point_cloud *pc, mgs_error *err);

#ifdef __cplusplus
}
#endif
#endif

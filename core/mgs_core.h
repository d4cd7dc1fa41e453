/* core/: what every other module builds on. It owns
 *   errors and logging ........ mgs_error.h, mgs_log.h
 *   threads and randomness .... mgs_parallel.h (TBB shim), mgs_rng.h
 *   math ...................... mgs_math.h
 *   the Gaussian model ........ mgs_gaussians.h (structure of arrays)
 *   cameras ................... mgs_camera.h
 *   files ..................... mgs_fs.h (atomic writes), mgs_image.h (OpenImageIO shim),
 *                               mgs_ply.h (3DGS .ply), mgs_mesh.h (assimp),
 *                               mgs_dataset.h (NeRF-synthetic, nerfstudio, COLMAP)
 * core depends on no other module of the project. */
#ifndef MGS_CORE_H
#define MGS_CORE_H
#include "core/mgs_error.h"
#include "core/mgs_log.h"
#include "core/mgs_parallel.h"
#include "core/mgs_rng.h"
#include "core/mgs_math.h"
#include "core/mgs_gaussians.h"
#include "core/mgs_camera.h"
#include "core/mgs_fs.h"
#include "core/mgs_image.h"
#include "core/mgs_ply.h"
#include "core/mgs_mesh.h"
#include "core/mgs_dataset.h"
#endif

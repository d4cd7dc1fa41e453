/* Signed distance field of a closed triangle mesh as an OpenVDB narrow-band level set
 * (tools::meshToLevelSet): the ground-truth SDF that `morsegs experiment` compares the
 * model's SDF with (Betti numbers, bottleneck distance between the two diagrams). Part of
 * the vdb module (mgs_vdb.h owns the grid handle); a header of its own so that the SDF of
 * the α-field (vdb/sdf.cpp) and this one can change independently. */
#ifndef MGS_VDB_MESH_SDF_H
#define MGS_VDB_MESH_SDF_H
#include "core/mgs_error.h"
#include "core/mgs_mesh.h"
#include "vdb/mgs_vdb.h"

#ifdef __cplusplus
extern "C" {
#endif

/* LEVEL_SET grid named "sdf" of mesh m: world-space distances, negative inside (sign by
 * OpenVDB's flood fill from outside, so the mesh should be closed), voxel size h with
 * voxel centres at ijk * h (translation 0, as the α-field grids), active band of
 * half-width `half_width` voxels, background half_width * h, interior -half_width * h
 * tiles. Errors: h not positive/finite, half_width outside [1, 1000], an empty mesh. */
mgs_status mgs_vdb_sdf_from_mesh(const mgs_mesh *m, double voxel_size, int half_width,
                                 mgs_vdb_grid **out, mgs_error *err);

#ifdef __cplusplus
}
#endif
#endif

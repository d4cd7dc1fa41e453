/* Validation of a narrow-band level set before its persistence is computed (used by
 * `morsegs persistence`; the engine checks only that interior tiles never touch the
 * background directly).
 *
 * A grid passes when
 *   1. its background b is finite and > 0 (OpenVDB's level-set convention: +half-width);
 *   2. every active voxel is finite with |value| ≤ b (values beyond ± background mean the
 *      band was clipped or the grid is not a level set);
 *   3. every inactive tile holds ±b;
 *   4. the field is a distance: across each face of an active voxel (to an active or
 *      inactive neighbour) the value changes by at most 3h (h = voxel size; an exact SDF
 *      changes by at most h; OpenVDB's fast-sweeping fogToSdf was measured at 2.03h across
 *      the interface of a trained scene, so the bound leaves room for that). This
 *      catches the usual broken bands: an active voxel far from the zero crossing whose
 *      sign disagrees with its neighbours, an interior left at +b (no sign flood fill),
 *      and distances stored in index units instead of world units.
 * The message names the file, the grid, the first offending voxel and the rule. */
#ifndef MGS_LEVELSET_CHECK_H
#define MGS_LEVELSET_CHECK_H
#include "core/mgs_error.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct mgs_vdb_grid mgs_vdb_grid;

#define MGS_LEVELSET_MAX_JUMP_VOXELS 3.0

/* source: the file name used in messages (may be NULL). */
mgs_status mgs_topo_check_level_set(const mgs_vdb_grid *g, const char *source, mgs_error *err);

#ifdef __cplusplus
}
#endif
#endif

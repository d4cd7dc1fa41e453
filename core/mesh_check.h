/* Internal to core/: checks a mesh file against its own header before assimp reads it.
 * Assimp trusts element counts (a truncated binary PLY reaches its post-processing with
 * faces pointing into vertices that were never read, and crashes there; an OFF header
 * claiming a billion faces makes it construct them all). These checks walk the whole
 * body of a PLY (binary or ASCII) with core's bounds-checked PLY walker, and compare the
 * counts an OFF or binary STL header claims with the bytes the file has. */
#ifndef MGS_MESH_CHECK_H
#define MGS_MESH_CHECK_H
#include "core/mgs_error.h"

/* MGS_OK when the file is no PLY/OFF/STL or its counts fit its size; otherwise
 * MGS_ERR_FORMAT with a one-line message naming the file and the claim. */
mgs_status mgs_mesh_precheck(const char *path, mgs_error *err);
#endif

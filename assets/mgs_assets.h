/* Built-in procedural scenes: triangle meshes made by the project's own code (implicit
 * surfaces polygonized by our marching tetrahedra, and closed primitives), so a dataset
 * with a known ground truth exists without any downloaded asset. Every builtin is a
 * closed, consistently outward-oriented 2-manifold (each connected part), z up.
 *   sphere  - a bumpy blob, genus 0
 *   genus2  - a double torus (two fused rings), genus 2
 *   thin    - a stand of thin rods and plates, a wire ring, and small floating balls
 *             (many connected parts, thin structures, floater-like bits)
 *   city    - N x N blocks of the above (mgs_assets_city; `morsegs scene --builtin city
 *             --size N`), for measuring how cost scales with the scene */
#ifndef MGS_ASSETS_H
#define MGS_ASSETS_H
#include <stddef.h>
#include "core/mgs_error.h"
#include "core/mgs_mesh.h"

#ifdef __cplusplus
extern "C" {
#endif

size_t mgs_assets_builtin_count(void);
const char *mgs_assets_builtin_name(size_t i);        /* NULL past the end */
const char *mgs_assets_builtin_description(size_t i); /* one line */

/* Makes builtin `name` (MGS_ERR_ARG naming it, and the known names, if unknown). */
mgs_status mgs_assets_builtin(const char *name, mgs_mesh **out, mgs_error *err);
/* Same at a finer level of detail: detail 1 = default; each step refines the
 * polygonization grid / primitive tessellation (about detail^2 times the triangles). */
mgs_status mgs_assets_builtin_detail(const char *name, int detail, mgs_mesh **out, mgs_error *err);

/* The large-scene builtin "city" (assets/builtin_city.c): size x size blocks of 2 x 2
 * world units (the city spans [-size, size]^2 x [-0.1, ~0.75], ground top at z = 0), each
 * with four small instanced builtins or towers; NOT normalized, so the content of a block
 * is the same at every size. size 1..64, detail as above. */
mgs_status mgs_assets_city(int size, int detail, mgs_mesh **out, mgs_error *err);

#ifdef __cplusplus
}
#endif
#endif

/* Triangle meshes: read (OBJ, PLY, OFF, anything assimp reads, triangulated, merged into
 * one vertex/index list, with the file's appearance when it has one: texture coordinates,
 * the diffuse texture's path, vertex colours), write (PLY binary or OBJ by extension,
 * atomically; geometry only), normalize and measure. */
#ifndef MGS_MESH_H
#define MGS_MESH_H
#include <stddef.h>
#include <stdint.h>
#include "core/mgs_error.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct mgs_mesh {
  size_t nv, nt;
  float *v;      /* nv*3 positions */
  uint32_t *t;   /* nt*3 vertex indices, counter-clockwise = outward */
  /* Optional appearance (NULL when the file has none). Stored per triangle corner, not per
     vertex: the read welds vertices by position (topology needs it) and a texture seam
     gives one position two UVs. A triangle that has no value holds NaN. */
  float *uv;     /* nt*3*2 texture coordinates of the diffuse texture (u right, v up: v = 0
                    is the image's bottom row, as assimp and OpenGL) */
  float *rgb;    /* nt*3*3 vertex colours in [0, 1] */
  char *texture; /* the diffuse texture (aiTextureType_DIFFUSE) of the first material that
                    has one, resolved against the mesh file's folder; `uv` is set only on
                    the triangles of materials using this file. Not checked to exist. */
} mgs_mesh;

mgs_mesh *mgs_mesh_create(size_t nv, size_t nt);
void mgs_mesh_destroy(mgs_mesh *m);
/* A deep copy, appearance included; NULL when out of memory. */
mgs_mesh *mgs_mesh_clone(const mgs_mesh *m);
/* Fails (MGS_ERR_FORMAT, naming the file) on an empty mesh, indices out of range or
 * non-finite vertices. Vertices at identical positions are welded (OBJ splits them by
 * normal), so boundary counts see the real topology; vertex order is not preserved.
 * Header counts are checked against the file size first, and assimp runs in a forked
 * child process under an address-space cap, so a corrupt file is an error, never a crash
 * of the caller (core/mesh_check.h, mesh_assimp.c).
 * Not for concurrent use from several threads (assimp's logger is process-global). */
mgs_status mgs_mesh_read(const char *path, mgs_mesh **out, mgs_error *err);
/* Binary PLY, OBJ or OFF by extension; refuses non-finite vertices and bad indices. */
mgs_status mgs_mesh_write(const char *path, const mgs_mesh *m, mgs_error *err);
void mgs_mesh_bounds(const mgs_mesh *m, double lo[3], double hi[3]);
/* v += sign * offset, in double (sign -1: world -> a local frame at origin `offset`,
 * core/mgs_origin.h). A zero offset changes nothing. */
void mgs_mesh_translate(mgs_mesh *m, const double offset[3], int sign);
/* Translate/scale so the bounding box is centred at the origin and its largest side is
 * `size`; returns the scale applied, centre in `center_out` (may be NULL). */
double mgs_mesh_normalize(mgs_mesh *m, double size, double center_out[3]);
double mgs_mesh_area(const mgs_mesh *m);
/* The volume the triangles enclose, signed: positive when they are wound outward
 * (counter-clockwise seen from outside); meaningful for a closed mesh. */
double mgs_mesh_signed_volume(const mgs_mesh *m);
/* Edges used by other than exactly two triangles (0 for a closed 2-manifold). */
size_t mgs_mesh_count_boundary_or_nonmanifold_edges(const mgs_mesh *m);

#ifdef __cplusplus
}
#endif
#endif

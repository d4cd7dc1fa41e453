/* Private to assets/: a growable mesh builder with closed primitives, and the
 * marching-tetrahedra polygonizer of implicit surfaces. */
#ifndef MGS_ASSETS_INTERNAL_H
#define MGS_ASSETS_INTERNAL_H
#include <stddef.h>
#include <stdint.h>
#include "core/mgs_error.h"
#include "core/mgs_mesh.h"

typedef struct mgs_mesh_builder {
  float *v; uint32_t *t;
  size_t nv, nt, cap_v, cap_t;
  int failed; /* allocation failed at some point */
} mgs_mesh_builder;

uint32_t mgs_mb_vertex(mgs_mesh_builder *b, double x, double y, double z);
void mgs_mb_triangle(mgs_mesh_builder *b, uint32_t a, uint32_t c, uint32_t d);
/* Closed primitives (each one its own connected, outward-oriented part). */
void mgs_mb_box(mgs_mesh_builder *b, const double lo[3], const double hi[3]);
void mgs_mb_cylinder(mgs_mesh_builder *b, const double a[3], const double c[3], double radius, int segments);
void mgs_mb_sphere(mgs_mesh_builder *b, const double c[3], double radius, int rings, int segments);
/* Torus around `axis` (unit) through c, major radius R, minor r. */
void mgs_mb_torus(mgs_mesh_builder *b, const double c[3], const double axis[3], double R, double r, int major_seg, int minor_seg);
/* Moves the builder's arrays into a new mgs_mesh (builder emptied). */
mgs_status mgs_mb_finish(mgs_mesh_builder *b, const char *name, mgs_mesh **out, mgs_error *err);
void mgs_mb_free(mgs_mesh_builder *b);

/* f < 0 inside. Must be thread-safe (evaluated in parallel). */
typedef double (*mgs_implicit_fn)(const double p[3], const void *ctx);
/* Marching tetrahedra (Kuhn split of each cube, shared edge vertices welded) over the
 * grid of n[0] x n[1] x n[2] cubes spanning [lo, hi]. Values on the grid border are
 * forced positive, so the result is always closed; no grid value is exactly zero, so it
 * is always a 2-manifold. Triangles face +f (outward). */
mgs_status mgs_assets_polygonize(mgs_implicit_fn f, const void *ctx, const double lo[3], const double hi[3],
                                 const int n[3], const char *name, mgs_mesh **out, mgs_error *err);

mgs_status mgs_builtin_sphere(int detail, mgs_mesh **out, mgs_error *err);
mgs_status mgs_builtin_genus2(int detail, mgs_mesh **out, mgs_error *err);
mgs_status mgs_builtin_thin(int detail, mgs_mesh **out, mgs_error *err);
#endif

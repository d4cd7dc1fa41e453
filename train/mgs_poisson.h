/* Surface reconstruction from oriented points and mesh decimation, through Debian's CGAL
 * (libcgal-dev 5.5, header-only; train/poisson_cgal.cpp is the shim). What SuGaR's mesh
 * (train/sugar_mesh.c) needs from a library; never a home-made solver.
 *
 * Why CGAL: the authors call Open3D's screened Poisson (Kazhdan's PoissonRecon). Debian 12
 * has Open3D's C++ headers only in libopen3d-dev, whose dependency set (GUI, filament,
 * fmt, ...) this build does not carry; CGAL's Poisson (Kazhdan, Bolitho & Hoppe 2006,
 * solved on a refined Delaunay triangulation, surface by Delaunay refinement) is
 * header-only and needs only GMP/MPFR/Eigen. Differences from
 * Open3D's: no screening term and no octree depth (CGAL's `distance` criterion, in average
 * point spacings, sets the accuracy), and no per-vertex density output (SuGaR's trimming
 * is done on a density proxy instead: train/sugar_mesh.c). */
#ifndef MGS_POISSON_H
#define MGS_POISSON_H
#include <stddef.h>
#include "core/mgs_error.h"
#include "core/mgs_mesh.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct mgs_poisson_options {
  double angle;    /* surface mesher: min triangle angle, degrees (20, CGAL's example) */
  double radius;   /* max triangle size, in average spacings (3: CGAL's example uses 30, which gives
                      ~700 vertices on a sphere; SuGaR wants a dense mesh, then decimates) */
  double distance; /* max distance to the implicit surface, in average spacings (0.375) */
} mgs_poisson_options;
void mgs_poisson_options_default(mgs_poisson_options *o);

/* Points p[3m] with unit normals n[3m] (pointing outward) -> a closed triangle mesh of the
 * Poisson indicator's level set (the component(s) the mesher finds from the function's
 * inner point). MGS_ERR_NUMERIC when the solver fails (too few / degenerate points). */
mgs_status mgs_poisson_reconstruct(const double *p, const double *n, size_t m, const mgs_poisson_options *o,
                                   mgs_mesh **out, mgs_error *err);
/* Edge-collapse decimation (Garland–Heckbert plane quadrics, as Open3D's
 * simplify_quadric_decimation) to at most `max_triangles`; the mesh is replaced. Meshes
 * that are not a valid oriented 2-manifold (with boundary) are left as they are
 * (*decimated = 0). */
mgs_status mgs_mesh_decimate(mgs_mesh **m, size_t max_triangles, int *decimated, mgs_error *err);

#ifdef __cplusplus
}
#endif
#endif

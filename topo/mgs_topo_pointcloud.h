/* Persistence of point clouds (homology dimensions 0..2) through small explicit simplicial
 * complexes whose simplices are valued by their longest edge, and the qhull Delaunay
 * triangulation they are built on. It serves Topology-GS (SPEC §5.3): the Vietoris–Rips
 * complex of a 16-point neighbourhood (LPVI) and the Delaunay "weak alpha" complex of an
 * image's pixels in RGB space (PersLoss). Voxel-grid persistence lives in mgs_persistence.h.
 *
 * Every finite bar end is the length of one *critical edge* (a vertex is born at 0), so a
 * bar records the two points of its birth and death edges: the gradient of an end with
 * respect to the points is ±(y_i − y_j)/‖y_i − y_j‖ on those two points. Bars of zero
 * persistence are not reported (GUDHI's persistence() drops them too). Coefficients Z/2
 * (no torsion in complexes embedded in R^3, so equal to GUDHI's Z/11 diagrams). */
#ifndef MGS_TOPO_POINTCLOUD_H
#define MGS_TOPO_POINTCLOUD_H
#include <stddef.h>
#include <stdint.h>
#include "core/mgs_error.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct mgs_topo_bar {
  int dim;                /* 0, 1, 2 */
  double birth, death;    /* death == INFINITY: essential class */
  int32_t birth_edge[2];  /* points of the edge whose length is the birth; -1 for vertex births */
  int32_t death_edge[2];  /* the same for the death; -1 for essential classes */
} mgs_topo_bar;

typedef struct mgs_topo_bars {
  size_t n, capacity;
  mgs_topo_bar *bars;
} mgs_topo_bars;

void mgs_topo_bars_init(mgs_topo_bars *b);
void mgs_topo_bars_free(mgs_topo_bars *b);

/* Delaunay triangulation of n points of dimension d (2 or 3, coordinates packed) by qhull
 * (reentrant libqhull_r, options "d Qbb Qc Qz Q12 Qt"; retried with joggle "QJ" when the
 * input is degenerate). *simplices (malloc'ed, caller frees) receives *count simplices of
 * d+1 point indices. Fewer than d+2 points, or points qhull cannot triangulate even
 * joggled (all equal, collinear in 3-D, ...), give *count = 0 and MGS_OK: a defined empty
 * result rather than an error. *joggled (may be NULL) tells whether QJ was needed. */
mgs_status mgs_topo_delaunay(const double *pts, size_t n, int d, int32_t **simplices, size_t *count,
                             int *joggled, mgs_error *err);

/* Circumcentres of the Delaunay simplices of the points (the finite Voronoi vertices, as
 * scipy.spatial.Voronoi's `vertices`), near-duplicates (cospherical input split by Qt)
 * merged; non-finite ones dropped. *centres malloc'ed (d doubles each). */
mgs_status mgs_topo_voronoi_vertices(const double *pts, size_t n, int d, double **centres, size_t *count,
                                     mgs_error *err);

/* Vietoris–Rips persistence of n points in R^3 with edges of length <= max_edge and
 * simplices up to dimension 2 (as GUDHI's RipsComplex(max_edge_length).create_simplex_tree(
 * max_dimension=2)): bars of dimensions 0 and 1 only (H2 of a 2-skeleton is not computed). */
mgs_status mgs_topo_rips_persistence(const double *pts, size_t n, double max_edge, mgs_topo_bars *out,
                                     mgs_error *err);

/* "Weak alpha" persistence of n points in R^3: the Delaunay triangulation with every simplex
 * valued by its longest edge, dimensions 0..2 (as GUDHI's DelaunayComplex /
 * AlphaComplex's triangulation re-valued by edge lengths). Exact duplicate points are merged
 * first (bars then name the first of them); fewer than 5 distinct points, or a degenerate
 * set, use the complete complex on the points or the joggled triangulation (see above).
 * A single distinct point gives one essential H0 bar. */
mgs_status mgs_topo_weak_alpha_persistence(const double *pts, size_t n, mgs_topo_bars *out, mgs_error *err);

#ifdef __cplusplus
}
#endif
#endif

/* Topology-GS's LPVI (Shen et al., AAAI 2025; SPEC §5.3): a densification of the initial
 * points, run once before training. It owns mgs_init_lpvi and its k-d tree (train/knn_tree.c).
 *
 * For each point not yet visited, in index order: its K_max nearest neighbours (itself
 * included); the finite Voronoi vertices of that neighbourhood are the candidates; the
 * order-1 Wasserstein distance (Euclidean ground metric) between the Vietoris–Rips
 * diagrams (edges <= max_edge, simplices up to dimension 2, H0 and H1 in one diagram) of
 * the neighbourhood before and after adding them. Below tau the candidates are accepted
 * and the K_max neighbours marked visited; otherwise the point and its first K_min
 * neighbours are projected on their 2-D PCA plane, that plane's Voronoi vertices are
 * lifted back to 3-D, and those K_min points are marked visited.
 *
 * faithful = 1 reproduces the authors' code: the lift adds the point instead of the
 * neighbourhood mean, candidates are never filtered, tau and max_edge are absolute scene
 * units, and only the new points are returned. faithful = 0 (default) corrects that: the
 * lift is from the mean, candidates must lie within the neighbourhood's bounding ball
 * (centre the mean, radius the largest distance to it; a disk in the plane for the 2-D
 * branch), tau and max_edge are scaled by extent / MGS_LPVI_REF_EXTENT, a neighbourhood
 * flat to rounding, or with no candidate inside its ball, goes to the 2-D branch (the 3-D
 * Voronoi vertices of coplanar points are not finite; those of a curved surface patch lie
 * near its medial axis, far from the patch), and the original points are kept (first, in
 * order). In both modes new
 * points get the inverse-distance-weighted colour of the neighbourhood they came from.
 *
 * Order and parallelism: which points are processed depends on the order (a point visited
 * by an earlier neighbourhood is skipped), but what one point computes depends only on the
 * input cloud. So points are computed speculatively in parallel batches of the next
 * unvisited indices and committed in index order; a point visited by an earlier commit of
 * its batch is discarded (counted in `discarded`). The result is identical to the
 * sequential loop for any thread count. */
#ifndef MGS_LPVI_H
#define MGS_LPVI_H
#include <stddef.h>
#include "core/mgs_error.h"

#ifdef __cplusplus
extern "C" {
#endif

/* NeRF-synthetic's scene extent (1.1 x its camera radius 4.0311): the corrected mode's
 * thresholds equal the authors' absolute ones at this scale. */
#define MGS_LPVI_REF_EXTENT 4.4342

typedef struct mgs_lpvi_options {
  int faithful;       /* 0: corrected (default), 1: the authors' behaviour */
  int k_max;          /* 16 */
  int k_min;          /* 8 */
  double tau;         /* 0.25 */
  double max_edge;    /* 2.0: Rips edge cap */
  double extent;      /* scene extent (corrected mode's scale); <= 0: MGS_LPVI_REF_EXTENT */
} mgs_lpvi_options;
void mgs_lpvi_options_default(mgs_lpvi_options *o);

typedef struct mgs_lpvi_stats {
  size_t input;        /* points in */
  size_t processed;    /* neighbourhoods evaluated and committed */
  size_t accepted_3d;  /* of which W1 < tau */
  size_t tangent_2d;   /* of which the 2-D branch */
  size_t added;        /* new points */
  size_t discarded;    /* speculative evaluations thrown away (parallel overhead) */
  double seconds;
} mgs_lpvi_stats;

/* xyz, rgb: n points (rgb may be NULL: grey). *out_xyz / *out_rgb malloc'ed (caller frees),
 * *out_n points: corrected mode the n originals then the new points; faithful mode the new
 * points only (MGS_ERR_NUMERIC if there are none). Fewer points than k_max: the
 * neighbourhood is the whole cloud; fewer than 5 (no 3-D Delaunay) give no candidates. */
mgs_status mgs_init_lpvi(const float *xyz, const float *rgb, size_t n, const mgs_lpvi_options *o,
                         float **out_xyz, float **out_rgb, size_t *out_n, mgs_lpvi_stats *stats,
                         mgs_error *err);

/* k nearest points of q among xyz (itself included when q is a point), by (distance,
 * index); a k-d tree built once. Exposed for tests. */
typedef struct mgs_kdtree mgs_kdtree;
mgs_kdtree *mgs_kdtree_build(const float *xyz, size_t n);
void mgs_kdtree_destroy(mgs_kdtree *t);
/* Writes min(k, n) indices (nearest first) and squared distances; returns the count. */
size_t mgs_kdtree_knn(const mgs_kdtree *t, const double q[3], size_t k, size_t *idx, double *d2);

#ifdef __cplusplus
}
#endif
#endif

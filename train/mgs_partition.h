/* Spatial partition of a scene into blocks for distributed training (train/partition.c):
 * tiles (cubes of a fixed side, as the visibility's) ordered along a Morton space-filling
 * curve, cut into `ranks` contiguous runs of about equal cost (by default the points in
 * them; with costs, the sum of the points' costs, e.g. mgs_partition_pixel_costs), so each
 * block is compact in space. A point belongs to the block whose run holds its tile's
 * curve position (every point of space has exactly one owner, also points born later
 * outside the initial tiles). Pure computation: the same input gives the same partition
 * on every rank, so none is sent. */
#ifndef MGS_PARTITION_H
#define MGS_PARTITION_H
#include <stddef.h>
#include <stdint.h>
#include "core/mgs_error.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct mgs_partition {
  int ranks;
  double tile;            /* tile side, world units */
  double t0[3];           /* curve origin, in tiles (from the points' lower corner) */
  uint64_t *split;        /* ranks + 1 curve positions: rank r owns [split[r], split[r+1]) */
  double (*lo)[3], (*hi)[3]; /* per rank: box of its tiles that held points (empty: lo > hi) */
  size_t *count;          /* per rank: points owned at build time */
  double *cost;           /* per rank: their summed cost (= count without costs) */
} mgs_partition;

struct mgs_camera;
struct mgs_dataset;

/* tile <= 0: chosen as the visibility's automatic side (~256 points a tile). Errors:
 * ranks < 1, no finite point. */
mgs_status mgs_partition_build(const float *xyz, size_t n, int ranks, double tile, mgs_partition **out, mgs_error *err);
/* The same, each point weighted by cost[i] >= 0 (NULL: 1 each; all 0: by count). */
mgs_status mgs_partition_build_weighted(const float *xyz, const double *cost, size_t n, int ranks, double tile,
                                        mgs_partition **out, mgs_error *err);
void mgs_partition_destroy(mgs_partition *p);
/* A training iteration costs per Gaussian (projection, sorting, Adam) and per pixel
 * (blending): cost[i] = 1/N + p_i/P, half the total for the points and half for the pixels,
 * where p_i shares each view's pixels equally among the points that project into it (no
 * occlusion) and P is every view's pixels. No view sees anything: 1/N each. */
mgs_status mgs_partition_pixel_costs(const float *xyz, size_t n, const struct mgs_camera *cams, size_t n_cams, double *cost,
                                     mgs_error *err);
/* The partition distributed training uses: the dataset's initial points, by points only
 * (by_pixels = 0) or by mgs_partition_pixel_costs over its training views. Every rank
 * computes the same. */
mgs_status mgs_partition_for_dataset(const struct mgs_dataset *ds, int ranks, int by_pixels, mgs_partition **out, mgs_error *err);
/* The owner of a point (non-finite coordinates: rank 0). */
int mgs_partition_owner(const mgs_partition *p, const float xyz[3]);

/* perm[j] = the point that comes j-th along the Morton curve of tiles of side `tile`
 * (ties by index; non-finite points first). Used to lay Gaussians out in memory in
 * spatial order, so the few a view sees share cache lines and pages. */
mgs_status mgs_partition_morton_order(const float *xyz, size_t n, double tile, uint32_t *perm, mgs_error *err);

/* Views ordered for locality: chunk_of[v] = the chunk of `chunk` consecutive views along
 * the Morton curve of their camera centres (n x 3 floats). */
mgs_status mgs_partition_view_chunks(const float *centers, size_t n, double tile, size_t chunk, uint32_t *chunk_of,
                                     mgs_error *err);
/* Reorders perm (a permutation of 0..n-1) so each chunk's views are consecutive: chunks
 * in the order their first view appears in perm, views within a chunk in perm's order
 * (a random perm stays random at both levels). scratch: 2n entries. */
void mgs_partition_order_by_chunks(const uint32_t *chunk_of, size_t n, uint32_t *perm, uint32_t *scratch);

#ifdef __cplusplus
}
#endif
#endif

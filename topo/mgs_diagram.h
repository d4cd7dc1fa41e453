/* Persistence diagrams: the data type the persistence engine (mgs_persistence.h)
 * produces and every diagram tool, plot, export and trainer hook consumes.
 *
 * A pair records a homology class of dimension 0, 1 or 2 born when the filtration reaches
 * `birth` and dying at `death` (INFINITY for essential classes). For gradients and for
 * placing features in the world, each end carries the critical cell that creates/destroys
 * the class and the voxel whose value sets that end (the cell's maximal vertex in the
 * lower-star V-construction; the voxel itself in the T-construction). */
#ifndef MGS_DIAGRAM_H
#define MGS_DIAGRAM_H
#include <stddef.h>
#include <stdint.h>
#include "core/mgs_error.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct mgs_pair_end {
  int32_t voxel[3];  /* index-space coordinate of the voxel whose value sets this end */
  double pos[3];     /* world position of the critical cell's centre */
  uint64_t cell;     /* cell id in the complex (engine-specific, for debugging) */
} mgs_pair_end;

typedef struct mgs_pair {
  int dim;           /* 0, 1, 2 */
  double birth, death; /* death == INFINITY for essential classes */
  mgs_pair_end b, d; /* d is undefined (voxel = {0,0,0}) when death is infinite */
  int truncated;     /* 1 if the death was set by the band clamp (true bar may be longer) */
} mgs_pair;

typedef struct mgs_diagram {
  size_t n, capacity;
  mgs_pair *pairs;
  /* statistics of the computation that made it */
  size_t n_cells;        /* cells of the complex (implicit ones counted) */
  size_t n_critical;     /* critical cells after the discrete gradient */
  size_t n_active_voxels;
  double seconds;
} mgs_diagram;

mgs_diagram *mgs_diagram_create(void);
void mgs_diagram_destroy(mgs_diagram *d);
mgs_status mgs_diagram_push(mgs_diagram *d, const mgs_pair *p, mgs_error *err);
/* Sorts by (dim, birth, death) for stable output and comparisons. */
void mgs_diagram_sort(mgs_diagram *d);
static inline double mgs_pair_persistence(const mgs_pair *p) { return p->death - p->birth; }

#ifdef __cplusplus
}
#endif
#endif

/* Spawn and prune sets for the trainer (SPEC §5.2 items 4–5, §6).
 *
 * Spawn: pairs selected by dimension / persistence / birth / death / position
 * (mgs_diagram_filter) and their world positions, at the birth cell (the seed's literal
 * placement: "index-0 critical points" = minima = births of H0 classes) or at the death
 * cell (SPEC §6: surface gaps are small tunnels, H1 pairs dying at small positive SDF
 * values; the death cell marks the hole).
 *
 * Prune: components of the sublevel set {d ≤ level} (level 0: the solid) on the voxel
 * grid, found by flood fill (6-connectivity, as the V-construction's edges; 26 for the
 * T-construction), with their voxel count, volume, opacity mass (Σ density·h³ when a
 * density field is given) and deepest voxel; the Gaussians whose kσ support (the ball of
 * radius k·max std-dev about the mean) touches a component's voxels are its prune
 * candidates. The "principled" floater rule (components other than the largest with little
 * volume or opacity mass) is mgs_topo_floater_components.
 *
 * Index/world convention (as vdb/mgs_vdb.h): world(ijk) = ijk·h + t, ijk = voxel centre.
 * Dense layout (as topo/mgs_persistence.h): values[(x*ny + y)*nz + z] is voxel
 * origin + (x, y, z). */
#ifndef MGS_TOPO_SELECT_H
#define MGS_TOPO_SELECT_H
#include <stddef.h>
#include <stdint.h>
#include "core/mgs_error.h"
#include "core/mgs_gaussians.h"
#include "topo/mgs_diagram.h"
#include "topo/mgs_diagram_tools.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct mgs_vdb_grid mgs_vdb_grid;

/* ---------------------------------------------------------------- spawn */
typedef enum mgs_topo_place {
  MGS_TOPO_PLACE_BIRTH = 0, /* birth cell (literal placement) */
  MGS_TOPO_PLACE_DEATH = 1  /* death cell (surface-gap placement; essential pairs skipped) */
} mgs_topo_place;

/* World positions xyz[n*3] (malloc'ed) of the pairs accepted by f, and their indices in
 * d->pairs (pair_idx may be NULL). n = 0 and NULL arrays when nothing is selected. */
mgs_status mgs_topo_select_positions(const mgs_diagram *d, const mgs_diagram_filter *f,
                                     mgs_topo_place where, double **xyz, size_t **pair_idx,
                                     size_t *n, mgs_error *err);

/* Preset filters for the two spawn rules of SPEC §6:
 *  surface gaps: dimension 1, 0 < death ≤ max_death, persistence ≥ min_persistence
 *                (place at the death cell);
 *  literal:      dimension 0, finite, persistence ≥ min_persistence (place at the birth). */
void mgs_topo_filter_surface_gaps(mgs_diagram_filter *f, double min_persistence, double max_death);
void mgs_topo_filter_literal_minima(mgs_diagram_filter *f, double min_persistence);

/* ---------------------------------------------------------------- components */
typedef struct mgs_topo_field {
  const float *values;    /* dims[0]*dims[1]*dims[2], layout above */
  const float *density;   /* optional, same layout (opacity mass); NULL = none */
  int32_t origin[3];      /* index coordinate of element 0 */
  int32_t dims[3];
  double voxel_size;      /* h */
  double translation[3];  /* t */
} mgs_topo_field;

typedef struct mgs_topo_component {
  size_t n_voxels;
  double volume;          /* n_voxels · h³ */
  double mass;            /* Σ density · h³ over its voxels (0 without density) */
  double min_value;       /* deepest value and where */
  int32_t min_voxel[3];
  int32_t lo[3], hi[3];   /* index bounding box, inclusive */
  double centroid[3];     /* world */
} mgs_topo_component;

typedef struct mgs_topo_components {
  size_t n;                   /* components, sorted by n_voxels descending (0 = largest) */
  mgs_topo_component *comp;
  int32_t *label;             /* per voxel of the box: component id or -1 */
  int32_t origin[3], dims[3];
  double voxel_size, translation[3];
} mgs_topo_components;

/* Components of {value ≤ level}; connectivity 6 or 26. */
mgs_status mgs_topo_components_dense(const mgs_topo_field *f, double level, int connectivity,
                                     mgs_topo_components **out, mgs_error *err);
/* Same over a VDB grid (and optional density grid with the same transform): the active
 * bounding box (plus one voxel) is sampled into a dense block; interior tiles count.
 * Refuses (MGS_ERR_NOMEM) boxes above max_voxels (0 = 2^31). */
mgs_status mgs_topo_components_vdb(const mgs_vdb_grid *sdf, const mgs_vdb_grid *density,
                                   double level, int connectivity, size_t max_voxels,
                                   mgs_topo_components **out, mgs_error *err);
void mgs_topo_components_destroy(mgs_topo_components *c);
/* Component id of a voxel, -1 if none or outside the box. */
int32_t mgs_topo_component_at(const mgs_topo_components *c, const int32_t ijk[3]);

/* The principled floater rule: ids of components other than the largest whose volume is
 * < max_volume OR whose mass is < max_mass (pass 0 to disable a test). Returns the count;
 * ids (may be NULL) must hold c->n entries. */
size_t mgs_topo_floater_components(const mgs_topo_components *c, double max_volume,
                                   double max_mass, int32_t *ids);

/* Prune candidates: indices (ascending, malloc'ed) of the Gaussians whose ball of radius
 * k_sigma · max std-dev about the mean intersects a voxel cube of any of the listed
 * components. */
mgs_status mgs_topo_gaussians_touching(const mgs_topo_components *c, const int32_t *ids,
                                       size_t n_ids, const mgs_gaussians *g, double k_sigma,
                                       size_t **idx, size_t *n, mgs_error *err);

#ifdef __cplusplus
}
#endif
#endif

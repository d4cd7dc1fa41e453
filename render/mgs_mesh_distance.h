/* Distances between points and triangle meshes (Embree 3 closest-point queries), area-uniform
 * surface sampling, and the geometry metrics built from them: Chamfer distance and F-score
 * between two surfaces, and point-to-surface distances for the floater count (SPEC §7). */
#ifndef MGS_MESH_DISTANCE_H
#define MGS_MESH_DISTANCE_H
#include <stddef.h>
#include <stdint.h>
#include "core/mgs_error.h"
#include "core/mgs_mesh.h"

#ifdef __cplusplus
extern "C" {
#endif

/* A BVH over one mesh for closest-point queries (the mesh may be freed afterwards). */
typedef struct mgs_mesh_distance mgs_mesh_distance;
mgs_status mgs_mesh_distance_create(const mgs_mesh *m, mgs_mesh_distance **out, mgs_error *err);
void mgs_mesh_distance_destroy(mgs_mesh_distance *d);
/* Unsigned distance from each point xyz[n*3] to the surface -> dist[n]; the closest surface
 * point -> closest[n*3] (may be NULL). Parallel. */
void mgs_mesh_distance_query(const mgs_mesh_distance *d, size_t n, const float *xyz, float *dist,
                             float *closest);
/* Signed distance: as above, positive on the side the closest triangle's face normal points
 * to (its winding, counter-clockwise = front). At a convex or concave edge either adjacent
 * face gives the same sign, so only exact ties between non-adjacent faces can differ. */
void mgs_mesh_distance_query_signed(const mgs_mesh_distance *d, size_t n, const float *xyz, float *signed_dist);

/* n points distributed uniformly by area on the surface (seeded, reproducible), written to
 * xyz[n*3]; the face normals of the sampled triangles to normal[n*3] (may be NULL).
 * Fails on a mesh of zero area. */
mgs_status mgs_mesh_sample_surface(const mgs_mesh *m, size_t n, uint64_t seed, float *xyz, float *normal,
                                   mgs_error *err);

typedef struct mgs_geometry_metrics {
  double accuracy;     /* mean distance, samples of `pred` -> `gt` surface */
  double completeness; /* mean distance, samples of `gt` -> `pred` surface */
  double chamfer;      /* (accuracy + completeness) / 2 */
  double offset;       /* mean signed distance, samples of `pred` -> `gt` (positive: outside gt,
                          with gt's winding taken outward by its signed volume): a systematic
                          shrink or growth of the reconstruction shows here, not in Chamfer */
  double threshold;    /* F-score distance threshold (absolute) */
  double precision, recall, fscore; /* share of pred / gt samples within threshold; 2PR/(P+R) */
  size_t samples;      /* per surface */
} mgs_geometry_metrics;

/* Chamfer distance and F-score between surfaces `pred` and `gt`, from `samples` area-uniform
 * samples on each (seeded). threshold: absolute distance for the F-score. */
mgs_status mgs_mesh_compare(const mgs_mesh *pred, const mgs_mesh *gt, size_t samples, double threshold,
                            uint64_t seed, mgs_geometry_metrics *out, mgs_error *err);

#ifdef __cplusplus
}
#endif
#endif

/* Helpers shared by the scene tests: an independent silhouette rasterizer (projects
 * triangles with the camera API, point-in-triangle at probe points), mask comparison,
 * mesh topology counts, file comparison. */
#ifndef SCENE_TEST_UTIL_H
#define SCENE_TEST_UTIL_H
#include <stddef.h>
#include <stdint.h>
#include "core/mgs_camera.h"
#include "core/mgs_mesh.h"

/* Probe grid of (2W+1) x (2H+1) points at (i/2, j/2): pixel corners, edge midpoints and
 * centres. 1 where the point lies inside some projected triangle. Caller frees. */
uint8_t *silhouette_probes(const mgs_mesh *m, const mgs_camera *cam);

typedef struct {
  size_t interior_mismatch; /* pixels whose 9 probes agree but alpha disagrees */
  size_t boundary_mismatch; /* pixels crossed by the silhouette edge that disagree */
  size_t boundary;          /* pixels crossed by the silhouette edge */
  size_t inside;            /* pixels whose centre is inside */
} mask_compare;
/* alpha: W*H values read at alpha[(y*W+x)*stride]; compared as alpha > 0.5. */
mask_compare compare_silhouette(const float *alpha, int stride, const uint8_t *probes, int W, int H);

size_t mesh_components(const mgs_mesh *m);
/* V - E + F over the vertices the triangles use. */
long mesh_euler(const mgs_mesh *m);

int files_equal(const char *a, const char *b);
/* Runs a shell command with output to `log`; returns the exit status (-1 on failure). */
int run_cmd(const char *cmd, const char *log);
/* 1 if the file contains `needle`. */
int file_contains(const char *path, const char *needle);
#endif

/* The rasterizer's byte accounting (mgs_raster_last_bytes) on a constructed scene whose
 * counts are known by construction: 7 Gaussians on a 64x32 image (4x2 tiles), identity
 * camera. Two behind the camera, one in front but off-screen (scales read, never
 * shaded), one too faint to bin (shaded, not binned), two inside one tile each and one on
 * a tile border (two tiles): 4 intersections in 4 tiles, at three depths whose float bits
 * differ in one byte (one radix pass). The expected bytes are written out below from these
 * counts and the layout (48-byte splat, 32-byte aux, 8-byte rect, 64-byte gradient slot,
 * 45 SH-rest floats), not taken from the rasterizer. */
#include <stdio.h>
#include "mgs_test.h"
#include "core/mgs_camera.h"
#include "core/mgs_gaussians.h"
#include "render/mgs_raster.h"

static void put(mgs_gaussians *g, size_t i, double u, double v, double z, float logit) {
  const double f = 64, cx = 32, cy = 16;
  g->mean[3 * i] = (float)((u - cx) * z / f);
  g->mean[3 * i + 1] = (float)((v - cy) * z / f);
  g->mean[3 * i + 2] = (float)z;
  for (int k = 0; k < 3; k++) { g->log_scale[3 * i + k] = logf(0.01f); g->sh_dc[3 * i + k] = 0.5f; }
  g->opacity[i] = logit;
  for (int k = 0; k < MGS_SH_REST_MAX; k++) g->sh_rest[MGS_SH_REST_MAX * i + k] = 0.01f * (float)(k % 5);
}

static void nop_sink(void *ctx, size_t first, size_t count, const mgs_gaussians *block) {
  (void)ctx; (void)first; (void)count; (void)block;
}

static void test_counts_and_bytes(void) {
  mgs_gaussians *g = mgs_gaussians_create(7, 3), *grad = mgs_gaussians_create(7, 3);
  size_t first;
  CHECK(g && grad && mgs_gaussians_append(g, 7, &first, NULL) == MGS_OK && mgs_gaussians_append(grad, 7, &first, NULL) == MGS_OK);
  put(g, 0, 8, 8, 4.0, 2.0f);     /* tile (0,0) */
  put(g, 1, 40, 8, 4.5, 2.0f);    /* tile (2,0) */
  put(g, 2, 16, 24, 5.0, 2.0f);   /* tiles (0,1) and (1,1) */
  put(g, 3, 20, 10, 4.0, 2.0f); g->mean[3 * 3 + 2] = -4.0f; /* behind */
  put(g, 4, 50, 20, 4.0, 2.0f); g->mean[3 * 4 + 2] = -1.0f; /* behind */
  put(g, 5, 1632, 16, 4.0, 2.0f); /* in front, off-screen */
  put(g, 6, 56, 24, 4.0, -10.0f); /* alpha < 1/255 */
  mgs_camera cam;
  mgs_camera_init(&cam, 64, 32, 64, 64, 32, 16);
  mgs_raster_settings s;
  mgs_raster_settings_default(&s);
  s.sh_degree = 3;
  mgs_raster *r = mgs_raster_create();
  mgs_raster_output out;
  mgs_error err;
  CHECK_OK(mgs_raster_forward(r, g, &cam, &s, &out, &err), &err);
  mgs_raster_counts c;
  mgs_raster_bytes b;
  mgs_raster_last_bytes(r, &c, &b);
  fprintf(stderr, "  counts: n %zu front %zu shaded %zu binned %zu isect %zu visit %zu passes %d chunks %d\n", c.n, c.n_front,
          c.n_shaded, c.n_binned, c.n_isect, c.fwd_visit, c.sort_passes, c.bin_chunks);
  CHECK(c.n == 7 && c.n_front == 5 && c.n_shaded == 4 && c.n_binned == 3 && c.n_isect == 4);
  CHECK(c.fwd_visit == 4 && c.sort_passes == 1 && c.bin_chunks == 1 && c.n_tiles == 8 && c.n_pix == 2048);
  CHECK(c.bwd_kind == 0);
  const double rest = 45 * 4, splat = 48, aux = 32;
  /* projection: 7 x (mean, rot, logit), 5 x scales, 4 x (dc, rest); 7 x (radius, count),
     4 x (splat, aux), 3 x rect */
  CHECK_NEAR(b.project[0], 7 * 32 + 5 * 12 + 4 * (12 + rest), 0);
  CHECK_NEAR(b.project[1], 7 * 8 + 4 * (splat + aux) + 3 * 8, 0);
  /* binning, read: counts twice (7), depths (3), 4 histogram sweeps and one pass (3 keys
     and indices), tile count (index + rect of 3, counter of 4 intersections, 8 tile
     counters in the prefix sum), scatter (index, rect, offset of 3; counter of 4) */
  CHECK_NEAR(b.bin[0], 2 * 7 * 4 + 3 * 4 + 4 * 3 * 4 + 3 * 8 + 3 * 12 + 4 * 4 + 8 * 4 + 3 * 16 + 4 * 4, 0);
  /* written: offset, key, index of 3; the pass (3 x 8); counters cleared (8), incremented
     (4), prefix-summed (8); tile starts (9); scatter: counter, index, slot of 4 */
  CHECK_NEAR(b.bin[1], 3 * 12 + 3 * 8 + 8 * 4 + 4 * 4 + 8 * 4 + 9 * 4 + 4 * 12, 0);
  CHECK_NEAR(b.render[0], 8 * 8 + 4 * (4 + splat), 0);
  CHECK_NEAR(b.render[1], 2048.0 * 7 * 4, 0);
  CHECK(b.tiles[0] == 0 && b.reduce[0] == 0);

  /* backward into gradient arrays, with the 2D-mean norm: every pixel's colour gradient */
  float *dl = malloc(64 * 32 * 3 * sizeof(float)), gm[7];
  for (int p = 0; p < 64 * 32 * 3; p++) dl[p] = (p % 3 == 1 ? -1.0f : 1.0f) / 6144.0f;
  CHECK_OK(mgs_raster_backward(r, dl, NULL, NULL, grad, gm, &err), &err);
  mgs_raster_last_bytes(r, &c, &b);
  CHECK(c.bwd_kind == 1 && c.bwd_visit == 4 && c.n_live == 3 && c.n_pix_listed == 4 * 256);
  /* tiles: 8 list bounds, 1024 listed pixels x (colour gradient, final T, count), 4 x
     (slot index, gradient index, splat); 4 slots written */
  CHECK_NEAR(b.tiles[0], 8 * 8 + 1024 * 5 * 4 + 4 * 4 + 4 * (4 + splat), 0);
  CHECK_NEAR(b.tiles[1], 4 * 64, 0);
  /* per Gaussian: 7 counts, 3 offsets, 4 slots, 3 x (aux, splat, scales, rot, rest) and
     their 14 + 45 gradient floats read and written; the 2D-mean norms (7 cleared, 3) */
  CHECK_NEAR(b.reduce[0], 7 * 4 + 3 * 4 + 4 * 64 + 3 * (aux + splat + 28 + rest) + 3 * (56 + rest), 0);
  CHECK_NEAR(b.reduce[1], 3 * (56 + rest) + 7 * 4 + 3 * 4, 0);

  /* the same through a sink (gradients in an L1 block): no gradient array traffic */
  CHECK_OK(mgs_raster_forward(r, g, &cam, &s, &out, &err), &err);
  CHECK_OK(mgs_raster_backward_sink(r, g, dl, NULL, NULL, NULL, nop_sink, NULL, &err), &err);
  mgs_raster_last_bytes(r, &c, &b);
  CHECK(c.bwd_kind == 2 && c.n_live == 3);
  CHECK_NEAR(b.reduce[0], 7 * 4 + 3 * 4 + 4 * 64 + 3 * (aux + splat + 28 + rest), 0);
  CHECK_NEAR(b.reduce[1], 0, 0);
  CHECK_NEAR(b.project[0], 7 * 32 + 5 * 12 + 4 * (12 + rest), 0);

  /* SH degree 1: the projection reads 9 rest floats of the shaded */
  s.sh_degree = 1;
  CHECK_OK(mgs_raster_forward(r, g, &cam, &s, &out, &err), &err);
  mgs_raster_last_bytes(r, &c, &b);
  CHECK_NEAR(b.project[0], 7 * 32 + 5 * 12 + 4 * (12 + 9 * 4), 0);
  free(dl);
  mgs_raster_destroy(r);
  mgs_gaussians_destroy(g);
  mgs_gaussians_destroy(grad);
}

int main(void) {
  RUN(test_counts_and_bytes);
  return mgs_test_finish();
}

/* The Morton-curve partition: every point has one owner, blocks are balanced to within a
 * tile, compact (far smaller boxes than the scene), identical when built twice, and the
 * owner of a point outside the initial tiles is still defined. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "mgs_test.h"
#include "core/mgs_rng.h"
#include "core/mgs_camera.h"
#include "train/mgs_partition.h"

/* slab 0: a flat city-like slab above z = 0; slab 1: a ground plane around z = 0 (the
   curve counted from the origin cut it horizontally: each block a whole-scene layer) */
static void test_partition_slab(int ground) {
  const size_t n = 20000;
  float *xyz = malloc(n * 3 * sizeof(float));
  mgs_rng r;
  mgs_rng_init(&r, 1, 2);
  for (size_t i = 0; i < n; i++) {
    xyz[3 * i] = (float)(8.0 * mgs_rng_uniform(&r) - 4.0);
    xyz[3 * i + 1] = (float)(8.0 * mgs_rng_uniform(&r) - 4.0);
    xyz[3 * i + 2] = ground ? (float)(0.1 * mgs_rng_uniform(&r) - 0.05) : (float)(0.5 * mgs_rng_uniform(&r));
  }
  mgs_error err;
  for (int ranks = 1; ranks <= 4; ranks++) {
    mgs_partition *p = NULL, *q = NULL;
    CHECK_OK(mgs_partition_build(xyz, n, ranks, 0, &p, &err), &err);
    CHECK_OK(mgs_partition_build(xyz, n, ranks, 0, &q, &err), &err);
    if (!p || !q) continue;
    size_t total = 0, per_tile = 0;
    for (int k = 0; k < ranks; k++) total += p->count[k];
    CHECK(total == n);
    per_tile = (size_t)(n * pow(p->tile, 2) / 64.0) + 1; /* points in one tile column, about */
    for (int k = 0; k < ranks; k++) {
      CHECK(p->split[k] == q->split[k] && p->count[k] == q->count[k]);
      CHECK_MSG(fabs((double)p->count[k] - (double)n / ranks) <= 2.0 * (double)per_tile + 1,
                "%d ranks: rank %d owns %zu", ranks, k, p->count[k]);
      /* compact: a block's footprint is about 1/ranks of the scene's 64 units^2 (for 2 and 4
         ranks, aligned with the Z curve's quadrants; a run of a Z curve can jump, so other
         counts get boxes that are not tight: a Hilbert curve would fix that) */
      if (ranks == 3) continue;
      double area = (p->hi[k][0] - p->lo[k][0]) * (p->hi[k][1] - p->lo[k][1]);
      /* ground, 4 ranks: a cut by count lands off the quarter lines (19 tiles a side: halves
         of 10 and 9), so a block can reach into the next quarter: 3/4 of the scene at most */
      double bound = ground && ranks == 4 ? 0.75 * 64.0 : 64.0 * 1.6 / ranks + 8.0 * p->tile;
      CHECK_MSG(area <= bound, "%s, %d ranks: rank %d box area %.1f", ground ? "ground" : "slab", ranks, k, area);
    }
    size_t agree = 0;
    for (size_t i = 0; i < n; i++) {
      int o = mgs_partition_owner(p, xyz + 3 * i);
      CHECK(o >= 0 && o < ranks);
      agree += o == mgs_partition_owner(q, xyz + 3 * i);
    }
    CHECK(agree == n);
    float far[3] = {100.0f, -50.0f, 3.0f}, nan3[3] = {NAN, 0, 0};
    int of = mgs_partition_owner(p, far);
    CHECK(of >= 0 && of < ranks);
    CHECK(mgs_partition_owner(p, nan3) == 0);
    mgs_partition_destroy(p);
    mgs_partition_destroy(q);
  }
  /* the Morton order: a permutation along which consecutive points are near each other
     (mean step far below the mean step of the input's random order) */
  uint32_t *perm = malloc(n * sizeof *perm);
  uint8_t *seen = calloc(n, 1);
  CHECK_OK(mgs_partition_morton_order(xyz, n, 0.5, perm, &err), &err);
  int is_perm = 1;
  for (size_t j = 0; j < n; j++) { is_perm &= perm[j] < n && !seen[perm[j]]; if (perm[j] < n) seen[perm[j]] = 1; }
  CHECK(is_perm);
  double step_sorted = 0, step_input = 0;
  for (size_t j = 1; j < n; j++)
    for (int k = 0; k < 3; k++) {
      step_sorted += fabs(xyz[3 * perm[j] + k] - xyz[3 * perm[j - 1] + k]);
      step_input += fabs(xyz[3 * j + k] - xyz[3 * (j - 1) + k]);
    }
  CHECK_MSG(step_sorted < 0.2 * step_input, "Morton order steps %.1f vs input %.1f", step_sorted, step_input);
  CHECK(mgs_partition_morton_order(xyz, n, 0, perm, &err) == MGS_ERR_ARG);
  fprintf(stderr, "  %s: Morton order steps %.1f vs input %.1f\n", ground ? "ground" : "slab", step_sorted, step_input);
  free(perm);
  free(seen);
  mgs_partition *p = NULL;
  CHECK(mgs_partition_build(xyz, n, 0, 0, &p, &err) == MGS_ERR_ARG && !p);
  float bad[3] = {NAN, NAN, NAN};
  CHECK(mgs_partition_build(bad, 1, 2, 0, &p, &err) == MGS_ERR_ARG && !p);
  free(xyz);
}
static void test_partition(void) { test_partition_slab(0); }
static void test_partition_ground(void) { test_partition_slab(1); }

/* Views ordered by chunks: a permutation, each chunk consecutive, chunks in the order of
 * their first appearance and views within a chunk in the input order. */
/* Cost by pixels: views that all look at one corner of a ground slab make its points dear,
   so the blocks balance cost (each about half of it), not points: the block over the seen
   corner holds fewer of them. Unseen points cost 1/N; the points' costs sum to 1 and the
   pixels' to 1. */
static void test_pixel_costs(void) {
  const size_t n = 20000;
  float *xyz = malloc(n * 3 * sizeof(float));
  double *cost = malloc(n * sizeof(double));
  mgs_rng r;
  mgs_rng_init(&r, 3, 2);
  for (size_t i = 0; i < n; i++) {
    xyz[3 * i] = (float)(8.0 * mgs_rng_uniform(&r) - 4.0);
    xyz[3 * i + 1] = (float)(8.0 * mgs_rng_uniform(&r) - 4.0);
    xyz[3 * i + 2] = (float)(0.1 * mgs_rng_uniform(&r) - 0.05);
  }
  mgs_camera cams[7];
  for (int v = 0; v < 7; v++) {
    mgs_camera_init_fovx(&cams[v], 64, 64, 1.0);
    const double eye[3] = {-2.0 + 0.2 * v, -2.0, 2.0}, at[3] = {-2.0 + 0.2 * v, -2.0, 0.0}, up[3] = {0, 1, 0};
    mgs_camera_look_at(&cams[v], eye, at, up);
  }
  mgs_error err;
  CHECK_OK(mgs_partition_pixel_costs(xyz, n, cams, 7, cost, &err), &err);
  double sum = 0, cheap = 0, dear = 0;
  size_t n_right = 0;
  for (size_t i = 0; i < n; i++) {
    sum += cost[i];
    if (xyz[3 * i] > 1 || xyz[3 * i + 1] > 1) { n_right++; cheap = fmax(cheap, cost[i]); } else dear = fmax(dear, cost[i]);
  }
  CHECK_MSG(fabs(sum - 2.0) < 1e-9, "costs sum to %.12f", sum);
  CHECK_MSG(cheap == 1.0 / (double)n, "an unseen point costs %g", cheap);
  CHECK(dear > 10.0 / (double)n);
  mgs_partition *p = NULL, *q = NULL;
  CHECK_OK(mgs_partition_build_weighted(xyz, cost, n, 2, 0, &p, &err), &err);
  CHECK_OK(mgs_partition_build(xyz, n, 2, 0, &q, &err), &err);
  if (p && q) {
    fprintf(stderr, "  by count: %zu / %zu points; by cost: %zu / %zu points, cost %.3f / %.3f\n", q->count[0], q->count[1],
            p->count[0], p->count[1], p->cost[0], p->cost[1]);
    CHECK(p->count[0] + p->count[1] == n);
    CHECK_MSG(fabs(p->cost[0] - 1.0) < 0.05 && fabs(p->cost[1] - 1.0) < 0.05, "cost %.3f / %.3f", p->cost[0], p->cost[1]);
    size_t lo = p->count[0] < p->count[1] ? p->count[0] : p->count[1];
    CHECK_MSG(lo < 0.4 * n, "the dear block still holds %zu of %zu points", lo, n);
    CHECK(fabs((double)q->count[0] - (double)q->count[1]) < 0.1 * n);
  }
  mgs_partition_destroy(p); mgs_partition_destroy(q);
  /* all costs zero: by count, as without costs; a negative cost is refused */
  for (size_t i = 0; i < n; i++) cost[i] = 0;
  p = NULL;
  CHECK_OK(mgs_partition_build_weighted(xyz, cost, n, 2, 0, &p, &err), &err);
  if (p) CHECK(fabs((double)p->count[0] - (double)p->count[1]) < 0.1 * n);
  mgs_partition_destroy(p);
  cost[5] = -1;
  p = NULL;
  CHECK(mgs_partition_build_weighted(xyz, cost, n, 2, 0, &p, &err) == MGS_ERR_ARG && p == NULL);
  (void)n_right;
  free(xyz); free(cost);
}

static void test_view_chunks(void) {
  const size_t n = 50;
  float c[150];
  mgs_rng r;
  mgs_rng_init(&r, 3, 3);
  for (size_t i = 0; i < 3 * n; i++) c[i] = (float)(10.0 * mgs_rng_uniform(&r));
  uint32_t chunk_of[50], perm[50], in[50], scratch[100];
  mgs_error err;
  CHECK_OK(mgs_partition_view_chunks(c, n, 1.0, 8, chunk_of, &err), &err);
  size_t per[8] = {0};
  for (size_t i = 0; i < n; i++) { CHECK(chunk_of[i] < 7); if (chunk_of[i] < 8) per[chunk_of[i]]++; }
  for (int k = 0; k < 6; k++) CHECK(per[k] == 8);
  CHECK(per[6] == 2);
  for (size_t i = 0; i < n; i++) perm[i] = (uint32_t)i;
  for (size_t i = n; i > 1; i--) { uint32_t j = mgs_rng_below(&r, (uint32_t)i), x = perm[i - 1]; perm[i - 1] = perm[j]; perm[j] = x; }
  memcpy(in, perm, sizeof in);
  mgs_partition_order_by_chunks(chunk_of, n, perm, scratch);
  int runs = 1, is_perm = 1, kept_order = 1;
  uint8_t seen[50] = {0};
  for (size_t j = 0; j < n; j++) { is_perm &= !seen[perm[j]]; seen[perm[j]] = 1; }
  for (size_t j = 1; j < n; j++) runs += chunk_of[perm[j]] != chunk_of[perm[j - 1]];
  CHECK(is_perm);
  CHECK_MSG(runs == 7, "%d runs of chunks", runs);
  CHECK(chunk_of[perm[0]] == chunk_of[in[0]]); /* the first view's chunk comes first */
  for (size_t a = 0; a < n; a++)
    for (size_t b = a + 1; b < n; b++)
      if (chunk_of[perm[a]] == chunk_of[perm[b]]) {
        size_t pa = 0, pb = 0;
        for (size_t k = 0; k < n; k++) { if (in[k] == perm[a]) pa = k; if (in[k] == perm[b]) pb = k; }
        kept_order &= pa < pb;
      }
  CHECK(kept_order);
  CHECK(mgs_partition_view_chunks(c, n, 1.0, 0, chunk_of, &err) == MGS_ERR_ARG);
}

int main(void) {
  RUN(test_partition);
  RUN(test_partition_ground);
  RUN(test_pixel_costs);
  RUN(test_view_chunks);
  return mgs_test_finish();
}

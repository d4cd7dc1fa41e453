/* Test utility: is a narrow-band level set a distance field between every pair of
 * 6-neighbours? (Stricter than topo's mgs_topo_check_level_set, which allows a 3-voxel
 * jump so that first-order fast sweeping passes: this one counts every pair that breaks
 * |d_i - d_j| <= h (1 + tol).)
 *
 * Each face pair (i, j) with i active is visited once and falls in one class:
 *   jump   both active, |d_i - d_j| > h (1 + tol)
 *   sign   j inactive (a voxel or tile beyond the band) holding the other sign than d_i:
 *          the band does not separate inside from outside there
 *   edge   j inactive with the same sign but |d_i| < b - h (1 + tol): an active voxel well
 *          inside the band next to a voxel the band left out, which reads the background
 *          ±b, more than a voxel from d_i (issue 21: 4 of 3.35M pairs, up to 1.35 voxels, on
 *          a 7050-iteration model; the band's outer layer missed voxels near sub-voxel
 *          parts of the surface)
 * bc_bad(r) = jump + sign + edge: every pair that is not a distance field's. */
#ifndef BAND_CHECK_H
#define BAND_CHECK_H
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include "vdb/mgs_vdb.h"

typedef struct bc_report {
  size_t active, pairs;      /* active voxels; face pairs visited */
  size_t jump, sign, edge;   /* see above */
  double max_jump;           /* largest |d_i - d_j| / h over active pairs */
  int32_t worst[2][3];       /* the pair with max_jump (index coordinates) */
  float worst_v[2];
  int32_t first_sign[2][3];  /* the first wrong-sign pair (active voxel, inactive neighbour) */
  float first_sign_v[2];
  double max_edge;           /* largest (b - |d_i|) / h over edge pairs */
  int32_t first_edge[2][3];  /* the edge pair with max_edge (active voxel, inactive neighbour) */
  float first_edge_v;
} bc_report;

static inline size_t bc_bad(const bc_report *r) { return r->jump + r->sign + r->edge; }

/* Returns 0 on success, -1 on allocation failure. */
static inline int bc_check(const mgs_vdb_grid *g, double tol, bc_report *r) {
  static const int face[6][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {-1, 0, 0}, {0, -1, 0}, {0, 0, -1}};
  const double h = mgs_vdb_grid_voxel_size(g), b = mgs_vdb_grid_background(g);
  const double lim = h * (1 + tol);
  *r = (bc_report){0};
  size_t nl = mgs_vdb_leaf_count(g);
  mgs_vdb_leaf_view *lv = malloc((nl ? nl : 1) * sizeof *lv);
  /* one leaf's neighbours at a time: 512 voxels x 6 faces */
  int32_t *ijk = malloc(512 * 6 * 3 * sizeof *ijk);
  float *val = malloc(512 * 6 * sizeof *val);
  uint8_t *act = malloc(512 * 6);
  int16_t *from = malloc(512 * 6 * sizeof *from);
  if (!lv || !ijk || !val || !act || !from) {
    free(lv), free(ijk), free(val), free(act), free(from);
    return -1;
  }
  nl = mgs_vdb_leaf_views(g, lv, nl);
  for (size_t l = 0; l < nl; l++) {
    const mgs_vdb_leaf_view *L = &lv[l];
    size_t n = 0;
    for (int off = 0; off < 512; off++) {
      if (!mgs_vdb_leaf_is_active(L, off)) continue;
      r->active++;
      const int32_t c[3] = {L->origin[0] + (off >> 6), L->origin[1] + ((off >> 3) & 7), L->origin[2] + (off & 7)};
      for (int f = 0; f < 6; f++) {
        ijk[3 * n] = c[0] + face[f][0];
        ijk[3 * n + 1] = c[1] + face[f][1];
        ijk[3 * n + 2] = c[2] + face[f][2];
        from[n++] = (int16_t)off;
      }
    }
    mgs_vdb_values(g, n, ijk, val, act);
    for (size_t k = 0; k < n; k++) {
      const int off = from[k];
      const double di = L->values[off], dj = val[k];
      const int32_t *nj = ijk + 3 * k;
      if (act[k]) {
        /* both active: each pair once (the neighbour on the + side, by coordinate order) */
        const int32_t c[3] = {L->origin[0] + (off >> 6), L->origin[1] + ((off >> 3) & 7), L->origin[2] + (off & 7)};
        if (nj[0] + nj[1] + nj[2] < c[0] + c[1] + c[2]) continue;
        r->pairs++;
        const double dd = fabs(di - dj);
        if (!(dd <= lim)) r->jump++;
        if (dd / h > r->max_jump) {
          r->max_jump = dd / h;
          for (int a = 0; a < 3; a++) r->worst[0][a] = c[a], r->worst[1][a] = nj[a];
          r->worst_v[0] = (float)di, r->worst_v[1] = (float)dj;
        }
      } else {
        r->pairs++;
        if ((di < 0) != (dj < 0)) {
          if (!r->sign++) {
            for (int a = 0; a < 3; a++)
              r->first_sign[0][a] = L->origin[a] + (a == 0 ? off >> 6 : a == 1 ? (off >> 3) & 7 : off & 7), r->first_sign[1][a] = nj[a];
            r->first_sign_v[0] = (float)di, r->first_sign_v[1] = (float)dj;
          }
        }
        else if (fabs(di) < b - lim) {
          r->edge++;
          if ((b - fabs(di)) / h > r->max_edge) {
            r->max_edge = (b - fabs(di)) / h;
            for (int a = 0; a < 3; a++)
              r->first_edge[0][a] = L->origin[a] + (a == 0 ? off >> 6 : a == 1 ? (off >> 3) & 7 : off & 7), r->first_edge[1][a] = nj[a];
            r->first_edge_v = (float)di;
          }
        }
      }
    }
  }
  free(lv), free(ijk), free(val), free(act), free(from);
  return 0;
}

static inline void bc_print(FILE *f, const char *what, const bc_report *r, double h) {
  fprintf(f, "  %s: %zu active, %zu pairs: %zu jumps (max %.2f voxels: (%d,%d,%d) = %.3g vs (%d,%d,%d) = %.3g), "
          "%zu wrong-sign background, %zu band-edge\n",
          what, r->active, r->pairs, r->jump, r->max_jump, r->worst[0][0], r->worst[0][1], r->worst[0][2],
          r->worst_v[0] / h, r->worst[1][0], r->worst[1][1], r->worst[1][2], r->worst_v[1] / h, r->sign, r->edge);
  if (r->edge)
    fprintf(f, "    worst band-edge pair: active (%d,%d,%d) = %.3g voxels beside inactive (%d,%d,%d) at the background: %.3g voxels apart\n",
            r->first_edge[0][0], r->first_edge[0][1], r->first_edge[0][2], r->first_edge_v / h, r->first_edge[1][0],
            r->first_edge[1][1], r->first_edge[1][2], r->max_edge);
  if (r->sign)
    fprintf(f, "    first wrong-sign pair: active (%d,%d,%d) = %.3g, inactive (%d,%d,%d) = %.3g voxels\n", r->first_sign[0][0],
            r->first_sign[0][1], r->first_sign[0][2], r->first_sign_v[0] / h, r->first_sign[1][0], r->first_sign[1][1],
            r->first_sign[1][2], r->first_sign_v[1] / h);
}
#endif

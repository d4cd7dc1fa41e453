/* The merged model's .vdb by blocks (apps/train_mpi.h): each rank builds the α-field over
 * the voxels it owns, rank 0 unions the disjoint pieces and writes what `morsegs vdb` writes
 * for the merged .ply (density + SDF, same voxel size and τ). The SDF and the density are
 * derived on rank 0 from the union: they read a band around the surface that crosses
 * block boundaries. */
#ifdef MGS_HAVE_MPI
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "dist/dist_internal.h"
#include "core/mgs_core.h"
#include "vdb/mgs_vdb.h"

enum { TAG_VOX_N = 21, TAG_VOX_IJK = 22, TAG_VOX_VAL = 23 };

static void bcast_floats(float *p, size_t n) {
  for (size_t off = 0; off < n;) { /* MPI counts are int */
    size_t k = n - off > (size_t)INT_MAX / 2 ? (size_t)INT_MAX / 2 : n - off;
    MPI_Bcast(p + off, (int)k, MPI_FLOAT, 0, MPI_COMM_WORLD);
    off += k;
  }
}

/* Every rank gets the merged model. */
static mgs_gaussians *share_model(const mgs_gaussians *merged, int rank) {
  unsigned long long head[2] = {merged ? merged->n : 0, merged ? (unsigned long long)merged->sh_degree : 0};
  MPI_Bcast(head, 2, MPI_UNSIGNED_LONG_LONG, 0, MPI_COMM_WORLD);
  mgs_gaussians *g = mgs_gaussians_create(head[0] ? (size_t)head[0] : 1, (int)head[1]);
  size_t first;
  if (!g || mgs_gaussians_append(g, (size_t)head[0], &first, NULL)) mgs_mpi_die(rank, "out of memory for the merged model");
  for (int k = 0; k < MGS_PARAM_COUNT; k++) {
    size_t d = (size_t)mgs_param_dim((mgs_param_group)k);
    float *dst = mgs_gaussians_group(g, (mgs_param_group)k);
    if (rank == 0) memcpy(dst, mgs_gaussians_group((mgs_gaussians *)merged, (mgs_param_group)k), g->n * d * sizeof(float));
    bcast_floats(dst, g->n * d);
  }
  return g;
}

/* Does the box [lo, hi] touch a tile `rank` owns? (tiles: floor(x / side), as the
   partition's). Boxes over too many tiles count as touching (kept: never wrong). */
static int box_touches_rank(const mgs_partition *part, int rank, const double lo[3], const double hi[3]) {
  const double T = part->tile;
  long long a[3], b[3], cells = 1;
  for (int k = 0; k < 3; k++) {
    a[k] = (long long)floor(lo[k] / T);
    b[k] = (long long)floor(hi[k] / T);
    cells *= b[k] - a[k] + 1;
  }
  if (cells > 4096) return 1;
  for (long long x = a[0]; x <= b[0]; x++)
    for (long long y = a[1]; y <= b[1]; y++)
      for (long long z = a[2]; z <= b[2]; z++) {
        float c[3] = {(float)((x + 0.5) * T), (float)((y + 0.5) * T), (float)((z + 0.5) * T)};
        if (mgs_partition_owner(part, c) == rank) return 1;
      }
  return 0;
}

void mgs_mpi_merged_vdb(const mgs_gaussians *merged, const mgs_partition *part, int rank, int size, int resolution,
                        double limit, int explicit_limit, const char *path, unsigned long long *voxels_out) {
  mgs_error err;
  mgs_error_clear(&err);
  mgs_gaussians *g = share_model(merged, rank);
  mgs_vdb_alpha_params ap;
  mgs_vdb_alpha_params_default(&ap);
  ap.resolution = resolution;
  mgs_vdb_sdf_params sp;
  mgs_vdb_sdf_params_default(&sp);
  ap.half_width = sp.half_width;
  if (rank == 0 && mgs_vdb_check_gaussians(g, "the merged model", &err)) mgs_mpi_die(rank, err.msg);
  const double h = mgs_vdb_voxel_size_for(g->n, g->mean, &ap);
  ap.voxel_size = h;
  /* the lattice of a single-process build of the merged model (alpha_field's rule) */
  double mlo[3] = {INFINITY, INFINITY, INFINITY}, mhi[3] = {-INFINITY, -INFINITY, -INFINITY}, shift[3];
  for (size_t i = 0; i < g->n; i++)
    for (int k = 0; k < 3; k++) {
      mlo[k] = fmin(mlo[k], g->mean[3 * i + k]);
      mhi[k] = fmax(mhi[k], g->mean[3 * i + k]);
    }
  for (int k = 0; k < 3; k++) shift[k] = h * round(0.5 * (mlo[k] + mhi[k]) / h);

  /* the Gaussians whose support (kσ of the filtered covariance, plus the padding the
     build adds for the band) reaches a tile of this rank */
  mgs_gaussians *sub = mgs_gaussians_create(g->n ? g->n : 1, g->sh_degree);
  if (!sub) mgs_mpi_die(rank, "out of memory");
  for (size_t i = 0; i < g->n; i++) {
    float smax = fmaxf(g->log_scale[3 * i], fmaxf(g->log_scale[3 * i + 1], g->log_scale[3 * i + 2]));
    double s = exp((double)smax), rad = ap.k_sigma * sqrt(s * s + 0.25 * h * h) + (ap.half_width + 2) * h;
    double lo[3], hi[3];
    for (int k = 0; k < 3; k++) { lo[k] = g->mean[3 * i + k] - rad; hi[k] = g->mean[3 * i + k] + rad; }
    if (!box_touches_rank(part, rank, lo, hi)) continue;
    size_t row;
    if (mgs_gaussians_append(sub, 1, &row, NULL)) mgs_mpi_die(rank, "out of memory");
    for (int k = 0; k < MGS_PARAM_COUNT; k++) {
      size_t d = (size_t)mgs_param_dim((mgs_param_group)k);
      memcpy(mgs_gaussians_group(sub, (mgs_param_group)k) + row * d, mgs_gaussians_group(g, (mgs_param_group)k) + i * d,
             d * sizeof(float));
    }
  }
  /* this rank's voxels, in the merged lattice */
  size_t cap = 0, n = 0;
  int32_t *ijk = NULL;
  float *val = NULL;
  if (sub->n) {
    mgs_vdb_grid *a = NULL;
    if (mgs_vdb_alpha_field(sub, &ap, &a, NULL, &err)) mgs_mpi_die(rank, err.msg);
    size_t nl = mgs_vdb_leaf_count(a);
    mgs_vdb_leaf_view *lv = malloc((nl ? nl : 1) * sizeof *lv);
    if (!lv) mgs_mpi_die(rank, "out of memory");
    mgs_vdb_leaf_views(a, lv, nl);
    for (size_t L = 0; L < nl; L++)
      for (int off = 0; off < MGS_VDB_LEAF_VOXELS; off++) {
        if (!mgs_vdb_leaf_is_active(&lv[L], off)) continue;
        double q[3] = {lv[L].origin[0] + (off >> 6), lv[L].origin[1] + ((off >> 3) & 7), lv[L].origin[2] + (off & 7)}, w[3];
        mgs_vdb_index_to_world(a, q, w);
        float wf[3] = {(float)w[0], (float)w[1], (float)w[2]};
        if (mgs_partition_owner(part, wf) != rank) continue;
        if (n == cap) {
          cap = cap ? 2 * cap : 4096;
          int32_t *ni = realloc(ijk, cap * 3 * sizeof *ni);
          float *nv = ni ? realloc(val, cap * sizeof *nv) : NULL;
          if (!ni || !nv) mgs_mpi_die(rank, "out of memory");
          ijk = ni; val = nv;
        }
        for (int k = 0; k < 3; k++) ijk[3 * n + k] = (int32_t)llround((w[k] - shift[k]) / h);
        val[n++] = lv[L].values[off];
      }
    free(lv);
    mgs_vdb_grid_destroy(a);
  }
  mgs_gaussians_destroy(sub);
  mgs_gaussians_destroy(g);
  *voxels_out = n;
  if (n > (size_t)INT_MAX / 3) mgs_mpi_die(rank, "too many voxels for one MPI message");
  int cnt = (int)n;
  if (rank != 0) {
    MPI_Request rq[3];
    MPI_Isend(&cnt, 1, MPI_INT, 0, TAG_VOX_N, MPI_COMM_WORLD, &rq[0]);
    MPI_Isend(ijk, 3 * cnt, MPI_INT32_T, 0, TAG_VOX_IJK, MPI_COMM_WORLD, &rq[1]);
    MPI_Isend(val, cnt, MPI_FLOAT, 0, TAG_VOX_VAL, MPI_COMM_WORLD, &rq[2]);
    MPI_Waitall(3, rq, MPI_STATUSES_IGNORE);
    free(ijk); free(val);
    return;
  }
  /* rank 0: the union */
  int *counts = calloc((size_t)size, sizeof(int));
  MPI_Request *rq = malloc((size_t)size * 2 * sizeof *rq);
  int32_t **ijks = calloc((size_t)size, sizeof *ijks);
  float **vals = calloc((size_t)size, sizeof *vals);
  if (!counts || !rq || !ijks || !vals) mgs_mpi_die(rank, "out of memory");
  counts[0] = cnt; ijks[0] = ijk; vals[0] = val;
  rq[0] = MPI_REQUEST_NULL;
  for (int r = 1; r < size; r++) MPI_Irecv(&counts[r], 1, MPI_INT, r, TAG_VOX_N, MPI_COMM_WORLD, &rq[r]);
  mgs_mpi_wait_all(rq, size, limit, "voxel count", explicit_limit);
  for (int r = 1; r < size; r++) {
    ijks[r] = malloc(((size_t)counts[r] * 3 + 1) * sizeof(int32_t));
    vals[r] = malloc(((size_t)counts[r] + 1) * sizeof(float));
    if (!ijks[r] || !vals[r]) mgs_mpi_die(rank, "out of memory for the merged grid");
  }
  MPI_Request *r2 = malloc((size_t)size * sizeof *r2);
  if (!r2) mgs_mpi_die(rank, "out of memory");
  r2[0] = MPI_REQUEST_NULL;
  for (int r = 1; r < size; r++) {
    MPI_Irecv(ijks[r], 3 * counts[r], MPI_INT32_T, r, TAG_VOX_IJK, MPI_COMM_WORLD, &rq[r]);
    MPI_Irecv(vals[r], counts[r], MPI_FLOAT, r, TAG_VOX_VAL, MPI_COMM_WORLD, &r2[r]);
  }
  mgs_mpi_wait_all(rq, size, limit, "voxel coordinates", explicit_limit);
  mgs_mpi_wait_all(r2, size, limit, "voxel values", explicit_limit);
  free(rq); free(r2);
  mgs_vdb_grid *alpha = NULL, *sdf = NULL, *density = NULL;
  if (mgs_vdb_grid_create("alpha", MGS_VDB_CLASS_FOG, h, shift, 0.0f, &alpha, &err)) mgs_mpi_die(rank, err.msg);
  for (int r = 0; r < size; r++) {
    for (int j = 0; j < counts[r]; j++) mgs_vdb_set_value(alpha, ijks[r] + 3 * (size_t)j, vals[r][j], 1);
    free(ijks[r]); free(vals[r]);
  }
  free(ijks); free(vals); free(counts);
  if (mgs_vdb_sdf_from_alpha(alpha, &sp, &sdf, &err) || mgs_vdb_density_from_alpha(alpha, &density, &err))
    mgs_mpi_die(rank, err.msg);
  mgs_vdb_grid_destroy(alpha);
  mgs_vdb_file_meta meta;
  mgs_vdb_file_meta_default(&meta);
  meta.tau = sp.tau;
  meta.voxel_size = h;
  snprintf(meta.source, sizeof meta.source, "morsegs train --mpi (%d ranks, merged by blocks)", size);
  for (int k = 0; k < 2 && merged; k++) mgs_vdb_grid_translate(k ? sdf : density, merged->origin); /* world coordinates */
  const mgs_vdb_grid *grids[2] = {density, sdf};
  if (mgs_vdb_write(path, grids, 2, NULL, 0, &meta, &err)) mgs_mpi_die(rank, err.msg);
  mgs_vdb_grid_destroy(sdf);
  mgs_vdb_grid_destroy(density);
}
#endif

/* Initial Gaussians as the reference's create_from_pcd, from points or at random. The
 * 3-nearest-neighbour distances (the reference uses simple-knn on the GPU) come from a
 * uniform grid with shell-by-shell search, exact, parallel over points. */
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "train/mgs_train.h"
#include "core/mgs_math.h"
#include "core/mgs_parallel.h"

typedef struct {
  const float *xyz;
  size_t n;
  double lo[3], h;
  int dim[3];
  size_t *start; /* per cell, ncell + 1 */
  size_t *order; /* points sorted by cell */
  float *out;
} knn_grid;

static int cell_coord(const knn_grid *k, float x, int axis) {
  int c = (int)floor((x - k->lo[axis]) / k->h);
  return c < 0 ? 0 : (c >= k->dim[axis] ? k->dim[axis] - 1 : c);
}

static size_t cell_of(const knn_grid *k, const float *p) {
  return ((size_t)cell_coord(k, p[2], 2) * (size_t)k->dim[1] + (size_t)cell_coord(k, p[1], 1)) * (size_t)k->dim[0] +
         (size_t)cell_coord(k, p[0], 0);
}

static void knn_range(void *vk, size_t b, size_t e) {
  const knn_grid *k = vk;
  int maxr = k->dim[0] > k->dim[1] ? k->dim[0] : k->dim[1];
  maxr = maxr > k->dim[2] ? maxr : k->dim[2];
  for (size_t i = b; i < e; i++) {
    const float *p = k->xyz + 3 * i;
    int c[3] = {cell_coord(k, p[0], 0), cell_coord(k, p[1], 1), cell_coord(k, p[2], 2)};
    double best[3] = {DBL_MAX, DBL_MAX, DBL_MAX};
    int found = 0;
    for (int r = 0; r <= maxr; r++) {
      for (int dz = -r; dz <= r; dz++) {
        int z = c[2] + dz;
        if (z < 0 || z >= k->dim[2]) continue;
        for (int dy = -r; dy <= r; dy++) {
          int y = c[1] + dy;
          if (y < 0 || y >= k->dim[1]) continue;
          for (int dx = -r; dx <= r; dx++) {
            if (abs(dx) != r && abs(dy) != r && abs(dz) != r) continue; /* shell only */
            int x = c[0] + dx;
            if (x < 0 || x >= k->dim[0]) continue;
            size_t cell = ((size_t)z * (size_t)k->dim[1] + (size_t)y) * (size_t)k->dim[0] + (size_t)x;
            for (size_t s = k->start[cell]; s < k->start[cell + 1]; s++) {
              size_t j = k->order[s];
              if (j == i) continue;
              const float *q = k->xyz + 3 * j;
              double d0 = (double)q[0] - p[0], d1 = (double)q[1] - p[1], d2 = (double)q[2] - p[2];
              double d = d0 * d0 + d1 * d1 + d2 * d2;
              found++;
              if (d < best[2]) {
                if (d < best[1]) {
                  best[2] = best[1];
                  if (d < best[0]) { best[1] = best[0]; best[0] = d; }
                  else best[1] = d;
                } else best[2] = d;
              }
            }
          }
        }
      }
      /* points in shells beyond r are at least r*h away */
      if (found >= 3 && best[2] <= (double)r * k->h * (double)r * k->h) break;
    }
    int m = found < 3 ? found : 3;
    double s = 0;
    for (int t = 0; t < m; t++) s += best[t];
    k->out[i] = m ? (float)(s / m) : 0.0f;
  }
}

mgs_status mgs_knn3_mean_sq(const float *xyz, size_t n, float *out, mgs_error *err) {
  if (n == 0) return MGS_OK;
  knn_grid k;
  memset(&k, 0, sizeof k);
  k.xyz = xyz; k.n = n; k.out = out;
  double hi[3];
  for (int a = 0; a < 3; a++) { k.lo[a] = xyz[a]; hi[a] = xyz[a]; }
  for (size_t i = 0; i < n; i++)
    for (int a = 0; a < 3; a++) {
      double v = xyz[3 * i + a];
      if (!isfinite(v)) return mgs_error_set(err, MGS_ERR_NUMERIC, "initial point %zu is not finite", i);
      if (v < k.lo[a]) k.lo[a] = v;
      if (v > hi[a]) hi[a] = v;
    }
  double ext[3], emax = 0;
  for (int a = 0; a < 3; a++) { ext[a] = hi[a] - k.lo[a]; if (ext[a] > emax) emax = ext[a]; }
  if (emax <= 0) emax = 1;
  double vol = 1;
  for (int a = 0; a < 3; a++) vol *= ext[a] > emax * 1e-3 ? ext[a] : emax * 1e-3;
  /* about two points per cell, at most 1024 cells per axis */
  k.h = cbrt(vol / ((double)n * 0.5 + 1));
  for (;;) {
    size_t total = 1;
    for (int a = 0; a < 3; a++) {
      double d = ceil(ext[a] / k.h);
      k.dim[a] = d < 1 ? 1 : (d > 1024 ? 1024 : (int)d);
      total *= (size_t)k.dim[a];
    }
    if (total <= 4 * n + 64 && ext[0] / k.h <= 1024 && ext[1] / k.h <= 1024 && ext[2] / k.h <= 1024) break;
    k.h *= 1.25;
  }
  size_t ncell = (size_t)k.dim[0] * k.dim[1] * k.dim[2];
  k.start = calloc(ncell + 1, sizeof(size_t));
  k.order = malloc(n * sizeof(size_t));
  size_t *cells = malloc(n * sizeof(size_t));
  if (!k.start || !k.order || !cells) {
    free(k.start); free(k.order); free(cells);
    return mgs_error_set(err, MGS_ERR_NOMEM, "knn: out of memory for %zu points", n);
  }
  for (size_t i = 0; i < n; i++) { cells[i] = cell_of(&k, xyz + 3 * i); k.start[cells[i] + 1]++; }
  for (size_t c = 0; c < ncell; c++) k.start[c + 1] += k.start[c];
  size_t *fill = malloc((ncell + 1) * sizeof(size_t));
  if (!fill) {
    free(k.start); free(k.order); free(cells);
    return mgs_error_set(err, MGS_ERR_NOMEM, "knn: out of memory for %zu points", n);
  }
  memcpy(fill, k.start, (ncell + 1) * sizeof(size_t));
  for (size_t i = 0; i < n; i++) k.order[fill[cells[i]]++] = i;
  free(fill);
  free(cells);
  mgs_parallel_for(0, n, 256, knn_range, &k);
  free(k.start);
  free(k.order);
  return MGS_OK;
}

mgs_status mgs_init_from_points(const float *xyz, const float *rgb, size_t n, int sh_degree,
                                mgs_gaussians **out, mgs_error *err) {
  *out = NULL;
  if (n == 0) return mgs_error_set(err, MGS_ERR_ARG, "init: no initial points");
  float *d2 = malloc(n * sizeof(float));
  mgs_gaussians *g = mgs_gaussians_create(n, sh_degree);
  if (!d2 || !g) {
    free(d2); mgs_gaussians_destroy(g);
    return mgs_error_set(err, MGS_ERR_NOMEM, "init: out of memory for %zu Gaussians", n);
  }
  mgs_status st = mgs_knn3_mean_sq(xyz, n, d2, err);
  size_t first = 0;
  if (st == MGS_OK) st = mgs_gaussians_append(g, n, &first, err);
  if (st != MGS_OK) { free(d2); mgs_gaussians_destroy(g); return st; }
  const float op = mgs_logitf(0.1f);
  for (size_t i = 0; i < n; i++) {
    float s = 0.5f * logf(d2[i] > 1e-7f ? d2[i] : 1e-7f); /* log(sqrt(max(d2, 1e-7))) */
    for (int a = 0; a < 3; a++) {
      g->mean[3 * i + a] = xyz[3 * i + a];
      g->log_scale[3 * i + a] = s;
      g->sh_dc[3 * i + a] = rgb ? (rgb[3 * i + a] - 0.5f) / MGS_SH_C0 : 0.0f;
    }
    g->rot[4 * i] = 1; g->rot[4 * i + 1] = g->rot[4 * i + 2] = g->rot[4 * i + 3] = 0;
    g->opacity[i] = op;
    memset(g->sh_rest + (size_t)MGS_SH_REST_MAX * i, 0, MGS_SH_REST_MAX * sizeof(float));
  }
  free(d2);
  *out = g;
  return MGS_OK;
}

mgs_status mgs_init_random(size_t count, const double lo[3], const double hi[3], int sh_degree,
                           mgs_rng *rng, mgs_gaussians **out, mgs_error *err) {
  *out = NULL;
  if (count == 0) return mgs_error_set(err, MGS_ERR_ARG, "init: random init needs at least one point");
  float *xyz = malloc(count * 3 * sizeof(float)), *rgb = malloc(count * 3 * sizeof(float));
  if (!xyz || !rgb) {
    free(xyz); free(rgb);
    return mgs_error_set(err, MGS_ERR_NOMEM, "init: out of memory for %zu points", count);
  }
  for (size_t i = 0; i < count; i++)
    for (int a = 0; a < 3; a++) xyz[3 * i + a] = (float)(lo[a] + (hi[a] - lo[a]) * mgs_rng_uniform(rng));
  /* colours SH2RGB(u / 255) as the reference, so SH DC = u / 255 */
  for (size_t i = 0; i < 3 * count; i++) rgb[i] = (float)(mgs_rng_uniform(rng) / 255.0) * MGS_SH_C0 + 0.5f;
  mgs_status st = mgs_init_from_points(xyz, rgb, count, sh_degree, out, err);
  free(xyz); free(rgb);
  return st;
}

mgs_status mgs_init_random_for_dataset(const mgs_dataset *ds, size_t count, int sh_degree, uint64_t seed,
                                       mgs_gaussians **out, mgs_error *err) {
  double lo[3], hi[3], centre[3] = {0, 0, 0};
  if (ds->format == MGS_DATASET_NERF_SYNTHETIC) {
    /* The reference's cube sits at the world origin because Blender scenes are modelled
       there; where a folder's cameras look is the same place for a centred folder and the
       moved place for a moved one. Snapped to 1/64 of the cameras' extent (a power of
       two) so that the float noise of a centred folder's matrices gives exactly 0: the
       reference's init, bit for bit. */
    double p[3];
    if (mgs_dataset_look_at(ds, p)) {
      double step = exp2(ceil(log2(ds->extent / 64.0)));
      for (int k = 0; k < 3; k++) centre[k] = step * nearbyint(p[k] / step);
    }
  } else {
    for (int k = 0; k < 3; k++) centre[k] = ds->center[k];
  }
  for (int k = 0; k < 3; k++) {
    double h = ds->format == MGS_DATASET_NERF_SYNTHETIC ? 1.3 : 0.5 * ds->extent / 1.1;
    lo[k] = centre[k] - h; hi[k] = centre[k] + h;
  }
  mgs_rng rng;
  mgs_rng_init(&rng, seed, 0x696e6974u);
  return mgs_init_random(count, lo, hi, sh_degree, &rng, out, err);
}

void mgs_init_to_surfels(mgs_gaussians *g, uint64_t seed) {
  mgs_rng rng;
  mgs_rng_init(&rng, seed, 2027); /* a stream of its own: the 3DGS init's draws stay as they are */
  g->kind = MGS_MODEL_2DGS;
  for (size_t i = 0; i < g->n; i++) {
    for (int k = 0; k < 4; k++) g->rot[4 * i + k] = (float)mgs_rng_uniform(&rng);
    g->log_scale[3 * i + 2] = MGS_SURFEL_LOG_SCALE2;
  }
}

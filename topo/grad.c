/* Topological losses on a diagram and the Brüel-Gabrielsson map of their gradients to
 * voxels (declared in topo/mgs_topo_grad.h). */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "topo/mgs_topo_grad.h"

double mgs_topo_loss(const mgs_diagram *d, mgs_topo_loss_kind kind, double eps_sig,
                     unsigned dim_mask, double *dL_dbirth, double *dL_ddeath) {
  double loss = 0.0;
  if (!d) return 0.0;
  for (size_t i = 0; i < d->n; i++) {
    const mgs_pair *p = &d->pairs[i];
    double gp = 0.0; /* dL/dp, p = death − birth */
    int in = p->dim >= 0 && p->dim <= 2 && ((dim_mask >> p->dim) & 1u) &&
             isfinite(p->birth) && isfinite(p->death);
    if (in) {
      double pers = p->death - p->birth;
      if (kind == MGS_TOPO_LOSS_ELIMINATE) {
        if (pers < eps_sig) { loss += pers * pers; gp = 2.0 * pers; }
      } else {
        double m = eps_sig - pers;
        if (m > 0) { loss += m * m; gp = -2.0 * m; }
      }
    }
    if (dL_dbirth) dL_dbirth[i] = -gp;
    if (dL_ddeath) dL_ddeath[i] = gp;
  }
  return loss;
}

static int at_clamp(double v, double w) { return isfinite(w) && fabs(v) >= w; }

/* Calls fn(voxel, g) for every end that receives gradient. */
typedef void (*end_fn)(const int32_t *ijk, double g, void *user);
static void for_each_end(const mgs_diagram *d, const double *gb, const double *gd,
                         double clamp_w, end_fn fn, void *user) {
  for (size_t i = 0; i < d->n; i++) {
    const mgs_pair *p = &d->pairs[i];
    if (gb && gb[i] != 0.0 && isfinite(p->birth) && !at_clamp(p->birth, clamp_w))
      fn(p->b.voxel, gb[i], user);
    if (gd && gd[i] != 0.0 && isfinite(p->death) && !at_clamp(p->death, clamp_w))
      fn(p->d.voxel, gd[i], user);
  }
}

typedef struct sparse_acc { mgs_voxel_grad *v; size_t n; } sparse_acc;
static void push_sparse(const int32_t *ijk, double g, void *user) {
  sparse_acc *a = user;
  mgs_voxel_grad *e = &a->v[a->n++];
  memcpy(e->ijk, ijk, sizeof e->ijk);
  e->grad = g;
}
static void count_end(const int32_t *ijk, double g, void *user) { (void)ijk; (void)g; (*(size_t *)user)++; }

static int cmp_voxel(const void *x, const void *y) {
  const mgs_voxel_grad *a = x, *b = y;
  for (int k = 0; k < 3; k++)
    if (a->ijk[k] != b->ijk[k]) return a->ijk[k] < b->ijk[k] ? -1 : 1;
  return 0;
}

mgs_status mgs_topo_grad_to_voxels(const mgs_diagram *d, const double *dL_dbirth,
                                   const double *dL_ddeath, double clamp_w,
                                   mgs_voxel_grad **out, size_t *n_out, mgs_error *err) {
  *out = NULL; *n_out = 0;
  if (!d) return mgs_error_set(err, MGS_ERR_ARG, "topo gradient: null diagram");
  size_t n = 0;
  for_each_end(d, dL_dbirth, dL_ddeath, clamp_w, count_end, &n);
  if (n == 0) return MGS_OK;
  sparse_acc a = {malloc(n * sizeof(mgs_voxel_grad)), 0};
  if (!a.v) return mgs_error_set(err, MGS_ERR_NOMEM, "topo gradient: out of memory (%zu ends)", n);
  for_each_end(d, dL_dbirth, dL_ddeath, clamp_w, push_sparse, &a);
  qsort(a.v, a.n, sizeof *a.v, cmp_voxel);
  /* merge equal voxels (a voxel can set several ends) */
  size_t m = 0;
  for (size_t i = 0; i < a.n; i++) {
    if (m > 0 && cmp_voxel(&a.v[m - 1], &a.v[i]) == 0) a.v[m - 1].grad += a.v[i].grad;
    else a.v[m++] = a.v[i];
  }
  size_t k = 0;
  for (size_t i = 0; i < m; i++) if (a.v[i].grad != 0.0) a.v[k++] = a.v[i];
  if (k == 0) { free(a.v); return MGS_OK; }
  *out = a.v; *n_out = k;
  return MGS_OK;
}

mgs_status mgs_topo_grad_to_dense(const mgs_diagram *d, const double *dL_dbirth,
                                  const double *dL_ddeath, double clamp_w,
                                  const int32_t origin[3], const int32_t dims[3],
                                  double *grad, mgs_error *err) {
  if (!d || !grad || !origin || !dims) return mgs_error_set(err, MGS_ERR_ARG, "topo gradient: null argument");
  /* check every end first, so an error leaves grad untouched */
  for (int pass = 0; pass < 2; pass++)
    for (size_t i = 0; i < d->n; i++) {
      const mgs_pair *p = &d->pairs[i];
      for (int end = 0; end < 2; end++) {
        const double *g = end ? dL_ddeath : dL_dbirth;
        double v = end ? p->death : p->birth;
        if (!g || g[i] == 0.0 || !isfinite(v) || at_clamp(v, clamp_w)) continue;
        const int32_t *ijk = end ? p->d.voxel : p->b.voxel;
        int64_t x = (int64_t)ijk[0] - origin[0], y = (int64_t)ijk[1] - origin[1], z = (int64_t)ijk[2] - origin[2];
        if (x < 0 || y < 0 || z < 0 || x >= dims[0] || y >= dims[1] || z >= dims[2])
          return mgs_error_set(err, MGS_ERR_ARG, "topo gradient: pair %zu's %s voxel (%d,%d,%d) is outside the dense box",
                               i, end ? "death" : "birth", ijk[0], ijk[1], ijk[2]);
        if (pass == 1) grad[((size_t)x * (size_t)dims[1] + (size_t)y) * (size_t)dims[2] + (size_t)z] += g[i];
      }
    }
  return MGS_OK;
}

/* Shared pieces of train/sugar_*.c (internal to train/). */
#ifndef MGS_TRAIN_SUGAR_INTERNAL_H
#define MGS_TRAIN_SUGAR_INTERNAL_H
#include <stdint.h>
#include "core/mgs_gaussians.h"
#include "train/gauss_local.h"
#include "train/mgs_sugar.h"

#define MGS_SUGAR_KMAX 32
#define MGS_SUGAR_DMIN 1e-16       /* the authors' opacity_min_clamp */
#define MGS_SUGAR_DMAX (1 - 1e-9)  /* at and above: inside, f = 0 (√(−2 ln d) has no
                                      finite slope at d = 1) */
/* A per-Gaussian gradient row: mean 3, log-scale 3, quaternion 4, opacity logit 1. */
enum { MGS_SUGAR_ROW_MEAN = 0, MGS_SUGAR_ROW_SCALE = 3, MGS_SUGAR_ROW_ROT = 6, MGS_SUGAR_ROW_OPACITY = 10,
       MGS_SUGAR_ROW = 11 };

int mgs_sugar_min_axis(const double s2[3]);

/* The Gaussians one loss evaluation reads, in their local frame once (a sample's k
 * neighbours were each rebuilt per sample and per function: ~3k times a sample, four exp and
 * a rotation each): loc[slot[i]] is Gaussian i. NULL everywhere below = rebuild on the fly;
 * both give the same doubles (the same inline code). */
typedef struct mgs_sugar_locals {
  mgs_gauss_local *loc;
  uint32_t *slot; /* model size; UINT32_MAX: not read */
} mgs_sugar_locals;
static inline const mgs_gauss_local *mgs_sugar_local(const mgs_gaussians *g, const mgs_sugar_locals *t, uint32_t i,
                                                     mgs_gauss_local *tmp) {
  if (t) return &t->loc[t->slot[i]];
  mgs_gauss_local_get(g, i, tmp);
  return tmp;
}
void mgs_sugar_field_with(const mgs_gaussians *g, const mgs_sugar_locals *t, const double p[3], const uint32_t *nb,
                          int k, double factor, mgs_sugar_value *v);
/* rows[k * MGS_SUGAR_ROW] = w ∂f(p)/∂θ of each neighbour nb[j]. */
void mgs_sugar_sdf_rows(const mgs_gaussians *g, const mgs_sugar_locals *t, const double p[3], const uint32_t *nb,
                        int k, double factor, double w, double *rows);
/* grad row i += r. */
void mgs_sugar_scatter(mgs_gaussians *grad, uint32_t i, const double *r);
#endif

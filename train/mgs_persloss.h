/* Topology-GS's PersLoss (SPEC §5.3) as a loss term (train/mgs_term.h, image_grad hook).
 *
 * The rendered and ground-truth images are area-downsampled (torch's interpolate
 * mode='area': output floor(W·f) x floor(H·f), each output pixel the mean of its adaptive
 * window); each pixel is a point in RGB space (no image position); the filtration is the
 * Delaunay triangulation of those points with every simplex valued by its longest edge
 * ("weak alpha", topo/mgs_topo_pointcloud.h), dimensions 0..2.
 *
 *   topk  (the authors' code, default): per dimension the k_d longest finite bar lengths,
 *         sorted, zero-padded; loss = Σ_d mean_j (L_j − L̂_j)².
 *   betti (seed 001's formula): per dimension the k_d most persistent finite pairs, sorted
 *         by persistence, zero-padded; loss = Σ_d β̂_d/Σβ̂ · Σ_j ((b_j − b̂_j)² + (d_j − d̂_j)²),
 *         β̂_d = the ground truth's number of finite bars of dimension d.
 *
 * Gradient: a bar end is the length of one critical edge, so it moves the edge's two
 * points by ±g·(y_i − y_j)/‖y_i − y_j‖ (zero-length edges get none), then back through the
 * area downsampling to the rendered pixels. Pixels of exactly equal colour are one point
 * (the first of them in raster order receives the gradient). The pairing is held fixed
 * (sorted order at the evaluated image), as autograd does.
 *
 * The ground truth's features are computed once per training image on first use and
 * kept in memory; they are not written to checkpoints (they are a deterministic function
 * of the image, recomputed after --resume). */
#ifndef MGS_PERSLOSS_H
#define MGS_PERSLOSS_H
#include "train/mgs_term.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum { MGS_PERSLOSS_TOPK = 0, MGS_PERSLOSS_BETTI = 1 } mgs_persloss_form;

typedef struct mgs_persloss_options {
  double lambda;        /* 10 */
  mgs_persloss_form form;
  int from, until, every; /* active when from <= it <= until and it % every == 0:
                             1500, 15000, 200 -> 1600..15000, 68 times (the authors') */
  double downsample;    /* 0.09 (the authors' for NeRF-synthetic; 0.06..0.1 elsewhere) */
  int k[3];             /* 10, 20, 50 */
} mgs_persloss_options;
void mgs_persloss_options_default(mgs_persloss_options *o);
/* Checks ranges; MGS_ERR_ARG with a message naming the option. */
mgs_status mgs_persloss_options_check(const mgs_persloss_options *o, mgs_error *err);

/* The term; its `value` is lambda x the loss. */
mgs_status mgs_term_persloss_create(const mgs_persloss_options *o, mgs_term **out, mgs_error *err);

/* The loss (without lambda) of image `img` against `gt` (w x h x 3 each) and, if grad is
 * non-NULL, its gradient with respect to img *added* into grad (times `scale`). Exposed for
 * tests and benchmarks; the term caches the ground truth's side. */
mgs_status mgs_persloss_eval(const mgs_persloss_options *o, const float *img, const float *gt, int w, int h,
                             double scale, double *loss, float *grad, mgs_error *err);

#ifdef __cplusplus
}
#endif
#endif

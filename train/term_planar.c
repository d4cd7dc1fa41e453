/* GaussianPro's planar loss, its depth half (train/mgs_gaussianpro.h): weight x the mean
 * over the view's checked propagated depth of |rendered depth - propagated depth|, the
 * rendered depth being the rasterizer's sum w z (what its backward takes a gradient for).
 * Views without a checked propagated depth (not yet matched as the reference) add
 * nothing, as the authors' cameras without a propagated normal.
 *
 * Deliberate difference: the authors' planar loss is on normals (0.001 L1 + 0.001 cosine
 * between the rendered normal and the propagated one); the 3DGS rasterizer here has no
 * backward for its normal map (render/raster_maps.c is forward only), so this term
 * constrains the depth that the propagated planes give instead. The term renders the view
 * once more (forward + backward) in each iteration where it is active. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "render/mgs_raster.h"
#include "train/mgs_gaussianpro.h"
#include "train/mgs_term.h"

typedef struct planar {
  const mgs_gpro *pro;
  double weight;
  int from;
  mgs_raster *raster;
  float *dl_ddepth, *dl_dcolor;
  size_t cap;
} planar;

static unsigned planar_active(void *self, int it) {
  planar *t = self;
  return t->weight > 0 && it > t->from ? MGS_TERM_MODEL : 0u;
}

mgs_status mgs_planar_loss(mgs_raster *r, const mgs_gaussians *g, const mgs_camera *cam, const float *target, double weight,
                           float **dl_ddepth, float **dl_dcolor, size_t *cap, mgs_gaussians *grad, double *value,
                           mgs_error *err) {
  *value = 0;
  size_t np = (size_t)cam->width * (size_t)cam->height, valid = 0;
  for (size_t k = 0; k < np; k++) valid += target[k] > 0;
  if (!valid) return MGS_OK;
  if (np > *cap) {
    float *a = realloc(*dl_ddepth, np * sizeof(float));
    if (a) *dl_ddepth = a;
    float *b = a ? realloc(*dl_dcolor, 3 * np * sizeof(float)) : NULL;
    if (b) *dl_dcolor = b;
    if (!a || !b) return mgs_error_set(err, MGS_ERR_NOMEM, "planar loss: out of memory");
    *cap = np;
  }
  mgs_raster_settings rs;
  mgs_raster_settings_default(&rs);
  rs.sh_degree = 0;
  mgs_raster_output ro;
  mgs_status st = mgs_raster_forward(r, g, cam, &rs, &ro, err);
  if (st) return st;
  double sum = 0, w = weight / (double)valid;
  for (size_t k = 0; k < np; k++) {
    float d = target[k] > 0 ? ro.depth[k] - target[k] : 0.0f;
    sum += fabs((double)d);
    (*dl_ddepth)[k] = d > 0 ? (float)w : d < 0 ? (float)-w : 0.0f;
  }
  memset(*dl_dcolor, 0, 3 * np * sizeof(float));
  *value = w * sum;
  return grad ? mgs_raster_backward(r, *dl_dcolor, NULL, *dl_ddepth, grad, NULL, err) : MGS_OK;
}

static mgs_status planar_model_grad(void *self, mgs_term_step *s, mgs_error *err) {
  planar *t = self;
  s->value = 0;
  const float *target = mgs_gpro_checked_depth(t->pro, s->view_index);
  if (!target) return MGS_OK;
  return mgs_planar_loss(t->raster, s->model, &s->view->cam, target, t->weight, &t->dl_ddepth, &t->dl_dcolor, &t->cap,
                         s->grad, &s->value, err);
}

static void planar_destroy(void *self) {
  planar *t = self;
  if (!t) return;
  mgs_raster_destroy(t->raster);
  free(t->dl_ddepth);
  free(t->dl_dcolor);
  free(t);
}

static const mgs_term_ops planar_ops = {"planar", planar_active, NULL, planar_model_grad, NULL, NULL, planar_destroy};

mgs_status mgs_term_planar_create(const mgs_gpro *pro, double weight, int from, mgs_term **out, mgs_error *err) {
  *out = NULL;
  planar *t = calloc(1, sizeof *t);
  if (t) t->raster = mgs_raster_create();
  if (!t || !t->raster) {
    planar_destroy(t);
    return mgs_error_set(err, MGS_ERR_NOMEM, "planar loss: out of memory");
  }
  t->pro = pro;
  t->weight = weight;
  t->from = from;
  *out = mgs_term_create(&planar_ops, t);
  return *out ? MGS_OK : mgs_error_set(err, MGS_ERR_NOMEM, "planar loss: out of memory");
}

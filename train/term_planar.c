/* GaussianPro's planar loss (train/mgs_gaussianpro.h) on the views matched as the
 * reference, from the maps of the iteration's own render; its gradient joins that render's
 * backward (dL/d(depth) and the normal map's gradient), as the authors' one loss.backward()
 * (so it also enters the densification statistics, as theirs does):
 *
 *   normal half  w_normal x mean over the accepted pixels of (1 - cos(N, n_p)), N the
 *                rendered normal (sum_i w_i n_i, render/mgs_render_maps.h; the authors
 *                normalize it, so the cosine), n_p the propagated normal; its gradient
 *                enters through mgs_raster_map_grads (the 3DGS normal map's backward).
 *                The authors' weight 0.001 (lambda_cos_normal of their demo script) and
 *                mask (normal_gt != -10: >= 2 consistent neighbours, sky mask). Where
 *                nothing is rendered (N = 0) their F.normalize gives 0: a cost of 1, no
 *                gradient; the same here.
 *   depth half   w_depth x mean |sum w z - propagated depth| over the checked propagated
 *                depth (our addition, docs/notes/gaussianpro.md: before the normal map
 *                had a backward it stood in for the normal half).
 *
 *   L1 half      w_l1 x mean over the same pixels of sum_j |R N/|N| - R n_p|_j, R the
 *                camera's world-to-camera rotation: the authors' lambda_l1_normal (0.001
 *                in their demo script) on camera-frame normals, summed over the channels. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "render/mgs_raster.h"
#include "train/mgs_gaussianpro.h"
#include "train/mgs_term.h"

typedef struct planar {
  const mgs_gpro *pro;
  double weight, weight_normal, weight_l1;
  int from;
} planar;

static unsigned planar_active(void *self, int it) {
  planar *t = self;
  if (!((t->weight > 0 || t->weight_normal > 0 || t->weight_l1 > 0) && it > t->from)) return 0u;
  return MGS_TERM_IMAGE | MGS_TERM_MAPS | (t->weight > 0 ? MGS_TERM_DEPTH : 0u);
}

mgs_status mgs_planar_loss_add(mgs_raster *r, const mgs_camera *cam, const mgs_planar_target *tg, const float *depth,
                               float *dl_ddepth, int *depth_used, int want_grad, double *value, mgs_error *err) {
  *value = 0;
  size_t np = (size_t)cam->width * (size_t)cam->height, valid = 0, valid_n = 0;
  const float *target = tg->w_depth > 0 ? tg->depth : NULL, *tn = tg->w_normal > 0 || tg->w_l1 > 0 ? tg->normal : NULL;
  if (target)
    for (size_t k = 0; k < np; k++) valid += target[k] > 0;
  if (tn)
    for (size_t k = 0; k < np; k++) valid_n += tn[3 * k] != 0 || tn[3 * k + 1] != 0 || tn[3 * k + 2] != 0;
  if (valid) {
    if (want_grad && !dl_ddepth)
      return mgs_error_set(err, MGS_ERR_ARG, "planar loss: a depth target but no depth gradient buffer");
    double sum = 0, w = tg->w_depth / (double)valid;
    for (size_t k = 0; k < np; k++) {
      float d = target[k] > 0 ? depth[k] - target[k] : 0.0f;
      sum += fabs((double)d);
      if (want_grad) dl_ddepth[k] += d > 0 ? (float)w : d < 0 ? (float)-w : 0.0f;
    }
    if (want_grad && depth_used) *depth_used = 1;
    *value = w * sum;
  }
  if (valid_n) {
    mgs_render_maps mp;
    mgs_raster_map_grad mg;
    mgs_status st = mgs_raster_maps(r, MGS_MAP_NORMAL, &mp, err);
    if (st == MGS_OK && want_grad) st = mgs_raster_map_grads(r, &mg, err);
    if (st) return st;
    const double wn = tg->w_normal / (double)valid_n, wl = tg->w_l1 / (double)valid_n;
    const double *R = cam->w2c; /* rows 0..2, columns 0..2: world -> camera rotation */
    double cost = 0, cost_l1 = 0;
    for (size_t k = 0; k < np; k++) {
      const float *t = tn + 3 * k, *N = mp.normal + 3 * k;
      if (t[0] == 0 && t[1] == 0 && t[2] == 0) continue;
      double tc[3];
      for (int a = 0; a < 3; a++) tc[a] = R[4 * a] * t[0] + R[4 * a + 1] * t[1] + R[4 * a + 2] * t[2];
      double len = sqrt((double)N[0] * N[0] + (double)N[1] * N[1] + (double)N[2] * N[2]);
      if (!(len > 1e-12)) { /* F.normalize(0) = 0: the cosine 0, the L1 |n|_1; no gradient */
        cost += 1;
        cost_l1 += fabs(tc[0]) + fabs(tc[1]) + fabs(tc[2]);
        continue;
      }
      double c = (N[0] * (double)t[0] + N[1] * (double)t[1] + N[2] * (double)t[2]) / len;
      cost += 1 - c;
      /* L1: s = sign(R u - R t), u = N/|N|; dL/du = R^T s, dL/dN = (g - u (u.g)) / |N| */
      double u[3] = {N[0] / len, N[1] / len, N[2] / len}, gu[3] = {0, 0, 0};
      for (int a = 0; a < 3; a++) {
        double d = R[4 * a] * u[0] + R[4 * a + 1] * u[1] + R[4 * a + 2] * u[2] - tc[a];
        cost_l1 += fabs(d);
        double s = d > 0 ? 1.0 : d < 0 ? -1.0 : 0.0;
        for (int j = 0; j < 3; j++) gu[j] += R[4 * a + j] * s;
      }
      const double ug = u[0] * gu[0] + u[1] * gu[1] + u[2] * gu[2];
      /* d(-N.t/|N|)/dN = -(t - c N/|N|)/|N| */
      if (want_grad)
        for (int j = 0; j < 3; j++)
          mg.normal[3 * k + j] += (float)(-wn * (t[j] - c * u[j]) / len + wl * (gu[j] - u[j] * ug) / len);
    }
    *value += wn * cost + wl * cost_l1;
  }
  return MGS_OK;
}

mgs_status mgs_planar_loss(mgs_raster *r, const mgs_gaussians *g, const mgs_camera *cam, const mgs_planar_target *tg,
                           float **dl_ddepth, float **dl_dcolor, size_t *cap, mgs_gaussians *grad, double *value,
                           mgs_error *err) {
  *value = 0;
  size_t np = (size_t)cam->width * (size_t)cam->height;
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
  memset(*dl_ddepth, 0, np * sizeof(float));
  memset(*dl_dcolor, 0, 3 * np * sizeof(float));
  int used = 0;
  if ((st = mgs_planar_loss_add(r, cam, tg, ro.depth, *dl_ddepth, &used, grad != NULL, value, err))) return st;
  return grad ? mgs_raster_backward(r, *dl_dcolor, NULL, used ? *dl_ddepth : NULL, grad, NULL, err) : MGS_OK;
}

/* On the iteration's own render (s->raster): its maps, and the depth gradient joins the
   trainer's backward (as the authors' loss.backward() over one render). */
static mgs_status planar_image_grad(void *self, mgs_term_step *s, mgs_error *err) {
  planar *t = self;
  s->value = 0;
  mgs_planar_target tg = {mgs_gpro_checked_depth(t->pro, s->view_index), mgs_gpro_checked_normal(t->pro, s->view_index),
                          t->weight, t->weight_normal, t->weight_l1};
  if (!tg.depth && !tg.normal) return MGS_OK;
  double v = 0;
  mgs_status st = mgs_planar_loss_add(s->raster, &s->view->cam, &tg, s->depth, s->dl_ddepth, &s->dl_ddepth_used, 1, &v, err);
  s->value = v;
  return st;
}

static void planar_destroy(void *self) {
  planar *t = self;
  if (!t) return;
  free(t);
}

static const mgs_term_ops planar_ops = {"planar", planar_active, planar_image_grad, NULL, NULL, NULL, planar_destroy, NULL};

mgs_status mgs_term_planar_create(const mgs_gpro *pro, double weight, double weight_normal, double weight_l1, int from,
                                  mgs_term **out, mgs_error *err) {
  *out = NULL;
  if (!(weight >= 0) || !(weight_normal >= 0) || !(weight_l1 >= 0))
    return mgs_error_set(err, MGS_ERR_ARG, "planar loss: negative weight (depth %g, normal %g, L1 %g)", weight, weight_normal,
                         weight_l1);
  planar *t = calloc(1, sizeof *t);
  if (!t) return mgs_error_set(err, MGS_ERR_NOMEM, "planar loss: out of memory");
  t->pro = pro;
  t->weight = weight;
  t->weight_normal = weight_normal;
  t->weight_l1 = weight_l1;
  t->from = from;
  *out = mgs_term_create(&planar_ops, t);
  return *out ? MGS_OK : mgs_error_set(err, MGS_ERR_NOMEM, "planar loss: out of memory");
}

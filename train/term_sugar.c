/* The loss term of SuGaR's coarse stage (train/mgs_sugar.h), as sugar_trainers/coarse_sdf.py
 * runs it from a 3DGS model at from_iter:
 *   from_iter < it < prune_at   opacity entropy of the Gaussians the view sees (radii > 0)
 *   it > prune_at               the SDF loss and the normal loss on samples near the
 *                               visible surface of this view
 * The samples, per iteration: the visible Gaussians whose centre lies within close_sigmas
 * standard deviations (along the view ray) of the rendered depth at their pixel; `samples`
 * points drawn uniformly among them, μ + R (1.5 s ⊙ ε), ε ~ N(0, I); the SDF estimate of a
 * sample is |D − z|, D the rendered depth at its pixel (bilinear, border clamp: the
 * authors' grid_sample), z its own depth. D is the authors' depth render: Σ w z + T·z_max
 * (background at the largest centre depth of the view).
 * Differences from the authors, both to keep the term a model-gradient term: the samples
 * and D are held fixed (the authors also differentiate the sample positions and, through
 * the rasterizer, D); the neighbour lists of the samples are those of the Gaussian they
 * were drawn in (as the authors). Neighbours are rebuilt every knn_every iterations and
 * whenever the count changed (after the prune); they are checkpointed so a resumed run
 * continues with the same lists. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "train/mgs_sugar.h"
#include "train/gauss_local.h"
#include "core/mgs_camera.h"

void mgs_sugar_options_default(mgs_sugar_options *o) {
  o->from_iter = 7000;
  o->prune_at = 9000;
  o->prune_alpha = 0.5;
  o->entropy = 0.1;
  o->sdf_weight = 0.2;
  o->normal_weight = 0.2;
  o->samples = 20000;
  o->knn_every = 500;
  o->density_factor = 1.0 / 16;
  o->sample_scale = 1.5;
  o->close_sigmas = 2.0;
}

typedef struct sugar_term {
  mgs_sugar_options o;
  uint32_t *knn;
  int k;
  size_t knn_n;   /* model count the lists were built for (0: none) */
  mgs_sugar_sample *s;
  size_t s_cap;
  uint32_t *close;
  size_t close_cap;
} sugar_term;

static unsigned sugar_active(void *self, int it) {
  const mgs_sugar_options *o = &((sugar_term *)self)->o;
  if (it > o->from_iter && it < o->prune_at && o->entropy > 0) return MGS_TERM_MODEL;
  if (it > o->prune_at && (o->sdf_weight > 0 || o->normal_weight > 0)) return MGS_TERM_MODEL;
  return 0;
}

/* D at continuous pixel (u, v) (pixel centres at +0.5), bilinear with border clamp. */
static double depth_at(const float *D, int w, int h, double u, double v) {
  double x = u - 0.5, y = v - 0.5;
  x = x < 0 ? 0 : x > w - 1 ? w - 1 : x;
  y = y < 0 ? 0 : y > h - 1 ? h - 1 : y;
  int x0 = (int)x, y0 = (int)y;
  int x1 = x0 + 1 < w ? x0 + 1 : x0, y1 = y0 + 1 < h ? y0 + 1 : y0;
  double fx = x - x0, fy = y - y0;
  double a = D[(size_t)y0 * w + x0] * (1 - fx) + D[(size_t)y0 * w + x1] * fx;
  double b = D[(size_t)y1 * w + x0] * (1 - fx) + D[(size_t)y1 * w + x1] * fx;
  return a * (1 - fy) + b * fy;
}

/* The training views' cameras are in the model's local frame (core/dataset.c moves them). */
static int project(const mgs_camera *cam, const double p[3], double *u, double *v, double *z) {
  return mgs_camera_project(cam, p, u, v, z);
}

static mgs_status sdf_step(sugar_term *t, mgs_term_step *s, mgs_error *err) {
  const mgs_gaussians *g = s->model;
  const mgs_sugar_options *o = &t->o;
  if (!s->depth || !s->alpha || !s->radii)
    return mgs_error_set(err, MGS_ERR_ARG, "sugar: the trainer handed no depth/alpha/radii to the term");
  if (!t->knn || t->knn_n != g->n || s->iteration % o->knn_every == 0) {
    free(t->knn);
    t->knn = NULL;
    t->knn_n = 0;
    if (!g->n) return MGS_OK;
    mgs_status st = mgs_sugar_knn(g, MGS_SUGAR_KNN, &t->knn, &t->k, err);
    if (st) return st;
    t->knn_n = g->n;
  }
  const mgs_camera *cam = &s->view->cam;
  int w = s->width, h = s->height;
  size_t np = (size_t)w * (size_t)h;
  /* the authors' depth render: background at the largest centre depth of the view */
  double zmax = 0, cc[3];
  mgs_camera_center(cam, cc);
  for (size_t i = 0; i < g->n; i++) {
    if (s->radii[i] <= 0) continue;
    double mu[3] = {g->mean[3 * i], g->mean[3 * i + 1], g->mean[3 * i + 2]}, u, v, z;
    if (project(cam, mu, &u, &v, &z) && z > zmax) zmax = z;
  }
  float *D = malloc(np * sizeof *D);
  if (!D) return mgs_error_set(err, MGS_ERR_NOMEM, "sugar: out of memory for a depth map");
  for (size_t p = 0; p < np; p++) D[p] = (float)(s->depth[p] + (1.0 - s->alpha[p]) * zmax);
  /* the Gaussians near the visible surface */
  if (t->close_cap < g->n) {
    uint32_t *c = realloc(t->close, g->n * sizeof *c);
    if (!c) { free(D); return mgs_error_set(err, MGS_ERR_NOMEM, "sugar: out of memory"); }
    t->close = c;
    t->close_cap = g->n;
  }
  size_t nc = 0;
  for (size_t i = 0; i < g->n; i++) {
    if (s->radii[i] <= 0) continue;
    mgs_gauss_local L;
    mgs_gauss_local_get(g, i, &L);
    double u, v, z;
    if (!project(cam, L.mu, &u, &v, &z)) continue;
    double dir[3], len = 0;
    for (int a = 0; a < 3; a++) { dir[a] = cc[a] - L.mu[a]; len += dir[a] * dir[a]; }
    len = sqrt(len);
    double sig = 0; /* |S Rᵀ v|: the authors' standard deviation toward the camera */
    for (int a = 0; a < 3; a++) {
      double y = (L.R[a] * dir[0] + L.R[3 + a] * dir[1] + L.R[6 + a] * dir[2]) / (len > 0 ? len : 1);
      sig += L.s2[a] * y * y;
    }
    if (fabs(depth_at(D, w, h, u, v) - z) < o->close_sigmas * sqrt(sig)) t->close[nc++] = (uint32_t)i;
  }
  double value = 0;
  mgs_status st = MGS_OK;
  if (nc) {
    size_t m = (size_t)o->samples;
    if (t->s_cap < m) {
      mgs_sugar_sample *ns = realloc(t->s, m * sizeof *ns);
      if (!ns) { free(D); return mgs_error_set(err, MGS_ERR_NOMEM, "sugar: out of memory for %zu samples", m); }
      t->s = ns;
      t->s_cap = m;
    }
    size_t kept = 0;
    for (size_t i = 0; i < m; i++) {
      uint32_t gi = t->close[mgs_rng_below(s->rng, (uint32_t)nc)];
      mgs_gauss_local L;
      mgs_gauss_local_get(g, gi, &L);
      double e[3], p[3];
      for (int a = 0; a < 3; a++) e[a] = o->sample_scale * sqrt(L.s2[a]) * mgs_rng_normal(s->rng);
      for (int a = 0; a < 3; a++) p[a] = L.mu[a] + L.R[3 * a] * e[0] + L.R[3 * a + 1] * e[1] + L.R[3 * a + 2] * e[2];
      double u, v, z;
      if (!project(cam, p, &u, &v, &z)) continue; /* behind the camera: the authors' proj_mask */
      mgs_sugar_sample *sm = t->s + kept++;
      memcpy(sm->p, p, sizeof p);
      sm->gauss = gi;
      sm->target = fabs(depth_at(D, w, h, u, v) - z);
    }
    double v1 = 0, v2 = 0;
    if (o->sdf_weight > 0)
      st = mgs_sugar_sdf_loss(g, t->knn, t->k, t->s, kept, o->density_factor, s->extent / 10, o->sdf_weight, s->grad,
                              &v1, err);
    if (st == MGS_OK && o->normal_weight > 0)
      st = mgs_sugar_normal_loss(g, t->knn, t->k, t->s, kept, o->density_factor, NULL, NULL, o->normal_weight,
                                 s->grad, &v2, err);
    value = v1 + v2;
  }
  free(D);
  s->value = value;
  return st;
}

static mgs_status sugar_model_grad(void *self, mgs_term_step *s, mgs_error *err) {
  sugar_term *t = self;
  if (s->iteration < t->o.prune_at)
    return mgs_sugar_entropy_loss(s->model, s->radii, t->o.entropy, s->grad, &s->value, err);
  return sdf_step(t, s, err);
}

static mgs_status sugar_save(void *self, FILE *f, mgs_error *err) {
  sugar_term *t = self;
  uint64_t n = t->knn ? t->knn_n : 0;
  int32_t k = t->k;
  int ok = fwrite(&n, sizeof n, 1, f) == 1 && fwrite(&k, sizeof k, 1, f) == 1;
  if (ok && n) ok = fwrite(t->knn, sizeof *t->knn, (size_t)n * (size_t)k, f) == (size_t)n * (size_t)k;
  return ok ? MGS_OK : mgs_error_set(err, MGS_ERR_IO, "sugar: cannot write its neighbours to the checkpoint");
}

static mgs_status sugar_load(void *self, FILE *f, mgs_error *err) {
  sugar_term *t = self;
  uint64_t n;
  int32_t k;
  if (fread(&n, sizeof n, 1, f) != 1 || fread(&k, sizeof k, 1, f) != 1 || (n && (k < 1 || k > MGS_SUGAR_KNN)) ||
      n > ((uint64_t)1 << 40))
    return mgs_error_set(err, MGS_ERR_FORMAT, "checkpoint: the sugar term's state is malformed");
  free(t->knn);
  t->knn = NULL;
  t->knn_n = 0;
  if (!n) return MGS_OK;
  t->knn = malloc((size_t)n * (size_t)k * sizeof *t->knn);
  if (!t->knn) return mgs_error_set(err, MGS_ERR_NOMEM, "sugar: out of memory loading neighbours");
  if (fread(t->knn, sizeof *t->knn, (size_t)n * (size_t)k, f) != (size_t)n * (size_t)k)
    return mgs_error_set(err, MGS_ERR_FORMAT, "checkpoint truncated in the sugar term's neighbours");
  for (size_t i = 0; i < (size_t)n * (size_t)k; i++)
    if (t->knn[i] >= n) return mgs_error_set(err, MGS_ERR_FORMAT, "checkpoint: a sugar neighbour index is out of range");
  t->knn_n = (size_t)n;
  t->k = k;
  return MGS_OK;
}

static void sugar_destroy(void *self) {
  sugar_term *t = self;
  if (!t) return;
  free(t->knn);
  free(t->s);
  free(t->close);
  free(t);
}

static const mgs_term_ops sugar_ops = {"sugar", sugar_active, NULL, sugar_model_grad, sugar_save, sugar_load,
                                       sugar_destroy, NULL};

mgs_status mgs_term_sugar_create(const mgs_sugar_options *o, mgs_term **out, mgs_error *err) {
  *out = NULL;
  if (o->samples < 1 || o->knn_every < 1 || !(o->density_factor > 0) || !(o->sample_scale > 0))
    return mgs_error_set(err, MGS_ERR_ARG, "sugar: samples, neighbour interval, density factor and sample scale must be positive");
  sugar_term *t = calloc(1, sizeof *t);
  if (!t) return mgs_error_set(err, MGS_ERR_NOMEM, "sugar: out of memory");
  t->o = *o;
  *out = mgs_term_create(&sugar_ops, t);
  return *out ? MGS_OK : mgs_error_set(err, MGS_ERR_NOMEM, "sugar: out of memory");
}

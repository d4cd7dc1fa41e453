/* PersLoss (train/mgs_persloss.h). */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "topo/mgs_topo_pointcloud.h"
#include "train/mgs_persloss.h"

void mgs_persloss_options_default(mgs_persloss_options *o) {
  o->lambda = 10.0;
  o->form = MGS_PERSLOSS_TOPK;
  o->from = 1500;
  o->until = 15000;
  o->every = 200;
  o->downsample = 0.09;
  o->k[0] = 10; o->k[1] = 20; o->k[2] = 50;
}

mgs_status mgs_persloss_options_check(const mgs_persloss_options *o, mgs_error *err) {
  if (!(o->lambda >= 0) || !isfinite(o->lambda)) return mgs_error_set(err, MGS_ERR_ARG, "--pers-loss: weight %g must be a finite number >= 0", o->lambda);
  if (!(o->downsample > 0 && o->downsample <= 1)) return mgs_error_set(err, MGS_ERR_ARG, "--pers-loss-downsample: %g must be in (0, 1]", o->downsample);
  if (o->every < 1 || o->from < 0 || o->until < o->from) return mgs_error_set(err, MGS_ERR_ARG, "--pers-loss-schedule: from %d until %d every %d (need 0 <= from <= until, every >= 1)", o->from, o->until, o->every);
  for (int d = 0; d < 3; d++)
    if (o->k[d] < 0 || o->k[d] > 100000) return mgs_error_set(err, MGS_ERR_ARG, "--pers-loss-k: k%d = %d (0..100000)", d, o->k[d]);
  if (o->form != MGS_PERSLOSS_TOPK && o->form != MGS_PERSLOSS_BETTI) return mgs_error_set(err, MGS_ERR_ARG, "--pers-loss-form: unknown form");
  return MGS_OK;
}

/* ---------------------------------------------------------------- downsampling */

typedef struct ds_img { int w, h; double *pts; } ds_img; /* w*h points, 3 doubles */

static int out_size(int n, double f) {
  int m = (int)floor((double)n * f);
  return m < 1 ? 1 : m;
}
/* adaptive window of output index i among m over n inputs: [floor(i n/m), ceil((i+1) n/m)) */
static void window(int i, int m, int n, int *b, int *e) {
  *b = (int)(((long long)i * n) / m);
  *e = (int)(((long long)(i + 1) * n + m - 1) / m);
}

static mgs_status downsample(const float *img, int w, int h, double f, ds_img *o, mgs_error *err) {
  o->w = out_size(w, f);
  o->h = out_size(h, f);
  o->pts = malloc((size_t)o->w * (size_t)o->h * 3 * sizeof *o->pts);
  if (!o->pts) return mgs_error_set(err, MGS_ERR_NOMEM, "PersLoss: out of memory");
  for (int y = 0; y < o->h; y++) {
    int yb, ye;
    window(y, o->h, h, &yb, &ye);
    for (int x = 0; x < o->w; x++) {
      int xb, xe;
      window(x, o->w, w, &xb, &xe);
      double s[3] = {0, 0, 0};
      for (int yy = yb; yy < ye; yy++)
        for (int xx = xb; xx < xe; xx++)
          for (int a = 0; a < 3; a++) s[a] += img[((size_t)yy * (size_t)w + (size_t)xx) * 3 + (size_t)a];
      double cnt = (double)(ye - yb) * (double)(xe - xb);
      for (int a = 0; a < 3; a++) {
        double v = s[a] / cnt;
        if (!isfinite(v)) { free(o->pts); o->pts = NULL; return mgs_error_set(err, MGS_ERR_NUMERIC, "PersLoss: the image has a non-finite pixel"); }
        o->pts[((size_t)y * (size_t)o->w + (size_t)x) * 3 + (size_t)a] = v;
      }
    }
  }
  return MGS_OK;
}

/* ---------------------------------------------------------------- features */

/* One selected bar per slot: its (birth, death) and the critical edges (-1: none / pad). */
typedef struct feat {
  int n[3];             /* filled slots per dimension (the rest are zero pads) */
  int beta[3];          /* finite bars per dimension */
  double *b[3], *d[3];  /* k[d] slots */
  int32_t (*be[3])[2], (*de[3])[2];
} feat;

static void feat_free(feat *f) {
  for (int d = 0; d < 3; d++) { free(f->b[d]); free(f->d[d]); free(f->be[d]); free(f->de[d]); }
  memset(f, 0, sizeof *f);
}

typedef struct bar_ref { double pers, birth; size_t i; } bar_ref;
static int cmp_bar(const void *x, const void *y) {
  const bar_ref *a = x, *b = y;
  if (a->pers != b->pers) return a->pers > b->pers ? -1 : 1; /* longest first */
  if (a->birth != b->birth) return a->birth < b->birth ? -1 : 1;
  return a->i < b->i ? -1 : a->i > b->i;
}

static mgs_status features(const mgs_persloss_options *o, const ds_img *im, feat *f, mgs_error *err) {
  memset(f, 0, sizeof *f);
  mgs_topo_bars bars;
  mgs_topo_bars_init(&bars);
  mgs_status st = mgs_topo_weak_alpha_persistence(im->pts, (size_t)im->w * (size_t)im->h, &bars, err);
  bar_ref *r = NULL;
  if (st) goto out;
  r = malloc((bars.n + 1) * sizeof *r);
  if (!r) { st = mgs_error_set(err, MGS_ERR_NOMEM, "PersLoss: out of memory"); goto out; }
  for (int d = 0; d < 3; d++) {
    size_t m = 0;
    for (size_t i = 0; i < bars.n; i++) {
      const mgs_topo_bar *x = &bars.bars[i];
      if (x->dim != d || !isfinite(x->death)) continue;
      r[m++] = (bar_ref){x->death - x->birth, x->birth, i};
    }
    qsort(r, m, sizeof *r, cmp_bar);
    int k = o->k[d];
    f->beta[d] = (int)m;
    f->n[d] = (int)(m < (size_t)k ? m : (size_t)k);
    f->b[d] = calloc((size_t)k + 1, sizeof(double));
    f->d[d] = calloc((size_t)k + 1, sizeof(double));
    f->be[d] = malloc(((size_t)k + 1) * sizeof *f->be[d]);
    f->de[d] = malloc(((size_t)k + 1) * sizeof *f->de[d]);
    if (!f->b[d] || !f->d[d] || !f->be[d] || !f->de[d]) { st = mgs_error_set(err, MGS_ERR_NOMEM, "PersLoss: out of memory"); goto out; }
    for (int j = 0; j < f->n[d]; j++) {
      const mgs_topo_bar *x = &bars.bars[r[j].i];
      f->b[d][j] = x->birth;
      f->d[d][j] = x->death;
      memcpy(f->be[d][j], x->birth_edge, sizeof x->birth_edge);
      memcpy(f->de[d][j], x->death_edge, sizeof x->death_edge);
    }
  }
out:
  free(r);
  mgs_topo_bars_free(&bars);
  if (st) feat_free(f);
  return st;
}

/* Loss of features `a` (image) against `g` (ground truth); per-slot derivatives of the
 * loss with respect to a's births and deaths in db/dd (k[d] each) when non-NULL. */
static double loss_of(const mgs_persloss_options *o, const feat *a, const feat *g, double *db[3], double *dd[3]) {
  double L = 0;
  double bsum = (double)g->beta[0] + g->beta[1] + g->beta[2];
  for (int d = 0; d < 3; d++) {
    int k = o->k[d];
    if (k == 0) continue;
    for (int j = 0; j < k; j++) {
      double ab = j < a->n[d] ? a->b[d][j] : 0, ad = j < a->n[d] ? a->d[d][j] : 0;
      double gb = j < g->n[d] ? g->b[d][j] : 0, gd = j < g->n[d] ? g->d[d][j] : 0;
      if (o->form == MGS_PERSLOSS_TOPK) {
        double diff = (ad - ab) - (gd - gb);
        L += diff * diff / k;
        if (db) { dd[d][j] = 2 * diff / k; db[d][j] = -2 * diff / k; }
      } else {
        double w = bsum > 0 ? g->beta[d] / bsum : 0;
        L += w * ((ab - gb) * (ab - gb) + (ad - gd) * (ad - gd));
        if (db) { db[d][j] = 2 * w * (ab - gb); dd[d][j] = 2 * w * (ad - gd); }
      }
    }
  }
  return L;
}

/* Adds g · d(edge length)/d(points) into gp (w*h x 3). */
static void edge_grad(const ds_img *im, const int32_t e[2], double g, double *gp) {
  if (e[0] < 0 || g == 0) return;
  const double *p = im->pts + 3 * (size_t)e[0], *q = im->pts + 3 * (size_t)e[1];
  double v[3] = {p[0] - q[0], p[1] - q[1], p[2] - q[2]};
  double len = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  if (!(len > 1e-12)) return; /* zero-length edge: no direction (duplicate-like pixels) */
  for (int a = 0; a < 3; a++) {
    gp[3 * (size_t)e[0] + (size_t)a] += g * v[a] / len;
    gp[3 * (size_t)e[1] + (size_t)a] -= g * v[a] / len;
  }
}

/* Gradient of the features' loss, back through the downsampling into grad (w x h). */
static mgs_status backward(const mgs_persloss_options *o, const ds_img *im, const feat *a, const feat *g, int w, int h,
                           double scale, float *grad, mgs_error *err) {
  double *db[3] = {0}, *dd[3] = {0};
  double *gp = calloc((size_t)im->w * (size_t)im->h * 3, sizeof *gp);
  mgs_status st = MGS_OK;
  for (int d = 0; d < 3; d++) {
    db[d] = calloc((size_t)o->k[d] + 1, sizeof(double));
    dd[d] = calloc((size_t)o->k[d] + 1, sizeof(double));
    if (!db[d] || !dd[d]) gp = (free(gp), NULL);
  }
  if (!gp) { st = mgs_error_set(err, MGS_ERR_NOMEM, "PersLoss: out of memory"); goto out; }
  loss_of(o, a, g, db, dd);
  for (int d = 0; d < 3; d++)
    for (int j = 0; j < a->n[d]; j++) { /* pads are constants */
      edge_grad(im, a->be[d][j], db[d][j], gp);
      edge_grad(im, a->de[d][j], dd[d][j], gp);
    }
  for (int y = 0; y < im->h; y++) {
    int yb, ye;
    window(y, im->h, h, &yb, &ye);
    for (int x = 0; x < im->w; x++) {
      const double *gq = gp + ((size_t)y * (size_t)im->w + (size_t)x) * 3;
      if (gq[0] == 0 && gq[1] == 0 && gq[2] == 0) continue;
      int xb, xe;
      window(x, im->w, w, &xb, &xe);
      double inv = scale / ((double)(ye - yb) * (double)(xe - xb));
      for (int yy = yb; yy < ye; yy++)
        for (int xx = xb; xx < xe; xx++)
          for (int c = 0; c < 3; c++) grad[((size_t)yy * (size_t)w + (size_t)xx) * 3 + (size_t)c] += (float)(gq[c] * inv);
    }
  }
out:
  free(gp);
  for (int d = 0; d < 3; d++) { free(db[d]); free(dd[d]); }
  return st;
}

static mgs_status image_features(const mgs_persloss_options *o, const float *img, int w, int h, ds_img *im, feat *f,
                                 mgs_error *err) {
  if (w < 1 || h < 1) return mgs_error_set(err, MGS_ERR_ARG, "PersLoss: image of %d x %d pixels", w, h);
  mgs_status st = downsample(img, w, h, o->downsample, im, err);
  if (st) return st;
  st = features(o, im, f, err);
  if (st) { free(im->pts); im->pts = NULL; }
  return st;
}

mgs_status mgs_persloss_eval(const mgs_persloss_options *o, const float *img, const float *gt, int w, int h,
                             double scale, double *loss, float *grad, mgs_error *err) {
  mgs_status st = mgs_persloss_options_check(o, err);
  if (st) return st;
  ds_img a = {0}, g = {0};
  feat fa, fg;
  memset(&fa, 0, sizeof fa);
  memset(&fg, 0, sizeof fg);
  if ((st = image_features(o, img, w, h, &a, &fa, err))) return st;
  if ((st = image_features(o, gt, w, h, &g, &fg, err))) { free(a.pts); feat_free(&fa); return st; }
  *loss = loss_of(o, &fa, &fg, NULL, NULL);
  if (grad) st = backward(o, &a, &fa, &fg, w, h, scale, grad, err);
  free(a.pts); free(g.pts);
  feat_free(&fa); feat_free(&fg);
  return st;
}

/* ---------------------------------------------------------------- the term */

typedef struct persloss_term {
  mgs_persloss_options o;
  size_t n_cache;
  feat *gt;          /* per training view; valid when cached[i] */
  uint8_t *cached;
} persloss_term;

static unsigned pl_active(void *self, int it) {
  const persloss_term *t = self;
  if (t->o.lambda == 0) return 0;
  return it >= t->o.from && it <= t->o.until && it % t->o.every == 0 ? MGS_TERM_IMAGE : 0;
}

static mgs_status pl_image_grad(void *self, mgs_term_step *s, mgs_error *err) {
  persloss_term *t = self;
  size_t vi = s->view_index;
  if (vi >= t->n_cache) {
    size_t n = vi + 1 > 2 * t->n_cache ? vi + 1 : 2 * t->n_cache;
    feat *ng = realloc(t->gt, n * sizeof *ng);
    if (!ng) return mgs_error_set(err, MGS_ERR_NOMEM, "PersLoss: out of memory");
    t->gt = ng;
    uint8_t *nc = realloc(t->cached, n);
    if (!nc) return mgs_error_set(err, MGS_ERR_NOMEM, "PersLoss: out of memory");
    t->cached = nc;
    memset(t->cached + t->n_cache, 0, n - t->n_cache);
    memset(t->gt + t->n_cache, 0, (n - t->n_cache) * sizeof *t->gt);
    t->n_cache = n;
  }
  mgs_status st;
  if (!t->cached[vi]) {
    ds_img g = {0};
    if ((st = image_features(&t->o, s->gt, s->width, s->height, &g, &t->gt[vi], err))) return st;
    free(g.pts);
    t->cached[vi] = 1;
  }
  ds_img a = {0};
  feat fa;
  memset(&fa, 0, sizeof fa);
  if ((st = image_features(&t->o, s->color, s->width, s->height, &a, &fa, err))) return st;
  s->value = t->o.lambda * loss_of(&t->o, &fa, &t->gt[vi], NULL, NULL);
  st = backward(&t->o, &a, &fa, &t->gt[vi], s->width, s->height, t->o.lambda, s->dl_dcolor, err);
  free(a.pts);
  feat_free(&fa);
  return st;
}

static void pl_destroy(void *self) {
  persloss_term *t = self;
  if (!t) return;
  for (size_t i = 0; i < t->n_cache; i++) if (t->cached[i]) feat_free(&t->gt[i]);
  free(t->gt);
  free(t->cached);
  free(t);
}

static const mgs_term_ops pl_ops = {"persloss", pl_active, pl_image_grad, NULL, NULL, NULL, pl_destroy, NULL};

mgs_status mgs_term_persloss_create(const mgs_persloss_options *o, mgs_term **out, mgs_error *err) {
  *out = NULL;
  mgs_status st = mgs_persloss_options_check(o, err);
  if (st) return st;
  persloss_term *t = calloc(1, sizeof *t);
  if (!t) return mgs_error_set(err, MGS_ERR_NOMEM, "PersLoss: out of memory");
  t->o = *o;
  *out = mgs_term_create(&pl_ops, t);
  return *out ? MGS_OK : mgs_error_set(err, MGS_ERR_NOMEM, "PersLoss: out of memory");
}

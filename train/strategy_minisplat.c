/* Mini-Splatting and Mini-Splatting-D (train/mgs_minisplat.h): ADC's accumulators and
 * densify-and-prune (train/strategy_adc.c) with the blur mask OR-ed into its split; the
 * reinitialisation and simplification render every train view on a context of their own
 * (the trainer's holds this iteration's forward). docs/notes/mini-splatting.md lists the
 * deliberate differences from the authors' code. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "train/mgs_minisplat.h"
#include "core/mgs_math.h"
#include "core/mgs_log.h"

void mgs_minisplat_options_default(mgs_minisplat_options *o) {
  memset(o, 0, sizeof *o);
  mgs_adc_options_default(&o->adc);
  o->reinit_every = 5000;
  o->simplify1 = 15000;
  o->simplify2 = 20000;
  o->lr_restart = 5000;
  o->blur_share = 1.0 / 5000.0;
  o->blur_min_px = 8;
  o->simplify_fraction = 0.5;
  o->prune_share = 0.01;
  o->depth_points = 0;
  o->max_gaussians = 4500000;
}

typedef struct ms {
  mgs_minisplat_options o;
  mgs_strategy *adc;  /* accumulators and densify-and-prune */
  uint8_t *blur;      /* per Gaussian: dominated > blur_share of a view since the last densification */
  size_t n, cap;
  mgs_raster *r;      /* full-view passes */
} ms;

static mgs_status blur_resize(ms *m, size_t n, mgs_error *err) {
  if (n > m->cap) {
    uint8_t *b = realloc(m->blur, n);
    if (!b) return mgs_error_set(err, MGS_ERR_NOMEM, "mini-splatting: out of memory for %zu Gaussians", n);
    m->blur = b;
    m->cap = n;
  }
  if (n) memset(m->blur, 0, n);
  m->n = n;
  return MGS_OK;
}

/* ---- the rules ---- */

typedef struct key_idx { double key; uint32_t idx; } key_idx;
static int by_key_desc(const void *a, const void *b) {
  double x = ((const key_idx *)a)->key, y = ((const key_idx *)b)->key;
  return x > y ? -1 : x < y ? 1 : 0;
}
static int by_u32(const void *a, const void *b) {
  uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
  return x < y ? -1 : x > y;
}

size_t mgs_minisplat_weighted_sample(const double *w, size_t n, size_t k, mgs_rng *rng, uint32_t *out) {
  size_t m = 0;
  for (size_t i = 0; i < n; i++) m += w[i] > 0;
  key_idx *ki = malloc((m ? m : 1) * sizeof *ki);
  if (!ki) return 0;
  m = 0;
  for (size_t i = 0; i < n; i++) {
    if (!(w[i] > 0)) continue;
    double u = mgs_rng_uniform(rng);
    /* u^(1/w) ordered as log(u)/w; u = 0 would give -inf for every weight: nudge it */
    ki[m].key = log(u > 0 ? u : 1e-300) / w[i];
    ki[m].idx = (uint32_t)i;
    m++;
  }
  if (k > m) k = m;
  qsort(ki, m, sizeof *ki, by_key_desc);
  for (size_t j = 0; j < k; j++) out[j] = ki[j].idx;
  free(ki);
  qsort(out, k, sizeof *out, by_u32);
  return k;
}

static int by_double(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return x < y ? -1 : x > y;
}

void mgs_minisplat_cdf_keep(const double *imp, size_t n, double share, uint8_t *keep) {
  if (n == 0) return;
  if (share <= 0) { memset(keep, 1, n); return; }
  double *v = malloc(n * sizeof *v);
  if (!v) { memset(keep, 1, n); return; }
  /* the authors' init_cdf_mask: sorted importance + 1e-6, the first index whose
     cumulative share exceeds `share`; strictly greater importance is kept */
  double sum = 0;
  for (size_t i = 0; i < n; i++) { v[i] = imp[i] + 1e-6; sum += v[i]; }
  qsort(v, n, sizeof *v, by_double);
  double c = 0, split = v[n - 1];
  for (size_t i = 0; i < n; i++) {
    c += v[i];
    if (c / sum > share) { split = v[i]; break; }
  }
  for (size_t i = 0; i < n; i++) keep[i] = imp[i] > split;
  free(v);
}

size_t mgs_minisplat_simplify_count(size_t n, size_t nonzero, double fraction) {
  if (n == 0) return 0;
  return (size_t)((double)n * fraction * ((double)nonzero / (double)n));
}

/* A surfel's point on the pixel ray o + z dw (dw: the ray's world direction with camera
 * depth 1, so z is the camera depth): where the ray meets the surfel's plane, the point the
 * 2DGS rasterizer evaluates, when it lies on the splat (u^2 + v^2 within alpha >= 1/255)
 * and at a depth the rasterizer keeps (>= 0.2); otherwise the pixel's weight came from the
 * screen-space filter, whose depth is the centre's: the ray's point at that depth. 0: none. */
static int surfel_point(const mgs_gaussians *g, size_t gi, const double o[3], const double dw[3], const double fwd[3],
                        double out[3]) {
  float R[9];
  mgs_quat_to_mat3f(g->rot + 4 * gi, R);
  const float *mu = g->mean + 3 * gi;
  double om[3] = {mu[0] - o[0], mu[1] - o[1], mu[2] - o[2]};
  double nd = 0, no = 0, zc = 0;
  for (int i = 0; i < 3; i++) { nd += R[3 * i + 2] * dw[i]; no += R[3 * i + 2] * om[i]; zc += fwd[i] * om[i]; }
  double z = no / nd, op = 1.0 / (1.0 + exp(-(double)g->opacity[gi]));
  if (isfinite(z) && z >= 0.2 && op * 255.0 > 1.0) {
    double u = 0, v = 0;
    for (int i = 0; i < 3; i++) {
      double h = z * dw[i] - om[i];
      u += R[3 * i] * h;
      v += R[3 * i + 1] * h;
    }
    u /= exp((double)g->log_scale[3 * gi]);
    v /= exp((double)g->log_scale[3 * gi + 1]);
    if (u * u + v * v <= 2.0 * log(255.0 * op)) {
      for (int i = 0; i < 3; i++) out[i] = o[i] + z * dw[i];
      return 1;
    }
  }
  if (!(zc >= 0.2)) return 0;
  for (int i = 0; i < 3; i++) out[i] = o[i] + zc * dw[i];
  return 1;
}

mgs_status mgs_minisplat_ray_points(mgs_raster *r, const mgs_gaussians *g, const mgs_camera *cam, float *xyz,
                                    mgs_error *err) {
  mgs_raster_blend b;
  mgs_status st = mgs_raster_blend_stats(r, &b, err);
  if (st) return st;
  if (b.n != g->n || b.width != cam->width || b.height != cam->height)
    return mgs_error_set(err, MGS_ERR_ARG, "mini-splatting: the raster's last forward is not of this model and camera");
  const double *M = cam->c2w;
  const double o[3] = {M[3], M[7], M[11]};
  for (int y = 0; y < b.height; y++)
    for (int x = 0; x < b.width; x++) {
      size_t p = (size_t)y * b.width + x;
      float *out = xyz + 3 * p;
      out[0] = out[1] = out[2] = NAN;
      int32_t gi = b.max_index[p];
      if (gi < 0) continue;
      double dc[3] = {((double)x + 0.5 - cam->cx) / cam->fx, ((double)y + 0.5 - cam->cy) / cam->fy, 1.0};
      double d[3], dl = 0;
      for (int i = 0; i < 3; i++) {
        d[i] = M[4 * i] * dc[0] + M[4 * i + 1] * dc[1] + M[4 * i + 2] * dc[2];
        dl += d[i] * d[i];
      }
      if (g->kind == MGS_MODEL_2DGS) {
        const double fwd[3] = {M[2], M[6], M[10]};
        double pt[3];
        if (surfel_point(g, (size_t)gi, o, d, fwd, pt))
          for (int i = 0; i < 3; i++) out[i] = (float)pt[i];
        continue;
      }
      dl = sqrt(dl);
      for (int i = 0; i < 3; i++) d[i] /= dl;
      float R[9];
      mgs_quat_to_mat3f(g->rot + 4 * (size_t)gi, R);
      /* a = S^-1 R^T (o - mu), e = S^-1 R^T d: t minimizes |a + t e|^2 */
      double a[3], e[3];
      for (int k = 0; k < 3; k++) {
        double s = exp((double)g->log_scale[3 * (size_t)gi + k]), ak = 0, ek = 0;
        for (int i = 0; i < 3; i++) {
          ak += R[3 * i + k] * (o[i] - g->mean[3 * (size_t)gi + i]);
          ek += R[3 * i + k] * d[i];
        }
        a[k] = ak / s;
        e[k] = ek / s;
      }
      double ee = e[0] * e[0] + e[1] * e[1] + e[2] * e[2];
      double t = ee > 0 ? -(a[0] * e[0] + a[1] * e[1] + a[2] * e[2]) / ee : -1;
      if (!(t >= 0) || !isfinite(t)) continue; /* behind the camera: the authors skip it too */
      for (int i = 0; i < 3; i++) out[i] = (float)(o[i] + t * d[i]);
    }
  return MGS_OK;
}

/* ---- model replacement ---- */

/* All Gaussians replaced by the reference initialisation at xyz/rgb (n points); Adam as
 * a new optimizer (zero moments, step counts 0), as the authors' training_setup. A 2DGS
 * model gets 2DGS's init (--model 2dgs from points): the same two 3-NN scales, opacity and
 * colour, rotations uniform in [0,1)^4 (mgs_init_to_surfels), from a stream seeded by the
 * strategy's generator (so a resumed run draws the same). */
static mgs_status replace_model(ms *m, mgs_gaussians *g, mgs_adam *a, const float *xyz, const float *rgb, size_t n,
                                mgs_rng *rng, mgs_error *err) {
  mgs_gaussians *ng = NULL;
  mgs_status st = mgs_init_from_points(xyz, rgb, n, g->sh_degree, &ng, err);
  if (st) return st;
  if (g->kind == MGS_MODEL_2DGS)
    mgs_init_to_surfels(ng, (uint64_t)mgs_rng_u32(rng) << 32 | mgs_rng_u32(rng));
  uint8_t *keep = calloc(g->n ? g->n : 1, 1);
  if (!keep) { mgs_gaussians_destroy(ng); return mgs_error_set(err, MGS_ERR_NOMEM, "mini-splatting: out of memory"); }
  mgs_model_compact(g, a, keep);
  free(keep);
  size_t first = 0;
  if ((st = mgs_model_append(g, a, n, &first, err))) { mgs_gaussians_destroy(ng); return st; }
  for (int k = 0; k < MGS_PARAM_COUNT; k++) {
    size_t d = (size_t)mgs_param_dim((mgs_param_group)k);
    memcpy(mgs_gaussians_group(g, (mgs_param_group)k), mgs_gaussians_group(ng, (mgs_param_group)k), n * d * sizeof(float));
  }
  mgs_gaussians_destroy(ng);
  for (int k = 0; k < MGS_PARAM_COUNT; k++) a->t[k] = 0;
  if (!mgs_strategy_adc_state(m->adc, g->n)) return mgs_error_set(err, MGS_ERR_NOMEM, "mini-splatting: out of memory");
  return blur_resize(m, g->n, err);
}

static void set_shs(mgs_raster_settings *rs) {
  mgs_raster_settings_default(rs);
  rs->sh_degree = 0; /* weights do not depend on colour */
}

/* Depth reinitialisation (ms/train.py, iteration % 5000 == 0). */
static mgs_status reinit(ms *m, mgs_strategy_step *s, mgs_error *err) {
  const mgs_dataset *ds = mgs_trainer_dataset(s->trainer);
  mgs_gaussians *g = s->model;
  size_t nv = ds->n_views[MGS_SPLIT_TRAIN], total = 0, maxpix = 0;
  for (size_t v = 0; v < nv; v++) {
    size_t p = (size_t)ds->views[MGS_SPLIT_TRAIN][v].cam.width * ds->views[MGS_SPLIT_TRAIN][v].cam.height;
    total += p;
    if (p > maxpix) maxpix = p;
  }
  if (!total || !g->n) return MGS_OK;
  double want = m->o.depth_points ? (double)m->o.depth_points : (double)g->n;
  float *pts = malloc(maxpix * 3 * sizeof(float));
  double *w = malloc(maxpix * sizeof(double));
  uint32_t *idx = malloc(maxpix * sizeof(uint32_t));
  size_t cap = (size_t)want + nv + 16, n = 0;
  float *xyz = malloc(cap * 3 * sizeof(float)), *rgb = malloc(cap * 3 * sizeof(float));
  mgs_status st = MGS_OK;
  if (!pts || !w || !idx || !xyz || !rgb) { st = mgs_error_set(err, MGS_ERR_NOMEM, "mini-splatting: out of memory"); goto done; }
  mgs_raster_settings rs;
  set_shs(&rs);
  for (size_t v = 0; v < nv && st == MGS_OK; v++) {
    const mgs_camera *cam = &ds->views[MGS_SPLIT_TRAIN][v].cam;
    size_t np = (size_t)cam->width * cam->height;
    mgs_raster_output ro;
    if ((st = mgs_raster_forward(m->r, g, cam, &rs, &ro, err))) break;
    if ((st = mgs_minisplat_ray_points(m->r, g, cam, pts, err))) break;
    mgs_raster_blend b;
    if ((st = mgs_raster_blend_stats(m->r, &b, err))) break;
    for (size_t p = 0; p < np; p++) w[p] = isfinite(pts[3 * p]) ? 1.0 - b.final_T[p] : 0.0;
    /* the authors: int(pixels * num_depth / (pixels of all views)) per view */
    size_t k = (size_t)((double)np * want / (double)total);
    size_t got;
    if (!m->o.dense) got = mgs_minisplat_weighted_sample(w, np, k, s->rng, idx);
    else { /* -D: k draws with replacement, duplicates removed (np.unique) */
      double sum = 0;
      for (size_t p = 0; p < np; p++) sum += w[p];
      got = 0;
      if (sum > 0) {
        double *cdf = malloc(np * sizeof *cdf);
        uint8_t *hit = calloc(np, 1);
        if (!cdf || !hit) { free(cdf); free(hit); st = mgs_error_set(err, MGS_ERR_NOMEM, "mini-splatting: out of memory"); break; }
        double c = 0;
        for (size_t p = 0; p < np; p++) { c += w[p]; cdf[p] = c; }
        for (size_t j = 0; j < k; j++) {
          double u = mgs_rng_uniform(s->rng) * c;
          size_t lo = 0, hi = np - 1;
          while (lo < hi) { size_t mid = (lo + hi) / 2; if (cdf[mid] > u) hi = mid; else lo = mid + 1; }
          while (lo > 0 && w[lo] <= 0) lo--; /* cannot land on a zero weight but for rounding */
          hit[lo] = 1;
        }
        for (size_t p = 0; p < np; p++) if (hit[p] && w[p] > 0) idx[got++] = (uint32_t)p;
        free(cdf); free(hit);
      }
    }
    const float *gt = NULL;
    if ((st = mgs_trainer_train_image(s->trainer, v, &gt, err))) break;
    if (n + got > cap) {
      cap = (n + got) * 2;
      float *a = realloc(xyz, cap * 3 * sizeof(float)), *c = a ? realloc(rgb, cap * 3 * sizeof(float)) : NULL;
      if (a) xyz = a;
      if (c) rgb = c;
      if (!a || !c) { st = mgs_error_set(err, MGS_ERR_NOMEM, "mini-splatting: out of memory"); break; }
    }
    for (size_t j = 0; j < got; j++, n++) {
      memcpy(xyz + 3 * n, pts + 3 * (size_t)idx[j], 3 * sizeof(float));
      memcpy(rgb + 3 * n, gt + 3 * (size_t)idx[j], 3 * sizeof(float));
    }
  }
  if (st == MGS_OK && n > 0) st = replace_model(m, g, s->adam, xyz, rgb, n, s->rng, err);
done:
  free(pts); free(w); free(idx); free(xyz); free(rgb);
  return st;
}

/* Importance over every train view (the authors' "indoor" metric): the sum of blending
 * weights, 0 for a Gaussian that is nowhere a max-weight Gaussian. */
static mgs_status importance(ms *m, mgs_strategy_step *s, double *imp, mgs_error *err) {
  const mgs_dataset *ds = mgs_trainer_dataset(s->trainer);
  mgs_gaussians *g = s->model;
  uint8_t *seen = calloc(g->n ? g->n : 1, 1);
  if (!seen) return mgs_error_set(err, MGS_ERR_NOMEM, "mini-splatting: out of memory");
  memset(imp, 0, g->n * sizeof *imp);
  mgs_raster_settings rs;
  set_shs(&rs);
  mgs_status st = MGS_OK;
  for (size_t v = 0; v < ds->n_views[MGS_SPLIT_TRAIN] && st == MGS_OK; v++) {
    mgs_raster_output ro;
    mgs_raster_blend b;
    if ((st = mgs_raster_forward(m->r, g, &ds->views[MGS_SPLIT_TRAIN][v].cam, &rs, &ro, err))) break;
    if ((st = mgs_raster_blend_stats(m->r, &b, err))) break;
    for (size_t i = 0; i < g->n; i++) {
      imp[i] += b.importance[i];
      seen[i] |= b.area_max[i] > 0;
    }
  }
  for (size_t i = 0; i < g->n; i++) if (!seen[i]) imp[i] = 0;
  free(seen);
  return st;
}

/* First simplification (not -D): importance sampling without replacement. */
static mgs_status simplify_sample(ms *m, mgs_strategy_step *s, mgs_error *err) {
  mgs_gaussians *g = s->model;
  size_t n = g->n;
  double *imp = malloc((n ? n : 1) * sizeof *imp);
  uint32_t *idx = malloc((n ? n : 1) * sizeof *idx);
  uint8_t *keep = calloc(n ? n : 1, 1);
  mgs_status st = MGS_OK;
  if (!imp || !idx || !keep) st = mgs_error_set(err, MGS_ERR_NOMEM, "mini-splatting: out of memory");
  if (st == MGS_OK) st = importance(m, s, imp, err);
  if (st == MGS_OK) {
    size_t nz = 0;
    for (size_t i = 0; i < n; i++) nz += imp[i] > 0;
    size_t k = mgs_minisplat_simplify_count(n, nz, m->o.simplify_fraction);
    k = mgs_minisplat_weighted_sample(imp, n, k, s->rng, idx);
    for (size_t j = 0; j < k; j++) keep[idx[j]] = 1;
    mgs_model_compact(g, s->adam, keep);
  }
  free(imp); free(idx); free(keep);
  return st;
}

/* At simplify1 (both variants): every Gaussian back to the reference init at its mean,
 * with its DC colour (the authors' reinitial_pts(xyz, SH2RGB(f_dc))). */
static mgs_status reset_in_place(ms *m, mgs_strategy_step *s, mgs_error *err) {
  mgs_gaussians *g = s->model;
  size_t n = g->n;
  if (!n) return MGS_OK;
  float *xyz = malloc(n * 3 * sizeof(float)), *rgb = malloc(n * 3 * sizeof(float));
  if (!xyz || !rgb) { free(xyz); free(rgb); return mgs_error_set(err, MGS_ERR_NOMEM, "mini-splatting: out of memory"); }
  memcpy(xyz, g->mean, n * 3 * sizeof(float));
  for (size_t i = 0; i < 3 * n; i++) rgb[i] = 0.5f + MGS_SH_C0 * g->sh_dc[i]; /* SH2RGB, unclamped */
  mgs_status st = replace_model(m, g, s->adam, xyz, rgb, n, s->rng, err);
  free(xyz); free(rgb);
  return st;
}

static mgs_status simplify_prune(ms *m, mgs_strategy_step *s, mgs_error *err) {
  mgs_gaussians *g = s->model;
  size_t n = g->n;
  double *imp = malloc((n ? n : 1) * sizeof *imp);
  uint8_t *keep = malloc(n ? n : 1);
  mgs_status st = MGS_OK;
  if (!imp || !keep) st = mgs_error_set(err, MGS_ERR_NOMEM, "mini-splatting: out of memory");
  if (st == MGS_OK) st = importance(m, s, imp, err);
  if (st == MGS_OK) {
    mgs_minisplat_cdf_keep(imp, n, m->o.prune_share, keep);
    mgs_model_compact(g, s->adam, keep);
    for (int k = 0; k < MGS_PARAM_COUNT; k++) { mgs_adam_reset_group(s->adam, (mgs_param_group)k); s->adam->t[k] = 0; }
    if (!mgs_strategy_adc_state(m->adc, g->n)) st = mgs_error_set(err, MGS_ERR_NOMEM, "mini-splatting: out of memory");
    if (st == MGS_OK) st = blur_resize(m, g->n, err);
  }
  free(imp); free(keep);
  return st;
}

/* ---- hooks ---- */

static int densify_iteration(const ms *m, int it, size_t n) {
  const mgs_adc_options *o = &m->o.adc;
  return it < o->densify_until && it > o->densify_from && o->densify_every > 0 && it % o->densify_every == 0 &&
         !(m->o.reinit_every > 0 && it % m->o.reinit_every == 0) && (m->o.dense || n < m->o.max_gaussians);
}
static int reinit_iteration(const ms *m, int it) {
  return it < m->o.adc.densify_until && m->o.reinit_every > 0 && it % m->o.reinit_every == 0;
}

static mgs_status ms_pre(void *self, mgs_strategy_step *s, mgs_error *err) {
  ms *m = self;
  if (m->n != s->model->n) { mgs_status st = blur_resize(m, s->model->n, err); if (st) return st; }
  if (s->iteration >= m->o.adc.densify_until || !s->raster) return MGS_OK;
  mgs_raster_blend b;
  mgs_status st = mgs_raster_blend_stats(s->raster, &b, err);
  if (st) return st;
  if (b.n != m->n) return MGS_OK; /* not this model's forward */
  double thr = fmax((double)b.width * b.height * m->o.blur_share, m->o.blur_min_px);
  for (size_t i = 0; i < m->n; i++) m->blur[i] |= (double)b.area_max[i] > thr;
  return MGS_OK;
}

static mgs_status ms_post(void *self, mgs_strategy_step *s, mgs_error *err) {
  ms *m = self;
  int it = s->iteration;
  mgs_gaussians *g = s->model;
  const unsigned all = (1u << MGS_PARAM_COUNT) - 1;
  mgs_status st = MGS_OK;
  if (m->n != g->n && (st = blur_resize(m, g->n, err))) return st;
  mgs_adc_state *a = mgs_strategy_adc_state(m->adc, g->n);
  if (!a) return mgs_error_set(err, MGS_ERR_NOMEM, "mini-splatting: out of memory");
  if (it < m->o.adc.densify_until) {
    for (size_t i = 0; i < g->n; i++) {
      int r = s->radii[i];
      if (r <= 0) continue;
      if (r > a->max_radii[i]) a->max_radii[i] = r;
      a->grad_accum[i] += s->grad_mean2d[i];
      a->count[i]++;
    }
    if (densify_iteration(m, it, g->n)) {
      const mgs_adc_options *o = &m->o.adc;
      int prune_big = o->opacity_reset_every > 0 && it > o->opacity_reset_every;
      if ((st = mgs_adc_densify_and_prune_mask(m->adc, g, s->adam, s->extent, prune_big, m->blur, s->rng, err))) return st;
      if ((st = blur_resize(m, g->n, err))) return st;
      s->replaced_groups = all;
    }
    if (reinit_iteration(m, it) && s->trainer) {
      size_t n0 = g->n;
      if ((st = reinit(m, s, err))) return st;
      mgs_info("mini-splatting: iteration %d: depth reinitialisation, %zu -> %zu Gaussians", it, n0, g->n);
      s->replaced_groups = all;
      s->model_replaced = 1;
    }
  }
  if (it == m->o.simplify1 && s->trainer) {
    size_t n0 = g->n;
    if (!m->o.dense && (st = simplify_sample(m, s, err))) return st;
    mgs_info("mini-splatting: iteration %d: simplification, %zu -> %zu Gaussians", it, n0, g->n);
    if ((st = reset_in_place(m, s, err))) return st;
    s->replaced_groups = all;
    s->model_replaced = 1; /* every kept Gaussian re-initialised */
  }
  if (!m->o.dense && it == m->o.simplify2 && s->trainer) {
    size_t n0 = g->n;
    if ((st = simplify_prune(m, s, err))) return st;
    mgs_info("mini-splatting: iteration %d: 1 %% importance cut, %zu -> %zu Gaussians", it, n0, g->n);
    s->replaced_groups = all;
  }
  return MGS_OK;
}

static int ms_fusable(void *self, const mgs_strategy_step *s) {
  ms *m = self;
  int it = s->iteration;
  if (densify_iteration(m, it, s->model->n) || reinit_iteration(m, it) || it == m->o.simplify1 ||
      (!m->o.dense && it == m->o.simplify2))
    return 0;
  return 1;
}

static void ms_schedule(void *self, int it, int *lr_step, int *sh_max) {
  ms *m = self;
  if (m->o.simplify1 <= 0) return;
  if (it <= m->o.simplify1) *sh_max = 0; /* the authors' model has degree 0 until then */
  if (it >= m->o.simplify1) *lr_step = it - m->o.simplify1 + m->o.lr_restart;
}

static const char MS_MAGIC[8] = "MSPLAT1";

static mgs_status ms_save(void *self, FILE *f, mgs_error *err) {
  ms *m = self;
  mgs_status st = m->adc->ops->save(m->adc->self, f, err);
  if (st) return st;
  uint64_t n = m->n;
  int ok = fwrite(MS_MAGIC, 1, 8, f) == 8 && fwrite(&n, sizeof n, 1, f) == 1;
  if (n) ok = ok && fwrite(m->blur, 1, n, f) == n;
  return ok ? MGS_OK : mgs_error_set(err, MGS_ERR_IO, "mini-splatting: cannot write its state to the checkpoint");
}

static mgs_status ms_load(void *self, FILE *f, size_t n_gaussians, mgs_error *err) {
  ms *m = self;
  mgs_status st = m->adc->ops->load(m->adc->self, f, n_gaussians, err);
  if (st) return st;
  char magic[8];
  uint64_t n = 0;
  /* n = 0: the run's initial checkpoint, before the first step sized the flags (as adc's) */
  if (fread(magic, 1, 8, f) != 8 || memcmp(magic, MS_MAGIC, 8) || fread(&n, sizeof n, 1, f) != 1 ||
      (n != n_gaussians && n != 0))
    return mgs_error_set(err, MGS_ERR_FORMAT, "mini-splatting state in the checkpoint does not match its %zu Gaussians",
                         n_gaussians);
  if ((st = blur_resize(m, n_gaussians, err)) || n == 0) return st;
  if (fread(m->blur, 1, n, f) != n) return mgs_error_set(err, MGS_ERR_FORMAT, "checkpoint truncated in the mini-splatting state");
  return MGS_OK;
}

static void ms_destroy(void *self) {
  ms *m = self;
  if (!m) return;
  mgs_strategy_destroy(m->adc);
  mgs_raster_destroy(m->r);
  free(m->blur);
  free(m);
}

static const mgs_strategy_ops ms_ops = {"mini-splatting", ms_pre, ms_post, ms_save, ms_load, ms_destroy, ms_fusable,
                                        ms_schedule};
static const mgs_strategy_ops msd_ops = {"mini-splatting-d", ms_pre, ms_post, ms_save, ms_load, ms_destroy, ms_fusable,
                                         ms_schedule};

mgs_status mgs_strategy_minisplat_create(const mgs_minisplat_options *o, mgs_strategy **out, mgs_error *err) {
  *out = NULL;
  mgs_strategy *s = calloc(1, sizeof *s);
  ms *m = calloc(1, sizeof *m);
  if (m) {
    if (o) m->o = *o; else mgs_minisplat_options_default(&m->o);
    mgs_adc_options ao = m->o.adc;
    ao.opacity_reset_every = 0; /* never reset (the adc strategy's own hooks are not run anyway) */
    m->adc = mgs_strategy_adc_create(&ao);
    m->r = mgs_raster_create();
  }
  if (!s || !m || !m->adc || !m->r) {
    if (m) { mgs_strategy_destroy(m->adc); mgs_raster_destroy(m->r); }
    free(s); free(m);
    return mgs_error_set(err, MGS_ERR_NOMEM, "mini-splatting: out of memory");
  }
  if (!(m->o.simplify_fraction > 0 && m->o.simplify_fraction <= 1)) {
    double f = m->o.simplify_fraction;
    ms_destroy(m); free(s);
    return mgs_error_set(err, MGS_ERR_ARG, "mini-splatting: simplify fraction %g not in (0, 1]", f);
  }
  s->ops = m->o.dense ? &msd_ops : &ms_ops;
  s->self = m;
  *out = s;
  return MGS_OK;
}

/* One GaussianPro propagation step (train/mgs_gaussianpro.h), after the authors' train.py
 * (depth_propagation, check_geometric_consistency, densify_from_depth_propagation).
 *
 * Deliberate differences from the authors' code:
 *  - neighbours are chosen by camera overlap of the reference's rendered depth
 *    (mgs_pm_select_neighbors), not by frame order or a pair file;
 *  - the plane hypotheses start from the rendered expected depth where the render is
 *    opaque (alpha >= 0.5) and from the rendered normal (the authors: the alpha-weighted
 *    depth everywhere and random normals); the disagreement test uses the alpha-weighted
 *    depth sum w z, as the authors' render_depth;
 *  - a new Gaussian is flat and aligned with the propagated normal, its in-plane scale the
 *    world spacing of the sampled pixels (stride x depth / focal, what the authors' 3-NN
 *    distance comes to on that grid), a tenth of it along the normal; opacity 0.99 (the
 *    authors' inverse_sigmoid(1.0) is infinite);
 *  - the image's alpha, where the dataset has one, masks the background as the authors'
 *    sky mask does;
 *  - a reference view is matched again each time its turn comes (the authors match each
 *    view once); neighbours reuse the kept depth, as the authors'. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "core/mgs_log.h"
#include "render/mgs_patchmatch.h"
#include "render/mgs_raster.h"
#include "train/mgs_gaussianpro.h"

#define GPRO_STATE_TAG 0x6f727047u /* "Gpro" */

void mgs_gpro_options_default(mgs_gpro_options *o) {
  o->from = 1000;
  o->until = 6000;
  o->every = 50;
  o->patch_size = 20;
  o->pm_iterations = 6;
  o->neighbors = 4;
  o->stride = 8;
  o->error_max = 1.0;
  o->error_min = 0.8;
  o->min_pixels = 100;
  o->depth_min = 0;
  o->depth_max = 0;
  o->seed = 0;
}

struct mgs_gpro {
  mgs_gpro_options o;
  const mgs_view *views;
  size_t n;
  float **depth; /* per view: its propagated depth (0 = none), NULL until matched */
  float **normal; /* per view matched as the reference: its accepted propagated normals (0 = none) */
  uint8_t *checked; /* per view: 1 when matched as the reference (depth then 0 where fewer
                       than 2 neighbours agree), 0 when only as a neighbour */
  mgs_raster *raster;
  float dmin, dmax;
};

mgs_status mgs_gpro_create(const mgs_gpro_options *o, const mgs_view *views, size_t n_views, double extent,
                           mgs_gpro **out, mgs_error *err) {
  *out = NULL;
  if (o->every < 1 || o->patch_size < 1 || o->patch_size > 62 || o->pm_iterations < 0 || o->neighbors < 2 ||
      o->neighbors > 32 || o->stride < 1)
    return mgs_error_set(err, MGS_ERR_ARG, "gaussianpro: invalid options (every %d, patch %d, neighbours %d, stride %d)",
                         o->every, o->patch_size, o->neighbors, o->stride);
  mgs_gpro *p = calloc(1, sizeof *p);
  if (p) p->depth = calloc(n_views ? n_views : 1, sizeof *p->depth);
  if (p) p->normal = calloc(n_views ? n_views : 1, sizeof *p->normal);
  if (p) p->checked = calloc(n_views ? n_views : 1, 1);
  if (p && p->depth && p->normal && p->checked) p->raster = mgs_raster_create();
  if (!p || !p->depth || !p->normal || !p->checked || !p->raster) {
    mgs_gpro_destroy(p);
    return mgs_error_set(err, MGS_ERR_NOMEM, "gaussianpro: out of memory");
  }
  p->o = *o;
  p->views = views;
  p->n = n_views;
  double ext = extent > 0 ? extent : 1.0;
  p->dmin = (float)(o->depth_min > 0 ? o->depth_min : 0.02 * ext);
  p->dmax = (float)(o->depth_max > 0 ? o->depth_max : 4.0 * ext);
  *out = p;
  return MGS_OK;
}

void mgs_gpro_destroy(mgs_gpro *p) {
  if (!p) return;
  if (p->depth)
    for (size_t i = 0; i < p->n; i++) free(p->depth[i]);
  if (p->normal)
    for (size_t i = 0; i < p->n; i++) free(p->normal[i]);
  free(p->depth);
  free(p->normal);
  free(p->checked);
  mgs_raster_destroy(p->raster);
  free(p);
}

const float *mgs_gpro_cached_depth(const mgs_gpro *p, size_t view) { return view < p->n ? p->depth[view] : NULL; }

const float *mgs_gpro_checked_depth(const mgs_gpro *p, size_t view) {
  return view < p->n && p->checked[view] ? p->depth[view] : NULL;
}

const float *mgs_gpro_checked_normal(const mgs_gpro *p, size_t view) {
  return view < p->n && p->checked[view] ? p->normal[view] : NULL;
}

/* ---- per-view inputs ------------------------------------------------------------------- */

typedef struct view_maps {
  float *gray;      /* 0..255 */
  float *depth_wz;  /* sum w z: the authors' rendered depth */
  float *depth_init;/* expected depth where alpha >= 0.5, else 0 */
  float *depth_any; /* expected depth wherever alpha > 0 (neighbour choice; after an
                       opacity reset no pixel is opaque) */
  float *normal;    /* world, sum w n */
} view_maps;

static void view_maps_free(view_maps *m) {
  free(m->gray); free(m->depth_wz); free(m->depth_init); free(m->depth_any); free(m->normal);
  memset(m, 0, sizeof *m);
}

static mgs_status gray_of(const mgs_view *v, float **out, mgs_error *err) {
  const mgs_image *im = v->image;
  if (!im) return mgs_error_set(err, MGS_ERR_ARG, "gaussianpro: the image of view %s is not loaded (propagation needs "
                                "the training images in memory: no --image-cache-mb)", v->name ? v->name : "?");
  if (im->width != v->cam.width || im->height != v->cam.height || im->channels < 3)
    return mgs_error_set(err, MGS_ERR_FORMAT, "gaussianpro: %s: image %dx%dx%d, camera %dx%d", v->image_path ? v->image_path : "?",
                         im->width, im->height, im->channels, v->cam.width, v->cam.height);
  size_t np = (size_t)im->width * (size_t)im->height;
  float *g = malloc(np * sizeof *g);
  if (!g) return mgs_error_set(err, MGS_ERR_NOMEM, "gaussianpro: out of memory");
  for (size_t i = 0; i < np; i++) {
    const float *c = im->data + (size_t)im->channels * i;
    g[i] = 255.0f * (0.299f * c[0] + 0.587f * c[1] + 0.114f * c[2]);
  }
  *out = g;
  return MGS_OK;
}

/* Renders view i of model g: the depths and normals above. */
static mgs_status render_view(mgs_gpro *p, const mgs_gaussians *g, size_t i, view_maps *m, mgs_error *err) {
  const mgs_camera *cam = &p->views[i].cam;
  mgs_raster_settings rs;
  mgs_raster_settings_default(&rs);
  rs.sh_degree = 0; /* colour plays no part in depth and normals */
  mgs_raster_output ro;
  mgs_render_maps maps;
  mgs_status st = mgs_raster_forward(p->raster, g, cam, &rs, &ro, err);
  if (st == MGS_OK) st = mgs_raster_maps(p->raster, MGS_MAP_DEPTH_EXPECTED | MGS_MAP_NORMAL, &maps, err);
  if (st) return st;
  size_t np = (size_t)cam->width * (size_t)cam->height;
  m->depth_wz = malloc(np * sizeof(float));
  m->depth_init = malloc(np * sizeof(float));
  m->depth_any = malloc(np * sizeof(float));
  m->normal = malloc(3 * np * sizeof(float));
  if (!m->depth_wz || !m->depth_init || !m->depth_any || !m->normal) return mgs_error_set(err, MGS_ERR_NOMEM, "gaussianpro: out of memory");
  memcpy(m->depth_wz, ro.depth, np * sizeof(float));
  memcpy(m->normal, maps.normal, 3 * np * sizeof(float));
  for (size_t k = 0; k < np; k++) {
    m->depth_init[k] = maps.alpha[k] >= 0.5f ? maps.depth_expected[k] : 0.0f;
    m->depth_any[k] = maps.alpha[k] > 0 ? maps.depth_expected[k] : 0.0f;
  }
  return MGS_OK;
}

/* Patch matching of view i against its best-overlapping views; depth (0 where no view
 * matched) and world normals into the given buffers. Returns the neighbours in nb. */
static mgs_status match_view(mgs_gpro *p, size_t i, const view_maps *m, float *depth, float *normal, size_t *nb,
                             size_t *n_nb, uint64_t salt, mgs_error *err) {
  const mgs_camera *cam = &p->views[i].cam;
  mgs_camera *cams = malloc(p->n * sizeof *cams);
  if (!cams) return mgs_error_set(err, MGS_ERR_NOMEM, "gaussianpro: out of memory");
  for (size_t j = 0; j < p->n; j++) cams[j] = p->views[j].cam;
  *n_nb = mgs_pm_select_neighbors(cams, p->n, i, m->depth_any, 4, (size_t)p->o.neighbors, nb);
  free(cams);
  size_t np = (size_t)cam->width * (size_t)cam->height;
  if (*n_nb == 0) {
    memset(depth, 0, np * sizeof(float));
    return MGS_OK;
  }
  float *grays[32] = {0}, *cost = malloc(np * sizeof(float));
  mgs_pm_view src[32];
  mgs_status st = cost ? MGS_OK : mgs_error_set(err, MGS_ERR_NOMEM, "gaussianpro: out of memory");
  for (size_t k = 0; k < *n_nb && st == MGS_OK; k++) {
    st = gray_of(&p->views[nb[k]], &grays[k], err);
    src[k].cam = &p->views[nb[k]].cam;
    src[k].gray = grays[k];
  }
  if (st == MGS_OK) {
    mgs_pm_options po;
    mgs_pm_options_default(&po);
    po.patch_size = p->o.patch_size;
    po.iterations = p->o.pm_iterations;
    po.depth_min = p->dmin;
    po.depth_max = p->dmax;
    po.seed = p->o.seed * 0x9E3779B97F4A7C15ull + salt;
    mgs_pm_view ref = {cam, m->gray};
    st = mgs_pm_run(&ref, src, (int)*n_nb, m->depth_init, m->normal, &po, depth, normal, cost, err);
  }
  if (st == MGS_OK)
    for (size_t k = 0; k < np; k++)
      if (!(cost[k] < 2.0f)) depth[k] = 0; /* no view matched: no depth */
  for (size_t k = 0; k < *n_nb; k++) free(grays[k]);
  free(cost);
  return st;
}

/* The kept propagated depth of view j, matching it first if it has none. */
static mgs_status neighbour_depth(mgs_gpro *p, const mgs_gaussians *g, size_t j, uint64_t salt, mgs_error *err) {
  if (p->depth[j]) return MGS_OK;
  const mgs_camera *cam = &p->views[j].cam;
  size_t np = (size_t)cam->width * (size_t)cam->height, nb[32], n_nb = 0;
  view_maps m = {0};
  float *d = malloc(np * sizeof(float)), *nrm = malloc(3 * np * sizeof(float));
  mgs_status st = d && nrm ? MGS_OK : mgs_error_set(err, MGS_ERR_NOMEM, "gaussianpro: out of memory");
  if (st == MGS_OK) st = gray_of(&p->views[j], &m.gray, err);
  if (st == MGS_OK) st = render_view(p, g, j, &m, err);
  if (st == MGS_OK) st = match_view(p, j, &m, d, nrm, nb, &n_nb, salt, err);
  view_maps_free(&m);
  free(nrm);
  if (st) { free(d); return st; }
  p->depth[j] = d;
  return MGS_OK;
}

/* Quaternion (w, x, y, z) turning the local z axis onto unit n. */
static void quat_z_to(const float n[3], float q[4]) {
  if (n[2] < -0.999999f) { q[0] = 0; q[1] = 1; q[2] = 0; q[3] = 0; return; }
  q[0] = 1.0f + n[2]; q[1] = -n[1]; q[2] = n[0]; q[3] = 0;
  float l = sqrtf(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
  for (int k = 0; k < 3; k++) q[k] /= l;
}

static mgs_status add_gaussians(mgs_gpro *p, mgs_gaussians *g, mgs_adam *a, size_t i, const float *depth,
                                const float *normal, const uint8_t *mask, size_t *added, mgs_error *err) {
  const mgs_view *v = &p->views[i];
  const mgs_camera *cam = &v->cam;
  const int W = cam->width, H = cam->height, s = p->o.stride;
  size_t count = 0;
  for (int y = 0; y < H; y += s)
    for (int x = 0; x < W; x += s) count += mask[(size_t)y * W + x] != 0;
  *added = 0;
  if (!count) return MGS_OK;
  size_t first;
  mgs_status st = mgs_model_append(g, a, count, &first, err);
  if (st) return st;
  size_t r = first;
  for (int y = 0; y < H; y += s)
    for (int x = 0; x < W; x += s) {
      size_t px = (size_t)y * W + x;
      if (!mask[px]) continue;
      double z = depth[px], xc = ((x + 0.5) - cam->cx) / cam->fx * z, yc = ((y + 0.5) - cam->cy) / cam->fy * z;
      for (int k = 0; k < 3; k++)
        g->mean[3 * r + k] = (float)(cam->c2w[4 * k] * xc + cam->c2w[4 * k + 1] * yc + cam->c2w[4 * k + 2] * z + cam->c2w[4 * k + 3]);
      float n[3] = {normal[3 * px], normal[3 * px + 1], normal[3 * px + 2]};
      float ln = sqrtf(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
      if (ln > 0) for (int k = 0; k < 3; k++) n[k] /= ln;
      else { n[0] = 0; n[1] = 0; n[2] = 1; }
      quat_z_to(n, g->rot + 4 * r);
      float spacing = (float)(s * z / cam->fx);
      g->log_scale[3 * r] = g->log_scale[3 * r + 1] = logf(spacing);
      g->log_scale[3 * r + 2] = logf(0.1f * spacing);
      g->opacity[r] = logf(0.99f / 0.01f);
      const float *c = v->image->data + (size_t)v->image->channels * px;
      for (int k = 0; k < 3; k++) g->sh_dc[3 * r + k] = (c[k] - 0.5f) / MGS_SH_C0;
      memset(g->sh_rest + MGS_SH_REST_MAX * r, 0, MGS_SH_REST_MAX * sizeof(float));
      r++;
    }
  *added = count;
  return MGS_OK;
}

mgs_status mgs_gpro_propagate(mgs_gpro *p, mgs_gaussians *g, mgs_adam *a, size_t view, double progress,
                              mgs_gpro_report *r, mgs_error *err) {
  memset(r, 0, sizeof *r);
  r->view = view;
  if (view >= p->n) return mgs_error_set(err, MGS_ERR_ARG, "gaussianpro: view %zu of %zu", view, p->n);
  struct timespec t0, t1;
  clock_gettime(CLOCK_MONOTONIC, &t0);
  const mgs_camera *cam = &p->views[view].cam;
  size_t np = (size_t)cam->width * (size_t)cam->height, nb[32], n_nb = 0;
  uint64_t salt = ((uint64_t)view << 20) ^ (uint64_t)g->n;
  view_maps m = {0};
  float *depth = malloc(np * sizeof(float)), *normal = malloc(3 * np * sizeof(float));
  uint8_t *cnt = malloc(np), *mask = malloc(np);
  mgs_status st = depth && normal && cnt && mask ? MGS_OK : mgs_error_set(err, MGS_ERR_NOMEM, "gaussianpro: out of memory");
  if (st == MGS_OK) st = gray_of(&p->views[view], &m.gray, err);
  if (st == MGS_OK) st = render_view(p, g, view, &m, err);
  if (st == MGS_OK) st = match_view(p, view, &m, depth, normal, nb, &n_nb, salt, err);
  for (size_t k = 0; k < n_nb && st == MGS_OK; k++) st = neighbour_depth(p, g, nb[k], salt + k + 1, err);
  if (st == MGS_OK) {
    r->neighbors = n_nb;
    const mgs_camera *sc[32];
    const float *sd[32];
    for (size_t k = 0; k < n_nb; k++) { sc[k] = &p->views[nb[k]].cam; sd[k] = p->depth[nb[k]]; }
    mgs_pm_geometric_consistency(cam, depth, sc, sd, (int)n_nb, 2.0f, 0.01f, cnt);
    double pr = progress < 0 ? 0 : progress > 1 ? 1 : progress;
    double thr = p->o.error_max - (p->o.error_max - p->o.error_min) * pr;
    /* the image's own alpha, where it has one, as the authors' sky mask: objects on a
       plain background otherwise gain Gaussians off their silhouette, where windows
       straddling the outline extend the surface's planes consistently in every view */
    const mgs_image *al = p->views[view].alpha;
    if (al && (al->width != cam->width || al->height != cam->height || al->channels != 1)) al = NULL;
    for (size_t k = 0; k < np; k++) {
      int ok = depth[k] > 0 && cnt[k] >= 2 && (!al || al->data[k] >= 0.5f);
      r->consistent += (size_t)ok;
      ok = ok && fabs(depth[k] - m.depth_wz[k]) / depth[k] > thr;
      mask[k] = (uint8_t)ok;
      r->accepted += (size_t)ok;
    }
    if (r->accepted > (size_t)p->o.min_pixels) st = add_gaussians(p, g, a, view, depth, normal, mask, &r->added, err);
    for (size_t k = 0; k < np; k++) {
      if (cnt[k] < 2) depth[k] = 0; /* kept checked, as the authors' (their 300 = none) */
      if (!(depth[k] > 0) || (al && al->data[k] < 0.5f)) /* the planar loss' mask (their -10) */
        normal[3 * k] = normal[3 * k + 1] = normal[3 * k + 2] = 0;
    }
  }
  if (st == MGS_OK) { /* keep this view's depth for the views that take it as a neighbour */
    free(p->depth[view]);
    free(p->normal[view]);
    p->depth[view] = depth;
    p->normal[view] = normal;
    p->checked[view] = 1;
    depth = NULL;
    normal = NULL;
  }
  view_maps_free(&m);
  free(depth); free(normal); free(cnt); free(mask);
  clock_gettime(CLOCK_MONOTONIC, &t1);
  r->seconds = (double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec);
  return st;
}

/* ---- checkpoint state: the kept depths ------------------------------------------------- */

mgs_status mgs_gpro_save(const mgs_gpro *p, FILE *f, mgs_error *err) {
  uint32_t hdr[2] = {GPRO_STATE_TAG, (uint32_t)p->n};
  int ok = fwrite(hdr, sizeof hdr, 1, f) == 1;
  for (size_t i = 0; i < p->n && ok; i++) {
    /* 1 neighbour depth, 2 checked depth, 3 checked depth and normals */
    uint8_t has = p->depth[i] ? (uint8_t)(1 + p->checked[i] + (p->checked[i] && p->normal[i])) : 0;
    ok = fwrite(&has, 1, 1, f) == 1;
    size_t np = (size_t)p->views[i].cam.width * (size_t)p->views[i].cam.height;
    if (ok && has) ok = fwrite(p->depth[i], sizeof(float), np, f) == np;
    if (ok && has == 3) ok = fwrite(p->normal[i], sizeof(float), 3 * np, f) == 3 * np;
  }
  return ok ? MGS_OK : mgs_error_set(err, MGS_ERR_IO, "gaussianpro: cannot write its state to the checkpoint");
}

mgs_status mgs_gpro_load(mgs_gpro *p, FILE *f, mgs_error *err) {
  uint32_t hdr[2];
  if (fread(hdr, sizeof hdr, 1, f) != 1 || hdr[0] != GPRO_STATE_TAG)
    return mgs_error_set(err, MGS_ERR_FORMAT, "checkpoint: the gaussianpro state is missing or damaged");
  if (hdr[1] != p->n)
    return mgs_error_set(err, MGS_ERR_FORMAT, "checkpoint: gaussianpro state for %u views, the dataset has %zu", hdr[1], p->n);
  for (size_t i = 0; i < p->n; i++) {
    uint8_t has;
    if (fread(&has, 1, 1, f) != 1 || has > 3) return mgs_error_set(err, MGS_ERR_FORMAT, "checkpoint: gaussianpro state truncated");
    free(p->depth[i]);
    free(p->normal[i]);
    p->depth[i] = p->normal[i] = NULL;
    p->checked[i] = has >= 2;
    if (!has) continue;
    size_t np = (size_t)p->views[i].cam.width * (size_t)p->views[i].cam.height;
    p->depth[i] = malloc(np * sizeof(float));
    if (!p->depth[i]) return mgs_error_set(err, MGS_ERR_NOMEM, "gaussianpro: out of memory");
    if (fread(p->depth[i], sizeof(float), np, f) != np)
      return mgs_error_set(err, MGS_ERR_FORMAT, "checkpoint: gaussianpro state truncated");
    if (has < 3) continue; /* checkpoints before the normal half: depth only */
    p->normal[i] = malloc(3 * np * sizeof(float));
    if (!p->normal[i]) return mgs_error_set(err, MGS_ERR_NOMEM, "gaussianpro: out of memory");
    if (fread(p->normal[i], sizeof(float), 3 * np, f) != 3 * np)
      return mgs_error_set(err, MGS_ERR_FORMAT, "checkpoint: gaussianpro state truncated");
  }
  return MGS_OK;
}

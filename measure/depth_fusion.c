/* Depth fusion of a splat model's renders (measure/mgs_depth_fusion.h). */
#include "measure/mgs_depth_fusion.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "core/mgs_dataset.h"
#include "core/mgs_fs.h"
#include "core/mgs_log.h"
#include "core/mgs_math.h"
#include "core/mgs_ply.h"
#include "render/mgs_raster.h"
#include "train/mgs_train.h"
#include "vdb/mgs_vdb_tsdf.h"

#define FUSION_BATCH 16 /* views rendered and fused at a time (memory bound) */

void mgs_fusion_opts_default(mgs_fusion_opts *o) {
  memset(o, 0, sizeof *o);
  o->depth = -1;
  o->voxel_fp = MGS_FUSION_VOXEL_FP;
  o->trunc_fp = MGS_FUSION_TRUNC_FP;
  o->thin_fp = MGS_FUSION_THIN_FP; /* measured: thin 0.0475 -> 0.0228, genus2/sphere unchanged (docs/notes/depth-fusion.md) */
  o->half_width = 3;
  o->min_weight = 1;
  o->alpha_mask = 0.5f;
  o->views = 64;
  o->view_size = 256;
  o->iteration = -1;
  o->image_alpha = 1;
  o->mask_carve_px = 4; /* measured: 2 px moved 18 % of a lever's surface by half a footprint (Chamfer +7 %), 4 px none; docs/notes/depth-fusion.md */
  o->carve = 0; /* measured: +t at every pixel outside the rendered silhouette erodes every surface seen at grazing angles (genus2 Chamfer 0.0040 -> 0.023) */
}

/* ---- the 3DGS depth source ---- */
struct mgs_depth_3dgs {
  const mgs_gaussians *g;
  mgs_raster *r;
  mgs_raster_settings s;
};

static mgs_status render_3dgs(void *ctx, const mgs_camera *cam, mgs_depth_kind kind, float *depth, float *alpha,
                              mgs_error *err) {
  mgs_depth_3dgs *s = ctx;
  mgs_raster_output ro;
  mgs_render_maps m;
  mgs_status st = mgs_raster_forward(s->r, s->g, cam, &s->s, &ro, err);
  if (st == MGS_OK)
    st = mgs_raster_maps(s->r, kind == MGS_DEPTH_MEDIAN ? MGS_MAP_DEPTH_MEDIAN : MGS_MAP_DEPTH_EXPECTED, &m, err);
  if (st != MGS_OK) return st;
  size_t np = (size_t)cam->width * cam->height;
  memcpy(depth, kind == MGS_DEPTH_MEDIAN ? m.depth_median : m.depth_expected, np * sizeof(float));
  memcpy(alpha, m.alpha, np * sizeof(float));
  return MGS_OK;
}

mgs_depth_3dgs *mgs_depth_3dgs_create(const mgs_gaussians *g, mgs_depth_source *out) {
  mgs_depth_3dgs *s = calloc(1, sizeof *s);
  if (!s || !(s->r = mgs_raster_create())) { free(s); return NULL; }
  s->g = g;
  mgs_raster_settings_default(&s->s);
  s->s.sh_degree = g->sh_degree;
  out->render = render_3dgs;
  out->ctx = s;
  out->preferred = MGS_DEPTH_MEDIAN; /* measured: docs/notes/depth-fusion.md */
  return s;
}

void mgs_depth_3dgs_destroy(mgs_depth_3dgs *s) {
  if (!s) return;
  mgs_raster_destroy(s->r);
  free(s);
}

/* ---- virtual views ---- */
static int cmp_float(const void *a, const void *b) {
  float x = *(const float *)a, y = *(const float *)b;
  return x < y ? -1 : x > y;
}

mgs_status mgs_virtual_views(const mgs_gaussians *g, int n, int size, mgs_camera **out, mgs_error *err) {
  *out = NULL;
  if (n < 1 || size < 8) return mgs_error_set(err, MGS_ERR_ARG, "virtual views: need n >= 1 and size >= 8 (%d, %d)", n, size);
  /* the opaque core: 1st-99th percentile box of the means of Gaussians with alpha > 0.1
   * (a few far floaters must not push the cameras away) */
  size_t m = 0;
  float *c = malloc(3 * (g->n ? g->n : 1) * sizeof(float));
  if (!c) return mgs_error_set(err, MGS_ERR_NOMEM, "virtual views: out of memory");
  for (int k = 0; k < 3; k++) {
    m = 0;
    for (size_t i = 0; i < g->n; i++)
      if (mgs_gaussian_alpha(g, i) > 0.1f) c[k * g->n + m++] = g->mean[3 * i + k];
  }
  if (m == 0) {
    free(c);
    return mgs_error_set(err, MGS_ERR_FORMAT, "virtual views: no Gaussian has opacity above 0.1; nothing to look at");
  }
  double lo[3], hi[3], ctr[3], rad = 0;
  for (int k = 0; k < 3; k++) {
    qsort(c + k * g->n, m, sizeof(float), cmp_float);
    lo[k] = c[k * g->n + m / 100];
    hi[k] = c[k * g->n + m - 1 - m / 100];
    ctr[k] = 0.5 * (lo[k] + hi[k]);
    rad += 0.25 * (hi[k] - lo[k]) * (hi[k] - lo[k]);
  }
  free(c);
  rad = sqrt(rad);
  if (!(rad > 0)) rad = 1;
  const double fov = 40.0 * M_PI / 180.0, dist = 1.1 * rad / sin(0.5 * fov);
  mgs_camera *cams = calloc((size_t)n, sizeof *cams);
  if (!cams) return mgs_error_set(err, MGS_ERR_NOMEM, "virtual views: out of memory");
  const double golden = M_PI * (3.0 - sqrt(5.0));
  for (int i = 0; i < n; i++) {
    double z = n > 1 ? 1 - 2 * (i + 0.5) / n : 0, r = sqrt(fmax(0, 1 - z * z)), phi = golden * i;
    double d[3] = {r * cos(phi), r * sin(phi), z};
    double eye[3] = {ctr[0] + dist * d[0], ctr[1] + dist * d[1], ctr[2] + dist * d[2]};
    double up[3] = {0, 0, 1};
    if (fabs(z) > 0.9) { up[0] = 1; up[2] = 0; }
    mgs_camera_init_fovx(&cams[i], size, size, fov);
    mgs_camera_look_at(&cams[i], eye, ctr, up);
  }
  *out = cams;
  return MGS_OK;
}

/* ---- fusion ---- */
/* Every stride-th foreground pixel of a masked depth map, back-projected to world xyz. */
static void keep_points(const mgs_camera *cam, const float *depth, size_t stride, size_t cap, mgs_fusion_report *rep) {
  size_t np = (size_t)cam->width * cam->height, c = 0;
  double o[3], d[3], axis[3];
  mgs_camera_ray(cam, cam->cx, cam->cy, o, axis); /* the optical axis */
  for (size_t p = 0; p < np && rep->n_points < cap; p++) {
    if (!(depth[p] > 0) || c++ % stride) continue;
    mgs_camera_ray(cam, (double)(p % cam->width) + 0.5, (double)(p / cam->width) + 0.5, o, d);
    /* depth is camera z: along the unit ray that is z / (d . optical axis) */
    const double t = depth[p] / (d[0] * axis[0] + d[1] * axis[1] + d[2] * axis[2]);
    float *q = rep->points + 3 * rep->n_points++;
    for (int i = 0; i < 3; i++) q[i] = (float)(o[i] + t * d[i]);
  }
}

static double median_d(double *v, size_t n) {
  if (!n) return NAN;
  for (size_t i = 1; i < n; i++) /* insertion sort: n is a few hundred views */
    for (size_t j = i; j > 0 && v[j - 1] > v[j]; j--) { double t = v[j]; v[j] = v[j - 1]; v[j - 1] = t; }
  return v[n / 2];
}

/* far[p] = 1 where the image mask is background (alpha < 0.5) at every pixel within
 * Chebyshev distance r of p (a separable max filter of the foreground). */
static void mask_far_background(const mgs_image *mask, int r, unsigned char *far, unsigned char *tmp) {
  const int w = mask->width, h = mask->height;
  for (int y = 0; y < h; y++) /* rows: tmp = foreground within r along x */
    for (int x = 0; x < w; x++) {
      unsigned char f = 0;
      for (int k = x - r < 0 ? 0 : x - r; k <= x + r && k < w && !f; k++)
        f = mask->data[((size_t)y * w + k) * mask->channels] >= 0.5f;
      tmp[(size_t)y * w + x] = f;
    }
  for (int y = 0; y < h; y++)
    for (int x = 0; x < w; x++) {
      unsigned char f = 0;
      for (int k = y - r < 0 ? 0 : y - r; k <= y + r && k < h && !f; k++) f = tmp[(size_t)k * w + x];
      far[(size_t)y * w + x] = !f;
    }
}

static int mask_fits(const mgs_image *mask, const mgs_camera *cam) {
  return mask && mask->width == cam->width && mask->height == cam->height;
}

/* Renders view k into depth (masked: 0 = background, -1 = free space that carves);
 * returns its foreground pixel count. */
static mgs_status render_masked(const mgs_depth_source *src, const mgs_camera *cam, const mgs_image *mask,
                                mgs_depth_kind kind, const mgs_fusion_opts *o, float *depth, float *alpha, size_t *fg,
                                mgs_error *err) {
  mgs_status st = src->render(src->ctx, cam, kind, depth, alpha, err);
  if (st != MGS_OK) return st;
  size_t np = (size_t)cam->width * cam->height, c = 0;
  int use_mask = mask_fits(mask, cam);
  for (size_t p = 0; p < np; p++) {
    int bg = !(alpha[p] >= o->alpha_mask) || (use_mask && mask->data[p * mask->channels] < 0.5f);
    if (bg) depth[p] = o->carve ? -1.0f : 0.0f; /* free space (vdb/mgs_vdb_tsdf.h) */
    else if (!(depth[p] > 0) || !isfinite(depth[p])) depth[p] = 0;
    else c++;
  }
  *fg = c;
  return MGS_OK;
}

mgs_status mgs_fuse_depth(const mgs_depth_source *src, size_t n, const mgs_camera *cams, const mgs_image *const *masks,
                          const mgs_fusion_opts *o, mgs_vdb_grid **sdf, mgs_vdb_grid **tsdf, mgs_vdb_grid **weight,
                          mgs_fusion_report *rep, mgs_error *err) {
  *sdf = NULL;
  if (tsdf) *tsdf = NULL;
  if (weight) *weight = NULL;
  mgs_fusion_report local;
  if (!rep) rep = &local;
  double t0 = mgs_now();
  const mgs_depth_kind kind = o->depth >= 0 ? (mgs_depth_kind)o->depth : src->preferred;
  rep->views = n;
  rep->views_empty = 0;
  rep->depth = kind;
  rep->points = NULL;
  rep->n_points = 0;
  if (n == 0) return mgs_error_set(err, MGS_ERR_ARG, "depth fusion: no views");
  size_t maxpix = 0;
  for (size_t k = 0; k < n; k++) {
    size_t np = (size_t)cams[k].width * cams[k].height;
    if (np > maxpix) maxpix = np;
  }
  size_t nb = n < FUSION_BATCH ? n : FUSION_BATCH;
  float *depth = malloc(nb * maxpix * sizeof(float)), *alpha = malloc(maxpix * sizeof(float));
  unsigned char *far = masks ? malloc(2 * maxpix) : NULL;
  double *fp = malloc(n * sizeof(double)), *tmp = NULL;
  mgs_vdb_tsdf *t = NULL;
  mgs_status st = MGS_OK;
  if (!depth || !alpha || !fp || (masks && !far)) { st = mgs_error_set(err, MGS_ERR_NOMEM, "depth fusion: out of memory"); goto done; }
  if (masks) { /* a mask of another size (images read at another downscale than the cameras') is not used: said */
    size_t misfit = 0, first = 0;
    for (size_t k = 0; k < n; k++)
      if (masks[k] && !mask_fits(masks[k], &cams[k]) && !misfit++) first = k;
    if (misfit)
      mgs_warn("depth fusion: %zu image mask(s) not used: their size differs from their camera's (view %zu: %dx%d "
               "image, %dx%d camera; were the images read at the cameras' downscale?)", misfit, first,
               masks[first]->width, masks[first]->height, cams[first].width, cams[first].height);
  }
  /* pass 1: the footprint (median over views of the median foreground depth / focal) */
  size_t nfp = 0, fg_sum = 0;
  for (size_t k = 0; k < n; k++) {
    size_t fg = 0, np = (size_t)cams[k].width * cams[k].height;
    if ((st = render_masked(src, &cams[k], masks ? masks[k] : NULL, kind, o, depth, alpha, &fg, err))) goto done;
    if (!fg) { rep->views_empty++; continue; }
    fg_sum += fg;
    float *d = malloc(fg * sizeof(float));
    if (!d) { st = mgs_error_set(err, MGS_ERR_NOMEM, "depth fusion: out of memory"); goto done; }
    size_t c = 0;
    for (size_t p = 0; p < np; p++) if (depth[p] > 0) d[c++] = depth[p];
    qsort(d, c, sizeof(float), cmp_float);
    fp[nfp++] = d[c / 2] / (0.5 * (cams[k].fx + cams[k].fy));
    free(d);
  }
  if (rep->views_empty)
    mgs_warn("depth fusion: %zu of %zu views see nothing of the model (no pixel with alpha >= %g)", rep->views_empty, n,
             (double)o->alpha_mask);
  if (nfp == 0) {
    st = mgs_error_set(err, MGS_ERR_FORMAT,
                       "depth fusion: none of the %zu views sees the model (every pixel is background, alpha < %g)", n,
                       (double)o->alpha_mask);
    goto done;
  }
  rep->footprint = median_d(fp, nfp);
  rep->voxel_size = o->voxel_size > 0 ? o->voxel_size : o->voxel_fp * rep->footprint;
  rep->truncation = o->truncation > 0 ? o->truncation : o->trunc_fp * rep->footprint;
  if (rep->truncation < rep->voxel_size) {
    mgs_warn("depth fusion: truncation %g below the voxel size %g; raised to it", rep->truncation, rep->voxel_size);
    rep->truncation = rep->voxel_size;
  }
  rep->truncation_back = o->trunc_back_fp > 0 ? o->trunc_back_fp * rep->footprint : rep->truncation;
  if (rep->truncation_back < rep->voxel_size) rep->truncation_back = rep->voxel_size;
  if (rep->truncation_back > rep->truncation) rep->truncation_back = rep->truncation;
  mgs_vdb_tsdf_params tp;
  memset(&tp, 0, sizeof tp);
  tp.voxel_size = rep->voxel_size;
  tp.truncation = rep->truncation;
  tp.truncation_back = rep->truncation_back;
  rep->truncation_thin = o->thin_fp > 0 ? fmin(fmax(o->thin_fp * rep->footprint, rep->voxel_size), rep->truncation) : 0;
  tp.truncation_thin = rep->truncation_thin;
  {
    /* the lattice near the views' target: the mean of the camera centres snapped to
     * 64 voxels (float precision of the leaves far from the origin) */
    double c[3] = {0, 0, 0};
    for (size_t k = 0; k < n; k++) { double cc[3]; mgs_camera_center(&cams[k], cc); for (int i = 0; i < 3; i++) c[i] += cc[i] / n; }
    for (int i = 0; i < 3; i++) tp.origin[i] = 64 * tp.voxel_size * floor(c[i] / (64 * tp.voxel_size));
  }
  if ((st = mgs_vdb_tsdf_create(&tp, &t, err))) goto done;
  /* pass 2: fuse in batches */
  size_t stride = 1, cap_pts = 0;
  if (o->keep_points) { /* an even subsample: every stride-th foreground pixel of every view */
    cap_pts = o->keep_points;
    stride = fg_sum / cap_pts + 1;
    rep->points = malloc(3 * cap_pts * sizeof(float));
    if (!rep->points) { st = mgs_error_set(err, MGS_ERR_NOMEM, "depth fusion: out of memory"); goto done; }
  }
  mgs_vdb_tsdf_info info;
  memset(&info, 0, sizeof info);
  for (size_t k0 = 0; k0 < n; k0 += nb) {
    size_t kn = n - k0 < nb ? n - k0 : nb;
    const float *dp[FUSION_BATCH];
    for (size_t j = 0; j < kn; j++) {
      size_t fg;
      float *d = depth + j * maxpix;
      if ((st = render_masked(src, &cams[k0 + j], masks ? masks[k0 + j] : NULL, kind, o, d, alpha, &fg, err)))
        goto done;
      dp[j] = d;
      if (cap_pts) keep_points(&cams[k0 + j], d, stride, cap_pts, rep);
    }
    if ((st = mgs_vdb_tsdf_integrate(t, kn, cams + k0, dp, &info, err))) goto done;
  }
  /* pass 3: the images' silhouettes carve, once every block exists (a block first allocated
   * by a later batch would miss the earlier views' carving) */
  if (masks && o->mask_carve_px >= 0 && !o->carve)
    for (size_t k0 = 0; k0 < n; k0 += nb) {
      size_t kn = 0;
      const float *dp[FUSION_BATCH];
      mgs_camera cb[FUSION_BATCH];
      for (size_t j = k0; j < n && j < k0 + nb; j++) {
        if (!mask_fits(masks[j], &cams[j])) continue;
        size_t np = (size_t)cams[j].width * cams[j].height;
        float *d = depth + kn * maxpix;
        mask_far_background(masks[j], o->mask_carve_px, far, far + np);
        for (size_t p = 0; p < np; p++) d[p] = far[p] ? -1.0f : 0.0f;
        cb[kn] = cams[j];
        dp[kn++] = d;
      }
      if (kn && (st = mgs_vdb_tsdf_integrate(t, kn, cb, dp, &info, err))) goto done;
    }
  rep->blocks = info.blocks;
  rep->observed = info.voxels_observed;
  if ((st = mgs_vdb_tsdf_to_sdf(t, o->half_width, o->min_weight, sdf, err))) goto done;
  rep->thin_voxels = mgs_vdb_tsdf_thin_voxels(t);
  rep->band_voxels = mgs_vdb_grid_active_voxel_count(*sdf);
  if (rep->band_voxels == 0) {
    mgs_vdb_grid_destroy(*sdf);
    *sdf = NULL;
    st = mgs_error_set(err, MGS_ERR_FORMAT, "depth fusion: the fused volume has no zero crossing (empty level set)");
    goto done;
  }
  if ((tsdf || weight) && (st = mgs_vdb_tsdf_grids(t, tsdf, weight, err))) {
    mgs_vdb_grid_destroy(*sdf);
    *sdf = NULL;
    goto done;
  }
done:
  rep->seconds = mgs_now() - t0;
  if (st != MGS_OK || rep == &local) {
    free(rep->points);
    rep->points = NULL;
    rep->n_points = 0;
  }
  mgs_vdb_tsdf_destroy(t);
  free(depth); free(alpha); free(far); free(fp); free(tmp);
  return st;
}

char *mgs_fusion_model_path(const char *path, int iteration, mgs_error *err) {
  if (!mgs_is_dir(path)) {
    char *p = mgs_strdup(path);
    if (!p) mgs_error_set(err, MGS_ERR_NOMEM, "out of memory");
    return p;
  }
  int it = iteration >= 0 ? iteration : mgs_run_latest_iteration(path);
  if (it < 0) {
    mgs_error_set(err, MGS_ERR_IO, "%s: no point_cloud/iteration_N/point_cloud.ply in this run folder", path);
    return NULL;
  }
  char sub[96];
  snprintf(sub, sizeof sub, "point_cloud/iteration_%d/point_cloud.ply", it);
  char *p = mgs_path_join(path, sub);
  if (p && !mgs_path_exists(p)) {
    mgs_error_set(err, MGS_ERR_IO, "%s: not found", p);
    free(p);
    return NULL;
  }
  return p;
}

/* The dataset images' alpha for the cameras of cameras.json, when the run's cfg_args
 * leads to a readable dataset with alpha (else all NULL, silently: a run folder copied
 * without its data is still fused from the renders' alpha). A camera is matched by its
 * name and its centre: names repeat across splits (NeRF-synthetic's train/r_0 and
 * test/r_0; the reference's cameras.json keeps only the stem), so the view of that name
 * whose centre is nearest, within 1e-4 of the camera's distance from the origin plus
 * 1e-6, is taken, and none when no view is that close. */
static size_t image_masks(const char *run, int iteration, const mgs_camera *cams, char **names, size_t n,
                          mgs_image **masks) {
  mgs_dataset *ds = NULL;
  mgs_gaussians *g = NULL;
  int it;
  mgs_error e = {0};
  size_t found = 0;
  if (mgs_run_open(run, iteration, 0, &ds, &g, &it, &e) != MGS_OK) {
    mgs_info("depth fusion: no image alpha (%s)", e.msg);
    return 0;
  }
  for (size_t k = 0; k < n; k++) {
    if (!names || !names[k] || !names[k][0]) continue;
    double ck[3], best_d = INFINITY;
    mgs_camera_center(&cams[k], ck);
    mgs_view *best = NULL;
    for (int s = 0; s < MGS_SPLIT_COUNT; s++)
      for (size_t i = 0; i < ds->n_views[s]; i++) {
        mgs_view *v = &ds->views[s][i];
        if (!v->name || strcmp(v->name, names[k])) continue;
        double cv[3];
        mgs_camera_center(&v->cam, cv);
        for (int j = 0; j < 3; j++) cv[j] += ds->origin[j]; /* the dataset's cameras are relative to its origin */
        const double d = sqrt((cv[0] - ck[0]) * (cv[0] - ck[0]) + (cv[1] - ck[1]) * (cv[1] - ck[1]) +
                              (cv[2] - ck[2]) * (cv[2] - ck[2]));
        if (d < best_d) best_d = d, best = v;
      }
    const double tol = 1e-4 * sqrt(ck[0] * ck[0] + ck[1] * ck[1] + ck[2] * ck[2]) + 1e-6;
    if (!best || !(best_d <= tol)) continue;
    if (mgs_dataset_load_image(ds, best, &e) == MGS_OK && best->alpha) {
      masks[k] = best->alpha;
      best->alpha = NULL;
      found++;
    }
    mgs_image_destroy(best->image);
    best->image = NULL;
  }
  mgs_gaussians_destroy(g);
  mgs_dataset_destroy(ds);
  return found;
}

mgs_status mgs_fuse_path(const char *path, const mgs_fusion_opts *o, mgs_vdb_grid **sdf, mgs_vdb_grid **tsdf,
                         mgs_vdb_grid **weight, mgs_fusion_report *rep, mgs_error *err) {
  mgs_fusion_report local;
  if (!rep) rep = &local;
  memset(rep, 0, sizeof *rep);
  *sdf = NULL;
  mgs_gaussians *g = NULL;
  mgs_camera *cams = NULL;
  mgs_image **masks = NULL;
  char **names = NULL;
  size_t n = 0;
  mgs_depth_source src;
  mgs_depth_3dgs *s3 = NULL;
  mgs_status st;
  char *ply = mgs_fusion_model_path(path, o->iteration, err);
  if (!ply) return err->code ? err->code : MGS_ERR_IO;
  snprintf(rep->ply, sizeof rep->ply, "%s", ply);
  if ((st = mgs_ply_read_gaussians(ply, &g, err))) goto done;
  if (g->n == 0) { st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: no Gaussians", ply); goto done; }
  char *cj = mgs_is_dir(path) ? mgs_path_join(path, "cameras.json") : NULL;
  if (cj && mgs_path_exists(cj)) {
    st = mgs_cameras_read_json(cj, &cams, &names, &n, err);
    free(cj);
    if (st) goto done;
    if (o->image_alpha && (masks = calloc(n, sizeof *masks))) rep->image_masks = image_masks(path, o->iteration, cams, names, n, masks);
  } else {
    if (cj) mgs_warn("%s: no cameras.json; fusing %d virtual views on a sphere around the model (--views)", path, o->views);
    free(cj);
    if ((st = mgs_virtual_views(g, o->views, o->view_size, &cams, err))) goto done;
    n = (size_t)o->views;
    rep->virtual_views = 1;
  }
  if (!(s3 = mgs_depth_3dgs_create(g, &src))) { st = mgs_error_set(err, MGS_ERR_NOMEM, "out of memory"); goto done; }
  {
    int virt = rep->virtual_views;
    size_t im = rep->image_masks;
    st = mgs_fuse_depth(&src, n, cams, (const mgs_image *const *)masks, o, sdf, tsdf, weight, rep, err);
    rep->virtual_views = virt;
    rep->image_masks = im;
  }
done:
  mgs_depth_3dgs_destroy(s3);
  for (size_t k = 0; masks && k < n; k++) mgs_image_destroy(masks[k]);
  for (size_t k = 0; names && k < n; k++) free(names[k]);
  free(names);
  free(masks);
  free(cams);
  free(ply);
  mgs_gaussians_destroy(g);
  if (rep == &local) free(local.points);
  return st;
}

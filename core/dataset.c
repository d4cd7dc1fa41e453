/* Dataset loading common to every format: detection, view lists, image loading and the
 * reference's scene normalization (getNerfppNorm). */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "core/dataset_internal.h"
#include "core/mgs_fs.h"
#include "core/mgs_image.h"
#include "core/mgs_log.h"
#include "core/mgs_origin.h"
#include "core/mgs_parallel.h"

void mgs_dataset_options_default(mgs_dataset_options *o) {
  memset(o, 0, sizeof *o);
  o->format = MGS_DATASET_AUTO;
  o->downscale = 1;
  o->max_width = 1600;
  o->white_background = -1;
  o->load_images = 0;
  o->test_every = 8;
}

const char *mgs_split_name(mgs_split s) {
  switch (s) {
    case MGS_SPLIT_TRAIN: return "train";
    case MGS_SPLIT_VAL: return "val";
    case MGS_SPLIT_TEST: return "test";
    default: return "?";
  }
}

int mgs_file_exists(const char *path) {
  struct stat st;
  return stat(path, &st) == 0 && S_ISREG(st.st_mode);
}

mgs_status mgs_dataset_add_view(mgs_dataset *d, mgs_split split, const char *name, const char *image_path,
                                const mgs_camera *cam, int full_width, int full_height, mgs_error *err) {
  if (!mgs_file_exists(image_path)) return mgs_error_set(err, MGS_ERR_IO, "%s: image file not found", image_path);
  size_t n = d->n_views[split];
  mgs_view *nv = realloc(d->views[split], sizeof *nv * (n + 1));
  if (!nv) return mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", d->root);
  d->views[split] = nv;
  mgs_view *v = &nv[n];
  memset(v, 0, sizeof *v);
  v->name = mgs_strdup(name);
  v->image_path = mgs_strdup(image_path);
  if (!v->name || !v->image_path) {
    free(v->name);
    free(v->image_path);
    return mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", d->root);
  }
  v->cam = *cam;
  v->full_width = full_width;
  v->full_height = full_height;
  d->n_views[split] = n + 1;
  return MGS_OK;
}

static int pending_cmp(const void *a, const void *b) {
  return strcmp(((const mgs_pending_view *)a)->name, ((const mgs_pending_view *)b)->name);
}

void mgs_pending_free(mgs_pending_view *pv, size_t n) {
  for (size_t i = 0; pv && i < n; i++) {
    free(pv[i].name);
    free(pv[i].image_path);
  }
  free(pv);
}

mgs_status mgs_dataset_split_every(mgs_dataset *d, mgs_pending_view *pv, size_t n, int test_every, mgs_error *err) {
  mgs_status st = MGS_OK;
  if (n) qsort(pv, n, sizeof *pv, pending_cmp);
  for (size_t i = 0; i < n && st == MGS_OK; i++) {
    mgs_split s = (test_every > 0 && n > 1 && i % (size_t)test_every == 0) ? MGS_SPLIT_TEST : MGS_SPLIT_TRAIN;
    /* The view name is the file stem, as the reference's image_name. */
    char stem[512];
    const char *b = strrchr(pv[i].name, '/');
    snprintf(stem, sizeof stem, "%s", b ? b + 1 : pv[i].name);
    char *dot = strrchr(stem, '.');
    if (dot && dot != stem) *dot = 0;
    st = mgs_dataset_add_view(d, s, stem, pv[i].image_path, &pv[i].cam, pv[i].width, pv[i].height, err);
  }
  mgs_pending_free(pv, n);
  return st;
}

static mgs_dataset_format detect(const char *dir) {
  static const char *colmap_files[] = {"sparse/0/cameras.bin", "sparse/0/cameras.txt", "sparse/cameras.bin", "sparse/cameras.txt"};
  char *p = mgs_path_join(dir, "transforms_train.json");
  int nerf = p && mgs_file_exists(p);
  free(p);
  if (nerf) return MGS_DATASET_NERF_SYNTHETIC;
  p = mgs_path_join(dir, "transforms.json");
  int ns = p && mgs_file_exists(p);
  free(p);
  if (ns) return MGS_DATASET_NERFSTUDIO;
  for (size_t i = 0; i < sizeof colmap_files / sizeof colmap_files[0]; i++) {
    p = mgs_path_join(dir, colmap_files[i]);
    int c = p && mgs_file_exists(p);
    free(p);
    if (c) return MGS_DATASET_COLMAP;
  }
  return MGS_DATASET_AUTO;
}

static mgs_split look_split(const mgs_dataset *d) { return d->n_views[MGS_SPLIT_TRAIN] ? MGS_SPLIT_TRAIN : MGS_SPLIT_TEST; }

/* The reference's getNerfppNorm over the training cameras: centre of the camera centres,
 * radius 1.1 x the largest distance from it. */
static void scene_norm(mgs_dataset *d) {
  mgs_split s = look_split(d);
  size_t n = d->n_views[s];
  double c[3] = {0, 0, 0};
  for (size_t i = 0; i < n; i++) {
    double p[3];
    mgs_camera_center(&d->views[s][i].cam, p);
    for (int k = 0; k < 3; k++) c[k] += p[k];
  }
  if (n)
    for (int k = 0; k < 3; k++) c[k] /= (double)n;
  double r = 0;
  for (size_t i = 0; i < n; i++) {
    double p[3];
    mgs_camera_center(&d->views[s][i].cam, p);
    double dd = sqrt((p[0] - c[0]) * (p[0] - c[0]) + (p[1] - c[1]) * (p[1] - c[1]) + (p[2] - c[2]) * (p[2] - c[2]));
    if (dd > r) r = dd;
  }
  memcpy(d->center, c, sizeof c);
  /* One camera (or all at one spot) gives radius 0, which would zero the learning rates
     scaled by it: fall back to 1. */
  d->extent = r > 0 ? 1.1 * r : 1.0;
}

int mgs_dataset_look_at(const mgs_dataset *d, double p[3]) {
  mgs_split s = look_split(d);
  size_t n = d->n_views[s];
  /* sum over the axes of (I - v v^T) p = (I - v v^T) c, v the viewing direction (OpenCV:
     the camera looks down +z, the third column of c2w) */
  double A[9] = {0}, b[3] = {0};
  for (size_t i = 0; i < n; i++) {
    const double *m = d->views[s][i].cam.c2w;
    double v[3] = {m[2], m[6], m[10]}, c[3] = {m[3], m[7], m[11]};
    double vn = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (!(vn > 0)) continue;
    for (int k = 0; k < 3; k++) v[k] /= vn;
    for (int r = 0; r < 3; r++)
      for (int q = 0; q < 3; q++) {
        double e = (r == q) - v[r] * v[q];
        A[3 * r + q] += e;
        b[r] += e * c[q];
      }
  }
  double det = A[0] * (A[4] * A[8] - A[5] * A[7]) - A[1] * (A[3] * A[8] - A[5] * A[6]) + A[2] * (A[3] * A[7] - A[4] * A[6]);
  double nn = (double)n;
  memcpy(p, d->center, 3 * sizeof(double));
  /* det of n(I - vv^T)-like sums is ~n^3 when the directions spread; parallel axes
     (a forward-facing capture) have no common point */
  if (n < 2 || !(fabs(det) > 1e-6 * nn * nn * nn)) return 0;
  double q[3];
  for (int k = 0; k < 3; k++) { /* Cramer's rule */
    double M[9];
    memcpy(M, A, sizeof M);
    for (int r = 0; r < 3; r++) M[3 * r + k] = b[r];
    q[k] = (M[0] * (M[4] * M[8] - M[5] * M[7]) - M[1] * (M[3] * M[8] - M[5] * M[6]) + M[2] * (M[3] * M[7] - M[4] * M[6])) / det;
  }
  size_t in_front = 0;
  for (size_t i = 0; i < n; i++) {
    const double *m = d->views[s][i].cam.c2w;
    in_front += (q[0] - m[3]) * m[2] + (q[1] - m[7]) * m[6] + (q[2] - m[11]) * m[10] > 0;
  }
  if (2 * in_front <= n || !isfinite(q[0] + q[1] + q[2])) return 0;
  memcpy(p, q, sizeof q);
  return 1;
}

/* Chooses the scene origin (mgs_dataset.h) from the world-coordinate cameras and points,
 * then moves both into the local frame: camera positions and point positions minus the
 * origin in double, then rounded to float where they are float. A centred scene is left
 * untouched. */
static void place_origin(mgs_dataset *d) {
  double c[3];
  double lo[3], hi[3];
  const mgs_point_cloud *pc = d->init_points;
  if (pc && pc->n && mgs_points_bounds_robust(pc->xyz, pc->n, lo, hi))
    for (int k = 0; k < 3; k++) c[k] = 0.5 * (lo[k] + hi[k]);
  else
    mgs_dataset_look_at(d, c);
  mgs_origin_choose(c, d->extent, d->origin);
  if (!mgs_origin_is_zero(d->origin)) {
    for (int s = 0; s < MGS_SPLIT_COUNT; s++)
      for (size_t i = 0; i < d->n_views[s]; i++) {
        mgs_camera *cam = &d->views[s][i].cam;
        double m[16];
        memcpy(m, cam->c2w, sizeof m);
        m[3] -= d->origin[0]; m[7] -= d->origin[1]; m[11] -= d->origin[2];
        mgs_camera_set_c2w_opencv(cam, m);
      }
    if (pc && pc->xyz64)
      for (size_t i = 0; i < pc->n; i++)
        for (int k = 0; k < 3; k++) pc->xyz[3 * i + (size_t)k] = (float)(pc->xyz64[3 * i + (size_t)k] - d->origin[k]);
    else if (pc)
      for (size_t i = 0; i < pc->n; i++)
        for (int k = 0; k < 3; k++) pc->xyz[3 * i + (size_t)k] = (float)((double)pc->xyz[3 * i + (size_t)k] - d->origin[k]);
  }
  if (d->init_points) { /* the local float positions are what the rest uses */
    free(d->init_points->xyz64);
    d->init_points->xyz64 = NULL;
  }
}

typedef struct {
  mgs_dataset *d;
  mgs_view **views;
  mgs_status *status;
  mgs_error *errors;
} image_job;

static void load_images_range(void *ctx, size_t b, size_t e) {
  image_job *job = ctx;
  for (size_t i = b; i < e; i++) job->status[i] = mgs_dataset_load_image(job->d, job->views[i], &job->errors[i]);
}

/* Decodes every view's image in parallel; reports the first failure in view order, so
   the message does not depend on scheduling. */
static mgs_status load_all_images(mgs_dataset *d, mgs_error *err) {
  size_t n = 0;
  for (int s = 0; s < MGS_SPLIT_COUNT; s++) n += d->n_views[s];
  image_job job = {d, calloc(n, sizeof(mgs_view *)), calloc(n, sizeof(mgs_status)), calloc(n, sizeof(mgs_error))};
  mgs_status st = MGS_OK;
  if (!job.views || !job.status || !job.errors) {
    st = mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", d->root);
  } else {
    size_t k = 0;
    for (int s = 0; s < MGS_SPLIT_COUNT; s++)
      for (size_t i = 0; i < d->n_views[s]; i++) job.views[k++] = &d->views[s][i];
    mgs_parallel_for(0, n, 1, load_images_range, &job);
    for (size_t i = 0; i < n; i++)
      if (job.status[i] != MGS_OK) {
        st = job.status[i];
        if (err) *err = job.errors[i];
        break;
      }
  }
  free(job.views);
  free(job.status);
  free(job.errors);
  return st;
}

mgs_status mgs_dataset_load(const char *dir, const mgs_dataset_options *opt, mgs_dataset **out, mgs_error *err) {
  *out = NULL;
  mgs_dataset_options o;
  if (opt) o = *opt;
  else mgs_dataset_options_default(&o);
  if (o.downscale < 1 || o.downscale > 64)
    return mgs_error_set(err, MGS_ERR_ARG, "%s: downscale factor %d out of range 1..64", dir, o.downscale);
  if (o.test_every < 0) return mgs_error_set(err, MGS_ERR_ARG, "%s: test_every must be >= 0", dir);
  if (!mgs_is_dir(dir)) return mgs_error_set(err, MGS_ERR_IO, "%s: dataset directory not found", dir);
  mgs_dataset_format fmt = o.format == MGS_DATASET_AUTO ? detect(dir) : o.format;
  if (fmt == MGS_DATASET_AUTO)
    return mgs_error_set(err, MGS_ERR_FORMAT,
                         "%s: not a dataset (no transforms_train.json, transforms.json or sparse/0/cameras.{bin,txt})", dir);
  if (mgs_dataset_other_image_folder(&o)) {
    if (fmt == MGS_DATASET_NERF_SYNTHETIC)
      return mgs_error_set(err, MGS_ERR_ARG, "%s: a NeRF-synthetic dataset names its images in transforms_*.json; "
                           "another image folder ('%s') applies to COLMAP and nerfstudio datasets", dir, o.images);
    char *f = o.images[0] == '/' ? mgs_strdup(o.images) : mgs_path_join(dir, o.images); /* as os.path.join */
    const int ok = f && mgs_is_dir(f);
    if (!ok) {
      mgs_status st = mgs_error_set(err, MGS_ERR_IO, "%s: image folder not found", f ? f : o.images);
      free(f);
      return st;
    }
    free(f);
  }
  mgs_dataset *d = calloc(1, sizeof *d);
  if (!d) return mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", dir);
  d->format = fmt;
  d->root = mgs_strdup(dir);
  d->downscale = o.downscale;
  if (o.max_width < 0) return mgs_error_set(err, MGS_ERR_ARG, "%s: max_width must be >= 0", dir);
  d->white_background = o.white_background < 0 ? fmt == MGS_DATASET_NERF_SYNTHETIC : o.white_background != 0;
  d->max_width = o.downscale > 1 ? 0 : o.max_width;
  for (int k = 0; k < 3; k++) d->background[k] = d->white_background ? 1.0f : 0.0f;
  o.white_background = d->white_background;
  mgs_status st;
  switch (fmt) {
    case MGS_DATASET_NERF_SYNTHETIC: st = mgs_dataset_load_nerf_synthetic(d, &o, err); break;
    case MGS_DATASET_NERFSTUDIO: st = mgs_dataset_load_nerfstudio(d, &o, err); break;
    case MGS_DATASET_COLMAP: st = mgs_dataset_load_colmap(d, &o, err); break;
    default: st = mgs_error_set(err, MGS_ERR_ARG, "%s: unknown dataset format", dir);
  }
  if (st == MGS_OK && d->n_views[MGS_SPLIT_TRAIN] + d->n_views[MGS_SPLIT_TEST] == 0)
    st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: dataset has no views", dir);
  if (st == MGS_OK) {
    for (int s = 0; s < MGS_SPLIT_COUNT; s++)
      for (size_t i = 0; i < d->n_views[s]; i++) {
        mgs_view *v = &d->views[s][i];
        int w, h;
        mgs_dataset_image_size(v->cam.width, v->cam.height, o.downscale, d->max_width, &w, &h);
        if (w < 1 || h < 1) {
          st = mgs_error_set(err, MGS_ERR_ARG, "%s: image %dx%d is smaller than the downscale factor %d", v->image_path,
                             v->cam.width, v->cam.height, o.downscale);
          break;
        }
        mgs_camera_resize(&v->cam, w, h);
      }
    if (st == MGS_OK) {
      scene_norm(d); /* the extent (translation-free) that decides the origin */
      place_origin(d);
      if (!mgs_origin_is_zero(d->origin)) scene_norm(d); /* the centre in the local frame */
    }
  }
  if (st == MGS_OK && o.load_images) st = load_all_images(d, err);
  if (st != MGS_OK) {
    mgs_dataset_destroy(d);
    return st;
  }
  *out = d;
  return MGS_OK;
}

/* (as the reference: the field of view from the camera, the resolution from the image) */
mgs_status mgs_pending_scale_to_image(mgs_pending_view *v, double *sx, double *sy, mgs_error *err) {
  int w = 0, h = 0, c = 0;
  mgs_status st = mgs_image_read_size(v->image_path, &w, &h, &c, err);
  if (st != MGS_OK) return st;
  if (w == v->width && h == v->height) return MGS_OK;
  const double r = (double)w / v->width;
  if (fabs(r * v->height - h) > 1.0)
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: image is %dx%d, its camera %dx%d: not the same aspect ratio", v->image_path,
                         w, h, v->width, v->height);
  *sx = (double)w / v->width;
  *sy = (double)h / v->height;
  v->width = w;
  v->height = h;
  return MGS_OK;
}

void mgs_dataset_image_size(int full_w, int full_h, int downscale, int max_width, int *w, int *h) {
  if (downscale > 1) { /* Python's round(): halves to even, as nearbyint in the default mode */
    *w = (int)nearbyint((double)full_w / downscale);
    *h = (int)nearbyint((double)full_h / downscale);
  } else if (max_width > 0 && full_w > max_width) {
    double scale = (double)full_w / (double)max_width; /* int(orig / scale), as the reference */
    *w = (int)((double)full_w / scale);
    *h = (int)((double)full_h / scale);
  } else {
    *w = full_w;
    *h = full_h;
  }
}

mgs_status mgs_dataset_load_image(mgs_dataset *d, mgs_view *v, mgs_error *err) {
  if (v->image) return MGS_OK;
  mgs_image *img = NULL;
  mgs_status st = mgs_image_read(v->image_path, &img, err);
  if (st != MGS_OK) return st;
  if (img->width != v->full_width || img->height != v->full_height) {
    st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: image is %dx%d but its camera expects %dx%d", v->image_path, img->width,
                       img->height, v->full_width, v->full_height);
    mgs_image_destroy(img);
    return st;
  }
  mgs_image *rgb = NULL, *alpha = NULL;
  const size_t npx = (size_t)img->width * (size_t)img->height;
  if (img->channels >= 3) {
    rgb = mgs_image_composite(img, d->background);
    if (img->channels >= 4 && (alpha = mgs_image_create(img->width, img->height, 1)))
      for (size_t i = 0; i < npx; i++) alpha->data[i] = img->data[i * (size_t)img->channels + 3];
  } else {
    /* Grey (+alpha): expand to RGB. */
    rgb = mgs_image_create(img->width, img->height, 3);
    if (img->channels == 2) alpha = mgs_image_create(img->width, img->height, 1);
    if (rgb)
      for (size_t i = 0; i < npx; i++) {
        float g = img->data[i * (size_t)img->channels];
        float a = img->channels == 2 ? img->data[i * 2 + 1] : 1.0f;
        for (int c = 0; c < 3; c++) rgb->data[i * 3 + (size_t)c] = g * a + d->background[c] * (1.0f - a);
        if (alpha) alpha->data[i] = a;
      }
  }
  mgs_image_destroy(img);
  if (!rgb) goto nomem;
  /* composited first, then resized: the reference's order (PIL resize of the RGB image) */
  if (rgb->width != v->cam.width || rgb->height != v->cam.height) {
    mgs_image *r2 = mgs_image_resize_bicubic(rgb, v->cam.width, v->cam.height);
    mgs_image_destroy(rgb);
    rgb = r2;
    if (alpha) {
      mgs_image *a2 = mgs_image_resize_bicubic(alpha, v->cam.width, v->cam.height);
      mgs_image_destroy(alpha);
      alpha = a2;
      if (!alpha) goto nomem;
    }
    if (!rgb) goto nomem;
  }
  v->image = rgb;
  v->alpha = alpha;
  return MGS_OK;
nomem:
  mgs_image_destroy(rgb);
  mgs_image_destroy(alpha);
  return mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory (or image smaller than the downscale factor)", v->image_path);
}

void mgs_dataset_destroy(mgs_dataset *d) {
  if (!d) return;
  for (int s = 0; s < MGS_SPLIT_COUNT; s++) {
    for (size_t i = 0; i < d->n_views[s]; i++) {
      mgs_view *v = &d->views[s][i];
      free(v->name);
      free(v->image_path);
      mgs_image_destroy(v->image);
      mgs_image_destroy(v->alpha);
    }
    free(d->views[s]);
  }
  mgs_point_cloud_destroy(d->init_points);
  free(d->mesh_path);
  free(d->root);
  free(d);
}

/* ---- JSON helpers ---- */

mgs_status mgs_json_parse_file(const char *path, cJSON **out, mgs_error *err) {
  *out = NULL;
  char *text = NULL;
  size_t size = 0;
  mgs_status st = mgs_read_file(path, &text, &size, err);
  if (st != MGS_OK) return st;
  const char *end = NULL;
  size_t skip = size >= 3 && memcmp(text, "\xEF\xBB\xBF", 3) == 0 ? 3 : 0; /* UTF-8 byte order mark */
  cJSON *j = cJSON_ParseWithLengthOpts(text + skip, size - skip, &end, 0);
  if (!j) {
    size_t off = end && end >= text && end <= text + size ? (size_t)(end - text) : 0;
    free(text);
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: invalid JSON near byte %zu", path, off);
  }
  free(text);
  if (!cJSON_IsObject(j)) {
    cJSON_Delete(j);
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: top level is not a JSON object", path);
  }
  *out = j;
  return MGS_OK;
}

mgs_status mgs_json_number(const cJSON *obj, const char *key, const char *what, double *v, mgs_error *err) {
  const cJSON *it = cJSON_GetObjectItemCaseSensitive(obj, key);
  if (!it) return mgs_error_set(err, MGS_ERR_FORMAT, "%s: missing field '%s'", what, key);
  if (!cJSON_IsNumber(it)) return mgs_error_set(err, MGS_ERR_FORMAT, "%s: field '%s' must be a number", what, key);
  if (!isfinite(it->valuedouble)) return mgs_error_set(err, MGS_ERR_FORMAT, "%s: field '%s' is not finite", what, key);
  *v = it->valuedouble;
  return MGS_OK;
}

int mgs_json_opt_number(const cJSON *obj, const char *key, const char *what, double *v, mgs_status *st, mgs_error *err) {
  if (!cJSON_GetObjectItemCaseSensitive(obj, key)) return 0;
  *st = mgs_json_number(obj, key, what, v, err);
  return 1;
}

mgs_status mgs_json_string(const cJSON *obj, const char *key, const char *what, const char **v, mgs_error *err) {
  const cJSON *it = cJSON_GetObjectItemCaseSensitive(obj, key);
  if (!it) return mgs_error_set(err, MGS_ERR_FORMAT, "%s: missing field '%s'", what, key);
  if (!cJSON_IsString(it) || !it->valuestring)
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: field '%s' must be a string", what, key);
  if (!it->valuestring[0]) return mgs_error_set(err, MGS_ERR_FORMAT, "%s: field '%s' is empty", what, key);
  *v = it->valuestring;
  return MGS_OK;
}

mgs_status mgs_json_matrix4(const cJSON *obj, const char *key, const char *what, double m[16], mgs_error *err) {
  const cJSON *it = cJSON_GetObjectItemCaseSensitive(obj, key);
  if (!it) return mgs_error_set(err, MGS_ERR_FORMAT, "%s: missing field '%s'", what, key);
  int ok = cJSON_IsArray(it) && cJSON_GetArraySize(it) == 4;
  for (int r = 0; ok && r < 4; r++) {
    const cJSON *row = cJSON_GetArrayItem(it, r);
    ok = cJSON_IsArray(row) && cJSON_GetArraySize(row) == 4;
    for (int c = 0; ok && c < 4; c++) {
      const cJSON *x = cJSON_GetArrayItem(row, c);
      ok = cJSON_IsNumber(x) && isfinite(x->valuedouble);
      if (ok) m[r * 4 + c] = x->valuedouble;
    }
  }
  if (!ok) return mgs_error_set(err, MGS_ERR_FORMAT, "%s: %s must be 4x4 finite numbers", what, key);
  /* A camera-to-world matrix: last row 0 0 0 1 and a rotation part that is orthonormal
     (up to a tolerance; Blender exports carry float noise). */
  if (fabs(m[12]) > 1e-6 || fabs(m[13]) > 1e-6 || fabs(m[14]) > 1e-6 || fabs(m[15] - 1) > 1e-6)
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: %s last row must be 0 0 0 1", what, key);
  for (int a = 0; a < 3; a++)
    for (int b = 0; b < 3; b++) {
      double dot = m[0 * 4 + a] * m[0 * 4 + b] + m[1 * 4 + a] * m[1 * 4 + b] + m[2 * 4 + a] * m[2 * 4 + b];
      if (fabs(dot - (a == b)) > 1e-3)
        return mgs_error_set(err, MGS_ERR_FORMAT, "%s: %s rotation part is not orthonormal (scaled or sheared pose)", what, key);
    }
  return MGS_OK;
}

/* COLMAP sparse models: sparse/0/{cameras,images,points3D}.{bin,txt} (binary preferred,
 * as the reference) with images in images/ (or another folder: options.images, scaling each
 * camera to its image's size as the reference's -i images_4 does). Only undistorted pinhole cameras
 * (PINHOLE, SIMPLE_PINHOLE) are accepted. COLMAP poses are world-to-camera in the
 * OpenCV convention: X_cam = R(q) X + t with q = (qw, qx, qy, qz). A gt_mesh.ply beside
 * sparse/ is the ground-truth mesh, taken to be in the model's frame (no normalisation
 * here: the poses are used as stored). */
#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/dataset_internal.h"
#include "core/mgs_fs.h"
#include "core/mgs_image.h"

typedef struct { uint32_t id; int model; int width, height; double params[4]; } cmp_camera;
typedef struct { uint32_t id; double q[4], t[3]; uint32_t camera_id; char *name; } cmp_image;
typedef struct {
  cmp_camera *cams;
  size_t n_cams;
  cmp_image *imgs;
  size_t n_imgs;
} cmp_model;

static const struct { const char *name; int n_params; } models[] = {
  {"SIMPLE_PINHOLE", 3}, {"PINHOLE", 4}, {"SIMPLE_RADIAL", 4}, {"RADIAL", 5}, {"OPENCV", 8}, {"OPENCV_FISHEYE", 8},
  {"FULL_OPENCV", 12}, {"FOV", 5}, {"SIMPLE_RADIAL_FISHEYE", 4}, {"RADIAL_FISHEYE", 5}, {"THIN_PRISM_FISHEYE", 12},
  {"RAD_TAN_THIN_PRISM_FISHEYE", 16}};
#define N_MODELS ((int)(sizeof models / sizeof models[0]))

static void model_free(cmp_model *m) {
  for (size_t i = 0; i < m->n_imgs; i++) free(m->imgs[i].name);
  free(m->imgs);
  free(m->cams);
  memset(m, 0, sizeof *m);
}

static mgs_status check_camera(const char *path, cmp_camera *c, const double *params, int n_params, mgs_error *err) {
  if (c->model != 0 && c->model != 1)
    return mgs_error_set(err, MGS_ERR_UNSUPPORTED,
                         "%s: camera %u uses model %s; only PINHOLE and SIMPLE_PINHOLE are supported (undistort with colmap image_undistorter)",
                         path, c->id, models[c->model].name);
  if (c->width < 1 || c->height < 1) return mgs_error_set(err, MGS_ERR_FORMAT, "%s: camera %u has invalid size", path, c->id);
  for (int k = 0; k < n_params; k++)
    if (!isfinite(params[k])) return mgs_error_set(err, MGS_ERR_FORMAT, "%s: camera %u has a non-finite parameter", path, c->id);
  if (c->model == 0) { c->params[0] = c->params[1] = params[0]; c->params[2] = params[1]; c->params[3] = params[2]; }
  else memcpy(c->params, params, sizeof(double) * 4);
  if (!(c->params[0] > 0 && c->params[1] > 0)) return mgs_error_set(err, MGS_ERR_FORMAT, "%s: camera %u has a non-positive focal length", path, c->id);
  if (!mgs_camera_focal_valid(c->params[0], c->width) || !mgs_camera_focal_valid(c->params[1], c->height))
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: camera %u has focal lengths %g, %g px for a %dx%d image (a field of view near 0 or 180 degrees)",
                         path, c->id, c->params[0], c->params[1], c->width, c->height);
  return MGS_OK;
}

static mgs_status check_image(const char *path, cmp_image *im, mgs_error *err) {
  double n = 0;
  for (int k = 0; k < 4; k++) {
    if (!isfinite(im->q[k])) return mgs_error_set(err, MGS_ERR_FORMAT, "%s: image %u has a non-finite quaternion", path, im->id);
    n += im->q[k] * im->q[k];
  }
  for (int k = 0; k < 3; k++)
    if (!isfinite(im->t[k])) return mgs_error_set(err, MGS_ERR_FORMAT, "%s: image %u has a non-finite translation", path, im->id);
  if (!(n > 1e-12)) return mgs_error_set(err, MGS_ERR_FORMAT, "%s: image %u has a zero quaternion", path, im->id);
  n = sqrt(n);
  for (int k = 0; k < 4; k++) im->q[k] /= n;
  if (!im->name || !im->name[0]) return mgs_error_set(err, MGS_ERR_FORMAT, "%s: image %u has an empty name", path, im->id);
  return MGS_OK;
}

/* ---- binary ---- */

typedef struct { const unsigned char *p; size_t n, pos; } cursor;
static int rd(cursor *c, void *out, size_t k) {
  if (k > c->n - c->pos) return 0;
  memcpy(out, c->p + c->pos, k); /* COLMAP writes little-endian; so is every host we build on */
  c->pos += k;
  return 1;
}
static int skip(cursor *c, uint64_t count, size_t each) {
  if (each && count > (c->n - c->pos) / each) return 0;
  c->pos += (size_t)count * each;
  return 1;
}

#define TRUNC(path) mgs_error_set(err, MGS_ERR_FORMAT, "%s: file ends early (truncated?)", path)

static mgs_status read_cameras_bin(const char *path, cmp_model *m, mgs_error *err) {
  char *buf = NULL;
  size_t size = 0;
  mgs_status st = mgs_read_file(path, &buf, &size, err);
  if (st != MGS_OK) return st;
  cursor c = {(const unsigned char *)buf, size, 0};
  uint64_t n = 0;
  if (!rd(&c, &n, 8)) { free(buf); return TRUNC(path); }
  if (n == 0 || n > (size - 8) / 24) { free(buf); return mgs_error_set(err, MGS_ERR_FORMAT, "%s: camera count %llu does not fit the file", path, (unsigned long long)n); }
  m->cams = calloc((size_t)n, sizeof *m->cams);
  if (!m->cams) { free(buf); return mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", path); }
  for (uint64_t i = 0; i < n && st == MGS_OK; i++) {
    uint32_t id;
    int32_t model;
    uint64_t w, h;
    if (!rd(&c, &id, 4) || !rd(&c, &model, 4) || !rd(&c, &w, 8) || !rd(&c, &h, 8)) { st = TRUNC(path); break; }
    if (model < 0 || model >= N_MODELS) { st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: camera %u has unknown model id %d", path, id, model); break; }
    double params[16];
    if (!rd(&c, params, 8 * (size_t)models[model].n_params)) { st = TRUNC(path); break; }
    if (w > (1u << 20) || h > (1u << 20)) { st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: camera %u has invalid size", path, id); break; }
    cmp_camera *cam = &m->cams[m->n_cams++];
    cam->id = id;
    cam->model = model;
    cam->width = (int)w;
    cam->height = (int)h;
    st = check_camera(path, cam, params, models[model].n_params, err);
  }
  free(buf);
  return st;
}

static mgs_status read_images_bin(const char *path, cmp_model *m, mgs_error *err) {
  char *buf = NULL;
  size_t size = 0;
  mgs_status st = mgs_read_file(path, &buf, &size, err);
  if (st != MGS_OK) return st;
  cursor c = {(const unsigned char *)buf, size, 0};
  uint64_t n = 0;
  if (!rd(&c, &n, 8)) { free(buf); return TRUNC(path); }
  if (n > (size - 8) / 73) { free(buf); return mgs_error_set(err, MGS_ERR_FORMAT, "%s: image count %llu does not fit the file", path, (unsigned long long)n); }
  m->imgs = calloc((size_t)n + 1, sizeof *m->imgs);
  if (!m->imgs) { free(buf); return mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", path); }
  for (uint64_t i = 0; i < n && st == MGS_OK; i++) {
    cmp_image *im = &m->imgs[m->n_imgs++];
    if (!rd(&c, &im->id, 4) || !rd(&c, im->q, 32) || !rd(&c, im->t, 24) || !rd(&c, &im->camera_id, 4)) { st = TRUNC(path); break; }
    const unsigned char *s = c.p + c.pos, *e = memchr(s, 0, c.n - c.pos);
    if (!e) { st = TRUNC(path); break; }
    if (e - s > 4000) { st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: image %u name too long", path, im->id); break; }
    im->name = mgs_strdup((const char *)s);
    c.pos += (size_t)(e - s) + 1;
    uint64_t np = 0;
    if (!rd(&c, &np, 8) || !skip(&c, np, 24)) { st = TRUNC(path); break; }
    st = check_image(path, im, err);
  }
  free(buf);
  return st;
}

static mgs_status read_points_bin(const char *path, mgs_point_cloud **out, mgs_error *err) {
  char *buf = NULL;
  size_t size = 0;
  mgs_status st = mgs_read_file(path, &buf, &size, err);
  if (st != MGS_OK) return st;
  cursor c = {(const unsigned char *)buf, size, 0};
  uint64_t n = 0;
  if (!rd(&c, &n, 8)) { free(buf); return TRUNC(path); }
  if (n > (size - 8) / 51) { free(buf); return mgs_error_set(err, MGS_ERR_FORMAT, "%s: point count %llu does not fit the file", path, (unsigned long long)n); }
  mgs_point_cloud *pc = calloc(1, sizeof *pc);
  if (pc) {
    pc->xyz = malloc(sizeof(float) * 3 * ((size_t)n + 1));
    pc->rgb = malloc(sizeof(float) * 3 * ((size_t)n + 1));
    pc->xyz64 = malloc(sizeof(double) * 3 * ((size_t)n + 1));
  }
  if (!pc || !pc->xyz || !pc->rgb || !pc->xyz64) { free(buf); mgs_point_cloud_destroy(pc); return mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", path); }
  for (uint64_t i = 0; i < n && st == MGS_OK; i++) {
    uint64_t id, track;
    double xyz[3], e;
    unsigned char rgb[3];
    if (!rd(&c, &id, 8) || !rd(&c, xyz, 24) || !rd(&c, rgb, 3) || !rd(&c, &e, 8) || !rd(&c, &track, 8) || !skip(&c, track, 8)) { st = TRUNC(path); break; }
    for (int k = 0; k < 3; k++) {
      if (!isfinite(xyz[k]) || fabs(xyz[k]) > 1e30) { st = mgs_error_set(err, MGS_ERR_NUMERIC, "%s: point %llu has a non-finite position", path, (unsigned long long)id); break; }
      pc->xyz[i * 3 + (size_t)k] = (float)xyz[k];
      pc->xyz64[i * 3 + (size_t)k] = xyz[k];
      pc->rgb[i * 3 + (size_t)k] = (float)rgb[k] / 255.0f;
    }
    pc->n = (size_t)i + 1;
  }
  free(buf);
  if (st != MGS_OK) { mgs_point_cloud_destroy(pc); return st; }
  *out = pc;
  return MGS_OK;
}

/* ---- text ---- */

/* Calls fn for every non-empty, non-comment line (tokenized), passing the line after it
 * through `next` so images.txt can consume its points line. */
typedef struct { char *text; size_t size, pos; size_t line_no; } lines;

static char *next_line(lines *L) {
  if (L->pos >= L->size) return NULL;
  char *s = L->text + L->pos;
  char *e = memchr(s, '\n', L->size - L->pos);
  if (e) { *e = 0; L->pos = (size_t)(e - L->text) + 1; }
  else L->pos = L->size;
  L->line_no++;
  size_t len = strlen(s);
  if (len && s[len - 1] == '\r') s[len - 1] = 0;
  return s;
}

static int tokenize(char *s, char **tok, int max) {
  int n = 0;
  char *save = NULL;
  for (char *t = strtok_r(s, " \t", &save); t; t = strtok_r(NULL, " \t", &save)) {
    if (n == max) return max + 1;
    tok[n++] = t;
  }
  return n;
}

static int parse_d(const char *s, double *v) {
  char *e = NULL;
  *v = strtod(s, &e);
  return e && e != s && *e == 0 && isfinite(*v);
}
static int parse_u(const char *s, uint64_t *v, uint64_t max) {
  if (s[0] == '-' || s[0] == '+') return 0;
  char *e = NULL;
  errno = 0;
  unsigned long long x = strtoull(s, &e, 10);
  if (errno || !e || e == s || *e || x > max) return 0;
  *v = x;
  return 1;
}

static int is_blank_or_comment(const char *s) {
  while (*s == ' ' || *s == '\t') s++;
  return *s == 0 || *s == '#';
}

static mgs_status read_cameras_txt(const char *path, cmp_model *m, mgs_error *err) {
  lines L = {0};
  mgs_status st = mgs_read_file(path, &L.text, &L.size, err);
  if (st != MGS_OK) return st;
  size_t cap = 0;
  char *s;
  while (st == MGS_OK && (s = next_line(&L))) {
    if (is_blank_or_comment(s)) continue;
    char *tok[24];
    int nt = tokenize(s, tok, 22);
    uint64_t id, w, h;
    if (nt < 4 || !parse_u(tok[0], &id, UINT32_MAX) || !parse_u(tok[2], &w, 1u << 20) || !parse_u(tok[3], &h, 1u << 20)) {
      st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: line %zu: expected CAMERA_ID MODEL WIDTH HEIGHT PARAMS...", path, L.line_no);
      break;
    }
    int model = -1;
    for (int k = 0; k < N_MODELS; k++)
      if (strcmp(tok[1], models[k].name) == 0) model = k;
    if (model < 0) {
      st = mgs_error_set(err, MGS_ERR_UNSUPPORTED, "%s: line %zu: unknown camera model '%s'; only PINHOLE and SIMPLE_PINHOLE are supported",
                         path, L.line_no, tok[1]);
      break;
    }
    cmp_camera cam = {(uint32_t)id, model, (int)w, (int)h, {0, 0, 0, 0}};
    if (model <= 1 && nt != 4 + models[model].n_params) {
      st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: line %zu: %s needs %d parameters, got %d", path, L.line_no, models[model].name,
                         models[model].n_params, nt - 4);
      break;
    }
    double params[16] = {0};
    for (int k = 0; model <= 1 && k < models[model].n_params; k++)
      if (!parse_d(tok[4 + k], &params[k])) {
        st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: line %zu: parameter %d is not a finite number", path, L.line_no, k);
        break;
      }
    if (st != MGS_OK) break;
    if ((st = check_camera(path, &cam, params, model <= 1 ? models[model].n_params : 0, err)) != MGS_OK) break;
    if (m->n_cams == cap) {
      cap = cap ? cap * 2 : 8;
      cmp_camera *nc = realloc(m->cams, cap * sizeof *nc);
      if (!nc) { st = mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", path); break; }
      m->cams = nc;
    }
    m->cams[m->n_cams++] = cam;
  }
  free(L.text);
  return st;
}

static mgs_status read_images_txt(const char *path, cmp_model *m, mgs_error *err) {
  lines L = {0};
  mgs_status st = mgs_read_file(path, &L.text, &L.size, err);
  if (st != MGS_OK) return st;
  size_t cap = 0;
  char *s;
  while (st == MGS_OK && (s = next_line(&L))) {
    if (is_blank_or_comment(s)) continue;
    char *tok[12];
    int nt = tokenize(s, tok, 10);
    uint64_t id, cid;
    cmp_image im;
    memset(&im, 0, sizeof im);
    int ok = nt == 10 && parse_u(tok[0], &id, UINT32_MAX) && parse_u(tok[8], &cid, UINT32_MAX);
    for (int k = 0; ok && k < 4; k++) ok = parse_d(tok[1 + k], &im.q[k]);
    for (int k = 0; ok && k < 3; k++) ok = parse_d(tok[5 + k], &im.t[k]);
    if (!ok) {
      st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: line %zu: expected IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME", path, L.line_no);
      break;
    }
    im.id = (uint32_t)id;
    im.camera_id = (uint32_t)cid;
    im.name = mgs_strdup(tok[9]);
    next_line(&L); /* the POINTS2D line (may be empty) */
    if (m->n_imgs == cap) {
      cap = cap ? cap * 2 : 16;
      cmp_image *ni = realloc(m->imgs, cap * sizeof *ni);
      if (!ni) { free(im.name); st = mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", path); break; }
      m->imgs = ni;
    }
    m->imgs[m->n_imgs++] = im;
    st = check_image(path, &m->imgs[m->n_imgs - 1], err);
  }
  free(L.text);
  return st;
}

static mgs_status read_points_txt(const char *path, mgs_point_cloud **out, mgs_error *err) {
  lines L = {0};
  mgs_status st = mgs_read_file(path, &L.text, &L.size, err);
  if (st != MGS_OK) return st;
  mgs_point_cloud *pc = calloc(1, sizeof *pc);
  size_t cap = 0;
  char *s;
  if (!pc) st = mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", path);
  while (st == MGS_OK && (s = next_line(&L))) {
    if (is_blank_or_comment(s)) continue;
    char *tok[9];
    int nt = tokenize(s, tok, 8); /* the track after ERROR is ignored */
    double xyz[3], e;
    uint64_t id, rgb[3];
    int ok = nt >= 8 && parse_u(tok[0], &id, UINT64_MAX) && parse_d(tok[7], &e);
    for (int k = 0; ok && k < 3; k++) ok = parse_d(tok[1 + k], &xyz[k]) && fabs(xyz[k]) < 1e30 && parse_u(tok[4 + k], &rgb[k], 255);
    if (!ok) {
      st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: line %zu: expected POINT3D_ID X Y Z R G B ERROR TRACK...", path, L.line_no);
      break;
    }
    if (pc->n == cap) {
      cap = cap ? cap * 2 : 256;
      float *nx = realloc(pc->xyz, cap * 3 * sizeof(float));
      if (nx) pc->xyz = nx;
      float *nr = realloc(pc->rgb, cap * 3 * sizeof(float));
      if (nr) pc->rgb = nr;
      double *n64 = realloc(pc->xyz64, cap * 3 * sizeof(double));
      if (n64) pc->xyz64 = n64;
      if (!nx || !nr || !n64) { st = mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", path); break; }
    }
    for (int k = 0; k < 3; k++) {
      pc->xyz[pc->n * 3 + (size_t)k] = (float)xyz[k];
      pc->xyz64[pc->n * 3 + (size_t)k] = xyz[k];
      pc->rgb[pc->n * 3 + (size_t)k] = (float)rgb[k] / 255.0f;
    }
    pc->n++;
  }
  free(L.text);
  if (st != MGS_OK) { mgs_point_cloud_destroy(pc); return st; }
  if (!pc->xyz) { pc->xyz = malloc(sizeof(float) * 3); pc->rgb = malloc(sizeof(float) * 3); }
  if (!pc->xyz64) pc->xyz64 = malloc(sizeof(double) * 3);
  *out = pc;
  return MGS_OK;
}

/* ---- assembling the dataset ---- */

static void quat_to_w2c(const double q[4], const double t[3], double m[16]) {
  const double w = q[0], x = q[1], y = q[2], z = q[3];
  const double R[9] = {1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
                       2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
                       2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)};
  for (int r = 0; r < 3; r++) {
    for (int c = 0; c < 3; c++) m[r * 4 + c] = R[r * 3 + c];
    m[r * 4 + 3] = t[r];
  }
  m[12] = m[13] = m[14] = 0;
  m[15] = 1;
}

mgs_status mgs_dataset_load_colmap(mgs_dataset *d, const mgs_dataset_options *o, mgs_error *err) {
  const int other_folder = mgs_dataset_other_image_folder(o);
  const char *folder = other_folder ? o->images : "images";
  char *sparse = mgs_path_join(d->root, "sparse/0");
  if (sparse && !mgs_is_dir(sparse)) { free(sparse); sparse = mgs_path_join(d->root, "sparse"); }
  if (!sparse) return mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", d->root);
  char *cb = mgs_path_join(sparse, "cameras.bin");
  const int bin = cb && mgs_file_exists(cb);
  free(cb);
  char *pc = mgs_path_join(sparse, bin ? "cameras.bin" : "cameras.txt");
  char *pi = mgs_path_join(sparse, bin ? "images.bin" : "images.txt");
  char *pp = mgs_path_join(sparse, bin ? "points3D.bin" : "points3D.txt");
  cmp_model m;
  memset(&m, 0, sizeof m);
  mgs_status st = (!pc || !pi || !pp) ? mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", d->root) : MGS_OK;
  if (st == MGS_OK) st = bin ? read_cameras_bin(pc, &m, err) : read_cameras_txt(pc, &m, err);
  if (st == MGS_OK) st = bin ? read_images_bin(pi, &m, err) : read_images_txt(pi, &m, err);
  if (st == MGS_OK && m.n_imgs == 0) st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: no images", pi);
  mgs_pending_view *pv = NULL;
  size_t npv = 0;
  if (st == MGS_OK && !(pv = calloc(m.n_imgs, sizeof *pv))) st = mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", d->root);
  for (size_t i = 0; st == MGS_OK && i < m.n_imgs; i++) {
    const cmp_image *im = &m.imgs[i];
    const cmp_camera *cam = NULL;
    for (size_t k = 0; k < m.n_cams; k++)
      if (m.cams[k].id == im->camera_id) cam = &m.cams[k];
    if (!cam) { st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: image %u refers to camera %u, which %s does not define", pi, im->id, im->camera_id, pc); break; }
    mgs_pending_view *v = &pv[npv++];
    v->name = mgs_strdup(im->name);
    char rel[4200];
    snprintf(rel, sizeof rel, "%s/%s", folder, im->name);
    v->image_path = folder[0] == '/' ? mgs_strdup(rel) : mgs_path_join(d->root, rel); /* as os.path.join */
    v->width = cam->width;
    v->height = cam->height;
    v->split = -1;
    if (!v->name || !v->image_path) { st = mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", d->root); break; }
    double sx = 1, sy = 1;
    if (other_folder && (st = mgs_pending_scale_to_image(v, &sx, &sy, err)) != MGS_OK) break;
    mgs_camera_init(&v->cam, v->width, v->height, cam->params[0] * sx, cam->params[1] * sy, cam->params[2] * sx,
                    cam->params[3] * sy);
    double w2c[16];
    quat_to_w2c(im->q, im->t, w2c);
    mgs_camera_set_w2c_opencv(&v->cam, w2c);
  }
  if (st == MGS_OK) st = mgs_dataset_split_every(d, pv, npv, o->test_every, err);
  else mgs_pending_free(pv, npv);
  if (st == MGS_OK && mgs_file_exists(pp))
    st = bin ? read_points_bin(pp, &d->init_points, err) : read_points_txt(pp, &d->init_points, err);
  if (st == MGS_OK) { /* a GT mesh in the model's (SfM) frame, as scripts/colmap_scene.sh writes it */
    char *mesh = mgs_path_join(d->root, "gt_mesh.ply");
    if (mesh && mgs_file_exists(mesh)) d->mesh_path = mesh;
    else free(mesh);
  }
  model_free(&m);
  free(pc);
  free(pi);
  free(pp);
  free(sparse);
  return st;
}

/* nerfstudio datasets: one transforms.json with intrinsics fl_x fl_y cx cy w h per
 * dataset or per frame, camera_model PINHOLE or OPENCV without distortion, frames with
 * file_path (with extension) and an OpenGL camera-to-world transform_matrix, optional
 * ply_file_path (initial points) and optional {train,val,test}_filenames splits. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/dataset_internal.h"
#include "core/mgs_fs.h"

static const char *const intrinsic_keys[6] = {"fl_x", "fl_y", "cx", "cy", "w", "h"};
static const char *const distortion_keys[6] = {"k1", "k2", "k3", "k4", "p1", "p2"};

/* Frame value, else dataset value, else an error. */
static mgs_status intrinsic(const cJSON *frame, const cJSON *top, const char *key, const char *what, double *v, mgs_error *err) {
  if (cJSON_GetObjectItemCaseSensitive(frame, key)) return mgs_json_number(frame, key, what, v, err);
  if (cJSON_GetObjectItemCaseSensitive(top, key)) return mgs_json_number(top, key, what, v, err);
  return mgs_error_set(err, MGS_ERR_FORMAT, "%s: missing field '%s' (neither per frame nor per dataset)", what, key);
}

static mgs_status check_model(const cJSON *obj, const char *what, mgs_error *err) {
  const cJSON *m = cJSON_GetObjectItemCaseSensitive(obj, "camera_model");
  if (m) {
    if (!cJSON_IsString(m) || !m->valuestring) return mgs_error_set(err, MGS_ERR_FORMAT, "%s: camera_model must be a string", what);
    if (strcmp(m->valuestring, "PINHOLE") != 0 && strcmp(m->valuestring, "OPENCV") != 0)
      return mgs_error_set(err, MGS_ERR_UNSUPPORTED, "%s: camera_model '%s' is not supported (PINHOLE or OPENCV without distortion)",
                           what, m->valuestring);
  }
  for (int k = 0; k < 6; k++) {
    double v = 0;
    mgs_status st = MGS_OK;
    if (mgs_json_opt_number(obj, distortion_keys[k], what, &v, &st, err)) {
      if (st != MGS_OK) return st;
      if (v != 0)
        return mgs_error_set(err, MGS_ERR_UNSUPPORTED, "%s: camera_model %s with distortion %s=%g is not supported (undistort the images first)",
                             what, m && cJSON_IsString(m) ? m->valuestring : "OPENCV", distortion_keys[k], v);
    }
  }
  return MGS_OK;
}

/* Which split a frame belongs to per the file's own *_filenames lists; -1 if the file has
 * none, -2 if it has lists but this frame is in none of them. */
static int listed_split(const cJSON *top, const char *file_path) {
  static const char *keys[MGS_SPLIT_COUNT] = {"train_filenames", "val_filenames", "test_filenames"};
  int any = 0;
  for (int s = 0; s < MGS_SPLIT_COUNT; s++) {
    const cJSON *arr = cJSON_GetObjectItemCaseSensitive(top, keys[s]);
    if (!cJSON_IsArray(arr)) continue;
    any = 1;
    const cJSON *it;
    cJSON_ArrayForEach(it, arr) {
      if (!cJSON_IsString(it) || !it->valuestring) continue;
      const char *a = it->valuestring, *b = file_path;
      if (a[0] == '.' && a[1] == '/') a += 2;
      if (b[0] == '.' && b[1] == '/') b += 2;
      if (strcmp(a, b) == 0) return s;
    }
  }
  return any ? -2 : -1;
}

mgs_status mgs_dataset_load_nerfstudio(mgs_dataset *d, const mgs_dataset_options *o, mgs_error *err) {
  char *path = mgs_path_join(d->root, "transforms.json");
  if (!path) return mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", d->root);
  cJSON *j = NULL;
  mgs_status st = mgs_json_parse_file(path, &j, err);
  if (st != MGS_OK) { free(path); return st; }
  mgs_pending_view *pv = NULL;
  size_t npv = 0;
  int use_lists = 0;
  const int other_folder = mgs_dataset_other_image_folder(o);
  st = check_model(j, path, err);
  const cJSON *frames = cJSON_GetObjectItemCaseSensitive(j, "frames");
  if (st == MGS_OK && !frames) st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: missing field 'frames'", path);
  if (st == MGS_OK && !cJSON_IsArray(frames)) st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: field 'frames' must be an array", path);
  if (st == MGS_OK) {
    pv = calloc((size_t)cJSON_GetArraySize(frames) + 1, sizeof *pv);
    if (!pv) st = mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", path);
  }
  int fi = 0;
  const cJSON *fr;
  if (st == MGS_OK) cJSON_ArrayForEach(fr, frames) {
    char what[4400];
    snprintf(what, sizeof what, "%s: frame %d", path, fi++);
    if (!cJSON_IsObject(fr)) { st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: not an object", what); break; }
    if ((st = check_model(fr, what, err)) != MGS_OK) break;
    double in[6], m[16];
    for (int k = 0; k < 6 && st == MGS_OK; k++) st = intrinsic(fr, j, intrinsic_keys[k], what, &in[k], err);
    if (st != MGS_OK) break;
    if (!(in[0] > 0 && in[1] > 0)) { st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: focal lengths must be positive", what); break; }
    if (!(in[4] >= 1 && in[4] <= 1 << 20 && in[4] == floor(in[4]) && in[5] >= 1 && in[5] <= 1 << 20 && in[5] == floor(in[5]))) {
      st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: w and h must be positive integers", what);
      break;
    }
    if (!mgs_camera_focal_valid(in[0], (int)in[4]) || !mgs_camera_focal_valid(in[1], (int)in[5])) {
      st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: focal lengths %g, %g px for a %gx%g image (a field of view near 0 or 180 degrees)", what, in[0], in[1], in[4], in[5]);
      break;
    }
    const char *fp = NULL;
    if ((st = mgs_json_string(fr, "file_path", what, &fp, err)) != MGS_OK) break;
    if ((st = mgs_json_matrix4(fr, "transform_matrix", what, m, err)) != MGS_OK) break;
    int split = listed_split(j, fp);
    if (split == -2) continue; /* listed splits that leave this frame out */
    if (split >= 0) use_lists = 1;
    mgs_pending_view *v = &pv[npv++];
    v->name = mgs_strdup(fp);
    if (other_folder) { /* nerfstudio's downscale folders: the file's name under images_N */
      const char *base = strrchr(fp, '/');
      char rel[4200];
      snprintf(rel, sizeof rel, "%s/%s", o->images, base ? base + 1 : fp);
      v->image_path = o->images[0] == '/' ? mgs_strdup(rel) : mgs_path_join(d->root, rel);
    } else {
      v->image_path = fp[0] == '/' ? mgs_strdup(fp) : mgs_path_join(d->root, fp);
    }
    v->width = (int)in[4];
    v->height = (int)in[5];
    if (!v->name || !v->image_path) { st = mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", path); break; }
    double sx = 1, sy = 1;
    if (other_folder && (st = mgs_pending_scale_to_image(v, &sx, &sy, err)) != MGS_OK) break;
    mgs_camera_init(&v->cam, v->width, v->height, in[0] * sx, in[1] * sy, in[2] * sx, in[3] * sy);
    mgs_camera_set_c2w_opengl(&v->cam, m);
    v->split = split;
  }
  if (st == MGS_OK && use_lists) {
    for (size_t i = 0; i < npv && st == MGS_OK; i++) {
      int split = pv[i].split >= 0 ? pv[i].split : MGS_SPLIT_TRAIN;
      const char *b = strrchr(pv[i].name, '/');
      char stem[512];
      snprintf(stem, sizeof stem, "%s", b ? b + 1 : pv[i].name);
      char *dot = strrchr(stem, '.');
      if (dot && dot != stem) *dot = 0;
      st = mgs_dataset_add_view(d, (mgs_split)split, stem, pv[i].image_path, &pv[i].cam, pv[i].width, pv[i].height, err);
    }
    mgs_pending_free(pv, npv);
  } else if (st == MGS_OK) {
    st = mgs_dataset_split_every(d, pv, npv, o->test_every, err);
  } else {
    mgs_pending_free(pv, npv);
  }
  if (st == MGS_OK) {
    const cJSON *ply = cJSON_GetObjectItemCaseSensitive(j, "ply_file_path");
    if (ply) {
      if (!cJSON_IsString(ply) || !ply->valuestring || !ply->valuestring[0]) {
        st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: ply_file_path must be a non-empty string", path);
      } else {
        char *pp = ply->valuestring[0] == '/' ? mgs_strdup(ply->valuestring) : mgs_path_join(d->root, ply->valuestring);
        st = pp ? mgs_ply_read_points(pp, &d->init_points, err) : mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", d->root);
        free(pp);
      }
    }
  }
  if (st == MGS_OK) {
    char *mesh = mgs_path_join(d->root, "gt_mesh.ply");
    if (mesh && mgs_file_exists(mesh)) d->mesh_path = mesh;
    else free(mesh);
  }
  cJSON_Delete(j);
  free(path);
  return st;
}

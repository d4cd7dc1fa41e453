/* NeRF-synthetic (Blender) datasets: transforms_{train,val,test}.json with camera_angle_x
 * and frames {file_path (no extension -> .png), transform_matrix (OpenGL c2w)}. The
 * image size comes from the image files (or optional "w"/"h", checked against them). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/dataset_internal.h"
#include "core/mgs_fs.h"

/* "./train/r_0" -> "r_0"; the stem without directories or extension. */
static void stem_of(const char *p, char *out, size_t n) {
  const char *s = strrchr(p, '/');
  s = s ? s + 1 : p;
  snprintf(out, n, "%s", s);
  char *dot = strrchr(out, '.');
  if (dot && dot != out) *dot = 0;
}

static int has_image_ext(const char *p) {
  const char *s = strrchr(p, '/');
  s = s ? s + 1 : p;
  const char *dot = strrchr(s, '.');
  if (!dot) return 0;
  static const char *exts[] = {".png", ".jpg", ".jpeg", ".exr", ".PNG", ".JPG", ".JPEG", ".EXR"};
  for (size_t i = 0; i < sizeof exts / sizeof exts[0]; i++)
    if (strcmp(dot, exts[i]) == 0) return 1;
  return 0;
}

static mgs_status load_split(mgs_dataset *d, mgs_split split, const char *json_name, mgs_error *err) {
  char *path = mgs_path_join(d->root, json_name);
  if (!path) return mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", d->root);
  cJSON *j = NULL;
  mgs_status st = mgs_json_parse_file(path, &j, err);
  if (st != MGS_OK) { free(path); return st; }
  double fovx = 0, jw = 0, jh = 0;
  int has_w = 0, has_h = 0;
  st = mgs_json_number(j, "camera_angle_x", path, &fovx, err);
  if (st == MGS_OK && !(fovx > 0 && fovx < 3.14159))
    st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: camera_angle_x %g is not in (0, pi)", path, fovx);
  if (st == MGS_OK) has_w = mgs_json_opt_number(j, "w", path, &jw, &st, err);
  if (st == MGS_OK) has_h = mgs_json_opt_number(j, "h", path, &jh, &st, err);
  const cJSON *frames = cJSON_GetObjectItemCaseSensitive(j, "frames");
  if (st == MGS_OK && !frames) st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: missing field 'frames'", path);
  if (st == MGS_OK && !cJSON_IsArray(frames)) st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: field 'frames' must be an array", path);
  int fi = 0;
  const cJSON *fr;
  cJSON_ArrayForEach(fr, frames) {
    if (st != MGS_OK) break;
    char what[4400];
    snprintf(what, sizeof what, "%s: frame %d", path, fi);
    if (!cJSON_IsObject(fr)) { st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: not an object", what); break; }
    const char *fp = NULL;
    double m[16];
    if ((st = mgs_json_string(fr, "file_path", what, &fp, err)) != MGS_OK) break;
    if ((st = mgs_json_matrix4(fr, "transform_matrix", what, m, err)) != MGS_OK) break;
    char rel[4096];
    snprintf(rel, sizeof rel, "%s%s", fp, has_image_ext(fp) ? "" : ".png");
    char *img = rel[0] == '/' ? mgs_strdup(rel) : mgs_path_join(d->root, rel);
    if (!img) { st = mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", d->root); break; }
    int w = 0, h = 0, c = 0;
    st = mgs_image_read_size(img, &w, &h, &c, err);
    if (st == MGS_OK && ((has_w && (double)w != jw) || (has_h && (double)h != jh)))
      st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: image is %dx%d but %s says w=%g h=%g", img, w, h, path, jw, jh);
    if (st == MGS_OK) {
      mgs_camera cam;
      mgs_camera_init_fovx(&cam, w, h, fovx);
      mgs_camera_set_c2w_opengl(&cam, m);
      char name[256];
      stem_of(fp, name, sizeof name);
      st = mgs_dataset_add_view(d, split, name, img, &cam, w, h, err);
    }
    free(img);
    fi++;
  }
  cJSON_Delete(j);
  free(path);
  return st;
}

mgs_status mgs_dataset_load_nerf_synthetic(mgs_dataset *d, const mgs_dataset_options *o, mgs_error *err) {
  (void)o;
  static const char *files[MGS_SPLIT_COUNT] = {"transforms_train.json", "transforms_val.json", "transforms_test.json"};
  for (int s = 0; s < MGS_SPLIT_COUNT; s++) {
    char *p = mgs_path_join(d->root, files[s]);
    int exists = p && mgs_file_exists(p);
    free(p);
    if (!exists) {
      if (s == MGS_SPLIT_TRAIN) return mgs_error_set(err, MGS_ERR_IO, "%s: transforms_train.json not found", d->root);
      continue; /* val / test are optional */
    }
    mgs_status st = load_split(d, (mgs_split)s, files[s], err);
    if (st != MGS_OK) return st;
  }
  if (d->n_views[MGS_SPLIT_TRAIN] == 0)
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s/transforms_train.json: no frames", d->root);
  char *pts = mgs_path_join(d->root, "points3d.ply");
  if (pts && mgs_file_exists(pts)) {
    mgs_status st = mgs_ply_read_points(pts, &d->init_points, err);
    if (st != MGS_OK) { free(pts); return st; }
  }
  free(pts);
  char *mesh = mgs_path_join(d->root, "gt_mesh.ply");
  if (mesh && mgs_file_exists(mesh)) d->mesh_path = mesh;
  else free(mesh);
  return MGS_OK;
}

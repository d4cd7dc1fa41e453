/* RUN/cameras.json of the reference 3DGS layout (its camera_to_JSON): a list of
 * {id, img_name, width, height, position, rotation, fx, fy}, position and rotation the
 * camera-to-world translation and rotation rows in the OpenCV convention, the principal
 * point at the image centre. Read so that a run folder of any trainer writing this layout
 * (the Inria code's included) can be rendered from its own cameras. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <cjson/cJSON.h>
#include "core/mgs_camera.h"
#include "core/mgs_fs.h"

static int num(const cJSON *o, const char *k, double *v) {
  const cJSON *x = cJSON_GetObjectItemCaseSensitive(o, k);
  if (!cJSON_IsNumber(x) || !isfinite(x->valuedouble)) return 0;
  *v = x->valuedouble;
  return 1;
}

static int vec3(const cJSON *a, double v[3]) {
  if (!cJSON_IsArray(a) || cJSON_GetArraySize(a) != 3) return 0;
  for (int i = 0; i < 3; i++) {
    const cJSON *x = cJSON_GetArrayItem(a, i);
    if (!cJSON_IsNumber(x) || !isfinite(x->valuedouble)) return 0;
    v[i] = x->valuedouble;
  }
  return 1;
}

mgs_status mgs_cameras_read_json(const char *path, mgs_camera **out, char ***names, size_t *n_out, mgs_error *err) {
  *out = NULL;
  if (names) *names = NULL;
  *n_out = 0;
  char *text = NULL;
  size_t size = 0;
  mgs_status st = mgs_read_file(path, &text, &size, err);
  if (st != MGS_OK) return st;
  cJSON *root = cJSON_ParseWithLength(text, size);
  free(text);
  if (!cJSON_IsArray(root)) {
    cJSON_Delete(root);
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: not a JSON list of cameras", path);
  }
  size_t n = (size_t)cJSON_GetArraySize(root);
  if (n == 0) {
    cJSON_Delete(root);
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: no cameras", path);
  }
  mgs_camera *cams = calloc(n, sizeof *cams);
  if (!cams) {
    cJSON_Delete(root);
    return mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", path);
  }
  size_t k = 0;
  for (const cJSON *c = root->child; c; c = c->next, k++) {
    double w, h, fx, fy, pos[3], rot[9];
    const cJSON *r = cJSON_GetObjectItemCaseSensitive(c, "rotation");
    int ok = num(c, "width", &w) && num(c, "height", &h) && num(c, "fx", &fx) && num(c, "fy", &fy) &&
             vec3(cJSON_GetObjectItemCaseSensitive(c, "position"), pos) && cJSON_IsArray(r) && cJSON_GetArraySize(r) == 3;
    for (int i = 0; ok && i < 3; i++) ok = vec3(cJSON_GetArrayItem(r, i), rot + 3 * i);
    if (!ok || w < 1 || h < 1 || w > 32768 || h > 32768 || w != floor(w) || h != floor(h) ||
        !mgs_camera_focal_valid(fx, (int)w) || !mgs_camera_focal_valid(fy, (int)h)) {
      free(cams);
      cJSON_Delete(root);
      return mgs_error_set(err, MGS_ERR_FORMAT,
                           "%s: camera %zu: needs width, height (integers 1..32768), fx, fy (valid focal lengths), "
                           "position [3] and rotation [3][3]", path, k);
    }
    /* a rotation: rows orthonormal to 1e-3 (files store ~7 digits) */
    for (int i = 0; i < 3 && ok; i++)
      for (int j = 0; j < 3; j++) {
        double d = rot[3 * i] * rot[3 * j] + rot[3 * i + 1] * rot[3 * j + 1] + rot[3 * i + 2] * rot[3 * j + 2];
        if (fabs(d - (i == j)) > 1e-3) ok = 0;
      }
    if (!ok) {
      free(cams);
      cJSON_Delete(root);
      return mgs_error_set(err, MGS_ERR_FORMAT, "%s: camera %zu: rotation is not orthonormal", path, k);
    }
    mgs_camera_init(&cams[k], (int)w, (int)h, fx, fy, w / 2, h / 2);
    double c2w[16] = {rot[0], rot[1], rot[2], pos[0], rot[3], rot[4], rot[5], pos[1],
                      rot[6], rot[7], rot[8], pos[2], 0, 0, 0, 1};
    mgs_camera_set_c2w_opencv(&cams[k], c2w);
  }
  if (names && (*names = calloc(n, sizeof(char *)))) {
    k = 0;
    for (const cJSON *c = root->child; c; c = c->next, k++) {
      const cJSON *nm = cJSON_GetObjectItemCaseSensitive(c, "img_name");
      (*names)[k] = mgs_strdup(cJSON_IsString(nm) ? nm->valuestring : "");
    }
  }
  cJSON_Delete(root);
  *out = cams;
  *n_out = n;
  return MGS_OK;
}

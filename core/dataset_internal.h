/* Internal to core/: what the dataset loaders share (view lists, JSON field access).
 * Not a public header: other modules use mgs_dataset.h. */
#ifndef MGS_DATASET_INTERNAL_H
#define MGS_DATASET_INTERNAL_H
#include <cjson/cJSON.h>
#include <string.h>

#include "core/mgs_dataset.h"

/* Appends a view (copies name and image_path) to a split. */
mgs_status mgs_dataset_add_view(mgs_dataset *d, mgs_split split, const char *name, const char *image_path,
                                const mgs_camera *cam, int full_width, int full_height, mgs_error *err);

/* A view not yet assigned to a split (formats without splits). Strings are owned. */
typedef struct mgs_pending_view {
  char *name, *image_path;
  mgs_camera cam;
  int width, height;
  int split; /* a split the file itself names, or -1 */
} mgs_pending_view;
/* Sorts by name and adds every test_every-th view (index % test_every == 0) to the test
 * split, the rest to train, as the reference's llffhold does (test_every 0: all train;
 * a single view always trains). Frees the pending strings. */
mgs_status mgs_dataset_split_every(mgs_dataset *d, mgs_pending_view *pv, size_t n, int test_every, mgs_error *err);
void mgs_pending_free(mgs_pending_view *pv, size_t n);
/* An image folder other than images/ (options.images: Mip-NeRF 360's images_2/4/8,
 * nerfstudio's images_N) holds the views at their own size while the cameras keep the
 * full one: reads the image's header, sets v's size to it and *sx, *sy to the intrinsics'
 * scale (1 if equal); another aspect ratio (beyond a pixel) is an error naming the file. */
static inline int mgs_dataset_other_image_folder(const mgs_dataset_options *o) {
  return o->images && *o->images && strcmp(o->images, "images") != 0;
}
mgs_status mgs_pending_scale_to_image(mgs_pending_view *v, double *sx, double *sy, mgs_error *err);

/* Per-format loaders: fill d (root, options already set) or fail naming the file. */
mgs_status mgs_dataset_load_nerf_synthetic(mgs_dataset *d, const mgs_dataset_options *o, mgs_error *err);
mgs_status mgs_dataset_load_nerfstudio(mgs_dataset *d, const mgs_dataset_options *o, mgs_error *err);
mgs_status mgs_dataset_load_colmap(mgs_dataset *d, const mgs_dataset_options *o, mgs_error *err);

/* JSON helpers; `what` names the file (and frame) in messages. */
mgs_status mgs_json_parse_file(const char *path, cJSON **out, mgs_error *err);
/* A finite number field; missing -> MGS_ERR_FORMAT "what: missing field 'key'". */
mgs_status mgs_json_number(const cJSON *obj, const char *key, const char *what, double *v, mgs_error *err);
/* 1 if present (and a number, else an error through *st), 0 if absent. */
int mgs_json_opt_number(const cJSON *obj, const char *key, const char *what, double *v, mgs_status *st, mgs_error *err);
mgs_status mgs_json_string(const cJSON *obj, const char *key, const char *what, const char **v, mgs_error *err);
mgs_status mgs_json_matrix4(const cJSON *obj, const char *key, const char *what, double m[16], mgs_error *err);

/* Sort helper: 1 if path names an existing regular file. */
int mgs_file_exists(const char *path);
#endif

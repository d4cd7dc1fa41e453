/* A COLMAP dataset in a scratch directory whose three model files are valid, except
 * the one the fuzz input replaces: the first input byte picks cameras / images /
 * points3D (mod 3), the rest is that file's content. */
#ifndef MGS_FUZZ_COLMAP_COMMON_H
#define MGS_FUZZ_COLMAP_COMMON_H
#include "core/mgs_dataset.h"
#include "fuzz_util.h"

static inline void fuzz_colmap_run(const uint8_t *data, size_t size, const char *ext, const uint8_t *const valid[3],
                                   const size_t valid_size[3]) {
  static const char *names[3] = {"cameras", "images", "points3D"};
  static int ready;
  char rel[64];
  if (!ready) {
    char *d = fuzz_path("sparse/0"), *im = fuzz_path("images");
    mgs_mkdir_p(d, NULL);
    mgs_mkdir_p(im, NULL);
    free(d);
    free(im);
    for (int i = 0; i < 2; i++) { /* the images named by the valid model (never opened) */
      snprintf(rel, sizeof rel, "images/a%d.png", i);
      char *p = fuzz_path(rel);
      fuzz_write(p, (const uint8_t *)"x", 1);
      free(p);
    }
    ready = 1;
  }
  int which = size ? data[0] % 3 : 0;
  for (int i = 0; i < 3; i++) {
    snprintf(rel, sizeof rel, "sparse/0/%s.%s", names[i], ext);
    char *p = fuzz_path(rel);
    if (i == which) fuzz_write(p, size ? data + 1 : data, size ? size - 1 : 0);
    else fuzz_write(p, valid[i], valid_size[i]);
    free(p);
  }
  mgs_dataset_options o;
  mgs_dataset_options_default(&o);
  mgs_dataset *ds = NULL;
  mgs_error err;
  if (mgs_dataset_load(fuzz_dir(), &o, &ds, &err) == MGS_OK) {
    if (!ds) abort();
    for (int s = 0; s < MGS_SPLIT_COUNT; s++)
      for (size_t i = 0; i < ds->n_views[s]; i++) {
        const mgs_camera *c = &ds->views[s][i].cam;
        if (!(c->fx > 0) || c->width < 1) abort();
      }
    mgs_dataset_destroy(ds);
  } else if (ds) {
    abort();
  }
}
#endif

/* libFuzzer target: bytes as transforms_train.json of a NeRF-synthetic dataset (with a
 * valid image train/r_0.png beside it), loaded through mgs_dataset_load; the second
 * half of the run feeds the same bytes as a nerfstudio transforms.json. */
#include "core/mgs_dataset.h"
#include "core/mgs_image.h"
#include "fuzz_util.h"

static void setup(const char *sub) {
  char rel[128];
  snprintf(rel, sizeof rel, "%s/train", sub);
  char *d = fuzz_path(rel);
  mgs_mkdir_p(d, NULL);
  free(d);
  snprintf(rel, sizeof rel, "%s/train/r_0.png", sub);
  char *p = fuzz_path(rel);
  mgs_image *img = mgs_image_create(4, 4, 4);
  mgs_error err;
  if (!img || mgs_image_write(p, img, &err) != MGS_OK) abort();
  mgs_image_destroy(img);
  free(p);
}

static void load(const char *sub) {
  char *dir = fuzz_path(sub);
  mgs_dataset_options o;
  mgs_dataset_options_default(&o);
  mgs_dataset *ds = NULL;
  mgs_error err;
  if (mgs_dataset_load(dir, &o, &ds, &err) == MGS_OK) {
    if (!ds) abort();
    mgs_dataset_destroy(ds);
  } else if (ds) {
    abort();
  }
  free(dir);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  static int ready;
  if (!ready) {
    setup("nerf");
    setup("ns");
    ready = 1;
  }
  char *p = fuzz_path("nerf/transforms_train.json");
  fuzz_write(p, data, size);
  free(p);
  load("nerf");
  p = fuzz_path("ns/transforms.json");
  fuzz_write(p, data, size);
  free(p);
  load("ns");
  return 0;
}

/* Internals of mgs_init_points_from_views (train/init_hull.c, train/init_warmup.c). */
#ifndef MGS_INIT_VIEWS_H
#define MGS_INIT_VIEWS_H
#include <stddef.h>
#include "core/mgs_dataset.h"
#include "train/mgs_init_levelset.h"

/* A train view's RGB and alpha, whether the dataset loaded them or not (then decoded into
   a private copy, freed by close). */
typedef struct mgs_view_images {
  const mgs_image *rgb, *alpha; /* alpha NULL: the file had none */
  mgs_view tmp;
  int owned;
} mgs_view_images;
mgs_status mgs_view_images_open(mgs_dataset *ds, mgs_view *v, mgs_view_images *vi, mgs_error *err);
void mgs_view_images_close(mgs_view_images *vi);

/* Without alpha: centres and colours of the Gaussians a short baseline warm-up from the
   random init made opaque. */
mgs_status mgs_warmup_points(mgs_dataset *ds, const mgs_view_points_options *o, float **xyz, float **rgb, size_t *n,
                             mgs_error *err);
#endif

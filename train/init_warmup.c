/* Surface points without silhouettes (train/init_views.h): the baseline trained briefly
 * from the reference's random init, without density control; its opaque Gaussians sit
 * where the images put matter, and their centres stand in for SfM points. */
#include <math.h>
#include <stdlib.h>
#include "core/mgs_log.h"
#include "train/init_views.h"
#include "train/mgs_train.h"

#define SH_C0 0.28209479177387814

mgs_status mgs_warmup_points(mgs_dataset *ds, const mgs_view_points_options *o, float **xyz_out, float **rgb_out,
                             size_t *n_out, mgs_error *err) {
  mgs_train_options to;
  mgs_train_options_default(&to);
  to.iterations = o->warmup_iterations > 0 ? o->warmup_iterations : 1;
  to.sh_degree = 0; /* positions and opacities are what is kept */
  to.seed = o->seed;
  to.progress = 0;
  to.checkpoint_every = 0;
  to.image_cache_mb = o->image_cache_mb;
  mgs_gaussians *g0 = NULL;
  mgs_trainer *t = NULL;
  mgs_status st = mgs_init_random_for_dataset(ds, o->warmup_points, 0, o->seed, &g0, err);
  if (!st) st = mgs_trainer_create(ds, &to, g0, NULL, &t, err); /* owns g0 from here */
  if (!st) st = mgs_trainer_run(t, err);
  if (st) {
    mgs_trainer_destroy(t);
    return st;
  }
  const mgs_gaussians *g = mgs_trainer_model(t);
  const float logit = (float)log(o->warmup_opacity / (1 - o->warmup_opacity));
  size_t m = 0;
  for (size_t i = 0; i < g->n; i++) m += g->opacity[i] >= logit;
  float *xyz = malloc((m ? m : 1) * 3 * sizeof *xyz), *rgb = malloc((m ? m : 1) * 3 * sizeof *rgb);
  if (!xyz || !rgb) {
    free(xyz), free(rgb);
    mgs_trainer_destroy(t);
    return mgs_error_set(err, MGS_ERR_NOMEM, "warm-up points: out of memory for %zu points", m);
  }
  size_t k = 0;
  for (size_t i = 0; i < g->n; i++) {
    if (!(g->opacity[i] >= logit)) continue;
    for (int a = 0; a < 3; a++) {
      xyz[3 * k + a] = g->mean[3 * i + a];
      const double c = SH_C0 * g->sh_dc[3 * i + a] + 0.5;
      rgb[3 * k + a] = (float)(c < 0 ? 0 : c > 1 ? 1 : c);
    }
    k++;
  }
  mgs_trainer_destroy(t);
  mgs_info("warm-up: %zu of %zu random Gaussians reached opacity %.2f after %d iterations", m, o->warmup_points,
           o->warmup_opacity, to.iterations);
  if (m < 16) {
    free(xyz), free(rgb);
    return mgs_error_set(err, MGS_ERR_NUMERIC,
                         "%s: no alpha in the images and the %d-iteration warm-up left %zu opaque Gaussians (16 needed)",
                         ds->root, to.iterations, m);
  }
  *xyz_out = xyz, *rgb_out = rgb, *n_out = m;
  return MGS_OK;
}

/* A trainer made from a config (train/mgs_config.h): the initial model, the density-control
 * strategy, the Morse analysis and the loss terms — every method is a choice among these
 * interfaces, never a special case of the trainer loop. */
#include <stdlib.h>
#include <string.h>
#include "train/mgs_config.h"
#include "train/mgs_init_levelset.h"
#include "train/mgs_gaussianpro.h"
#include "train/mgs_strategy.h"
#include "train/mgs_term.h"
#include "train/mgs_sugar.h"
#include "core/mgs_core.h"

/* The normal loss reads the Morse analysis' SDF when one runs (none before the first). */
static const mgs_vdb_grid *morse_sdf_source(void *user, int *iteration) {
  const mgs_morse_ctx *c = user;
  const mgs_morse_result *r = mgs_morse_ctx_result(c);
  *iteration = r ? r->iteration : -1;
  return r && r->iteration > 0 ? mgs_morse_ctx_sdf(c) : NULL;
}

/* LPVI over the dataset's points, or over the random init's when it has none. */
static mgs_status init_lpvi(const mgs_train_config *c, const mgs_dataset *ds, mgs_gaussians **out, mgs_error *err) {
  const float *xyz, *rgb;
  size_t n;
  float *tx = NULL, *tc = NULL;
  if (ds->init_points && ds->init_points->n > 0) {
    xyz = ds->init_points->xyz; rgb = ds->init_points->rgb; n = ds->init_points->n;
  } else {
    mgs_gaussians *r = NULL;
    mgs_status st = mgs_init_random_for_dataset(ds, (size_t)c->random_points, 0, c->seed, &r, err);
    if (st) return st;
    n = r->n;
    tx = malloc(3 * n * sizeof *tx);
    tc = malloc(3 * n * sizeof *tc);
    if (!tx || !tc) { free(tx); free(tc); mgs_gaussians_destroy(r); return mgs_error_set(err, MGS_ERR_NOMEM, "LPVI: out of memory"); }
    for (size_t i = 0; i < 3 * n; i++) { tx[i] = r->mean[i]; tc[i] = r->sh_dc[i] * MGS_SH_C0 + 0.5f; }
    mgs_gaussians_destroy(r);
    xyz = tx; rgb = tc;
    mgs_info("--init lpvi: the dataset has no initial points; LPVI over %zu random points", n);
  }
  mgs_lpvi_options lo;
  mgs_config_lpvi_options(c, &lo);
  lo.extent = ds->extent;
  float *ox = NULL, *oc = NULL;
  size_t on = 0;
  mgs_lpvi_stats s;
  mgs_status st = mgs_init_lpvi(xyz, rgb, n, &lo, &ox, &oc, &on, &s, err);
  free(tx); free(tc);
  if (st) return st;
  mgs_info("LPVI (%s): %zu points in, %zu neighbourhoods (%zu accepted in 3-D, %zu tangent), %zu points added, %zu out, %.2f s",
           lo.faithful ? "faithful" : "corrected", s.input, s.processed, s.accepted_3d, s.tangent_2d, s.added, on, s.seconds);
  st = mgs_init_from_points(ox, oc, on, c->sh_degree, out, err);
  free(ox); free(oc);
  return st;
}

static mgs_status init_levelset(const mgs_train_config *c, mgs_dataset *ds, mgs_gaussians **out, mgs_error *err) {
  mgs_view_points_options vo; /* no point file: surface points from the train views (train/init_hull.c) */
  mgs_view_points_options_default(&vo);
  vo.seed = c->seed;
  vo.image_cache_mb = (size_t)c->image_cache_mb;
  mgs_status st0 = mgs_init_dataset_points(ds, &vo, err);
  if (st0) return st0;
  mgs_levelset_options lo;
  mgs_levelset_options_default(&lo);
  lo.seed = c->seed;
  mgs_levelset_info li;
  mgs_status st = mgs_init_levelset(ds->init_points->xyz, ds->init_points->rgb, ds->init_points->n, c->sh_degree, &lo, out, &li, err);
  if (!st) mgs_info("level-set init: %zu Gaussians from %zu points (%zu far outliers left out; voxel %.4g, delta %.4g, %.2f s)",
                    (*out)->n, ds->init_points->n, li.outliers, li.voxel_size, li.delta, li.seconds);
  return st;
}

static mgs_status initial_model(const mgs_train_config *c, mgs_dataset *ds, int for_resume, mgs_gaussians **g0,
                                char *used, mgs_error *err) {
  snprintf(used, 16, "%s", mgs_config_enum_name(c, "init"));
  if (for_resume) { /* replaced by the checkpoint */
    size_t first;
    *g0 = mgs_gaussians_create(1, c->sh_degree);
    mgs_status st = *g0 ? mgs_gaussians_append(*g0, 1, &first, err) : mgs_error_set(err, MGS_ERR_NOMEM, "out of memory");
    if (st) { mgs_gaussians_destroy(*g0); *g0 = NULL; }
    return st;
  }
  switch (c->init) {
    case MGS_INIT_LPVI: return init_lpvi(c, ds, g0, err);
    case MGS_INIT_LEVELSET: return init_levelset(c, ds, g0, err);
    case MGS_INIT_SFM:
      if (ds->init_points && ds->init_points->n > 0)
        return mgs_init_from_points(ds->init_points->xyz, ds->init_points->rgb, ds->init_points->n, c->sh_degree, g0, err);
      mgs_info("%s: no initial points; random init with %d Gaussians", ds->root, c->random_points);
      /* fall through */
    default:
      snprintf(used, 16, "random");
      return mgs_init_random_for_dataset(ds, (size_t)c->random_points, c->sh_degree, c->seed, g0, err);
  }
}

mgs_status mgs_train_setup_create(const mgs_train_config *c, mgs_dataset *ds, const mgs_train_options *o,
                                  const char *run_dir, int for_resume, mgs_train_setup *out, mgs_error *err) {
  memset(out, 0, sizeof *out);
  mgs_gaussians *g0 = NULL;
  mgs_status st = initial_model(c, ds, for_resume, &g0, out->init_used, err);
  if (st) return st;
  if (c->model == MGS_MODEL_2DGS) mgs_init_to_surfels(g0, c->seed); /* a checkpoint keeps the kind set here */
  mgs_morse_options mo;
  int use_morse = mgs_config_morse_options(c, &mo);
  mgs_strategy *strat = NULL;
  if (use_morse) {
    if ((st = mgs_morse_ctx_create(&mo, ds, &out->morse, err))) goto fail;
    if (run_dir) {
      char *csv = mgs_path_join(run_dir, "morse_analysis.csv");
      if (!csv) { st = mgs_error_set(err, MGS_ERR_NOMEM, "out of memory"); goto fail; }
      mgs_morse_ctx_set_csv(out->morse, csv);
      free(csv);
    }
  }
  if (c->strategy == MGS_STRAT_ADC && !(strat = mgs_strategy_adc_create(&o->adc))) {
    st = mgs_error_set(err, MGS_ERR_NOMEM, "out of memory");
    goto fail;
  }
  if (c->strategy == MGS_STRAT_MORSE && (st = mgs_strategy_morse_create(&o->adc, out->morse, &strat, err))) goto fail;
  mgs_minisplat_options mso;
  if (mgs_config_minisplat_options(c, &mso)) {
    mso.adc = o->adc; /* the trainer's (scaled) ADC settings */
    if ((st = mgs_strategy_minisplat_create(&mso, &strat, err))) goto fail;
  }
  mgs_sugar_options so;
  int use_sugar = mgs_config_sugar_options(c, &so);
  if (use_sugar && (st = mgs_strategy_sugar_create(&o->adc, &so, &strat, err))) goto fail;
  mgs_gpro_options go;
  if (mgs_config_gpro_options(c, &go)) {
    if ((st = mgs_strategy_gaussianpro_create(&o->adc, &go, ds->views[MGS_SPLIT_TRAIN], ds->n_views[MGS_SPLIT_TRAIN],
                                              ds->extent, &strat, err)))
      goto fail;
  }
  st = mgs_trainer_create(ds, o, g0, strat, &out->trainer, err); /* owns g0 and strat from here */
  g0 = NULL;
  if (st) goto fail;
  if (c->strategy == MGS_STRAT_GAUSSIANPRO && (c->gpro_planar > 0 || c->gpro_planar_normal > 0 || c->gpro_planar_l1 > 0)) {
    mgs_term *pt = NULL;
    if ((st = mgs_term_planar_create(mgs_strategy_gaussianpro_pro(strat), c->gpro_planar, c->gpro_planar_normal, c->gpro_planar_l1, go.from,
                                     &pt, err)) ||
        (st = mgs_trainer_add_term(out->trainer, pt, err)))
      goto fail;
  }
  if (use_morse && mo.topo != MGS_MORSE_TOPO_NONE) {
    mgs_term *topo = NULL;
    if ((st = mgs_term_topo_create(out->morse, c->strategy != MGS_STRAT_MORSE, &topo, err))) goto fail;
    if ((st = mgs_trainer_add_term(out->trainer, topo, err))) goto fail;
  }
  mgs_persloss_options po;
  if (mgs_config_persloss_options(c, &po)) {
    mgs_term *pt = NULL;
    if ((st = mgs_term_persloss_create(&po, &pt, err)) || (st = mgs_trainer_add_term(out->trainer, pt, err))) goto fail;
  }
  mgs_2dgs_term_options to;
  if (mgs_config_2dgs_options(c, (int)ds->format, &to)) {
    mgs_term *tt = NULL;
    if ((st = mgs_term_2dgs_create(&to, &tt, err))) goto fail;
    if (tt && (st = mgs_trainer_add_term(out->trainer, tt, err))) goto fail;
  }
  if (use_sugar) {
    mgs_term *sg = NULL;
    if ((st = mgs_term_sugar_create(&so, &sg, err)) || (st = mgs_trainer_add_term(out->trainer, sg, err))) goto fail;
  }
  mgs_normal_options no;
  if (mgs_config_normal_options(c, &no)) {
    mgs_term *nt = NULL;
    mgs_normal_term *nh = NULL;
    if ((st = mgs_term_normal_create(&no, &nt, &nh, err)) || (st = mgs_trainer_add_term(out->trainer, nt, err))) goto fail;
    if (out->morse) mgs_term_normal_set_source(nh, morse_sdf_source, out->morse); /* ∇d of the last analysis */
  }
  return MGS_OK;
fail:
  mgs_gaussians_destroy(g0);
  mgs_train_setup_destroy(out);
  return st;
}

void mgs_train_setup_destroy(mgs_train_setup *s) {
  mgs_trainer_destroy(s->trainer);
  mgs_morse_ctx_unref(s->morse);
  s->trainer = NULL;
  s->morse = NULL;
}

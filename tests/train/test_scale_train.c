/* The large-scene paths of training: sparse Adam (only what the view saw is stepped;
 * fused with the backward or separate, the same), and a trainer with tile visibility
 * giving the same model as one projecting everything (through ADC densification,
 * pruning and opacity resets, which re-bin the tiles). */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "mgs_test.h"
#include "synth.h"
#include "train/mgs_train.h"
#include "train/mgs_strategy.h"
#include "core/mgs_image_cache.h"
#include "core/mgs_fs.h"
#include <unistd.h>
#include <time.h>

static double max_diff(const float *a, const float *b, size_t n) {
  double w = 0;
  for (size_t i = 0; i < n; i++) {
    double d = fabs((double)a[i] - (double)b[i]);
    if (!(d <= w)) w = d;
  }
  return w;
}

static void seed_adam(mgs_adam *a, size_t n) {
  mgs_rng r;
  mgs_rng_init(&r, 3, 9);
  for (int k = 0; k < MGS_PARAM_COUNT; k++) {
    size_t d = (size_t)mgs_param_dim((mgs_param_group)k);
    for (size_t i = 0; i < n * d; i++) {
      a->m[k][i] = (float)(1e-3 * mgs_rng_normal(&r));
      a->v[k][i] = (float)(1e-6 * mgs_rng_uniform(&r));
    }
    a->t[k] = 4;
    a->lr[k] = 1e-3f * (float)(k + 1);
  }
}

/* Sparse fused = sparse separate; visible rows = the dense step's; culled rows and their
 * moments untouched (the dense step moves them by momentum). */
static void test_sparse_adam(void) {
  const int W = 80, H = 64;
  const size_t n = 2000;
  mgs_camera cam;
  synth_camera(&cam, W, H, 1, 8, 0.2);
  mgs_gaussians *g0 = synth_model(n, 17);
  double c[3];
  mgs_camera_center(&cam, c);
  for (size_t i = 0; i < n; i += 7) /* behind the camera: culled */
    for (int k = 0; k < 3; k++) g0->mean[3 * i + k] = (float)(2.0 * c[k]);
  mgs_gaussians *gs = mgs_gaussians_clone(g0), *gf = mgs_gaussians_clone(g0), *gd = mgs_gaussians_clone(g0);
  mgs_gaussians *grad = mgs_gaussians_create(n, 3);
  size_t first;
  mgs_gaussians_append(grad, n, &first, NULL);
  mgs_adam *as = mgs_adam_create(n), *af = mgs_adam_create(n), *ad = mgs_adam_create(n), *a0 = mgs_adam_create(n);
  seed_adam(as, n); seed_adam(af, n); seed_adam(ad, n); seed_adam(a0, n);
  mgs_raster_settings rs;
  mgs_raster_settings_default(&rs);
  rs.sh_degree = 3;
  mgs_raster *rs_ = mgs_raster_create(), *rf = mgs_raster_create();
  size_t np = (size_t)W * H * 3;
  float *dl = malloc(np * sizeof(float)), *gm = malloc(n * sizeof(float));
  mgs_rng r;
  mgs_rng_init(&r, 1, 1);
  for (size_t i = 0; i < np; i++) dl[i] = (float)(mgs_rng_normal(&r) / (double)np);
  mgs_error err;
  mgs_raster_output os, of;
  CHECK_OK(mgs_raster_forward(rs_, gs, &cam, &rs, &os, &err), &err);
  CHECK_OK(mgs_raster_forward(rf, gf, &cam, &rs, &of, &err), &err);
  int *radii = malloc(n * sizeof(int));
  memcpy(radii, os.radii, n * sizeof(int));
  for (int k = 0; k < MGS_PARAM_COUNT; k++)
    memset(mgs_gaussians_group(grad, (mgs_param_group)k), 0, n * (size_t)mgs_param_dim((mgs_param_group)k) * sizeof(float));
  CHECK_OK(mgs_raster_backward(rs_, dl, NULL, NULL, grad, gm, &err), &err);
  mgs_gaussians *grad_copy = mgs_gaussians_clone(grad);
  CHECK_OK(mgs_adam_step_sparse(as, gs, grad, 0x3f, radii, 1, &err), &err);
  CHECK_OK(mgs_adam_step_backward_sparse(af, gf, rf, dl, NULL, NULL, gm, 0x3f, of.radii, &err), &err);
  CHECK_OK(mgs_adam_step(ad, gd, grad_copy, 0x3f, &err), &err);
  size_t culled = 0, visible = 0;
  int vis_same = 1, culled_same = 1, culled_moved_dense = 0, grad_zeroed = 1;
  for (size_t i = 0; i < n; i++) {
    int vis = radii[i] > 0;
    culled += !vis; visible += vis;
    for (int k = 0; k < MGS_PARAM_COUNT; k++) {
      mgs_param_group pg = (mgs_param_group)k;
      size_t d = (size_t)mgs_param_dim(pg);
      const float *ps = mgs_gaussians_group(gs, pg) + i * d, *pd = mgs_gaussians_group(gd, pg) + i * d;
      const float *p0 = mgs_gaussians_group(g0, pg) + i * d, *gr = mgs_gaussians_group(grad, pg) + i * d;
      for (size_t j = 0; j < d; j++) {
        if (vis) vis_same &= ps[j] == pd[j] && as->m[k][i * d + j] == ad->m[k][i * d + j];
        else {
          culled_same &= ps[j] == p0[j] && as->m[k][i * d + j] == a0->m[k][i * d + j] && as->v[k][i * d + j] == a0->v[k][i * d + j];
          culled_moved_dense |= pd[j] != p0[j];
        }
        grad_zeroed &= gr[j] == 0.0f;
      }
    }
  }
  CHECK(culled >= n / 7 && visible > n / 4);
  CHECK(vis_same);
  CHECK(culled_same);
  CHECK(culled_moved_dense); /* the difference from the reference is real */
  CHECK(grad_zeroed);
  for (int k = 0; k < MGS_PARAM_COUNT; k++) {
    mgs_param_group pg = (mgs_param_group)k;
    size_t len = n * (size_t)mgs_param_dim(pg);
    CHECK_MSG(max_diff(mgs_gaussians_group(gs, pg), mgs_gaussians_group(gf, pg), len) == 0 &&
              max_diff(as->m[k], af->m[k], len) == 0 && max_diff(as->v[k], af->v[k], len) == 0,
              "fused and separate sparse steps differ in %s", mgs_param_name(pg));
    CHECK(as->t[k] == 5 && af->t[k] == 5);
  }
  /* a non-finite gradient of a visible Gaussian is reported; radii are required */
  mgs_error_clear(&err);
  CHECK(mgs_adam_step_sparse(as, gs, grad, 0x3f, NULL, 0, &err) == MGS_ERR_ARG);
  size_t vi = 0;
  while (radii[vi] <= 0) vi++;
  grad->opacity[vi] = NAN;
  CHECK(mgs_adam_step_sparse(as, gs, grad, 0x3f, radii, 0, &err) == MGS_ERR_NUMERIC && strstr(err.msg, "opacity"));
  free(radii); free(dl); free(gm);
  mgs_raster_destroy(rs_); mgs_raster_destroy(rf);
  mgs_adam_destroy(as); mgs_adam_destroy(af); mgs_adam_destroy(ad); mgs_adam_destroy(a0);
  mgs_gaussians_destroy(g0); mgs_gaussians_destroy(gs); mgs_gaussians_destroy(gf); mgs_gaussians_destroy(gd);
  mgs_gaussians_destroy(grad); mgs_gaussians_destroy(grad_copy);
}

static mgs_trainer *make_trainer(mgs_dataset *ds, const mgs_train_options *o) {
  mgs_rng r;
  mgs_rng_init(&r, 8, 1);
  double lo[3] = {-3, -3, -3}, hi[3] = {3, 3, 3}; /* wider than the views: tiles get culled */
  mgs_gaussians *g = NULL;
  mgs_error err;
  if (mgs_init_random(1500, lo, hi, 3, &r, &g, &err) != MGS_OK) { fprintf(stderr, "%s\n", err.msg); exit(2); }
  mgs_trainer *t = NULL;
  if (mgs_trainer_create(ds, o, g, mgs_strategy_adc_create(&o->adc), &t, &err) != MGS_OK) {
    fprintf(stderr, "%s\n", err.msg);
    exit(2);
  }
  return t;
}

static void train_opts(mgs_train_options *o) {
  mgs_train_options_default(o);
  o->iterations = 60;
  o->sh_every = 10;
  o->adc.densify_from = 5;
  o->adc.densify_every = 10;
  o->adc.opacity_reset_every = 25;
  o->adc.densify_until = 45;
  o->seed = 3;
}

/* Culling changes nothing: the same model as projecting everything. */
static void test_trainer_visibility_identical(void) {
  mgs_gaussians *gt = synth_model(150, 42);
  mgs_dataset *ds = synth_dataset(gt, 6, 1, 48, 40);
  mgs_train_options o;
  train_opts(&o);
  mgs_trainer *a = make_trainer(ds, &o);
  o.visibility = 1;
  o.vis_tile = 0.5;
  o.vis_rebin_every = 7;
  mgs_trainer *b = make_trainer(ds, &o);
  mgs_error err;
  CHECK_OK(mgs_trainer_run(a, &err), &err);
  CHECK_OK(mgs_trainer_run(b, &err), &err);
  const mgs_gaussians *ma = mgs_trainer_model(a), *mb = mgs_trainer_model(b);
  CHECK_MSG(ma->n == mb->n && ma->n != 1500, "counts %zu vs %zu", ma->n, mb->n);
  if (ma->n == mb->n)
    for (int k = 0; k < MGS_PARAM_COUNT; k++) {
      mgs_param_group pg = (mgs_param_group)k;
      double d = max_diff(mgs_gaussians_group((mgs_gaussians *)ma, pg), mgs_gaussians_group((mgs_gaussians *)mb, pg),
                          ma->n * (size_t)mgs_param_dim(pg));
      CHECK_MSG(d == 0, "group %s differs by %g", mgs_param_name(pg), d);
    }
  CHECK(mgs_trainer_last_loss(a) == mgs_trainer_last_loss(b));
  double listed;
  size_t tiles;
  double ts;
  mgs_trainer_visibility_stats(b, &listed, &tiles, &ts);
  CHECK_MSG(tiles > 10 && ts == 0.5 && listed < 0.9 * (double)mb->n, "tiles %zu, listed %.0f of %zu", tiles, listed, mb->n);
  mgs_trainer_destroy(a); mgs_trainer_destroy(b);
  mgs_dataset_destroy(ds);
  mgs_gaussians_destroy(gt);
}

/* Sparse Adam in the trainer: trains (the loss falls) and never touches a Gaussian no
 * view sees. */
static void test_trainer_sparse(void) {
  mgs_gaussians *gt = synth_model(150, 42);
  mgs_dataset *ds = synth_dataset(gt, 6, 1, 48, 40);
  mgs_train_options o;
  train_opts(&o);
  o.adc.densify_until = 0; /* a fixed set, to follow each Gaussian */
  o.adc.opacity_reset_every = 0;
  o.visibility = 1;
  o.sparse_adam = 1;
  mgs_trainer *t = make_trainer(ds, &o);
  /* 300 Gaussians far out in all directions: most outside every view */
  mgs_gaussians *gm = mgs_trainer_model_mut(t);
  mgs_rng rr;
  mgs_rng_init(&rr, 4, 4);
  for (size_t i = 0; i < 300; i++) {
    double d[3] = {mgs_rng_normal(&rr), mgs_rng_normal(&rr), mgs_rng_normal(&rr)};
    double l = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    for (int k = 0; k < 3; k++) gm->mean[3 * i + k] = (float)(60.0 * d[k] / l);
  }
  mgs_gaussians *g0 = mgs_gaussians_clone(mgs_trainer_model(t));
  mgs_error err;
  CHECK_OK(mgs_trainer_step(t, &err), &err);
  double first = mgs_trainer_last_loss(t);
  CHECK_OK(mgs_trainer_run(t, &err), &err);
  CHECK(mgs_trainer_last_loss(t) < first);
  const mgs_gaussians *m = mgs_trainer_model(t);
  CHECK(m->n == g0->n);
  uint8_t *seen = calloc(g0->n, 1);
  mgs_raster *r = mgs_raster_create();
  mgs_raster_settings rs;
  mgs_raster_settings_default(&rs);
  size_t moved_unseen = 0, unseen = 0;
  /* what a view sees depends on the model, which moved: a Gaussian never seen in the
     initial and the final model, and far from every camera's view, must not move */
  for (int pass = 0; pass < 2; pass++)
    for (size_t v = 0; v < ds->n_views[MGS_SPLIT_TRAIN]; v++) {
      mgs_raster_output ro;
      CHECK_OK(mgs_raster_forward(r, pass ? m : g0, &ds->views[MGS_SPLIT_TRAIN][v].cam, &rs, &ro, &err), &err);
      for (size_t i = 0; i < g0->n; i++) seen[i] |= ro.radii[i] > 0;
    }
  for (size_t i = 0; i < g0->n; i++) {
    if (seen[i]) continue;
    unseen++;
    moved_unseen += memcmp(g0->mean + 3 * i, m->mean + 3 * i, 3 * sizeof(float)) != 0 || g0->opacity[i] != m->opacity[i];
  }
  CHECK_MSG(unseen > 20 && moved_unseen == 0, "%zu of %zu unseen Gaussians moved", moved_unseen, unseen);
  free(seen);
  mgs_raster_destroy(r);
  mgs_gaussians_destroy(g0);
  mgs_trainer_destroy(t);
  mgs_dataset_destroy(ds);
  mgs_gaussians_destroy(gt);
}

/* A NeRF-synthetic folder of the synthetic scene, loaded without images. */
static mgs_dataset *written_dataset(const char *dir, size_t n_views, int W, int H) {
  mgs_gaussians *gt = synth_model(150, 42);
  mgs_dataset *mem = synth_dataset(gt, n_views, 1, W, H);
  mgs_error err;
  mgs_remove_tree(dir, &err);
  if (!synth_write_nerf(mem, dir)) { fprintf(stderr, "cannot write %s\n", dir); exit(2); }
  mgs_dataset_destroy(mem);
  mgs_gaussians_destroy(gt);
  mgs_dataset_options o;
  mgs_dataset_options_default(&o);
  o.load_images = 0;
  o.white_background = 0;
  mgs_dataset *ds = NULL;
  if (mgs_dataset_load(dir, &o, &ds, &err) != MGS_OK) { fprintf(stderr, "%s\n", err.msg); exit(2); }
  return ds;
}

static size_t wait_decodes(mgs_image_cache *c, size_t at_least) {
  mgs_image_cache_stats st;
  for (int k = 0; k < 5000; k++) { /* up to 5 s on a loaded machine */
    mgs_image_cache_get_stats(c, &st);
    if (st.decodes >= at_least) break;
    usleep(1000);
  }
  return st.decodes;
}

/* The cache hands out the float images rounded to 8 bits, stays within its budget, hits
 * what the thread prefetched, and names a missing file. */
static void test_image_cache(void) {
  const int W = 40, H = 32;
  char dir[256];
  snprintf(dir, sizeof dir, "/tmp/mgs_test_cache_%d", (int)getpid());
  mgs_dataset *ds = written_dataset(dir, 6, W, H);
  mgs_dataset *ref = written_dataset(dir, 6, W, H); /* same files, float path */
  size_t img = (size_t)W * H * 3;
  mgs_image_cache *c = NULL;
  mgs_error err;
  CHECK_OK(mgs_image_cache_create(ds, MGS_SPLIT_TRAIN, 2 * img + img / 2, 1, &c, &err), &err);
  float *buf = malloc(img * sizeof(float));
  double worst = 0;
  size_t decodes = 0;
  for (int round = 0; round < 2; round++)
    for (uint32_t i = 0; i < 6; i++) {
      CHECK_OK(mgs_image_cache_get(c, i, buf, &err), &err);
      mgs_view *rv = &ref->views[MGS_SPLIT_TRAIN][i];
      CHECK_OK(mgs_dataset_load_image(ref, rv, &err), &err);
      for (size_t k = 0; k < img; k++) worst = fmax(worst, fabs(buf[k] - rv->image->data[k]));
      CHECK(ds->views[MGS_SPLIT_TRAIN][i].image == NULL); /* no float copy kept */
      uint32_t next = (i + 1) % 6;
      mgs_image_cache_stats now;
      mgs_image_cache_get_stats(c, &now);
      mgs_image_cache_prefetch(c, &next, 1); /* never resident here: 2.5 images, 6 in a cycle */
      decodes = wait_decodes(c, now.decodes + 1);
    }
  CHECK_MSG(worst <= 0.5 / 255.0 + 1e-6, "8-bit rounding error %g", worst);
  mgs_image_cache_stats st;
  mgs_image_cache_get_stats(c, &st);
  CHECK_MSG(st.peak_bytes <= st.budget_bytes && st.resident_bytes <= st.budget_bytes, "peak %zu of %zu", st.peak_bytes,
            st.budget_bytes);
  CHECK(decodes >= 12);
  CHECK_MSG(st.hits == 11 && st.hits + st.misses == 12, "hits %zu misses %zu", st.hits, st.misses);
  CHECK(st.evictions > 0);
  mgs_image_cache_destroy(c);
  /* a budget below one image, no thread: still works, one image at a time */
  CHECK_OK(mgs_image_cache_create(ds, MGS_SPLIT_TRAIN, 10, 0, &c, &err), &err);
  for (uint32_t i = 0; i < 6; i++) CHECK_OK(mgs_image_cache_get(c, i, buf, &err), &err);
  mgs_image_cache_get_stats(c, &st);
  CHECK(st.misses == 6 && st.peak_bytes == img);
  /* a missing file: the error names it, and the cache stays usable */
  char path[512];
  snprintf(path, sizeof path, "%s/train/r_3.png", dir);
  CHECK(remove(path) == 0);
  mgs_error_clear(&err);
  CHECK(mgs_image_cache_get(c, 3, buf, &err) != MGS_OK && strstr(err.msg, "r_3"));
  CHECK_OK(mgs_image_cache_get(c, 2, buf, &err), &err);
  mgs_image_cache_destroy(c);
  free(buf);
  mgs_dataset_destroy(ds);
  mgs_dataset_destroy(ref);
  mgs_remove_tree(dir, &err);
}

/* Training through the cache: runs, and ends near the float-image run (the only
 * difference is the 8-bit rounding of the targets). */
static void test_trainer_image_cache(void) {
  char dir[256];
  snprintf(dir, sizeof dir, "/tmp/mgs_test_cache_tr_%d", (int)getpid());
  mgs_dataset *ds = written_dataset(dir, 6, 48, 40);
  mgs_train_options o;
  train_opts(&o);
  o.iterations = 40;
  mgs_trainer *a = make_trainer(ds, &o); /* loads float images into ds */
  mgs_dataset *ds2 = written_dataset(dir, 6, 48, 40);
  o.image_cache_mb = 1;
  o.prefetch = 3;
  mgs_trainer *b = make_trainer(ds2, &o);
  mgs_error err;
  CHECK_OK(mgs_trainer_run(a, &err), &err);
  CHECK_OK(mgs_trainer_run(b, &err), &err);
  CHECK_NEAR(mgs_trainer_last_loss(a), mgs_trainer_last_loss(b), 0.02);
  size_t hits, misses, peak;
  mgs_trainer_image_cache_stats(b, &hits, &misses, &peak);
  CHECK(hits + misses == 40 && peak <= (1u << 20) && peak >= 48 * 40 * 3);
  for (size_t i = 0; i < 6; i++) CHECK(ds2->views[MGS_SPLIT_TRAIN][i].image == NULL);
  mgs_trainer_destroy(a); mgs_trainer_destroy(b);
  mgs_dataset_destroy(ds); mgs_dataset_destroy(ds2);
  mgs_remove_tree(dir, &err);
}

int main(void) {
  RUN(test_image_cache);
  RUN(test_trainer_image_cache);
  RUN(test_sparse_adam);
  RUN(test_trainer_visibility_identical);
  RUN(test_trainer_sparse);
  return mgs_test_finish();
}

/* Tile culling (render/mgs_visibility.h): a view that projects only the Gaussians of the
 * tiles its frustum can see renders exactly what projecting every Gaussian renders
 * (image, alpha, depth, radii, gradients), on scenes much larger than the view, with
 * Gaussians straddling the image border and the near plane, large and tiny scales, an
 * off-centre principal point, non-finite values, and after the Gaussians move (refit)
 * or change count (invalidate). */
#include "tests/mgs_test.h"
#include "tests/raster/raster_test_util.h"
#include "render/mgs_visibility.h"

static int same_output(const mgs_raster_output *a, const mgs_raster_output *b, size_t n) {
  size_t np = (size_t)a->width * a->height;
  if (a->n_visible != b->n_visible || a->n_intersections != b->n_intersections) {
    fprintf(stderr, "visible %zu vs %zu, intersections %zu vs %zu\n", a->n_visible, b->n_visible,
            a->n_intersections, b->n_intersections);
    return 0;
  }
  if (memcmp(a->color, b->color, np * 3 * sizeof(float)) || memcmp(a->alpha, b->alpha, np * sizeof(float)) ||
      memcmp(a->depth, b->depth, np * sizeof(float))) {
    fprintf(stderr, "images differ\n");
    return 0;
  }
  for (size_t i = 0; i < n; i++)
    if (a->radii[i] != b->radii[i]) {
      fprintf(stderr, "radius of %zu: %d vs %d\n", i, a->radii[i], b->radii[i]);
      return 0;
    }
  return 1;
}

/* Renders g from cam with and without culling; 1 when identical. Also reports the share
 * of Gaussians projected. */
static int compare_view(mgs_visibility *vis, const mgs_gaussians *g, const mgs_camera *cam, double *share) {
  mgs_error err;
  mgs_raster_settings rs;
  mgs_raster_settings_default(&rs);
  rs.sh_degree = 3;
  mgs_raster *ra = mgs_raster_create(), *rb = mgs_raster_create();
  mgs_raster_output oa, ob;
  const uint32_t *list;
  size_t nb;
  int ok = mgs_raster_forward(ra, g, cam, &rs, &oa, &err) == MGS_OK &&
           mgs_visibility_query(vis, g, cam, &rs, &list, &nb, &err) == MGS_OK &&
           mgs_raster_forward_list(rb, g, cam, &rs, list, nb, &ob, &err) == MGS_OK;
  if (!ok) fprintf(stderr, "%s\n", err.msg);
  ok = ok && same_output(&oa, &ob, g->n);
  if (share) *share = g->n ? (double)nb / (double)g->n : 0;
  /* gradients too (the backward walks the same binned lists) */
  if (ok) {
    size_t np = (size_t)cam->width * cam->height * 3;
    float *dl = malloc(np * sizeof(float));
    mgs_rng rng;
    mgs_rng_init(&rng, 5, 5);
    for (size_t i = 0; i < np; i++) dl[i] = (float)mgs_rng_normal(&rng);
    mgs_gaussians *ga = mgs_gaussians_create(g->n, 3), *gb = mgs_gaussians_create(g->n, 3);
    size_t first;
    mgs_gaussians_append(ga, g->n, &first, NULL);
    mgs_gaussians_append(gb, g->n, &first, NULL);
    for (int k = 0; k < MGS_PARAM_COUNT; k++) {
      size_t d = (size_t)mgs_param_dim((mgs_param_group)k) * g->n * sizeof(float);
      memset(mgs_gaussians_group(ga, (mgs_param_group)k), 0, d);
      memset(mgs_gaussians_group(gb, (mgs_param_group)k), 0, d);
    }
    ok = mgs_raster_backward(ra, dl, NULL, NULL, ga, NULL, &err) == MGS_OK &&
         mgs_raster_backward(rb, dl, NULL, NULL, gb, NULL, &err) == MGS_OK;
    for (int k = 0; k < MGS_PARAM_COUNT && ok; k++) {
      size_t d = (size_t)mgs_param_dim((mgs_param_group)k) * g->n * sizeof(float);
      if (memcmp(mgs_gaussians_group(ga, (mgs_param_group)k), mgs_gaussians_group(gb, (mgs_param_group)k), d)) {
        fprintf(stderr, "gradients of group %d differ\n", k);
        ok = 0;
      }
    }
    mgs_gaussians_destroy(ga);
    mgs_gaussians_destroy(gb);
    free(dl);
  }
  mgs_raster_destroy(ra);
  mgs_raster_destroy(rb);
  return ok;
}

/* A large scene, cameras inside it: most tiles are outside or behind each view. */
static void test_identical_inside_large_scene(void) {
  scene_opts so = {20000, 12.0, 0.01, 0.6, 0.5, 1.5, 0.2};
  mgs_gaussians *g = rt_random_scene(3, &so);
  mgs_visibility *vis = mgs_visibility_create(0);
  double worst_share = 0, sum = 0;
  int views = 0;
  for (uint64_t seed = 1; seed <= 12; seed++) {
    mgs_camera cam;
    double target[3] = {0.3 * (double)seed - 2.0, 1.0, -0.5};
    rt_camera(&cam, 96 + 8 * (int)(seed % 3), 80, 0.9, 2.5, target, seed);
    if (seed % 4 == 0) { cam.cx += 23.0; cam.cy -= 11.0; } /* off-centre principal point */
    double share;
    CHECK_MSG(compare_view(vis, g, &cam, &share), "view %d", (int)seed);
    sum += share; views++;
    if (share > worst_share) worst_share = share;
  }
  /* the culling must cull: cameras see a small part of a scene 10x their distance */
  CHECK_MSG(sum / views < 0.6, "mean share of Gaussians projected %.2f", sum / views);
  mgs_visibility_stats st;
  mgs_visibility_get_stats(vis, &st);
  CHECK(st.tiles > 10 && st.rebins == 1);
  mgs_visibility_destroy(vis);
  mgs_gaussians_destroy(g);
}

/* Tiny tiles, huge tiles, a fixed tile size, and Gaussians with huge scales far outside
 * the view whose footprint still reaches in. */
static void test_identical_tile_sizes_and_big_splats(void) {
  scene_opts so = {3000, 6.0, 0.002, 0.05, 0.0, 1.0, 0.1};
  mgs_gaussians *g = rt_random_scene(9, &so);
  /* a few enormous ones */
  for (size_t i = 0; i < g->n; i += 97) for (int k = 0; k < 3; k++) g->log_scale[3 * i + k] = (float)log(1.5 + 0.1 * k);
  double sizes[4] = {0, 0.05, 1.0, 100.0};
  for (int s = 0; s < 4; s++) {
    mgs_visibility *vis = mgs_visibility_create(sizes[s]);
    for (uint64_t seed = 20; seed < 26; seed++) {
      mgs_camera cam;
      double target[3] = {0, 0, 0};
      rt_camera(&cam, 64, 64, 1.2, 1.0 + 0.5 * (double)(seed % 3), target, seed);
      CHECK_MSG(compare_view(vis, g, &cam, NULL), "tile size %g, view %d", sizes[s], (int)seed);
    }
    mgs_visibility_destroy(vis);
  }
  mgs_gaussians_destroy(g);
}

/* Parameters move after binning: refit keeps the bounds covering them; the count
 * changes: the next query re-bins. Non-finite values land in the always-kept tile. */
static void test_refit_and_rebin(void) {
  scene_opts so = {4000, 8.0, 0.01, 0.3, 0.5, 1.0, 0.1};
  mgs_gaussians *g = rt_random_scene(11, &so);
  mgs_visibility *vis = mgs_visibility_create(0);
  mgs_rng rng;
  mgs_rng_init(&rng, 77, 1);
  mgs_camera cam;
  double target[3] = {1, 0, 0};
  rt_camera(&cam, 80, 64, 1.0, 2.0, target, 31);
  CHECK(compare_view(vis, g, &cam, NULL));
  mgs_raster_settings rs;
  mgs_raster_settings_default(&rs);
  rs.sh_degree = 3;
  for (int round = 0; round < 4; round++) {
    /* what a sparse step does: move the Gaussians the last view saw, far (across many
       tiles, into other views) and grow some of them */
    mgs_raster *r = mgs_raster_create();
    mgs_raster_output o;
    const uint32_t *list;
    size_t nb;
    mgs_error err;
    CHECK_OK(mgs_visibility_query(vis, g, &cam, &rs, &list, &nb, &err), &err);
    CHECK_OK(mgs_raster_forward_list(r, g, &cam, &rs, list, nb, &o, &err), &err);
    int *radii = malloc(g->n * sizeof(int));
    memcpy(radii, o.radii, g->n * sizeof(int));
    for (size_t i = 0; i < g->n; i++) {
      if (radii[i] <= 0) continue;
      for (int k = 0; k < 3; k++) g->mean[3 * i + k] += (float)(3.0 * mgs_rng_normal(&rng));
      if (i % 5 == 0) g->log_scale[3 * i] += 1.0f;
    }
    if (round == 2) g->mean[3 * 7] = NAN; /* caught: culled by the rasterizer either way */
    mgs_visibility_refit(vis, g, radii);
    free(radii);
    mgs_raster_destroy(r);
    rt_camera(&cam, 80, 64, 1.0, 2.0, target, 40 + (uint64_t)round);
    CHECK_MSG(compare_view(vis, g, &cam, NULL), "after sparse moves, round %d", round);
  }
  /* dense moves of everything, refit of all */
  for (size_t i = 0; i < g->n; i++) g->mean[3 * i + 2] += 0.7f;
  mgs_visibility_refit(vis, g, NULL);
  CHECK(compare_view(vis, g, &cam, NULL));
  /* count change: appended Gaussians are seen after the automatic re-bin */
  size_t first;
  CHECK_OK(mgs_gaussians_append(g, 33, &first, NULL), NULL);
  for (size_t i = first; i < g->n; i++) {
    for (int k = 0; k < 3; k++) {
      g->mean[3 * i + k] = g->mean[3 * (i - first) + k];
      g->log_scale[3 * i + k] = -2.0f;
      g->sh_dc[3 * i + k] = 0.5f;
    }
    g->opacity[i] = 2.0f;
  }
  mgs_visibility_stats st0, st1;
  mgs_visibility_get_stats(vis, &st0);
  CHECK(compare_view(vis, g, &cam, NULL));
  mgs_visibility_get_stats(vis, &st1);
  CHECK(st1.rebins == st0.rebins + 1);
  /* the same count but replaced contents: invalidate */
  for (size_t i = 0; i < g->n; i++) g->mean[3 * i] = -g->mean[3 * i];
  mgs_visibility_invalidate(vis);
  CHECK(compare_view(vis, g, &cam, NULL));
  mgs_visibility_destroy(vis);
  mgs_gaussians_destroy(g);
}

/* Fewer than one block, and an empty block list (nothing in view). */
static void test_small_and_empty(void) {
  scene_opts so = {5, 1.0, 0.05, 0.2, 1.0, 0.5, 0.1};
  mgs_gaussians *g = rt_random_scene(13, &so);
  mgs_visibility *vis = mgs_visibility_create(0);
  mgs_camera cam;
  double target[3] = {0, 0, 0};
  rt_camera(&cam, 32, 32, 1.0, 3.0, target, 3);
  CHECK(compare_view(vis, g, &cam, NULL));
  /* looking away: nothing listed, image = background */
  double eye[3] = {0, 0, 5}, away[3] = {0, 0, 10}, up[3] = {0, 1, 0};
  mgs_camera_look_at(&cam, eye, away, up);
  mgs_raster_settings rs;
  mgs_raster_settings_default(&rs);
  const uint32_t *list;
  size_t nb = 99;
  mgs_error err;
  CHECK_OK(mgs_visibility_query(vis, g, &cam, &rs, &list, &nb, &err), &err);
  CHECK(nb == 0);
  CHECK(compare_view(vis, g, &cam, NULL));
  mgs_visibility_destroy(vis);
  mgs_gaussians_destroy(g);
}

int main(void) {
  RUN(test_identical_inside_large_scene);
  RUN(test_identical_tile_sizes_and_big_splats);
  RUN(test_refit_and_rebin);
  RUN(test_small_and_empty);
  return mgs_test_finish();
}

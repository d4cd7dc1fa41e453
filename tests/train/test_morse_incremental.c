/* Incremental Morse analyses (--morse-incremental, issue 12 item 4): a sheet of Gaussians
 * (a ground with bumps, like a city block) analysed twice, a corner of it changed in
 * between. The second analysis copies the α leaves the change did not reach (most of them,
 * not all), the SDF band leaves away from the change and their critical cells, and its
 * diagram equals, pair for pair, a from-scratch analysis of the changed
 * model at the same voxel size. The voxel size is kept while the analysed box's diagonal
 * moves by under 10 % and re-derived past that. */
#include <math.h>
#include <stdio.h>
#include <string.h>
#include "mgs_test.h"
#include "core/mgs_core.h"
#include "train/mgs_morse.h"

static mgs_gaussians *sheet(void) {
  const int n = 30;
  mgs_gaussians *g = mgs_gaussians_create((size_t)(n * n), 0);
  size_t first = 0;
  mgs_error err;
  if (!g || mgs_gaussians_append(g, (size_t)(n * n), &first, &err)) return g;
  for (int i = 0; i < n; i++)
    for (int j = 0; j < n; j++) {
      size_t k = (size_t)(i * n + j);
      float x = (float)i * 0.05f, y = (float)j * 0.05f;
      /* bumps: a few tall Gaussians make handles and cavities for the diagram */
      float z = ((i % 7 == 3) && (j % 7 == 3)) ? 0.06f : 0.0f;
      g->mean[3 * k] = x; g->mean[3 * k + 1] = y; g->mean[3 * k + 2] = z;
      for (int a = 0; a < 3; a++) g->log_scale[3 * k + a] = logf(a == 2 ? 0.012f : 0.03f);
      g->rot[4 * k] = 1; g->rot[4 * k + 1] = g->rot[4 * k + 2] = g->rot[4 * k + 3] = 0;
      g->opacity[k] = mgs_logitf(0.3f + 0.5f * (float)((i * 7 + j * 3) % 11) / 10.0f);
    }
  return g;
}

static void options(mgs_morse_options *o) {
  mgs_morse_options_default(o);
  o->topo = MGS_MORSE_TOPO_ELIMINATE; /* needs the persistence */
  o->warmup = 1; o->every = 1; o->until = 1000;
  o->resolution = 160;
  o->incremental = 1;
}

/* a corner of the sheet changes: opacities and scales, means kept (the box stays) */
static void change_corner(mgs_gaussians *g) {
  for (int i = 0; i < 5; i++)
    for (int j = 0; j < 5; j++) {
      size_t k = (size_t)(i * 30 + j);
      g->opacity[k] = mgs_logitf(0.9f);
      g->log_scale[3 * k] += 0.2f;
    }
}

static int same_diagrams(const mgs_morse_result *a, const mgs_morse_result *b) {
  if (a->n != b->n) return 0;
  for (size_t k = 0; k < a->n; k++) {
    const mgs_pair *p = &a->pairs[k].p, *q = &b->pairs[k].p;
    if (p->dim != q->dim || memcmp(&p->birth, &q->birth, sizeof p->birth) || memcmp(&p->death, &q->death, sizeof p->death)) return 0;
  }
  return 1;
}

static void test_changed_corner(void) {
  mgs_gaussians *g = sheet();
  mgs_morse_options o;
  options(&o);
  mgs_morse_ctx *inc = NULL, *fresh = NULL;
  mgs_error err;
  CHECK_OK(mgs_morse_ctx_create(&o, NULL, &inc, &err), &err);
  CHECK_OK(mgs_morse_analyze(inc, g, 1, &err), &err);
  const mgs_morse_result *r = mgs_morse_ctx_result(inc);
  double h1 = r->voxel_size;
  CHECK(r->leaves > 50 && r->leaves_reused == 0);
  change_corner(g);
  CHECK_OK(mgs_morse_analyze(inc, g, 2, &err), &err);
  r = mgs_morse_ctx_result(inc);
  fprintf(stderr, "  second analysis: %zu of %zu alpha leaves, %zu of %zu SDF band leaves reused, %zu pairs\n", r->leaves_reused,
          r->leaves, r->sdf_leaves_reused, r->sdf_leaves, r->n);
  CHECK_MSG(r->sdf_leaves_reused > 0 && r->sdf_leaves_reused < r->sdf_leaves, "%zu of %zu SDF leaves reused", r->sdf_leaves_reused,
            r->sdf_leaves);
  CHECK_MSG(r->pers_leaves_reused > 0 && r->pers_leaves_reused < r->pers_leaves, "%zu of %zu persistence leaves reused",
            r->pers_leaves_reused, r->pers_leaves);
  CHECK_MSG(r->leaves_reused > r->leaves / 2 && r->leaves_reused < r->leaves, "%zu of %zu leaves reused", r->leaves_reused, r->leaves);
  CHECK(r->voxel_size == h1);
  CHECK(r->n > 10);
  /* from scratch on the changed model */
  CHECK_OK(mgs_morse_ctx_create(&o, NULL, &fresh, &err), &err);
  CHECK_OK(mgs_morse_analyze(fresh, g, 2, &err), &err);
  const mgs_morse_result *f = mgs_morse_ctx_result(fresh);
  CHECK(f->leaves_reused == 0 && f->voxel_size == h1);
  CHECK_MSG(same_diagrams(r, f), "incremental diagram (%zu pairs) differs from the from-scratch one (%zu pairs)", r->n, f->n);
  CHECK(r->betti0[0] == f->betti0[0] && r->betti0[1] == f->betti0[1] && r->betti0[2] == f->betti0[2]);
  mgs_morse_ctx_unref(inc);
  mgs_morse_ctx_unref(fresh);
  mgs_gaussians_destroy(g);
}

/* the lattice is kept through a 3 % growth of the box, re-derived after a 30 % one */
static void test_voxel_size_kept(void) {
  mgs_gaussians *g = sheet();
  mgs_morse_options o;
  options(&o);
  mgs_morse_ctx *c = NULL;
  mgs_error err;
  CHECK_OK(mgs_morse_ctx_create(&o, NULL, &c, &err), &err);
  CHECK_OK(mgs_morse_analyze(c, g, 1, &err), &err);
  double h1 = mgs_morse_ctx_result(c)->voxel_size, d1 = mgs_morse_ctx_result(c)->diagonal;
  for (size_t k = 0; k < 3 * g->n; k++) g->mean[k] *= 1.03f;
  CHECK_OK(mgs_morse_analyze(c, g, 2, &err), &err);
  CHECK(mgs_morse_ctx_result(c)->voxel_size == h1 && mgs_morse_ctx_result(c)->diagonal > d1);
  for (size_t k = 0; k < 3 * g->n; k++) g->mean[k] *= 1.3f;
  CHECK_OK(mgs_morse_analyze(c, g, 3, &err), &err);
  const mgs_morse_result *r = mgs_morse_ctx_result(c);
  CHECK_MSG(fabs(r->voxel_size - r->diagonal / o.resolution) < 1e-12 && r->voxel_size > 1.2 * h1, "voxel %g (was %g)", r->voxel_size, h1);
  mgs_morse_ctx_unref(c);
  mgs_gaussians_destroy(g);
}

int main(void) {
  RUN(test_changed_corner);
  RUN(test_voxel_size_kept);
  return mgs_test_finish();
}

/* 2DGS models in .ply files: written with two scale columns (as hbb1/2d-gaussian-
 * splatting writes them), read back bit for bit with the kind recognised from the column
 * count; a file with the authors' header written by hand reads as 2DGS; reading a model
 * of the other kind where one kind is required fails with a message naming the file. */
#include <stdint.h>
#include <unistd.h>

#include "core/mgs_gaussians.h"
#include "core/mgs_ply.h"
#include "core/mgs_rng.h"
#include "mgs_test.h"

static const char *dir;
static char path_buf[4096];
static const char *tmp_path(const char *name) {
  snprintf(path_buf, sizeof path_buf, "%s/%s", dir, name);
  return path_buf;
}

static mgs_gaussians *random_surfels(size_t n, int deg, uint64_t seed) {
  mgs_rng rng;
  mgs_rng_init(&rng, seed, 1);
  mgs_gaussians *g = mgs_gaussians_create(n, deg);
  size_t first;
  mgs_gaussians_append(g, n, &first, NULL);
  g->kind = MGS_MODEL_2DGS;
  for (size_t i = 0; i < n; i++) {
    for (int k = 0; k < 3; k++) {
      g->mean[3 * i + k] = (float)mgs_rng_normal(&rng);
      g->sh_dc[3 * i + k] = (float)mgs_rng_normal(&rng);
    }
    g->log_scale[3 * i] = (float)mgs_rng_normal(&rng);
    g->log_scale[3 * i + 1] = (float)mgs_rng_normal(&rng);
    g->log_scale[3 * i + 2] = MGS_SURFEL_LOG_SCALE2;
    for (int k = 0; k < 4; k++) g->rot[4 * i + k] = (float)mgs_rng_normal(&rng);
    g->opacity[i] = (float)mgs_rng_normal(&rng);
    for (int k = 0; k < MGS_SH_REST_MAX; k++)
      g->sh_rest[MGS_SH_REST_MAX * i + k] = k < 3 * ((deg + 1) * (deg + 1) - 1) ? (float)mgs_rng_normal(&rng) : 0.0f;
  }
  return g;
}

static int header_has(const char *path, const char *needle) {
  FILE *f = fopen(path, "rb");
  if (!f) return 0;
  char buf[8192];
  size_t n = fread(buf, 1, sizeof buf - 1, f);
  fclose(f);
  buf[n] = 0;
  char *end = strstr(buf, "end_header");
  if (end) *end = 0;
  return strstr(buf, needle) != NULL;
}

static void test_round_trip(void) {
  for (int deg = 0; deg <= 3; deg += 3) {
    mgs_gaussians *g = random_surfels(50, deg, 7 + (uint64_t)deg), *h = NULL;
    mgs_error err;
    const char *p = tmp_path("surfels.ply");
    CHECK_OK(mgs_ply_write_gaussians(p, g, &err), &err);
    CHECK(header_has(p, "property float scale_1\n"));
    CHECK(!header_has(p, "scale_2"));
    CHECK_OK(mgs_ply_read_gaussians(p, &h, &err), &err);
    if (!h) { mgs_gaussians_destroy(g); continue; }
    CHECK(h->kind == MGS_MODEL_2DGS && h->n == g->n && h->sh_degree == deg);
    size_t diff = 0;
    for (int grp = 0; grp < MGS_PARAM_COUNT; grp++) {
      int d = mgs_param_dim((mgs_param_group)grp);
      const float *a = mgs_gaussians_group(g, (mgs_param_group)grp), *b = mgs_gaussians_group(h, (mgs_param_group)grp);
      diff += memcmp(a, b, g->n * (size_t)d * sizeof(float)) != 0;
    }
    CHECK_MSG(diff == 0, "degree %d: %zu groups differ after the round trip", deg, diff);
    mgs_gaussians_destroy(h);
    /* the same model as 3DGS keeps its three columns */
    g->kind = MGS_MODEL_3DGS;
    CHECK_OK(mgs_ply_write_gaussians(p, g, &err), &err);
    CHECK(header_has(p, "scale_2"));
    CHECK_OK(mgs_ply_read_gaussians(p, &h, &err), &err);
    if (h) CHECK(h->kind == MGS_MODEL_3DGS);
    mgs_gaussians_destroy(h);
    mgs_gaussians_destroy(g);
  }
}

/* The authors' header (their construct_list_of_attributes: x y z nx ny nz f_dc f_rest
 * opacity scale_0 scale_1 rot_0..3), ascii, written by hand. */
static void test_authors_layout(void) {
  const char *p = tmp_path("authors.ply");
  FILE *f = fopen(p, "w");
  fputs("ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\n"
        "property float nx\nproperty float ny\nproperty float nz\nproperty float f_dc_0\nproperty float f_dc_1\n"
        "property float f_dc_2\nproperty float opacity\nproperty float scale_0\nproperty float scale_1\n"
        "property float rot_0\nproperty float rot_1\nproperty float rot_2\nproperty float rot_3\nend_header\n"
        "1 2 3 0 0 0 0.1 0.2 0.3 -2.2 -4 -5 1 0 0 0\n4 5 6 0 0 0 0.4 0.5 0.6 0.5 -3 -3.5 0 1 0 0\n", f);
  fclose(f);
  mgs_gaussians *g = NULL;
  mgs_error err;
  CHECK_OK(mgs_ply_read_gaussians(p, &g, &err), &err);
  if (g) {
    CHECK(g->kind == MGS_MODEL_2DGS && g->n == 2 && g->sh_degree == 0);
    CHECK(g->log_scale[0] == -4.0f && g->log_scale[1] == -5.0f && g->log_scale[2] == MGS_SURFEL_LOG_SCALE2);
    CHECK(g->log_scale[3] == -3.0f && g->log_scale[4] == -3.5f && g->mean[5] == 6.0f && g->opacity[0] == -2.2f);
  }
  mgs_gaussians_destroy(g);
}

static void test_kind_required(void) {
  mgs_gaussians *g = random_surfels(5, 1, 3), *h = NULL;
  mgs_error err;
  char p2[4096], p3[4096];
  snprintf(p2, sizeof p2, "%s", tmp_path("two.ply"));
  snprintf(p3, sizeof p3, "%s", tmp_path("three.ply"));
  CHECK_OK(mgs_ply_write_gaussians(p2, g, &err), &err);
  g->kind = MGS_MODEL_3DGS;
  CHECK_OK(mgs_ply_write_gaussians(p3, g, &err), &err);
  CHECK_OK(mgs_ply_read_gaussians_kind(p2, MGS_MODEL_2DGS, NULL, &h, &err), &err);
  mgs_gaussians_destroy(h);
  h = NULL;
  mgs_error_clear(&err);
  CHECK(mgs_ply_read_gaussians_kind(p2, MGS_MODEL_3DGS, NULL, &h, &err) == MGS_ERR_FORMAT && h == NULL);
  fprintf(stderr, "  %s\n", err.msg);
  CHECK(strstr(err.msg, p2) && strstr(err.msg, "2dgs") && strstr(err.msg, "expected a 3dgs"));
  mgs_error_clear(&err);
  CHECK(mgs_ply_read_gaussians_kind(p3, MGS_MODEL_2DGS, NULL, &h, &err) == MGS_ERR_FORMAT && h == NULL);
  fprintf(stderr, "  %s\n", err.msg);
  CHECK(strstr(err.msg, p3) && strstr(err.msg, "expected a 2dgs"));
  /* one scale column is neither */
  const char *p1 = tmp_path("one.ply");
  FILE *f = fopen(p1, "w");
  fputs("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
        "property float f_dc_0\nproperty float f_dc_1\nproperty float f_dc_2\nproperty float opacity\n"
        "property float scale_0\nproperty float rot_0\nproperty float rot_1\nproperty float rot_2\n"
        "property float rot_3\nend_header\n0 0 0 0 0 0 0 0 1 0 0 0\n", f);
  fclose(f);
  mgs_error_clear(&err);
  CHECK(mgs_ply_read_gaussians(p1, &h, &err) == MGS_ERR_FORMAT && h == NULL);
  CHECK(strstr(err.msg, "scale_1") != NULL);
  mgs_gaussians_destroy(g);
}

int main(void) {
  dir = mgs_test_tmpdir("io_ply_2dgs");
  RUN(test_round_trip);
  RUN(test_authors_layout);
  RUN(test_kind_required);
  return mgs_test_finish();
}

/* Adam's byte accounting (mgs_adam_bytes) against a count written out from the layout:
 * 59 floats a Gaussian (3 + 3 + 4 + 1 + 3 + 45), each step reading and writing the
 * parameter and two moments, the gradient read (and cleared) only from gradient arrays;
 * a partly active SH rest, a group subset and a sparse row count change it as stated.
 * And the bfloat16 SH-rest moments it counts: close to float Adam over many steps, and
 * unbiased where round-to-nearest would stall (v's 0.999 decay under zero gradients). */
#include <math.h>
#include <stdio.h>
#include "mgs_test.h"
#include "core/mgs_rng.h"
#include "train/mgs_train.h"

static void test_adam_bytes(void) {
  mgs_adam *a = mgs_adam_create(10);
  CHECK(a != NULL);
  double rd, wr;
  const unsigned all = (1u << MGS_PARAM_COUNT) - 1;
  mgs_adam_bytes(a, 10, all, 0, 0, &rd, &wr); /* fused: gradient in L1 */
  CHECK_NEAR(rd, 10 * 59 * 12, 0);
  CHECK_NEAR(wr, 10 * 59 * 12, 0);
  mgs_adam_bytes(a, 10, all, 1, 1, &rd, &wr); /* separate, gradients cleared */
  CHECK_NEAR(rd, 10 * 59 * 16, 0);
  CHECK_NEAR(wr, 10 * 59 * 16, 0);
  mgs_adam_bytes(a, 10, all, 1, 0, &rd, &wr);
  CHECK_NEAR(rd, 10 * 59 * 16, 0);
  CHECK_NEAR(wr, 10 * 59 * 12, 0);
  a->sh_rest_active = 3; /* SH degree 1: 9 of the 45 rest floats */
  mgs_adam_bytes(a, 4, all, 0, 0, &rd, &wr);
  CHECK_NEAR(rd, 4 * (14 + 9) * 12, 0);
  mgs_adam_bytes(a, 4, (1u << MGS_PARAM_MEAN) | (1u << MGS_PARAM_OPACITY), 0, 0, &rd, &wr);
  CHECK_NEAR(wr, 4 * 4 * 12, 0);
  a->sh_rest_active = 15;
  CHECK(mgs_adam_set_sh_rest_bf16(a, 1, NULL) == MGS_OK);
  mgs_adam_bytes(a, 10, all, 0, 0, &rd, &wr); /* 45 floats: 4-byte word for m and v */
  CHECK_NEAR(rd, 10 * (14 * 12 + 45 * 8), 0);
  CHECK_NEAR(wr, 10 * (14 * 12 + 45 * 8), 0);
  mgs_adam_destroy(a);
}

/* n Gaussians, float Adam (a) against bf16 SH-rest moments (b) on the same gradients. */
static void test_bf16_moments(void) {
  const size_t n = 64;
  mgs_adam *a = mgs_adam_create(n), *b = mgs_adam_create(n);
  mgs_gaussians *ga = mgs_gaussians_create(n, 3), *gb = mgs_gaussians_create(n, 3), *gr = mgs_gaussians_create(n, 3);
  size_t first;
  CHECK(mgs_gaussians_append(ga, n, &first, NULL) == MGS_OK && mgs_gaussians_append(gb, n, &first, NULL) == MGS_OK &&
        mgs_gaussians_append(gr, n, &first, NULL) == MGS_OK);
  CHECK(mgs_adam_set_sh_rest_bf16(b, 1, NULL) == MGS_OK);
  for (int k = 0; k < MGS_PARAM_COUNT; k++) a->lr[k] = b->lr[k] = 1e-3f;
  mgs_rng rng;
  mgs_rng_init(&rng, 5, 1);
  const unsigned rest = 1u << MGS_PARAM_SH_REST;
  mgs_error err;
  /* 300 steps of noisy gradients around a per-element mean: parameters agree closely */
  float mu[64 * 45];
  for (size_t i = 0; i < n * 45; i++) mu[i] = (float)(1e-3 * mgs_rng_normal(&rng));
  for (int step = 0; step < 300; step++) {
    for (size_t i = 0; i < n * 45; i++) gr->sh_rest[i] = mu[i] + (float)(3e-4 * mgs_rng_normal(&rng));
    CHECK_OK(mgs_adam_step(a, ga, gr, rest, &err), &err);
    CHECK_OK(mgs_adam_step(b, gb, gr, rest, &err), &err);
  }
  double maxd = 0, maxp = 0, sd = 0, sp = 0;
  for (size_t i = 0; i < n * 45; i++) {
    double d = fabs(ga->sh_rest[i] - gb->sh_rest[i]);
    maxd = fmax(maxd, d);
    maxp = fmax(maxp, fabs(ga->sh_rest[i]));
    sd += d; sp += fabs(ga->sh_rest[i]);
  }
  fprintf(stderr, "  300 steps: max |p| %.3g, max |p_float - p_bf16| %.3g, mean %.3g of mean |p| %.3g\n", maxp, maxd,
          sd / (double)(n * 45), sp / (double)(n * 45));
  /* each step moves |p| by up to lr: the moments' rounding (0.4 %) changes the steps by
     about that, at random */
  CHECK(maxp > 0.1 && maxd < 0.03 * maxp && sd < 0.005 * sp);
  /* 2000 zero-gradient steps: v decays by 0.999^2000 = 0.135 (on average over elements);
     rounding to nearest would keep it (a 0.1 % change is below half a bf16 ulp) */
  for (size_t i = 0; i < n * 45; i++) gr->sh_rest[i] = 0;
  double v0 = 0, v1 = 0;
  CHECK(mgs_adam_set_sh_rest_bf16(b, 0, NULL) == MGS_OK);
  for (size_t i = 0; i < n * 45; i++) v0 += b->v[MGS_PARAM_SH_REST][i];
  CHECK(mgs_adam_set_sh_rest_bf16(b, 1, NULL) == MGS_OK);
  for (int step = 0; step < 2000; step++) CHECK_OK(mgs_adam_step(b, gb, gr, rest, &err), &err);
  CHECK(mgs_adam_set_sh_rest_bf16(b, 0, NULL) == MGS_OK);
  for (size_t i = 0; i < n * 45; i++) v1 += b->v[MGS_PARAM_SH_REST][i];
  fprintf(stderr, "  v after 2000 zero-gradient steps: %.4f of before (0.999^2000 = %.4f)\n", v1 / v0, pow(0.999, 2000));
  CHECK(v0 > 0 && fabs(v1 / v0 / pow(0.999, 2000) - 1) < 0.02);
  mgs_adam_destroy(a); mgs_adam_destroy(b);
  mgs_gaussians_destroy(ga); mgs_gaussians_destroy(gb); mgs_gaussians_destroy(gr);
}

/* Packed, the SH-rest v array is gone (the memory the option saves), and the row
 * operations carry the packed words: append adds zero words, compact keeps the kept rows'
 * words in order, reset zeroes them; unpacking gives the moments back. */
static void test_bf16_frees_v(void) {
  mgs_adam *a = mgs_adam_create(4);
  mgs_error err;
  for (size_t i = 0; i < 4 * 45; i++) { a->m[MGS_PARAM_SH_REST][i] = (float)(i + 1); a->v[MGS_PARAM_SH_REST][i] = 0.5f * (float)(i + 1); }
  CHECK_OK(mgs_adam_set_sh_rest_bf16(a, 1, &err), &err);
  CHECK(a->v[MGS_PARAM_SH_REST] == NULL && a->v[MGS_PARAM_MEAN] != NULL);
  CHECK_OK(mgs_adam_append(a, 1000, &err), &err); /* grows past the capacity */
  CHECK(a->n == 1004 && a->v[MGS_PARAM_SH_REST] == NULL);
  const uint32_t *w = (const uint32_t *)(const void *)a->m[MGS_PARAM_SH_REST];
  CHECK(w[1003 * 45 + 44] == 0);
  uint8_t *keep = calloc(1004, 1);
  keep[1] = keep[3] = keep[1003] = 1;
  mgs_adam_compact(a, keep);
  free(keep);
  CHECK(a->n == 3);
  CHECK_OK(mgs_adam_set_sh_rest_bf16(a, 0, &err), &err);
  CHECK(a->v[MGS_PARAM_SH_REST] != NULL);
  /* row 1 and row 3 of the original, exactly (small integers are exact in bfloat16) */
  CHECK(a->m[MGS_PARAM_SH_REST][0] == 46.0f && a->v[MGS_PARAM_SH_REST][0] == 23.0f);
  CHECK(a->m[MGS_PARAM_SH_REST][45] == 136.0f && a->v[MGS_PARAM_SH_REST][45] == 68.0f);
  CHECK(a->m[MGS_PARAM_SH_REST][90] == 0.0f && a->v[MGS_PARAM_SH_REST][90] == 0.0f);
  CHECK_OK(mgs_adam_set_sh_rest_bf16(a, 1, &err), &err);
  mgs_adam_reset_group(a, MGS_PARAM_SH_REST);
  CHECK(w != NULL && ((const uint32_t *)(const void *)a->m[MGS_PARAM_SH_REST])[45] == 0);
  mgs_adam_destroy(a);
}

int main(void) {
  RUN(test_bf16_frees_v);
  RUN(test_adam_bytes);
  RUN(test_bf16_moments);
  return mgs_test_finish();
}

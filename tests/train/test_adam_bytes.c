/* Adam's byte accounting (mgs_adam_bytes) against a count written out from the layout:
 * 59 floats a Gaussian (3 + 3 + 4 + 1 + 3 + 45), each step reading and writing the
 * parameter and two moments, the gradient read (and cleared) only from gradient arrays;
 * a partly active SH rest, a group subset and a sparse row count change it as stated. */
#include "mgs_test.h"
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
  mgs_adam_destroy(a);
}

int main(void) {
  RUN(test_adam_bytes);
  return mgs_test_finish();
}

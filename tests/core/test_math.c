/* Quaternions, rigid inverses and the symmetric eigen-solver. */
#include "core/mgs_core.h"
#include "mgs_test.h"

static void test_quat_roundtrip(void) {
  mgs_rng r; mgs_rng_init(&r, 7, 0);
  for (int t = 0; t < 200; t++) {
    double q[4] = {mgs_rng_normal(&r), mgs_rng_normal(&r), mgs_rng_normal(&r), mgs_rng_normal(&r)}, R[9], q2[4];
    double n = sqrt(q[0]*q[0] + q[1]*q[1] + q[2]*q[2] + q[3]*q[3]);
    for (int k = 0; k < 4; k++) q[k] /= (q[0] < 0 ? -n : n);
    mgs_quat_to_mat3d(q, R);
    /* orthonormal with det +1 */
    double RtR[9], Rt[9];
    mgs_mat3_transpose(R, Rt);
    mgs_mat3_mul(Rt, R, RtR);
    for (int i = 0; i < 9; i++) CHECK_NEAR(RtR[i], i % 4 == 0 ? 1.0 : 0.0, 1e-12);
    mgs_mat3_to_quatd(R, q2);
    for (int k = 0; k < 4; k++) CHECK_NEAR(q2[k], q[k], 1e-9);
  }
  float qz[4] = {0, 0, 0, 0}, Rz[9];
  mgs_quat_to_mat3f(qz, Rz); /* zero quaternion: identity, not NaN */
  for (int i = 0; i < 9; i++) CHECK_NEAR(Rz[i], i % 4 == 0 ? 1.0 : 0.0, 0);
}

static void test_rigid_inverse(void) {
  double q[4] = {0.9, 0.1, -0.3, 0.2}, R[9];
  mgs_quat_to_mat3d(q, R);
  double M[16] = {R[0], R[1], R[2], 1e5, R[3], R[4], R[5], -3, R[6], R[7], R[8], 2, 0, 0, 0, 1}, Mi[16], I[16];
  mgs_mat4_rigid_inverse(M, Mi);
  mgs_mat4_mul(M, Mi, I);
  for (int i = 0; i < 16; i++) CHECK_NEAR(I[i], i % 5 == 0 ? 1.0 : 0.0, 1e-10);
}

static void test_eigen(void) {
  mgs_rng r; mgs_rng_init(&r, 3, 0);
  for (int t = 0; t < 100; t++) {
    double A[9];
    for (int i = 0; i < 3; i++) for (int j = i; j < 3; j++) A[3*i+j] = A[3*j+i] = mgs_rng_normal(&r);
    if (t == 0) { for (int i = 0; i < 9; i++) A[i] = 0; A[0] = 1e-12; A[4] = 5; A[8] = 1e6; } /* near singular */
    double w[3], V[9];
    mgs_sym3_eigen(A, w, V);
    CHECK(w[0] <= w[1] && w[1] <= w[2]);
    for (int c = 0; c < 3; c++) { /* A v = w v */
      double v[3] = {V[c], V[3+c], V[6+c]}, Av[3];
      mgs_mat3_mul_vec(A, v, Av);
      double scale = fabs(w[0]) + fabs(w[2]) + 1e-30;
      for (int k = 0; k < 3; k++) CHECK_NEAR(Av[k], w[c] * v[k], 1e-9 * scale);
    }
  }
}

int main(void) {
  RUN(test_quat_roundtrip);
  RUN(test_rigid_inverse);
  RUN(test_eigen);
  return mgs_test_finish();
}

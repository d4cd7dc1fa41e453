/* Small fixed-size linear algebra: vec3, mat3 (row-major), mat4 (row-major), quaternions
 * (w, x, y, z). Header-only so hot loops inline it. Double versions (suffix d) are for
 * cameras and geometry, where scenes far from the origin need the precision. */
#ifndef MGS_MATH_H
#define MGS_MATH_H
#include <math.h>

#ifdef __cplusplus
extern "C" {
#endif

#define MGS_PI 3.14159265358979323846

static inline double mgs_dot3d(const double a[3], const double b[3]) { return a[0]*b[0] + a[1]*b[1] + a[2]*b[2]; }
static inline float mgs_dot3f(const float a[3], const float b[3]) { return a[0]*b[0] + a[1]*b[1] + a[2]*b[2]; }
static inline void mgs_cross3d(const double a[3], const double b[3], double o[3]) {
  double x = a[1]*b[2] - a[2]*b[1], y = a[2]*b[0] - a[0]*b[2], z = a[0]*b[1] - a[1]*b[0];
  o[0] = x; o[1] = y; o[2] = z;
}
static inline double mgs_norm3d(const double a[3]) { return sqrt(mgs_dot3d(a, a)); }
static inline double mgs_normalize3d(double a[3]) {
  double n = mgs_norm3d(a);
  if (n > 0) { a[0] /= n; a[1] /= n; a[2] /= n; }
  return n;
}
static inline void mgs_sub3d(const double a[3], const double b[3], double o[3]) { o[0]=a[0]-b[0]; o[1]=a[1]-b[1]; o[2]=a[2]-b[2]; }

/* o = M v, M row-major 3x3 */
static inline void mgs_mat3_mul_vec(const double M[9], const double v[3], double o[3]) {
  double x = M[0]*v[0] + M[1]*v[1] + M[2]*v[2];
  double y = M[3]*v[0] + M[4]*v[1] + M[5]*v[2];
  double z = M[6]*v[0] + M[7]*v[1] + M[8]*v[2];
  o[0] = x; o[1] = y; o[2] = z;
}
/* o = A B (3x3 row-major); o may alias neither input */
static inline void mgs_mat3_mul(const double A[9], const double B[9], double o[9]) {
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++)
      o[3*i+j] = A[3*i]*B[j] + A[3*i+1]*B[3+j] + A[3*i+2]*B[6+j];
}
static inline void mgs_mat3_transpose(const double A[9], double o[9]) {
  for (int i = 0; i < 3; i++) for (int j = 0; j < 3; j++) o[3*j+i] = A[3*i+j];
}
/* o = A B (4x4 row-major); o may alias neither input */
static inline void mgs_mat4_mul(const double A[16], const double B[16], double o[16]) {
  for (int i = 0; i < 4; i++)
    for (int j = 0; j < 4; j++) {
      double s = 0; for (int k = 0; k < 4; k++) s += A[4*i+k]*B[4*k+j];
      o[4*i+j] = s;
    }
}
/* Inverse of a rigid (rotation + translation) 4x4 transform. */
static inline void mgs_mat4_rigid_inverse(const double M[16], double o[16]) {
  for (int i = 0; i < 3; i++) for (int j = 0; j < 3; j++) o[4*i+j] = M[4*j+i];
  for (int i = 0; i < 3; i++) o[4*i+3] = -(o[4*i]*M[3] + o[4*i+1]*M[7] + o[4*i+2]*M[11]);
  o[12] = o[13] = o[14] = 0; o[15] = 1;
}

/* Rotation matrix (row-major) of the normalized quaternion q = (w, x, y, z), as the
 * reference 3DGS build_rotation does. A zero quaternion gives the identity. */
static inline void mgs_quat_to_mat3f(const float q[4], float R[9]) {
  float n = sqrtf(q[0]*q[0] + q[1]*q[1] + q[2]*q[2] + q[3]*q[3]);
  float w = 1, x = 0, y = 0, z = 0;
  if (n > 0) { w = q[0]/n; x = q[1]/n; y = q[2]/n; z = q[3]/n; }
  R[0] = 1 - 2*(y*y + z*z); R[1] = 2*(x*y - w*z);     R[2] = 2*(x*z + w*y);
  R[3] = 2*(x*y + w*z);     R[4] = 1 - 2*(x*x + z*z); R[5] = 2*(y*z - w*x);
  R[6] = 2*(x*z - w*y);     R[7] = 2*(y*z + w*x);     R[8] = 1 - 2*(x*x + y*y);
}
static inline void mgs_quat_to_mat3d(const double q[4], double R[9]) {
  double n = sqrt(q[0]*q[0] + q[1]*q[1] + q[2]*q[2] + q[3]*q[3]);
  double w = 1, x = 0, y = 0, z = 0;
  if (n > 0) { w = q[0]/n; x = q[1]/n; y = q[2]/n; z = q[3]/n; }
  R[0] = 1 - 2*(y*y + z*z); R[1] = 2*(x*y - w*z);     R[2] = 2*(x*z + w*y);
  R[3] = 2*(x*y + w*z);     R[4] = 1 - 2*(x*x + z*z); R[5] = 2*(y*z - w*x);
  R[6] = 2*(x*z - w*y);     R[7] = 2*(y*z + w*x);     R[8] = 1 - 2*(x*x + y*y);
}
/* Quaternion (w, x, y, z) of a proper rotation matrix (row-major). */
void mgs_mat3_to_quatd(const double R[9], double q[4]);

static inline float mgs_sigmoidf(float x) { return 1.0f / (1.0f + expf(-x)); }
static inline float mgs_logitf(float p) { return logf(p / (1.0f - p)); }
static inline double mgs_clampd(double x, double lo, double hi) { return x < lo ? lo : (x > hi ? hi : x); }
static inline float mgs_clampf(float x, float lo, float hi) { return x < lo ? lo : (x > hi ? hi : x); }

/* Symmetric 3x3 eigen-decomposition (Jacobi): eigenvalues ascending in w, eigenvectors
 * as columns of V (row-major). */
void mgs_sym3_eigen(const double A[9], double w[3], double V[9]);

#ifdef __cplusplus
}
#endif
#endif

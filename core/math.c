/* Non-inline math: quaternion from a rotation matrix, symmetric 3x3 eigen-decomposition. */
#include <math.h>
#include <string.h>
#include "core/mgs_math.h"

void mgs_mat3_to_quatd(const double R[9], double q[4]) {
  /* Shepperd's method: pick the largest diagonal term for stability. */
  double tr = R[0] + R[4] + R[8];
  double w, x, y, z;
  if (tr > 0) {
    double s = sqrt(tr + 1.0) * 2;
    w = 0.25 * s; x = (R[7] - R[5]) / s; y = (R[2] - R[6]) / s; z = (R[3] - R[1]) / s;
  } else if (R[0] > R[4] && R[0] > R[8]) {
    double s = sqrt(1.0 + R[0] - R[4] - R[8]) * 2;
    w = (R[7] - R[5]) / s; x = 0.25 * s; y = (R[1] + R[3]) / s; z = (R[2] + R[6]) / s;
  } else if (R[4] > R[8]) {
    double s = sqrt(1.0 + R[4] - R[0] - R[8]) * 2;
    w = (R[2] - R[6]) / s; x = (R[1] + R[3]) / s; y = 0.25 * s; z = (R[5] + R[7]) / s;
  } else {
    double s = sqrt(1.0 + R[8] - R[0] - R[4]) * 2;
    w = (R[3] - R[1]) / s; x = (R[2] + R[6]) / s; y = (R[5] + R[7]) / s; z = 0.25 * s;
  }
  double n = sqrt(w*w + x*x + y*y + z*z);
  if (w < 0) n = -n; /* canonical sign: w >= 0 */
  q[0] = w / n; q[1] = x / n; q[2] = y / n; q[3] = z / n;
}

void mgs_sym3_eigen(const double Ain[9], double w[3], double V[9]) {
  double A[9];
  memcpy(A, Ain, sizeof A);
  for (int i = 0; i < 9; i++) V[i] = (i % 4 == 0) ? 1.0 : 0.0;
  for (int sweep = 0; sweep < 50; sweep++) {
    double off = A[1]*A[1] + A[2]*A[2] + A[5]*A[5];
    if (off < 1e-30 * (A[0]*A[0] + A[4]*A[4] + A[8]*A[8]) || off == 0) break;
    for (int p = 0; p < 2; p++)
      for (int q = p + 1; q < 3; q++) {
        double apq = A[3*p+q];
        if (apq == 0) continue;
        double theta = (A[3*q+q] - A[3*p+p]) / (2 * apq);
        double t = (theta >= 0 ? 1.0 : -1.0) / (fabs(theta) + sqrt(theta*theta + 1));
        double c = 1 / sqrt(t*t + 1), s = t * c;
        for (int k = 0; k < 3; k++) { /* A = Jᵀ A J */
          double akp = A[3*k+p], akq = A[3*k+q];
          A[3*k+p] = c*akp - s*akq; A[3*k+q] = s*akp + c*akq;
        }
        for (int k = 0; k < 3; k++) {
          double apk = A[3*p+k], aqk = A[3*q+k];
          A[3*p+k] = c*apk - s*aqk; A[3*q+k] = s*apk + c*aqk;
        }
        for (int k = 0; k < 3; k++) {
          double vkp = V[3*k+p], vkq = V[3*k+q];
          V[3*k+p] = c*vkp - s*vkq; V[3*k+q] = s*vkp + c*vkq;
        }
      }
  }
  w[0] = A[0]; w[1] = A[4]; w[2] = A[8];
  /* sort ascending, permuting eigenvector columns */
  for (int i = 0; i < 2; i++)
    for (int j = 0; j < 2 - i; j++)
      if (w[j] > w[j+1]) {
        double t = w[j]; w[j] = w[j+1]; w[j+1] = t;
        for (int k = 0; k < 3; k++) { t = V[3*k+j]; V[3*k+j] = V[3*k+j+1]; V[3*k+j+1] = t; }
      }
}

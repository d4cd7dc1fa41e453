/* Real spherical harmonics up to degree 3 with the reference 3DGS constants and signs
 * (colour = C0*dc + sum_k b_k(dir)*rest_k + 0.5, clamped at 0 by the caller), and the
 * backward to the coefficients and to the view direction. */
#include "render/raster_internal.h"

static const float SH_C0 = 0.28209479177387814f;
static const float SH_C1 = 0.4886025119029199f;
static const float SH_C2[5] = {1.0925484305920792f, -1.0925484305920792f, 0.31539156525252005f,
                               -1.0925484305920792f, 0.5462742152960396f};
static const float SH_C3[7] = {-0.5900435899266435f, 2.890611442640554f, -0.4570457994644658f,
                               0.3731763325901154f, -0.4570457994644658f, 1.445305721320277f,
                               -0.5900435899266435f};

/* Basis values b[k] (k = 0..14 for the 15 rest coefficients) and, if db != NULL, their
 * partial derivatives in x, y, z (db[3k+j]). Returns the number of rest coefficients. */
static int sh_basis(int deg, const float d[3], float b[15], float *db) {
  float x = d[0], y = d[1], z = d[2];
  if (deg < 1) return 0;
  b[0] = -SH_C1 * y; b[1] = SH_C1 * z; b[2] = -SH_C1 * x;
  if (db) {
    for (int i = 0; i < 45; i++) db[i] = 0;
    db[0 * 3 + 1] = -SH_C1; db[1 * 3 + 2] = SH_C1; db[2 * 3 + 0] = -SH_C1;
  }
  if (deg < 2) return 3;
  float xx = x * x, yy = y * y, zz = z * z, xy = x * y, yz = y * z, xz = x * z;
  b[3] = SH_C2[0] * xy;
  b[4] = SH_C2[1] * yz;
  b[5] = SH_C2[2] * (2.0f * zz - xx - yy);
  b[6] = SH_C2[3] * xz;
  b[7] = SH_C2[4] * (xx - yy);
  if (db) {
    float *q = db + 9;
    q[0] = SH_C2[0] * y; q[1] = SH_C2[0] * x;
    q[3 + 1] = SH_C2[1] * z; q[3 + 2] = SH_C2[1] * y;
    q[6 + 0] = -2.0f * SH_C2[2] * x; q[6 + 1] = -2.0f * SH_C2[2] * y; q[6 + 2] = 4.0f * SH_C2[2] * z;
    q[9 + 0] = SH_C2[3] * z; q[9 + 2] = SH_C2[3] * x;
    q[12 + 0] = 2.0f * SH_C2[4] * x; q[12 + 1] = -2.0f * SH_C2[4] * y;
  }
  if (deg < 3) return 8;
  b[8] = SH_C3[0] * y * (3.0f * xx - yy);
  b[9] = SH_C3[1] * xy * z;
  b[10] = SH_C3[2] * y * (4.0f * zz - xx - yy);
  b[11] = SH_C3[3] * z * (2.0f * zz - 3.0f * xx - 3.0f * yy);
  b[12] = SH_C3[4] * x * (4.0f * zz - xx - yy);
  b[13] = SH_C3[5] * z * (xx - yy);
  b[14] = SH_C3[6] * x * (xx - 3.0f * yy);
  if (db) {
    float *q = db + 24;
    q[0] = SH_C3[0] * 6.0f * xy; q[1] = SH_C3[0] * 3.0f * (xx - yy);
    q[3] = SH_C3[1] * yz; q[4] = SH_C3[1] * xz; q[5] = SH_C3[1] * xy;
    q[6] = SH_C3[2] * -2.0f * xy; q[7] = SH_C3[2] * (4.0f * zz - xx - 3.0f * yy); q[8] = SH_C3[2] * 8.0f * yz;
    q[9] = SH_C3[3] * -6.0f * xz; q[10] = SH_C3[3] * -6.0f * yz; q[11] = SH_C3[3] * (6.0f * zz - 3.0f * xx - 3.0f * yy);
    q[12] = SH_C3[4] * (4.0f * zz - 3.0f * xx - yy); q[13] = SH_C3[4] * -2.0f * xy; q[14] = SH_C3[4] * 8.0f * xz;
    q[15] = SH_C3[5] * 2.0f * xz; q[16] = SH_C3[5] * -2.0f * yz; q[17] = SH_C3[5] * (xx - yy);
    q[18] = SH_C3[6] * 3.0f * (xx - yy); q[19] = SH_C3[6] * -6.0f * xy;
  }
  return 15;
}

void mgs_sh_eval(int deg, const float *dc, const float *rest, const float dir[3], float rgb[3]) {
  float b[15];
  int nk = sh_basis(deg, dir, b, NULL);
  for (int c = 0; c < 3; c++) {
    float s = SH_C0 * dc[c];
    for (int k = 0; k < nk; k++) s += b[k] * rest[3 * k + c];
    rgb[c] = s + 0.5f;
  }
}

void mgs_sh_backward(int deg, const float *dc, const float *rest, const float dir[3],
                     const float dL_drgb[3], float *g_dc, float *g_rest, float dL_ddir[3]) {
  (void)dc;
  float b[15], db[45];
  int nk = sh_basis(deg, dir, b, db);
  for (int c = 0; c < 3; c++) g_dc[c] += SH_C0 * dL_drgb[c];
  dL_ddir[0] = dL_ddir[1] = dL_ddir[2] = 0;
  for (int k = 0; k < nk; k++) {
    float dot = 0;
    for (int c = 0; c < 3; c++) {
      g_rest[3 * k + c] += b[k] * dL_drgb[c];
      dot += rest[3 * k + c] * dL_drgb[c];
    }
    for (int j = 0; j < 3; j++) dL_ddir[j] += db[3 * k + j] * dot;
  }
}

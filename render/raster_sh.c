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

/* ---- 16 Gaussians at a time (AVX-512 gathers/scatters). The operations and their order
 * are those of the scalar functions above (no contraction), so the results are identical. */
#if defined(__AVX512F__)
#include "render/raster_simd.h"

MGS_VINLINE int sh_basis_v(int deg, v16f x, v16f y, v16f z, v16f *b) {
  if (deg < 1) return 0;
  const v16f c1 = v16f_set1(SH_C1);
  b[0] = v16f_set1(-SH_C1) * y; b[1] = c1 * z; b[2] = v16f_set1(-SH_C1) * x;
  if (deg < 2) return 3;
  v16f xx = x * x, yy = y * y, zz = z * z, xy = x * y, yz = y * z, xz = x * z;
  const v16f two = v16f_set1(2.0f), three = v16f_set1(3.0f), four = v16f_set1(4.0f);
  b[3] = v16f_set1(SH_C2[0]) * xy;
  b[4] = v16f_set1(SH_C2[1]) * yz;
  b[5] = v16f_set1(SH_C2[2]) * (two * zz - xx - yy);
  b[6] = v16f_set1(SH_C2[3]) * xz;
  b[7] = v16f_set1(SH_C2[4]) * (xx - yy);
  if (deg < 3) return 8;
  b[8] = v16f_set1(SH_C3[0]) * y * (three * xx - yy);
  b[9] = v16f_set1(SH_C3[1]) * xy * z;
  b[10] = v16f_set1(SH_C3[2]) * y * (four * zz - xx - yy);
  b[11] = v16f_set1(SH_C3[3]) * z * (two * zz - three * xx - three * yy);
  b[12] = v16f_set1(SH_C3[4]) * x * (four * zz - xx - yy);
  b[13] = v16f_set1(SH_C3[5]) * z * (xx - yy);
  b[14] = v16f_set1(SH_C3[6]) * x * (xx - three * yy);
  return 15;
}

/* In-register 16x16 transpose (unpack, unpack, two 128-bit shuffle stages). */
MGS_VINLINE void tr16(__m512 r[16]) {
  __m512 t[16];
  for (int i = 0; i < 8; i++) { t[2 * i] = _mm512_unpacklo_ps(r[2 * i], r[2 * i + 1]); t[2 * i + 1] = _mm512_unpackhi_ps(r[2 * i], r[2 * i + 1]); }
  for (int i = 0; i < 4; i++) {
    __m512d a0 = _mm512_castps_pd(t[4 * i]), a1 = _mm512_castps_pd(t[4 * i + 1]);
    __m512d a2 = _mm512_castps_pd(t[4 * i + 2]), a3 = _mm512_castps_pd(t[4 * i + 3]);
    r[4 * i] = _mm512_castpd_ps(_mm512_unpacklo_pd(a0, a2));
    r[4 * i + 1] = _mm512_castpd_ps(_mm512_unpackhi_pd(a0, a2));
    r[4 * i + 2] = _mm512_castpd_ps(_mm512_unpacklo_pd(a1, a3));
    r[4 * i + 3] = _mm512_castpd_ps(_mm512_unpackhi_pd(a1, a3));
  }
  for (int i = 0; i < 4; i++) {
    t[i] = _mm512_shuffle_f32x4(r[i], r[i + 4], 0x88);
    t[i + 4] = _mm512_shuffle_f32x4(r[i], r[i + 4], 0xdd);
    t[i + 8] = _mm512_shuffle_f32x4(r[i + 8], r[i + 12], 0x88);
    t[i + 12] = _mm512_shuffle_f32x4(r[i + 8], r[i + 12], 0xdd);
  }
  for (int i = 0; i < 8; i++) {
    r[i] = _mm512_shuffle_f32x4(t[i], t[i + 8], 0x88);
    r[i + 8] = _mm512_shuffle_f32x4(t[i], t[i + 8], 0xdd);
  }
}

/* mask of the floats of 16-float chunk q that belong to the first `used` of a row */
static inline __mmask16 chunk_mask(int q, int used) {
  int n = used - 16 * q;
  return n <= 0 ? 0 : n >= 16 ? (__mmask16)0xFFFF : (__mmask16)((1u << n) - 1);
}

/* cols[j][l] = row_l[j] for j < 16 * chunks; rows of lanes outside mask read as zero */
MGS_VINLINE void load_cols(const float *base, const int32_t *lane, uint16_t mask, int used, v16f *cols) {
  for (int q = 0; q * 16 < used; q++) {
    __m512 r[16];
    __mmask16 cm = chunk_mask(q, used);
    for (int l = 0; l < 16; l++)
      r[l] = (mask >> l) & 1 ? _mm512_maskz_loadu_ps(cm, base + (size_t)lane[l] * MGS_SH_REST_MAX + 16 * q) : _mm512_setzero_ps();
    tr16(r);
    for (int j = 0; j < 16; j++) cols[16 * q + j] = (v16f)r[j];
  }
}

void mgs_sh_eval16(int deg, const float *dc, const float *rest, const int32_t *lane, uint16_t mask,
                   const float dir[3][16], float rgb[3][16]) {
  float dcs[3][16];
  for (int l = 0; l < 16; l++)
    for (int c = 0; c < 3; c++) dcs[c][l] = (mask >> l) & 1 ? dc[3 * (size_t)lane[l] + c] : 0.0f;
  v16f b[15], cols[48];
  int nk = sh_basis_v(deg, v16f_load(dir[0]), v16f_load(dir[1]), v16f_load(dir[2]), b);
  load_cols(rest, lane, mask, 3 * nk, cols);
  for (int c = 0; c < 3; c++) {
    v16f s = v16f_set1(SH_C0) * v16f_load(dcs[c]);
    for (int k = 0; k < nk; k++) s += b[k] * cols[3 * k + c];
    v16f_store(rgb[c], s + v16f_set1(0.5f));
  }
}

void mgs_sh_backward16(int deg, const float *rest, const int32_t *lane, uint16_t mask, const float dir[3][16],
                       const float dL_drgb[3][16], float *g_dc, float *g_rest, float dL_ddir[3][16]) {
  v16f x = v16f_load(dir[0]), y = v16f_load(dir[1]), z = v16f_load(dir[2]);
  v16f b[15], cols[48];
  int nk = sh_basis_v(deg, x, y, z, b);
  for (int l = 0; l < 16; l++)
    if ((mask >> l) & 1)
      for (int c = 0; c < 3; c++) g_dc[3 * (size_t)lane[l] + c] += SH_C0 * dL_drgb[c][l];
  v16f d[3] = {v16f_load(dL_drgb[0]), v16f_load(dL_drgb[1]), v16f_load(dL_drgb[2])};
  const int used = 3 * nk;
  load_cols(rest, lane, mask, used, cols);
  v16f dot[15];
  for (int k = 0; k < nk; k++) {
    v16f dk = v16f_set1(0.0f);
    for (int c = 0; c < 3; c++) dk += cols[3 * k + c] * d[c];
    dot[k] = dk;
  }
  /* g_rest rows += b_k dL/drgb_c: the increments as columns, transposed back to rows */
  for (int q = 0; q * 16 < used; q++) {
    __m512 r[16];
    for (int j = 0; j < 16; j++) {
      int o = 16 * q + j, k = o / 3, c = o % 3;
      r[j] = o < used ? (__m512)(b[k] * d[c]) : _mm512_setzero_ps();
    }
    tr16(r);
    __mmask16 cm = chunk_mask(q, used);
    for (int l = 0; l < 16; l++) {
      if (!((mask >> l) & 1)) continue;
      float *row = g_rest + (size_t)lane[l] * MGS_SH_REST_MAX + 16 * q;
      _mm512_mask_storeu_ps(row, cm, _mm512_add_ps(_mm512_maskz_loadu_ps(cm, row), r[l]));
    }
  }
  /* dL/ddir = sum_k db_k dot_k, the nonzero partials of sh_basis in the same k order */
  v16f gx = v16f_set1(0.0f), gy = gx, gz = gx;
  if (nk >= 3) {
    gy += v16f_set1(-SH_C1) * dot[0];
    gz += v16f_set1(SH_C1) * dot[1];
    gx += v16f_set1(-SH_C1) * dot[2];
  }
  if (nk >= 8) {
    v16f xx = x * x, yy = y * y, zz = z * z, xy = x * y, yz = y * z, xz = x * z;
    gx += (v16f_set1(SH_C2[0]) * y) * dot[3]; gy += (v16f_set1(SH_C2[0]) * x) * dot[3];
    gy += (v16f_set1(SH_C2[1]) * z) * dot[4]; gz += (v16f_set1(SH_C2[1]) * y) * dot[4];
    gx += (v16f_set1(-2.0f * SH_C2[2]) * x) * dot[5]; gy += (v16f_set1(-2.0f * SH_C2[2]) * y) * dot[5];
    gz += (v16f_set1(4.0f * SH_C2[2]) * z) * dot[5];
    gx += (v16f_set1(SH_C2[3]) * z) * dot[6]; gz += (v16f_set1(SH_C2[3]) * x) * dot[6];
    gx += (v16f_set1(2.0f * SH_C2[4]) * x) * dot[7]; gy += (v16f_set1(-2.0f * SH_C2[4]) * y) * dot[7];
    if (nk >= 15) {
      const v16f three = v16f_set1(3.0f), four = v16f_set1(4.0f), six = v16f_set1(6.0f);
      gx += (v16f_set1(SH_C3[0]) * six * xy) * dot[8]; gy += (v16f_set1(SH_C3[0]) * three * (xx - yy)) * dot[8];
      gx += (v16f_set1(SH_C3[1]) * yz) * dot[9]; gy += (v16f_set1(SH_C3[1]) * xz) * dot[9];
      gz += (v16f_set1(SH_C3[1]) * xy) * dot[9];
      gx += (v16f_set1(SH_C3[2]) * v16f_set1(-2.0f) * xy) * dot[10];
      gy += (v16f_set1(SH_C3[2]) * (four * zz - xx - three * yy)) * dot[10];
      gz += (v16f_set1(SH_C3[2]) * v16f_set1(8.0f) * yz) * dot[10];
      gx += (v16f_set1(SH_C3[3]) * v16f_set1(-6.0f) * xz) * dot[11];
      gy += (v16f_set1(SH_C3[3]) * v16f_set1(-6.0f) * yz) * dot[11];
      gz += (v16f_set1(SH_C3[3]) * (six * zz - three * xx - three * yy)) * dot[11];
      gx += (v16f_set1(SH_C3[4]) * (four * zz - three * xx - yy)) * dot[12];
      gy += (v16f_set1(SH_C3[4]) * v16f_set1(-2.0f) * xy) * dot[12];
      gz += (v16f_set1(SH_C3[4]) * v16f_set1(8.0f) * xz) * dot[12];
      gx += (v16f_set1(SH_C3[5]) * v16f_set1(2.0f) * xz) * dot[13];
      gy += (v16f_set1(SH_C3[5]) * v16f_set1(-2.0f) * yz) * dot[13];
      gz += (v16f_set1(SH_C3[5]) * (xx - yy)) * dot[13];
      gx += (v16f_set1(SH_C3[6]) * three * (xx - yy)) * dot[14];
      gy += (v16f_set1(SH_C3[6]) * v16f_set1(-6.0f) * xy) * dot[14];
    }
  }
  v16f_store(dL_ddir[0], gx); v16f_store(dL_ddir[1], gy); v16f_store(dL_ddir[2], gz);
}
#endif

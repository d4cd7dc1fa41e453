/* 16-wide float vectors (one tile row of 16 pixels) for the rasterizer's inner loops, as
 * GCC/Clang vector extensions: with -march=native on AVX-512 one vector is one register,
 * on AVX2 two, and any other target still compiles. Also the one exp() both the forward
 * and the backward use, so that both take bit-identical alpha decisions. Internal. */
#ifndef MGS_RASTER_SIMD_H
#define MGS_RASTER_SIMD_H
#include <stdint.h>
#include <math.h>
#include <string.h>
#if defined(__AVX512F__) || defined(__AVX2__)
#include <immintrin.h>
#endif
#if defined(__GNUC__) && !defined(__clang__)
/* 64-byte vectors passed between MGS_VINLINE functions: no ABI is involved, but GCC
 * warns about one on targets without AVX-512 */
#pragma GCC diagnostic ignored "-Wpsabi"
#endif

/* always inlined: no 64-byte vector ever crosses a call boundary */
#define MGS_VINLINE static inline __attribute__((always_inline))

typedef float v16f __attribute__((vector_size(64)));
typedef int32_t v16i __attribute__((vector_size(64)));

MGS_VINLINE v16f v16f_set1(float x) { return (v16f){x, x, x, x, x, x, x, x, x, x, x, x, x, x, x, x}; }
MGS_VINLINE v16i v16i_set1(int32_t x) { return (v16i){x, x, x, x, x, x, x, x, x, x, x, x, x, x, x, x}; }
MGS_VINLINE v16f v16f_load(const float *p) { v16f v; memcpy(&v, p, sizeof v); return v; }
MGS_VINLINE void v16f_store(float *p, v16f v) { memcpy(p, &v, sizeof v); }
MGS_VINLINE v16i v16i_load(const int32_t *p) { v16i v; memcpy(&v, p, sizeof v); return v; }
MGS_VINLINE void v16i_store(int32_t *p, v16i v) { memcpy(p, &v, sizeof v); }
/* Comparisons, min/max and masks of whole rows. Kernels call these rather than the
 * operators (a < b on v16f): on AVX2 without AVX-512 GCC 12 scalarizes a comparison of
 * 64-byte vectors (a compare, a branch and a setcc per lane), so there they are done as
 * two native 256-bit halves with the same predicates, lane for lane the same results.
 * The ordered predicates (<, <=, >, >=) are the signalling ones, as C's operators; ==
 * is ordered-quiet and != unordered-quiet (true on NaN), as C's. */
#if !defined(__AVX512F__) && defined(__AVX2__)
#define MGS_V16_HALVES 1
typedef union { v16f v; __m256 h[2]; } mgs_v16f_h;
typedef union { v16i v; __m256i h[2]; } mgs_v16i_h;
#define MGS_V16F_CMP(name, op, pred)                                                    \
  MGS_VINLINE v16i name(v16f a, v16f b) {                                               \
    mgs_v16f_h x = {a}, y = {b}, r;                                                     \
    r.h[0] = _mm256_cmp_ps(x.h[0], y.h[0], pred);                                       \
    r.h[1] = _mm256_cmp_ps(x.h[1], y.h[1], pred);                                       \
    return (v16i)r.v;                                                                   \
  }
#else
#define MGS_V16F_CMP(name, op, pred) \
  MGS_VINLINE v16i name(v16f a, v16f b) { return a op b; }
#endif
MGS_V16F_CMP(v16f_lt, <, _CMP_LT_OS)
MGS_V16F_CMP(v16f_le, <=, _CMP_LE_OS)
MGS_V16F_CMP(v16f_gt, >, _CMP_GT_OS)
MGS_V16F_CMP(v16f_ge, >=, _CMP_GE_OS)
MGS_V16F_CMP(v16f_eq, ==, _CMP_EQ_OQ)
MGS_V16F_CMP(v16f_ne, !=, _CMP_NEQ_UQ)
#undef MGS_V16F_CMP
MGS_VINLINE v16i v16i_eq(v16i a, v16i b) {
#if defined(MGS_V16_HALVES)
  mgs_v16i_h x = {a}, y = {b}, r;
  r.h[0] = _mm256_cmpeq_epi32(x.h[0], y.h[0]);
  r.h[1] = _mm256_cmpeq_epi32(x.h[1], y.h[1]);
  return r.v;
#else
  return a == b;
#endif
}
MGS_VINLINE v16i v16i_ne(v16i a, v16i b) { return ~v16i_eq(a, b); }
MGS_VINLINE v16i v16i_lt(v16i a, v16i b) {
#if defined(MGS_V16_HALVES)
  mgs_v16i_h x = {a}, y = {b}, r;
  r.h[0] = _mm256_cmpgt_epi32(y.h[0], x.h[0]);
  r.h[1] = _mm256_cmpgt_epi32(y.h[1], x.h[1]);
  return r.v;
#else
  return a < b;
#endif
}
/* m: lanes all-ones or zero (the result of a vector comparison). */
MGS_VINLINE v16f v16f_select(v16i m, v16f a, v16f b) { return (v16f)((m & (v16i)a) | (~m & (v16i)b)); }
MGS_VINLINE v16f v16f_and(v16i m, v16f a) { return (v16f)(m & (v16i)a); }
/* (a < b ? a : b) and (a > b ? a : b) per lane: b when either is NaN or both are zeros,
 * which is exactly what minps/maxps return (their second operand then) */
MGS_VINLINE v16f v16f_min(v16f a, v16f b) {
#if defined(MGS_V16_HALVES)
  mgs_v16f_h x = {a}, y = {b}, r;
  r.h[0] = _mm256_min_ps(x.h[0], y.h[0]);
  r.h[1] = _mm256_min_ps(x.h[1], y.h[1]);
  return r.v;
#else
  return v16f_select(a < b, a, b);
#endif
}
MGS_VINLINE v16f v16f_max(v16f a, v16f b) {
#if defined(MGS_V16_HALVES)
  mgs_v16f_h x = {a}, y = {b}, r;
  r.h[0] = _mm256_max_ps(x.h[0], y.h[0]);
  r.h[1] = _mm256_max_ps(x.h[1], y.h[1]);
  return r.v;
#else
  return v16f_select(a > b, a, b);
#endif
}
/* a*b + c, fused where the target has FMA (explicit, so that the result does not depend
 * on the compiler's contraction choices: forward and backward must agree bit for bit) */
MGS_VINLINE v16f v16f_fma(v16f a, v16f b, v16f c) {
#if defined(__AVX512F__)
  return (v16f)_mm512_fmadd_ps((__m512)a, (__m512)b, (__m512)c);
#else
  return a * b + c;
#endif
}
/* 1/x to about 1 ulp: hardware estimate + one Newton step (a 512-bit divide has a
 * fraction of the throughput). Used where the value feeds no threshold decision. */
MGS_VINLINE v16f v16f_rcp(v16f x) {
#if defined(__AVX512F__)
  v16f r = (v16f)_mm512_rcp14_ps((__m512)x);
  return r * v16f_fma(v16f_set1(-1.0f) * x, r, v16f_set1(2.0f));
#else
  return v16f_set1(1.0f) / x;
#endif
}
MGS_VINLINE int v16i_any(v16i m) {
#if defined(__AVX512F__)
  return _mm512_test_epi32_mask((__m512i)m, (__m512i)m) != 0;
#elif defined(MGS_V16_HALVES)
  mgs_v16i_h x = {m};
  __m256i o = _mm256_or_si256(x.h[0], x.h[1]);
  return !_mm256_testz_si256(o, o);
#else
  int32_t t[16]; memcpy(t, &m, sizeof t);
  int32_t r = 0;
  for (int i = 0; i < 16; i++) r |= t[i];
  return r != 0;
#endif
}
/* bit i set where lane i of m is nonzero */
MGS_VINLINE uint32_t v16i_bits(v16i m) {
#if defined(__AVX512F__)
  return _mm512_test_epi32_mask((__m512i)m, (__m512i)m);
#elif defined(MGS_V16_HALVES)
  /* lanes equal to zero, inverted: exact for any m, not only all-ones/zero masks */
  mgs_v16i_h u = {m};
  const __m256i z = _mm256_setzero_si256();
  uint32_t lo = (uint32_t)_mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(u.h[0], z)));
  uint32_t hi = (uint32_t)_mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(u.h[1], z)));
  return ~(lo | hi << 8) & 0xffffu;
#else
  uint32_t b = 0;
  for (int i = 0; i < 16; i++) b |= (uint32_t)(m[i] != 0) << i;
  return b;
#endif
}
MGS_VINLINE float v16f_sum(v16f v) {
#if defined(__AVX512F__)
  return _mm512_reduce_add_ps((__m512)v);
#else
  float t[16]; memcpy(t, &v, sizeof t);
  float a = 0;
  for (int i = 0; i < 16; i++) a += t[i];
  return a;
#endif
}

MGS_VINLINE v16f v16f_sqrt(v16f x) {
#if defined(__AVX512F__)
  return (v16f)_mm512_sqrt_ps((__m512)x);
#elif defined(MGS_V16_HALVES)
  /* correctly rounded as sqrtf; on x < 0 the same default NaN */
  mgs_v16f_h u = {x};
  u.h[0] = _mm256_sqrt_ps(u.h[0]);
  u.h[1] = _mm256_sqrt_ps(u.h[1]);
  return u.v;
#else
  v16f r;
  for (int i = 0; i < 16; i++) r[i] = sqrtf(x[i]);
  return r;
#endif
}
MGS_VINLINE v16f v16f_ceil(v16f x) {
#if defined(__AVX512F__)
  return (v16f)_mm512_roundscale_ps((__m512)x, _MM_FROUND_TO_POS_INF | _MM_FROUND_NO_EXC);
#elif defined(MGS_V16_HALVES)
  mgs_v16f_h u = {x};
  u.h[0] = _mm256_round_ps(u.h[0], _MM_FROUND_TO_POS_INF | _MM_FROUND_NO_EXC);
  u.h[1] = _mm256_round_ps(u.h[1], _MM_FROUND_TO_POS_INF | _MM_FROUND_NO_EXC);
  return u.v;
#else
  v16f r;
  for (int i = 0; i < 16; i++) r[i] = ceilf(x[i]);
  return r;
#endif
}

/* exp(x) for x <= 0 (Cephes expf polynomial, about 1 ulp), with x clamped below at -12:
 * the rasterizer only uses values with opacity*exp(x) >= 1/255, i.e. x > -5.55, and the
 * clamp keeps every product downstream far from denormals (whose microcode assists made
 * tiny Gaussians several times slower). Bit-identical in the forward and the backward,
 * which is what matters. */
/* One body for the 16- and 8-lane versions, so that both stay the same operations. */
#define MGS_EXP_NEG_BODY(VF, VI, SET1, MAX, FMA)                                  \
  x = MAX(x, SET1(-12.0f));                                                       \
  /* round to nearest via the 1.5*2^23 trick (|x*log2e| < 126) */                 \
  const VF magic = SET1(12582912.0f);                                             \
  VF n = FMA(x, SET1(1.44269504088896341f), magic) - magic;                      \
  VF r = FMA(n, SET1(-0.693359375f), x);                                          \
  r = FMA(n, SET1(2.12194440e-4f), r);                                            \
  VF z = r * r;                                                                   \
  VF y = SET1(1.9875691500E-4f);                                                  \
  y = FMA(y, r, SET1(1.3981999507E-3f));                                          \
  y = FMA(y, r, SET1(8.3334519073E-3f));                                          \
  y = FMA(y, r, SET1(4.1665795894E-2f));                                          \
  y = FMA(y, r, SET1(1.6666665459E-1f));                                          \
  y = FMA(y, r, SET1(5.0000001201E-1f));                                          \
  y = FMA(y, z, r + SET1(1.0f));                                                  \
  VI e = __builtin_convertvector(n, VI);                                          \
  VI bits = (e + 127) << 23;                                                      \
  return y * (VF)bits;
MGS_VINLINE v16f v16f_exp_neg(v16f x) { MGS_EXP_NEG_BODY(v16f, v16i, v16f_set1, v16f_max, v16f_fma) }
/* ---- 8 lanes (half a tile row), for Gaussians whose pixels lie in one half of a tile
 * (cheaper where a 512-bit operation runs as two 256-bit halves, as on AMD Zen 4). The
 * same operations as the 16-wide versions lane for lane (identical results).
 * On AVX2 without AVX-512 (MGS_ROWS8) the 3DGS tile kernels work in these halves
 * throughout: GCC scalarizes comparisons of 64-byte vectors there (a compare and a branch
 * per lane), while 32-byte vectors are native. */
typedef float v8f __attribute__((vector_size(32)));
typedef int32_t v8i __attribute__((vector_size(32)));
#if defined(__AVX512F__) && defined(__AVX512VL__)
#define MGS_HALF_ROWS 1
#elif !defined(__AVX512F__) && defined(__AVX2__)
#define MGS_ROWS8 1
#endif
#if defined(MGS_HALF_ROWS) || defined(MGS_ROWS8)
MGS_VINLINE v8f v8f_set1(float x) { return (v8f){x, x, x, x, x, x, x, x}; }
MGS_VINLINE v8i v8i_set1(int32_t x) { return (v8i){x, x, x, x, x, x, x, x}; }
/* half h (0 or 8: the first float) of a 16-lane row kept in memory */
MGS_VINLINE v8f v8f_half(const void *row, int h) { v8f v; memcpy(&v, (const float *)row + h, sizeof v); return v; }
MGS_VINLINE void v8f_put(void *row, int h, v8f v) { memcpy((float *)row + h, &v, sizeof v); }
MGS_VINLINE v8i v8i_half(const void *row, int h) { v8i v; memcpy(&v, (const int32_t *)row + h, sizeof v); return v; }
MGS_VINLINE void v8i_put(void *row, int h, v8i v) { memcpy((int32_t *)row + h, &v, sizeof v); }
MGS_VINLINE v8f v8f_select(v8i m, v8f a, v8f b) { return (v8f)((m & (v8i)a) | (~m & (v8i)b)); }
MGS_VINLINE v8f v8f_and(v8i m, v8f a) { return (v8f)(m & (v8i)a); }
MGS_VINLINE v8f v8f_min(v8f a, v8f b) { return v8f_select(a < b, a, b); }
MGS_VINLINE v8f v8f_max(v8f a, v8f b) { return v8f_select(a > b, a, b); }
#if defined(MGS_HALF_ROWS)
MGS_VINLINE v8f v8f_fma(v8f a, v8f b, v8f c) { return (v8f)_mm256_fmadd_ps((__m256)a, (__m256)b, (__m256)c); }
MGS_VINLINE int v8i_any(v8i m) { return _mm256_test_epi32_mask((__m256i)m, (__m256i)m) != 0; }
#else
/* unfused, as v16f_fma without AVX-512 (C17 mode: no contraction) */
MGS_VINLINE v8f v8f_fma(v8f a, v8f b, v8f c) { return a * b + c; }
MGS_VINLINE int v8i_any(v8i m) { return !_mm256_testz_si256((__m256i)m, (__m256i)m); }
/* v16f_rcp without AVX-512: a true division */
MGS_VINLINE v8f v8f_rcp(v8f x) { return v8f_set1(1.0f) / x; }
#endif
/* v16f_exp_neg, 8 lanes */
MGS_VINLINE v8f v8f_exp_neg(v8f x) { MGS_EXP_NEG_BODY(v8f, v8i, v8f_set1, v8f_max, v8f_fma) }
#endif

/* out[0..16) = the lane-wise sum, in row order from +0, of n rows of 16 floats st floats
 * apart (what a v16f accumulator gives, bit for bit); nonzero when a lane of the sum is
 * nonzero (+-0 count as zero, NaN as nonzero). On AVX2 without AVX-512 the accumulator is
 * two 8-lane registers: GCC kept a 64-byte one on the stack there, a store and two reloads
 * per row, and tested the lanes one by one. */
MGS_VINLINE int mgs_sum_rows16(const float *q, uint32_t n, size_t st, float out[16]) {
#if defined(MGS_ROWS8)
  v8f a0 = v8f_set1(0.0f), a1 = a0;
  for (uint32_t k = 0; k < n; k++, q += st) {
    a0 += v8f_half(q, 0);
    a1 += v8f_half(q, 8);
  }
  v8f_put(out, 0, a0);
  v8f_put(out, 8, a1);
  return v8i_any(((v8i)a0 << 1) | ((v8i)a1 << 1));
#else
  v16f acc = v16f_set1(0.0f);
  for (uint32_t k = 0; k < n; k++, q += st) acc += v16f_load(q);
  v16f_store(out, acc);
  return v16i_any(((v16i)acc << 1) != 0);
#endif
}

/* exp(x) over the float range (Cephes, about 1 ulp); x clamped to [-87, 88] so the result
 * stays a normal float (e^88 ~ 1.7e38: still overflows whatever it multiplies). */
MGS_VINLINE v16f v16f_exp(v16f x) {
  x = v16f_min(v16f_max(x, v16f_set1(-87.0f)), v16f_set1(88.0f));
  const v16f magic = v16f_set1(12582912.0f);
  v16f n = v16f_fma(x, v16f_set1(1.44269504088896341f), magic) - magic;
  v16f r = v16f_fma(n, v16f_set1(-0.693359375f), x);
  r = v16f_fma(n, v16f_set1(2.12194440e-4f), r);
  v16f z = r * r;
  v16f y = v16f_set1(1.9875691500E-4f);
  y = v16f_fma(y, r, v16f_set1(1.3981999507E-3f));
  y = v16f_fma(y, r, v16f_set1(8.3334519073E-3f));
  y = v16f_fma(y, r, v16f_set1(4.1665795894E-2f));
  y = v16f_fma(y, r, v16f_set1(1.6666665459E-1f));
  y = v16f_fma(y, r, v16f_set1(5.0000001201E-1f));
  y = v16f_fma(y, z, r + v16f_set1(1.0f));
  /* 2^n in two halves so that n = 128 (x near 88.7) does not overflow the exponent field */
  v16i e = __builtin_convertvector(n, v16i);
  v16i e1 = e >> 1, e2 = e - e1;
  return y * (v16f)((e1 + 127) << 23) * (v16f)((e2 + 127) << 23);
}
#endif

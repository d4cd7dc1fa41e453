/* The row helpers of render/raster_simd.h (comparisons, min/max, select, any, bits, sqrt,
 * ceil) against their plain scalar definitions, bit for bit, lane by lane: on AVX2
 * without AVX-512 they are two 256-bit halves of intrinsics, which must give exactly what
 * the C operators gave (NaN in either operand, +-0, +-inf, denormals, equal values). */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <string.h>
#include "mgs_test.h"
#include "render/raster_simd.h"

static uint32_t fbits(float x) { uint32_t u; memcpy(&u, &x, 4); return u; }
static float bitsf(uint32_t u) { float x; memcpy(&x, &u, 4); return x; }

#define NV 4096
static float vals[NV];
static int nvals;

static void build_values(void) {
  const uint32_t special[] = {0x7fc00000u, 0xffc00000u, 0x7fc00001u, 0xffc12345u, 0x7f800001u, 0xff800123u,
                              0x7f800000u, 0xff800000u, 0x00000000u, 0x80000000u, 0x00000001u, 0x80000001u,
                              0x007fffffu, 0x807fffffu, 0x00400000u, 0x00800000u, 0x80800000u, 0x7f7fffffu,
                              0xff7fffffu, 0x3f800000u, 0xbf800000u, 0x3f800001u, 0x3f7fffffu, 0x3c23d70au};
  int n = 0;
  for (size_t i = 0; i < sizeof special / sizeof special[0]; i++) vals[n++] = bitsf(special[i]);
  const float more[] = {0.5f, -0.5f, 1e-4f, 1.0f / 255.0f, 0.99f, 1e7f, -12.0f, 88.0f, -87.0f, 2.5f, -2.5f, 3.0f};
  for (size_t i = 0; i < sizeof more / sizeof more[0]; i++) vals[n++] = more[i];
  uint32_t s = 12345u; /* xorshift: any bit pattern, plus values near 1 (many ties) */
  while (n < 256) {
    s ^= s << 13; s ^= s >> 17; s ^= s << 5;
    float v = (n & 1) ? bitsf(s) : (float)(s % 9u) * 0.25f - 1.0f;
    vals[n++] = v;
  }
  nvals = n;
}

static int n_bad;
static void bad(const char *what, float a, float b, uint32_t got, uint32_t want) {
  if (n_bad++ < 8)
    fprintf(stderr, "%s(%08x, %08x): %08x, scalar %08x\n", what, fbits(a), fbits(b), got, want);
}

/* every (a, b) pair of values, 16 lanes at a time */
static void test_binary(void) {
  float A[16], B[16];
  int k = 0;
  n_bad = 0;
  for (int i = 0; i < nvals; i++)
    for (int j = 0; j < nvals; j++) {
      A[k] = vals[i]; B[k] = vals[j];
      if (++k < 16 && !(i == nvals - 1 && j == nvals - 1)) continue;
      v16f a = v16f_load(A), b = v16f_load(B);
      v16i r[6] = {v16f_lt(a, b), v16f_le(a, b), v16f_gt(a, b), v16f_ge(a, b), v16f_eq(a, b), v16f_ne(a, b)};
      v16f mn = v16f_min(a, b), mx = v16f_max(a, b);
      v16i ia = (v16i)a, ib = (v16i)b;
      v16i ieq = v16i_eq(ia, ib), ine = v16i_ne(ia, ib), ilt = v16i_lt(ia, ib);
      v16f sel = v16f_select(ia, a, b), an = v16f_and(ib, a); /* masks of any bits */
      static const char *names[6] = {"lt", "le", "gt", "ge", "eq", "ne"};
      for (int l = 0; l < k; l++) {
        float x = A[l], y = B[l];
        int32_t ux = (int32_t)fbits(x), uy = (int32_t)fbits(y);
        int want[6] = {x < y, x <= y, x > y, x >= y, x == y, x != y};
        for (int c = 0; c < 6; c++)
          if (r[c][l] != -want[c]) bad(names[c], x, y, (uint32_t)r[c][l], (uint32_t)-want[c]);
        if (fbits(mn[l]) != fbits(x < y ? x : y)) bad("min", x, y, fbits(mn[l]), fbits(x < y ? x : y));
        if (fbits(mx[l]) != fbits(x > y ? x : y)) bad("max", x, y, fbits(mx[l]), fbits(x > y ? x : y));
        if (ieq[l] != -(ux == uy)) bad("i_eq", x, y, (uint32_t)ieq[l], (uint32_t)-(ux == uy));
        if (ine[l] != -(ux != uy)) bad("i_ne", x, y, (uint32_t)ine[l], (uint32_t)-(ux != uy));
        if (ilt[l] != -(ux < uy)) bad("i_lt", x, y, (uint32_t)ilt[l], (uint32_t)-(ux < uy));
        uint32_t ws = ((uint32_t)ux & (uint32_t)ux) | (~(uint32_t)ux & (uint32_t)uy);
        if (fbits(sel[l]) != ws) bad("select", x, y, fbits(sel[l]), ws);
        if (fbits(an[l]) != ((uint32_t)uy & (uint32_t)ux)) bad("and", x, y, fbits(an[l]), (uint32_t)uy & (uint32_t)ux);
      }
      k = 0;
    }
  CHECK_MSG(n_bad == 0, "%d lanes differ from the scalar definitions", n_bad);
}

static void test_unary(void) {
  n_bad = 0;
  for (int i = 0; i + 16 <= nvals; i++) { /* sliding windows: every value in every lane */
    v16f a = v16f_load(vals + i);
    v16f sq = v16f_sqrt(a), ce = v16f_ceil(a);
    for (int l = 0; l < 16; l++) {
      float x = vals[i + l];
      if (fbits(sq[l]) != fbits(sqrtf(x))) bad("sqrt", x, 0, fbits(sq[l]), fbits(sqrtf(x)));
      if (fbits(ce[l]) != fbits(ceilf(x))) bad("ceil", x, 0, fbits(ce[l]), fbits(ceilf(x)));
    }
  }
  CHECK_MSG(n_bad == 0, "%d lanes differ from sqrtf/ceilf", n_bad);
}

/* any/bits on masks with one lane set to each value's bits (also non-mask patterns) */
static void test_masks(void) {
  n_bad = 0;
  for (int i = 0; i < nvals; i++)
    for (int l = -1; l < 16; l++) {
      v16i m = v16i_set1(0);
      if (l >= 0) m[l] = (int32_t)fbits(vals[i]);
      uint32_t want = (l >= 0 && m[l] != 0) ? 1u << l : 0u;
      if (v16i_bits(m) != want) bad("bits", vals[i], (float)l, v16i_bits(m), want);
      if (v16i_any(m) != (want != 0)) bad("any", vals[i], (float)l, (uint32_t)v16i_any(m), want != 0);
      v16i f = v16i_set1((int32_t)fbits(vals[i]));
      uint32_t wf = fbits(vals[i]) ? 0xffffu : 0u;
      if (v16i_bits(f) != wf) bad("bits", vals[i], -2.0f, v16i_bits(f), wf);
    }
  CHECK_MSG(n_bad == 0, "%d masks differ", n_bad);
}

/* mgs_sum_rows16 against a scalar sum in row order from +0: n = 0..6 rows at strides 16
 * and 19, lanes drawn from the special and random values (NaN compared by class); the flag
 * against "some lane is neither +0 nor -0". */
static void test_sum_rows(void) {
  n_bad = 0;
  float rows[6 * 19];
  uint32_t s = 777u;
  for (int trial = 0; trial < 4000; trial++) {
    int n = trial % 7;
    size_t st = trial % 2 ? 19 : 16;
    for (size_t k = 0; k < 6 * 19; k++) {
      s ^= s << 13; s ^= s >> 17; s ^= s << 5;
      /* mostly zeros of either sign (the flag's case), some small values, some specials */
      uint32_t pick = s % 16u;
      rows[k] = pick < 8 ? (pick & 1 ? -0.0f : 0.0f) : pick < 14 ? (float)(int32_t)(s >> 20) * 1e-3f : vals[(s >> 8) % (uint32_t)nvals];
    }
    float out[16];
    int flag = mgs_sum_rows16(rows, (uint32_t)n, st, out), wflag = 0;
    for (int l = 0; l < 16; l++) {
      float a = 0.0f;
      for (int k = 0; k < n; k++) a += rows[(size_t)k * st + (size_t)l];
      wflag |= (fbits(a) << 1) != 0;
      int same = fbits(out[l]) == fbits(a) || (isnan(out[l]) && isnan(a));
      if (!same) bad("sum_rows", (float)n, (float)l, fbits(out[l]), fbits(a));
    }
    if (flag != wflag) bad("sum_rows flag", (float)n, (float)st, (uint32_t)flag, (uint32_t)wflag);
  }
  CHECK_MSG(n_bad == 0, "%d sums or flags differ", n_bad);
}

int main(void) {
  build_values();
#if defined(MGS_V16_HALVES)
  fprintf(stderr, "raster_simd.h: 256-bit halves (AVX2 without AVX-512)\n");
#endif
  RUN(test_binary);
  RUN(test_unary);
  RUN(test_masks);
  RUN(test_sum_rows);
  return mgs_test_finish();
}

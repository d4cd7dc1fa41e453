/* PCG32 (O'Neill, pcg-random.org, XSH-RR variant) and derived distributions. */
#include <math.h>
#include "core/mgs_rng.h"

void mgs_rng_init(mgs_rng *r, uint64_t seed, uint64_t stream) {
  r->state = 0u;
  r->inc = (stream << 1u) | 1u;
  (void)mgs_rng_u32(r);
  r->state += seed;
  (void)mgs_rng_u32(r);
}

uint32_t mgs_rng_u32(mgs_rng *r) {
  uint64_t old = r->state;
  r->state = old * 6364136223846793005ULL + r->inc;
  uint32_t xorshifted = (uint32_t)(((old >> 18u) ^ old) >> 27u);
  uint32_t rot = (uint32_t)(old >> 59u);
  return (xorshifted >> rot) | (xorshifted << ((-rot) & 31));
}

double mgs_rng_uniform(mgs_rng *r) {
  uint64_t hi = mgs_rng_u32(r), lo = mgs_rng_u32(r);
  return (double)((hi << 21) ^ lo) * (1.0 / 9007199254740992.0); /* 53 bits */
}

double mgs_rng_normal(mgs_rng *r) {
  /* Box-Muller; u1 in (0,1] so log is finite. */
  double u1 = 1.0 - mgs_rng_uniform(r), u2 = mgs_rng_uniform(r);
  return sqrt(-2.0 * log(u1)) * cos(6.283185307179586 * u2);
}

uint32_t mgs_rng_below(mgs_rng *r, uint32_t n) {
  if (n == 0) return 0;
  uint32_t threshold = (uint32_t)(-n) % n; /* rejection removes modulo bias */
  for (;;) {
    uint32_t x = mgs_rng_u32(r);
    if (x >= threshold) return x % n;
  }
}

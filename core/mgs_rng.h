/* Seeded, reproducible random numbers (PCG32). The same seed gives the same stream on
 * every machine. Not thread-safe: give each thread its own stream (mgs_rng_init with
 * a different `stream`). */
#ifndef MGS_RNG_H
#define MGS_RNG_H
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct mgs_rng { uint64_t state, inc; } mgs_rng;

void mgs_rng_init(mgs_rng *r, uint64_t seed, uint64_t stream);
uint32_t mgs_rng_u32(mgs_rng *r);
double mgs_rng_uniform(mgs_rng *r);          /* [0, 1) */
double mgs_rng_normal(mgs_rng *r);           /* standard normal */
uint32_t mgs_rng_below(mgs_rng *r, uint32_t n); /* [0, n), unbiased */

#ifdef __cplusplus
}
#endif
#endif

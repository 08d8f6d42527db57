/* splitmix64 (Steele, Lea & Flood, OOPSLA 2014): a reproducible stream of 64-bit numbers, the same
 * on every platform, for the tests' random point clouds and states, and a uniform double in [0, 1)
 * from its top 53 bits. Header only (static inline: a test that uses one of the two gets no unused-
 * function warning for the other). */
#ifndef EJ_TEST_RNG_H
#define EJ_TEST_RNG_H

#include <stdint.h>

static inline uint64_t rng_next(uint64_t *s)
{
  uint64_t z = (*s += 0x9e3779b97f4a7c15ULL);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

static inline double rng_uniform(uint64_t *s) { return (double)(rng_next(s) >> 11) * 0x1.0p-53; }

#endif

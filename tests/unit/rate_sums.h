/* Momentum and energy rate sums of a set for the conservation tests of the particle methods:
 * P = sum_i m_i a_i and E = sum_i m_i (v_i . a_i + de_i/dt), with the sums of the absolute terms
 * as their scales (exact conservation leaves round-off relative to them). Header only. */
#ifndef EJ_TEST_RATE_SUMS_H
#define EJ_TEST_RATE_SUMS_H

#include <math.h>

#include "ejecta/plugin.h"

typedef struct rate_sums {
  double P[3], Pabs; /* momentum rate and its scale */
  double E, Eabs;    /* energy rate and its scale */
} rate_sums;

static inline rate_sums rate_sums_of(ej_idx n, const ej_real *m, const ej_real *v, const ej_real *a,
                                     const ej_real *edot)
{
  rate_sums r = {{0, 0, 0}, 0, 0, 0};
  for (ej_idx i = 0; i < n; ++i) {
    for (int d = 0; d < 3; ++d) {
      r.P[d] += m[i] * a[3 * i + d];
      r.Pabs += fabs(m[i] * a[3 * i + d]);
      r.E += m[i] * v[3 * i + d] * a[3 * i + d];
      r.Eabs += fabs(m[i] * v[3 * i + d] * a[3 * i + d]);
    }
    r.E += m[i] * edot[i];
    r.Eabs += fabs(m[i] * edot[i]);
  }
  return r;
}

#endif

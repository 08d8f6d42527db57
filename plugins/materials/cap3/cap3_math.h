/* cap3's yield-surface pieces as pure functions of the principal stresses, with the first and
 * second derivatives its Newton return needs (the analytic Jacobian of cap3.c's residual, whose
 * flow direction is built from the signed square of the shear function, c3_shear_sq);
 * tests/unit/test_cap3.c checks them against central differences. Tension positive, I1 = tr. */
#ifndef EJ_CAP3_MATH_H
#define EJ_CAP3_MATH_H

#include <math.h>
#include <stdbool.h>

#include "ejecta/plugin.h"

/* F_f^2 of 003 Eq 57 / 79 */
static inline ej_real c3_ff2(ej_real C, ej_real M, ej_real Xi, ej_real I1)
{
  const ej_real a = C - M * I1, b = C - M * Xi;
  return a * a - b * b;
}

/* Largest admissible I1 of the hyperbola (F_f = 0): Xi when C >= M Xi, else the other root
 * 2C/M - Xi of (C - M I1)^2 = (C - M Xi)^2 (Table 2's residual values have C_res < M Xi_max). */
static inline ej_real c3_tip_I1(ej_real C, ej_real M, ej_real Xi) { return C >= M * Xi ? Xi : 2 * C / M - Xi; }

/* The signed square P = S |S| = +-|F_c F_f^2| of the shear function S below (a polynomial in I1 on
 * each branch: finite slopes where S has a vertical tangent, at the tension and cap tips) and its
 * first and second derivatives in I1 (either pointer may be NULL). The sign is that of S: negative
 * outside the admissible I1 range. Beyond the tension tip (I1 > c3_tip_I1) it is negative although
 * F_f^2 = (C - M I1)^2 - (C - M Xi)^2 turns positive again there (the hyperbola's other branch,
 * mirrored about I1 = C/M; for the cone C = M Xi there is no negative band at all): taking that
 * branch as admissible let a point carry any hydrostatic tension (found 2026-11-30 with a
 * cohesionless cone, C = 1 Pa: 1.8 MPa of tension under a dilating strain path). */
static inline ej_real c3_shear_sq(ej_real C, ej_real M, ej_real Xi, ej_real kappa, ej_real X, bool cap, ej_real I1,
                                  ej_real *d1, ej_real *d2)
{
  const ej_real ff2 = c3_ff2(C, M, Xi, I1), dff2 = -2 * M * (C - M * I1), ddff2 = 2 * M * M;
  ej_real fc = 1, dfc = 0, ddfc = 0;
  if (cap && I1 < kappa) {
    const ej_real w = X - kappa, z = (I1 - kappa) / w;
    fc = 1 - z * z, dfc = -2 * z / w, ddfc = -2 / (w * w);
  }
  const ej_real Q = fc * ff2;
  const bool neg = fc < 0 || ff2 < 0 || I1 > c3_tip_I1(C, M, Xi);
  const ej_real k = (neg ? -1 : 1) * (Q < 0 ? -1 : 1);
  if (d1) *d1 = k * (dfc * ff2 + fc * dff2);
  if (d2) *d2 = k * (ddfc * ff2 + 2 * dfc * dff2 + fc * ddff2);
  return k * Q;
}

/* S = sqrt(F_c) F_f (Eqs 57, 58) as a signed, continuous function of I1 (negative outside the
 * admissible I1 range, so that f > 0 there: the sign of c3_shear_sq), with its derivative in I1
 * (d1 may be NULL): S = sgn(P) sqrt|P|, S' = P' / (2 sqrt|P|). At a root (the tips) the slope is
 * unbounded: taken large with P' 's sign. */
static inline ej_real c3_shear(ej_real C, ej_real M, ej_real Xi, ej_real kappa, ej_real X, bool cap, ej_real I1,
                               ej_real *d1)
{
  ej_real P1;
  const ej_real P = c3_shear_sq(C, M, Xi, kappa, X, cap, I1, d1 ? &P1 : NULL, NULL);
  const ej_real r = sqrt(fabs(P));
  if (d1) *d1 = P1 / (2 * fmax(r, 1e-300));
  return copysign(r, P);
}

/* Gamma sqrt(J2) from the invariants (the value c3_lode below returns). */
static inline ej_real c3_lode_inv(ej_real psi, ej_real J2, ej_real J3, ej_real scale)
{
  const ej_real rJ2 = sqrt(J2);
  if (!(rJ2 > 1e-13 * scale)) return rJ2 * 0.5 * (1 + 1 / psi);
  const ej_real S = fmin(fmax(-1.5 * sqrt(3.0) * J3 / (J2 * rJ2), -1.0), 1.0);
  return 0.5 * (1 + S + (1 - S) / psi) * rJ2;
}

static inline ej_real c3_lode(ej_real psi, const ej_real sg[3], ej_real grad[3], ej_real hess[3][3], ej_real scale)
{
  const ej_real m = (sg[0] + sg[1] + sg[2]) / 3;
  const ej_real sd[3] = {sg[0] - m, sg[1] - m, sg[2] - m};
  const ej_real J2 = 0.5 * (sd[0] * sd[0] + sd[1] * sd[1] + sd[2] * sd[2]), J3 = sd[0] * sd[1] * sd[2];
  const ej_real rJ2 = sqrt(J2);
  if (!(rJ2 > 1e-13 * scale)) {
    for (int A = 0; A < 3 && grad; ++A) grad[A] = 0;
    for (int A = 0; A < 3 && hess; ++A) hess[A][0] = hess[A][1] = hess[A][2] = 0;
    return rJ2 * 0.5 * (1 + 1 / psi);
  }
  ej_real S = -1.5 * sqrt(3.0) * J3 / (J2 * rJ2);
  S = fmin(fmax(S, -1.0), 1.0);
  const ej_real Gam = 0.5 * (1 + S + (1 - S) / psi), dGdS = 0.5 * (1 - 1 / psi);
  ej_real t[3];
  for (int A = 0; A < 3; ++A) t[A] = sd[A] * sd[A] - 2.0 / 3.0 * J2;
  if (grad) {
    for (int A = 0; A < 3; ++A) {
      const ej_real dS = -1.5 * sqrt(3.0) * (t[A] / (J2 * rJ2) - 1.5 * J3 * sd[A] / (J2 * J2 * rJ2));
      grad[A] = Gam * sd[A] / (2 * rJ2) + rJ2 * dGdS * dS;
    }
  }
  if (hess) {
    const ej_real a0 = 0.5 * (1 + 1 / psi), k = 0.75 * sqrt(3.0) * (1 - 1 / psi);
    for (int A = 0; A < 3; ++A)
      for (int B = 0; B < 3; ++B) {
        const ej_real P = (A == B) - 1.0 / 3.0;
        const ej_real T = 2 * sd[A] * (A == B) - 2.0 / 3.0 * (sd[A] + sd[B]);
        const ej_real hr = P / (2 * rJ2) - sd[A] * sd[B] / (4 * J2 * rJ2);
        const ej_real hq = T / J2 - (t[A] * sd[B] + sd[A] * t[B]) / (J2 * J2) - J3 * P / (J2 * J2) +
                           2 * J3 * sd[A] * sd[B] / (J2 * J2 * J2);
        hess[A][B] = a0 * hr - k * hq;
      }
  }
  return Gam * rJ2;
}

#endif

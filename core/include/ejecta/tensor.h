/* ejecta SDK: small 3x3 tensor helpers shared by methods and materials (header only).
 *
 * Storage: a 3x3 tensor is ej_real[9], row-major (A[3*i+j] = A_ij); a symmetric tensor is
 * ej_real[6] in Voigt order xx yy zz xy yz zx (tensor components, not engineering strains).
 * Every function is static inline so that pair loops inline them; none allocates.
 */
#ifndef EJ_TENSOR_H
#define EJ_TENSOR_H

#include <math.h>

#include "ejecta/plugin.h"

static inline void ej_m3_zero(ej_real A[9])
{
  for (int k = 0; k < 9; ++k) A[k] = 0;
}

static inline void ej_m3_identity(ej_real A[9])
{
  for (int k = 0; k < 9; ++k) A[k] = (k % 4 == 0) ? 1 : 0;
}

static inline void ej_m3_copy(ej_real B[9], const ej_real A[9])
{
  for (int k = 0; k < 9; ++k) B[k] = A[k];
}

/* C = A B (C may not alias A or B) */
static inline void ej_m3_mul(ej_real C[9], const ej_real A[9], const ej_real B[9])
{
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) C[3 * i + j] = A[3 * i] * B[j] + A[3 * i + 1] * B[3 + j] + A[3 * i + 2] * B[6 + j];
}

/* C = A B^T */
static inline void ej_m3_mul_bt(ej_real C[9], const ej_real A[9], const ej_real B[9])
{
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      C[3 * i + j] = A[3 * i] * B[3 * j] + A[3 * i + 1] * B[3 * j + 1] + A[3 * i + 2] * B[3 * j + 2];
}

/* C = A^T B */
static inline void ej_m3_mul_at(ej_real C[9], const ej_real A[9], const ej_real B[9])
{
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) C[3 * i + j] = A[i] * B[j] + A[3 + i] * B[3 + j] + A[6 + i] * B[6 + j];
}

static inline void ej_m3_transpose(ej_real B[9], const ej_real A[9])
{
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) B[3 * i + j] = A[3 * j + i];
}

static inline ej_real ej_m3_det(const ej_real A[9])
{
  return A[0] * (A[4] * A[8] - A[5] * A[7]) - A[1] * (A[3] * A[8] - A[5] * A[6]) + A[2] * (A[3] * A[7] - A[4] * A[6]);
}

static inline ej_real ej_m3_trace(const ej_real A[9]) { return A[0] + A[4] + A[8]; }

/* y = A x */
static inline void ej_m3_apply(ej_real y[3], const ej_real A[9], const ej_real x[3])
{
  for (int i = 0; i < 3; ++i) y[i] = A[3 * i] * x[0] + A[3 * i + 1] * x[1] + A[3 * i + 2] * x[2];
}

/* Frobenius norm */
static inline ej_real ej_m3_norm(const ej_real A[9])
{
  ej_real s = 0;
  for (int k = 0; k < 9; ++k) s += A[k] * A[k];
  return sqrt(s);
}

/* B = A^-1 by cofactors. Returns the reciprocal condition estimate
 * 1 / (|A|_F |A^-1|_F) in [0, 1/3]; 0 (and B untouched) when A is singular. Callers compare
 * it with their own threshold to detect an ill-conditioned shape tensor. */
static inline ej_real ej_m3_inverse(ej_real B[9], const ej_real A[9])
{
  const ej_real c00 = A[4] * A[8] - A[5] * A[7], c01 = A[5] * A[6] - A[3] * A[8], c02 = A[3] * A[7] - A[4] * A[6];
  const ej_real det = A[0] * c00 + A[1] * c01 + A[2] * c02;
  const ej_real na = ej_m3_norm(A);
  /* relative test: a rank-deficient A computes a det of round-off size, not exactly 0 */
  const ej_real scale = na / 1.7320508075688772;
  if (!(na > 0) || !(fabs(det) > 1e-12 * scale * scale * scale)) return 0;
  const ej_real id = 1 / det;
  ej_real T[9] = {c00 * id,
                  (A[2] * A[7] - A[1] * A[8]) * id,
                  (A[1] * A[5] - A[2] * A[4]) * id,
                  c01 * id,
                  (A[0] * A[8] - A[2] * A[6]) * id,
                  (A[2] * A[3] - A[0] * A[5]) * id,
                  c02 * id,
                  (A[1] * A[6] - A[0] * A[7]) * id,
                  (A[0] * A[4] - A[1] * A[3]) * id};
  const ej_real ni = ej_m3_norm(T);
  if (!isfinite(ni)) return 0;
  ej_m3_copy(B, T);
  return 1 / (na * ni);
}

/* Symmetric and skew parts: d = (L + L^T)/2 as Voigt, w = (L - L^T)/2 as 3x3. */
static inline void ej_m3_sym(ej_real d[6], const ej_real L[9])
{
  d[0] = L[0], d[1] = L[4], d[2] = L[8];
  d[3] = 0.5 * (L[1] + L[3]), d[4] = 0.5 * (L[5] + L[7]), d[5] = 0.5 * (L[2] + L[6]);
}

static inline void ej_m3_skew(ej_real w[9], const ej_real L[9])
{
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) w[3 * i + j] = 0.5 * (L[3 * i + j] - L[3 * j + i]);
}

static inline void ej_s6_to_m3(ej_real A[9], const ej_real s[6])
{
  A[0] = s[0], A[4] = s[1], A[8] = s[2];
  A[1] = A[3] = s[3];
  A[5] = A[7] = s[4];
  A[2] = A[6] = s[5];
}

static inline void ej_m3_to_s6(ej_real s[6], const ej_real A[9])
{
  s[0] = A[0], s[1] = A[4], s[2] = A[8];
  s[3] = 0.5 * (A[1] + A[3]), s[4] = 0.5 * (A[5] + A[7]), s[5] = 0.5 * (A[2] + A[6]);
}

static inline ej_real ej_s6_trace(const ej_real s[6]) { return s[0] + s[1] + s[2]; }

/* a : b for symmetric tensors in Voigt storage (shear terms counted twice) */
static inline ej_real ej_s6_ddot(const ej_real a[6], const ej_real b[6])
{
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + 2 * (a[3] * b[3] + a[4] * b[4] + a[5] * b[5]);
}

/* Deviator s = a - tr(a)/3 I; returns the mean tr(a)/3. */
static inline ej_real ej_s6_dev(ej_real s[6], const ej_real a[6])
{
  const ej_real m = (a[0] + a[1] + a[2]) / 3;
  s[0] = a[0] - m, s[1] = a[1] - m, s[2] = a[2] - m;
  s[3] = a[3], s[4] = a[4], s[5] = a[5];
  return m;
}

/* sqrt(J2) of a symmetric tensor (J2 = s:s/2 of its deviator) */
static inline ej_real ej_s6_sqrt_j2(const ej_real a[6])
{
  ej_real s[6];
  ej_s6_dev(s, a);
  return sqrt(0.5 * ej_s6_ddot(s, s));
}

/* B = Q A Q^T for a symmetric A (Voigt in, Voigt out; B may alias A). */
static inline void ej_s6_rotate(ej_real B[6], const ej_real Q[9], const ej_real A[6])
{
  ej_real M[9], T[9], R[9];
  ej_s6_to_m3(M, A);
  ej_m3_mul(T, Q, M);
  ej_m3_mul_bt(R, T, Q);
  ej_m3_to_s6(B, R);
}

/* Hughes–Winget incremental rotation for alpha = 1/2:
 *   Q = (I - dt w / 2)^-1 (I + dt w / 2),
 * w the spin (skew part of the velocity gradient at the mid-step). Q is orthogonal for a
 * skew w; a stress is carried to the new configuration as Q sigma Q^T (000 Eqs 78-94 with
 * the transpose erratum of Eq 93 in its digest). Returns 0 if the left factor is singular. */
static inline int ej_hughes_winget(ej_real Q[9], const ej_real w[9], ej_real dt)
{
  ej_real A[9], B[9], Ai[9];
  for (int k = 0; k < 9; ++k) {
    const ej_real I = (k % 4 == 0) ? 1 : 0;
    A[k] = I - 0.5 * dt * w[k];
    B[k] = I + 0.5 * dt * w[k];
  }
  if (ej_m3_inverse(Ai, A) == 0) return 0;
  ej_m3_mul(Q, Ai, B);
  return 1;
}

/* Eigen-decomposition of a symmetric tensor (cyclic Jacobi, converged to round-off):
 * A = sum_k lam[k] v_k v_k^T with v_k = column k of V (row-major: V[3*i+k] = (v_k)_i), V a
 * rotation. Eigenvalues unsorted. Used by spectral (principal-stress) return mappings. */
static inline void ej_s6_eig(ej_real lam[3], ej_real V[9], const ej_real s[6])
{
  ej_real A[9];
  ej_s6_to_m3(A, s);
  ej_m3_identity(V);
  for (int sweep = 0; sweep < 50; ++sweep) {
    const ej_real off = A[1] * A[1] + A[2] * A[2] + A[5] * A[5];
    const ej_real dia = A[0] * A[0] + A[4] * A[4] + A[8] * A[8];
    if (!(off > 1e-36 * dia) || off == 0) break;
    for (int p = 0; p < 2; ++p)
      for (int q = p + 1; q < 3; ++q) {
        const ej_real apq = A[3 * p + q];
        if (apq == 0) continue;
        const ej_real th = (A[3 * q + q] - A[3 * p + p]) / (2 * apq);
        const ej_real t = (th >= 0 ? 1 : -1) / (fabs(th) + sqrt(th * th + 1));
        const ej_real c = 1 / sqrt(t * t + 1), sn = t * c;
        for (int k = 0; k < 3; ++k) { /* A <- A J (columns p, q) */
          const ej_real akp = A[3 * k + p], akq = A[3 * k + q];
          A[3 * k + p] = c * akp - sn * akq, A[3 * k + q] = sn * akp + c * akq;
        }
        for (int k = 0; k < 3; ++k) { /* A <- J^T A (rows p, q) */
          const ej_real apk = A[3 * p + k], aqk = A[3 * q + k];
          A[3 * p + k] = c * apk - sn * aqk, A[3 * q + k] = sn * apk + c * aqk;
        }
        for (int k = 0; k < 3; ++k) { /* V <- V J */
          const ej_real vkp = V[3 * k + p], vkq = V[3 * k + q];
          V[3 * k + p] = c * vkp - sn * vkq, V[3 * k + q] = sn * vkp + c * vkq;
        }
      }
  }
  lam[0] = A[0], lam[1] = A[4], lam[2] = A[8];
}

/* s = sum_k lam[k] v_k v_k^T (inverse of ej_s6_eig). */
static inline void ej_s6_from_eig(ej_real s[6], const ej_real lam[3], const ej_real V[9])
{
  ej_real A[9];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      A[3 * i + j] = lam[0] * V[3 * i] * V[3 * j] + lam[1] * V[3 * i + 1] * V[3 * j + 1] + lam[2] * V[3 * i + 2] * V[3 * j + 2];
  ej_m3_to_s6(s, A);
}

#endif /* EJ_TENSOR_H */

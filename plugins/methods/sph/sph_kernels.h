/* SPH smoothing kernels, support radius 2h, normalised in 1, 2 and 3 dimensions.
 *
 * Each kernel is split into a dimensionless shape f(q), q = r/h, and a normalisation sigma_d,
 * so that W(r, h) = sigma_d / h^d * f(q) and dW/dr = sigma_d / h^(d+1) * f'(q). The pair loop
 * of sph.c multiplies by 1/h^(d+1) itself (powers by multiplication, no pow()).
 *
 * Cubic spline (M4): Monaghan & Lattanzio, A&A 149 (1985) 135;
 *   f(q) = 1 - 3/2 q^2 + 3/4 q^3 (0 <= q < 1), 1/4 (2 - q)^3 (1 <= q < 2), 0 beyond;
 *   sigma = 2/3, 10/(7 pi), 1/pi in 1, 2, 3 D.
 * Wendland C2: Wendland, Adv. Comput. Math. 4 (1995) 389; normalisations for support 2h from
 *   Dehnen & Aly, MNRAS 425 (2012) 1068, Table 1 (rescaled from support H = 2h):
 *   3D and 2D: f(q) = (1 - q/2)^4 (2q + 1), sigma = 21/(16 pi), 7/(4 pi);
 *   1D (Wendland psi_{3,1}): f(q) = (1 - q/2)^3 (3/2 q + 1), sigma = 5/8.
 */
#ifndef EJ_SPH_KERNELS_H
#define EJ_SPH_KERNELS_H

#include "ejecta/plugin.h"

enum { SPH_KERNEL_CUBIC_SPLINE = 0, SPH_KERNEL_WENDLAND_C2 = 1 };

#define SPH_PI 3.14159265358979323846

/* sph geometry: spherical with spherical_energy: pair (README "Spherical symmetry"): a particle at
 * radius |x| >= this many smoothing lengths takes the exactly conservative pair form of the pdV work (u_ij = (r_i^2 v_i -
 * r_j^2 v_j)/r_i^2); nearer the axis the local form -2 (p/rho) v/r. `continuum` reads the same
 * constant so that the cross-set pairs of a spherical set follow the same switch. */
#define SPH_SPHERICAL_EXACT_R 4.0

/* sigma_d of the kernel (dim 1, 2 or 3). */
static inline ej_real sph_kernel_sigma(int kernel, int dim)
{
  if (kernel == SPH_KERNEL_CUBIC_SPLINE) {
    return dim == 1 ? 2.0 / 3.0 : dim == 2 ? 10.0 / (7.0 * SPH_PI) : 1.0 / SPH_PI;
  }
  return dim == 1 ? 5.0 / 8.0 : dim == 2 ? 7.0 / (4.0 * SPH_PI) : 21.0 / (16.0 * SPH_PI);
}

/* Shape f(q); dim only matters for the Wendland kernel (1D uses psi_{3,1}). */
static inline ej_real sph_kernel_f(int kernel, int dim, ej_real q)
{
  if (q >= 2.0) return 0.0;
  if (kernel == SPH_KERNEL_CUBIC_SPLINE) {
    if (q < 1.0) return 1.0 - 1.5 * q * q + 0.75 * q * q * q;
    const ej_real t = 2.0 - q;
    return 0.25 * t * t * t;
  }
  const ej_real t = 1.0 - 0.5 * q;
  if (dim == 1) return t * t * t * (1.5 * q + 1.0);
  const ej_real t2 = t * t;
  return t2 * t2 * (2.0 * q + 1.0);
}

/* Derivative f'(q) = df/dq (<= 0 on [0, 2)). Wendland: d/dq[t^4 (2q + 1)] = -5 q t^3 and
 * d/dq[t^3 (3/2 q + 1)] = -3 q t^2 with t = 1 - q/2, which vanish at q = 0 so the gradient is
 * smooth through r = 0. */
static inline ej_real sph_kernel_df(int kernel, int dim, ej_real q)
{
  /* Branch-free (t clamped at 0 beyond the support, both cubic pieces evaluated): in the
   * pair loop q jumps around unpredictably along a neighbour row. */
  if (kernel == SPH_KERNEL_CUBIC_SPLINE) {
    const ej_real t0 = 2.0 - q, t = t0 > 0.0 ? t0 : 0.0;
    const ej_real inner = q * (-3.0 + 2.25 * q), outer = -0.75 * t * t;
    return q < 1.0 ? inner : outer;
  }
  const ej_real t0 = 1.0 - 0.5 * q, t = t0 > 0.0 ? t0 : 0.0;
  if (dim == 1) return -3.0 * q * t * t;
  return -5.0 * q * t * t * t;
}

/* 1/h^n for n = 1..4 by multiplication. */
static inline ej_real sph_inv_pow(ej_real inv_h, int n)
{
  ej_real r = inv_h;
  for (int k = 1; k < n; ++k) r *= inv_h;
  return r;
}

/* W(r, h) and dW/dr (r >= 0, h > 0): the reference (non-hot-path) forms, used by tests and
 * setup code. */
static inline ej_real sph_kernel_w(int kernel, int dim, ej_real r, ej_real h)
{
  const ej_real inv_h = 1.0 / h;
  return sph_kernel_sigma(kernel, dim) * sph_inv_pow(inv_h, dim) * sph_kernel_f(kernel, dim, r * inv_h);
}

static inline ej_real sph_kernel_dw(int kernel, int dim, ej_real r, ej_real h)
{
  const ej_real inv_h = 1.0 / h;
  return sph_kernel_sigma(kernel, dim) * sph_inv_pow(inv_h, dim + 1) * sph_kernel_df(kernel, dim, r * inv_h);
}

/* One pair of the artificial conductivity (Price, J. Comput. Phys. 227 (2008) 10040, section 4),
 * shared by sph's own pairs and `continuum`'s cross-set pairs:
 *   m_j v_sig (e_i - e_j) / rhobar dW/dr,   v_sig = sqrt(|p_i - p_j| / rhobar), rhobar = (rho_i + rho_j)/2;
 * with line masses (geometry: spherical, 1D, x = r) the pair is weighted by rbar^2 / r_i^2, rbar =
 * (|r_i| + |r_j|)/2 (inv_ri2 = 1/r_i^2), so that m_i de_i = -m_j de_j with shell masses 4 pi r^2 mu. */
static inline ej_real sph_cond_pair(ej_real mj, ej_real pi, ej_real pj, ej_real rhoi, ej_real rhoj, ej_real ei,
                                    ej_real ej, bool line, ej_real ri_abs, ej_real rj_abs, ej_real inv_ri2,
                                    ej_real dwdr)
{
  const ej_real rhobar = 0.5 * (rhoi + rhoj);
  const ej_real vsig = sqrt(fabs(pi - pj) / rhobar);
  const ej_real rbar = 0.5 * (ri_abs + rj_abs);
  const ej_real geo = line ? rbar * rbar * inv_ri2 : 1.0;
  return mj * geo * vsig * (ei - ej) / rhobar * dwdr;
}

#endif /* EJ_SPH_KERNELS_H */

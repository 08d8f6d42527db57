/* Helpers shared by the material-point plugins drucker_prager, dp_cap, von_mises, johnson_cook
 * and soil_evp (header only, every function static inline; included by relative path so that
 * each plugin stays one folder = one shared object).
 *
 * Elastic constants: a scene gives either (E, nu) or (K, G). nu defaults to NaN so that "E
 * without nu" is caught by check_config instead of silently taking a default.
 * Stress: Cauchy, tension positive, Voigt xx yy zz xy yz zx with tensor shear components. */
#ifndef EJ_MP_COMMON_H
#define EJ_MP_COMMON_H

#include <math.h>
#include <stdio.h>

#include "ejecta/plugin.h"
#include "ejecta/tensor.h"

/* Four parameter-table rows for a config struct with fields E, nu, K, G. */
#define MP_ELASTIC_PARAMS(cfg)                                                                          \
  EJ_PARAM_REAL(cfg, E, "Pa", 0, 0, 0, EJ_PF_HAS_MIN,                                                    \
                "Young's modulus; give E with nu, or K with G (0 = not given)."),                       \
      EJ_PARAM_REAL(cfg, nu, "1", NAN, 0, 0, 0,                                                         \
                    "Poisson's ratio, -1 < nu < 0.5, required with E (leave out with K and G)."),         \
      EJ_PARAM_REAL(cfg, K, "Pa", 0, 0, 0, EJ_PF_HAS_MIN, "Bulk modulus, with G instead of E and nu (0 = not given)."), \
      EJ_PARAM_REAL(cfg, G, "Pa", 0, 0, 0, EJ_PF_HAS_MIN, "Shear modulus, with K instead of E and nu (0 = not given).")

/* Resolves (E, nu) or (K, G) into K and G. Returns NULL on success, else a message. */
static inline const char *mp_elastic_resolve(ej_real E, ej_real nu, ej_real K, ej_real G, ej_real *Ko, ej_real *Go)
{
  if (K > 0 || G > 0) {
    if (!(K > 0 && G > 0)) return "give both K and G (or E and nu)";
    if (E > 0 || !isnan(nu)) return "give either E and nu, or K and G, not both";
    *Ko = K, *Go = G;
    return NULL;
  }
  if (!(E > 0)) return "needs elastic constants: E and nu, or K and G";
  if (isnan(nu)) return "E needs Poisson's ratio nu";
  if (!(nu > -1 && nu < 0.5)) return "nu must lie in (-1, 0.5)";
  *Ko = E / (3 * (1 - 2 * nu));
  *Go = E / (2 * (1 + nu));
  return NULL;
}

/* check_config helper: reports the message of mp_elastic_resolve through the diagnostic. */
static inline ej_err mp_elastic_check(ej_real E, ej_real nu, ej_real K, ej_real G, ej_diag *diag)
{
  ej_real k, g;
  const char *msg = mp_elastic_resolve(E, nu, K, G, &k, &g);
  if (msg) return ej_diag_error(diag, isnan(nu) && E > 0 ? "E" : NULL, "%s", msg);
  return EJ_OK;
}

/* Hypoelastic trial stress sigma_tr = sigma_n + dt (lambda tr(d) I + 2 G d). */
static inline void mp_elastic_trial(ej_real tr[6], const ej_real sn[6], const ej_real d[6], ej_real K, ej_real G,
                                    ej_real dt)
{
  const ej_real lam = K - 2.0 * G / 3.0, dv = d[0] + d[1] + d[2];
  for (int k = 0; k < 6; ++k) tr[k] = sn[k] + dt * 2.0 * G * d[k];
  for (int k = 0; k < 3; ++k) tr[k] += dt * lam * dv;
}

/* Plastic strain increment of a return sigma_tr -> sigma (elastic compliance of the stress
 * correction): volumetric dev = (m_tr - m)/K (m = tr/3, dilation positive) and the deviatoric
 * part de = (s_tr - s)/(2G). Also returns the backward-Euler plastic work sigma : deps_p
 * (per unit volume) through *work. */
static inline void mp_plastic_increment(const ej_real tr[6], const ej_real s1[6], ej_real K, ej_real G,
                                        ej_real *dev, ej_real de[6], ej_real *work)
{
  ej_real str[6], s[6];
  const ej_real mtr = ej_s6_dev(str, tr), m = ej_s6_dev(s, s1);
  *dev = (mtr - m) / K;
  for (int k = 0; k < 6; ++k) de[k] = (str[k] - s[k]) / (2.0 * G);
  *work = m * *dev + ej_s6_ddot(s, de);
}

/* Duvaut-Lions overstress, backward Euler (Simo & Hughes, Computational Inelasticity, 1998,
 * §2.7, the viscoplastic regularisation): sigma = (sigma_tr + dt/tau sigma_qs) / (1 + dt/tau),
 * i.e. sigma = sigma_tr + theta (sigma_qs - sigma_tr) with theta below; internal variables
 * relax with the same theta. tau = 0 is the rate-independent limit (theta = 1). */
static inline ej_real mp_duvaut_lions_theta(ej_real dt, ej_real tau)
{
  if (!(tau > 0)) return 1.0;
  const ej_real r = dt / tau;
  return r / (1.0 + r);
}

/* Longitudinal (P-wave) sound speed of the hypoelastic solid. */
static inline ej_real mp_sound_speed(ej_real K, ej_real G, ej_real rho)
{
  return rho > 0 ? sqrt((K + 4.0 * G / 3.0) / rho) : 0.0;
}

#endif /* EJ_MP_COMMON_H */

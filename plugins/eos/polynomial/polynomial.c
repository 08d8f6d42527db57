/* Linear-polynomial equation of state (LS-DYNA *EOS_LINEAR_POLYNOMIAL, AUTODYN polynomial):
 *   p = C0 + C1 mu + C2 mu^2 + C3 mu^3 + (C4 + C5 mu + C6 mu^2) rho0 e,   mu = rho/rho0 - 1,
 * e specific internal energy (rho0 e is the energy per unit initial volume of the keyword).
 * In tension (mu < 0) the C2 mu^2 and C6 mu^2 terms are dropped when `tension_quadratic` is
 * false (default), as in the LS-DYNA keyword, so that a quadratic fit for compression does not
 * stiffen the material in tension (C3 mu^3 is kept). `tension: linear` instead drops C2, C3 and C6
 * in tension and adds an own quadratic tension coefficient T2 (the tension coefficients T1 = C1
 * and T2 of AUTODYN's polynomial EOS, as recalled, not re-checked):
 *   p = C0 + C1 mu + T2 mu^2 + (C4 + C5 mu) rho0 e            (mu < 0, tension: linear)
 * e.g. a Mie-Grueneisen EOS with a linear tension branch, p = (1 - gamma mu/2) rho0 C^2 mu + gamma rho e
 * for mu < 0 (PySPH's MieGruneisenEOS, pysph/sph/solid_mech/hvi.py), is C1 = rho0 C^2,
 * T2 = -gamma rho0 C^2 / 2, C4 = C5 = gamma. Linear use: C1 = K (and C4 = C5 = gamma0 for a
 * gamma-law energy term). Sound speed c^2 = dp/drho|_e + p/rho^2 dp/de|_rho, clamped at 0. */
#include <math.h>

#include "ejecta/plugin.h"

enum { POLY_TENSION_LS_DYNA = 0, POLY_TENSION_LINEAR = 1 };

typedef struct poly_config {
  ej_real rho0, C0, C1, C2, C3, C4, C5, C6;
  bool tension_quadratic;
  int tension;
  ej_real T2;
} poly_config;

static const char *const poly_tensions[] = {"ls_dyna", "linear", NULL};

static const ej_param poly_params[] = {
    EJ_PARAM_REAL(poly_config, rho0, "kg/m^3", 0, 0, 0, EJ_PF_REQUIRED | EJ_PF_HAS_MIN | EJ_PF_MIN_OPEN,
                  "Reference density of mu = rho/rho0 - 1 (give the material's rho0)."),
    EJ_PARAM_REAL(poly_config, C0, "Pa", 0, 0, 0, 0, "Constant term C0."),
    EJ_PARAM_REAL(poly_config, C1, "Pa", 0, 0, 0, 0, "Linear coefficient C1 (the bulk modulus for a linear EOS)."),
    EJ_PARAM_REAL(poly_config, C2, "Pa", 0, 0, 0, 0, "Quadratic coefficient C2."),
    EJ_PARAM_REAL(poly_config, C3, "Pa", 0, 0, 0, 0, "Cubic coefficient C3."),
    EJ_PARAM_REAL(poly_config, C4, "1", 0, 0, 0, 0, "Energy coefficient C4 (of rho0 e)."),
    EJ_PARAM_REAL(poly_config, C5, "1", 0, 0, 0, 0, "Energy coefficient C5 (of mu rho0 e)."),
    EJ_PARAM_REAL(poly_config, C6, "1", 0, 0, 0, 0, "Energy coefficient C6 (of mu^2 rho0 e)."),
    EJ_PARAM_BOOL(poly_config, tension_quadratic, false,
                  "Keep the C2 mu^2 and C6 mu^2 terms in tension (mu < 0); false drops them (LS-DYNA)."),
    EJ_PARAM_ENUM(poly_config, tension, poly_tensions, "ls_dyna",
                  "Tension branch (mu < 0): ls_dyna keeps C3 mu^3 (and C2, C6 with tension_quadratic); linear gives "
                  "p = C0 + C1 mu + T2 mu^2 + (C4 + C5 mu) rho0 e (C2, C3, C6 dropped; AUTODYN's T1 = C1, T2)."),
    EJ_PARAM_REAL(poly_config, T2, "Pa", 0, 0, 0, 0,
                  "Quadratic tension coefficient T2 of tension: linear (0 otherwise)."),
    {0}};

static ej_err poly_create(const void *config, void **state)
{
  EJ_ENSURE(config && state, EJ_ERR_ARG, "polynomial: NULL config or state");
  const poly_config *cfg = config;
  EJ_ENSURE(cfg->rho0 > 0, EJ_ERR_ARG, "polynomial: rho0 must be positive");
  if (cfg->tension != POLY_TENSION_LINEAR && cfg->T2 != 0)
    EJ_FAIL(EJ_ERR_INPUT, "polynomial: T2 is the tension coefficient of tension: linear (tension is ls_dyna)");
  if (cfg->tension == POLY_TENSION_LINEAR && cfg->tension_quadratic)
    EJ_FAIL(EJ_ERR_INPUT, "polynomial: tension_quadratic applies to tension: ls_dyna; with tension: linear give T2");
  poly_config *s = ej_malloc(sizeof *s);
  EJ_ENSURE(s, EJ_ERR_MEM, "polynomial: out of memory");
  *s = *cfg;
  *state = s;
  return EJ_OK;
}

static ej_err poly_evaluate(const void *state, ej_idx n, const ej_real *restrict rho, const ej_real *restrict e,
                            ej_real *restrict p, ej_real *restrict c)
{
  const poly_config *s = state;
  for (ej_idx i = 0; i < n; ++i) {
    const ej_real mu = rho[i] / s->rho0 - 1, E = s->rho0 * e[i];
    const bool lin = mu < 0 && s->tension == POLY_TENSION_LINEAR;
    const bool q = mu >= 0 || s->tension_quadratic;
    const ej_real C2 = lin ? s->T2 : q ? s->C2 : 0, C3 = lin ? 0 : s->C3, C6 = q ? s->C6 : 0;
    p[i] = s->C0 + mu * (s->C1 + mu * (C2 + mu * C3)) + (s->C4 + mu * (s->C5 + mu * C6)) * E;
    if (c) {
      const ej_real dpdmu = s->C1 + mu * (2 * C2 + 3 * mu * C3) + (s->C5 + 2 * mu * C6) * E;
      const ej_real dpde = (s->C4 + mu * (s->C5 + mu * C6)) * s->rho0;
      const ej_real c2 = dpdmu / s->rho0 + (rho[i] > 0 ? p[i] / (rho[i] * rho[i]) * dpde : 0.0);
      c[i] = sqrt(fmax(c2, 0.0));
    }
  }
  return EJ_OK;
}

static void poly_destroy(void *state) { ej_free(state); }

static const ej_eos_ops poly_ops = {
    .struct_size = sizeof(ej_eos_ops),
    .name = "polynomial",
    .summary = "Linear-polynomial EOS: p = C0 + C1 mu + C2 mu^2 + C3 mu^3 + (C4 + C5 mu + C6 mu^2) rho0 e",
    .doc = "LS-DYNA *EOS_LINEAR_POLYNOMIAL form with mu = rho/rho0 - 1 and e specific internal energy; C2 and C6 "
           "terms dropped in tension unless tension_quadratic is true; tension: linear gives p = C0 + C1 mu + "
           "T2 mu^2 + (C4 + C5 mu) rho0 e in tension instead.",
    .params = poly_params,
    .config_size = sizeof(poly_config),
    .check_config = NULL,
    .create = poly_create,
    .evaluate = poly_evaluate,
    .destroy = poly_destroy,
};

static ej_err poly_register(ej_registry *reg)
{
  EJ_TRY(ej_register_eos(reg, &poly_ops));
  return EJ_OK;
}

EJ_PLUGIN_DEFINE(polynomial, "0.1.0", "BSD-3-Clause", "Linear-polynomial equation of state", poly_register)

/* Mie-Grüneisen equation of state, shock (Us-up) form.
 *
 * Source: Chen et al., Appl. Math. Model. 99 (2021) 760-784, Eq 14 (digest 001 §2.2), the
 * LS-DYNA *EOS_GRUNEISEN form, with mu = rho/rho0 - 1:
 *   mu > 0:  p = rho0 C0^2 mu [1 + (1 - g0/2) mu - a mu^2/2]
 *                / [1 - (S1 - 1) mu - S2 mu^2/(mu + 1) - S3 mu^3/(mu + 1)^2]^2 + (g0 + a mu) rho0 e
 *   mu <= 0: p = rho0 C0^2 mu + (g0 + a mu) rho0 e
 * Erratum (digest 001 §2.2 and §6 item 6): the paper prints (g0 + a mu) E with E the specific
 * energy, which is not a pressure; E is energy per unit initial volume, so the term is
 * (g0 + a mu) rho0 e with e in J/kg. On the Hugoniot of Us = C0 + S1 up (S2 = S3 = 0, e = up^2/2)
 * the first branch gives p = rho0 Us up exactly, for any a (tested).
 * Sound speed: c^2 = dp/drho|_e + p/rho^2 dp/de|_rho (isentropic), analytic, clamped at 0. */
#include <math.h>

#include "ejecta/plugin.h"

typedef struct mg_config {
  ej_real rho0, C0, S1, S2, S3, gamma0, a;
} mg_config;

static const ej_param mg_params[] = {
    EJ_PARAM_REAL(mg_config, rho0, "kg/m^3", 0, 0, 0, EJ_PF_REQUIRED | EJ_PF_HAS_MIN | EJ_PF_MIN_OPEN,
                  "Reference density of mu = rho/rho0 - 1 (give the material's rho0)."),
    EJ_PARAM_REAL(mg_config, C0, "m/s", 0, 0, 0, EJ_PF_REQUIRED | EJ_PF_HAS_MIN | EJ_PF_MIN_OPEN,
                  "Bulk sound speed: intercept of the Us-up Hugoniot."),
    EJ_PARAM_REAL(mg_config, S1, "1", 0, 0, 0, EJ_PF_REQUIRED | EJ_PF_HAS_MIN, "Linear Us-up slope S1."),
    EJ_PARAM_REAL(mg_config, S2, "1", 0, 0, 0, 0, "Quadratic Us-up coefficient S2 (Us = C0 + S1 up + S2 up^2/Us + ...)."),
    EJ_PARAM_REAL(mg_config, S3, "1", 0, 0, 0, 0, "Cubic Us-up coefficient S3."),
    EJ_PARAM_REAL(mg_config, gamma0, "1", 0, 0, 0, EJ_PF_REQUIRED | EJ_PF_HAS_MIN, "Grüneisen coefficient gamma0."),
    EJ_PARAM_REAL(mg_config, a, "1", 0, 0, 0, 0, "First-order volume correction a of gamma (gamma0 + a mu)."),
    {0}};

static ej_err mg_create(const void *config, void **state)
{
  EJ_ENSURE(config && state, EJ_ERR_ARG, "mie_gruneisen: NULL config or state");
  const mg_config *cfg = config;
  EJ_ENSURE(cfg->rho0 > 0 && cfg->C0 > 0, EJ_ERR_ARG, "mie_gruneisen: rho0 and C0 must be positive");
  mg_config *s = ej_malloc(sizeof *s);
  EJ_ENSURE(s, EJ_ERR_MEM, "mie_gruneisen: out of memory");
  *s = *cfg;
  *state = s;
  return EJ_OK;
}

/* p and dp/dmu at fixed e. */
static void mg_p(const mg_config *s, ej_real mu, ej_real e, ej_real *p, ej_real *dpdmu)
{
  const ej_real r0c2 = s->rho0 * s->C0 * s->C0, g = s->gamma0 + s->a * mu;
  if (mu > 0) {
    const ej_real m1 = mu + 1;
    const ej_real N = r0c2 * mu * (1 + (1 - s->gamma0 / 2) * mu - s->a * mu * mu / 2);
    const ej_real dN = r0c2 * (1 + 2 * (1 - s->gamma0 / 2) * mu - 1.5 * s->a * mu * mu);
    const ej_real D = 1 - (s->S1 - 1) * mu - s->S2 * mu * mu / m1 - s->S3 * mu * mu * mu / (m1 * m1);
    const ej_real dD = -(s->S1 - 1) - s->S2 * (mu * mu + 2 * mu) / (m1 * m1) -
                       s->S3 * (mu * mu * mu + 3 * mu * mu) / (m1 * m1 * m1);
    *p = N / (D * D) + g * s->rho0 * e;
    *dpdmu = dN / (D * D) - 2 * N * dD / (D * D * D) + s->a * s->rho0 * e;
  } else {
    *p = r0c2 * mu + g * s->rho0 * e;
    *dpdmu = r0c2 + s->a * s->rho0 * e;
  }
}

static ej_err mg_evaluate(const void *state, ej_idx n, const ej_real *restrict rho, const ej_real *restrict e,
                          ej_real *restrict p, ej_real *restrict c)
{
  const mg_config *s = state;
  for (ej_idx i = 0; i < n; ++i) {
    const ej_real mu = rho[i] / s->rho0 - 1;
    ej_real dpdmu;
    mg_p(s, mu, e[i], &p[i], &dpdmu);
    if (c) {
      const ej_real dpde = (s->gamma0 + s->a * mu) * s->rho0;
      const ej_real c2 = dpdmu / s->rho0 + (rho[i] > 0 ? p[i] / (rho[i] * rho[i]) * dpde : 0.0);
      c[i] = sqrt(fmax(c2, 0.0));
    }
  }
  return EJ_OK;
}

static void mg_destroy(void *state) { ej_free(state); }

static const ej_eos_ops mg_ops = {
    .struct_size = sizeof(ej_eos_ops),
    .name = "mie_gruneisen",
    .summary = "Mie-Grüneisen EOS in the shock Us-up form (LS-DYNA *EOS_GRUNEISEN)",
    .doc = "Hugoniot reference from Us = C0 + S1 up + S2 up^2/Us + S3 up^3/Us^2, Grüneisen gamma0 + a mu, energy "
           "term (gamma0 + a mu) rho0 e (digest 001 erratum); linear tension branch rho0 C0^2 mu.",
    .params = mg_params,
    .config_size = sizeof(mg_config),
    .check_config = NULL,
    .create = mg_create,
    .evaluate = mg_evaluate,
    .destroy = mg_destroy,
};

static ej_err mg_register(ej_registry *reg)
{
  EJ_TRY(ej_register_eos(reg, &mg_ops));
  return EJ_OK;
}

EJ_PLUGIN_DEFINE(mie_gruneisen, "0.1.0", "BSD-3-Clause", "Mie-Grüneisen equation of state (Us-up form)", mg_register)

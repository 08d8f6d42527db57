/* Ideal-gas equation of state (gamma law).
 *
 *   p = (gamma - 1) rho e                     (ideal gas, e specific internal energy)
 *   c = sqrt(gamma p / rho)                   (isentropic sound speed, c^2 = dp/drho|_s)
 *
 * Reference: any gas-dynamics text, e.g. Toro, "Riemann Solvers and Numerical Methods for
 * Fluid Dynamics", 3rd ed. (2009), Eqs 1.46-1.48 and 3.7. */
#include <math.h>

#include "ejecta/plugin.h"

typedef struct ideal_gas_config {
  ej_real gamma;
} ideal_gas_config;

static const ej_param ideal_gas_params[] = {
    EJ_PARAM_REAL(ideal_gas_config, gamma, "1", 1.4, 1.0, 0.0, EJ_PF_HAS_MIN | EJ_PF_MIN_OPEN,
                  "Ratio of specific heats cp/cv (1.4 for air, 5/3 for a monatomic gas)."),
    {0}};

static ej_err ideal_gas_create(const void *config, void **state)
{
  EJ_ENSURE(config && state, EJ_ERR_ARG, "ideal_gas: NULL config or state");
  const ideal_gas_config *cfg = config;
  /* The parameter table already enforces gamma > 1; a direct caller may not have used it. */
  EJ_ENSURE(cfg->gamma > 1.0, EJ_ERR_ARG, "ideal_gas: gamma = %g must be > 1", cfg->gamma);
  ideal_gas_config *s = ej_malloc(sizeof *s);
  EJ_ENSURE(s, EJ_ERR_MEM, "ideal_gas: out of memory");
  *s = *cfg;
  *state = s;
  return EJ_OK;
}

static ej_err ideal_gas_evaluate(const void *state, ej_idx n, const ej_real *restrict rho,
                                 const ej_real *restrict e, ej_real *restrict p, ej_real *restrict c)
{
  const ideal_gas_config *s = state;
  const ej_real gm1 = s->gamma - 1.0, gamma = s->gamma;
  for (ej_idx i = 0; i < n; ++i) p[i] = gm1 * rho[i] * e[i];
  if (c) {
    /* c^2 = gamma p / rho = gamma (gamma - 1) e: written in e so that rho -> 0 cannot divide by
     * zero, and with max(e, 0) so that a (numerically) negative energy gives c = 0, not NaN. */
    const ej_real k = gamma * gm1;
    for (ej_idx i = 0; i < n; ++i) c[i] = sqrt(k * fmax(e[i], 0.0));
  }
  return EJ_OK;
}

static void ideal_gas_destroy(void *state) { ej_free(state); }

static const ej_eos_ops ideal_gas_ops = {
    .struct_size = sizeof(ej_eos_ops),
    .name = "ideal_gas",
    .summary = "Ideal gas (gamma law): p = (gamma - 1) rho e",
    .doc = "Pressure p = (gamma - 1) rho e and sound speed c = sqrt(gamma p / rho) = "
           "sqrt(gamma (gamma - 1) e), with e clamped at 0 for the sound speed.",
    .params = ideal_gas_params,
    .config_size = sizeof(ideal_gas_config),
    .check_config = NULL,
    .create = ideal_gas_create,
    .evaluate = ideal_gas_evaluate,
    .destroy = ideal_gas_destroy,
};

static ej_err ideal_gas_register(ej_registry *reg)
{
  EJ_TRY(ej_register_eos(reg, &ideal_gas_ops));
  return EJ_OK;
}

EJ_PLUGIN_DEFINE(ideal_gas, "0.1.0", "BSD-3-Clause", "Ideal-gas (gamma-law) equation of state",
                 ideal_gas_register)

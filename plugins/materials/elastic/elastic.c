/* Isotropic linear elasticity as a strength model: hypoelastic (rate form in the corotational
 * frame) or compressible neo-Hookean (from the deformation gradient).
 *
 * hypoelastic (000 Eqs 91-92, with a = lambda I (x) I + 2 mu II the constant isotropic tensor):
 *   sigma_n+1 = sigma_hat_n + dt (lambda tr(d) I + 2 mu d)
 * where sigma_hat_n is the stress at t_n already carried to the new configuration by the method
 * (Hughes-Winget, Lambda sigma Lambda^T: 000 Eq 93 with the transpose erratum in its digest),
 * and d the rotation-neutralised rate of deformation.
 *
 * neo_hookean (Bonet & Wood, "Nonlinear Continuum Mechanics for Finite Element Analysis",
 * 2nd ed. (2008), Eq 6.28):
 *   sigma = mu/J (b - I) + lambda ln(J)/J I,   b = F F^T,  J = det F
 * which reduces to lambda tr(eps) I + 2 mu eps for small strain. Needs F from the method.
 *
 * Sound speed (both): c = sqrt((K + 4G/3) / rho), the P-wave speed with the initial moduli
 * K = E / (3 (1 - 2 nu)), G = E / (2 (1 + nu)) and the current density. */
#include <math.h>

#include "ejecta/plugin.h"
#include "ejecta/tensor.h"

enum { ELASTIC_HYPO = 0, ELASTIC_NEO_HOOKEAN = 1 };
static const char *const elastic_formulations[] = {"hypoelastic", "neo_hookean", NULL};

typedef struct elastic_config {
  ej_real E, nu;
  int formulation;
} elastic_config;

typedef struct elastic_state {
  elastic_config cfg;
  ej_real lambda, mu, K, G;
} elastic_state;

/* The YAML key `model` selects the plugin itself (materials: {rock: {model: elastic, ...}}),
 * so the choice of formulation is called `formulation`. */
static const ej_param elastic_params[] = {
    EJ_PARAM_REAL(elastic_config, E, "Pa", 0, 0, 0, EJ_PF_REQUIRED | EJ_PF_HAS_MIN | EJ_PF_MIN_OPEN,
                  "Young's modulus."),
    EJ_PARAM_REAL(elastic_config, nu, "1", 0.25, -1.0, 0.5,
                  EJ_PF_HAS_MIN | EJ_PF_HAS_MAX | EJ_PF_MIN_OPEN | EJ_PF_MAX_OPEN,
                  "Poisson's ratio, in (-1, 0.5)."),
    EJ_PARAM_ENUM(elastic_config, formulation, elastic_formulations, "hypoelastic",
                  "hypoelastic: sigma_n+1 = rotated sigma_n + dt (lambda tr(d) I + 2 mu d) (needs an objective "
                  "rotation by the method); neo_hookean: sigma = mu/J (F F^T - I) + lambda ln(J)/J I from the "
                  "deformation gradient."),
    {0}};

static ej_err elastic_create(const void *config, void **state)
{
  EJ_ENSURE(config && state, EJ_ERR_ARG, "elastic: NULL config or state");
  const elastic_config *cfg = config;
  EJ_ENSURE(cfg->E > 0 && cfg->nu > -1 && cfg->nu < 0.5, EJ_ERR_ARG, "elastic: E = %g, nu = %g out of range",
            cfg->E, cfg->nu);
  EJ_ENSURE(cfg->formulation == ELASTIC_HYPO || cfg->formulation == ELASTIC_NEO_HOOKEAN, EJ_ERR_ARG,
            "elastic: formulation %d unknown", cfg->formulation);
  elastic_state *s = ej_calloc(1, sizeof *s);
  EJ_ENSURE(s, EJ_ERR_MEM, "elastic: out of memory");
  s->cfg = *cfg;
  s->G = s->mu = cfg->E / (2 * (1 + cfg->nu));
  s->K = cfg->E / (3 * (1 - 2 * cfg->nu));
  s->lambda = s->K - 2 * s->G / 3;
  *state = s;
  return EJ_OK;
}

static void elastic_destroy(void *state) { ej_free(state); }

static ej_err elastic_moduli(const void *state, ej_real *K, ej_real *G)
{
  const elastic_state *s = state;
  *K = s->K;
  *G = s->G;
  return EJ_OK;
}

static ej_err elastic_update(const void *state, ej_mat_batch *b)
{
  const elastic_state *s = state;
  const ej_real lam = s->lambda, mu = s->mu, M = s->K + 4 * s->G / 3;
  if (s->cfg.formulation == ELASTIC_HYPO) {
    EJ_ENSURE(b->d, EJ_ERR_ARG, "elastic: hypoelastic update needs the rate of deformation d");
    const ej_real dt = b->dt;
    for (ej_idx i = 0; i < b->n; ++i) {
      const ej_real *d = b->d + 6 * i;
      ej_real *sg = b->stress + 6 * i;
      const ej_real ltr = lam * (d[0] + d[1] + d[2]);
      for (int k = 0; k < 3; ++k) sg[k] += dt * (ltr + 2 * mu * d[k]);
      for (int k = 3; k < 6; ++k) sg[k] += dt * 2 * mu * d[k];
    }
  } else {
    EJ_ENSURE(b->F, EJ_ERR_ARG, "elastic: the neo_hookean formulation needs the deformation gradient F");
    for (ej_idx i = 0; i < b->n; ++i) {
      const ej_real *F = b->F + 9 * i;
      const ej_real J = ej_m3_det(F);
      if (!(J > 0)) EJ_FAIL(EJ_ERR_NUMERIC, "elastic: neo_hookean point %d has det F = %g", (int)i, J);
      ej_real Bm[9];
      ej_m3_mul_bt(Bm, F, F);
      ej_real *sg = b->stress + 6 * i;
      const ej_real a = mu / J, v = lam * log(J) / J;
      sg[0] = a * (Bm[0] - 1) + v, sg[1] = a * (Bm[4] - 1) + v, sg[2] = a * (Bm[8] - 1) + v;
      sg[3] = a * Bm[1], sg[4] = a * Bm[5], sg[5] = a * Bm[2];
    }
  }
  for (ej_idx i = 0; i < b->n; ++i) {
    if (b->c) b->c[i] = b->rho[i] > 0 ? sqrt(M / b->rho[i]) : 0;
    if (b->w_plastic) b->w_plastic[i] = 0;
  }
  return EJ_OK;
}

static const ej_material_ops elastic_ops = {
    .struct_size = sizeof(ej_material_ops),
    .name = "elastic",
    .summary = "Isotropic linear elasticity: hypoelastic (corotational rate form) or neo-Hookean",
    .doc = "Young's modulus E and Poisson's ratio nu; lambda = K - 2G/3, K = E/(3(1-2nu)), G = E/(2(1+nu)). "
           "hypoelastic: sigma_n+1 = sigma_hat_n + dt (lambda tr(d) I + 2 mu d), sigma_hat_n rotated by the "
           "method (Hughes-Winget); neo_hookean (Bonet & Wood Eq 6.28): sigma = mu/J (F F^T - I) + lambda "
           "ln(J)/J I. Sound speed sqrt((K + 4G/3)/rho). No history, no failure.",
    .params = elastic_params,
    .config_size = sizeof(elastic_config),
    .check_config = NULL,
    .n_hist = 0,
    .hist_names = NULL,
    .needs_eos = false,
    .create = elastic_create,
    .init_hist = NULL,
    .update = elastic_update,
    .destroy = elastic_destroy,
    .moduli = elastic_moduli,
};

static ej_err elastic_register(ej_registry *reg)
{
  EJ_TRY(ej_register_material(reg, &elastic_ops));
  return EJ_OK;
}

EJ_PLUGIN_DEFINE(elastic, "0.1.0", "BSD-3-Clause", "Isotropic linear elastic strength model", elastic_register)

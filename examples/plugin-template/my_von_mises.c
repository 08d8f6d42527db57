/* my_von_mises: an out-of-tree strength model built against an installed ejecta SDK.
 * Von Mises (J2) plasticity with linear isotropic hardening, integrated by the radial return
 * (J. C. Simo and T. J. R. Hughes, "Computational Inelasticity", Springer 1998, Box 3.1:
 * elastic predictor, trial yield function, return along the trial deviator), with a
 * hypoelastic volumetric part (no EOS needed):
 *
 *   s_tr   = s_n + 2 G dt dev(d)                         deviatoric trial stress
 *   f_tr   = |s_tr| - sqrt(2/3) (sigma_y + H eps_p,n)    trial yield function (|s| = sqrt(s:s))
 *   dgamma = f_tr / (2 G + 2 H / 3)        if f_tr > 0   plastic multiplier (Box 3.1, step 4)
 *   s      = s_tr - 2 G dgamma s_tr / |s_tr|
 *   eps_p  = eps_p,n + sqrt(2/3) dgamma                  equivalent plastic strain
 *   mean   = mean_n + K dt tr(d)
 *   w_p    = dgamma |s| / rho                            specific plastic work increment
 *
 * The stress handed in is already rotated to the new configuration by the method (objective
 * update), so the model works in the corotational frame. */
#include <math.h>

#include "ejecta/plugin.h"

typedef struct mvm_config {
  ej_real E, nu, yield_stress, hardening;
} mvm_config;

typedef struct mvm_state {
  mvm_config cfg;
  ej_real K, G;
} mvm_state;

/* One row per parameter: YAML key = C field, SI unit, default, bounds, flags, one-line doc.
 * From this table come validation (with file:line:col), `ejecta describe`, the generated
 * docs and the JSON schema. Defaults are those of a mild steel. */
static const ej_param mvm_params[] = {
    EJ_PARAM_REAL(mvm_config, E, "Pa", 0, 0, 0, EJ_PF_REQUIRED | EJ_PF_HAS_MIN | EJ_PF_MIN_OPEN,
                  "Young's modulus."),
    EJ_PARAM_REAL(mvm_config, nu, "1", 0.3, -1.0, 0.5,
                  EJ_PF_HAS_MIN | EJ_PF_HAS_MAX | EJ_PF_MIN_OPEN | EJ_PF_MAX_OPEN, "Poisson's ratio, in (-1, 0.5)."),
    EJ_PARAM_REAL(mvm_config, yield_stress, "Pa", 250e6, 0, 0, EJ_PF_HAS_MIN | EJ_PF_MIN_OPEN,
                  "Initial uniaxial yield stress sigma_y."),
    EJ_PARAM_REAL(mvm_config, hardening, "Pa", 0, 0, 0, EJ_PF_HAS_MIN,
                  "Linear isotropic hardening modulus H: yield stress sigma_y + H eps_p."),
    {0}};

/* History variables: the core allocates one scalar field per name (written to the output). */
static const char *const mvm_hist_names[] = {"eps_p"};

static ej_err mvm_create(const void *config, void **state)
{
  EJ_ENSURE(config && state, EJ_ERR_ARG, "my_von_mises: NULL config or state");
  const mvm_config *cfg = config;
  /* The table enforces these for scenes; a direct caller (a test) may not have used it. */
  EJ_ENSURE(cfg->E > 0 && cfg->nu > -1 && cfg->nu < 0.5 && cfg->yield_stress > 0 && cfg->hardening >= 0,
            EJ_ERR_ARG, "my_von_mises: parameters out of range");
  mvm_state *s = ej_calloc(1, sizeof *s);
  EJ_ENSURE(s, EJ_ERR_MEM, "my_von_mises: out of memory");
  s->cfg = *cfg;
  s->G = cfg->E / (2 * (1 + cfg->nu));
  s->K = cfg->E / (3 * (1 - 2 * cfg->nu));
  *state = s;
  return EJ_OK;
}

static void mvm_destroy(void *state) { ej_free(state); }

static ej_err mvm_moduli(const void *state, ej_real *K, ej_real *G)
{
  const mvm_state *s = state;
  *K = s->K;
  *G = s->G;
  return EJ_OK;
}

static ej_err mvm_update(const void *state, ej_mat_batch *b)
{
  const mvm_state *s = state;
  EJ_ENSURE(b->d, EJ_ERR_ARG, "my_von_mises: the update needs the rate of deformation d");
  const ej_real G = s->G, K = s->K, H = s->cfg.hardening, sy = s->cfg.yield_stress, dt = b->dt;
  const ej_real c2 = sqrt(2.0 / 3.0), M = K + 4 * G / 3;
  ej_real *eps_p = b->hist[0];
  for (ej_idx i = 0; i < b->n; ++i) {
    const ej_real *d = b->d + 6 * i;
    ej_real *sg = b->stress + 6 * i;
    const ej_real trd = d[0] + d[1] + d[2];
    const ej_real mean = (sg[0] + sg[1] + sg[2]) / 3 + K * dt * trd;
    /* Deviatoric trial stress; Voigt shear entries are tensor components (s_xy, not 2 s_xy). */
    ej_real st[6];
    for (int k = 0; k < 3; ++k) st[k] = sg[k] - (sg[0] + sg[1] + sg[2]) / 3 + 2 * G * dt * (d[k] - trd / 3);
    for (int k = 3; k < 6; ++k) st[k] = sg[k] + 2 * G * dt * d[k];
    const ej_real norm = sqrt(st[0] * st[0] + st[1] * st[1] + st[2] * st[2] +
                              2 * (st[3] * st[3] + st[4] * st[4] + st[5] * st[5]));
    const ej_real f = norm - c2 * (sy + H * eps_p[i]);
    ej_real dgamma = 0, scale = 1;
    if (f > 0) {
      dgamma = f / (2 * G + 2 * H / 3);
      scale = 1 - 2 * G * dgamma / norm;
      eps_p[i] += c2 * dgamma;
    }
    for (int k = 0; k < 3; ++k) sg[k] = scale * st[k] + mean;
    for (int k = 3; k < 6; ++k) sg[k] = scale * st[k];
    if (b->w_plastic) b->w_plastic[i] = b->rho[i] > 0 ? dgamma * scale * norm / b->rho[i] : 0;
    if (b->c) b->c[i] = b->rho[i] > 0 ? sqrt(M / b->rho[i]) : 0;
  }
  return EJ_OK;
}

static const ej_material_ops mvm_ops = {
    .struct_size = sizeof(ej_material_ops),
    .name = "my_von_mises",
    .summary = "Example out-of-tree plugin: von Mises plasticity with linear isotropic hardening",
    .doc = "Radial return (Simo & Hughes 1998, Box 3.1) on the corotational stress: deviatoric trial "
           "s_tr = s_n + 2G dt dev(d), yield |s| = sqrt(2/3)(sigma_y + H eps_p), plastic multiplier "
           "f_tr/(2G + 2H/3); hypoelastic mean stress K dt tr(d) (no EOS). History: eps_p. Sound speed "
           "sqrt((K + 4G/3)/rho). Built from examples/plugin-template against the installed SDK.",
    .params = mvm_params,
    .config_size = sizeof(mvm_config),
    .n_hist = 1,
    .hist_names = mvm_hist_names,
    .needs_eos = false,
    .create = mvm_create,
    .init_hist = NULL, /* eps_p starts at 0 */
    .update = mvm_update,
    .destroy = mvm_destroy,
    .moduli = mvm_moduli,
};

static ej_err mvm_register(ej_registry *reg)
{
  EJ_TRY(ej_register_material(reg, &mvm_ops));
  return EJ_OK;
}

/* The plugin's name (first argument) must match the file name ej_my_von_mises.so. */
EJ_PLUGIN_DEFINE(my_von_mises, "1.0.0", "BSD-3-Clause", "Example out-of-tree von Mises material", mvm_register)

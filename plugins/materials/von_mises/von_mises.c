/* von Mises (J2) plasticity with linear isotropic hardening, radial return.
 *
 *   s_tr = s_n + 2G dt dev(d),  sigma_eq = sqrt(3/2 s_tr:s_tr),  sigma_y = sigma_y0 + H eps_p
 *   deps_p = (sigma_eq - sigma_y) / (3G + H),  s = s_tr (1 - 3G deps_p / sigma_eq)
 * (Wilkins 1964 radial return; Simo & Hughes, Computational Inelasticity, 1998, Box 3.1; the
 * perfectly plastic case H = 0 is the "elastic-perfectly plastic" model of Chen et al. 2021
 * §3.3, digest 001 §2.3, Eq 17 with the trial J2).
 * Volumetric part (option `volumetric`): `elastic` adds K tr(d) dt to the mean stress
 * (self-contained); `eos` returns s - p I with p from the attached EOS (b->p, needs an eos in
 * the scene); `auto` (default) uses the EOS pressure when the method passes one. */
#include <math.h>
#include <string.h>

#include "../drucker_prager/mp_common.h"
#include "ejecta/plugin.h"

typedef struct vm_config {
  ej_real E, nu, K, G;
  ej_real yield_stress, H;
  int volumetric;
} vm_config;

typedef struct vm_state {
  vm_config cfg;
  ej_real K, G;
} vm_state;

enum { VM_VOL_AUTO, VM_VOL_ELASTIC, VM_VOL_EOS };
static const char *const vm_vol_choices[] = {"auto", "elastic", "eos", NULL};
static const char *const vm_hist_names[] = {"eps_p", NULL};

static const ej_param vm_params[] = {
    MP_ELASTIC_PARAMS(vm_config),
    EJ_PARAM_REAL(vm_config, yield_stress, "Pa", 0, 0, 0, EJ_PF_REQUIRED | EJ_PF_HAS_MIN,
                  "Initial yield stress sigma_y0 in uniaxial tension."),
    EJ_PARAM_REAL(vm_config, H, "Pa", 0, 0, 0, EJ_PF_HAS_MIN,
                  "Linear isotropic hardening modulus d sigma_y / d eps_p (0 = perfectly plastic)."),
    EJ_PARAM_ENUM(vm_config, volumetric, vm_vol_choices, "auto",
                  "Mean stress: elastic (K tr d), eos (-p from the attached EOS), auto (eos when one is attached)."),
    {0}};

static ej_err vm_check(const void *config, ej_diag *diag)
{
  const vm_config *c = config;
  return mp_elastic_check(c->E, c->nu, c->K, c->G, diag);
}

static ej_err vm_create(const void *config, void **state)
{
  EJ_ENSURE(config && state, EJ_ERR_ARG, "von_mises: NULL config or state");
  const vm_config *cfg = config;
  vm_state t = {.cfg = *cfg};
  const char *msg = mp_elastic_resolve(cfg->E, cfg->nu, cfg->K, cfg->G, &t.K, &t.G);
  EJ_ENSURE(!msg, EJ_ERR_ARG, "von_mises: %s", msg ? msg : "");
  vm_state *s = ej_malloc(sizeof *s);
  EJ_ENSURE(s, EJ_ERR_MEM, "von_mises: out of memory");
  *s = t;
  *state = s;
  return EJ_OK;
}

static ej_err vm_update(const void *state, ej_mat_batch *b)
{
  const vm_state *s = state;
  const ej_real K = s->K, G = s->G, H = s->cfg.H, sy0 = s->cfg.yield_stress;
  const bool use_eos = s->cfg.volumetric == VM_VOL_EOS || (s->cfg.volumetric == VM_VOL_AUTO && b->p);
  EJ_ENSURE(!use_eos || b->p, EJ_ERR_UNSUPPORTED,
            "von_mises: volumetric: eos needs an equation of state on the material (no pressure passed)");
  for (ej_idx i = 0; i < b->n; ++i) {
    ej_real *sig = b->stress + 6 * (size_t)i;
    const ej_real *d = b->d + 6 * (size_t)i;
    ej_real sn[6], dd[6], str[6];
    const ej_real m = ej_s6_dev(sn, sig), dv = ej_s6_dev(dd, d);
    for (int k = 0; k < 6; ++k) str[k] = sn[k] + 2 * G * b->dt * dd[k];
    const ej_real seq = sqrt(1.5 * ej_s6_ddot(str, str));
    ej_real *ep = &b->hist[0][i];
    const ej_real sy = sy0 + H * *ep;
    ej_real k = 1, dep = 0;
    if (seq > sy) {
      dep = (seq - sy) / (3 * G + H);
      k = 1 - 3 * G * dep / seq;
    }
    *ep += dep;
    const ej_real mean = use_eos ? -b->p[i] : m + K * dv * 3 * b->dt;
    for (int j = 0; j < 6; ++j) sig[j] = k * str[j];
    for (int j = 0; j < 3; ++j) sig[j] += mean;
    /* plastic work s:de_p = sigma_y(n+1) deps_p (backward Euler) */
    if (b->w_plastic) b->w_plastic[i] = b->rho[i] > 0 ? (sy + H * dep) * dep / b->rho[i] : 0.0;
    if (b->c) b->c[i] = mp_sound_speed(K, G, b->rho[i]);
  }
  return EJ_OK;
}

static ej_err vm_moduli(const void *state, ej_real *K, ej_real *G)
{
  const vm_state *s = state;
  *K = s->K, *G = s->G;
  return EJ_OK;
}

static void vm_destroy(void *state) { ej_free(state); }

/* ABI 1.9: `volumetric: eos` needs the material's EOS (auto takes it when there is one) */
static const char *vm_eos_required_by(const void *config)
{
  return ((const vm_config *)config)->volumetric == VM_VOL_EOS ? "volumetric" : NULL;
}

static const ej_material_ops vm_ops = {
    .struct_size = sizeof(ej_material_ops),
    .name = "von_mises",
    .summary = "J2 plasticity with linear isotropic hardening (radial return)",
    .doc = "Hypoelastic deviator with radial return to sigma_y0 + H eps_p; mean stress from K tr(d) or from the "
           "attached EOS (volumetric: auto | elastic | eos). History: eps_p.",
    .params = vm_params,
    .config_size = sizeof(vm_config),
    .check_config = vm_check,
    .n_hist = 1,
    .hist_names = vm_hist_names,
    .needs_eos = false,
    .create = vm_create,
    .init_hist = NULL,
    .update = vm_update,
    .destroy = vm_destroy,
    .moduli = vm_moduli,
    .eos_required_by = vm_eos_required_by,
};

static ej_err vm_register(ej_registry *reg)
{
  EJ_TRY(ej_register_material(reg, &vm_ops));
  return EJ_OK;
}

EJ_PLUGIN_DEFINE(von_mises, "0.1.0", "BSD-3-Clause", "von Mises plasticity with linear hardening", vm_register)

/* Elasto-viscoplastic granular soil (Dunatunga & Kamrin, J. Fluid Mech. 779 (2015) 483-513, the
 * mu(I) rheology with a disconnection density), as used by Chen et al., Appl. Math. Model. 99
 * (2021) §3.5, Eq 21 (digest 001 §2.5).
 *   sigma_tr = sigma_n + dt (K tr(d) I + 2G dev(d))        (the method has rotated sigma_n)
 *   1. rho < rho_c: sigma = 0 (disconnected)
 *   2. p_tr = -tr(sigma_tr)/3 < 0: sigma = 0 (no tension)
 *   3. tau_tr = sqrt(S_tr:S_tr/2), S0 = mu_s p_tr; tau_tr <= S0: elastic
 *      else tau = 2H/(B + sqrt(B^2 - 4H)), B = S2 + tau_tr + alpha, H = S2 tau_tr + S0 alpha,
 *      S2 = mu_2 p_tr, alpha = xi G dt sqrt(p_tr)
 *   4. sigma = (tau/tau_tr) S_tr - p_tr I                    (Eq 21)
 * Erratum (digest 001 §2.5 and §6 item 12): the paper prints alpha = xi G dt p_tr, which is not
 * a stress with xi in m^(1/2) kg^(-1/2); the D&K form is xi G dt sqrt(p_tr) (xi = I0/(d sqrt(rho_s))).
 * The quadratic is the backward-Euler form of tau = p [mu_s + (mu_2 - mu_s) g/(g + xi sqrt p)]
 * with g the plastic shear rate (tau_tr - tau = G dt g): in steady simple shear at rate g the
 * stress is exactly that value (tested). */
#include <math.h>
#include <string.h>

#include "../drucker_prager/mp_common.h"
#include "ejecta/plugin.h"

typedef struct evp_config {
  ej_real E, nu, K, G;
  ej_real rho_c, xi, mu_s, mu_2;
} evp_config;

typedef struct evp_state {
  evp_config cfg;
  ej_real K, G;
} evp_state;

static const char *const evp_hist_names[] = {"gamma_p", NULL};

static const ej_param evp_params[] = {
    MP_ELASTIC_PARAMS(evp_config),
    EJ_PARAM_REAL(evp_config, rho_c, "kg/m^3", 0, 0, 0, EJ_PF_HAS_MIN,
                  "Critical (disconnection) density: stress-free below it (001 Table 5: 500)."),
    EJ_PARAM_REAL(evp_config, xi, "1", 0, 0, 0, EJ_PF_REQUIRED | EJ_PF_HAS_MIN,
                  "Rate coefficient xi = I0/(d sqrt(rho_s)) in m^(1/2) kg^(-1/2) (SI number; 001 Table 5: 1.1233)."),
    EJ_PARAM_REAL(evp_config, mu_s, "1", 0, 0, 0, EJ_PF_REQUIRED | EJ_PF_HAS_MIN,
                  "Static friction coefficient mu_s (001 Table 5: 0.6419)."),
    EJ_PARAM_REAL(evp_config, mu_2, "1", 0, 0, 0, EJ_PF_REQUIRED | EJ_PF_HAS_MIN,
                  "Limiting friction coefficient mu_2 >= mu_s at high inertial number (001 Table 5: 0.8435)."),
    {0}};

static ej_err evp_check(const void *config, ej_diag *diag)
{
  const evp_config *c = config;
  EJ_TRY(mp_elastic_check(c->E, c->nu, c->K, c->G, diag));
  if (c->mu_2 < c->mu_s) return ej_diag_error(diag, "mu_2", "mu_2 must not be below mu_s");
  return EJ_OK;
}

static ej_err evp_create(const void *config, void **state)
{
  EJ_ENSURE(config && state, EJ_ERR_ARG, "soil_evp: NULL config or state");
  const evp_config *cfg = config;
  evp_state t = {.cfg = *cfg};
  const char *msg = mp_elastic_resolve(cfg->E, cfg->nu, cfg->K, cfg->G, &t.K, &t.G);
  EJ_ENSURE(!msg, EJ_ERR_ARG, "soil_evp: %s", msg ? msg : "");
  EJ_ENSURE(cfg->mu_2 >= cfg->mu_s, EJ_ERR_ARG, "soil_evp: mu_2 must not be below mu_s");
  evp_state *s = ej_malloc(sizeof *s);
  EJ_ENSURE(s, EJ_ERR_MEM, "soil_evp: out of memory");
  *s = t;
  *state = s;
  return EJ_OK;
}

static ej_err evp_update(const void *state, ej_mat_batch *b)
{
  const evp_state *s = state;
  const ej_real K = s->K, G = s->G;
  for (ej_idx i = 0; i < b->n; ++i) {
    ej_real *sig = b->stress + 6 * (size_t)i;
    ej_real tr[6], str[6];
    mp_elastic_trial(tr, sig, b->d + 6 * (size_t)i, K, G, b->dt);
    const ej_real ptr = -ej_s6_dev(str, tr);
    if (b->rho[i] < s->cfg.rho_c || ptr < 0) {
      memset(sig, 0, 6 * sizeof *sig); /* disconnected or in tension: stress free */
    } else {
      const ej_real ttr = sqrt(0.5 * ej_s6_ddot(str, str)), S0 = s->cfg.mu_s * ptr;
      ej_real k = 1;
      if (ttr > S0) {
        const ej_real S2 = s->cfg.mu_2 * ptr, alpha = s->cfg.xi * G * b->dt * sqrt(ptr); /* sqrt erratum */
        const ej_real B = S2 + ttr + alpha, H = S2 * ttr + S0 * alpha;
        const ej_real tau = 2 * H / (B + sqrt(fmax(B * B - 4 * H, 0.0)));
        k = tau / ttr;
      }
      for (int j = 0; j < 6; ++j) sig[j] = k * str[j];
      for (int j = 0; j < 3; ++j) sig[j] -= ptr;
    }
    ej_real dev, de[6], work;
    mp_plastic_increment(tr, sig, K, G, &dev, de, &work);
    b->hist[0][i] += sqrt(2 * ej_s6_ddot(de, de));
    if (b->w_plastic) b->w_plastic[i] = b->rho[i] > 0 ? work / b->rho[i] : 0.0;
    if (b->c) b->c[i] = mp_sound_speed(K, G, b->rho[i]);
  }
  return EJ_OK;
}

static ej_err evp_moduli(const void *state, ej_real *K, ej_real *G)
{
  const evp_state *s = state;
  *K = s->K, *G = s->G;
  return EJ_OK;
}

static void evp_destroy(void *state) { ej_free(state); }

static const ej_material_ops evp_ops = {
    .struct_size = sizeof(ej_material_ops),
    .name = "soil_evp",
    .summary = "Elasto-viscoplastic granular soil, mu(I) rheology (Dunatunga & Kamrin 2015; Chen et al. 2021)",
    .doc = "Hypoelastic trial stress; stress free below rho_c or in tension; shear stress from the backward-Euler "
           "mu(I) law tau = p [mu_s + (mu_2 - mu_s) g/(g + xi sqrt p)] (alpha = xi G dt sqrt p, digest 001 erratum). "
           "History: gamma_p (accumulated plastic shear strain).",
    .params = evp_params,
    .config_size = sizeof(evp_config),
    .check_config = evp_check,
    .n_hist = 1,
    .hist_names = evp_hist_names,
    .needs_eos = false,
    .create = evp_create,
    .init_hist = NULL,
    .update = evp_update,
    .destroy = evp_destroy,
    .moduli = evp_moduli,
};

static ej_err evp_register(ej_registry *reg)
{
  EJ_TRY(ej_register_material(reg, &evp_ops));
  return EJ_OK;
}

EJ_PLUGIN_DEFINE(soil_evp, "0.1.0", "BSD-3-Clause", "Elasto-viscoplastic granular soil (mu(I) rheology)", evp_register)

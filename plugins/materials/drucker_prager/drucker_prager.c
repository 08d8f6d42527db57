/* Drucker-Prager strength model, non-associated, with linear cohesion hardening, apex return,
 * optional tension cutoff and optional Duvaut-Lions overstress.
 *
 * Source: H. Fan, S. Li, CMAME 318 (2017) 349-381, §3 Eqs 43-59 (digest 000 §2.1):
 *   f = ||s|| - (A(phi) c - B(phi) p),  g = ||s|| - (A(psi) c - B(psi) p)          (Eqs 43-45)
 *   A(x) = 2 sqrt6 cos x / (3 + beta sin x),  B(x) = 2 sqrt6 sin x / (3 + beta sin x)
 * with p = tr(sigma)/3 the tension-positive mean stress (NOT the compression-positive pressure
 * of the core) and ||s|| = sqrt(s:s). beta = -1 puts the cone through the triaxial-compression
 * corners of Mohr-Coulomb (000 Table 2).
 * Return (single step, exact for this yield function and linear H_c):
 *   dgamma = f_tr / (2G + K B(phi) B(psi) + H_c A(phi)^2)                          (Eq 57)
 *   sigma  = sigma_tr - dgamma (K B(psi) I + 2G n),  n = s_tr/||s_tr||              (Eq 58, erratum:
 *            the printed bracket "(K B(psi)) I + 2G n" is misplaced; digest 000 §6 item 14)
 *   c      = c_n + dgamma H_c A(phi)                                                (Eq 59, h_c = A)
 * The apex is not treated in the paper [GAP]. Here: when the cone return would reverse the
 * deviator (2G dgamma > ||s_tr||) the point returns to the apex p = A c / B, s = 0 — for this
 * non-associated cone that is exactly the set of trial states whose flow lies in the
 * subdifferential of g at the apex (README). With a tension cutoff T below the apex the
 * tension region returns to p = T with the deviator kept or, at the cone/cutoff corner,
 * scaled to the cone radius there. Apex and corner returns do not harden c. */
#include <math.h>
#include <string.h>

#include "ejecta/plugin.h"
#include "mp_common.h"

typedef struct dp_config {
  ej_real E, nu, K, G;
  ej_real friction_angle, dilation_angle, cohesion, beta, H_c, tension_cutoff, relaxation_time;
} dp_config;

typedef struct dp_state {
  dp_config cfg;
  ej_real K, G, A_phi, B_phi, B_psi;
} dp_state;

enum { DP_H_EPS_P, DP_H_EPS_V, DP_H_COH, DP_NHIST };
static const char *const dp_hist_names[] = {"eps_p", "eps_v_p", "cohesion", NULL};

static const ej_param dp_params[] = {
    MP_ELASTIC_PARAMS(dp_config),
    EJ_PARAM_REAL(dp_config, friction_angle, "deg", 30, 0, 90, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX | EJ_PF_MAX_OPEN,
                  "Friction angle phi of the yield cone (000 Eq 43)."),
    EJ_PARAM_REAL(dp_config, dilation_angle, "deg", 0, 0, 90, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX | EJ_PF_MAX_OPEN,
                  "Dilation angle psi of the plastic potential (non-associated; psi = phi is associated)."),
    EJ_PARAM_REAL(dp_config, cohesion, "Pa", 0, 0, 0, EJ_PF_HAS_MIN, "Initial cohesion c."),
    EJ_PARAM_REAL(dp_config, beta, "1", -1, -1, 1, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX,
                  "Cone fit to Mohr-Coulomb: -1 triaxial-compression corners, +1 triaxial-extension corners."),
    EJ_PARAM_REAL(dp_config, H_c, "Pa", 0, 0, 0, 0,
                  "Linear cohesion hardening modulus H^c (000 Eq 59: dc = H^c A(phi) dgamma); negative softens."),
    EJ_PARAM_REAL(dp_config, tension_cutoff, "Pa", INFINITY, 0, 0, EJ_PF_HAS_MIN,
                  "Largest tensile mean stress tr(sigma)/3; inf = none (the cone apex A c / B limits tension)."),
    EJ_PARAM_REAL(dp_config, relaxation_time, "s", 0, 0, 0, EJ_PF_HAS_MIN,
                  "Duvaut-Lions overstress relaxation time; 0 = rate independent."),
    {0}};

static ej_real dp_A(ej_real x, ej_real beta) { return 2 * sqrt(6.0) * cos(x) / (3 + beta * sin(x)); }
static ej_real dp_B(ej_real x, ej_real beta) { return 2 * sqrt(6.0) * sin(x) / (3 + beta * sin(x)); }

static ej_err dp_check(const void *config, ej_diag *diag)
{
  const dp_config *c = config;
  EJ_TRY(mp_elastic_check(c->E, c->nu, c->K, c->G, diag));
  if (c->dilation_angle > c->friction_angle)
    return ej_diag_error(diag, "dilation_angle", "dilation_angle must not exceed friction_angle");
  if (c->H_c < 0 && c->cohesion <= 0)
    return ej_diag_error(diag, "H_c", "cohesion softening (H_c < 0) needs a positive cohesion");
  return EJ_OK;
}

static ej_err dp_create(const void *config, void **state)
{
  EJ_ENSURE(config && state, EJ_ERR_ARG, "drucker_prager: NULL config or state");
  const dp_config *cfg = config;
  dp_state tmp = {.cfg = *cfg};
  const char *msg = mp_elastic_resolve(cfg->E, cfg->nu, cfg->K, cfg->G, &tmp.K, &tmp.G);
  EJ_ENSURE(!msg, EJ_ERR_ARG, "drucker_prager: %s", msg ? msg : "");
  EJ_ENSURE(cfg->dilation_angle <= cfg->friction_angle, EJ_ERR_ARG,
            "drucker_prager: dilation_angle must not exceed friction_angle");
  tmp.A_phi = dp_A(cfg->friction_angle, cfg->beta);
  tmp.B_phi = dp_B(cfg->friction_angle, cfg->beta);
  tmp.B_psi = dp_B(cfg->dilation_angle, cfg->beta);
  dp_state *s = ej_malloc(sizeof *s);
  EJ_ENSURE(s, EJ_ERR_MEM, "drucker_prager: out of memory");
  *s = tmp;
  *state = s;
  return EJ_OK;
}

static ej_err dp_init_hist(const void *state, ej_idx n, ej_real *const *hist)
{
  const dp_state *s = state;
  for (ej_idx i = 0; i < n; ++i) {
    hist[DP_H_EPS_P][i] = 0;
    hist[DP_H_EPS_V][i] = 0;
    hist[DP_H_COH][i] = s->cfg.cohesion;
  }
  return EJ_OK;
}

/* Rate-independent return of the trial stress tr with cohesion c (in/out). Returns true when the
 * trial state is elastic (out = tr, c unchanged), false after a return. */
static bool dp_return(const dp_state *s, const ej_real tr[6], ej_real out[6], ej_real *c)
{
  const ej_real K = s->K, G = s->G, A = s->A_phi, B = s->B_phi, Bp = s->B_psi, H = s->cfg.H_c;
  ej_real str[6];
  const ej_real ptr = ej_s6_dev(str, tr);
  const ej_real qtr = sqrt(ej_s6_ddot(str, str));
  const ej_real apex = B > 0 ? A * *c / B : INFINITY;
  const ej_real T = fmin(s->cfg.tension_cutoff, apex);
  const ej_real ftr = qtr - (A * *c - B * ptr);
  memcpy(out, tr, 6 * sizeof *out);
  if (ftr <= 0 && ptr <= T) return true; /* elastic */
  if (ftr > 0) {
    const ej_real dg = ftr / (2 * G + K * B * Bp + H * A * A); /* Eq 57 */
    const ej_real p1 = ptr - K * Bp * dg, c1 = *c + H * A * dg;
    if (2 * G * dg <= qtr && p1 <= fmin(s->cfg.tension_cutoff, B > 0 ? A * c1 / B : INFINITY)) {
      const ej_real k = 1 - 2 * G * dg / qtr; /* Eq 58 (corrected) */
      for (int j = 0; j < 6; ++j) out[j] = k * str[j];
      for (int j = 0; j < 3; ++j) out[j] += p1;
      *c = c1; /* Eq 59 */
      return false;
    }
  }
  /* Tension region: apex (T = A c / B), cutoff plane, or the cone/cutoff corner. */
  const ej_real qmax = fmax(A * *c - B * T, 0.0);
  const ej_real k = qtr > qmax ? qmax / qtr : 1.0;
  for (int j = 0; j < 6; ++j) out[j] = k * str[j];
  for (int j = 0; j < 3; ++j) out[j] += T;
  return false;
}

static ej_err dp_update(const void *state, ej_mat_batch *b)
{
  const dp_state *s = state;
  const ej_real K = s->K, G = s->G;
  const ej_real theta = mp_duvaut_lions_theta(b->dt, s->cfg.relaxation_time);
  for (ej_idx i = 0; i < b->n; ++i) {
    ej_real *sig = b->stress + 6 * (size_t)i;
    ej_real tr[6], qs[6];
    mp_elastic_trial(tr, sig, b->d + 6 * (size_t)i, K, G, b->dt);
    ej_real c = b->hist[DP_H_COH][i];
    if (dp_return(s, tr, qs, &c)) {
      /* elastic predictor kept (the usual case): sigma = sigma_tr, and the history, plastic work
       * and increments below would all be exact zeros (sigma_tr - sigma = 0), so skip them */
      memcpy(sig, tr, 6 * sizeof *sig);
      if (b->w_plastic) b->w_plastic[i] = 0.0;
      if (b->c) b->c[i] = mp_sound_speed(K, G, b->rho[i]);
      continue;
    }
    /* Duvaut-Lions: sigma = sigma_tr + theta (sigma_qs - sigma_tr); theta = 1 rate independent. */
    for (int k = 0; k < 6; ++k) sig[k] = tr[k] + theta * (qs[k] - tr[k]);
    b->hist[DP_H_COH][i] += theta * (c - b->hist[DP_H_COH][i]);
    ej_real dev, de[6], work;
    mp_plastic_increment(tr, sig, K, G, &dev, de, &work);
    b->hist[DP_H_EPS_V][i] += dev;
    b->hist[DP_H_EPS_P][i] += sqrt(2.0 / 3.0 * ej_s6_ddot(de, de));
    if (b->w_plastic) b->w_plastic[i] = b->rho[i] > 0 ? work / b->rho[i] : 0.0;
    if (b->c) b->c[i] = mp_sound_speed(K, G, b->rho[i]);
  }
  return EJ_OK;
}

static ej_err dp_moduli(const void *state, ej_real *K, ej_real *G)
{
  const dp_state *s = state;
  *K = s->K, *G = s->G;
  return EJ_OK;
}

static void dp_destroy(void *state) { ej_free(state); }

static const ej_material_ops dp_ops = {
    .struct_size = sizeof(ej_material_ops),
    .name = "drucker_prager",
    .summary = "Non-associated Drucker-Prager with cohesion hardening, apex return, tension cutoff",
    .doc = "Hypoelastic (K, G) trial stress and the single-step return of Fan & Li (2017) Eqs 57-59 on the cone "
           "||s|| = A(phi) c - B(phi) tr(sigma)/3, flow along ||s|| + B(psi) tr(sigma)/3; apex and tension-cutoff "
           "returns; optional Duvaut-Lions overstress (relaxation_time). History: eps_p (equivalent plastic "
           "strain), eps_v_p (volumetric plastic strain, dilation positive), cohesion.",
    .params = dp_params,
    .config_size = sizeof(dp_config),
    .check_config = dp_check,
    .n_hist = DP_NHIST,
    .hist_names = dp_hist_names,
    .needs_eos = false,
    .create = dp_create,
    .init_hist = dp_init_hist,
    .update = dp_update,
    .destroy = dp_destroy,
    .moduli = dp_moduli,
};

static ej_err dp_register(ej_registry *reg)
{
  EJ_TRY(ej_register_material(reg, &dp_ops));
  return EJ_OK;
}

EJ_PLUGIN_DEFINE(drucker_prager, "0.1.0", "BSD-3-Clause", "Drucker-Prager strength model (Fan & Li 2017)",
                 dp_register)

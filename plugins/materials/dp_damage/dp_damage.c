/* Non-associated Drucker-Prager with linear hardening of A and scalar damage, after Chi et al.,
 * SERDP MR-2628 (2017) §4.2.1 Eqs 50-56 and §5.1.1 Eqs 88-91 (digest 003 §2.1).
 *
 *   f = sqrt(2 J2) + beta p - A,  g = sqrt(2 J2) + b p - A        (Eqs 50, 53; p = tr(sigma_hat)/3,
 *                                                                   tension positive, sqrt(2J2) = ||s||)
 *   beta = 2 sqrt6 sin(phi)/(3 - sin(phi)),  A = 2 sqrt6 c cos(phi)/(3 - sin(phi))   (Eqs 51-52;
 *          erratum 003 §7 item 8: c outside the square root), b likewise from psi (Eq 54)
 *   dA = H_alpha dlambda                                          (Eq 91)
 * Return (one step, exact for the linear cone): dlambda = f_tr / (2G + K beta b + H_alpha),
 *   sigma_hat = sigma_tr - dlambda (2G n + K b I); apex p = A/beta when 2G dlambda > ||s_tr||.
 * Damage (Eq 55 with the 1/3 erratum, 003 §7 item 9: the split is on the mean stress p_hat):
 *   sigma = (1 - d) s_hat + [(1 - d) <p_hat>+ + <p_hat>-] I
 *   d = c1 (eta - c2) / (eta (c1 - c2)) for eta >= c2 (Eq 56; 003 §7 item 10: c2 = initiation,
 *       c1 = full damage), eta = sqrt(e : e) the norm of the total deviatoric strain,
 *       d non-decreasing and capped at d_max < 1 (neither stated in the report).
 * The method hands in the rotated damaged stress sigma_n; the effective stress is recovered by
 * inverting Eq 55 (exact for d < 1), so the method's objective rotation carries over. */
#include <math.h>
#include <string.h>

#include "ejecta/plugin.h"
#include "../drucker_prager/mp_common.h"

typedef struct dd_config {
  ej_real E, nu, K, G;
  ej_real A, beta, b, friction_angle, dilation_angle, cohesion, H_alpha;
  ej_real c1, c2, d_max;
  bool damage;
} dd_config;

typedef struct dd_state {
  dd_config cfg;
  ej_real K, G, A0, beta, b;
} dd_state;

enum { DD_H_EPS_P, DD_H_EPS_V, DD_H_A, DD_H_D, DD_H_ETA, DD_H_E0, DD_NHIST = DD_H_E0 + 6 };
static const char *const dd_hist_names[] = {"eps_p",    "eps_v_p",  "dp_A",     "damage",   "dmg_eta",  "dmg_e_xx",
                                            "dmg_e_yy", "dmg_e_zz", "dmg_e_xy", "dmg_e_yz", "dmg_e_zx", NULL};

static const ej_param dd_params[] = {
    MP_ELASTIC_PARAMS(dd_config),
    EJ_PARAM_REAL(dd_config, A, "Pa", 0, 0, 0, EJ_PF_HAS_MIN,
                  "Cohesion constant A of f = sqrt(2 J2) + beta p - A (003 Eq 50; the tables' 'cohesion strength'); "
                  "or give friction_angle and cohesion."),
    EJ_PARAM_REAL(dd_config, beta, "1", 0, 0, 2.4, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX,
                  "Friction constant beta of the yield cone (003 Eq 50); or give friction_angle."),
    EJ_PARAM_REAL(dd_config, b, "1", 0, 0, 2.4, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX,
                  "Dilatancy constant b of the plastic potential (003 Eq 53), b <= beta; or give dilation_angle."),
    EJ_PARAM_REAL(dd_config, friction_angle, "deg", NAN, 0, 0, 0,
                  "Friction angle phi: sets beta and (with cohesion) A by 003 Eqs 51-52 (leave out to give beta)."),
    EJ_PARAM_REAL(dd_config, dilation_angle, "deg", NAN, 0, 0, 0,
                  "Dilation angle psi: sets b by 003 Eq 54 (with friction_angle; default 0)."),
    EJ_PARAM_REAL(dd_config, cohesion, "Pa", 0, 0, 0, EJ_PF_HAS_MIN,
                  "Cohesion c (with friction_angle): A = 2 sqrt6 c cos phi / (3 - sin phi), 003 Eq 52."),
    EJ_PARAM_REAL(dd_config, H_alpha, "Pa", 0, 0, 0, 0,
                  "Linear hardening modulus of A, dA = H_alpha dlambda (003 Eq 91); negative softens (A >= 0 kept)."),
    EJ_PARAM_REAL(dd_config, c1, "1", 1.0, 0, 0, EJ_PF_HAS_MIN | EJ_PF_MIN_OPEN,
                  "Deviatoric strain norm at full damage (003 Eq 56, Tables 7/10 'second parameter')."),
    EJ_PARAM_REAL(dd_config, c2, "1", 0.05, 0, 0, EJ_PF_HAS_MIN,
                  "Deviatoric strain norm at damage initiation (003 Eq 56, Tables 7/10 'first parameter'), c2 < c1."),
    EJ_PARAM_REAL(dd_config, d_max, "1", 0.99, 0, 0.999999, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX,
                  "Largest damage (keeps a residual shear stiffness and Eq 55 invertible)."),
    EJ_PARAM_BOOL(dd_config, damage, 1, "Scalar damage on (003 Eqs 55-56); off = plain Drucker-Prager."),
    {0}};

static ej_real dd_cone(ej_real x) { return 2 * sqrt(6.0) * sin(x) / (3 - sin(x)); } /* 003 Eq 51/54 */

static ej_err dd_check(const void *config, ej_diag *diag)
{
  const dd_config *c = config;
  EJ_TRY(mp_elastic_check(c->E, c->nu, c->K, c->G, diag));
  if (!isnan(c->friction_angle)) {
    if (!(c->friction_angle >= 0 && c->friction_angle < M_PI / 2))
      return ej_diag_error(diag, "friction_angle", "friction_angle must lie in [0, 90) deg");
    if (c->beta > 0 || c->A > 0)
      return ej_diag_error(diag, "friction_angle", "give friction_angle and cohesion, or beta and A, not both");
    if (!isnan(c->dilation_angle) && !(c->dilation_angle >= 0 && c->dilation_angle <= c->friction_angle))
      return ej_diag_error(diag, "dilation_angle", "dilation_angle must lie in [0, friction_angle]");
  } else {
    if (!isnan(c->dilation_angle))
      return ej_diag_error(diag, "dilation_angle", "dilation_angle needs friction_angle (else give b)");
    if (c->cohesion > 0) return ej_diag_error(diag, "cohesion", "cohesion needs friction_angle (else give A)");
    if (c->b > c->beta) return ej_diag_error(diag, "b", "b must not exceed beta");
  }
  if (!(c->c2 < c->c1)) return ej_diag_error(diag, "c2", "damage initiation c2 must be below c1");
  return EJ_OK;
}

static ej_err dd_create(const void *config, void **state)
{
  EJ_ENSURE(config && state, EJ_ERR_ARG, "dp_damage: NULL config or state");
  const dd_config *cfg = config;
  dd_state tmp = {.cfg = *cfg};
  const char *msg = mp_elastic_resolve(cfg->E, cfg->nu, cfg->K, cfg->G, &tmp.K, &tmp.G);
  EJ_ENSURE(!msg, EJ_ERR_ARG, "dp_damage: %s", msg ? msg : "");
  if (!isnan(cfg->friction_angle)) {
    const ej_real phi = cfg->friction_angle, psi = isnan(cfg->dilation_angle) ? 0 : cfg->dilation_angle;
    tmp.beta = dd_cone(phi);
    tmp.b = dd_cone(psi);
    tmp.A0 = 2 * sqrt(6.0) * cfg->cohesion * cos(phi) / (3 - sin(phi)); /* Eq 52 (erratum 8) */
  } else {
    tmp.beta = cfg->beta, tmp.b = cfg->b, tmp.A0 = cfg->A;
  }
  EJ_ENSURE(cfg->c2 < cfg->c1, EJ_ERR_ARG, "dp_damage: c2 must be below c1");
  dd_state *s = ej_malloc(sizeof *s);
  EJ_ENSURE(s, EJ_ERR_MEM, "dp_damage: out of memory");
  *s = tmp;
  *state = s;
  return EJ_OK;
}

static ej_err dd_init_hist(const void *state, ej_idx n, ej_real *const *hist)
{
  const dd_state *s = state;
  for (int k = 0; k < DD_NHIST; ++k)
    for (ej_idx i = 0; i < n; ++i) hist[k][i] = (k == DD_H_A) ? s->A0 : 0;
  return EJ_OK;
}

/* Rate-independent return of the effective trial stress (A in/out, dlambda out). */
static void dd_return(const dd_state *s, const ej_real tr[6], ej_real out[6], ej_real *A, ej_real *dlam)
{
  const ej_real K = s->K, G = s->G, be = s->beta, b = s->b, H = s->cfg.H_alpha;
  ej_real str[6];
  const ej_real ptr = ej_s6_dev(str, tr), qtr = sqrt(ej_s6_ddot(str, str));
  const ej_real ftr = qtr + be * ptr - *A; /* Eq 50 */
  memcpy(out, tr, 6 * sizeof *out);
  *dlam = 0;
  if (ftr <= 0) return;
  const ej_real dl = ftr / (2 * G + K * be * b + H);
  if (2 * G * dl <= qtr || !(be > 0)) {
    /* Cone: sigma = sigma_tr - dl (2G n + K b I), dA = H dl (Eqs 53, 91). */
    const ej_real A1 = fmax(*A + H * dl, 0.0);
    const ej_real k = qtr > 0 ? fmax(1 - 2 * G * dl / qtr, 0.0) : 0.0;
    for (int j = 0; j < 6; ++j) out[j] = k * str[j];
    for (int j = 0; j < 3; ++j) out[j] += ptr - K * b * dl;
    *A = A1, *dlam = dl;
    return;
  }
  /* Apex p = A / beta, s = 0 (no hardening there; documented). */
  for (int j = 0; j < 6; ++j) out[j] = 0;
  for (int j = 0; j < 3; ++j) out[j] = *A / be;
}

/* Eq 56 (erratum item 10: c2 initiation, c1 full damage), non-decreasing, capped at d_max. */
static ej_real dd_damage_of(const dd_config *c, ej_real eta)
{
  if (eta <= c->c2) return 0;
  return fmin(c->c1 * (eta - c->c2) / (eta * (c->c1 - c->c2)), c->d_max);
}

static ej_err dd_update(const void *state, ej_mat_batch *b)
{
  const dd_state *s = state;
  const ej_real K = s->K, G = s->G;
  for (ej_idx i = 0; i < b->n; ++i) {
    ej_real *sig = b->stress + 6 * (size_t)i;
    const ej_real *d = b->d + 6 * (size_t)i;
    const ej_real d0 = b->hist[DD_H_D][i];
    /* Effective stress at t_n: Eq 55 inverted (d0 <= d_max < 1). */
    ej_real sn[6], dev[6];
    const ej_real pbar = ej_s6_dev(dev, sig);
    const ej_real ph = pbar > 0 ? pbar / (1 - d0) : pbar;
    for (int k = 0; k < 6; ++k) sn[k] = dev[k] / (1 - d0);
    for (int k = 0; k < 3; ++k) sn[k] += ph;
    ej_real tr[6], hat[6];
    mp_elastic_trial(tr, sn, d, K, G, b->dt);
    ej_real A = b->hist[DD_H_A][i], dl;
    dd_return(s, tr, hat, &A, &dl);
    b->hist[DD_H_A][i] = A;
    ej_real dv, de[6], work;
    mp_plastic_increment(tr, hat, K, G, &dv, de, &work);
    b->hist[DD_H_EPS_V][i] += dv;
    b->hist[DD_H_EPS_P][i] += sqrt(2.0 / 3.0 * ej_s6_ddot(de, de));
    /* Total strain (hypoelastic integral of d) and eta = ||e_dev|| (Eq 56). */
    ej_real e[6], edev[6];
    for (int k = 0; k < 6; ++k) e[k] = (b->hist[DD_H_E0 + k][i] += b->dt * d[k]);
    ej_s6_dev(edev, e);
    const ej_real eta = sqrt(ej_s6_ddot(edev, edev));
    b->hist[DD_H_ETA][i] = eta;
    const ej_real dn = s->cfg.damage ? fmax(d0, dd_damage_of(&s->cfg, eta)) : 0;
    b->hist[DD_H_D][i] = dn;
    /* Eq 55 with the 1/3 erratum: degrade the deviator and a tensile mean stress only. */
    const ej_real phat = ej_s6_dev(dev, hat);
    const ej_real pout = phat > 0 ? (1 - dn) * phat : phat;
    for (int k = 0; k < 6; ++k) sig[k] = (1 - dn) * dev[k];
    for (int k = 0; k < 3; ++k) sig[k] += pout;
    if (b->w_plastic) b->w_plastic[i] = b->rho[i] > 0 ? (1 - dn) * work / b->rho[i] : 0.0;
    if (b->c) b->c[i] = mp_sound_speed(K, G, b->rho[i]);
  }
  return EJ_OK;
}

static ej_err dd_moduli(const void *state, ej_real *K, ej_real *G)
{
  const dd_state *s = state;
  *K = s->K, *G = s->G;
  return EJ_OK;
}

static void dd_destroy(void *state) { ej_free(state); }

static const ej_material_ops dd_ops = {
    .struct_size = sizeof(ej_material_ops),
    .name = "dp_damage",
    .summary = "Non-associated Drucker-Prager with linear hardening and scalar damage (Chi et al. 2017)",
    .doc = "Hypoelastic trial stress, single-step return on the cone sqrt(2J2) + beta p - A (003 Eqs 50-54, 88-91), "
           "apex return, hardening dA = H_alpha dlambda; scalar damage d(eta) of the total deviatoric strain norm "
           "(Eq 56) degrading the deviator and tensile mean stress (Eq 55 with the 1/3 erratum). History: eps_p, "
           "eps_v_p, dp_A, damage, dmg_eta, total strain dmg_e_*.",
    .params = dd_params,
    .config_size = sizeof(dd_config),
    .check_config = dd_check,
    .n_hist = DD_NHIST,
    .hist_names = dd_hist_names,
    .needs_eos = false,
    .create = dd_create,
    .init_hist = dd_init_hist,
    .update = dd_update,
    .destroy = dd_destroy,
    .moduli = dd_moduli,
};

static ej_err dd_register(ej_registry *reg)
{
  EJ_TRY(ej_register_material(reg, &dd_ops));
  return EJ_OK;
}

EJ_PLUGIN_DEFINE(dp_damage, "0.1.0", "BSD-3-Clause", "Drucker-Prager with scalar damage (Chi et al. 2017)",
                 dd_register)

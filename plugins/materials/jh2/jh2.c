/* Johnson-Holmquist 2 (JH2) strength, damage and bulking for brittle solids (rock, ceramics),
 * with the rate-dependent principal-stress tension failure of Zhu & Zhao (seed 002).
 *
 * Digest 002 §2 (seed 002 Sec. 2.2, Eqs 19-36), with its flags resolved as the digest recommends:
 *   strengths (Eqs 21-23), p* = p/p_HEL, T* = T/p_HEL, R = 1 + C ln(epsdot/epsdot0):
 *     sigma_i* = A (p* + T*)^N R      intact     (capped at simax when simax > 0)
 *     sigma_f* = B p*^M R             fractured  (capped at sfmax when sfmax > 0; 0 for p* <= 0)
 *     sigma_y  = sigma_HEL (sigma_i* - D (sigma_i* - sigma_f*)),  sigma_HEL = 3/2 (HEL - p_HEL)
 *   epsdot = sqrt(2/3 d':d'), the deviatoric rate of deformation (Eq 24; [FLAG] "strain" read as
 *     its rate); epsdot* clamped at >= 1 unless rate_clamp: false (digest [FLAG], most codes clamp).
 *   return: radial, deps_p = (s_tr - sigma_y)/(3G) (digest [REC] for Eqs 31-34, whose projection
 *     is ambiguous); D at t_n in the strength (explicit, as the paper's algorithm).
 *   damage: D += deps_p / eps_f, eps_f = max(D1 (p* + T*)^D2, efmin) (Eqs 29-30: digest [FLAG],
 *     the sum of ratios of standard JH2, not the printed sum over the current eps_f).
 *   bulking (Eqs 26-28): dp_{n+1} = -K1 mu + sqrt((K1 mu + dp_n)^2 + 2 beta K1 dU),
 *     dU = U(D_n) - U(D_n+1) >= 0, U = sigma_y^2/(6G); mu = rho/rho0 - 1, K1 the bulk modulus.
 *   pressure (compression positive; digest [REC] for the contradictory Eq 35): p = p_EOS + dp with
 *     p_EOS from the attached EOS, or, without one, the polynomial of Eq 25,
 *     K1 mu + K2 mu^2 + K3 mu^3 (mu >= 0), K1 mu (mu < 0); stress = s - p I (tension positive).
 *   tension: cutoff (Johnson & Holmquist 1994): p >= -T (1 - D); fail (002 Sec. 2.2 / step 5 of
 *     Sec. 2.7): p < -T fails the point.
 *   damage_failure (002 Sec. 2.4 (i)): D reaching 1 fails the point; otherwise the fractured
 *     strength carries on (standard JH2).
 *   tension model (002 Eqs 37-38, in tension-positive form, digest §3): the point fails when its
 *     largest principal stress exceeds tension_strength max(1, epsdot/tension_rate0)^tension_C1.
 * A failed point (history `failed` = 1) carries no shear and no tension, p = max(p_EOS, 0), and
 * sets b->failed every step (a PD method then breaks its bonds: point failure).
 * Sound speed: sqrt((K_t + 4G/3)/rho), K_t = max(K1, dp/dmu) of the polynomial (digest §2.2
 * [REC]: the 002 EOS has dp/dmu < 0 for 0.004184 < mu < 0.005817). */
#include <math.h>
#include <string.h>

#include "../drucker_prager/mp_common.h"
#include "ejecta/plugin.h"

typedef struct jh2_config {
  ej_real E, nu, K, G;
  ej_real rho0, K2, K3;
  ej_real HEL, p_HEL, A, N, B, M, C, eps_dot0, T, simax, sfmax;
  ej_real beta, D1, D2, efmin;
  bool rate_clamp, damage_failure;
  int tension;
  ej_real tension_strength, tension_rate0, tension_C1;
} jh2_config;

typedef struct jh2_state {
  jh2_config cfg;
  ej_real K, G, s_hel;
} jh2_state;

enum { JH2_TENSION_CUTOFF, JH2_TENSION_FAIL };
static const char *const jh2_tension_choices[] = {"cutoff", "fail", NULL};
enum { JH2_H_D, JH2_H_EPS_P, JH2_H_DP, JH2_H_FAILED, JH2_NHIST };
static const char *const jh2_hist_names[] = {"damage", "eps_p", "dp_bulk", "jh2_failed", NULL};

#define JH2_POS (EJ_PF_REQUIRED | EJ_PF_HAS_MIN | EJ_PF_MIN_OPEN)
static const ej_param jh2_params[] = {
    MP_ELASTIC_PARAMS(jh2_config),
    EJ_PARAM_REAL(jh2_config, rho0, "kg/m^3", 0, 0, 0, JH2_POS,
                  "Reference density of mu = rho/rho0 - 1 (give the material's rho0)."),
    EJ_PARAM_REAL(jh2_config, K2, "Pa", 0, 0, 0, 0, "Polynomial EOS K2 mu^2 (mu >= 0), used when no EOS is attached."),
    EJ_PARAM_REAL(jh2_config, K3, "Pa", 0, 0, 0, 0, "Polynomial EOS K3 mu^3 (mu >= 0), used when no EOS is attached."),
    EJ_PARAM_REAL(jh2_config, HEL, "Pa", 0, 0, 0, JH2_POS, "Hugoniot elastic limit HEL."),
    EJ_PARAM_REAL(jh2_config, p_HEL, "Pa", 0, 0, 0, JH2_POS, "Pressure at the HEL (below HEL)."),
    EJ_PARAM_REAL(jh2_config, A, "1", 0, 0, 0, JH2_POS, "Intact strength constant A."),
    EJ_PARAM_REAL(jh2_config, N, "1", 0, 0, 0, JH2_POS, "Intact strength exponent N."),
    EJ_PARAM_REAL(jh2_config, B, "1", 0, 0, 0, EJ_PF_HAS_MIN, "Fractured strength constant B."),
    EJ_PARAM_REAL(jh2_config, M, "1", 1, 0, 0, EJ_PF_HAS_MIN | EJ_PF_MIN_OPEN, "Fractured strength exponent M."),
    EJ_PARAM_REAL(jh2_config, C, "1", 0, 0, 0, EJ_PF_HAS_MIN, "Strain-rate coefficient C (0 = rate independent)."),
    EJ_PARAM_REAL(jh2_config, eps_dot0, "1/s", 1, 0, 0, EJ_PF_HAS_MIN | EJ_PF_MIN_OPEN,
                  "Reference strain rate of epsdot* = epsdot/eps_dot0."),
    EJ_PARAM_REAL(jh2_config, T, "Pa", 0, 0, 0, JH2_POS, "Maximum hydrostatic tensile strength T."),
    EJ_PARAM_REAL(jh2_config, simax, "1", 0, 0, 0, EJ_PF_HAS_MIN,
                  "Cap of the normalised intact strength sigma_i* (0 = no cap)."),
    EJ_PARAM_REAL(jh2_config, sfmax, "1", 0, 0, 0, EJ_PF_HAS_MIN,
                  "Cap of the normalised fractured strength sigma_f* (0 = no cap)."),
    EJ_PARAM_REAL(jh2_config, beta, "1", 1, 0, 1, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX,
                  "Bulking: fraction of the elastic energy lost to damage converted to pressure (0 = no bulking)."),
    EJ_PARAM_REAL(jh2_config, D1, "1", 0, 0, 0, JH2_POS, "Damage constant D1 of eps_f = D1 (p* + T*)^D2."),
    EJ_PARAM_REAL(jh2_config, D2, "1", 1, 0, 0, EJ_PF_HAS_MIN, "Damage exponent D2."),
    EJ_PARAM_REAL(jh2_config, efmin, "1", 0, 0, 0, EJ_PF_HAS_MIN,
                  "Least plastic strain to fracture (0: none; at p* <= -T* a plastic increment then fractures at once)."),
    EJ_PARAM_BOOL(jh2_config, rate_clamp, true,
                  "Clamp epsdot* >= 1 in the rate term (false: strength falls below the quasi-static one at low rates)."),
    EJ_PARAM_ENUM(jh2_config, tension, jh2_tension_choices, "cutoff",
                  "Hydrostatic tension: cutoff (p >= -T (1 - D), Johnson & Holmquist 1994) or fail (p < -T fails the point, "
                  "Zhu & Zhao Sec. 2.2)."),
    EJ_PARAM_BOOL(jh2_config, damage_failure, false,
                  "The point fails when D reaches 1 (Zhu & Zhao Sec. 2.4); false keeps the fractured strength."),
    EJ_PARAM_REAL(jh2_config, tension_strength, "Pa", 0, 0, 0, EJ_PF_HAS_MIN,
                  "Static tensile strength of the principal-stress tension model (Zhu & Zhao Eqs 37-38); 0 = off."),
    EJ_PARAM_REAL(jh2_config, tension_rate0, "1/s", 1, 0, 0, EJ_PF_HAS_MIN | EJ_PF_MIN_OPEN,
                  "Rate threshold of the tension model: strength x (epsdot/tension_rate0)^tension_C1 above it."),
    EJ_PARAM_REAL(jh2_config, tension_C1, "1", 0, 0, 0, EJ_PF_HAS_MIN, "Rate exponent of the tension model."),
    {0}};

static ej_err jh2_check(const void *config, ej_diag *diag)
{
  const jh2_config *c = config;
  EJ_TRY(mp_elastic_check(c->E, c->nu, c->K, c->G, diag));
  if (!(c->p_HEL < c->HEL)) return ej_diag_error(diag, "p_HEL", "p_HEL must be below HEL (sigma_HEL = 3/2 (HEL - p_HEL) > 0)");
  return EJ_OK;
}

static ej_err jh2_create(const void *config, void **state)
{
  EJ_ENSURE(config && state, EJ_ERR_ARG, "jh2: NULL config or state");
  const jh2_config *cfg = config;
  jh2_state t = {.cfg = *cfg};
  const char *msg = mp_elastic_resolve(cfg->E, cfg->nu, cfg->K, cfg->G, &t.K, &t.G);
  EJ_ENSURE(!msg, EJ_ERR_ARG, "jh2: %s", msg ? msg : "");
  EJ_ENSURE(cfg->p_HEL < cfg->HEL && cfg->rho0 > 0, EJ_ERR_ARG, "jh2: needs p_HEL < HEL and rho0 > 0");
  t.s_hel = 1.5 * (cfg->HEL - cfg->p_HEL);
  jh2_state *s = ej_malloc(sizeof *s);
  EJ_ENSURE(s, EJ_ERR_MEM, "jh2: out of memory");
  *s = t;
  *state = s;
  return EJ_OK;
}

/* Eq 25: p(mu) and dp/dmu of the built-in polynomial (compression positive). */
static ej_real jh2_poly(const jh2_state *s, ej_real mu, ej_real *dpdmu)
{
  const jh2_config *c = &s->cfg;
  if (mu < 0) {
    *dpdmu = s->K;
    return s->K * mu;
  }
  *dpdmu = s->K + 2 * c->K2 * mu + 3 * c->K3 * mu * mu;
  return mu * (s->K + mu * (c->K2 + mu * c->K3));
}

/* Normalised yield strength sigma_y* at pressure ratio ps = p*, rate factor R, damage D. */
static ej_real jh2_strength(const jh2_config *c, ej_real ps, ej_real R, ej_real D)
{
  const ej_real ts = c->T / c->p_HEL;
  ej_real si = ps + ts > 0 ? c->A * pow(ps + ts, c->N) * R : 0.0;
  if (c->simax > 0) si = fmin(si, c->simax);
  ej_real sf = ps > 0 ? c->B * pow(ps, c->M) * R : 0.0;
  if (c->sfmax > 0) sf = fmin(sf, c->sfmax);
  return fmax(si - D * (si - sf), 0.0);
}

/* The failed state: no shear, no tension. */
static void jh2_failed_stress(ej_real sig[6], ej_real p_eos)
{
  for (int k = 0; k < 6; ++k) sig[k] = 0;
  for (int k = 0; k < 3; ++k) sig[k] = -fmax(p_eos, 0.0);
}

static ej_err jh2_update(const void *state, ej_mat_batch *b)
{
  const jh2_state *s = state;
  const jh2_config *c = &s->cfg;
  /* dt = 0 (the core's first evaluation) is a zero increment; nothing here divides by dt */
  const ej_real K = s->K, G = s->G, dt = fmax(b->dt, 0.0);
  const ej_real ts = c->T / c->p_HEL;
  for (ej_idx i = 0; i < b->n; ++i) {
    ej_real *sig = b->stress + 6 * (size_t)i;
    const ej_real *d = b->d + 6 * (size_t)i;
    ej_real *Dp = &b->hist[JH2_H_D][i], *ep = &b->hist[JH2_H_EPS_P][i];
    ej_real *dpb = &b->hist[JH2_H_DP][i], *fl = &b->hist[JH2_H_FAILED][i];
    const ej_real mu = b->rho[i] / c->rho0 - 1;
    ej_real dpdmu = K; /* the polynomial's tangent; K with an attached EOS */
    const ej_real p_eos = b->p ? b->p[i] : jh2_poly(s, mu, &dpdmu);
    const ej_real Kt = fmax(K, dpdmu);
    if (b->c) b->c[i] = mp_sound_speed(Kt, G, b->rho[i]);
    if (b->w_plastic) b->w_plastic[i] = 0;
    if (*fl != 0) {
      jh2_failed_stress(sig, p_eos);
      if (b->failed) b->failed[i] = 1;
      continue;
    }
    const ej_real D = *Dp;
    ej_real sn[6], dd[6], str[6];
    ej_s6_dev(sn, sig);
    ej_s6_dev(dd, d);
    for (int k = 0; k < 6; ++k) str[k] = sn[k] + 2 * G * dt * dd[k];
    /* pressure of the strength and of the tension check: EOS + the bulking of t_n */
    ej_real p = p_eos + *dpb;
    bool fail = false;
    if (c->tension == JH2_TENSION_CUTOFF)
      p = fmax(p, -c->T * (1 - D));
    else if (p < -c->T)
      fail = true;
    const ej_real rate = sqrt(2.0 / 3.0 * ej_s6_ddot(dd, dd));
    ej_real rstar = rate / c->eps_dot0;
    if (c->rate_clamp) rstar = fmax(rstar, 1.0);
    const ej_real R = c->C > 0 ? fmax(1 + c->C * log(fmax(rstar, 1e-300)), 0.0) : 1.0;
    const ej_real ps = p / c->p_HEL;
    const ej_real sy = s->s_hel * jh2_strength(c, ps, R, D);
    const ej_real seq = sqrt(1.5 * ej_s6_ddot(str, str));
    ej_real k = 1, dep = 0;
    if (!fail && seq > sy) {
      dep = (seq - sy) / (3 * G);
      k = seq > 0 ? sy / seq : 0.0;
    }
    ej_real Dn = D;
    if (dep > 0) {
      const ej_real ef = fmax(ps + ts > 0 ? c->D1 * pow(ps + ts, c->D2) : 0.0, c->efmin);
      Dn = ef > 0 ? fmin(D + dep / ef, 1.0) : 1.0;
    }
    if (Dn > D && c->beta > 0) {
      const ej_real sy1 = s->s_hel * jh2_strength(c, ps, R, Dn);
      const ej_real dU = fmax((sy * sy - sy1 * sy1) / (6 * G), 0.0);
      const ej_real a = K * mu + *dpb;
      *dpb = fmax(-K * mu + sqrt(a * a + 2 * c->beta * K * dU), *dpb);
    }
    *Dp = Dn;
    *ep += dep;
    if (c->damage_failure && Dn >= 1) fail = true;
    ej_real pn = p_eos + *dpb;
    if (c->tension == JH2_TENSION_CUTOFF) pn = fmax(pn, -c->T * (1 - Dn));
    for (int j = 0; j < 6; ++j) sig[j] = k * str[j];
    for (int j = 0; j < 3; ++j) sig[j] -= pn;
    if (!fail && c->tension_strength > 0) {
      ej_real lam[3], V[9];
      ej_s6_eig(lam, V, sig);
      const ej_real smax = fmax(lam[0], fmax(lam[1], lam[2]));
      const ej_real lim = c->tension_strength * pow(fmax(1.0, rate / c->tension_rate0), c->tension_C1);
      if (smax > lim) fail = true;
    }
    if (b->w_plastic && b->rho[i] > 0) b->w_plastic[i] = sy * dep / b->rho[i];
    if (fail) {
      *fl = 1;
      *Dp = 1;
      jh2_failed_stress(sig, p_eos);
      if (b->failed) b->failed[i] = 1;
    }
  }
  return EJ_OK;
}

static ej_err jh2_moduli(const void *state, ej_real *K, ej_real *G)
{
  const jh2_state *s = state;
  *K = s->K, *G = s->G;
  return EJ_OK;
}

static void jh2_destroy(void *state) { ej_free(state); }

static const ej_material_ops jh2_ops = {
    .struct_size = sizeof(ej_material_ops),
    .name = "jh2",
    .summary = "Johnson-Holmquist 2 brittle strength, damage and bulking; optional rate-dependent tension failure",
    .doc = "Intact and fractured strengths A (p* + T*)^N R and B p*^M R, sigma_y = sigma_HEL (sigma_i* - D (sigma_i* - "
           "sigma_f*)), radial return, damage D += deps_p / (D1 (p* + T*)^D2), bulking pressure from the lost elastic "
           "energy (beta), hydrostatic tension cut off or failing, and the principal-stress tension model of Zhu & Zhao "
           "(seed 002). Pressure from the attached EOS or the built-in polynomial K mu + K2 mu^2 + K3 mu^3. A failed "
           "point carries only compression and sets failed (PD point failure). History: damage, eps_p, dp_bulk, "
           "jh2_failed.",
    .params = jh2_params,
    .config_size = sizeof(jh2_config),
    .check_config = jh2_check,
    .n_hist = JH2_NHIST,
    .hist_names = jh2_hist_names,
    .needs_eos = false,
    .create = jh2_create,
    .init_hist = NULL,
    .update = jh2_update,
    .destroy = jh2_destroy,
    .moduli = jh2_moduli,
};

static ej_err jh2_register(ej_registry *reg)
{
  EJ_TRY(ej_register_material(reg, &jh2_ops));
  return EJ_OK;
}

EJ_PLUGIN_DEFINE(jh2, "0.1.0", "BSD-3-Clause", "Johnson-Holmquist 2 brittle strength and damage", jh2_register)

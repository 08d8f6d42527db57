/* Johnson-Cook strength with adiabatic heating and optional Johnson-Cook failure.
 *
 * Flow stress (Johnson & Cook 1983; Chen et al. 2021 §3.3, digest 001 §2.3):
 *   sigma_y = (A + B eps_p^n) (1 + C ln(max(epsdot_p / eps_dot0, 1))) (1 - T*^m),
 *   T* = (T - T_room)/(T_melt - T_room) clamped to [0, 1]
 * Radial return solved implicitly in deps_p (digest 001 §2.3 issue 4: the increment comes from
 * the trial equivalent stress; issue 6: epsdot_p = deps_p/dt; issue 5: the rate term is clamped
 * at epsdot_p >= eps_dot0):
 *   sigma_eq_tr - 3G deps = sigma_y(eps_p,n + deps, deps/dt, T_n)
 * `rate: total` (option, issue 6 diagnostic) uses instead the step's equivalent total deviatoric
 * strain rate sqrt(2/3 d':d') in the rate term, in the elastic check as well.
 * Temperature (digest 001 §2.3 issue 3: the paper gives no thermal model), `temperature`:
 *   plastic_work (default): T += chi sigma_y deps / (rho c_p), chi the Taylor-Quinney factor (0.9),
 *     T_n in the flow stress;
 *   internal_energy: T_n = T0 + chi e_n / c_p from the method's specific internal energy (e = 0 at
 *     T0), which holds every dissipated energy: the plastic work and also the artificial
 *     viscosity's heating, the adiabatic assumption of hydrocodes that take T from the energy.
 * Failure (Johnson & Cook 1985), optional:
 *   eps_f = (D1 + D2 exp(D3 sigma*)) (1 + D4 ln(max(epsdot_p/eps_dot0, 1))) (1 + D5 T*),
 *   sigma* = mean stress / sigma_eq (tension positive), D += deps_p / eps_f;
 *   D >= 1 sets b->failed[i] = 1; a failed point carries no deviatoric stress and no tension.
 * Volumetric part as von_mises (`volumetric`: auto | elastic | eos). */
#include <math.h>
#include <string.h>

#include "../drucker_prager/mp_common.h"
#include "ejecta/plugin.h"

typedef struct jc_config {
  ej_real E, nu, K, G;
  ej_real A, B, n, C, m, eps_dot0, T_room, T_melt, T0, cp, taylor_quinney;
  bool failure;
  ej_real D1, D2, D3, D4, D5;
  int volumetric;
  int rate;
  int temperature;
} jc_config;

typedef struct jc_state {
  jc_config cfg;
  ej_real K, G;
} jc_state;

enum { JC_VOL_AUTO, JC_VOL_ELASTIC, JC_VOL_EOS };
enum { JC_RATE_PLASTIC, JC_RATE_TOTAL };
static const char *const jc_rate_choices[] = {"plastic", "total", NULL};
enum { JC_TEMP_PLASTIC_WORK, JC_TEMP_INTERNAL_ENERGY };
static const char *const jc_temp_choices[] = {"plastic_work", "internal_energy", NULL};
enum { JC_H_EPS_P, JC_H_T, JC_H_DAMAGE, JC_NHIST };
static const char *const jc_vol_choices[] = {"auto", "elastic", "eos", NULL};
static const char *const jc_hist_names[] = {"eps_p", "temperature", "damage", NULL};

#define JC_REQ (EJ_PF_REQUIRED | EJ_PF_HAS_MIN)
static const ej_param jc_params[] = {
    MP_ELASTIC_PARAMS(jc_config),
    EJ_PARAM_REAL(jc_config, A, "Pa", 0, 0, 0, JC_REQ, "Quasi-static yield stress A."),
    EJ_PARAM_REAL(jc_config, B, "Pa", 0, 0, 0, JC_REQ, "Strain-hardening coefficient B."),
    EJ_PARAM_REAL(jc_config, n, "1", 0, 0, 0, JC_REQ, "Strain-hardening exponent n."),
    EJ_PARAM_REAL(jc_config, C, "1", 0, 0, 0, EJ_PF_HAS_MIN, "Strain-rate coefficient C (0 = rate independent)."),
    EJ_PARAM_REAL(jc_config, m, "1", 1, 0, 0, EJ_PF_HAS_MIN | EJ_PF_MIN_OPEN, "Thermal-softening exponent m."),
    EJ_PARAM_REAL(jc_config, eps_dot0, "1/s", 1, 0, 0, EJ_PF_HAS_MIN | EJ_PF_MIN_OPEN, "Reference plastic strain rate."),
    EJ_PARAM_REAL(jc_config, T_room, "K", 293, 0, 0, EJ_PF_HAS_MIN, "Reference (room) temperature of T*."),
    EJ_PARAM_REAL(jc_config, T_melt, "K", 0, 0, 0, EJ_PF_REQUIRED | EJ_PF_HAS_MIN | EJ_PF_MIN_OPEN,
                  "Melting temperature of T* (above T_room)."),
    EJ_PARAM_REAL(jc_config, T0, "K", 0, 0, 0, EJ_PF_HAS_MIN, "Initial temperature; 0 = T_room."),
    EJ_PARAM_REAL(jc_config, cp, "J/kg/K", 0, 0, 0, EJ_PF_HAS_MIN,
                  "Specific heat for adiabatic heating; 0 = isothermal (temperature stays T0)."),
    EJ_PARAM_REAL(jc_config, taylor_quinney, "1", 0.9, 0, 1, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX,
                  "Taylor-Quinney factor: fraction of plastic work converted to heat."),
    EJ_PARAM_BOOL(jc_config, failure, false, "Johnson-Cook damage: the point fails when D = sum deps_p/eps_f reaches 1."),
    EJ_PARAM_REAL(jc_config, D1, "1", 0, 0, 0, 0, "Failure constant D1 (with failure: true)."),
    EJ_PARAM_REAL(jc_config, D2, "1", 0, 0, 0, 0, "Failure constant D2."),
    EJ_PARAM_REAL(jc_config, D3, "1", 0, 0, 0, 0, "Failure constant D3 (triaxiality exponent, usually negative)."),
    EJ_PARAM_REAL(jc_config, D4, "1", 0, 0, 0, 0, "Failure constant D4 (strain rate)."),
    EJ_PARAM_REAL(jc_config, D5, "1", 0, 0, 0, 0, "Failure constant D5 (temperature)."),
    EJ_PARAM_ENUM(jc_config, volumetric, jc_vol_choices, "auto",
                  "Mean stress: elastic (K tr d), eos (-p from the attached EOS), auto (eos when one is attached)."),
    EJ_PARAM_ENUM(jc_config, rate, jc_rate_choices, "plastic",
                  "Strain rate of the rate term: plastic (deps_p/dt, digest 001 §2.3 issue 6) or total (equivalent "
                  "deviatoric strain rate sqrt(2/3 d':d') of the step, also in the elastic check)."),
    EJ_PARAM_ENUM(jc_config, temperature, jc_temp_choices, "plastic_work",
                  "Temperature of T*: plastic_work (T += taylor_quinney sigma_y deps_p / (rho cp)) or internal_energy "
                  "(T = T0 + taylor_quinney e / cp from the specific internal energy e of the method, e = 0 at T0: "
                  "the plastic work plus the artificial viscosity's heating)."),
    {0}};

static ej_err jc_check(const void *config, ej_diag *diag)
{
  const jc_config *c = config;
  EJ_TRY(mp_elastic_check(c->E, c->nu, c->K, c->G, diag));
  if (!(c->T_melt > c->T_room)) return ej_diag_error(diag, "T_melt", "T_melt must exceed T_room");
  if (c->failure && !(c->D1 + c->D2 > 0))
    return ej_diag_error(diag, "D1", "failure: true needs D1 + D2 > 0 (a positive failure strain)");
  return EJ_OK;
}

static ej_err jc_create(const void *config, void **state)
{
  EJ_ENSURE(config && state, EJ_ERR_ARG, "johnson_cook: NULL config or state");
  const jc_config *cfg = config;
  jc_state t = {.cfg = *cfg};
  const char *msg = mp_elastic_resolve(cfg->E, cfg->nu, cfg->K, cfg->G, &t.K, &t.G);
  EJ_ENSURE(!msg, EJ_ERR_ARG, "johnson_cook: %s", msg ? msg : "");
  EJ_ENSURE(cfg->T_melt > cfg->T_room, EJ_ERR_ARG, "johnson_cook: T_melt must exceed T_room");
  if (!(t.cfg.T0 > 0)) t.cfg.T0 = t.cfg.T_room;
  jc_state *s = ej_malloc(sizeof *s);
  EJ_ENSURE(s, EJ_ERR_MEM, "johnson_cook: out of memory");
  *s = t;
  *state = s;
  return EJ_OK;
}

static ej_err jc_init_hist(const void *state, ej_idx n, ej_real *const *hist)
{
  const jc_state *s = state;
  for (ej_idx i = 0; i < n; ++i) {
    hist[JC_H_EPS_P][i] = 0;
    hist[JC_H_T][i] = s->cfg.T0;
    hist[JC_H_DAMAGE][i] = 0;
  }
  return EJ_OK;
}

static ej_real jc_tstar(const jc_config *c, ej_real T)
{
  return fmin(fmax((T - c->T_room) / (c->T_melt - c->T_room), 0.0), 1.0);
}

static ej_real jc_rate_log(const jc_config *c, ej_real epsdot) { return log(fmax(epsdot / c->eps_dot0, 1.0)); }

static ej_real jc_flow(const jc_config *c, ej_real ep, ej_real epsdot, ej_real tstar)
{
  const ej_real th = tstar > 0 ? 1 - pow(tstar, c->m) : 1.0;
  return (c->A + c->B * (ep > 0 ? pow(ep, c->n) : 0.0)) * (1 + c->C * jc_rate_log(c, epsdot)) * th;
}

/* Solve seq - 3G x = sigma_y(ep + x, rate, T*) for x in [0, seq/3G], rate = x/dt (rate_fixed < 0)
 * or rate_fixed (the left side minus the right is decreasing in x): Illinois regula falsi with
 * bisection safeguard. */
static ej_real jc_solve(const jc_config *c, ej_real G, ej_real seq, ej_real ep, ej_real dt, ej_real ts,
                        ej_real rate_fixed)
{
  const bool fixed = rate_fixed >= 0;
  ej_real a = 0, b = seq / (3 * G);
  ej_real fa = seq - jc_flow(c, ep, fixed ? rate_fixed : 0, ts), fb = -jc_flow(c, ep + b, fixed ? rate_fixed : b / dt, ts);
  if (fb >= 0) return b; /* zero strength (melted) */
  int side = 0;
  for (int it = 0; it < 200; ++it) {
    ej_real x = (a * fb - b * fa) / (fb - fa);
    if (!(x > a && x < b) || it % 8 == 7) x = 0.5 * (a + b);
    if (b - a <= 1e-15 * b) return x;
    const ej_real fx = seq - 3 * G * x - jc_flow(c, ep + x, fixed ? rate_fixed : x / dt, ts);
    if (fx == 0) return x;
    if (fx < 0) {
      b = x, fb = fx;
      if (side == -1) fa *= 0.5;
      side = -1;
    } else {
      a = x, fa = fx;
      if (side == 1) fb *= 0.5;
      side = 1;
    }
  }
  return 0.5 * (a + b);
}

static ej_err jc_update(const void *state, ej_mat_batch *b)
{
  const jc_state *s = state;
  const jc_config *c = &s->cfg;
  const ej_real K = s->K, G = s->G;
  const bool use_eos = c->volumetric == JC_VOL_EOS || (c->volumetric == JC_VOL_AUTO && b->p);
  EJ_ENSURE(!use_eos || b->p, EJ_ERR_UNSUPPORTED,
            "johnson_cook: volumetric: eos needs an equation of state on the material (no pressure passed)");
  EJ_ENSURE(b->dt > 0, EJ_ERR_ARG, "johnson_cook: dt must be positive");
  const bool T_from_e = c->temperature == JC_TEMP_INTERNAL_ENERGY && c->cp > 0;
  EJ_ENSURE(!T_from_e || b->e, EJ_ERR_UNSUPPORTED,
            "johnson_cook: temperature: internal_energy needs the specific internal energy (none passed)");
  for (ej_idx i = 0; i < b->n; ++i) {
    ej_real *sig = b->stress + 6 * (size_t)i;
    const ej_real *d = b->d + 6 * (size_t)i;
    ej_real sn[6], dd[6], str[6];
    const ej_real m = ej_s6_dev(sn, sig), dv = ej_s6_dev(dd, d);
    const ej_real mean_el = use_eos ? -b->p[i] : m + K * dv * 3 * b->dt;
    ej_real *ep = &b->hist[JC_H_EPS_P][i], *T = &b->hist[JC_H_T][i], *D = &b->hist[JC_H_DAMAGE][i];
    if (c->failure && *D >= 1) { /* failed: no shear, no tension */
      for (int j = 0; j < 6; ++j) sig[j] = 0;
      for (int j = 0; j < 3; ++j) sig[j] = fmin(mean_el, 0.0);
      if (b->failed) b->failed[i] = 1;
      if (b->w_plastic) b->w_plastic[i] = 0;
      if (b->c) b->c[i] = mp_sound_speed(K, G, b->rho[i]);
      continue;
    }
    if (T_from_e) *T = c->T0 + c->taylor_quinney * b->e[i] / c->cp;
    for (int k = 0; k < 6; ++k) str[k] = sn[k] + 2 * G * b->dt * dd[k];
    const ej_real seq = sqrt(1.5 * ej_s6_ddot(str, str));
    const ej_real ts = jc_tstar(c, *T);
    /* rate: total: the step's equivalent deviatoric strain rate, in the elastic check too */
    const ej_real rate_tot = c->rate == JC_RATE_TOTAL ? sqrt(2.0 / 3.0 * ej_s6_ddot(dd, dd)) : -1.0;
    ej_real k = 1, dep = 0, sy = jc_flow(c, *ep, rate_tot > 0 ? rate_tot : 0, ts);
    if (seq > sy) {
      dep = jc_solve(c, G, seq, *ep, b->dt, ts, rate_tot);
      k = seq > 0 ? fmax(1 - 3 * G * dep / seq, 0.0) : 0.0;
      sy = k * seq;
    }
    for (int j = 0; j < 6; ++j) sig[j] = k * str[j];
    for (int j = 0; j < 3; ++j) sig[j] += mean_el;
    const ej_real work = sy * dep; /* s : de_p per unit volume */
    if (!T_from_e && c->cp > 0 && b->rho[i] > 0) *T += c->taylor_quinney * work / (b->rho[i] * c->cp);
    if (c->failure && dep > 0) {
      const ej_real triax = sy > 0 ? mean_el / sy : 0.0;
      const ej_real ef = (c->D1 + c->D2 * exp(c->D3 * triax)) * (1 + c->D4 * jc_rate_log(c, dep / b->dt)) *
                         (1 + c->D5 * ts);
      *D += ef > 0 ? dep / ef : 1.0;
      if (*D >= 1 && b->failed) b->failed[i] = 1;
    }
    *ep += dep;
    if (b->w_plastic) b->w_plastic[i] = b->rho[i] > 0 ? work / b->rho[i] : 0.0;
    if (b->c) b->c[i] = mp_sound_speed(K, G, b->rho[i]);
  }
  return EJ_OK;
}

static ej_err jc_moduli(const void *state, ej_real *K, ej_real *G)
{
  const jc_state *s = state;
  *K = s->K, *G = s->G;
  return EJ_OK;
}

static void jc_destroy(void *state) { ej_free(state); }

/* ABI 1.9: `volumetric: eos` needs the material's EOS (auto takes it when there is one) */
static const char *jc_eos_required_by(const void *config)
{
  return ((const jc_config *)config)->volumetric == JC_VOL_EOS ? "volumetric" : NULL;
}

static const ej_material_ops jc_ops = {
    .struct_size = sizeof(ej_material_ops),
    .name = "johnson_cook",
    .summary = "Johnson-Cook flow stress, adiabatic heating, optional Johnson-Cook failure",
    .doc = "Radial return (implicit in the plastic strain increment) to (A + B eps_p^n)(1 + C ln epsdot*)(1 - T*^m); "
           "temperature from the plastic work (Taylor-Quinney) or the internal energy; JC damage D1..D5 sets failed when D >= 1. Mean "
           "stress from K tr(d) or the attached EOS. History: eps_p, temperature, damage.",
    .params = jc_params,
    .config_size = sizeof(jc_config),
    .check_config = jc_check,
    .n_hist = JC_NHIST,
    .hist_names = jc_hist_names,
    .needs_eos = false,
    .create = jc_create,
    .init_hist = jc_init_hist,
    .update = jc_update,
    .destroy = jc_destroy,
    .moduli = jc_moduli,
    .eos_required_by = jc_eos_required_by,
};

static ej_err jc_register(ej_registry *reg)
{
  EJ_TRY(ej_register_material(reg, &jc_ops));
  return EJ_OK;
}

EJ_PLUGIN_DEFINE(johnson_cook, "0.1.0", "BSD-3-Clause", "Johnson-Cook strength and failure", jc_register)

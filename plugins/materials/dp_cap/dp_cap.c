/* Drucker-Prager cap model (non-associated shear, tension cap, hardening compression cap).
 *
 * Source: H. Fan, S. Li, CMAME 318 (2017) 349-381, §3.2, Eqs 60-70 and Appendix A (digest 000
 * §2.2). Mean stress p = tr(sigma)/3 tension positive, I1 = 3p, q = ||s|| = sqrt(s:s).
 *   f = q - sqrt(Fcap) sqrt((A - B p)^2 - (A - B zeta)^2)                      (Eq 60)
 *   A = A(phi) c = 2 sqrt6 c cos(phi)/(3 + beta sin phi), B = 2 sqrt6 sin(phi)/(3 + beta sin phi)  (Eq 61)
 *   Fcap = 1 - H(kappa - I1) ((I1 - kappa)/(X - kappa))^2                     (Eq 62)
 *   X = kappa - R (A - B kappa/3)                                              (Eq 63; kappa is an
 *       I1 value and the shear envelope is evaluated at p = kappa/3: digest 000 §2.2 ambiguity)
 *   g = q - sqrt(Fcap) sqrt((A_psi - B_psi p)^2 - t_psi^2)                     (Eq 64)
 * Choices where the paper is silent or degenerate (README):
 *   - the cap position follows the crush curve of the same paper, Eqs 76-77 (written for
 *     Arenisca; the DPC section gives no hardening law for kappa) [GAP]:
 *       X = X0 + ln(1 + eps_v_p / p3) / p1   (eps_v_p <= 0),
 *       X = X0 (1 + eps_v_p)^(1/(X0 p1 p3))   (eps_v_p > 0; Eq 77 erratum eps_n -> eps_v);
 *   - g uses the yield function's cap factor Fcap (Eq 64's psi-version of Eq 63 is degenerate
 *     for c = 0, psi = 0: X_psi = kappa) and the tension term t_psi = (B_psi/B) (A - B zeta), so
 *     that g is the drucker_prager potential wherever the caps are inactive;
 *   - c, phi, psi and zeta are constant (000 Table 2 gives H^c = 0; the tension-cap softening
 *     modulus "H chi" cannot be applied: h^zeta of Eq 65 is singular at the tension tip).
 * Return: Eq 100 with the erratum R^tau = tau - tau_tr + dgamma a:dg/dtau (digest 000 §6 item
 * 21: the printed d - d^p double counts the flow). With isotropic elasticity and a g depending
 * on (p, q) only, the deviator keeps the trial direction, so the 10x10 system of Eqs 106-112
 * (with the Eq 112 erratum D -> D^-1) reduces exactly to the two-invariant problem
 *   p = p_tr - K dl n_p,  q = q_tr - 2G dl n_q,  f(p, q; X(eps_v_p)) = 0,
 * n the unit normal of g in (p, q). It is solved as one safeguarded scalar equation in p on the
 * yield surface (parallelism of the stress correction and n), which is robust at the cap's
 * hydrostatic tip where dg/dp is unbounded. Trial states beyond the vertex of a sharp cone
 * (zeta at the apex) or on the hydrostat return to the tips. */
#include <math.h>
#include <string.h>

#include "../drucker_prager/mp_common.h"
#include "ejecta/plugin.h"

typedef struct dpc_config {
  ej_real E, nu, K, G;
  ej_real friction_angle, dilation_angle, cohesion, beta;
  ej_real cap_ratio, kappa0, crush_p1, crush_p3, zeta, relaxation_time;
  bool cap;
} dpc_config;

typedef struct dpc_state {
  dpc_config cfg;
  ej_real K, G;
  ej_real A, B, Ag, Bg; /* A, Ag include c */
  ej_real pt;           /* tension tip zeta_eff = min(zeta, apex) */
  ej_real t, tg;        /* tension terms A - B zeta_eff, (Bg/B) t */
  ej_real X0;           /* initial cap position (I1) */
} dpc_state;

enum { DPC_H_EPS_P, DPC_H_EPS_V, DPC_H_X, DPC_NHIST };
static const char *const dpc_hist_names[] = {"eps_p", "eps_v_p", "cap_X", NULL};

static const ej_param dpc_params[] = {
    MP_ELASTIC_PARAMS(dpc_config),
    EJ_PARAM_REAL(dpc_config, friction_angle, "deg", 20, 0, 90, EJ_PF_HAS_MIN | EJ_PF_MIN_OPEN | EJ_PF_HAS_MAX | EJ_PF_MAX_OPEN,
                  "Friction angle phi of the shear surface (000 Eq 61; 0.35 rad in 000 Table 2)."),
    EJ_PARAM_REAL(dpc_config, dilation_angle, "deg", 0, 0, 90, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX | EJ_PF_MAX_OPEN,
                  "Dilation angle psi of the plastic potential (0.17 rad in 000 Table 2), at most phi."),
    EJ_PARAM_REAL(dpc_config, cohesion, "Pa", 0, 0, 0, EJ_PF_HAS_MIN, "Cohesion c (100 kPa in 000 Table 2)."),
    EJ_PARAM_REAL(dpc_config, beta, "1", -1, -1, 1, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX,
                  "Cone fit to Mohr-Coulomb: -1 triaxial-compression corners, +1 triaxial-extension corners."),
    EJ_PARAM_REAL(dpc_config, cap_ratio, "1", 10, 0, 0, EJ_PF_HAS_MIN | EJ_PF_MIN_OPEN,
                  "Cap ellipticity R of Eq 63 (I1 semi-axis over shear semi-axis)."),
    EJ_PARAM_REAL(dpc_config, kappa0, "Pa", -2e3, 0, 0, EJ_PF_HAS_MAX,
                  "Initial I1 where the cap meets the shear surface (000 Table 2: -2 kPa); compression negative."),
    EJ_PARAM_REAL(dpc_config, crush_p1, "1/Pa", 1.2e-8, 0, 0, EJ_PF_HAS_MIN | EJ_PF_MIN_OPEN,
                  "Crush-curve rate p1 of 000 Eq 76 (initial slope of plastic compaction against I1 is p1 p3)."),
    EJ_PARAM_REAL(dpc_config, crush_p3, "1", 0.25, 0, 1, EJ_PF_HAS_MIN | EJ_PF_MIN_OPEN | EJ_PF_HAS_MAX | EJ_PF_MAX_OPEN,
                  "Crush-curve maximum plastic volumetric compaction p3 of 000 Eq 76."),
    EJ_PARAM_REAL(dpc_config, zeta, "Pa", INFINITY, 0, 0, 0,
                  "Tension-cap mean stress tr(sigma)/3 where the strength vanishes; inf = the shear cone apex."),
    EJ_PARAM_REAL(dpc_config, relaxation_time, "s", 0, 0, 0, EJ_PF_HAS_MIN,
                  "Duvaut-Lions overstress relaxation time; 0 = rate independent."),
    EJ_PARAM_BOOL(dpc_config, cap, true, "Compression cap on; false gives the capped-free Drucker-Prager limit."),
    {0}};

static ej_real dpc_Af(ej_real x, ej_real beta) { return 2 * sqrt(6.0) * cos(x) / (3 + beta * sin(x)); }
static ej_real dpc_Bf(ej_real x, ej_real beta) { return 2 * sqrt(6.0) * sin(x) / (3 + beta * sin(x)); }

/* Crush curve, 000 Eqs 76-77 (X is an I1 value, negative). */
static ej_real dpc_crush(const dpc_state *s, ej_real ev)
{
  const ej_real p1 = s->cfg.crush_p1, p3 = s->cfg.crush_p3, X0 = s->X0;
  if (ev <= 0) {
    const ej_real a = 1 + ev / p3;
    return a > 0 ? X0 + log(a) / p1 : -INFINITY;
  }
  return X0 * pow(1 + ev, 1 / (X0 * p1 * p3));
}

/* kappa from X (Eq 63 solved for kappa), kept <= 0 (the cap never reaches into tension). */
static ej_real dpc_kappa(const dpc_state *s, ej_real X)
{
  const ej_real R = s->cfg.cap_ratio;
  return fmin((X + R * s->A) / (1 + R * s->B / 3), 0.0);
}

/* Cap factor F and dF/dp at p for the cap (X, kappa). */
static void dpc_fcap(const dpc_state *s, ej_real p, ej_real X, ej_real kap, ej_real *F, ej_real *dF)
{
  const ej_real I1 = 3 * p;
  if (!s->cfg.cap || I1 >= kap) {
    *F = 1, *dF = 0;
    return;
  }
  const ej_real r = (I1 - kap) / (X - kap);
  *F = 1 - r * r;
  *dF = -2 * r / (X - kap) * 3;
}

/* Shear strength S(p) on the yield surface (0 outside the admissible p range). */
static ej_real dpc_strength(const dpc_state *s, ej_real p, ej_real X, ej_real kap)
{
  ej_real F, dF;
  dpc_fcap(s, p, X, kap, &F, &dF);
  const ej_real a = s->A - s->B * p;
  const ej_real psi2 = a * a - s->t * s->t;
  if (F <= 0 || psi2 <= 0 || p > s->pt) return 0;
  return sqrt(F) * sqrt(psi2);
}

/* Unit normal (n_p, n_q) of g at p (scaled by 2 sqrt(F) Psi_g so that it stays finite at the
 * cap tip and at the tension tip). */
static void dpc_normal(const dpc_state *s, ej_real p, ej_real X, ej_real kap, ej_real *np, ej_real *nq)
{
  ej_real F, dF;
  dpc_fcap(s, p, X, kap, &F, &dF);
  F = fmax(F, 0.0);
  const ej_real ag = s->Ag - s->Bg * p;
  const ej_real psig2 = fmax(ag * ag - s->tg * s->tg, 0.0);
  /* grad g = (-(dF Psi^2 + 2 F Psi Psi'), 2 sqrt(F) Psi), Psi Psi' = -Bg ag */
  const ej_real vp = -(dF * psig2 - 2 * F * s->Bg * ag), vq = 2 * sqrt(F) * sqrt(psig2);
  const ej_real nn = hypot(vp, vq);
  if (nn > 0) {
    *np = vp / nn, *nq = vq / nn;
  } else {
    *np = 0, *nq = 1;
  }
}

/* Cap position after a return to mean stress p from the trial (p_tr) with history ev_n. */
static ej_real dpc_X_at(const dpc_state *s, ej_real p, ej_real ptr, ej_real ev_n)
{
  return dpc_crush(s, ev_n + (ptr - p) / s->K);
}

/* Parallelism residual r(p) = (p_tr - p)/K n_q - (q_tr - S)/(2G) n_p on the yield surface. */
static ej_real dpc_resid(const dpc_state *s, ej_real p, ej_real ptr, ej_real qtr, ej_real ev_n)
{
  const ej_real X = s->cfg.cap ? dpc_X_at(s, p, ptr, ev_n) : -INFINITY;
  const ej_real kap = s->cfg.cap ? dpc_kappa(s, X) : 0;
  const ej_real S = dpc_strength(s, p, X, kap);
  ej_real np, nq;
  dpc_normal(s, p, X, kap, &np, &nq);
  return (ptr - p) / s->K * nq - (qtr - S) / (2 * s->G) * np;
}

/* Root of a function of one variable changing sign from fa (at a) to fb (at b): Illinois
 * (modified regula falsi) with a bisection safeguard. */
typedef ej_real (*dpc_fn)(const dpc_state *s, ej_real p, ej_real ptr, ej_real qtr, ej_real ev_n);
static ej_real dpc_root(dpc_fn fn, const dpc_state *s, ej_real a, ej_real fa, ej_real b, ej_real fb, ej_real ptr,
                        ej_real qtr, ej_real ev_n)
{
  int side = 0;
  for (int it = 0; it < 200; ++it) {
    if (fa == 0) return a;
    if (fb == 0) return b;
    ej_real c = (a * fb - b * fa) / (fb - fa);
    if (!(c > fmin(a, b) && c < fmax(a, b)) || it % 8 == 7) c = 0.5 * (a + b);
    if (fabs(b - a) <= 4e-16 * fmax(fabs(a), fabs(b)) + 1e-300) return c;
    const ej_real fc = fn(s, c, ptr, qtr, ev_n);
    if ((fc > 0) == (fb > 0)) {
      b = c, fb = fc;
      if (side == -1) fa *= 0.5;
      side = -1;
    } else {
      a = c, fa = fc;
      if (side == 1) fb *= 0.5;
      side = 1;
    }
  }
  return 0.5 * (a + b);
}

/* Hydrostatic cap tip: 3p - X(ev_n + (p_tr - p)/K) = 0 (increasing in p). */
static ej_real dpc_tip_fn(const dpc_state *s, ej_real p, ej_real ptr, ej_real qtr, ej_real ev_n)
{
  (void)qtr;
  const ej_real X = dpc_X_at(s, p, ptr, ev_n);
  return isinf(X) ? INFINITY : 3 * p - X;
}

static ej_real dpc_cap_tip(const dpc_state *s, ej_real ptr, ej_real ev_n)
{
  const ej_real Xn = dpc_crush(s, ev_n);
  ej_real hi = fmax(ptr, Xn / 3), lo = fmin(ptr, Xn / 3);
  const ej_real scale = fabs(Xn) + fabs(ptr) + 1.0;
  ej_real flo = dpc_tip_fn(s, lo, ptr, 0, ev_n), fhi = dpc_tip_fn(s, hi, ptr, 0, ev_n);
  for (int k = 0; k < 200 && !(flo < 0); ++k) lo -= scale * ldexp(1.0, k), flo = dpc_tip_fn(s, lo, ptr, 0, ev_n);
  if (fhi == INFINITY) { /* beyond full compaction: tighten from above by bisection */
    for (int k = 0; k < 200 && fhi == INFINITY; ++k) hi = 0.5 * (hi + lo), fhi = dpc_tip_fn(s, hi, ptr, 0, ev_n);
  }
  return dpc_root(dpc_tip_fn, s, lo, flo, hi, fhi, ptr, 0, ev_n);
}

/* Rate-independent return: trial tr, volumetric plastic strain ev_n -> out. */
static void dpc_return(const dpc_state *s, const ej_real tr[6], ej_real ev_n, ej_real out[6])
{
  ej_real str[6];
  const ej_real ptr = ej_s6_dev(str, tr);
  const ej_real qtr = sqrt(ej_s6_ddot(str, str));
  const ej_real Xn = s->cfg.cap ? dpc_crush(s, ev_n) : -INFINITY;
  const ej_real kn = s->cfg.cap ? dpc_kappa(s, Xn) : 0;
  memcpy(out, tr, 6 * sizeof *out);
  const bool in_cap = !s->cfg.cap || 3 * ptr >= Xn;
  if (in_cap && ptr <= s->pt && qtr <= dpc_strength(s, ptr, Xn, kn)) return; /* elastic */

  /* compression end of the surface */
  ej_real plo, rlo;
  if (s->cfg.cap) {
    plo = dpc_cap_tip(s, ptr, ev_n);
    rlo = qtr / (2 * s->G); /* normal (-1, 0) at the tip */
  } else {
    const ej_real scale = fabs(ptr) + qtr + fabs(s->A) + 1.0;
    plo = fmin(ptr, s->pt) - scale;
    rlo = dpc_resid(s, plo, ptr, qtr, 0);
    for (int k = 1; k < 200 && !(rlo > 0); ++k) plo -= scale * ldexp(1.0, k), rlo = dpc_resid(s, plo, ptr, qtr, 0);
  }
  /* tension end: the residual just below the tip (a sharp vertex when t = 0) */
  const ej_real phi_ = s->pt;
  ej_real rhi;
  {
    const ej_real X = s->cfg.cap ? dpc_X_at(s, phi_, ptr, ev_n) : -INFINITY;
    const ej_real kap = s->cfg.cap ? dpc_kappa(s, X) : 0;
    ej_real np, nq;
    dpc_normal(s, phi_ - 1e-12 * (fabs(phi_) + 1.0), X, kap, &np, &nq);
    rhi = (ptr - phi_) / s->K * nq - qtr / (2 * s->G) * np;
  }
  ej_real p;
  bool tip = false;
  if (qtr <= 0) { /* hydrostatic: one of the tips */
    p = (s->cfg.cap && 3 * ptr < Xn) ? plo : phi_;
    tip = true;
  } else if (rhi >= 0) { /* beyond the vertex (apex region) */
    p = phi_, tip = true;
  } else if (plo >= phi_) {
    p = phi_, tip = true;
  } else {
    p = dpc_root(dpc_resid, s, plo, rlo, phi_, rhi, ptr, qtr, ev_n);
  }
  ej_real q = 0;
  if (!tip) {
    const ej_real X = s->cfg.cap ? dpc_X_at(s, p, ptr, ev_n) : -INFINITY;
    q = fmin(dpc_strength(s, p, X, s->cfg.cap ? dpc_kappa(s, X) : 0), qtr);
  }
  const ej_real k = qtr > 0 ? q / qtr : 0;
  for (int j = 0; j < 6; ++j) out[j] = k * str[j];
  for (int j = 0; j < 3; ++j) out[j] += p;
}

static ej_err dpc_check(const void *config, ej_diag *diag)
{
  const dpc_config *c = config;
  EJ_TRY(mp_elastic_check(c->E, c->nu, c->K, c->G, diag));
  if (c->dilation_angle > c->friction_angle)
    return ej_diag_error(diag, "dilation_angle", "dilation_angle must not exceed friction_angle");
  if (!(c->zeta > c->kappa0 / 3))
    return ej_diag_error(diag, "zeta", "the tension cap zeta must lie above kappa0/3 (mean stress)");
  return EJ_OK;
}

static ej_err dpc_create(const void *config, void **state)
{
  EJ_ENSURE(config && state, EJ_ERR_ARG, "dp_cap: NULL config or state");
  const dpc_config *cfg = config;
  dpc_state t = {.cfg = *cfg};
  const char *msg = mp_elastic_resolve(cfg->E, cfg->nu, cfg->K, cfg->G, &t.K, &t.G);
  EJ_ENSURE(!msg, EJ_ERR_ARG, "dp_cap: %s", msg ? msg : "");
  EJ_ENSURE(cfg->friction_angle > 0 && cfg->dilation_angle <= cfg->friction_angle, EJ_ERR_ARG,
            "dp_cap: need 0 < dilation_angle <= friction_angle");
  t.A = dpc_Af(cfg->friction_angle, cfg->beta) * cfg->cohesion;
  t.B = dpc_Bf(cfg->friction_angle, cfg->beta);
  t.Ag = dpc_Af(cfg->dilation_angle, cfg->beta) * cfg->cohesion;
  t.Bg = dpc_Bf(cfg->dilation_angle, cfg->beta);
  const ej_real apex = t.A / t.B;
  t.pt = fmin(cfg->zeta, apex);
  t.t = t.A - t.B * t.pt;
  t.tg = t.Bg / t.B * t.t;
  const ej_real R = cfg->cap_ratio, k0 = cfg->kappa0;
  t.X0 = k0 - R * (t.A - t.B * k0 / 3); /* Eq 63 */
  EJ_ENSURE(t.X0 < 0, EJ_ERR_ARG, "dp_cap: initial cap position X0 = %g must be negative", t.X0);
  dpc_state *s = ej_malloc(sizeof *s);
  EJ_ENSURE(s, EJ_ERR_MEM, "dp_cap: out of memory");
  *s = t;
  *state = s;
  return EJ_OK;
}

static ej_err dpc_init_hist(const void *state, ej_idx n, ej_real *const *hist)
{
  const dpc_state *s = state;
  for (ej_idx i = 0; i < n; ++i) {
    hist[DPC_H_EPS_P][i] = 0;
    hist[DPC_H_EPS_V][i] = 0;
    hist[DPC_H_X][i] = s->X0;
  }
  return EJ_OK;
}

static ej_err dpc_update(const void *state, ej_mat_batch *b)
{
  const dpc_state *s = state;
  const ej_real K = s->K, G = s->G;
  const ej_real theta = mp_duvaut_lions_theta(b->dt, s->cfg.relaxation_time);
  for (ej_idx i = 0; i < b->n; ++i) {
    ej_real *sig = b->stress + 6 * (size_t)i;
    ej_real tr[6], qs[6];
    mp_elastic_trial(tr, sig, b->d + 6 * (size_t)i, K, G, b->dt);
    dpc_return(s, tr, b->hist[DPC_H_EPS_V][i], qs);
    for (int k = 0; k < 6; ++k) sig[k] = tr[k] + theta * (qs[k] - tr[k]);
    ej_real dev, de[6], work;
    mp_plastic_increment(tr, sig, K, G, &dev, de, &work);
    b->hist[DPC_H_EPS_V][i] += dev;
    b->hist[DPC_H_EPS_P][i] += sqrt(2.0 / 3.0 * ej_s6_ddot(de, de));
    b->hist[DPC_H_X][i] = dpc_crush(s, b->hist[DPC_H_EPS_V][i]); /* finite even with cap: false */
    if (b->w_plastic) b->w_plastic[i] = b->rho[i] > 0 ? work / b->rho[i] : 0.0;
    if (b->c) b->c[i] = mp_sound_speed(K, G, b->rho[i]);
  }
  return EJ_OK;
}

static ej_err dpc_moduli(const void *state, ej_real *K, ej_real *G)
{
  const dpc_state *s = state;
  *K = s->K, *G = s->G;
  return EJ_OK;
}

static void dpc_destroy(void *state) { ej_free(state); }

static const ej_material_ops dpc_ops = {
    .struct_size = sizeof(ej_material_ops),
    .name = "dp_cap",
    .summary = "Drucker-Prager with a hardening compression cap and a tension cap (Fan & Li 2017 DPC)",
    .doc = "Hypoelastic (K, G) trial stress; yield f = ||s|| - sqrt(Fcap) sqrt((A - B p)^2 - (A - B zeta)^2) "
           "(Fan & Li 2017 Eqs 60-64), non-associated shear flow, cap position from the crush curve of Eqs 76-77, "
           "implicit return solved on the (p, q) surface. History: eps_p, eps_v_p (dilation positive), cap_X (I1 "
           "of the cap on the hydrostat).",
    .params = dpc_params,
    .config_size = sizeof(dpc_config),
    .check_config = dpc_check,
    .n_hist = DPC_NHIST,
    .hist_names = dpc_hist_names,
    .needs_eos = false,
    .create = dpc_create,
    .init_hist = dpc_init_hist,
    .update = dpc_update,
    .destroy = dpc_destroy,
    .moduli = dpc_moduli,
};

static ej_err dpc_register(ej_registry *reg)
{
  EJ_TRY(ej_register_material(reg, &dpc_ops));
  return EJ_OK;
}

EJ_PLUGIN_DEFINE(dp_cap, "0.1.0", "BSD-3-Clause", "Drucker-Prager cap model (Fan & Li 2017)", dpc_register)

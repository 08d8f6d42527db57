/* Jones-Wilkins-Lee (JWL) equation of state for detonation products, with programmed burn.
 *
 *   p = A (1 - omega/(R1 V)) exp(-R1 V) + B (1 - omega/(R2 V)) exp(-R2 V) + omega rho e,
 *   V = rho0 / rho  (relative volume), e specific internal energy (J/kg).
 *
 * Form: Chen et al. (digest 001, Eq 13, "the last term equals omega rho E"); Fan & Li (digest
 * 000, Eq 38) and Zhu & Zhao (digest 002, Eq 48) print the last term as omega E / V with E the
 * energy per unit initial volume, which is the same term since E / V = rho0 e / V = rho e
 * (000 digest "Clarification"; 002 digest: Table 2 e0 is per unit volume although called
 * "specific"). The plugin takes the initial energy either per mass (e0, J/kg, 001 Table 1) or
 * per initial volume (E0, J/m^3, 000 Table 1 and 002 Table 2) and adds e0 = E0 / rho0 to the
 * particles' specific energy in setup.
 *
 * Sound speed (001 digest section 1.7, recommendation for the JWL gas):
 *   c^2 = (dp/drho)_e + (p / rho^2)(dp/de)_rho,  (dp/de)_rho = omega rho,
 *   (dp/drho)_e = -(V/rho) sum_k A_k exp(-R_k V) [omega/(R_k V^2) - R_k + omega/V] + omega e.
 *
 * Programmed burn (001 digest section 1.9, 002 digest section 5.3 [REC]): lighting time
 * t_L = min over sources of (distance / D + delay); burn fraction
 * F = clamp((t - t_L) D / (burn_width * spacing), 0, 1), raised to Wilkins' beta burn
 * (1 - V)/(1 - V_CJ) under compression (volume_burn) within volume_burn_lead spacings ahead of the
 * lighting front, kept monotone; p = F p_JWL. Unburnt
 * material is inert (p = 0) but keeps the products' sound speed, so the time step and the
 * artificial viscosity stay finite. V_CJ comes from the CJ point of the parameters (create). */
#include <math.h>
#include <string.h>

#include "ejecta/plugin.h"

#define JWL_MAX_SOURCES 4

typedef struct jwl_source {
  ej_real point[3];
  ej_real normal[3];    /* non-zero: a plane through point */
  ej_real direction[3]; /* non-zero: a line through point  */
  ej_real speed;
  ej_real delay;
} jwl_source;

typedef struct jwl_config {
  ej_real A, B, R1, R2, omega, rho0, e0, E0;
  jwl_source detonation, detonation_2, detonation_3, detonation_4;
  ej_real burn_width, rho_min, p_min;
  bool volume_burn;
  ej_real volume_burn_lead;
} jwl_config;

static const ej_param jwl_source_params[] = {
    EJ_PARAM_ARRAY(jwl_source, point, 3, "m", 0,
                   "Detonation point (three coordinates; y = z = 0 in 1D); for a plane or a line, a point on it."),
    EJ_PARAM_ARRAY(jwl_source, normal, 3, "1", 0,
                   "Normal of a detonation plane: lit at t = delay, the front runs to both sides; "
                   "leave out for a point or a line."),
    EJ_PARAM_ARRAY(jwl_source, direction, 3, "1", 0,
                   "Direction of a detonation line (a cylindrical front around it); leave out for a point or a plane."),
    EJ_PARAM_REAL(jwl_source, speed, "m/s", 0, 0, 0, EJ_PF_REQUIRED | EJ_PF_HAS_MIN | EJ_PF_MIN_OPEN,
                  "Detonation speed D (for example 8193 m/s for C4); all sources of one explosive share it."),
    EJ_PARAM_REAL(jwl_source, delay, "s", 0, 0, 0, EJ_PF_HAS_MIN, "Time at which this source is lit."),
    {0}};

static const ej_param jwl_params[] = {
    EJ_PARAM_REAL(jwl_config, A, "Pa", 0, 0, 0, EJ_PF_REQUIRED | EJ_PF_HAS_MIN,
                  "First JWL coefficient A (e.g. 609.8 GPa for C4, 371.2 GPa for TNT)."),
    EJ_PARAM_REAL(jwl_config, B, "Pa", 0, 0, 0, EJ_PF_REQUIRED | EJ_PF_HAS_MIN, "Second JWL coefficient B."),
    EJ_PARAM_REAL(jwl_config, R1, "1", 0, 0, 0, EJ_PF_REQUIRED | EJ_PF_HAS_MIN | EJ_PF_MIN_OPEN,
                  "Exponent R1 of the first term (about 4 to 6)."),
    EJ_PARAM_REAL(jwl_config, R2, "1", 0, 0, 0, EJ_PF_REQUIRED | EJ_PF_HAS_MIN | EJ_PF_MIN_OPEN,
                  "Exponent R2 of the second term (about 1 to 2)."),
    EJ_PARAM_REAL(jwl_config, omega, "1", 0, 0, 0, EJ_PF_REQUIRED | EJ_PF_HAS_MIN | EJ_PF_MIN_OPEN,
                  "Grueneisen coefficient omega of the products (about 0.25 to 0.4)."),
    EJ_PARAM_REAL(jwl_config, rho0, "kg/m^3", 0, 0, 0, EJ_PF_REQUIRED | EJ_PF_HAS_MIN | EJ_PF_MIN_OPEN,
                  "Density of the unreacted explosive, defining V = rho0/rho (give the material's rho0)."),
    EJ_PARAM_REAL(jwl_config, e0, "J/kg", 0, 0, 0, EJ_PF_HAS_MIN,
                  "Detonation energy per unit mass, added to e in setup; give e0 or E0, not both."),
    EJ_PARAM_REAL(jwl_config, E0, "J/m^3", 0, 0, 0, EJ_PF_HAS_MIN,
                  "Detonation energy per unit initial volume (LS-DYNA E0), e0 = E0/rho0; give e0 or E0."),
    EJ_PARAM_BLOCK(jwl_config, detonation, jwl_source_params, jwl_source, 0,
                   "Programmed burn: a point (point), plane (point, normal) or line (point, direction) lit at "
                   "delay, and the speed; without it the whole charge is burnt from t = 0."),
    EJ_PARAM_BLOCK(jwl_config, detonation_2, jwl_source_params, jwl_source, 0,
                   "A second detonation source (lighting time = the earliest over all sources)."),
    EJ_PARAM_BLOCK(jwl_config, detonation_3, jwl_source_params, jwl_source, 0, "A third detonation source."),
    EJ_PARAM_BLOCK(jwl_config, detonation_4, jwl_source_params, jwl_source, 0, "A fourth detonation source."),
    EJ_PARAM_REAL(jwl_config, burn_width, "1", 3, 0, 0, EJ_PF_HAS_MIN | EJ_PF_MIN_OPEN,
                  "Width of the burn ramp behind the lighting front, in initial particle spacings."),
    EJ_PARAM_BOOL(jwl_config, volume_burn, true,
                  "Also burn compressed explosive: F >= (1 - V)/(1 - V_CJ) (Wilkins' beta burn), which keeps a "
                  "front lit at D <= D_CJ from piling up inert explosive."),
    EJ_PARAM_REAL(jwl_config, volume_burn_lead, "1", 6, 0, 0, EJ_PF_HAS_MIN,
                  "The beta burn acts only on explosive within this many initial spacings ahead of the lighting "
                  "front (t >= t_L - lead dx / D), so a slight compression far from the front (air pressure on "
                  "the charge's surface, a stress wave) does not pre-light it; 0 = anywhere (Wilkins, Radioss)."),
    EJ_PARAM_REAL(jwl_config, rho_min, "kg/m^3", 1e-3, 0, 0, EJ_PF_HAS_MIN | EJ_PF_MIN_OPEN,
                  "Density below which the EOS is evaluated at rho_min (vacuum, expansion)."),
    EJ_PARAM_REAL(jwl_config, p_min, "Pa", 0, 0, 0, EJ_PF_HAS_MAX,
                  "Pressure floor: the products hold no tension below it."),
    {0}};

typedef struct jwl_state {
  jwl_config cfg;
  ej_real e0;    /* specific detonation energy, J/kg */
  ej_real c_min; /* sound-speed floor, m/s */
  int n_src;     /* active detonation sources; 0 = no burn */
  int kind[JWL_MAX_SOURCES]; /* 0 point, 1 plane, 2 line */
  ej_real pt[JWL_MAX_SOURCES][3], dir[JWL_MAX_SOURCES][3], delay[JWL_MAX_SOURCES];
  ej_real speed;
  ej_real V_cj, D_cj, p_cj; /* CJ state of the parameters (relative volume, speed, pressure) */
} jwl_state;

static const jwl_source *jwl_source_at(const jwl_config *c, int k)
{
  return k == 0 ? &c->detonation : k == 1 ? &c->detonation_2 : k == 2 ? &c->detonation_3 : &c->detonation_4;
}

static ej_real jwl_norm3(const ej_real *a) { return sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]); }

/* ------------------------------------------------------------------ checks */

static ej_err jwl_check(const void *config, ej_diag *d)
{
  const jwl_config *c = config;
  if (c->e0 > 0 && c->E0 > 0)
    return ej_diag_error(d, "E0", "give the detonation energy once: e0 (J/kg) or E0 (J/m^3), not both");
  if (!(c->e0 > 0) && !(c->E0 > 0))
    return ej_diag_error(d, NULL, "needs the detonation energy: e0 (J/kg, per mass) or E0 (J/m^3, per initial "
                                  "volume), > 0");
  if (!(c->A > 0) && !(c->B > 0)) return ej_diag_error(d, "A", "A and B are both zero: this is not a JWL");
  static const char *const names[JWL_MAX_SOURCES] = {"detonation", "detonation_2", "detonation_3", "detonation_4"};
  ej_real speed = 0;
  for (int k = 0; k < JWL_MAX_SOURCES; ++k) {
    const jwl_source *s = jwl_source_at(c, k);
    if (!(s->speed > 0)) continue;
    if (jwl_norm3(s->normal) > 0 && jwl_norm3(s->direction) > 0)
      return ej_diag_error(d, names[k], "%s: give normal (a plane) or direction (a line), not both", names[k]);
    if (speed > 0 && s->speed != speed)
      return ej_diag_error(d, names[k],
                           "%s: speed %g m/s differs from the first source's %g m/s (one explosive, one "
                           "detonation speed)",
                           names[k], s->speed, speed);
    speed = s->speed;
  }
  return EJ_OK;
}

/* ------------------------------------------------------------------ CJ state */

/* Pressure on the products' Hugoniot centred on the unreacted state (rho0, p = 0, e0) at
 * eta = rho/rho0: the Rankine-Hugoniot energy jump e = e0 + p (1/rho0 - 1/rho)/2 inserted in
 * p = P_AB(V) + omega rho e, which is linear in e, gives
 *   p_H = (P_AB(V) + omega rho e0) / (1 - omega (eta - 1)/2). */
static ej_real jwl_hugoniot(const jwl_config *c, ej_real e0, ej_real eta)
{
  const ej_real V = 1.0 / eta, w = c->omega;
  const ej_real pab = c->A * (1.0 - w / (c->R1 * V)) * exp(-c->R1 * V) + c->B * (1.0 - w / (c->R2 * V)) * exp(-c->R2 * V);
  return (pab + w * eta * c->rho0 * e0) / (1.0 - 0.5 * w * (eta - 1.0));
}

/* D^2 on the Rayleigh line from (1/rho0, 0) through the Hugoniot point: p = rho0 D^2 (1 - 1/eta). */
static ej_real jwl_d2(const jwl_config *c, ej_real e0, ej_real eta)
{
  return jwl_hugoniot(c, e0, eta) / (c->rho0 * (1.0 - 1.0 / eta));
}

/* The CJ point is where the Rayleigh line is tangent to the Hugoniot, i.e. the minimum of D over
 * the Hugoniot (Chapman-Jouguet; digest 001 section 2.1 "[D] CJ states computed by minimising D
 * along the Rayleigh line"). Golden-section search on eta in (1, eta_max), where eta_max keeps
 * the Hugoniot's denominator positive. */
static void jwl_cj(const jwl_config *c, ej_real e0, ej_real *V_cj, ej_real *D_cj, ej_real *p_cj)
{
  const ej_real g = 0.5 * (sqrt(5.0) - 1.0);
  ej_real a = 1.0 + 1e-6, b = 1.0 + 1.98 / c->omega;
  if (b > 4.0) b = 4.0;
  ej_real x1 = b - g * (b - a), x2 = a + g * (b - a);
  ej_real f1 = jwl_d2(c, e0, x1), f2 = jwl_d2(c, e0, x2);
  for (int it = 0; it < 200 && b - a > 1e-12; ++it) {
    if (f1 < f2) {
      b = x2, x2 = x1, f2 = f1;
      x1 = b - g * (b - a), f1 = jwl_d2(c, e0, x1);
    } else {
      a = x1, x1 = x2, f1 = f2;
      x2 = a + g * (b - a), f2 = jwl_d2(c, e0, x2);
    }
  }
  const ej_real eta = 0.5 * (a + b);
  *V_cj = 1.0 / eta;
  *D_cj = sqrt(jwl_d2(c, e0, eta));
  *p_cj = jwl_hugoniot(c, e0, eta);
}

/* ------------------------------------------------------------------ create / destroy */

static ej_err jwl_create(const void *config, void **state)
{
  EJ_ENSURE(config && state, EJ_ERR_ARG, "jwl: NULL config or state");
  const jwl_config *cfg = config;
  /* The parameter table checks bounds; a direct caller may not have used it. */
  EJ_ENSURE(cfg->A >= 0 && cfg->B >= 0 && cfg->R1 > 0 && cfg->R2 > 0 && cfg->omega > 0 && cfg->rho0 > 0 &&
                cfg->burn_width > 0 && cfg->rho_min > 0 && cfg->p_min <= 0 && cfg->e0 >= 0 && cfg->E0 >= 0,
            EJ_ERR_ARG, "jwl: parameter out of range (A, B >= 0; R1, R2, omega, rho0, burn_width, rho_min > 0; "
                        "p_min <= 0)");
  EJ_TRY(jwl_check(cfg, NULL));
  const ej_real e0 = cfg->e0 > 0 ? cfg->e0 : cfg->E0 / cfg->rho0;
  ej_real V_cj, D_cj, p_cj;
  jwl_cj(cfg, e0, &V_cj, &D_cj, &p_cj);
  /* An interior minimum of D: the search did not stop at one of its ends. */
  EJ_ENSURE(V_cj > 0.0 && V_cj < 1.0 - 1e-5 && isfinite(D_cj) && p_cj > 0, EJ_ERR_INPUT,
            "jwl: these parameters have no Chapman-Jouguet point (V_CJ = %g, D_CJ = %g m/s)", V_cj, D_cj);
  jwl_state *s = ej_calloc(1, sizeof *s);
  EJ_ENSURE(s, EJ_ERR_MEM, "jwl: out of memory");
  s->cfg = *cfg;
  s->e0 = e0;
  s->V_cj = V_cj, s->D_cj = D_cj, s->p_cj = p_cj;
  /* A floor far below any physical sound speed of the products (sqrt((A+B)/rho0) is ~20 km/s):
   * keeps c > 0 where e <= 0 and p sits on p_min. */
  s->c_min = 1e-4 * sqrt((cfg->A + cfg->B) / cfg->rho0);
  for (int k = 0; k < JWL_MAX_SOURCES; ++k) {
    const jwl_source *src = jwl_source_at(cfg, k);
    if (!(src->speed > 0)) continue;
    const int i = s->n_src++;
    const ej_real nn = jwl_norm3(src->normal), nd = jwl_norm3(src->direction);
    s->kind[i] = nn > 0 ? 1 : nd > 0 ? 2 : 0;
    for (int a = 0; a < 3; ++a) {
      s->pt[i][a] = src->point[a];
      s->dir[i][a] = nn > 0 ? src->normal[a] / nn : nd > 0 ? src->direction[a] / nd : 0;
    }
    s->delay[i] = src->delay;
    s->speed = src->speed;
  }
  *state = s;
  return EJ_OK;
}

static void jwl_destroy(void *state) { ej_free(state); }

/* ------------------------------------------------------------------ pressure and sound speed */

/* Fully burnt p and c at one point, with the cutoffs. */
static inline void jwl_point(const jwl_state *s, ej_real rho_in, ej_real e, ej_real *p_out, ej_real *c_out)
{
  const jwl_config *c = &s->cfg;
  /* rho_min also catches rho <= 0 and keeps exp(-R V) away from exp(+inf). */
  const ej_real rho = rho_in > c->rho_min ? rho_in : c->rho_min;
  const ej_real V = c->rho0 / rho, w = c->omega;
  const ej_real x1 = exp(-c->R1 * V), x2 = exp(-c->R2 * V);
  /* digest 001 Eq 13 / 000 Eq 38 with the last term omega rho e (000 "Clarification") */
  const ej_real p = c->A * (1.0 - w / (c->R1 * V)) * x1 + c->B * (1.0 - w / (c->R2 * V)) * x2 + w * rho * e;
  /* (dp/drho)_e = -(V/rho) dp/dV|_e + omega e; dp/de|_rho = omega rho (001 digest section 1.7) */
  const ej_real dpdV = c->A * x1 * (w / (c->R1 * V * V) - c->R1 + w / V) + c->B * x2 * (w / (c->R2 * V * V) - c->R2 + w / V);
  const ej_real dpdrho = -(V / rho) * dpdV + w * e;
  const ej_real pc = p > c->p_min ? p : c->p_min;
  if (p_out) *p_out = pc;
  if (c_out) {
    /* Isentropic c^2 = (dp/drho)_e + (p/rho^2) dp/de with the pressure actually used. The
     * ideal-gas tail omega (1 + omega) e (the V -> inf limit) and c_min keep it real and > 0. */
    ej_real c2 = dpdrho + w * pc / rho;
    const ej_real tail = w * (1.0 + w) * (e > 0 ? e : 0.0);
    if (!(c2 > tail)) c2 = tail; /* also replaces a NaN */
    const ej_real cc = sqrt(c2);
    *c_out = cc > s->c_min ? cc : s->c_min;
  }
}

static ej_err jwl_evaluate(const void *state, ej_idx n, const ej_real *restrict rho, const ej_real *restrict e,
                           ej_real *restrict p, ej_real *restrict c)
{
  const jwl_state *s = state;
  for (ej_idx i = 0; i < n; ++i) jwl_point(s, rho[i], e[i], p + i, c ? c + i : NULL);
  return EJ_OK;
}

/* ------------------------------------------------------------------ programmed burn */

static ej_err jwl_declare(const void *config, int dim, ej_decl *d)
{
  (void)dim;
  const jwl_config *cfg = config;
  bool burn = false;
  for (int k = 0; k < JWL_MAX_SOURCES; ++k) burn |= jwl_source_at(cfg, k)->speed > 0;
  if (!burn) return EJ_OK;
  static const ej_field_decl fields[] = {
      {.name = "t_light", .kind = EJ_SCALAR, .flags = EJ_FIELD_OUTPUT, .unit = "s",
       .doc = "Lighting time of the programmed burn (distance to the nearest source / D + delay)."},
      {.name = "burn", .kind = EJ_SCALAR, .flags = EJ_FIELD_OUTPUT, .unit = "1",
       .doc = "Burn fraction F in [0, 1]; the pressure is F p_JWL."},
  };
  for (size_t k = 0; k < sizeof fields / sizeof fields[0]; ++k) EJ_TRY(ej_decl_field(d, &fields[k]));
  return EJ_OK;
}

/* Distance from x to source k: point, plane (both sides) or line. */
static ej_real jwl_distance(const jwl_state *s, int k, const ej_real *x)
{
  ej_real r[3];
  for (int a = 0; a < 3; ++a) r[a] = x[a] - s->pt[k][a];
  if (s->kind[k] == 0) return jwl_norm3(r);
  const ej_real along = r[0] * s->dir[k][0] + r[1] * s->dir[k][1] + r[2] * s->dir[k][2];
  if (s->kind[k] == 1) return fabs(along);
  for (int a = 0; a < 3; ++a) r[a] -= along * s->dir[k][a];
  return jwl_norm3(r);
}

static ej_err jwl_setup(const void *state, ej_set *set)
{
  const jwl_state *s = state;
  const ej_idx n = ej_set_count(set);
  ej_real *e = ej_set_field(set, "e");
  EJ_ENSURE(e, EJ_ERR_UNSUPPORTED,
            "set '%s': the jwl EOS needs a method with a specific internal energy field 'e'", ej_set_name(set));
  /* The detonation energy is internal energy of the unreacted charge (digest 001 section 1.9:
   * "switches to JWL with e = E0"); it is added, so an `e:` initial condition comes on top. */
  for (ej_idx i = 0; i < n; ++i) e[i] += s->e0;
  if (s->n_src == 0) return EJ_OK;
  const ej_real *x = ej_set_field(set, "x");
  ej_real *tl = ej_set_field(set, "t_light"), *burn = ej_set_field(set, "burn");
  EJ_ENSURE(x && tl && burn, EJ_ERR_INTERNAL, "set '%s': jwl burn fields missing", ej_set_name(set));
  for (ej_idx i = 0; i < n; ++i) {
    ej_real t = INFINITY;
    for (int k = 0; k < s->n_src; ++k) {
      const ej_real tk = s->delay[k] + jwl_distance(s, k, x + 3 * i) / s->speed;
      if (tk < t) t = tk;
    }
    tl[i] = t;
    burn[i] = 0.0;
  }
  return EJ_OK;
}

static ej_err jwl_evaluate_set(const void *state, ej_set *set, ej_range r, const ej_real *restrict rho,
                               const ej_real *restrict e, ej_real *restrict p, ej_real *restrict c)
{
  const jwl_state *s = state;
  const ej_idx n = r.end - r.begin;
  if (s->n_src == 0) return jwl_evaluate(state, n, rho, e, p, c);
  const ej_real *restrict tl = ej_set_field(set, "t_light");
  ej_real *restrict burn = ej_set_field(set, "burn");
  EJ_ENSURE(tl && burn, EJ_ERR_INTERNAL, "set '%s': jwl burn fields missing", ej_set_name(set));
  const ej_real t = ej_set_time(set);
  const ej_real width = s->cfg.burn_width * ej_set_spacing_min(set);
  /* Ramp duration width / D: the burn front has the lighting front's speed and this thickness. */
  const ej_real rate = width > 0 ? s->speed / width : INFINITY;
  /* the beta burn's window ahead of the lighting front: SPH's kernel push and the front's own
   * smoothing reach a few spacings ahead (h <= 2 dx: support <= 4 dx); beyond that a compressed
   * particle is not part of the detonation and stays inert until its lighting time */
  const ej_real lead = s->cfg.volume_burn_lead > 0 ? s->cfg.volume_burn_lead * ej_set_spacing_min(set) / s->speed
                                                   : INFINITY;
  for (ej_idx k = 0; k < n; ++k) {
    const ej_idx i = r.begin + k;
    ej_real F = t >= tl[i] ? (t - tl[i]) * rate : 0.0;
    if (s->cfg.volume_burn && rho[k] > s->cfg.rho0 && t >= tl[i] - lead) {
      /* Wilkins' beta burn (M. L. Wilkins, Methods Comput. Phys. 3 (1964) 211; Radioss
       * /MAT/LAW5 IBFRAC = 0, "volumetric compression + burning time"): compression to V_CJ
       * burns completely. Inert explosive (p = 0) ahead of a front lit at D <= D_CJ is otherwise
       * compressed without resistance by the kernel-smoothed push of the products and the
       * front overdrives itself (measured: 73 GPa instead of 28 GPa after 1800 spacings). */
      const ej_real Fv = (1.0 - s->cfg.rho0 / rho[k]) / (1.0 - s->V_cj);
      if (Fv > F) F = Fv;
    }
    F = F < 1.0 ? F : 1.0;
    if (F < burn[i]) F = burn[i]; /* never un-burn */
    burn[i] = F;
    ej_real pk;
    jwl_point(s, rho[k], e[k], &pk, c ? c + k : NULL);
    /* Unburnt explosive is inert (p = 0; 002 digest section 5.3 [REC]); it keeps the products'
     * sound speed above, which bounds the step and sets the viscosity at the front. */
    p[k] = F * pk;
  }
  return EJ_OK;
}

static const ej_eos_ops jwl_ops = {
    .struct_size = sizeof(ej_eos_ops),
    .name = "jwl",
    .summary = "Jones-Wilkins-Lee detonation products with programmed burn",
    .doc = "p = A (1 - omega/(R1 V)) exp(-R1 V) + B (1 - omega/(R2 V)) exp(-R2 V) + omega rho e, V = rho0/rho; "
           "e0 (or E0/rho0) is added to e at setup. With a detonation block, p = F p_JWL with the burn "
           "fraction F = clamp((t - t_light) D / (burn_width spacing), 0, 1), t_light = distance/D + delay.",
    .params = jwl_params,
    .config_size = sizeof(jwl_config),
    .check_config = jwl_check,
    .create = jwl_create,
    .evaluate = jwl_evaluate,
    .destroy = jwl_destroy,
    .declare = jwl_declare,
    .setup = jwl_setup,
    .evaluate_set = jwl_evaluate_set,
};

static ej_err jwl_register(ej_registry *reg)
{
  EJ_TRY(ej_register_eos(reg, &jwl_ops));
  return EJ_OK;
}

EJ_PLUGIN_DEFINE(jwl, "0.1.0", "BSD-3-Clause", "Jones-Wilkins-Lee EOS with programmed burn", jwl_register)

/* Updated-Lagrangian non-ordinary state-based peridynamics (correspondence form) for gases,
 * explosive products and, through a strength model, solids.
 *
 * Source: Zhu & Zhao, "Peridynamic modelling of blasting induced rock fractures", digest 002
 * section 5.1 (Eqs 45-47; after Bergel & Li 2016 and Behzadinasab & Foster 2020), with the
 * influence function of section 1.2, the artificial viscosity of section 1.7 (Eqs 42-44, in the
 * digest's recommended viscous-pressure form, erratum 6) and, for strength models, the stress
 * update of section 1.5 with Hughes-Winget rotation (erratum 2: the printed Flanagan-Taylor
 * update of Eq 7 is not orthogonal). Every bond is evaluated in the CURRENT configuration:
 *
 *   y_ij  = x_j - x_i,  r = |y_ij|,  omega_ij = (1 - r/delta_i)^2 for r < delta_i    (002 sec 1.2)
 *   M_i   = sum_j omega_ij V_j y_ij (x) y_ij                                           (002 Eq 45)
 *   L_i   = [sum_j omega_ij V_j (v_j - v_i) (x) y_ij] M_i^-1                           (002 Eq 46)
 *   T_ij  = omega_ij (sigma_i - q_i I) M_i^-1 y_ij                                     (002 Eq 47)
 *   rho_i a_i = sum_j V_j (T_ij - T_ji) = sum_j V_j [omega_ij S_i + omega_ji S_j] y_ij,
 *               S_i = (sigma_i - q_i I) M_i^-1                          (002 Eq 1, UL form)
 *   drho_i/dt = -rho_i tr(L_i)                         (002 sec 5.1: V_dot = V tr L, rho = m/V)
 *   de_i/dt   = (sigma_i - q_i I) : D_i / rho_i,  D = sym(L)
 *
 * The paper's omega = (delta - r)^2 differs from ours by delta^2, which cancels in L, in
 * omega M^-1 and in every ratio used below, so the discrete equations are the paper's.
 * V_j = m_j / rho_j is the current volume. omega_ji uses delta_j (dual horizon, 002 sec 5.4), so
 * a pair appears in both rows with the same two terms and the pair forces are equal and opposite:
 * momentum is conserved to round-off for any particle arrangement and any horizons. With the
 * same M_i^-1 (symmetric) in L_i and in the force, sum_i m_i v_i.a_i = -sum_i V_i S_i : N_i =
 * -sum_i V_i (sigma_i - q_i I) : L_i, so the energy equation above conserves total energy
 * exactly for the semi-discrete system.
 *
 * Two passes per step (the core copies fields to ghosts in between):
 *   pass 0 (family of i): density floor, horizon, EOS, M_i, L_i, phi_i, stress (fluid: -p I;
 *          strength model: Hughes-Winget rotation, then the material's update), q_i, S_i,
 *          rates of rho, e, w_visc, w_plastic, local stable step;
 *   pass 1 (pairs, gather form): accelerations and the stabilisation heat.
 */
#include <math.h>
#include <string.h>

#include "ejecta/plugin.h"
#include "ejecta/tensor.h"

#if defined(__GNUC__)
#define ULPD_ALWAYS_INLINE __attribute__((always_inline))
#else
#define ULPD_ALWAYS_INLINE
#endif

#define ULPD_MAX_HIST 32

typedef struct ulpd_config {
  ej_real horizon;
  bool variable_horizon;
  ej_real delta_min, delta_max;
  ej_real C_q, C_l;
  ej_real c_hg;
  ej_real rcond_min;
  ej_real regularization;
  ej_real rho_min;
  ej_real p_min;
  int density;
} ulpd_config;

enum { ULPD_DENS_CONTINUITY = 0, ULPD_DENS_SUMMATION = 1 };
static const char *const ulpd_density_names[] = {"continuity", "summation", NULL};

static const ej_param ulpd_params[] = {
    EJ_PARAM_REAL(ulpd_config, horizon, "1", 3.0, 1.0, 6.0, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX | EJ_PF_MIN_OPEN,
                  "Horizon in particle spacings, delta_i = horizon (m_i/rho_i)^(1/dim) (002 sec 1.2: three "
                  "times the element size; the paper's explosive used 3.75)."),
    EJ_PARAM_BOOL(ulpd_config, variable_horizon, 1,
                  "Scale the horizon with the current particle spacing (m/rho)^(1/dim), like an SPH smoothing "
                  "length (true), or keep delta = horizon vol0^(1/dim) as in the paper (false; the family then "
                  "empties as the gas expands)."),
    EJ_PARAM_REAL(ulpd_config, delta_min, "1", 0.0, 0.0, 1.0, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX,
                  "Lower bound of a variable horizon as a multiple of the initial one; 0 gives 0.2 in 3D and the "
                  "same volume ratio in 1D and 2D, 0.2^(3/dim)."),
    EJ_PARAM_REAL(ulpd_config, delta_max, "1", 0.0, 0.0, 0.0, EJ_PF_HAS_MIN,
                  "Upper bound of a variable horizon as a multiple of the initial one (bounds the family size "
                  "in an expansion towards vacuum); 0 gives 2 in 3D and the same volume ratio in 1D and 2D."),
    EJ_PARAM_REAL(ulpd_config, C_q, "1", 8.0, 0.0, 0.0, EJ_PF_HAS_MIN,
                  "Quadratic coefficient of the artificial viscous pressure q = rho (C_q phi^2 - C_l c phi) in "
                  "compression (002 Eq 42: 8.0)."),
    EJ_PARAM_REAL(ulpd_config, C_l, "1", 0.1, 0.0, 0.0, EJ_PF_HAS_MIN,
                  "Linear coefficient of the artificial viscous pressure (002 Eq 42: 0.1)."),
    EJ_PARAM_REAL(ulpd_config, c_hg, "1", 0.1, 0.0, 1.0, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX,
                  "Zero-energy-mode control: bond viscosity on the part of v_j - v_i that L_i does not "
                  "reproduce, kinematic viscosity c_hg c delta (the rate analogue of 002 Eq 15; vanishes for "
                  "linear velocity fields); 0 switches it off."),
    EJ_PARAM_REAL(ulpd_config, rcond_min, "1", 1e-3, 0.0, 0.3, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX | EJ_PF_EXPERT,
                  "Shape-tensor guard: below this reciprocal condition estimate (1/3 for an isotropic family) "
                  "M is regularised and the particle counted as a fallback."),
    EJ_PARAM_REAL(ulpd_config, regularization, "1", 1e-2, 0.0, 1.0,
                  EJ_PF_HAS_MIN | EJ_PF_HAS_MAX | EJ_PF_MIN_OPEN | EJ_PF_EXPERT,
                  "Fallback: M + lambda I is inverted instead of M, lambda = regularization tr(M)/dim (a "
                  "Tikhonov pseudo-inverse: exact in the span of the bonds as lambda -> 0)."),
    EJ_PARAM_REAL(ulpd_config, rho_min, "1", 1e-6, 0.0, 1.0,
                  EJ_PF_HAS_MIN | EJ_PF_HAS_MAX | EJ_PF_MAX_OPEN | EJ_PF_EXPERT,
                  "Density floor as a fraction of each particle's initial density m/vol0 (expansion into "
                  "vacuum)."),
    EJ_PARAM_REAL(ulpd_config, p_min, "Pa", 0.0, 0.0, 0.0, 0,
                  "Pressure cutoff of fluid sets (no strength model): an EOS pressure below it is replaced by it "
                  "(0: a fluid carries no tension). Sets with a strength model are not cut."),
    EJ_PARAM_ENUM(ulpd_config, density, ulpd_density_names, "continuity",
                    "Density: continuity, drho/dt = -rho tr(L) (002 sec 5.1), or summation over the family, "
                    "rho_i = sum_j m_j W(r_ij, delta_i/2) with the cubic spline of support delta_i "
                    "(ejecta's option: the density follows the particle arrangement, which keeps an "
                    "irregular initial cloud from carrying a density error; under-estimates at free surfaces)."),
    {0}};

/* Bits of the per-step flag field. */
enum { ULPD_FLAG_FALLBACK = 1, ULPD_FLAG_RHO_FLOOR = 2, ULPD_FLAG_P_CUT = 4 };

typedef struct ulpd_state {
  ulpd_config cfg;
  const ej_set *set;
  int dim;
  const ej_eos *eos;
  const ej_material *mat;
  bool use_eos; /* EOS pressure feeds the stress (fluid, or a material with needs_eos) */
  const char *set_name;
  int64_t n_rho_floor, n_p_cut, n_fallback_steps; /* summed by report (serial) */
} ulpd_state;

/* Field pointers of one compute call (valid until the next rebuild). */
typedef struct ulpd_fields {
  ej_real *x, *v, *a, *m, *vol0;
  ej_real *rho, *rho_dot, *e, *e_dot, *p, *c, *delta, *h, *q, *stress;
  ej_real *w_visc_dot, *w_plastic_dot, *L, *S, *kappa, *d_rate, *wp_inc, *dt_local;
  int32_t *flags, *fb_total;
} ulpd_fields;

/* ------------------------------------------------------------------ declare */

static ej_err ulpd_declare(const void *config, int dim, ej_decl *d)
{
  const ulpd_config *cfg = config;
  EJ_ENSURE(dim >= 1 && dim <= 3, EJ_ERR_ARG, "ulpd: dimension %d not in 1..3", dim);
  /* With summation density rho is recomputed from the positions each step: not integrated. */
  const bool summation = cfg && cfg->density == ULPD_DENS_SUMMATION;
  const ej_field_decl fields[] = {
      {.name = "rho", .kind = EJ_SCALAR, .flags = EJ_FIELD_OUTPUT, .unit = "kg/m^3",
       .rate = summation ? NULL : "rho_dot",
       .doc = "Density, evolved by drho/dt = -rho tr(L) (density: continuity) or summed over the family "
              "(density: summation)."},
      {.name = "e", .kind = EJ_SCALAR, .flags = EJ_FIELD_OUTPUT, .unit = "J/kg", .rate = "e_dot",
       .energy = EJ_ENERGY_INTERNAL, .doc = "Specific internal energy."},
      {.name = "p", .kind = EJ_SCALAR, .flags = EJ_FIELD_SCRATCH | EJ_FIELD_OUTPUT, .unit = "Pa",
       .doc = "Pressure -tr(sigma)/3 (compression positive), without the artificial viscosity."},
      {.name = "c", .kind = EJ_SCALAR, .flags = EJ_FIELD_SCRATCH, .unit = "m/s",
       .doc = "Sound speed (EOS, or the strength model's P-wave speed)."},
      {.name = "delta", .kind = EJ_SCALAR, .flags = EJ_FIELD_SCRATCH | EJ_FIELD_OUTPUT, .unit = "m",
       .doc = "Horizon: radius of the current-configuration family."},
      {.name = "h", .kind = EJ_SCALAR, .flags = EJ_FIELD_SCRATCH | EJ_FIELD_OUTPUT, .unit = "m",
       .doc = "Smoothing length published for kernel couplings (continuum, pd_sph): delta/2, so that a "
              "coupling kernel of support 2h reaches as far as the family and follows the current spacing."},
      {.name = "q", .kind = EJ_SCALAR, .flags = EJ_FIELD_SCRATCH | EJ_FIELD_NO_GHOST, .unit = "Pa",
       .doc = "Artificial viscous pressure (002 Eq 42-44, viscous-pressure form)."},
      /* ghosted: a coupling (continuum, pd_sph) reads it at this set's mirror and periodic images */
      {.name = "stress", .kind = EJ_SYM6, .flags = EJ_FIELD_OUTPUT, .unit = "Pa",
       .doc = "Cauchy stress without the artificial viscosity (fluids: -p I)."},
      {.name = "w_visc", .kind = EJ_SCALAR, .flags = EJ_FIELD_NO_GHOST, .unit = "J/kg", .rate = "w_visc_dot",
       .energy = EJ_ENERGY_VISCOUS,
       .doc = "Specific work dissipated by the artificial viscosity and the zero-energy-mode control "
              "(already part of e)."},
      {.name = "w_plastic", .kind = EJ_SCALAR, .flags = EJ_FIELD_NO_GHOST, .unit = "J/kg",
       .rate = "w_plastic_dot", .energy = EJ_ENERGY_PLASTIC,
       .doc = "Specific plastic work reported by the strength model (already part of e)."},
      {.name = "vel_grad", .kind = EJ_TENSOR9, .flags = EJ_FIELD_SCRATCH, .unit = "1/s",
       .doc = "Velocity gradient L_i (002 Eq 46)."},
      {.name = "S_force", .kind = EJ_TENSOR9, .flags = EJ_FIELD_SCRATCH, .unit = "Pa/m^5",
       .doc = "(sigma_i - q_i I) M_i^-1: the force state is omega S_i y (002 Eq 47)."},
      {.name = "kappa", .kind = EJ_SCALAR, .flags = EJ_FIELD_SCRATCH, .unit = "Pa s/m^5",
       .doc = "Bond viscosity of the zero-energy-mode control, 2 dim c_hg rho c delta / tr(M)."},
      {.name = "d_rate", .kind = EJ_SYM6, .flags = EJ_FIELD_SCRATCH | EJ_FIELD_NO_GHOST, .unit = "1/s",
       .doc = "Rate of deformation D = sym(L) handed to the strength model."},
      {.name = "wp_inc", .kind = EJ_SCALAR, .flags = EJ_FIELD_SCRATCH | EJ_FIELD_NO_GHOST, .unit = "J/kg",
       .doc = "Plastic work increment of the step from the strength model."},
      {.name = "dt_local", .kind = EJ_SCALAR, .flags = EJ_FIELD_SCRATCH | EJ_FIELD_NO_GHOST, .unit = "s",
       .doc = "Stable step of the particle."},
      {.name = "ulpd_flags", .kind = EJ_INT, .flags = EJ_FIELD_SCRATCH | EJ_FIELD_NO_GHOST, .unit = "1",
       .doc = "This step: 1 shape-tensor fallback, 2 density floor, 4 pressure cutoff."},
      {.name = "shape_fallbacks", .kind = EJ_INT, .flags = EJ_FIELD_NO_GHOST, .unit = "1",
       .doc = "Steps in which this particle's shape tensor was ill-conditioned and regularised."},
  };
  for (size_t k = 0; k < sizeof fields / sizeof fields[0]; ++k) EJ_TRY(ej_decl_field(d, &fields[k]));
  EJ_TRY(ej_decl_neighbours(d, EJ_NBR_CURRENT));
  return EJ_OK;
}

/* ------------------------------------------------------------------ create / destroy */

static ej_err ulpd_create(const void *config, ej_set *set, const ej_model *model, void **state)
{
  EJ_ENSURE(config && set && model && state, EJ_ERR_ARG, "ulpd: NULL argument to create");
  const ulpd_config *cfg = config;
  const int dim = ej_set_dim(set);
  EJ_ENSURE(dim >= 1 && dim <= 3, EJ_ERR_ARG, "ulpd: dimension %d not in 1..3", dim);
  const ej_eos *eos = ej_model_eos(model);
  const ej_material *mat = ej_model_material(model);
  EJ_ENSURE(eos || mat, EJ_ERR_UNSUPPORTED,
            "set '%s': ulpd needs an equation of state (fluid) or a strength model, and material '%s' has "
            "neither (add eos: {...})",
            ej_set_name(set), ej_model_name(model));
  EJ_ENSURE(!mat || ej_material_n_hist(mat) <= ULPD_MAX_HIST, EJ_ERR_UNSUPPORTED,
            "set '%s': ulpd supports at most %d history variables", ej_set_name(set), ULPD_MAX_HIST);
  ulpd_state *s = ej_calloc(1, sizeof *s);
  EJ_ENSURE(s, EJ_ERR_MEM, "ulpd: out of memory");
  s->cfg = *cfg;
  if (s->cfg.delta_min <= 0.0) s->cfg.delta_min = pow(0.2, 3.0 / dim);
  if (s->cfg.delta_max <= 0.0) s->cfg.delta_max = pow(2.0, 3.0 / dim);
  if (!(s->cfg.delta_max >= 1.0 && s->cfg.delta_min <= 1.0)) {
    ej_free(s);
    EJ_FAIL(EJ_ERR_INPUT, "set '%s': ulpd needs delta_min <= 1 <= delta_max", ej_set_name(set));
  }
  s->dim = dim;
  s->eos = eos;
  s->mat = mat;
  /* The EOS pressure feeds the stress whenever the model has an EOS: a fluid's stress is -p I,
   * and a strength model with needs_eos adds -p I to its deviator (plugin.h); one without
   * needs_eos computes its volumetric part itself and ignores b->p. */
  s->use_eos = eos != NULL;
  s->set_name = ej_set_name(set);
  s->set = set;
  *state = s;
  return EJ_OK;
}

static void ulpd_destroy(void *state) { ej_free(state); }

/* ------------------------------------------------------------------ helpers */

static inline ej_real ulpd_root(int dim, ej_real v) { return dim == 3 ? cbrt(v) : dim == 2 ? sqrt(v) : v; }
static inline ej_real ulpd_powd(int dim, ej_real x) { return dim == 3 ? x * x * x : dim == 2 ? x * x : x; }

static inline ej_real ulpd_rho_floor(const ulpd_config *cfg, ej_real m, ej_real vol0)
{
  return cfg->rho_min * m / vol0;
}

/* Horizon delta_i = horizon (m/rho)^(1/dim), the volume ratio rho0/rho bounded to
 * [delta_min, delta_max]^dim (as the sph smoothing length; LS-DYNA HMIN/HMAX), or the fixed
 * delta = horizon vol0^(1/dim) of the paper (002 sec 5.1: the family radius does not change). */
static inline ej_real ulpd_horizon(const ulpd_config *cfg, int dim, ej_real m, ej_real vol0, ej_real rho)
{
  if (!cfg->variable_horizon) return cfg->horizon * ulpd_root(dim, vol0);
  ej_real ratio = m / (rho * vol0);
  const ej_real lo = ulpd_powd(dim, cfg->delta_min), hi = ulpd_powd(dim, cfg->delta_max);
  ratio = ratio < lo ? lo : ratio > hi ? hi : ratio;
  return cfg->horizon * ulpd_root(dim, ratio * vol0);
}

static ej_err ulpd_bad_particle(const ulpd_state *s, const ej_set *set, ej_idx i, const char *what, ej_real val)
{
  const ej_real *x = ej_set_field(set, "x");
  const int32_t *id = ej_set_field_int(set, "id");
  EJ_FAIL(EJ_ERR_NUMERIC, "set '%s': ulpd particle id %d at (%g, %g, %g): %s = %g", s->set_name,
          id ? (int)id[i] : (int)i, x ? x[3 * i] : NAN, x ? x[3 * i + 1] : NAN, x ? x[3 * i + 2] : NAN, what, val);
}

static ej_err ulpd_get_fields(const ulpd_state *s, ej_set *set, ulpd_fields *F)
{
  F->x = ej_set_field(set, "x"), F->v = ej_set_field(set, "v"), F->a = ej_set_field(set, "a");
  F->m = ej_set_field(set, "m"), F->vol0 = ej_set_field(set, "vol0");
  F->rho = ej_set_field(set, "rho"), F->rho_dot = ej_set_field(set, "rho_dot");
  F->e = ej_set_field(set, "e"), F->e_dot = ej_set_field(set, "e_dot");
  F->p = ej_set_field(set, "p"), F->c = ej_set_field(set, "c"), F->delta = ej_set_field(set, "delta");
  F->h = ej_set_field(set, "h");
  F->q = ej_set_field(set, "q"), F->stress = ej_set_field(set, "stress");
  F->w_visc_dot = ej_set_field(set, "w_visc_dot"), F->w_plastic_dot = ej_set_field(set, "w_plastic_dot");
  F->L = ej_set_field(set, "vel_grad"), F->S = ej_set_field(set, "S_force"), F->kappa = ej_set_field(set, "kappa");
  F->d_rate = ej_set_field(set, "d_rate"), F->wp_inc = ej_set_field(set, "wp_inc");
  F->dt_local = ej_set_field(set, "dt_local");
  F->flags = ej_set_field_int(set, "ulpd_flags"), F->fb_total = ej_set_field_int(set, "shape_fallbacks");
  /* rho_dot exists only with density: continuity (the rate of the integrated rho). */
  const bool rho_ok = F->rho && (F->rho_dot || s->cfg.density == ULPD_DENS_SUMMATION);
  EJ_ENSURE(F->x && F->v && F->a && F->m && F->vol0 && rho_ok && F->e && F->e_dot && F->p && F->c &&
                F->delta && F->h && F->q && F->stress && F->w_visc_dot && F->w_plastic_dot && F->L && F->S && F->kappa &&
                F->d_rate && F->wp_inc && F->dt_local && F->flags && F->fb_total,
            EJ_ERR_INTERNAL, "set '%s': ulpd fields missing", s->set_name);
  return EJ_OK;
}

/* B = M^-1 for the dim x dim block of M (embedded in 3x3, zero outside the block). The block
 * is padded with tr(M)/dim on the unused diagonal so that ej_m3_inverse's reciprocal condition
 * estimate is that of the block (1/3 for an isotropic family in any dimension). Below rcond_min
 * (collinear or coplanar family, an isolated pair) M + lambda I, lambda = reg tr(M)/dim, is
 * inverted instead: on the span of the bonds it tends to the pseudo-inverse, and B stays
 * symmetric, which the energy identity needs. Returns 1 for a fallback. */
static inline int ulpd_inverse(int dim, const ej_real M[9], ej_real rcond_min, ej_real reg, ej_real B[9])
{
  ej_m3_zero(B);
  const ej_real trM = M[0] + M[4] + M[8];
  if (!(trM > 0.0)) return 1; /* no bond in the family: no force, no kinematics */
  const ej_real pad = trM / dim;
  ej_real A[9], Bi[9];
  ej_m3_copy(A, M);
  for (int k = dim; k < 3; ++k) A[4 * k] = pad;
  ej_real rc = ej_m3_inverse(Bi, A);
  int fb = 0;
  if (!(rc >= rcond_min) || rc == 0.0) {
    fb = 1;
    for (int k = 0; k < dim; ++k) A[4 * k] += reg * pad;
    rc = ej_m3_inverse(Bi, A);
    if (rc == 0.0) return 1;
  }
  for (int a = 0; a < dim; ++a)
    for (int b = 0; b < dim; ++b) B[3 * a + b] = 0.5 * (Bi[3 * a + b] + Bi[3 * b + a]);
  return fb;
}

/* ------------------------------------------------------------------ pass 0: families */

/* Entries of a row handled per block by the pair loops (stack scratch, no allocation). */
#define ULPD_BLK 128

/* Bond vectors y = x_j - x_i of a block of list entries jx[0..nb) into y0, y1, y2 (zero beyond dim). */
static inline ULPD_ALWAYS_INLINE void ulpd_block_bonds(const int dim, const ej_real *restrict x,
                                                       const ej_idx *restrict jx, int nb, ej_real xi0, ej_real xi1,
                                                       ej_real xi2, ej_real *restrict y0, ej_real *restrict y1,
                                                       ej_real *restrict y2)
{
  for (int t = 0; t < nb; ++t) {
    const ej_idx j = jx[t];
    y0[t] = x[3 * j] - xi0;
    y1[t] = dim > 1 ? x[3 * j + 1] - xi1 : 0.0;
    y2[t] = dim > 2 ? x[3 * j + 2] - xi2 : 0.0;
  }
}

/* Floors rho, sets delta for the particles of r; flags particles that hit the floor. */
static ej_err ulpd_prepare(const ulpd_state *s, const ej_set *set, const ulpd_fields *F, ej_range r, bool horizon)
{
  const ulpd_config *cfg = &s->cfg;
  for (ej_idx i = r.begin; i < r.end; ++i) {
    const ej_real floor = ulpd_rho_floor(cfg, F->m[i], F->vol0[i]);
    F->flags[i] = 0;
    /* "<" so that a NaN reaches the check below instead of being floored away. */
    if (F->rho[i] < floor) F->rho[i] = floor, F->flags[i] |= ULPD_FLAG_RHO_FLOOR;
    if (!(F->rho[i] > 0.0)) return ulpd_bad_particle(s, set, i, "density rho", F->rho[i]);
    if (!horizon) continue;
    F->delta[i] = ulpd_horizon(cfg, s->dim, F->m[i], F->vol0[i], F->rho[i]);
    F->h[i] = 0.5 * F->delta[i];
  }
  return EJ_OK;
}

/* Summation density (density: summation, ejecta's option): rho_i = sum_j m_j W(r_ij, h_i), self
 * term included, with the cubic spline (M4) of support delta_i, h_i = delta_i/2 (Monaghan &
 * Lattanzio, A&A 149 (1985) 135: f(q) = 1 - 3/2 q^2 + 3/4 q^3 for q < 1, (2 - q)^3/4 for
 * q < 2; sigma_d = 2/3, 10/(7 pi), 1/pi). Not the influence (1 - r/delta)^2 itself: its cusp at
 * r = 0 makes the lattice sum 5.6 % high at horizon 3 in 1D, where M4 at h = 1.5 spacings is
 * exact to 1e-4. delta_i is the one the neighbour list was built with (from the previous
 * density, as an SPH smoothing length lags one step); pass 0 then keeps it. Writes rho_i and
 * delta_i only: gather form. */
static ej_err ulpd_summation_pass(const ulpd_state *s, ej_set *set, const ej_nbr *nbr, ej_range r)
{
  EJ_ENSURE(nbr && nbr->n_rows >= r.end, EJ_ERR_INTERNAL, "set '%s': ulpd neighbour list has %d rows, range ends at %d",
            s->set_name, nbr ? (int)nbr->n_rows : -1, (int)r.end);
  ulpd_fields F;
  EJ_TRY(ulpd_get_fields(s, set, &F));
  EJ_TRY(ulpd_prepare(s, set, &F, r, true));
  const int dim = s->dim;
  const ej_real pi = 3.14159265358979323846;
  const ej_real sigma = dim == 1 ? 2.0 / 3.0 : dim == 2 ? 10.0 / (7.0 * pi) : 1.0 / pi;
  const ej_real *restrict x = F.x, *restrict m = F.m;
  /* Blocked as the pair loops below: the terms of a block of list entries in a vectorised loop
   * (an entry outside the support adds an exact 0, as the former `continue` skipped it), then
   * summed in list order: bitwise the former sums. */
  ej_real yb[3][ULPD_BLK], mb[ULPD_BLK], tb[ULPD_BLK];
  for (ej_idx i = r.begin; i < r.end; ++i) {
    const ej_real inv_h = 2.0 / F.delta[i];
    const ej_real xi[3] = {x[3 * i], x[3 * i + 1], x[3 * i + 2]};
    ej_real sum = m[i];
    for (ej_off k0 = nbr->off[i]; k0 < nbr->off[i + 1]; k0 += ULPD_BLK) {
      const int nb = nbr->off[i + 1] - k0 < ULPD_BLK ? (int)(nbr->off[i + 1] - k0) : ULPD_BLK;
      for (int t = 0; t < nb; ++t) {
        const ej_idx j = nbr->idx[k0 + t];
        for (int a = 0; a < 3; ++a) yb[a][t] = a < dim ? x[3 * j + a] - xi[a] : 0.0;
        mb[t] = m[j];
      }
#pragma omp simd
      for (int t = 0; t < nb; ++t) {
        const ej_real r2 = dim == 1 ? yb[0][t] * yb[0][t]
                           : dim == 2 ? yb[0][t] * yb[0][t] + yb[1][t] * yb[1][t]
                                      : yb[0][t] * yb[0][t] + yb[1][t] * yb[1][t] + yb[2][t] * yb[2][t];
        const ej_real q = sqrt(r2) * inv_h;
        const ej_real u = 2.0 - q;
        const ej_real w = q < 1.0 ? 1.0 - 1.5 * q * q + 0.75 * q * q * q : 0.25 * u * u * u;
        tb[t] = q >= 2.0 ? 0.0 : mb[t] * w;
      }
      for (int t = 0; t < nb; ++t) sum += tb[t];
    }
    F.rho[i] = sigma * sum * ulpd_powd(dim, inv_h);
  }
  return EJ_OK;
}

/* The family sums of particle i: M (Eq 45), N = sum omega V (v_j - v_i) (x) y (Eq 46 before
 * M^-1), gamma = sum omega V (Eq 43), phi_num = sum omega V (v_j - v_i).y/|y| (Eq 44). The
 * neighbour volume uses the floored density computed here from rho_j, so that the result does
 * not depend on whether j's own pass-0 floor already ran (gather form, any thread count).
 * Blocked as ulpd_forces: bond lengths and influences vectorised per block of entries, the bonds
 * inside the family compacted, their 17 products vectorised, then summed in list order (the same
 * expressions and sums as the former per-entry loop: bitwise the same results). */
static inline ULPD_ALWAYS_INLINE void ulpd_family(const int dim, const ulpd_config *cfg, const ulpd_fields *F,
                                                  const ej_off *restrict off, const ej_idx *restrict idx, ej_idx i,
                                                  ej_real M[9], ej_real N[9], ej_real *gamma, ej_real *phi_num)
{
  const ej_real *restrict x = F->x, *restrict v = F->v, *restrict m = F->m, *restrict vol0 = F->vol0;
  const ej_real *restrict rho = F->rho;
  const ej_real xi0 = x[3 * i], xi1 = dim > 1 ? x[3 * i + 1] : 0.0, xi2 = dim > 2 ? x[3 * i + 2] : 0.0;
  const ej_real vi0 = v[3 * i], vi1 = dim > 1 ? v[3 * i + 1] : 0.0, vi2 = dim > 2 ? v[3 * i + 2] : 0.0;
  const ej_real inv_delta = 1.0 / F->delta[i];
  const ej_real rmin = cfg->rho_min;
  enum { P00, P01, P02, P11, P12, P22, Q00, Q01, Q02, Q10, Q11, Q12, Q20, Q21, Q22, PG, PH, NP };
  ej_real acc[NP] = {0};
  ej_real y0b[ULPD_BLK], y1b[ULPD_BLK], y2b[ULPD_BLK], rb[ULPD_BLK], tb[ULPD_BLK];
  int64_t keep[ULPD_BLK]; /* 64-bit: the lanes of the influence loop are doubles */
  int kp[ULPD_BLK];
  ej_real ky0[ULPD_BLK], ky1[ULPD_BLK], ky2[ULPD_BLK], kr[ULPD_BLK], kt[ULPD_BLK], km[ULPD_BLK], kf[ULPD_BLK];
  ej_real krho[ULPD_BLK], kd0[ULPD_BLK], kd1[ULPD_BLK], kd2[ULPD_BLK];
  ej_real pr[NP][ULPD_BLK];
  for (ej_off k0 = off[i]; k0 < off[i + 1]; k0 += ULPD_BLK) {
    const int nb = off[i + 1] - k0 < ULPD_BLK ? (int)(off[i + 1] - k0) : ULPD_BLK;
    const ej_idx *restrict jx = idx + k0;
    ulpd_block_bonds(dim, x, jx, nb, xi0, xi1, xi2, y0b, y1b, y2b);
#pragma omp simd
    for (int t = 0; t < nb; ++t) {
      const ej_real y0 = y0b[t], y1 = y1b[t], y2 = y2b[t];
      const ej_real r2 = y0 * y0 + y1 * y1 + y2 * y2;
      const ej_real r = sqrt(r2);
      const ej_real tt = 1.0 - r * inv_delta;
      rb[t] = r, tb[t] = tt;
      /* outside the family (the list has a skin), or coincident: the former skip test */
      keep[t] = (int64_t)((tt > 0.0) & (r > 0.0));
    }
    int nk = 0;
    for (int t = 0; t < nb; ++t) kp[nk] = t, nk += keep[t];
    for (int q = 0; q < nk; ++q) {
      const int t = kp[q];
      const ej_idx j = jx[t];
      ky0[q] = y0b[t], ky1[q] = y1b[t], ky2[q] = y2b[t], kr[q] = rb[t], kt[q] = tb[t];
      km[q] = m[j], kf[q] = vol0[j], krho[q] = rho[j];
      kd0[q] = v[3 * j] - vi0;
      kd1[q] = dim > 1 ? v[3 * j + 1] - vi1 : 0.0;
      kd2[q] = dim > 2 ? v[3 * j + 2] - vi2 : 0.0;
    }
#pragma omp simd
    for (int q = 0; q < nk; ++q) {
      const ej_real y0 = ky0[q], y1 = ky1[q], y2 = ky2[q], r = kr[q], tt = kt[q];
      const ej_real floor_j = rmin * km[q] / kf[q];
      const ej_real rhoj = krho[q] < floor_j ? floor_j : krho[q];
      const ej_real wV = tt * tt * km[q] / rhoj;
      const ej_real d0 = kd0[q], d1 = kd1[q], d2 = kd2[q];
      pr[P00][q] = wV * y0 * y0, pr[Q00][q] = wV * d0 * y0;
      pr[P01][q] = wV * y0 * y1, pr[P11][q] = wV * y1 * y1;
      pr[Q01][q] = wV * d0 * y1, pr[Q10][q] = wV * d1 * y0, pr[Q11][q] = wV * d1 * y1;
      pr[P02][q] = wV * y0 * y2, pr[P12][q] = wV * y1 * y2, pr[P22][q] = wV * y2 * y2;
      pr[Q02][q] = wV * d0 * y2, pr[Q12][q] = wV * d1 * y2, pr[Q20][q] = wV * d2 * y0;
      pr[Q21][q] = wV * d2 * y1, pr[Q22][q] = wV * d2 * y2;
      pr[PG][q] = wV, pr[PH][q] = wV * (d0 * y0 + d1 * y1 + d2 * y2) / r;
    }
    for (int q = 0; q < nk; ++q) {
      acc[P00] += pr[P00][q], acc[Q00] += pr[Q00][q];
      if (dim > 1) {
        acc[P01] += pr[P01][q], acc[P11] += pr[P11][q];
        acc[Q01] += pr[Q01][q], acc[Q10] += pr[Q10][q], acc[Q11] += pr[Q11][q];
      }
      if (dim > 2) {
        acc[P02] += pr[P02][q], acc[P12] += pr[P12][q], acc[P22] += pr[P22][q];
        acc[Q02] += pr[Q02][q], acc[Q12] += pr[Q12][q], acc[Q20] += pr[Q20][q], acc[Q21] += pr[Q21][q];
        acc[Q22] += pr[Q22][q];
      }
      acc[PG] += pr[PG][q], acc[PH] += pr[PH][q];
    }
  }
  M[0] = acc[P00], M[1] = acc[P01], M[2] = acc[P02], M[3] = acc[P01], M[4] = acc[P11], M[5] = acc[P12];
  M[6] = acc[P02], M[7] = acc[P12], M[8] = acc[P22];
  N[0] = acc[Q00], N[1] = acc[Q01], N[2] = acc[Q02], N[3] = acc[Q10], N[4] = acc[Q11], N[5] = acc[Q12];
  N[6] = acc[Q20], N[7] = acc[Q21], N[8] = acc[Q22];
  *gamma = acc[PG];
  *phi_num = acc[PH];
}

/* The per-entry form of the family sums (the code before the blocked loops, kept for 1D): a 1D
 * family holds about 6 members, where the blocked loops' fixed costs made ulpd's 1D Sod 40 %
 * slower (bench/speed_vs_error, 1600 particles: 2.36 -> 3.30 s CPU). Same sums, same order. */
static inline ULPD_ALWAYS_INLINE void ulpd_family_entry(const int dim, const ulpd_config *cfg, const ulpd_fields *F,
                                                        const ej_off *restrict off, const ej_idx *restrict idx,
                                                        ej_idx i, ej_real M[9], ej_real N[9], ej_real *gamma,
                                                        ej_real *phi_num)
{
  const ej_real *restrict x = F->x, *restrict v = F->v, *restrict m = F->m, *restrict vol0 = F->vol0;
  const ej_real *restrict rho = F->rho;
  const ej_real xi0 = x[3 * i], xi1 = dim > 1 ? x[3 * i + 1] : 0.0, xi2 = dim > 2 ? x[3 * i + 2] : 0.0;
  const ej_real vi0 = v[3 * i], vi1 = dim > 1 ? v[3 * i + 1] : 0.0, vi2 = dim > 2 ? v[3 * i + 2] : 0.0;
  const ej_real inv_delta = 1.0 / F->delta[i];
  const ej_real rmin = cfg->rho_min;
  ej_real m00 = 0, m01 = 0, m02 = 0, m11 = 0, m12 = 0, m22 = 0;
  ej_real n00 = 0, n01 = 0, n02 = 0, n10 = 0, n11 = 0, n12 = 0, n20 = 0, n21 = 0, n22 = 0;
  ej_real g = 0, ph = 0;
  for (ej_off k = off[i]; k < off[i + 1]; ++k) {
    const ej_idx j = idx[k];
    const ej_real y0 = x[3 * j] - xi0;
    const ej_real y1 = dim > 1 ? x[3 * j + 1] - xi1 : 0.0;
    const ej_real y2 = dim > 2 ? x[3 * j + 2] - xi2 : 0.0;
    const ej_real r2 = y0 * y0 + y1 * y1 + y2 * y2;
    const ej_real r = sqrt(r2);
    const ej_real t = 1.0 - r * inv_delta;
    if (!(t > 0.0) || !(r > 0.0)) continue; /* outside the family (the list has a skin), or coincident */
    const ej_real floor_j = rmin * m[j] / vol0[j];
    const ej_real rhoj = rho[j] < floor_j ? floor_j : rho[j];
    const ej_real wV = t * t * m[j] / rhoj;
    const ej_real d0 = v[3 * j] - vi0;
    const ej_real d1 = dim > 1 ? v[3 * j + 1] - vi1 : 0.0;
    const ej_real d2 = dim > 2 ? v[3 * j + 2] - vi2 : 0.0;
    m00 += wV * y0 * y0;
    n00 += wV * d0 * y0;
    if (dim > 1) {
      m01 += wV * y0 * y1, m11 += wV * y1 * y1;
      n01 += wV * d0 * y1, n10 += wV * d1 * y0, n11 += wV * d1 * y1;
    }
    if (dim > 2) {
      m02 += wV * y0 * y2, m12 += wV * y1 * y2, m22 += wV * y2 * y2;
      n02 += wV * d0 * y2, n12 += wV * d1 * y2, n20 += wV * d2 * y0, n21 += wV * d2 * y1, n22 += wV * d2 * y2;
    }
    g += wV;
    ph += wV * (d0 * y0 + d1 * y1 + d2 * y2) / r;
  }
  M[0] = m00, M[1] = m01, M[2] = m02, M[3] = m01, M[4] = m11, M[5] = m12, M[6] = m02, M[7] = m12, M[8] = m22;
  N[0] = n00, N[1] = n01, N[2] = n02, N[3] = n10, N[4] = n11, N[5] = n12, N[6] = n20, N[7] = n21, N[8] = n22;
  *gamma = g;
  *phi_num = ph;
}

static ej_err ulpd_family_pass(ulpd_state *s, ej_set *set, const ej_nbr *nbr, ej_range r)
{
  EJ_ENSURE(nbr && nbr->n_rows >= r.end, EJ_ERR_INTERNAL, "set '%s': ulpd neighbour list has %d rows, range ends at %d",
            s->set_name, nbr ? (int)nbr->n_rows : -1, (int)r.end);
  if (r.end <= r.begin) return EJ_OK;
  ulpd_fields F;
  EJ_TRY(ulpd_get_fields(s, set, &F));
  const ulpd_config *cfg = &s->cfg;
  const int dim = s->dim;
  const ej_real dt = ej_set_dt(set);
  EJ_TRY(ulpd_prepare(s, set, &F, r, cfg->density == ULPD_DENS_CONTINUITY));
  if (s->use_eos)
    EJ_TRY(ej_eos_evaluate_set(s->eos, set, r, F.rho + r.begin, F.e + r.begin, F.p + r.begin, F.c + r.begin));

  /* Kinematics: M, L, phi; the stress of t_n carried to t_n+1 by Hughes-Winget. */
  for (ej_idx i = r.begin; i < r.end; ++i) {
    ej_real M[9], N[9], B[9], L[9], gamma, phi_num;
    switch (dim) {
    case 1: ulpd_family_entry(1, cfg, &F, nbr->off, nbr->idx, i, M, N, &gamma, &phi_num); break;
    case 2: ulpd_family(2, cfg, &F, nbr->off, nbr->idx, i, M, N, &gamma, &phi_num); break;
    default: ulpd_family(3, cfg, &F, nbr->off, nbr->idx, i, M, N, &gamma, &phi_num); break;
    }
    const int fb = ulpd_inverse(dim, M, cfg->rcond_min, cfg->regularization, B);
    if (fb) F.flags[i] |= ULPD_FLAG_FALLBACK, F.fb_total[i] += 1;
    ej_m3_mul(L, N, B); /* L_ab = N_ac B_cb: zero outside the dim x dim block */
    ej_m3_copy(F.L + 9 * i, L);
    ej_m3_sym(F.d_rate + 6 * i, L);
    /* S temporarily holds B (overwritten below once the stress is known); kappa holds
     * tr(M), q holds phi and dt_local gamma: no allocation, all in the particle's own slots. */
    ej_m3_copy(F.S + 9 * i, B);
    F.kappa[i] = M[0] + M[4] + M[8];
    F.q[i] = gamma > 0.0 ? phi_num / gamma : 0.0;
    F.dt_local[i] = gamma;
    if (s->mat && dt > 0.0) {
      ej_real W[9], Q[9];
      ej_m3_skew(W, L);
      if (!ej_hughes_winget(Q, W, dt)) return ulpd_bad_particle(s, set, i, "Hughes-Winget spin |W| dt", ej_m3_norm(W) * dt);
      ej_s6_rotate(F.stress + 6 * i, Q, F.stress + 6 * i);
    }
  }

  /* Stress at t_n+1. */
  if (s->mat) {
    ej_real *hist_base[ULPD_MAX_HIST], *hist[ULPD_MAX_HIST];
    const int nh = ej_set_hist(set, hist_base, ULPD_MAX_HIST);
    for (int k = 0; k < nh; ++k) hist[k] = hist_base[k] + r.begin;
    ej_mat_batch b = {.n = r.end - r.begin,
                      .dt = dt,
                      .rho = F.rho + r.begin,
                      .e = F.e + r.begin,
                      .d = F.d_rate + 6 * (size_t)r.begin,
                      .F = NULL,
                      .p = s->use_eos ? F.p + r.begin : NULL,
                      .stress = F.stress + 6 * (size_t)r.begin,
                      .hist = hist,
                      .c = F.c + r.begin,
                      .w_plastic = F.wp_inc + r.begin,
                      .failed = NULL};
    for (ej_idx i = r.begin; i < r.end; ++i) F.wp_inc[i] = 0.0;
    EJ_TRY(ej_material_update(s->mat, &b));
    for (ej_idx i = r.begin; i < r.end; ++i) F.p[i] = -ej_s6_trace(F.stress + 6 * i) / 3.0;
  } else {
    for (ej_idx i = r.begin; i < r.end; ++i) {
      if (F.p[i] < cfg->p_min) F.p[i] = cfg->p_min, F.flags[i] |= ULPD_FLAG_P_CUT;
      ej_real *sg = F.stress + 6 * i;
      sg[0] = sg[1] = sg[2] = -F.p[i];
      sg[3] = sg[4] = sg[5] = 0.0;
    }
  }

  /* Viscous pressure, force tensor, rates, stable step. */
  const ej_real Cq = cfg->C_q, Cl = cfg->C_l, chg = cfg->c_hg;
  for (ej_idx i = r.begin; i < r.end; ++i) {
    const ej_real rho = F.rho[i], c = F.c[i], phi = F.q[i], trM = F.kappa[i], gamma = F.dt_local[i];
    const ej_real *L = F.L + 9 * i, *sg = F.stress + 6 * i;
    const ej_real trL = L[0] + L[4] + L[8];
    if (!isfinite(trL)) return ulpd_bad_particle(s, set, i, "tr(L)", trL);
    if (!isfinite(c) || !isfinite(F.p[i])) return ulpd_bad_particle(s, set, i, "pressure p", F.p[i]);
    /* 002 Eqs 42-44 as the digest recommends (erratum 6): a viscous pressure from the family's
     * effective velocity change phi (Eq 44), applied in compression only (phi < 0 and
     * tr L < 0, so that its work -q tr(L) V is never negative); Eq 42's rho0 v^2 = rho0^3/rho^2
     * is replaced by the current density rho, the dimensionally consistent von Neumann-Richtmyer
     * form q = rho (C_q phi^2 - C_l c phi). */
    const ej_real qv = (phi < 0.0 && trL < 0.0) ? rho * (Cq * phi * phi - Cl * c * phi) : 0.0;
    F.q[i] = qv;
    ej_real T[9], B[9], Sm[9];
    ej_s6_to_m3(T, sg);
    T[0] -= qv, T[4] -= qv, T[8] -= qv;
    ej_m3_copy(B, F.S + 9 * i);
    ej_m3_mul(Sm, T, B);
    ej_m3_copy(F.S + 9 * i, Sm);
    /* Zero-energy-mode control: kinematic viscosity c_hg c delta (see pass 1). */
    F.kappa[i] = trM > 0.0 ? 2.0 * dim * chg * rho * c * F.delta[i] / trM : 0.0;
    /* (sigma - q I) : D / rho = (sigma - q I) : L / rho for symmetric sigma */
    ej_real sd = 0.0;
    for (int k = 0; k < 9; ++k) sd += T[k] * L[k];
    if (cfg->density == ULPD_DENS_CONTINUITY) F.rho_dot[i] += -rho * trL;
    F.e_dot[i] += sd / rho;
    F.w_visc_dot[i] += -qv * trL / rho;
    if (s->mat && dt > 0.0) F.w_plastic_dot[i] += F.wp_inc[i] / dt;
    /* Stable step: the Courant condition on the current spacing with the viscous signal speed
     * (von Neumann-Richtmyer: c + 2 C_q |phi| for the quadratic term, C_l c for the linear
     * one), the diffusion limit of the bond viscosity (its largest rate kappa gamma / rho), and
     * a bound on the relative volume change per step (|tr L| dt <= 1/2). */
    const ej_real sp_rho = ulpd_root(dim, F.m[i] / rho), sp_d = F.delta[i] / cfg->horizon;
    const ej_real spacing = sp_rho < sp_d ? sp_rho : sp_d;
    const ej_real sig = c * (1.0 + Cl) + 2.0 * Cq * fabs(phi);
    ej_real dtl = sig > 0.0 ? spacing / sig : HUGE_VAL;
    const ej_real nu = F.kappa[i] * gamma / rho;
    if (nu > 0.0 && 1.0 / nu < dtl) dtl = 1.0 / nu;
    if (fabs(trL) > 0.0 && 0.5 / fabs(trL) < dtl) dtl = 0.5 / fabs(trL);
    F.dt_local[i] = dtl;
  }
  return EJ_OK;
}

/* ------------------------------------------------------------------ pass 1: forces */

/* The pair loops' result for particle i: a += f / rho, and the stabilisation heat into e and w_visc. */
static inline ULPD_ALWAYS_INLINE void ulpd_store_force(const int dim, const bool stab, const ulpd_fields *F, ej_idx i,
                                                       ej_real f0, ej_real f1, ej_real f2, ej_real heat)
{
  const ej_real inv_rho = 1.0 / F->rho[i];
  F->a[3 * i] += f0 * inv_rho;
  if (dim > 1) F->a[3 * i + 1] += f1 * inv_rho;
  if (dim > 2) F->a[3 * i + 2] += f2 * inv_rho;
  if (stab) {
    F->e_dot[i] += heat * inv_rho;
    F->w_visc_dot[i] += heat * inv_rho;
  }
}

/* rho_i a_i = sum_j V_j (omega_ij S_i + omega_ji S_j) y_ij                  (002 Eqs 1, 47)
 * plus the zero-energy-mode control, the rate form of the nonlocal-operator hourglass force of
 * 002 Eq 15 (digest sec 1.6 recommendation, applied to velocities): with z_ij = v_j - v_i -
 * L_i y_ij, the part of the velocity difference that the linear field L_i does not explain,
 *   f_ij = V_i V_j (kappa_i omega_ij z_ij + kappa_j omega_ji z~_ij),  z~_ij = v_j - v_i - L_j y_ij,
 * antisymmetric in i, j (momentum exact), zero for any linear velocity field, and dissipative:
 * the kinetic energy it removes, sum_i V_i kappa_i sum_j V_j omega_ij z_ij.(v_j - v_i), is
 * added to e_i (and w_visc_i) particle by particle, so the budget stays exact. kappa_i =
 * 2 dim c_hg rho_i c_i delta_i / tr(M_i) makes the continuum limit a kinematic viscosity
 * c_hg c delta acting on the second-order part of v. */
/* Pair loop of the forces, blocked: per block of list entries, (1) the neighbours' positions and
 * horizons are copied into local arrays and the bond lengths and the two influences computed in
 * a vectorised loop; (2) the entries with a non-zero influence are compacted (the list has a skin:
 * no unpredictable branch per entry); (3) the kept neighbours' m, rho, S (and L, kappa, v with the
 * stabilisation) are copied; (4) each pair's contribution is computed in a vectorised loop; (5) the
 * contributions are summed in list order. Every expression is the one of the former per-entry loop
 * in the same order, and the sums run in the same order: the results are bitwise those of it. */
static inline ULPD_ALWAYS_INLINE void ulpd_forces(const int dim, const bool stab, const ulpd_fields *F,
                                                  const ej_off *restrict off, const ej_idx *restrict idx, ej_range rg)
{
  const ej_real *restrict x = F->x, *restrict v = F->v, *restrict m = F->m, *restrict rho = F->rho;
  const ej_real *restrict delta = F->delta, *restrict S = F->S, *restrict Lg = F->L, *restrict kappa = F->kappa;
  ej_real y0b[ULPD_BLK], y1b[ULPD_BLK], y2b[ULPD_BLK], wib[ULPD_BLK], wjb[ULPD_BLK], db[ULPD_BLK];
  int64_t keep[ULPD_BLK]; /* 64-bit: the lanes of the weights loop are doubles */
  int kp[ULPD_BLK];
  /* kept entries (compacted) */
  ej_real ky0[ULPD_BLK], ky1[ULPD_BLK], ky2[ULPD_BLK], kwi[ULPD_BLK], kwj[ULPD_BLK], kV[ULPD_BLK];
  ej_real kS[9][ULPD_BLK], kL[9][ULPD_BLK], kk[ULPD_BLK], kd[3][ULPD_BLK];
  ej_real c0[ULPD_BLK], c1[ULPD_BLK], c2[ULPD_BLK], ch[ULPD_BLK];
  for (ej_idx i = rg.begin; i < rg.end; ++i) {
    const ej_real xi0 = x[3 * i], xi1 = dim > 1 ? x[3 * i + 1] : 0.0, xi2 = dim > 2 ? x[3 * i + 2] : 0.0;
    const ej_real vi0 = v[3 * i], vi1 = dim > 1 ? v[3 * i + 1] : 0.0, vi2 = dim > 2 ? v[3 * i + 2] : 0.0;
    ej_real Si[9], Li[9];
    for (int c = 0; c < 9; ++c) Si[c] = S[9 * i + c], Li[c] = Lg[9 * i + c];
    const ej_real inv_di = 1.0 / delta[i], ki = kappa[i];
    ej_real f0 = 0, f1 = 0, f2 = 0, heat = 0;
    for (ej_off k0 = off[i]; k0 < off[i + 1]; k0 += ULPD_BLK) {
      const int nb = off[i + 1] - k0 < ULPD_BLK ? (int)(off[i + 1] - k0) : ULPD_BLK;
      const ej_idx *restrict jx = idx + k0;
      ulpd_block_bonds(dim, x, jx, nb, xi0, xi1, xi2, y0b, y1b, y2b);
      for (int t = 0; t < nb; ++t) db[t] = delta[jx[t]];
#pragma omp simd
      for (int t = 0; t < nb; ++t) {
        const ej_real y0 = y0b[t], y1 = y1b[t], y2 = y2b[t];
        const ej_real r = sqrt(y0 * y0 + y1 * y1 + y2 * y2);
        const ej_real ti = 1.0 - r * inv_di, tj = 1.0 - r / db[t];
        const ej_real wi = ti > 0.0 ? ti * ti : 0.0, wj = tj > 0.0 ? tj * tj : 0.0;
        wib[t] = wi, wjb[t] = wj;
        /* the former skip test, (wi == 0 && wj == 0) || !(r > 0), without branches (wi, wj >= 0) */
        keep[t] = (int64_t)((wi + wj > 0.0) & (r > 0.0));
      }
      int nk = 0;
      for (int t = 0; t < nb; ++t) kp[nk] = t, nk += keep[t];
      for (int q = 0; q < nk; ++q) {
        const int t = kp[q];
        const ej_idx j = jx[t];
        ky0[q] = y0b[t], ky1[q] = y1b[t], ky2[q] = y2b[t], kwi[q] = wib[t], kwj[q] = wjb[t];
        kV[q] = m[j] / rho[j];
        for (int c = 0; c < 9; ++c) kS[c][q] = S[9 * j + c];
        if (stab) {
          for (int c = 0; c < 9; ++c) kL[c][q] = Lg[9 * j + c];
          kk[q] = kappa[j];
          kd[0][q] = v[3 * j] - vi0;
          kd[1][q] = dim > 1 ? v[3 * j + 1] - vi1 : 0.0;
          kd[2][q] = dim > 2 ? v[3 * j + 2] - vi2 : 0.0;
        }
      }
#pragma omp simd
      for (int q = 0; q < nk; ++q) {
        const ej_real y0 = ky0[q], y1 = ky1[q], y2 = ky2[q], wi = kwi[q], wj = kwj[q], Vj = kV[q];
        /* (wi S_i + wj S_j) y */
        ej_real t0 = (wi * Si[0] + wj * kS[0][q]) * y0, t1 = 0, t2 = 0;
        if (dim > 1) {
          t0 += (wi * Si[1] + wj * kS[1][q]) * y1;
          t1 = (wi * Si[3] + wj * kS[3][q]) * y0 + (wi * Si[4] + wj * kS[4][q]) * y1;
        }
        if (dim > 2) {
          t0 += (wi * Si[2] + wj * kS[2][q]) * y2;
          t1 += (wi * Si[5] + wj * kS[5][q]) * y2;
          t2 = (wi * Si[6] + wj * kS[6][q]) * y0 + (wi * Si[7] + wj * kS[7][q]) * y1 + (wi * Si[8] + wj * kS[8][q]) * y2;
        }
        ej_real hq = 0.0;
        if (stab) {
          const ej_real kj = kk[q];
          const ej_real d0 = kd[0][q], d1 = kd[1][q], d2 = kd[2][q];
          ej_real zi0 = d0 - Li[0] * y0, zj0 = d0 - kL[0][q] * y0, zi1 = 0, zj1 = 0, zi2 = 0, zj2 = 0;
          if (dim > 1) {
            zi0 -= Li[1] * y1, zj0 -= kL[1][q] * y1;
            zi1 = d1 - Li[3] * y0 - Li[4] * y1, zj1 = d1 - kL[3][q] * y0 - kL[4][q] * y1;
          }
          if (dim > 2) {
            zi0 -= Li[2] * y2, zj0 -= kL[2][q] * y2;
            zi1 -= Li[5] * y2, zj1 -= kL[5][q] * y2;
            zi2 = d2 - Li[6] * y0 - Li[7] * y1 - Li[8] * y2, zj2 = d2 - kL[6][q] * y0 - kL[7][q] * y1 - kL[8][q] * y2;
          }
          const ej_real ai = ki * wi, aj = kj * wj;
          t0 += ai * zi0 + aj * zj0;
          t1 += ai * zi1 + aj * zj1;
          t2 += ai * zi2 + aj * zj2;
          hq = Vj * ai * (zi0 * d0 + zi1 * d1 + zi2 * d2);
        }
        c0[q] = Vj * t0, c1[q] = Vj * t1, c2[q] = Vj * t2, ch[q] = hq;
      }
      for (int q = 0; q < nk; ++q) {
        f0 += c0[q];
        if (dim > 1) f1 += c1[q];
        if (dim > 2) f2 += c2[q];
        if (stab) heat += ch[q];
      }
    }
    ulpd_store_force(dim, stab, F, i, f0, f1, f2, heat);
  }
}

/* The per-entry form of the pair loop (kept for 1D, as ulpd_family_entry). */
static inline ULPD_ALWAYS_INLINE void ulpd_forces_entry(const int dim, const bool stab, const ulpd_fields *F,
                                                        const ej_off *restrict off, const ej_idx *restrict idx,
                                                        ej_range rg)
{
  const ej_real *restrict x = F->x, *restrict v = F->v, *restrict m = F->m, *restrict rho = F->rho;
  const ej_real *restrict delta = F->delta, *restrict S = F->S, *restrict Lg = F->L, *restrict kappa = F->kappa;
  for (ej_idx i = rg.begin; i < rg.end; ++i) {
    const ej_real xi0 = x[3 * i], xi1 = dim > 1 ? x[3 * i + 1] : 0.0, xi2 = dim > 2 ? x[3 * i + 2] : 0.0;
    const ej_real vi0 = v[3 * i], vi1 = dim > 1 ? v[3 * i + 1] : 0.0, vi2 = dim > 2 ? v[3 * i + 2] : 0.0;
    const ej_real *Si = S + 9 * i, *Li = Lg + 9 * i;
    const ej_real inv_di = 1.0 / delta[i], ki = kappa[i];
    ej_real f0 = 0, f1 = 0, f2 = 0, heat = 0;
    for (ej_off k = off[i]; k < off[i + 1]; ++k) {
      const ej_idx j = idx[k];
      const ej_real y0 = x[3 * j] - xi0;
      const ej_real y1 = dim > 1 ? x[3 * j + 1] - xi1 : 0.0;
      const ej_real y2 = dim > 2 ? x[3 * j + 2] - xi2 : 0.0;
      const ej_real r = sqrt(y0 * y0 + y1 * y1 + y2 * y2);
      const ej_real ti = 1.0 - r * inv_di, tj = 1.0 - r / delta[j];
      const ej_real wi = ti > 0.0 ? ti * ti : 0.0, wj = tj > 0.0 ? tj * tj : 0.0;
      if ((wi == 0.0 && wj == 0.0) || !(r > 0.0)) continue;
      const ej_real Vj = m[j] / rho[j];
      const ej_real *Sj = S + 9 * j;
      /* (wi S_i + wj S_j) y */
      ej_real t0 = (wi * Si[0] + wj * Sj[0]) * y0, t1 = 0, t2 = 0;
      if (dim > 1) {
        t0 += (wi * Si[1] + wj * Sj[1]) * y1;
        t1 = (wi * Si[3] + wj * Sj[3]) * y0 + (wi * Si[4] + wj * Sj[4]) * y1;
      }
      if (dim > 2) {
        t0 += (wi * Si[2] + wj * Sj[2]) * y2;
        t1 += (wi * Si[5] + wj * Sj[5]) * y2;
        t2 = (wi * Si[6] + wj * Sj[6]) * y0 + (wi * Si[7] + wj * Sj[7]) * y1 + (wi * Si[8] + wj * Sj[8]) * y2;
      }
      if (stab) {
        const ej_real *Lj = Lg + 9 * j;
        const ej_real kj = kappa[j];
        const ej_real d0 = v[3 * j] - vi0;
        const ej_real d1 = dim > 1 ? v[3 * j + 1] - vi1 : 0.0;
        const ej_real d2 = dim > 2 ? v[3 * j + 2] - vi2 : 0.0;
        ej_real zi0 = d0 - Li[0] * y0, zj0 = d0 - Lj[0] * y0, zi1 = 0, zj1 = 0, zi2 = 0, zj2 = 0;
        if (dim > 1) {
          zi0 -= Li[1] * y1, zj0 -= Lj[1] * y1;
          zi1 = d1 - Li[3] * y0 - Li[4] * y1, zj1 = d1 - Lj[3] * y0 - Lj[4] * y1;
        }
        if (dim > 2) {
          zi0 -= Li[2] * y2, zj0 -= Lj[2] * y2;
          zi1 -= Li[5] * y2, zj1 -= Lj[5] * y2;
          zi2 = d2 - Li[6] * y0 - Li[7] * y1 - Li[8] * y2, zj2 = d2 - Lj[6] * y0 - Lj[7] * y1 - Lj[8] * y2;
        }
        const ej_real ai = ki * wi, aj = kj * wj;
        t0 += ai * zi0 + aj * zj0;
        t1 += ai * zi1 + aj * zj1;
        t2 += ai * zi2 + aj * zj2;
        heat += Vj * ai * (zi0 * d0 + zi1 * d1 + zi2 * d2);
      }
      f0 += Vj * t0;
      if (dim > 1) f1 += Vj * t1;
      if (dim > 2) f2 += Vj * t2;
    }
    ulpd_store_force(dim, stab, F, i, f0, f1, f2, heat);
  }
}

static ej_err ulpd_force_pass(const ulpd_state *s, ej_set *set, const ej_nbr *nbr, ej_range r)
{
  EJ_ENSURE(nbr && nbr->n_rows >= r.end, EJ_ERR_INTERNAL, "set '%s': ulpd neighbour list has %d rows, range ends at %d",
            s->set_name, nbr ? (int)nbr->n_rows : -1, (int)r.end);
  ulpd_fields F;
  EJ_TRY(ulpd_get_fields(s, set, &F));
  const bool stab = s->cfg.c_hg > 0.0;
#define ULPD_CASE(d)                                                                                    \
  case d:                                                                                               \
    if ((d) == 1 && stab) ulpd_forces_entry(1, true, &F, nbr->off, nbr->idx, r);                         \
    else if ((d) == 1) ulpd_forces_entry(1, false, &F, nbr->off, nbr->idx, r);                           \
    else if (stab) ulpd_forces((d), true, &F, nbr->off, nbr->idx, r);                                   \
    else ulpd_forces((d), false, &F, nbr->off, nbr->idx, r);                                            \
    break
  switch (s->dim) {
    ULPD_CASE(1);
    ULPD_CASE(2);
    ULPD_CASE(3);
  default: EJ_FAIL(EJ_ERR_INTERNAL, "ulpd: dimension %d", s->dim);
  }
#undef ULPD_CASE
  return EJ_OK;
}

/* ------------------------------------------------------------------ ops */

static ej_err ulpd_setup(void *state, ej_set *set)
{
  ulpd_state *s = state;
  ulpd_fields F;
  EJ_TRY(ulpd_get_fields(s, set, &F));
  const ej_idx n = ej_set_count(set);
  for (ej_idx i = 0; i < n; ++i) {
    if (!(F.m[i] > 0.0)) return ulpd_bad_particle(s, set, i, "mass m", F.m[i]);
    if (!(F.vol0[i] > 0.0)) return ulpd_bad_particle(s, set, i, "volume vol0", F.vol0[i]);
    F.fb_total[i] = 0;
  }
  /* delta exists before the first support call and the first frame. */
  EJ_TRY(ulpd_prepare(s, set, &F, (ej_range){0, n}, true));
  return EJ_OK;
}

static ej_err ulpd_support(void *state, const ej_set *set, ej_range r, ej_real *radius)
{
  const ulpd_state *s = state;
  const ej_real *restrict rho = ej_set_field(set, "rho");
  const ej_real *restrict m = ej_set_field(set, "m");
  const ej_real *restrict vol0 = ej_set_field(set, "vol0");
  EJ_ENSURE(rho && m && vol0, EJ_ERR_INTERNAL, "set '%s': ulpd fields missing", s->set_name);
  /* The same delta as pass 0 (floored density); radius[k] belongs to particle r.begin + k. */
  for (ej_idx i = r.begin; i < r.end; ++i) {
    const ej_real floor = ulpd_rho_floor(&s->cfg, m[i], vol0[i]);
    const ej_real rf = rho[i] < floor ? floor : rho[i];
    radius[i - r.begin] = ulpd_horizon(&s->cfg, s->dim, m[i], vol0[i], rf);
  }
  return EJ_OK;
}

/* Passes: [summation density], families, forces. */
static int ulpd_pass_count(const void *state)
{
  const ulpd_state *s = state;
  return s->cfg.density == ULPD_DENS_SUMMATION ? 3 : 2;
}

static ej_err ulpd_compute(void *state, ej_set *set, const ej_nbr *nbr, int pass, ej_range r)
{
  ulpd_state *s = state;
  if (s->cfg.density == ULPD_DENS_SUMMATION) {
    if (pass == 0) return ulpd_summation_pass(s, set, nbr, r);
    --pass;
  }
  switch (pass) {
  case 0: EJ_TRY(ulpd_family_pass(s, set, nbr, r)); break;
  case 1: EJ_TRY(ulpd_force_pass(s, set, nbr, r)); break;
  default: EJ_FAIL(EJ_ERR_INTERNAL, "ulpd: pass %d out of range", pass);
  }
  return EJ_OK;
}

static ej_err ulpd_stable_dt(void *state, const ej_set *set, ej_range r, ej_real *dt)
{
  const ulpd_state *s = state;
  const ej_real *restrict dl = ej_set_field(set, "dt_local");
  EJ_ENSURE(dl, EJ_ERR_INTERNAL, "set '%s': ulpd fields missing", s->set_name);
  ej_real best = HUGE_VAL;
  for (ej_idx i = r.begin; i < r.end; ++i) best = dl[i] < best ? dl[i] : best;
  *dt = best;
  return EJ_OK;
}

static ej_err ulpd_counters(void *state, ej_counter *out, int max, int *n)
{
  const ulpd_state *s = state;
  *n = 0;
  const int32_t *fb = ej_set_field_int(s->set, "shape_fallbacks");
  if (!fb || max < 1) return EJ_OK;
  int64_t total = 0;
  for (ej_idx i = 0; i < ej_set_count(s->set); ++i) total += fb[i];
  out[(*n)++] = (ej_counter){.name = "shape-tensor fallbacks (particle-steps)", .value = total};
  if (max >= 2) out[(*n)++] = (ej_counter){.name = "density floor hits (particle-steps)", .value = s->n_rho_floor};
  if (max >= 3) out[(*n)++] = (ej_counter){.name = "pressure cutoff hits (particle-steps)", .value = s->n_p_cut};
  return EJ_OK;
}

/* Per step: particles whose shape tensor was regularised, that hit the density floor or the
 * pressure cutoff, and the largest viscous pressure. */
static ej_err ulpd_report(void *state, const ej_set *set, ej_series_value *out, int max, int *n)
{
  ulpd_state *s = state;
  *n = 0;
  const int32_t *fl = ej_set_field_int(set, "ulpd_flags");
  const ej_real *q = ej_set_field(set, "q");
  EJ_ENSURE(fl && q, EJ_ERR_INTERNAL, "set '%s': ulpd fields missing", s->set_name);
  int64_t nfb = 0, nrho = 0, np = 0;
  ej_real qmax = 0.0;
  for (ej_idx i = 0; i < ej_set_count(set); ++i) {
    nfb += (fl[i] & ULPD_FLAG_FALLBACK) != 0;
    nrho += (fl[i] & ULPD_FLAG_RHO_FLOOR) != 0;
    np += (fl[i] & ULPD_FLAG_P_CUT) != 0;
    qmax = q[i] > qmax ? q[i] : qmax;
  }
  s->n_rho_floor += nrho;
  s->n_p_cut += np;
  s->n_fallback_steps += nfb;
  if (max < 4) return EJ_OK;
  out[0] = (ej_series_value){.name = "shape_fallbacks", .value = (ej_real)nfb, .role = EJ_SERIES_PLAIN};
  out[1] = (ej_series_value){.name = "rho_floor_hits", .value = (ej_real)nrho, .role = EJ_SERIES_PLAIN};
  out[2] = (ej_series_value){.name = "p_cutoff_hits", .value = (ej_real)np, .role = EJ_SERIES_PLAIN};
  out[3] = (ej_series_value){.name = "q_max", .value = qmax, .role = EJ_SERIES_PLAIN};
  *n = 4;
  return EJ_OK;
}

/* ------------------------------------------------------------------ registration */

static const ej_method_ops ulpd_ops = {
    .struct_size = sizeof(ej_method_ops),
    .name = "ulpd",
    .summary = "Updated-Lagrangian state-based peridynamics (correspondence) for gases, explosives and solids",
    .doc = "Non-ordinary state-based peridynamics in the current configuration (Zhu & Zhao, digest 002 Eqs "
           "45-47): families of radius delta = horizon x spacing rebuilt as particles move, influence "
           "(1 - r/delta)^2, shape tensor M and velocity gradient L = N M^-1 from current bonds, density by "
           "drho/dt = -rho tr(L), stress -p I from the EOS (programmed burn included) or from the strength "
           "model (Hughes-Winget rotation), force states omega (sigma - q I) M^-1 y with a von Neumann-"
           "Richtmyer viscous pressure q from the family velocity change (002 Eqs 42-44, C_q 8, C_l 0.1) and a "
           "bond viscosity against zero-energy modes. Momentum and total energy conserved to round-off by the "
           "semi-discrete equations. Ill-conditioned shape tensors are regularised and counted.",
    .params = ulpd_params,
    .config_size = sizeof(ulpd_config),
    .check_config = NULL,
    .declare = ulpd_declare,
    .create = ulpd_create,
    .setup = ulpd_setup,
    .support = ulpd_support,
    .n_passes = 3,
    .compute = ulpd_compute,
    .stable_dt = ulpd_stable_dt,
    .post_step = NULL,
    .counters = ulpd_counters,
    .destroy = ulpd_destroy,
    .pass_count = ulpd_pass_count,
    .report = ulpd_report,
};

static ej_err ulpd_register(ej_registry *reg)
{
  EJ_TRY(ej_register_method(reg, &ulpd_ops));
  return EJ_OK;
}

EJ_PLUGIN_DEFINE(ulpd, "0.1.0", "BSD-3-Clause", "Updated-Lagrangian state-based peridynamics", ulpd_register)

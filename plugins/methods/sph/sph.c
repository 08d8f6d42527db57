/* Standard SPH for gas dynamics with the continuity equation.
 *
 * Equations: Fan & Li digest 000, section 1.3 (Eqs 22-28), with the sign erratum of Eq 24
 * (the energy equation uses (v_i - v_j).grad_i W_ij; as printed it would cool a compressed
 * gas). Monaghan viscosity Eqs 26-28; time step after Monaghan, "Smoothed particle
 * hydrodynamics", ARA&A 30 (1992) 543, section 10.3.
 *
 * Up to four passes per step, because a pair needs p, c, h (and L or M^-1) of both particles:
 *   (pairs, only with density: summation): rho_i = sum_j m_j W_ij;
 *   pass 0 (per particle): density floor, smoothing length h, EOS -> p, c;
 *   (the core copies fields to ghost particles between passes)
 *   pass 1 (pairs, only with `correction` or gradient: shape_tensor): the gradient correction
 *     matrix L_i, or the inverse current shape tensor M_i^-1 of 000 Eqs 29-37;
 *   pass 2 (pairs, gather form): accelerations and rates of rho, e, w_visc; mu_max for dt.
 * The method accumulates into a, rho_dot, e_dot and w_visc_dot, which the core zeroes (a:
 * sets to the body force) before pass 0, so that other contributions compose. */
#include <math.h>
#include <string.h>

#include "ejecta/plugin.h"
#include "ejecta/tensor.h"
#include "sph_kernels.h"

typedef struct sph_config {
  int kernel;
  int continuity;
  int density;
  bool renormalize;
  bool renormalize_interfaces;
  bool correction;
  int gradient;
  int shape_form;
  int shape_viscosity;
  int shape_energy;
  int shape_continuity;
  ej_real shape_rcond_min;
  ej_real h_factor;
  bool variable_h;
  ej_real h_min, h_max;
  ej_real alpha, beta, eta;
  ej_real rho_min;
  ej_real drho_max;
  bool strength;
  int stress_rate;
  bool art_stress;
  ej_real art_eps, art_n;
  ej_real xsph;
  int visc_switch; /* SPH_VSW_*: none, or Balsara's factor on Pi_ij (strength: true) */
  int geometry; /* SPH_GEOM_*: planar, or 1D spherical (x = r) */
  int spherical_energy; /* geometry: spherical: 0 local pdV form, 1 exact pair form away from the axis */
  ej_real conductivity; /* artificial conductivity alpha_u (Price 2008); 0: off */
} sph_config;

static const char *const sph_kernel_names[] = {"cubic_spline", "wendland_c2", NULL};
enum { SPH_CONT_VOLUME = 0, SPH_CONT_MASS = 1, SPH_CONT_AUTO = 2, SPH_CONT_NUMBER = 3 };
static const char *const sph_continuity_names[] = {"volume", "mass", "auto", "number", NULL};
enum { SPH_DENS_CONTINUITY = 0, SPH_DENS_SUMMATION = 1 };
static const char *const sph_density_names[] = {"continuity", "summation", NULL};
enum { SPH_GRAD_KERNEL = 0, SPH_GRAD_SHAPE = 1 };
static const char *const sph_gradient_names[] = {"kernel", "shape_tensor", NULL};
enum { SPH_SHAPE_SYMMETRIC = 0, SPH_SHAPE_PAPER = 1 };
static const char *const sph_shape_form_names[] = {"symmetric", "paper", NULL};
enum { SPH_SHAPE_VISC_KERNEL = 0, SPH_SHAPE_VISC_SHAPE = 1 };
static const char *const sph_shape_visc_names[] = {"kernel", "shape", NULL};
enum { SPH_SHAPE_ENERGY_OWN = 0, SPH_SHAPE_ENERGY_SYMMETRIC = 1 };
static const char *const sph_shape_energy_names[] = {"own", "symmetric", NULL};
enum { SPH_SHAPE_CONT_OWN = 0, SPH_SHAPE_CONT_SYMMETRIC = 1 };
static const char *const sph_shape_cont_names[] = {"own", "symmetric", NULL};
enum { SPH_RATE_HW = 0, SPH_RATE_JAUMANN = 1 };
enum { SPH_VSW_NONE = 0, SPH_VSW_BALSARA = 1 };
static const char *const sph_visc_switch_names[] = {"none", "balsara", NULL};
static const char *const sph_stress_rate_names[] = {"hughes_winget", "jaumann", NULL};
enum { SPH_GEOM_PLANAR = 0, SPH_GEOM_SPHERICAL = 1 };
static const char *const sph_geometry_names[] = {"planar", "spherical", NULL};
static const char *const sph_spherical_energy_names[] = {"local", "pair", NULL};
#define SPH_MAX_HIST 16

static const ej_param sph_params[] = {
    EJ_PARAM_ENUM(sph_config, kernel, sph_kernel_names, "cubic_spline",
                  "Smoothing kernel, support radius 2h: M4 cubic spline or Wendland C2."),
    EJ_PARAM_ENUM(sph_config, continuity, sph_continuity_names, "auto",
                  "Discrete continuity equation (gas; README \"Continuity form\"): mass, drho_i/dt = sum_j m_j "
                  "v_ij.grad W (000 Eq 22: the time derivative of the summation density, so shock jumps are right, "
                  "validation/strong_shock; a light particle next to heavy ones in one set is driven by them); "
                  "volume, rho_i sum_j (m_j/rho_j) v_ij.grad W (neighbour volumes as weights: a strong shock's "
                  "plateau comes out 18 % too dense); number, rho_i (m_i/rho_i) sum_j v_ij.grad W (every neighbour "
                  "weighs 1: the mass form for equal masses, the volume form at an equal-spacing contact; needs "
                  "renormalize: true); auto (default): number with the renormalised kernel gradient in planar "
                  "geometry, else volume."),
    EJ_PARAM_ENUM(sph_config, density, sph_density_names, "continuity",
                  "Density: continuity, evolved by the continuity equation (form set by continuity); "
                  "summation, rho_i = sum_j m_j W(x_ij, hbar) + m_i W(0, h_i) each step with h of the previous "
                  "step (Monaghan 1992 Eq 2.7; one more pair pass)."),
    EJ_PARAM_BOOL(sph_config, renormalize, 1,
                  "Divide the discrete velocity divergence of the continuity equation by the discrete "
                  "divergence of x over dim, so that uniform compression and expansion are exact (the "
                  "density stays consistent with the particle volumes through shocks)."),
    EJ_PARAM_BOOL(sph_config, renormalize_interfaces, 0,
                  "With renormalize: the divergence and the renormalisation sum also take the neighbours of "
                  "other sets that a continuum or pd_sph (pair_stress both or fluid) interaction couples, so the "
                  "factor is dim over the sum over all neighbours (README \"Renormalisation across interfaces\"): "
                  "a gas next to another set then expands and compresses consistently (volume continuity, kernel "
                  "gradient)."),
    EJ_PARAM_BOOL(sph_config, correction, 0,
                  "Kernel gradient correction (Bonet & Lok 1999) in the conservative form "
                  "G_ij = (L_i + L_j)/2 grad_i W_ij: linear fields exact on any particle arrangement "
                  "(needed when compression is one-sided, e.g. a shock tube in 3D); one more pair pass."),
    EJ_PARAM_ENUM(sph_config, gradient, sph_gradient_names, "kernel",
                  "Gradient operator: kernel, grad_i W_ij; shape_tensor, the consistent SPH of digest 000 "
                  "Eqs 29-37, w_ij M_i^-1 x_ij with the current shape tensor M_i = sum_j V_j w_ij x_ij (x) x_ij "
                  "(linear fields exact; one more pair pass)."),
    EJ_PARAM_ENUM(sph_config, shape_form, sph_shape_form_names, "symmetric",
                  "With gradient: shape_tensor: symmetric, G_ij = (g_i + g_j)/2 in the momentum and energy "
                  "equations (equal and opposite pair forces: momentum and energy conserved to round-off); "
                  "paper, G_ij = g_i = w_ij M_i^-1 x_ij as printed (000 Eqs 35-36), which conserves neither "
                  "exactly. The continuity equation uses g_i with paper and, with symmetric, what shape_continuity says "
                  "(default G_ij)."),
    EJ_PARAM_ENUM(sph_config, shape_viscosity, sph_shape_visc_names, "kernel",
                  "With gradient: shape_tensor, shape_form: symmetric: the gradient of the Monaghan viscosity "
                  "term, kernel (grad_i W_ij along the line of centres: the viscous heating of every pair is "
                  ">= 0) or shape (G_ij like the pressure term: the heating can be negative where M is "
                  "anisotropic, which drives e < 0 in the Sedov blast)."),
    EJ_PARAM_ENUM(sph_config, shape_energy, sph_shape_energy_names, "own",
                  "With gradient: shape_tensor, shape_form: symmetric: pdV work of the energy equation, own "
                  "(de_i/dt = sum_j m_j p_i/rho_i^2 v_ij.G_ij: follows particle i's own compression, e cannot "
                  "change sign by it) or symmetric (1/2 sum_j m_j (p_i/rho_i^2 + p_j/rho_j^2) v_ij.G_ij, 000 "
                  "Eq 36 with its erratum). Both conserve total energy exactly."),
    EJ_PARAM_ENUM(sph_config, shape_continuity, sph_shape_cont_names, "symmetric",
                  "With gradient: shape_tensor, shape_form: symmetric: gradient of the continuity equation, own "
                  "(g_i = w_ij M_i^-1 x_ij, 000 Eq 34) or symmetric (G_ij = (g_i + g_j)/2, the gradient of the "
                  "momentum and energy equations, with the matching (p_i + p_j)/(rho_i rho_j) pressure term in the "
                  "volume form: with shape_energy own, de_i/dt = p_i/rho_i^2 drho_i/dt for every row, no entropy "
                  "change without viscosity; README \"Compatible continuity\"). At a strong density contact use "
                  "own: there the g_j half runs a shock ahead (ideal gas, density ratio 133: steady shock speed "
                  "+10.5 % with symmetric, +0.5 % with own; validation/c4_air README)."),
    EJ_PARAM_REAL(sph_config, shape_rcond_min, "1", 0.02, 0.0, 1.0 / 3.0, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX,
                  "Smallest reciprocal condition estimate 1/(|M|_F |M^-1|_F) of a particle's shape tensor "
                  "(1/3 for an isotropic neighbourhood) below which it falls back to the kernel gradient "
                  "(counted: series gradient_fallbacks)."),
    EJ_PARAM_REAL(sph_config, h_factor, "1", 0.0, 0.0, 3.0, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX,
                  "Smoothing length in particle spacings, h = h_factor (m/rho)^(1/dim); 0 picks the "
                  "value where the kernel's lattice sums are most accurate for the dimension "
                  "(cubic spline: 2.0 in 1D, exact; 1.5 in 2D; 1.3 in 3D, about 60-80 neighbours)."),
    EJ_PARAM_REAL(sph_config, h_min, "1", 0.0, 0.0, 1.0, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX,
                  "Lower bound of a variable h as a multiple of the initial h (LS-DYNA HMIN); 0 gives "
                  "0.2 in 3D and the same volume ratio in 1D and 2D, 0.2^(3/dim)."),
    EJ_PARAM_REAL(sph_config, h_max, "1", 0.0, 0.0, 0.0, EJ_PF_HAS_MIN,
                  "Upper bound of a variable h as a multiple of the initial h (LS-DYNA HMAX): keeps the "
                  "neighbour count bounded where the gas expands towards vacuum; 0 gives 2 in 3D and the "
                  "same volume ratio in 1D and 2D, 2^(3/dim)."),
    EJ_PARAM_BOOL(sph_config, variable_h, 1,
                  "Adapt h to the current density (true) or keep h = h_factor vol0^(1/dim)."),
    EJ_PARAM_REAL(sph_config, alpha, "1", 1.0, 0.0, 0.0, EJ_PF_HAS_MIN,
                  "Linear (bulk) coefficient of the Monaghan artificial viscosity. Across a shear band it "
                  "drags with a traction of about 0.056 alpha rho c dv at any spacing: for slow granular flow "
                  "without shocks use 0 (README \"Viscosity in a shear band\")."),
    EJ_PARAM_REAL(sph_config, beta, "1", 2.0, 0.0, 0.0, EJ_PF_HAS_MIN,
                  "Quadratic (von Neumann-Richtmyer) coefficient of the Monaghan viscosity."),
    EJ_PARAM_REAL(sph_config, eta, "1", 0.1, 0.0, 0.0, EJ_PF_HAS_MIN | EJ_PF_MIN_OPEN,
                  "Regularisation of mu_ij in units of h: keeps it finite as r -> 0."),
    EJ_PARAM_REAL(sph_config, rho_min, "1", 1e-6, 0.0, 1.0,
                  EJ_PF_HAS_MIN | EJ_PF_HAS_MAX | EJ_PF_MAX_OPEN | EJ_PF_EXPERT,
                  "Density floor as a fraction of each particle's initial density m/vol0; guards "
                  "the EOS and h against expansion into vacuum. Keep it at or above h_max^-dim: below that a "
                  "floored particle's volume m/rho outgrows its kernel (README)."),
    EJ_PARAM_REAL(sph_config, drho_max, "1", 0.5, 0.0, 0.0,
                  EJ_PF_HAS_MIN | EJ_PF_MIN_OPEN | EJ_PF_EXPERT,
                  "Bound on the relative density change per step before the CFL factor: dt <= drho_max "
                  "rho/|rho_dot| with rho_dot the full rate of the last evaluation (method and interactions), "
                  "so that a strong expansion cannot overshoot rho below zero (0.5: at most cfl x 0.5 = 0.15 "
                  "per step at the default CFL, as ulpd's |tr L| dt <= 1/2). Not used with density: summation."),
    EJ_PARAM_BOOL(sph_config, strength, 0,
                  "Solid mechanics: the material's strength model gives the Cauchy stress (Libersky-Petschek "
                  "form, README); required when the material has a strength model, because the method's "
                  "declare op cannot see the material (ABI 1.1)."),
    EJ_PARAM_ENUM(sph_config, stress_rate, sph_stress_rate_names, "hughes_winget",
                  "With strength: objective update of the stress of t_n, hughes_winget (Q sigma Q^T, exact "
                  "rotation) or jaumann (explicit sigma + dt (w sigma - sigma w))."),
    EJ_PARAM_BOOL(sph_config, art_stress, 1,
                  "With strength: Monaghan/Gray artificial stress against the tensile instability (Gray, "
                  "Monaghan & Swift 2001), f_ij^n (R_i + R_j) added to the pair stress."),
    EJ_PARAM_REAL(sph_config, art_eps, "1", 0.3, 0.0, 1.0, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX,
                  "Artificial-stress coefficient epsilon: R = -epsilon sigma'/rho^2 for principal tension."),
    EJ_PARAM_REAL(sph_config, art_n, "1", 4.0, 1.0, 16.0, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX,
                  "Artificial-stress exponent n of f_ij = W(r_ij)/W(dx), dx = hbar/h_factor: the current local spacing "
                  "with variable_h (the initial one with constant h)."),
    EJ_PARAM_REAL(sph_config, xsph, "1", 0.0, 0.0, 1.0, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX,
                  "With strength: XSPH coefficient epsilon (Monaghan 1989): after each step the particles move by "
                  "dt eps sum_j (m_j/rhobar_ij) (v_j - v_i) W_ij on top of the integrator; 0 is off."),
    EJ_PARAM_ENUM(sph_config, visc_switch, sph_visc_switch_names, "none",
                  "With strength: none, or balsara: Pi_ij is multiplied by (f_i + f_j)/2, f = |div v| / (|div v| + "
                  "|curl v| + 1e-4 c/h) from the stress pass's velocity gradient (Balsara, JCP 121 (1995) 357): the "
                  "viscosity stays in compression and fades in shear, where it otherwise drags across a shear band "
                  "with about alpha rho c dv at any spacing (README \"Viscosity switch\")."),
    EJ_PARAM_ENUM(sph_config, geometry, sph_geometry_names, "planar",
                  "planar, or spherical (dimension: 1 only): x is the radius r >= 0 of a spherically symmetric "
                  "flow, m the true shell mass, the 1D sums use the line mass m/(4 pi r^2) and the divergence "
                  "gets its 2v/r part (README \"Spherical symmetry\"; needs a symmetry plane at x = 0)."),
    EJ_PARAM_ENUM(sph_config, spherical_energy, sph_spherical_energy_names, "local",
                  "geometry: spherical: pdV work in the local form -2 (p/rho) v/r (local) or, for particles at "
                  "r >= 4 h, in the pair form that conserves energy exactly with the momentum equation (pair; "
                  "coupled sets then need it on both sides; README \"Spherical symmetry\")."),
    EJ_PARAM_REAL(sph_config, conductivity, "1", 0.0, 0.0, 10.0, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX,
                  "Gas (strength: false): artificial conductivity alpha_u of the energy equation (Price 2008), "
                  "de_i/dt += sum_j m_j alpha_u v_sig (e_i - e_j)/rhobar dW/dr, v_sig = sqrt(|p_i - p_j|/rhobar); "
                  "pairwise energy-conserving; 0 is off (README \"Artificial conductivity\")."),
    {0}};

typedef struct sph_state {
  sph_config cfg;
  const ej_set *set;
  int64_t shape_fallbacks; /* sum over the run of the per-step series (report op) */
  int dim;
  const ej_eos *eos;
  const ej_material *mat; /* strength model (strength: true), else NULL */
  ej_real K, G;           /* its initial moduli */
  const char *set_name;
  /* gradient: shape_tensor: per owned row i, the neighbours inside 2 hbar in list order,
   * kept[SPH_KEPT_MAX * i + 0 .. kept_n[i] - 1] (written by the shape pass's compaction gather, read by
   * the pair pass of the same step, which then neither tests nor walks the list); kept_n[i] = -1 for a
   * row with more than SPH_KEPT_MAX such entries or more than SPH_KEPT_ROW list entries (that row's
   * pair pass runs its own compaction gather). Allocated in setup for kept_cap rows. */
  ej_idx *kept;
  int32_t *kept_n;
  ej_idx kept_cap;
  ej_real geom_rho0; /* geometry: spherical: the material's rho0 (density floor reference), else 0 */
} sph_state;

/* Slot of kept neighbours per row (one pair-loop block, SPH_BLK), and the longest list row that
 * uses it (longer rows: the pair pass runs its own compaction gather, as for the kernel gradient). */
#define SPH_KEPT_MAX 128
#define SPH_KEPT_ROW 512

/* ------------------------------------------------------------------ declare */

static ej_err sph_declare(const void *config, int dim, ej_decl *d)
{
  const sph_config *cfg = config;
  EJ_ENSURE(dim >= 1 && dim <= 3, EJ_ERR_ARG, "sph: dimension %d not in 1..3", dim);
  static const ej_field_decl fields[] = {
      {.name = "rho", .kind = EJ_SCALAR, .flags = EJ_FIELD_OUTPUT, .unit = "kg/m^3", .rate = "rho_dot",
       .doc = "Density, evolved by the continuity equation."},
      {.name = "e", .kind = EJ_SCALAR, .flags = EJ_FIELD_OUTPUT, .unit = "J/kg", .rate = "e_dot",
       .energy = EJ_ENERGY_INTERNAL, .doc = "Specific internal energy."},
      {.name = "p", .kind = EJ_SCALAR, .flags = EJ_FIELD_SCRATCH | EJ_FIELD_OUTPUT, .unit = "Pa",
       .doc = "Pressure from the equation of state (compression positive)."},
      {.name = "c", .kind = EJ_SCALAR, .flags = EJ_FIELD_SCRATCH, .unit = "m/s",
       .doc = "Sound speed from the equation of state."},
      {.name = "w_cont", .kind = EJ_SCALAR, .flags = EJ_FIELD_SCRATCH, .unit = "1",
       .doc = "Neighbour weight of the continuity sum: m/rho (volume form) or m (mass form)."},
      {.name = "p_rho2", .kind = EJ_SCALAR, .flags = EJ_FIELD_SCRATCH, .unit = "m^5/(kg s^2)",
       .doc = "p / rho^2, computed once per particle so that the pair loop does not divide."},
      /* not scratch: sph_wall's gradient pre-pass reads the previous evaluation's h, so a restart
       * needs it from the checkpoint (test_restart_methods test_sph_wall_gradient_restart) */
      {.name = "h", .kind = EJ_SCALAR, .flags = EJ_FIELD_OUTPUT, .unit = "m",
       .doc = "Smoothing length (kernel support is 2h)."},
      {.name = "w_visc", .kind = EJ_SCALAR, .flags = EJ_FIELD_NO_GHOST, .unit = "J/kg",
       .rate = "w_visc_dot", .energy = EJ_ENERGY_VISCOUS,
       .doc = "Specific work dissipated by artificial viscosity (already part of e)."},
      {.name = "mu_max", .kind = EJ_SCALAR, .flags = EJ_FIELD_SCRATCH | EJ_FIELD_NO_GHOST, .unit = "m/s",
       .doc = "Largest |mu_ij| over approaching neighbours, for the viscous time step."},
  };
  for (size_t k = 0; k < sizeof fields / sizeof fields[0]; ++k) EJ_TRY(ej_decl_field(d, &fields[k]));
  if (cfg->correction) {
    static const ej_field_decl corr[] = {
        {.name = "L_corr", .kind = EJ_SYM6, .flags = EJ_FIELD_SCRATCH, .unit = "1",
         .doc = "Gradient correction L_i = (sum_j V_j grad_i W_ij (x) x_ji)^-1."},
        {.name = "corr_fallbacks", .kind = EJ_INT, .flags = EJ_FIELD_NO_GHOST, .unit = "1",
         .doc = "Steps in which L_i was ill-conditioned and the uncorrected gradient was used."},
    };
    for (size_t k = 0; k < sizeof corr / sizeof corr[0]; ++k) EJ_TRY(ej_decl_field(d, &corr[k]));
  }
  if (cfg->renormalize_interfaces) {
    /* README "Renormalisation across interfaces": pass 2 sets them for its own neighbours,
     * interactions add their pairs, finish applies the factor */
    static const ej_field_decl ren[] = {
        {.name = "ren_div", .kind = EJ_SCALAR, .flags = EJ_FIELD_SCRATCH | EJ_FIELD_NO_GHOST, .unit = "1/s",
         .doc = "Unrenormalised velocity divergence sum_j V_j (v_i - v_j) . grad_i W_ij over the set's own and "
                "the coupled sets' neighbours."},
        {.name = "ren_norm", .kind = EJ_SCALAR, .flags = EJ_FIELD_SCRATCH | EJ_FIELD_NO_GHOST, .unit = "1",
         .doc = "Renormalisation sum sum_j V_j r_ij dW/dr (-dim for an exact quadrature) over the same "
                "neighbours."},
    };
    for (size_t k = 0; k < sizeof ren / sizeof ren[0]; ++k) EJ_TRY(ej_decl_field(d, &ren[k]));
  }
  if (cfg->gradient == SPH_GRAD_SHAPE) {
    static const ej_field_decl shape[] = {
        {.name = "M_inv", .kind = EJ_SYM6, .flags = EJ_FIELD_SCRATCH, .unit = "1/m^2",
         .doc = "Inverse current shape tensor M_i^-1, M_i = sum_j V_j w_ij x_ij (x) x_ij (zero on fallback)."},
        {.name = "grad_fallback", .kind = EJ_INT, .flags = EJ_FIELD_SCRATCH | EJ_FIELD_OUTPUT, .unit = "1",
         .doc = "1 where the shape tensor was ill-conditioned this step and the kernel gradient was used."},
        {.name = "M_cpl", .kind = EJ_SYM6, .flags = EJ_FIELD_SCRATCH | EJ_FIELD_NO_GHOST, .unit = "m^2",
         .doc = "The coupled sets' share of M_i, sum_j V_j w_ij x_ij (x) x_ij over their neighbours, added by an "
                "interaction's pre-pass (continuum) and consumed (zeroed) by the shape pass."},
    };
    for (size_t k = 0; k < sizeof shape / sizeof shape[0]; ++k) EJ_TRY(ej_decl_field(d, &shape[k]));
  }
  if (cfg->strength) {
    static const ej_field_decl solid[] = {
        {.name = "stress", .kind = EJ_SYM6, .flags = EJ_FIELD_OUTPUT, .unit = "Pa",
         .doc = "Cauchy stress (tension positive) from the strength model."},
        {.name = "d_rate", .kind = EJ_SYM6, .flags = EJ_FIELD_SCRATCH | EJ_FIELD_NO_GHOST, .unit = "1/s",
         .doc = "Rate of deformation sym(L) of the step."},
        {.name = "c_mat", .kind = EJ_SCALAR, .flags = EJ_FIELD_SCRATCH | EJ_FIELD_NO_GHOST, .unit = "m/s",
         .doc = "Sound speed returned by the strength model."},
        {.name = "wp_inc", .kind = EJ_SCALAR, .flags = EJ_FIELD_SCRATCH | EJ_FIELD_NO_GHOST, .unit = "J/kg",
         .doc = "Specific plastic work of the step."},
        {.name = "w_plastic", .kind = EJ_SCALAR, .flags = EJ_FIELD_NO_GHOST, .unit = "J/kg",
         .rate = "w_plastic_dot", .energy = EJ_ENERGY_PLASTIC,
         .doc = "Specific plastic work (already part of e)."},
        {.name = "sigma_rho2", .kind = EJ_SYM6, .flags = EJ_FIELD_SCRATCH, .unit = "m^5/(kg s^2)",
         .doc = "sigma / rho^2 for the pair loop."},
        {.name = "art_stress", .kind = EJ_SYM6, .flags = EJ_FIELD_SCRATCH, .unit = "m^5/(kg s^2)",
         .doc = "Artificial stress R_i (Gray, Monaghan & Swift 2001)."},
        {.name = "failed", .kind = EJ_INT, .flags = EJ_FIELD_OUTPUT | EJ_FIELD_NO_GHOST, .unit = "1",
         .doc = "1 once the strength model reported failure (no shear, no tension afterwards)."},
        {.name = "v_xsph", .kind = EJ_VEC3, .flags = EJ_FIELD_SCRATCH | EJ_FIELD_NO_GHOST, .unit = "m/s",
         .doc = "XSPH velocity correction eps sum_j (m_j/rhobar_ij) (v_j - v_i) W_ij (xsph > 0)."},
        {.name = "L_wall", .kind = EJ_TENSOR9, .flags = EJ_FIELD_SCRATCH | EJ_FIELD_NO_GHOST, .unit = "1/s",
         .doc = "Velocity gradient from wall interactions, sum_w V_w (v_w - v_i) (x) grad_i W_iw (sph_wall adds it "
                "before sph's passes; zero without walls), added to L_i before the material update (with "
                "correction: times L_corr,i) and zeroed."},
    };
    for (size_t k = 0; k < sizeof solid / sizeof solid[0]; ++k) EJ_TRY(ej_decl_field(d, &solid[k]));
    if (cfg->correction) {
      static const ej_field_decl bw = {
          .name = "B_wall", .kind = EJ_SYM6, .flags = EJ_FIELD_SCRATCH | EJ_FIELD_NO_GHOST, .unit = "1",
          .doc = "The walls' share sum_w V_w (x_w - x_i) (x) grad_i W_iw of B_i (sph_wall adds it before sph's "
                 "passes; zero without walls), added before B_i is inverted into L_corr, and zeroed."};
      EJ_TRY(ej_decl_field(d, &bw));
    }
    if (cfg->visc_switch == SPH_VSW_BALSARA) {
      static const ej_field_decl sw = {
          .name = "visc_switch", .kind = EJ_SCALAR, .flags = EJ_FIELD_SCRATCH, .unit = "1",
          .doc = "Balsara factor |div v| / (|div v| + |curl v| + 1e-4 c/h) of the step (visc_switch: balsara)."};
      EJ_TRY(ej_decl_field(d, &sw));
    }
  }
  if (cfg->geometry == SPH_GEOM_SPHERICAL) {
    static const ej_field_decl geom = {
        .name = "m_line", .kind = EJ_SCALAR, .flags = EJ_FIELD_SCRATCH, .unit = "kg/m^2",
        .doc = "geometry: spherical: line mass m/(4 pi r^2) that the 1D sums use in place of m (pass 0)."};
    EJ_TRY(ej_decl_field(d, &geom));
    if (cfg->spherical_energy == 1) {
      /* its presence tells `continuum` to use the pair form u_ij on its cross-set pairs too */
      static const ej_field_decl pairf = {
          .name = "pdv_pair", .kind = EJ_SCALAR, .flags = EJ_FIELD_SCRATCH | EJ_FIELD_NO_GHOST, .unit = "1",
          .doc = "spherical_energy: pair: 1 where the particle took the exact pair form of the pdV work (r >= 4 h), "
                 "0 where the local form (last step)."};
      EJ_TRY(ej_decl_field(d, &pairf));
    }
  }
  EJ_TRY(ej_decl_neighbours(d, EJ_NBR_CURRENT));
  return EJ_OK;
}

/* ------------------------------------------------------------------ create / destroy */

static ej_err sph_create(const void *config, ej_set *set, const ej_model *model, void **state)
{
  EJ_ENSURE(config && set && model && state, EJ_ERR_ARG, "sph: NULL argument to create");
  const sph_config *cfg = config;
  const int dim = ej_set_dim(set);
  EJ_ENSURE(dim >= 1 && dim <= 3, EJ_ERR_ARG, "sph: dimension %d not in 1..3", dim);
  EJ_ENSURE(cfg->kernel == SPH_KERNEL_CUBIC_SPLINE || cfg->kernel == SPH_KERNEL_WENDLAND_C2, EJ_ERR_ARG,
            "sph: kernel index %d unknown", cfg->kernel);
  const ej_eos *eos = ej_model_eos(model);
  const ej_material *mat = ej_model_material(model);
  EJ_ENSURE(eos || mat, EJ_ERR_UNSUPPORTED,
            "set '%s': sph needs an equation of state, and material '%s' has none (add eos: {...})",
            ej_set_name(set), ej_model_name(model));
  /* A strength model needs the solid fields, which declare adds only with strength: true. */
  EJ_ENSURE(!mat || cfg->strength, EJ_ERR_UNSUPPORTED,
            "set '%s': material '%s' has a strength model; add 'strength: true' to the sph method so that "
            "the stress is computed (without it sph models fluids only)",
            ej_set_name(set), ej_model_name(model));
  EJ_ENSURE(mat || !cfg->strength, EJ_ERR_UNSUPPORTED,
            "set '%s': sph has strength: true, but material '%s' has no strength model", ej_set_name(set),
            ej_model_name(model));
  EJ_ENSURE(!mat || ej_material_n_hist(mat) <= SPH_MAX_HIST, EJ_ERR_UNSUPPORTED,
            "set '%s': sph supports at most %d history variables", ej_set_name(set), SPH_MAX_HIST);
  sph_state *s = ej_calloc(1, sizeof *s);
  EJ_ENSURE(s, EJ_ERR_MEM, "sph: out of memory");
  s->cfg = *cfg;
  /* continuity: auto (README "Continuity form"): the number form with the renormalised kernel
   * gradient in planar geometry, else the volume form (the shape tensor's shape_continuity symmetric
   * is written for it; geometry: spherical was validated with it) */
  if (s->cfg.continuity == SPH_CONT_AUTO)
    s->cfg.continuity = s->cfg.gradient == SPH_GRAD_KERNEL && s->cfg.renormalize && !s->cfg.correction &&
                                s->cfg.geometry == SPH_GEOM_PLANAR
                            ? SPH_CONT_NUMBER
                            : SPH_CONT_VOLUME;
  /* The discrete gradient sum sum_j V_j x_ji (x) grad W equals I only approximately on a
   * lattice; its bias scales every pressure force and does not shrink with resolution at
   * fixed h/dx. Cubic spline: exact at integer h/dx in 1D (B-spline partition of unity),
   * +0.7 % at 1.5 in 2D, +0.65 % at 1.3 in 3D (+2.2 % at 1.3 in 1D, which alone makes the
   * Sod star velocity 0.8 % fast). Wendland C2: best near 1.5 in 2D and 3D. */
  if (s->cfg.h_factor <= 0.0) {
    const bool cubic = cfg->kernel == SPH_KERNEL_CUBIC_SPLINE;
    s->cfg.h_factor = dim == 1 ? 2.0 : dim == 2 ? 1.5 : (cubic ? 1.3 : 1.5);
  }
  /* LS-DYNA's defaults bound the volume of a particle's support to [0.2^3, 2^3] of its
   * initial value; the same volume ratios in 1D and 2D are wider in h. */
  if (s->cfg.h_min <= 0.0) s->cfg.h_min = pow(0.2, 3.0 / dim);
  if (s->cfg.h_max <= 0.0) s->cfg.h_max = pow(2.0, 3.0 / dim);
  EJ_ENSURE(s->cfg.h_max >= 1.0 && s->cfg.h_min <= 1.0, EJ_ERR_ARG, "set '%s': need h_min <= 1 <= h_max",
            ej_set_name(set));
  EJ_ENSURE(s->cfg.h_factor >= 0.5, EJ_ERR_ARG, "set '%s': h_factor %g is below 0.5", ej_set_name(set),
            s->cfg.h_factor);
  s->dim = dim;
  s->eos = eos;
  s->mat = mat;
  if (mat) {
    const ej_err rc = ej_material_moduli(mat, &s->K, &s->G);
    if (rc != EJ_OK) {
      ej_free(s);
      return rc;
    }
  }
  s->set_name = ej_set_name(set);
  s->set = set;
  /* check_config cannot see the dimension: the create error is tied to the set's node (ej_located). */
  if (cfg->geometry == SPH_GEOM_SPHERICAL) {
    if (dim != 1) {
      ej_free(s);
      EJ_FAIL(EJ_ERR_INPUT,
              "set '%s': sph geometry: spherical needs dimension: 1 (x is the radius), the scene has dimension: %d",
              ej_set_name(set), dim);
    }
    s->geom_rho0 = ej_model_rho0(model);
  }
  *state = s;
  return EJ_OK;
}

static void sph_destroy(void *state)
{
  sph_state *s = state;
  if (s) {
    ej_free(s->kept);
    ej_free(s->kept_n);
  }
  ej_free(state);
}

/* ------------------------------------------------------------------ smoothing length */

/* v^(1/dim): the particle's linear size from its volume (per unit depth in 2D, per unit area
 * in 1D, so the same formula holds in every dimension). */
static inline ej_real sph_root(int dim, ej_real v) { return dim == 3 ? cbrt(v) : dim == 2 ? sqrt(v) : v; }

/* h_i = h_factor (m_i / rho_i)^(1/dim) (variable) or h_factor vol0_i^(1/dim) (fixed): the
 * usual SPH choice h ~ particle spacing (Monaghan, Rep. Prog. Phys. 68 (2005) 1703, section 2;
 * no iteration on rho, because here rho is evolved, not summed). */
static inline ej_real sph_h(const sph_config *cfg, int dim, ej_real m, ej_real vol0, ej_real rho)
{
  if (!cfg->variable_h) return cfg->h_factor * sph_root(dim, vol0);
  /* (m/rho) / vol0 = rho0 / rho, bounded to [h_min, h_max]^dim (LS-DYNA *SECTION_SPH HMIN, HMAX) */
  ej_real ratio = m / (rho * vol0);
  const ej_real lo = cfg->h_min, hi = cfg->h_max;
  const ej_real lo_d = dim == 3 ? lo * lo * lo : dim == 2 ? lo * lo : lo;
  const ej_real hi_d = dim == 3 ? hi * hi * hi : dim == 2 ? hi * hi : hi;
  ratio = ratio < lo_d ? lo_d : ratio > hi_d ? hi_d : ratio;
  return cfg->h_factor * sph_root(dim, ratio * vol0);
}

/* The floor is relative to the initial density m/vol0 (the core sets m = rho_init vol0). */
static inline ej_real sph_rho_floor(const sph_config *cfg, ej_real m, ej_real vol0)
{
  return cfg->rho_min * m / vol0;
}

/* geometry: spherical (README "Spherical symmetry"). m is the true shell mass, vol0 the initial
 * radial spacing, and the 1D sums use the line mass mu = m/(4 pi r^2) (so that m/rho -> mu/rho is
 * the radial extent of the particle and h = h_factor mu/rho); the density floor is relative to the
 * material's rho0 (m/vol0 is not a density there). r is kept off 0 only against a division by 0:
 * particles sit at r >= dx/2 and the mirror ghosts of x = 0 keep them there. */
static inline ej_real sph_line_mass(ej_real m, ej_real x, ej_real vol0)
{
  const ej_real r = fmax(fabs(x), 1e-9 * vol0);
  return m / (4.0 * 3.14159265358979323846 * r * r);
}

static inline ej_real sph_floor_of(const sph_state *s, ej_real m, ej_real vol0)
{
  return s->geom_rho0 > 0.0 ? s->cfg.rho_min * s->geom_rho0 : sph_rho_floor(&s->cfg, m, vol0);
}

static ej_err sph_bad_particle(const sph_state *s, const ej_set *set, ej_idx i, const char *what, ej_real val)
{
  const ej_real *x = ej_set_field(set, "x");
  const int32_t *id = ej_set_field_int(set, "id");
  EJ_FAIL(EJ_ERR_NUMERIC, "set '%s': sph particle id %d at (%g, %g, %g): %s = %g", s->set_name,
          id ? (int)id[i] : (int)i, x ? x[3 * i] : NAN, x ? x[3 * i + 1] : NAN, x ? x[3 * i + 2] : NAN, what,
          val);
}

/* The mass the 1D sums read: m, or with geometry: spherical the line mass m/(4 pi r^2) of the
 * particles in r, written into m_line (the core copies it to the ghosts before the pair pass). */
static const ej_real *sph_geom_mass(const sph_state *s, ej_set *set, ej_range r)
{
  const ej_real *m = ej_set_field(set, "m");
  if (s->cfg.geometry != SPH_GEOM_SPHERICAL) return m;
  ej_real *mu = ej_set_field(set, "m_line");
  const ej_real *x = ej_set_field(set, "x"), *vol0 = ej_set_field(set, "vol0");
  if (!m || !mu || !x || !vol0) return NULL;
  for (ej_idx i = r.begin; i < r.end; ++i) mu[i] = sph_line_mass(m[i], x[3 * i], vol0[i]);
  return mu;
}

/* Pass 0 and setup: floor rho, then h, p and c of the particles in r. */
static ej_err sph_particle_pass(const sph_state *s, ej_set *set, ej_range r)
{
  ej_real *restrict rho = ej_set_field(set, "rho");
  ej_real *restrict h = ej_set_field(set, "h");
  ej_real *restrict p = ej_set_field(set, "p");
  ej_real *restrict c = ej_set_field(set, "c");
  ej_real *restrict p_rho2 = ej_set_field(set, "p_rho2");
  ej_real *restrict w_cont = ej_set_field(set, "w_cont");
  const ej_real *restrict e = ej_set_field(set, "e");
  const ej_real *restrict m = sph_geom_mass(s, set, r); /* m, or the line mass (geometry: spherical) */
  const ej_real *restrict vol0 = ej_set_field(set, "vol0");
  EJ_ENSURE(rho && h && p && c && p_rho2 && w_cont && e && m && vol0, EJ_ERR_INTERNAL,
            "set '%s': sph fields missing", s->set_name);
  const sph_config *cfg = &s->cfg;
  const int dim = s->dim;
  for (ej_idx i = r.begin; i < r.end; ++i) {
    const ej_real floor = sph_floor_of(s, m[i], vol0[i]);
    /* Written as "<" so that a NaN density reaches the check below instead of being hidden. */
    if (rho[i] < floor) rho[i] = floor;
    if (!(rho[i] > 0.0)) return sph_bad_particle(s, set, i, "density rho", rho[i]);
    h[i] = sph_h(cfg, dim, m[i], vol0[i], rho[i]);
  }
  if (r.end > r.begin && s->eos)
    EJ_TRY(ej_eos_evaluate_set(s->eos, set, r, rho + r.begin, e + r.begin, p + r.begin, c + r.begin));
  if (!s->eos) { /* strength model without EOS: p of the current stress, c of the moduli */
    const ej_real *stress = ej_set_field(set, "stress");
    EJ_ENSURE(stress, EJ_ERR_INTERNAL, "set '%s': sph field stress missing", s->set_name);
    for (ej_idx i = r.begin; i < r.end; ++i) {
      p[i] = -ej_s6_trace(stress + 6 * i) / 3.0;
      c[i] = sqrt((s->K + 4.0 * s->G / 3.0) / rho[i]);
    }
  }
  for (ej_idx i = r.begin; i < r.end; ++i) {
    p_rho2[i] = p[i] / (rho[i] * rho[i]);
    w_cont[i] = cfg->continuity == SPH_CONT_VOLUME ? m[i] / rho[i] : cfg->continuity == SPH_CONT_NUMBER ? 1.0 : m[i];
  }
  return EJ_OK;
}

static ej_err sph_setup(void *state, ej_set *set)
{
  const sph_state *s = state;
  const ej_real *m = ej_set_field(set, "m");
  const ej_real *vol0 = ej_set_field(set, "vol0");
  EJ_ENSURE(m && vol0, EJ_ERR_INTERNAL, "set '%s': base fields m, vol0 missing", s->set_name);
  const ej_idx n = ej_set_count(set);
  if (s->cfg.geometry == SPH_GEOM_SPHERICAL) {
    /* The lattice gives the 1D mass m = rho dx (the core sets m = rho vol0): the true mass of the
     * shell of radius r = x is rho 4 pi r^2 dx (midpoint rule: the exact shell holds
     * rho 4 pi (r^2 + dx^2/12) dx, 1/(4 N^2) more in all for N shells of a sphere). The midpoint
     * mass keeps the line mass mu = m/(4 pi r^2) = rho dx uniform on a uniform lattice, so a
     * uniform gas is in equilibrium to round-off. Done once here (a restart reads m back). */
    ej_real *mm = ej_set_field(set, "m");
    const ej_real *x = ej_set_field(set, "x");
    EJ_ENSURE(mm && x, EJ_ERR_INTERNAL, "set '%s': base fields m, x missing", s->set_name);
    for (ej_idx i = 0; i < n; ++i) {
      if (!(x[3 * i] > 0.0))
        return sph_bad_particle(s, set, i, "geometry: spherical needs every particle at radius x > 0; x", x[3 * i]);
      mm[i] *= 4.0 * 3.14159265358979323846 * x[3 * i] * x[3 * i];
    }
  }
  for (ej_idx i = 0; i < n; ++i) {
    if (!(m[i] > 0.0)) return sph_bad_particle(s, set, i, "mass m", m[i]);
    if (!(vol0[i] > 0.0)) return sph_bad_particle(s, set, i, "volume vol0", vol0[i]);
  }
  /* h, p and c exist before the first support call and the first output frame. */
  EJ_TRY(sph_particle_pass(s, set, (ej_range){0, n}));
  if (s->cfg.gradient == SPH_GRAD_SHAPE && !s->kept) { /* the shape pass's kept-neighbour slots (setup only) */
    sph_state *ms = state;
    ms->kept = ej_malloc(((size_t)n * SPH_KEPT_MAX + 1) * sizeof(ej_idx));
    ms->kept_n = ej_malloc(((size_t)n + 1) * sizeof(int32_t));
    EJ_ENSURE(ms->kept && ms->kept_n, EJ_ERR_MEM, "set '%s': sph out of memory", s->set_name);
    ms->kept_cap = n;
  }
  return EJ_OK;
}

static ej_err sph_support(void *state, const ej_set *set, ej_range r, ej_real *radius)
{
  const sph_state *s = state;
  const ej_real *restrict rho = ej_set_field(set, "rho");
  const ej_real *restrict m = ej_set_field(set, "m");
  const ej_real *restrict vol0 = ej_set_field(set, "vol0");
  EJ_ENSURE(rho && m && vol0, EJ_ERR_INTERNAL, "set '%s': sph fields missing", s->set_name);
  /* Same h as pass 0 (floored density), so the list holds every pair with r < 2 hbar.
   * radius[k] belongs to particle r.begin + k (plugin.h). */
  const ej_real *restrict x = s->cfg.geometry == SPH_GEOM_SPHERICAL ? ej_set_field(set, "x") : NULL;
  for (ej_idx i = r.begin; i < r.end; ++i) {
    const ej_real mi = x ? sph_line_mass(m[i], x[3 * i], vol0[i]) : m[i]; /* as pass 0 */
    const ej_real rf = fmax(rho[i], sph_floor_of(s, mi, vol0[i]));
    radius[i - r.begin] = 2.0 * sph_h(&s->cfg, s->dim, mi, vol0[i], rf);
  }
  return EJ_OK;
}

/* ------------------------------------------------------------------ pair pass */

/* Inlining is what turns kernel and dim into constants; without it every pair would branch. */
#if defined(__GNUC__)
#define SPH_ALWAYS_INLINE __attribute__((always_inline))
#else
#define SPH_ALWAYS_INLINE
#endif

/* Neighbour entries per block of the blocked pair loops (gather, vectorised terms, sum). */
#define SPH_BLK 128
/* the shape pass compaction-gathers one block straight into a row's kept slot */
_Static_assert(SPH_KEPT_MAX == SPH_BLK, "a kept slot holds one pair-loop block");

typedef struct sph_pair_args {
  const ej_real *x, *v, *m, *rho, *p_rho2, *c, *h, *w_cont, *L, *M;
  const int32_t *fb;
  bool volume_form, renormalize, cont_rate;
  bool unit_w; /* continuity: number: every neighbour weighs 1 in the continuity sums (volume_form is set) */
  bool visc_kernel, energy_own; /* shape_form symmetric: shape_viscosity kernel, shape_energy own */
  bool cont_sym;                /* shape_form symmetric: shape_continuity symmetric */
  const ej_idx *kept;    /* shape tensor: the shape pass's kept neighbours (sph_state.kept), or NULL */
  const int32_t *kept_n; /* their counts per row (-1: not kept) */
  ej_real *a, *rho_dot, *e_dot, *w_dot, *mu_max;
  ej_real *ren_div, *ren_norm; /* renormalize_interfaces: the raw sums for finish (else NULL) */
  const ej_off *off;
  const ej_idx *idx;
  ej_real alpha, beta, eta2;
} sph_pair_args;

/* Kernel gradient correction, Bonet & Lok, CMAME 180 (1999) 97, Eq 37 (also Randles &
 * Libersky 1996): B_i = sum_j V_j grad_i W_ij (x) x_ji = -sum_j V_j W'/r r_ij (x) r_ij
 * (symmetric, ~ I for a full support), L_i = B_i^-1, so that sum_j V_j (f_j - f_i) L_i grad_i W_ij
 * is the exact gradient of any linear f. Only the dim x dim block is used. A particle with
 * too few or coplanar neighbours (free surface, expanding front) has a nearly singular B:
 * it keeps L = I and the event is counted. */
static inline SPH_ALWAYS_INLINE void sph_corr_rows(const int kernel, const int dim, const ej_real *restrict x,
                                                    const ej_real *restrict m, const ej_real *restrict rho,
                                                    const ej_real *restrict h, const ej_off *restrict off,
                                                    const ej_idx *restrict idx, ej_real *restrict Bw,
                                                    ej_real *restrict L, int32_t *restrict fallbacks, ej_range rg)
{
  const ej_real sigma = sph_kernel_sigma(kernel, dim);
  for (ej_idx i = rg.begin; i < rg.end; ++i) {
    ej_real b[6] = {0, 0, 0, 0, 0, 0}; /* xx yy zz xy yz zx */
    /* the walls' share (B_wall, filled by sph_wall's pre-pass): wall particles are neighbours in
     * B_i as they are in L_i, so the corrected gradient stays exact for a linear field next to a wall */
    if (Bw)
      for (int q = 0; q < 6; ++q) b[q] = Bw[6 * (size_t)i + q], Bw[6 * (size_t)i + q] = 0.0;
    for (ej_off k = off[i]; k < off[i + 1]; ++k) {
      const ej_idx j = idx[k];
      const ej_real rx = x[3 * i] - x[3 * j];
      const ej_real ry = dim > 1 ? x[3 * i + 1] - x[3 * j + 1] : 0.0;
      const ej_real rz = dim > 2 ? x[3 * i + 2] - x[3 * j + 2] : 0.0;
      const ej_real r2 = rx * rx + ry * ry + rz * rz;
      const ej_real hbar = 0.5 * (h[i] + h[j]);
      if (r2 >= 4.0 * hbar * hbar || r2 <= 0.0) continue;
      const ej_real r = sqrt(r2), inv_h = 1.0 / hbar;
      const ej_real w = -(m[j] / rho[j]) * sigma * sph_inv_pow(inv_h, dim + 1) * sph_kernel_df(kernel, dim, r * inv_h) / r;
      b[0] += w * rx * rx;
      if (dim > 1) b[1] += w * ry * ry, b[3] += w * rx * ry;
      if (dim > 2) b[2] += w * rz * rz, b[4] += w * ry * rz, b[5] += w * rz * rx;
    }
    ej_real *Li = L + 6 * i;
    Li[0] = Li[1] = Li[2] = 1.0;
    Li[3] = Li[4] = Li[5] = 0.0;
    /* well-conditioned: det(B) above 1e-3 of (tr B / dim)^dim */
    const ej_real tr = (b[0] + (dim > 1 ? b[1] : 0) + (dim > 2 ? b[2] : 0)) / dim;
    ej_real det;
    if (dim == 1) {
      det = b[0];
      if (det > 1e-3 * tr) Li[0] = 1.0 / b[0];
      else ++fallbacks[i];
    } else if (dim == 2) {
      det = b[0] * b[1] - b[3] * b[3];
      if (tr > 0 && det > 1e-3 * tr * tr) {
        Li[0] = b[1] / det, Li[1] = b[0] / det, Li[3] = -b[3] / det;
      } else {
        ++fallbacks[i];
      }
    } else {
      const ej_real c0 = b[1] * b[2] - b[4] * b[4], c1 = b[4] * b[5] - b[3] * b[2], c2 = b[3] * b[4] - b[1] * b[5];
      det = b[0] * c0 + b[3] * c1 + b[5] * c2;
      if (tr > 0 && det > 1e-3 * tr * tr * tr) {
        const ej_real id = 1.0 / det;
        Li[0] = c0 * id;
        Li[1] = (b[0] * b[2] - b[5] * b[5]) * id;
        Li[2] = (b[0] * b[1] - b[3] * b[3]) * id;
        Li[3] = c1 * id;
        Li[4] = (b[3] * b[5] - b[0] * b[4]) * id;
        Li[5] = c2 * id;
      } else {
        ++fallbacks[i];
      }
    }
  }
}

/* The instantiations of a per-(kernel, dimension) kernel: CASE(k, d) expands to one
 * `case k * 4 + d:` of `switch (kernel * 4 + dim)`. Adding a kernel means adding it here only. */
#define SPH_FOR_EACH_KERNEL_DIM(CASE)                                                                   \
  CASE(SPH_KERNEL_CUBIC_SPLINE, 1);                                                                     \
  CASE(SPH_KERNEL_CUBIC_SPLINE, 2);                                                                     \
  CASE(SPH_KERNEL_CUBIC_SPLINE, 3);                                                                     \
  CASE(SPH_KERNEL_WENDLAND_C2, 1);                                                                      \
  CASE(SPH_KERNEL_WENDLAND_C2, 2);                                                                      \
  CASE(SPH_KERNEL_WENDLAND_C2, 3)

static ej_err sph_corr_pass(const sph_state *s, ej_set *set, const ej_nbr *nbr, ej_range r)
{
  if (!s->cfg.correction) return EJ_OK;
  const ej_real *x = ej_set_field(set, "x"), *m = ej_set_field(set, "m"), *rho = ej_set_field(set, "rho");
  const ej_real *h = ej_set_field(set, "h");
  ej_real *L = ej_set_field(set, "L_corr");
  ej_real *Bw = ej_set_field(set, "B_wall"); /* strength sets with correction; zeroed after use */
  int32_t *fb = ej_set_field_int(set, "corr_fallbacks");
  EJ_ENSURE(x && m && rho && h && L && fb && nbr, EJ_ERR_INTERNAL, "set '%s': sph correction fields missing",
            s->set_name);
#define SPH_CORR_CASE(k, d)                                                                             \
  case (k) * 4 + (d):                                                                                   \
    sph_corr_rows((k), (d), x, m, rho, h, nbr->off, nbr->idx, Bw, L, fb, r);                            \
    break
  switch (s->cfg.kernel * 4 + s->dim) {
    SPH_FOR_EACH_KERNEL_DIM(SPH_CORR_CASE);
  default: EJ_FAIL(EJ_ERR_INTERNAL, "sph: kernel %d, dimension %d", s->cfg.kernel, s->dim);
  }
#undef SPH_CORR_CASE
  return EJ_OK;
}

#if defined(__AVX2__)
#include <immintrin.h>
/* dst[0..3] = a[stride * j4[0..3]]: scalar loads into one vector and one store (not vgatherdpd:
 * slower on the AMD Zen 3 here, README "Performance"). Data movement only. */
static inline SPH_ALWAYS_INLINE void sph_pairs_g4(const ej_real *restrict a, const size_t stride,
                                                  const ej_idx *restrict j4, ej_real *restrict dst)
{
  _mm256_storeu_pd(dst, _mm256_set_pd(a[stride * (size_t)j4[3]], a[stride * (size_t)j4[2]],
                                      a[stride * (size_t)j4[1]], a[stride * (size_t)j4[0]]));
}
/* The first two components of four 3-vectors a[3 j4[0..3]]: two 128-bit loads per pair of
 * entries, interleaved (x in *c0, y in *c1); the third component stays in-bounds (no 256-bit
 * load past the array's end). Data movement only. */
static inline SPH_ALWAYS_INLINE void sph_pairs_xy4(const ej_real *restrict a, const ej_idx *restrict j4,
                                                   __m256d *c0, __m256d *c1)
{
  const __m256d u02 = _mm256_insertf128_pd(_mm256_castpd128_pd256(_mm_loadu_pd(a + 3 * (size_t)j4[0])),
                                           _mm_loadu_pd(a + 3 * (size_t)j4[2]), 1);
  const __m256d u13 = _mm256_insertf128_pd(_mm256_castpd128_pd256(_mm_loadu_pd(a + 3 * (size_t)j4[1])),
                                           _mm_loadu_pd(a + 3 * (size_t)j4[3]), 1);
  *c0 = _mm256_unpacklo_pd(u02, u13), *c1 = _mm256_unpackhi_pd(u02, u13);
}
/* Six values per particle (M_inv, a Voigt tensor) of four entries, transposed into dst[t ds + 0..3]
 * (t = 0..5): a 256-bit and a 128-bit load per entry, a 4 x 4 and a 2 x 4 transpose, instead of 24
 * scalar loads and stores. Data movement only. The gas loop (ds = SPH_BLK) and the solid force
 * loop (ds = SPH_SOLID_BLK) use it. */
static inline SPH_ALWAYS_INLINE void sph_gather_t6(const ej_real *restrict M, const ej_idx *restrict j4,
                                                  ej_real *restrict dst, const size_t ds)
{
  const ej_real *m0 = M + 6 * (size_t)j4[0], *m1 = M + 6 * (size_t)j4[1], *m2 = M + 6 * (size_t)j4[2],
                *m3 = M + 6 * (size_t)j4[3];
  const __m256d A0 = _mm256_loadu_pd(m0), A1 = _mm256_loadu_pd(m1), A2 = _mm256_loadu_pd(m2), A3 = _mm256_loadu_pd(m3);
  const __m256d t0 = _mm256_unpacklo_pd(A0, A1), t1 = _mm256_unpackhi_pd(A0, A1);
  const __m256d t2 = _mm256_unpacklo_pd(A2, A3), t3 = _mm256_unpackhi_pd(A2, A3);
  _mm256_storeu_pd(dst, _mm256_permute2f128_pd(t0, t2, 0x20));
  _mm256_storeu_pd(dst + ds, _mm256_permute2f128_pd(t1, t3, 0x20));
  _mm256_storeu_pd(dst + 2 * ds, _mm256_permute2f128_pd(t0, t2, 0x31));
  _mm256_storeu_pd(dst + 3 * ds, _mm256_permute2f128_pd(t1, t3, 0x31));
  const __m256d b02 = _mm256_insertf128_pd(_mm256_castpd128_pd256(_mm_loadu_pd(m0 + 4)), _mm_loadu_pd(m2 + 4), 1);
  const __m256d b13 = _mm256_insertf128_pd(_mm256_castpd128_pd256(_mm_loadu_pd(m1 + 4)), _mm_loadu_pd(m3 + 4), 1);
  _mm256_storeu_pd(dst + 4 * ds, _mm256_unpacklo_pd(b02, b13));
  _mm256_storeu_pd(dst + 5 * ds, _mm256_unpackhi_pd(b02, b13));
}
#endif

static inline SPH_ALWAYS_INLINE int sph_pairs_gather(const int dim, const ej_real *restrict x,
                                                     const ej_real *restrict h, const ej_idx *restrict idx,
                                                     ej_off *k, const ej_off kend, const ej_real xi0,
                                                     const ej_real xi1, const ej_real xi2, const ej_real hi,
                                                     ej_real *restrict bx, ej_real *restrict by, ej_real *restrict bz,
                                                     ej_real *restrict bh, ej_idx *restrict jb);

/* Inverse of the symmetric 3 x 3 matrix b (Voigt order xx yy zz xy yz zx) into t, returning the
 * reciprocal condition estimate 1/(|A|_F |A^-1|_F), or 0 for a matrix that is singular relative to
 * its scale (|det A| <= 1e-12 (|A|_F/sqrt 3)^3: a rank-1 M, an isolated pair in 3D, has cofactors of
 * round-off size and an estimate that can come out ~0.1) or whose inverse is not finite. The
 * operations of ej_m3_inverse (core tensor.h) on the full matrix, in the same order, with the three
 * cofactors that equal others by symmetry (products commute exactly) left out and ej_m3_to_s6's
 * 0.5 (T_ab + T_ba) = T_ab exact: bitwise its result, for about half the work (the shape pass runs
 * it once per particle and step). */
static inline SPH_ALWAYS_INLINE ej_real sph_s6_inverse(ej_real t[6], const ej_real b[6])
{
  const ej_real c00 = b[1] * b[2] - b[4] * b[4], c01 = b[4] * b[5] - b[3] * b[2], c02 = b[3] * b[4] - b[1] * b[5];
  const ej_real det = b[0] * c00 + b[3] * c01 + b[5] * c02;
  /* |A|_F^2 summed in ej_m3_norm's order: A0 A1 A2 A3 A4 A5 A6 A7 A8 */
  ej_real sa = b[0] * b[0];
  sa += b[3] * b[3], sa += b[5] * b[5], sa += b[3] * b[3], sa += b[1] * b[1];
  sa += b[4] * b[4], sa += b[5] * b[5], sa += b[4] * b[4], sa += b[2] * b[2];
  const ej_real na = sqrt(sa), scale = na / 1.7320508075688772;
  if (!(na > 0) || !(fabs(det) > 1e-12 * scale * scale * scale)) return 0.0;
  const ej_real id = 1 / det;
  const ej_real T0 = c00 * id, T1 = c01 * id, T2 = c02 * id;
  const ej_real T4 = (b[0] * b[2] - b[5] * b[5]) * id, T5 = (b[5] * b[3] - b[0] * b[4]) * id;
  const ej_real T8 = (b[0] * b[1] - b[3] * b[3]) * id;
  ej_real si = T0 * T0;
  si += T1 * T1, si += T2 * T2, si += T1 * T1, si += T4 * T4;
  si += T5 * T5, si += T2 * T2, si += T5 * T5, si += T8 * T8;
  const ej_real ni = sqrt(si);
  if (!isfinite(ni)) return 0.0;
  t[0] = T0, t[1] = T4, t[2] = T8, t[3] = T1, t[4] = T5, t[5] = T2;
  return 1 / (na * ni);
}

/* Current shape tensor of the consistent SPH, digest 000 Eqs 29-31 (Fan & Li): the discrete
 * M_i = sum_j (m_j/rho_j) w(|x_ij|) x_ij (x) x_ij (the digest's [GAP] note: only the continuous
 * Eq 30 is printed; this is the quadrature consistent with Eq 31), x_ij = x_j - x_i, w the kernel
 * value at hbar (the same symmetric smoothing length as the pair loop). Accumulated in units of
 * h_i^2 so that the condition estimate and the determinant test of ej_m3_inverse do not depend
 * on the length scale. In 1D and 2D M_i is singular in the unused directions: only the
 * dim x dim block is inverted (the unused diagonal is padded with the block's mean diagonal,
 * which leaves the block's inverse untouched and makes an isotropic M give rcond = 1/3 in any
 * dimension). A particle with few or coplanar neighbours (an isolated pair, an expanding front)
 * has a nearly singular M_i: below shape_rcond_min it falls back to the kernel gradient
 * (grad_fallback = 1, M_inv = 0). */
static inline SPH_ALWAYS_INLINE void sph_shape_rows(const int kernel, const int dim, const ej_real *restrict x,
                                                     const ej_real *restrict m, const ej_real *restrict rho,
                                                     const ej_real *restrict h, const ej_off *restrict off,
                                                     const ej_idx *restrict idx, ej_real rcond_min,
                                                     const ej_real *restrict vol, ej_real *restrict Mc,
                                                     ej_real *restrict Minv, int32_t *restrict fb, ej_idx *restrict kept,
                                                     int32_t *restrict kept_n, ej_range rg)
{
  const ej_real sigma = sph_kernel_sigma(kernel, dim);
  /* Blocked like sph_pairs_blocked: the compaction gather (sph_pairs_gather, the pair loop's test
   * r2 < 4 hbar^2 with the same operations) passes only the entries inside 2 hbar, then a vectorised
   * sum over them (omp simd reduction: a fixed order for a given build, whatever the thread count).
   * The first block's indices go straight into the row's slot of `kept` (SPH_KEPT_MAX = SPH_BLK
   * entries), which the pair pass reads back; a row with a second block does not fit (kept_n = -1). */
  ej_real bx[SPH_BLK], by[SPH_BLK], bz[SPH_BLK], bh[SPH_BLK], bV[SPH_BLK];
  ej_idx jstack[SPH_BLK];
  for (ej_idx i = rg.begin; i < rg.end; ++i) {
    ej_idx *restrict ks = kept && off[i + 1] - off[i] <= SPH_KEPT_ROW ? kept + (size_t)SPH_KEPT_MAX * i : NULL;
    int32_t nkept = ks ? 0 : -1;
    ej_real b0 = 0, b1 = 0, b2 = 0, b3 = 0, b4 = 0, b5 = 0; /* xx yy zz xy yz zx */
    const ej_real inv_hi = 1.0 / h[i], hi = h[i];
    const ej_real xi0 = x[3 * i], xi1 = dim > 1 ? x[3 * i + 1] : 0.0, xi2 = dim > 2 ? x[3 * i + 2] : 0.0;
    ej_off kc = off[i];
    for (;;) {
      ej_idx *restrict jb = nkept == 0 ? ks : jstack; /* the first block: into the slot */
      const int nk = sph_pairs_gather(dim, x, h, idx, &kc, off[i + 1], xi0, xi1, xi2, hi, bx, by, bz, bh, jb);
      if (nk == 0) break;
      nkept = nkept == 0 ? nk : -1;
      /* vol: m/rho from pass 0 (the volume-form continuity weight), the same number without a division */
      int q = 0;
#if defined(__AVX2__)
      if (vol)
        for (; q + 4 <= nk; q += 4) sph_pairs_g4(vol, 1, jb + q, bV + q);
#endif
      for (; q < nk; ++q) {
        const ej_idx j = jb[q];
        bV[q] = vol ? vol[j] : m[j] / rho[j];
      }
      /* Two loops: the weights w_j first (elementwise, into bV), then the six moments. In one loop GCC 12
       * kept two of the six accumulators on the stack (16 live vectors: 6 sums, the row's x_i and h_i,
       * the kernel's constants), and their load-add-store chain bound the loop. Same operations, same
       * order, same reduction: bitwise the one-loop result. */
#if defined(_OPENMP)
#pragma omp simd
#endif
      for (int p = 0; p < nk; ++p) {
        const ej_real rx = xi0 - bx[p];
        const ej_real ry = dim > 1 ? xi1 - by[p] : 0.0;
        const ej_real rz = dim > 2 ? xi2 - bz[p] : 0.0;
        const ej_real r2 = rx * rx + ry * ry + rz * rz;
        const ej_real hbar = 0.5 * (hi + bh[p]);
        const ej_real inv_h = 1.0 / hbar;
        bV[p] = bV[p] * sigma * sph_inv_pow(inv_h, dim) * sph_kernel_f(kernel, dim, sqrt(r2) * inv_h);
      }
#if defined(_OPENMP)
#pragma omp simd reduction(+ : b0, b1, b2, b3, b4, b5)
#endif
      for (int p = 0; p < nk; ++p) {
        /* x_i - x_j: the products below are those of x_j - x_i (both factors change sign) */
        const ej_real rx = xi0 - bx[p];
        const ej_real ry = dim > 1 ? xi1 - by[p] : 0.0;
        const ej_real rz = dim > 2 ? xi2 - bz[p] : 0.0;
        const ej_real w = bV[p];
        b0 += w * rx * rx;
        b1 += w * ry * ry;
        b2 += w * rz * rz;
        b3 += w * rx * ry;
        b4 += w * ry * rz;
        b5 += w * rz * rx;
      }
    }
    if (kept_n) kept_n[i] = nkept;
    ej_real b[6] = {b0, dim > 1 ? b1 : 0.0, dim > 2 ? b2 : 0.0, dim > 1 ? b3 : 0.0, dim > 2 ? b4 : 0.0,
                    dim > 2 ? b5 : 0.0};
    if (Mc) { /* the coupled sets' share (README "Shape tensor across an interface"), consumed */
      ej_real *restrict mc = Mc + 6 * i;
      b[0] += mc[0];
      if (dim > 1) b[1] += mc[1], b[3] += mc[3];
      if (dim > 2) b[2] += mc[2], b[4] += mc[4], b[5] += mc[5];
      for (int c = 0; c < 6; ++c) mc[c] = 0.0;
    }
    for (int c = 0; c < 6; ++c) b[c] *= inv_hi * inv_hi;
    const ej_real pad = (b[0] + b[1] + b[2]) / dim;
    if (dim < 3) b[2] = pad > 0.0 ? pad : 1.0;
    if (dim < 2) b[1] = b[2];
    ej_real t[6];
    const ej_real rc = sph_s6_inverse(t, b);
    ej_real *Mi = Minv + 6 * i;
    if (rc >= rcond_min && rc > 0.0) {
      const ej_real s2 = inv_hi * inv_hi;
      Mi[0] = t[0] * s2;
      Mi[1] = dim > 1 ? t[1] * s2 : 0.0;
      Mi[2] = dim > 2 ? t[2] * s2 : 0.0;
      Mi[3] = dim > 1 ? t[3] * s2 : 0.0;
      Mi[4] = dim > 2 ? t[4] * s2 : 0.0;
      Mi[5] = dim > 2 ? t[5] * s2 : 0.0;
      fb[i] = 0;
    } else {
      for (int c = 0; c < 6; ++c) Mi[c] = 0.0;
      fb[i] = 1;
    }
  }
}

static ej_err sph_shape_pass(const sph_state *s, ej_set *set, const ej_nbr *nbr, ej_range r)
{
  const ej_real *x = ej_set_field(set, "x"), *m = ej_set_field(set, "m"), *rho = ej_set_field(set, "rho");
  const ej_real *h = ej_set_field(set, "h");
  ej_real *Minv = ej_set_field(set, "M_inv");
  int32_t *fb = ej_set_field_int(set, "grad_fallback");
  ej_real *Mc = ej_set_field(set, "M_cpl");
  EJ_ENSURE(x && m && rho && h && Minv && fb && Mc && nbr, EJ_ERR_INTERNAL,
            "set '%s': sph shape-tensor fields missing", s->set_name);
  const ej_real thr = s->cfg.shape_rcond_min;
  const ej_real *vol = s->cfg.continuity == SPH_CONT_VOLUME ? ej_set_field(set, "w_cont") : NULL;
  const bool slots = s->kept && ej_set_count(set) <= s->kept_cap;
  ej_idx *kept = slots ? s->kept : NULL;
  int32_t *kept_n = slots ? s->kept_n : NULL;
#define SPH_SHAPE_CASE(k, d)                                                                            \
  case (k) * 4 + (d):                                                                                   \
    sph_shape_rows((k), (d), x, m, rho, h, nbr->off, nbr->idx, thr, vol, Mc, Minv, fb, kept, kept_n, r); \
    break
  switch (s->cfg.kernel * 4 + s->dim) {
    SPH_FOR_EACH_KERNEL_DIM(SPH_SHAPE_CASE);
  default: EJ_FAIL(EJ_ERR_INTERNAL, "sph: kernel %d, dimension %d", s->cfg.kernel, s->dim);
  }
#undef SPH_SHAPE_CASE
  return EJ_OK;
}

/* The end of a row of the pair loops (sph_pairs, sph_pairs_row): a, the continuity rate, e_dot,
 * w_visc_dot and mu_max of particle i. The kernel sum sum_j V_j x_ji . grad_i W_ij (-norm) equals
 * dim only for an exact quadrature; at h = 1.3 dx it is off by a few per cent, and that bias goes
 * straight into the density of every compressed or expanded particle (3.5 % behind the Sod shock).
 * Dividing by it (the trace of the Randles & Libersky 1996 normalisation, CMAME 139, 375) makes the
 * divergence of any isotropic linear velocity field exact; mass, momentum and energy conservation
 * are untouched (masses are fixed, the continuity equation is not in them). The factor only removes
 * a quadrature bias of a few per cent. Far from 1, the support is truncated or sparse (free
 * surface, a disordered shock front) and the sum says nothing about the bias: clamp it rather than
 * amplify noise into the density. */
static inline ej_real sph_ren_clamp(ej_real fac) { return fac < 0.5 ? 0.5 : fac > 2.0 ? 2.0 : fac; }

static inline SPH_ALWAYS_INLINE void sph_row_store(const sph_pair_args *A, ej_idx i, const int dim, const bool ren,
                                                  const bool volume_form, ej_real rhoi, ej_real ax, ej_real ay,
                                                  ej_real az, ej_real drho, ej_real norm, ej_real de, ej_real dw,
                                                  ej_real mumax)
{
  A->a[3 * i] += ax;
  if (dim > 1) A->a[3 * i + 1] += ay;
  if (dim > 2) A->a[3 * i + 2] += az;
  if (A->unit_w) { /* continuity: number: the unit weights as the particle's own volume m_i/rho_i, so
                     * that norm is about -dim (the clamp's scale) and the sums are in volume units */
    const ej_real u = A->m[i] / rhoi;
    drho *= u, norm *= u;
  }
  if (A->ren_norm) { /* renormalize_interfaces: the factor over every set's neighbours, in finish; the
                      * sums in volume units as the couplings add theirs (the mass form's m_j as m_j/rho_i) */
    A->ren_div[i] = volume_form ? drho : drho / rhoi, A->ren_norm[i] = volume_form ? norm : norm / rhoi;
  } else {
    if (ren && norm < 0.0) drho *= sph_ren_clamp(-(ej_real)dim / (volume_form ? norm : norm / rhoi));
    if (A->cont_rate) A->rho_dot[i] += volume_form ? rhoi * drho : drho;
  }
  A->e_dot[i] += 0.5 * de;
  A->w_dot[i] += 0.5 * dw;
  A->mu_max[i] = mumax;
}

/* The pair loop. kernel and dim are compile-time constants at every call site (the function
 * is always inlined into a switch), so the kernel branch and the dimension masks fold away.
 *
 * With r_ij = x_i - x_j, grad_i W_ij = W'(r, hbar) r_ij / r, hbar = (h_i + h_j)/2: symmetric
 * under i <-> j except for the sign, so every pair force is equal and opposite (Monaghan 1992,
 * section 3) and momentum is conserved to round-off; the energy equation is the matching
 * one, so sum_i m_i (v_i.a_i + de_i/dt) = 0 exactly for the semi-discrete system.
 *   drho_i/dt = sum_j m_j (v_i - v_j).grad_i W_ij                                  (000 Eq 22)
 *     or (continuity: volume) rho_i sum_j (m_j/rho_j) (v_i - v_j).grad_i W_ij: the same continuum
 *     equation (d ln rho/dt = -div v) with a rate proportional to rho_i, so that rho never
 *     reaches 0 in an expansion into vacuum. With Eq 22 a particle of the Sedov core reaches
 *     the density floor, where p/rho^2 collapses the time step (125k-particle octant,
 *     t = 0.044 s); Eq 22 is less dissipative where it survives (kinetic energy fraction
 *     0.155 against 0.105 at t = 0.05 s, exact 0.219). Momentum and energy equations do not
 *     involve it, so conservation is the same either way.
 *   dv_i/dt  = -sum_j m_j (p_i/rho_i^2 + p_j/rho_j^2 + Pi_ij) grad_i W_ij             (000 Eq 23)
 *   de_i/dt  = 1/2 sum_j m_j (p_i/rho_i^2 + p_j/rho_j^2 + Pi_ij) (v_i - v_j).grad_i W_ij
 *                                                         (000 Eq 24, sign erratum: v_i - v_j)
 *   dw_i/dt  = 1/2 sum_j m_j Pi_ij (v_i - v_j).grad_i W_ij   (the viscous part of Eq 24)
 *   Pi_ij = (-alpha cbar mu + beta mu^2) / rhobar if v_ij.x_ij < 0, else 0           (Eq 26)
 *   mu_ij = hbar v_ij.x_ij / (|x_ij|^2 + eta^2 hbar^2)                               (Eq 27)
 * v_ij.x_ij = (v_i - v_j).(x_i - x_j), so the digest's x_ij = x_j - x_i convention and ours
 * give the same mu. */
static inline SPH_ALWAYS_INLINE void sph_pairs(const int kernel, const int dim, const bool corr, const int shape,
                                                const sph_pair_args *A, ej_range rg)
{
  const ej_real *restrict x = A->x, *restrict v = A->v, *restrict m = A->m, *restrict rho = A->rho;
  const ej_real *restrict p_rho2 = A->p_rho2, *restrict c = A->c, *restrict h = A->h;
  const ej_real *restrict w_cont = A->w_cont, *restrict L = A->L, *restrict M = A->M;
  const int32_t *restrict fb = A->fb;
  const bool volume_form = A->volume_form, renormalize = A->renormalize && !corr;
  const ej_off *restrict off = A->off;
  const ej_idx *restrict idx = A->idx;
  const ej_real alpha = A->alpha, beta = A->beta, eta2 = A->eta2;
  const ej_real sigma = sph_kernel_sigma(kernel, dim);

  for (ej_idx i = rg.begin; i < rg.end; ++i) {
    const ej_real xi0 = x[3 * i], xi1 = dim > 1 ? x[3 * i + 1] : 0.0, xi2 = dim > 2 ? x[3 * i + 2] : 0.0;
    const ej_real vi0 = v[3 * i], vi1 = dim > 1 ? v[3 * i + 1] : 0.0, vi2 = dim > 2 ? v[3 * i + 2] : 0.0;
    const ej_real rhoi = rho[i], hi = h[i], ci = c[i];
    const ej_real pri = p_rho2[i];
    const ej_real *li = corr ? L + 6 * i : NULL;
    /* shape tensor: a row whose M_i was ill-conditioned uses the kernel gradient (and, as in
     * the kernel form, the renormalised divergence) */
    const bool fbi = shape && fb[i];
    const ej_real *mi = shape ? M + 6 * i : NULL;
    const bool ren = shape ? renormalize && fbi : renormalize;
    ej_real ax = 0.0, ay = 0.0, az = 0.0, drho = 0.0, norm = 0.0, de = 0.0, dw = 0.0, mumax = 0.0;
    for (ej_off k = off[i]; k < off[i + 1]; ++k) {
      const ej_idx j = idx[k];
      const ej_real rx = xi0 - x[3 * j];
      const ej_real ry = dim > 1 ? xi1 - x[3 * j + 1] : 0.0;
      const ej_real rz = dim > 2 ? xi2 - x[3 * j + 2] : 0.0;
      const ej_real r2 = rx * rx + ry * ry + rz * rz;
      const ej_real hbar = 0.5 * (hi + h[j]);
      /* The list carries a Verlet skin: pairs beyond 2 hbar contribute nothing. */
      if (r2 >= 4.0 * hbar * hbar) continue;
      /* A coincident pair has f'(0) = 0 for both kernels: clamping r keeps 0 * finite.
       * (Ternaries, not fmin/fmax: those are libm calls unless -ffinite-math-only.) */
      const ej_real r_raw = sqrt(r2), r_min = 1e-12 * hbar;
      const ej_real r = r_raw > r_min ? r_raw : r_min;
      const ej_real rhoj = rho[j];
      const ej_real d1 = r2 + eta2 * hbar * hbar, rho_sum = rhoi + rhoj;
      /* Four independent divisions: measured faster than one shared division, whose
       * multiply chain lengthens the critical path of the pair. */
      const ej_real inv_h = 1.0 / hbar, inv_r = 1.0 / r;
      const ej_real inv_d1 = 1.0 / d1, inv_rho_sum = 1.0 / rho_sum;
      /* grad_i W_ij = gw * r_ij, gw = sigma_d / hbar^(d+1) f'(q) / r. */
      const ej_real gw = sigma * sph_inv_pow(inv_h, dim + 1) * sph_kernel_df(kernel, dim, r * inv_h) * inv_r;
      const ej_real vx = vi0 - v[3 * j];
      const ej_real vy = dim > 1 ? vi1 - v[3 * j + 1] : 0.0;
      const ej_real vz = dim > 2 ? vi2 - v[3 * j + 2] : 0.0;
      const ej_real vr = vx * rx + vy * ry + vz * rz; /* = v_ij . x_ij */
      /* Receding pairs (v_ij.x_ij >= 0) get mu = 0, hence Pi = 0: a select, not a branch,
       * because approach and recession alternate unpredictably along a row. */
      const ej_real mu = hbar * (vr < 0.0 ? vr : 0.0) * inv_d1;
      const ej_real pi_ij = (-alpha * 0.5 * (ci + c[j]) * mu + beta * mu * mu) * 2.0 * inv_rho_sum;
      mumax = -mu > mumax ? -mu : mumax;
      const ej_real mj = m[j];
      const ej_real fP = mj * (pri + p_rho2[j] + pi_ij);
      /* G_ij: grad_i W_ij, or with the correction (L_i + L_j)/2 grad_i W_ij, antisymmetric
       * under i <-> j either way, so pair forces stay equal and opposite. The continuity
       * equation (row i only) uses L_i grad_i W_ij. */
      ej_real gx = gw * rx, gy = gw * ry, gz = gw * rz, vC;
      if (corr) {
        const ej_real *Lj = L + 6 * j;
        const ej_real s0 = 0.5 * (li[0] + Lj[0]), s1 = 0.5 * (li[1] + Lj[1]), s2 = 0.5 * (li[2] + Lj[2]);
        const ej_real s3 = 0.5 * (li[3] + Lj[3]), s4 = 0.5 * (li[4] + Lj[4]), s5 = 0.5 * (li[5] + Lj[5]);
        const ej_real ux = gw * rx, uy = gw * ry, uz = gw * rz;
        gx = s0 * ux + s3 * uy + s5 * uz;
        gy = dim > 1 ? s3 * ux + s1 * uy + s4 * uz : 0.0;
        gz = dim > 2 ? s5 * ux + s4 * uy + s2 * uz : 0.0;
        vC = vx * (li[0] * ux + li[3] * uy + li[5] * uz);
        if (dim > 1) vC += vy * (li[3] * ux + li[1] * uy + li[4] * uz);
        if (dim > 2) vC += vz * (li[5] * ux + li[4] * uy + li[2] * uz);
      } else if (shape) {
        /* Consistent SPH, digest 000 Eqs 34-37: grad_i W_ij -> g_i = w_ij M_i^-1 x_ij with
         * x_ij = x_j - x_i = -r (pointing from i to j, like grad_i W_ij). shape == 1: the paper's
         * G_ij = g_i in all equations; shape == 2: G_ij = (g_i + g_j)/2 in momentum and energy
         * (antisymmetric: equal and opposite pair forces), g_i in the continuity equation. */
        const ej_real wv = sigma * sph_inv_pow(inv_h, dim) * sph_kernel_f(kernel, dim, r * inv_h);
        const ej_real ux = -wv * rx, uy = -wv * ry, uz = -wv * rz;
        ej_real ix, iy, iz;
        if (fbi) {
          ix = gw * rx, iy = gw * ry, iz = gw * rz;
        } else {
          ix = mi[0] * ux + mi[3] * uy + mi[5] * uz;
          iy = dim > 1 ? mi[3] * ux + mi[1] * uy + mi[4] * uz : 0.0;
          iz = dim > 2 ? mi[5] * ux + mi[4] * uy + mi[2] * uz : 0.0;
        }
        /* a fallback row keeps the kernel form's rounding (bitwise the kernel result) */
        vC = fbi ? vr * gw : vx * ix + vy * iy + vz * iz;
        if (shape == 2) {
          ej_real jx, jy, jz;
          if (fb[j]) {
            jx = gw * rx, jy = gw * ry, jz = gw * rz;
          } else {
            const ej_real *mj_ = M + 6 * j;
            jx = mj_[0] * ux + mj_[3] * uy + mj_[5] * uz;
            jy = dim > 1 ? mj_[3] * ux + mj_[1] * uy + mj_[4] * uz : 0.0;
            jz = dim > 2 ? mj_[5] * ux + mj_[4] * uy + mj_[2] * uz : 0.0;
          }
          gx = 0.5 * (ix + jx), gy = 0.5 * (iy + jy), gz = 0.5 * (iz + jz);
        } else {
          gx = ix, gy = iy, gz = iz;
        }
      } else {
        vC = vr * gw;
      }
      const bool plain = !corr && (!shape || (fbi && (shape == 1 || fb[j])));
      const ej_real vG = plain ? vr * gw : vx * gx + vy * gy + vz * gz; /* (v_i - v_j) . G_ij */
      ax -= fP * gx;
      if (dim > 1) ay -= fP * gy;
      if (dim > 2) az -= fP * gz;
      drho += w_cont[j] * vC;
      if (!corr) norm += w_cont[j] * r2 * gw; /* = -sum_j w_j x_ji . grad_i W_ij */
      de += fP * vG;
      dw += mj * pi_ij * vG;
    }
    sph_row_store(A, i, dim, ren, volume_form, rhoi, ax, ay, az, drho, norm, de, dw, mumax);
  }
}

/* The pair loop of the kernel gradient (no correction) and of the shape tensor, in blocks of up
 * to SPH_BLK entries of a row: (1) gather the neighbours' data into contiguous buffers (a scalar
 * loop), (2) evaluate every pair term and sum it in one vectorised loop (omp simd reduction):
 * pairs beyond 2 hbar (the Verlet skin) contribute a selected 0, so there is no branch and no
 * store of per-pair terms. The reduction order is fixed for a given build and independent of
 * the thread count (each row is summed by one thread), so results are bitwise identical for any
 * --threads; they differ from sph_pairs (the scalar reference loop, used with `correction`) by
 * round-off only. The four reciprocals of a pair (1/hbar, 1/r, 1/d1, 1/(rho_i + rho_j)) come
 * from one division, 1/(r hbar d1 rho_sum), times the other three factors: divisions are the
 * slowest vector operations (profile in README). With r >= 1e-12 hbar, d1 >= eta^2 hbar^2 and
 * rho_sum >= 2 rho_min the product neither overflows nor underflows for any physical scale. */
/* the gathered neighbour data of sph_pairs_row (buf[k], k one of these) */
enum { BX, BY, BZ, BH, BVX, BVY, BVZ, BRHO, BC, BPR, BM, BGW, BID1, BIRS, BWJ, BWS, NBUF };

static inline SPH_ALWAYS_INLINE void sph_pairs_row(const int kernel, const int dim, const int shape, const bool fb0,
                                                    const sph_pair_args *A, const ej_idx i,
                                                    ej_real (*restrict buf)[SPH_BLK], ej_real (*restrict bM)[SPH_BLK],
                                                    ej_idx *restrict jb)
{
  /* fb0 (shape == 3 only): row i is known not to have fallen back (fb[i] = 0), a compile-time constant in
   * this instantiation, so the fallback selects of row i fold away (the same expressions otherwise) */
  const ej_real *restrict x = A->x, *restrict v = A->v, *restrict m = A->m, *restrict rho = A->rho;
  const ej_real *restrict p_rho2 = A->p_rho2, *restrict c = A->c, *restrict h = A->h;
  const ej_real *restrict M = A->M;
  const int32_t *restrict fb = A->fb;
  /* shape == 3: the symmetric form (2) with the default options (continuity: volume, shape_viscosity:
   * kernel, shape_energy: own, shape_continuity: symmetric) as compile-time constants, so that the
   * vectorised loop carries neither the unused branch nor its selects (the same expressions) */
  const bool sym = shape >= 2;
  const bool volume_form = shape == 3 || A->volume_form, renormalize = A->renormalize;
  const bool unit_w = shape == 0 && A->unit_w; /* continuity: number (kernel gradient only) */
  const ej_real w_one = unit_w ? 1.0 : 0.0, w_mul = unit_w ? 0.0 : 1.0;
  const ej_off *restrict off = A->off;
  const ej_idx *restrict idx = A->idx;
  const ej_real alpha = A->alpha, beta = A->beta, eta2 = A->eta2;
  const ej_real sigma = sph_kernel_sigma(kernel, dim);
  /* shape == 2 (and 3) only (README "Stabilised symmetric form"): the Monaghan viscosity with the kernel
   * gradient (radial, so v_ij.grad_i W_ij >= 0 wherever Pi_ij > 0: non-negative heating; Monaghan,
   * ARA&A 30 (1992) 543), and the pdV work of particle i's own pressure,
   *   de_i/dt = sum_j m_j (p_i/rho_i^2) v_ij.G_ij + 1/2 sum_j m_j Pi_ij v_ij.grad_i W_ij
   * (the "p_i" energy equation, Monaghan 1992; Price, JCP 231 (2012) 759), instead of 000 Eq 36's
   * 1/2 (p_i/rho_i^2 + p_j/rho_j^2). Energy stays exactly conserved: v_ij.G_ij is symmetric in i, j
   * (both factors antisymmetric), so sum_ij m_i m_j (p_i/rho_i^2) v_ij.G_ij equals the symmetrised
   * sum, which is -sum_i m_i v_i.a_i of the pressure force. */
  const bool visc_kernel = shape == 3 || (shape == 2 && A->visc_kernel);
  const bool energy_own = shape == 3 || (shape == 2 && A->energy_own);
  const bool cont_sym = shape == 3 || (shape == 2 && A->cont_sym);
  /* shape_continuity: symmetric with continuity: volume (README "Compatible continuity"): the volume form
   * drho_i/dt = rho_i sum_j V_j v_ij.G_ij pairs with dv_i/dt = -sum_j m_j (p_i + p_j)/(rho_i rho_j) G_ij and
   * de_i/dt = (p_i/rho_i) sum_j V_j v_ij.G_ij (Monaghan 1992 Eq 3.3's (p_i + p_j)/(rho_i rho_j) form), so that
   * de_i/dt = p_i/rho_i^2 drho_i/dt pair by pair; momentum and energy stay exactly conserved (the coefficient
   * V_i V_j (p_i + p_j) is symmetric, G_ij antisymmetric). */
  const bool vol_pair = cont_sym && volume_form && (visc_kernel || energy_own);
  /* the buffers of sph_pairs_blocked: bM (shape >= 2: the neighbours' M_j^-1, all 0 for a fallback row),
   * buf (the other gathered neighbour data) and jb */
  ej_real *restrict bx = buf[BX], *restrict by = buf[BY], *restrict bz = buf[BZ], *restrict bh = buf[BH];
  ej_real *restrict bvx = buf[BVX], *restrict bvy = buf[BVY], *restrict bvz = buf[BVZ];
  ej_real *restrict brho = buf[BRHO], *restrict bc = buf[BC], *restrict bpr = buf[BPR], *restrict bm = buf[BM];
  ej_real *restrict bgw = buf[BGW], *restrict bid1 = buf[BID1], *restrict birs = buf[BIRS], *restrict bwj = buf[BWJ];
  ej_real *restrict bws = buf[BWS];

  const ej_real xi0 = x[3 * i], xi1 = dim > 1 ? x[3 * i + 1] : 0.0, xi2 = dim > 2 ? x[3 * i + 2] : 0.0;
  const ej_real vi0 = v[3 * i], vi1 = dim > 1 ? v[3 * i + 1] : 0.0, vi2 = dim > 2 ? v[3 * i + 2] : 0.0;
  const ej_real rhoi = rho[i], hi = h[i], ci = c[i];
  const ej_real pri = p_rho2[i];
  const ej_real p_over_rho_i = vol_pair ? pri * rhoi : 0.0, inv_rhoi = vol_pair ? 1.0 / rhoi : 0.0;
  /* shape tensor (as in sph_pairs): row i's M_i^-1 and fallback flag */
  const int fbi = shape ? (fb0 ? 0 : fb[i]) : 0;
  const ej_real cfi = fbi ? 1.0 : 0.0; /* shape == 3: c_i of the combined product below */
  const ej_real mi0 = shape ? M[6 * i] : 0.0, mi1 = shape ? M[6 * i + 1] : 0.0, mi2 = shape ? M[6 * i + 2] : 0.0;
  const ej_real mi3 = shape ? M[6 * i + 3] : 0.0, mi4 = shape ? M[6 * i + 4] : 0.0, mi5 = shape ? M[6 * i + 5] : 0.0;
  const bool ren = shape ? renormalize && fbi : renormalize;
  ej_real ax = 0.0, ay = 0.0, az = 0.0, drho = 0.0, norm = 0.0, de = 0.0, dw = 0.0, mumax = 0.0;
  /* shape tensor: the entries inside 2 hbar that the shape pass kept (one block), when the row fits */
  const int32_t nkept = shape && A->kept ? A->kept_n[i] : -1;
  const ej_idx *restrict ks = nkept >= 0 ? A->kept + (size_t)SPH_KEPT_MAX * i : NULL;
  ej_off kc = off[i];
  for (;;) {
    int nk = 0, q0 = 0, qs = 0; /* x and h gathered below q0, the rest below qs */
    const ej_idx *restrict jq = jb;
    if (ks) { /* the shape pass's compaction, in list order: no test, one block */
      if (kc == off[i + 1] || nkept == 0) break;
      kc = off[i + 1], nk = nkept, jq = ks;
    } else {
      /* kernel gradient (and shape rows that did not fit the slots): only the entries inside 2 hbar
       * (~62 of ~80 on the throughput scene) reach the buffers: the same test r2 < 4 hbar^2, with the
       * same operations, as `keep` below (README "Throughput") */
      nk = sph_pairs_gather(dim, x, h, idx, &kc, off[i + 1], xi0, xi1, xi2, hi, bx, by, bz, bh, jb);
      if (nk == 0) break;
      q0 = nk;
    }
#if defined(__AVX2__)
    /* 3D: the rest four entries at a time (scalar loads into one vector, one store; data movement only) */
    if (dim == 3) {
      for (; q0 + 4 <= nk; q0 += 4) {
        const ej_idx *restrict j4 = jq + q0;
        __m256d c0, c1;
        sph_pairs_xy4(x, j4, &c0, &c1);
        _mm256_storeu_pd(bx + q0, c0), _mm256_storeu_pd(by + q0, c1), sph_pairs_g4(x + 2, 3, j4, bz + q0);
        sph_pairs_g4(h, 1, j4, bh + q0);
      }
      int q = 0;
      for (; q + 4 <= nk; q += 4) {
        const ej_idx *restrict j4 = jq + q;
        __m256d c0, c1;
        sph_pairs_xy4(v, j4, &c0, &c1);
        _mm256_storeu_pd(bvx + q, c0), _mm256_storeu_pd(bvy + q, c1), sph_pairs_g4(v + 2, 3, j4, bvz + q);
        sph_pairs_g4(rho, 1, j4, brho + q), sph_pairs_g4(c, 1, j4, bc + q);
        sph_pairs_g4(p_rho2, 1, j4, bpr + q), sph_pairs_g4(m, 1, j4, bm + q);
        if (sym)
          sph_gather_t6(M, j4, bM[0] + q, SPH_BLK);
      }
      for (; q < nk; ++q) {
        const ej_idx j = jq[q];
        if (q >= q0) bx[q] = x[3 * j], by[q] = x[3 * j + 1], bz[q] = x[3 * j + 2], bh[q] = h[j];
        bvx[q] = v[3 * j], bvy[q] = v[3 * j + 1], bvz[q] = v[3 * j + 2];
        brho[q] = rho[j], bc[q] = c[j], bpr[q] = p_rho2[j], bm[q] = m[j];
        if (sym)
          for (int t = 0; t < 6; ++t) bM[t][q] = M[6 * j + t];
      }
      qs = nk;
    }
#endif
    for (int q = qs; q < nk; ++q) {
      const ej_idx j = jq[q];
      if (q >= q0) {
        bx[q] = x[3 * j];
        by[q] = dim > 1 ? x[3 * j + 1] : 0.0;
        bz[q] = dim > 2 ? x[3 * j + 2] : 0.0;
        bh[q] = h[j];
      }
      bvx[q] = v[3 * j];
      bvy[q] = dim > 1 ? v[3 * j + 1] : 0.0;
      bvz[q] = dim > 2 ? v[3 * j + 2] : 0.0;
      brho[q] = rho[j], bc[q] = c[j], bpr[q] = p_rho2[j], bm[q] = m[j];
      if (sym) /* M_inv = 0 marks a fallback row (a regular M^-1 has M^-1_xx > 0) */
        for (int t = 0; t < 6; ++t) bM[t][q] = M[6 * j + t];
#if defined(__GNUC__)
      /* keeps this loop scalar: vectorised, its indexed loads become element inserts (slower) */
      __asm__ volatile("");
#endif
    }
    /* Two loops (as the shape pass's): the pair's geometric factors first (elementwise, into buffers:
     * grad W, 1/d1, 1/(rho_i + rho_j), the continuity weight, the kernel value of the shape forms), then
     * the sums. In one loop GCC 12 spilled accumulators (8 sums, ~20 row constants), and their
     * load-add-store chains bound it. The same operations in the same order: bitwise the one-loop sums. */
#if defined(_OPENMP)
#pragma omp simd
#endif
    for (int q = 0; q < nk; ++q) {
      const ej_real rx = xi0 - bx[q];
      const ej_real ry = dim > 1 ? xi1 - by[q] : 0.0;
      const ej_real rz = dim > 2 ? xi2 - bz[q] : 0.0;
      const ej_real r2 = rx * rx + ry * ry + rz * rz;
      const ej_real hbar = 0.5 * (hi + bh[q]);
      /* A coincident pair has f'(0) = 0 for both kernels: clamping r keeps 0 * finite. */
      const ej_real r_raw = sqrt(r2), r_min = 1e-12 * hbar;
      const ej_real r = r_raw > r_min ? r_raw : r_min;
      const ej_real rhoj = brho[q], d1 = r2 + eta2 * hbar * hbar, rho_sum = rhoi + rhoj;
      /* one division for the five reciprocals (1/rho_j: the continuity weight m_j/rho_j of the
       * volume form, one copied array less than gathering w_cont) */
      const ej_real P = r * hbar, Q = d1 * rho_sum, PQ = P * Q, D = 1.0 / (PQ * rhoj), Dj = D * rhoj;
      const ej_real PD = P * Dj, QD = Q * Dj;
      const ej_real inv_h = r * QD, inv_r = hbar * QD, inv_d1 = rho_sum * PD, inv_rho_sum = d1 * PD;
      /* continuity: number weighs every neighbour 1: w_one = 1, w_mul = 0 (exact, wv finite); else
       * w_one = 0, w_mul = 1 (wv itself, bitwise). Arithmetic rather than a second select: a nested
       * select here kept the loop from vectorising (the kernel pair pass ran 2.4x slower). */
      const ej_real wv = volume_form ? bm[q] * (PQ * D) : bm[q];
      const ej_real wj = wv * w_mul + w_one;
      const ej_real gw = sigma * sph_inv_pow(inv_h, dim + 1) * sph_kernel_df(kernel, dim, r * inv_h) * inv_r;
      bgw[q] = gw, bid1[q] = inv_d1, birs[q] = inv_rho_sum, bwj[q] = wj;
      if (shape) bws[q] = sigma * sph_inv_pow(inv_h, dim) * sph_kernel_f(kernel, dim, r * inv_h);
    }
#if defined(_OPENMP)
#pragma omp simd reduction(+ : ax, ay, az, drho, norm, de, dw) reduction(max : mumax)
#endif
    for (int q = 0; q < nk; ++q) {
      const ej_real rx = xi0 - bx[q];
      const ej_real ry = dim > 1 ? xi1 - by[q] : 0.0;
      const ej_real rz = dim > 2 ? xi2 - bz[q] : 0.0;
      const ej_real r2 = rx * rx + ry * ry + rz * rz;
      const ej_real hbar = 0.5 * (hi + bh[q]);
      /* every gathered entry passed r2 < 4 hbar^2 with these operations (sph_pairs_gather, or the
       * shape pass's kept-neighbour slots: the same r2 and hbar), so the skin selects below fold away */
      const bool keep = true;
      const ej_real rhoj = brho[q];
      const ej_real inv_d1 = bid1[q], inv_rho_sum = birs[q], wj = bwj[q];
      const ej_real gw = bgw[q];
      const ej_real vx = vi0 - bvx[q];
      const ej_real vy = dim > 1 ? vi1 - bvy[q] : 0.0;
      const ej_real vz = dim > 2 ? vi2 - bvz[q] : 0.0;
      const ej_real vr = vx * rx + vy * ry + vz * rz;
      const ej_real mu = hbar * (vr < 0.0 ? vr : 0.0) * inv_d1;
      const ej_real pi_ij = (-alpha * 0.5 * (ci + bc[q]) * mu + beta * mu * mu) * 2.0 * inv_rho_sum;
      const ej_real mj = bm[q];
      const ej_real fP = mj * (pri + bpr[q] + pi_ij);
      ej_real gx = gw * rx, gy = gw * ry, gz = gw * rz;
      ej_real vC = vr * gw, vG = vC;
      const ej_real kx = gx, ky = gy, kz = gz, vK = vC; /* grad_i W_ij and v_ij . grad_i W_ij */
      if (shape == 3) {
        /* G_ij = (g_i + g_j)/2, g_i = M_i^-1 u (u = -w_ij x_ij: the u of the branch below), a fallback
         * row's g being grad_i W_ij. M^-1 = 0 marks a fallback row, so with c = 1 for a fallback row
         * (else 0) g_i + g_j = (M_i^-1 + M_j^-1) u + (c_i + c_j) grad_i W_ij: one 3 x 3 product per pair
         * instead of two, and no select on the row's flag (README "Throughput note (shape pair loop,
         * explosive bench)"). The same G_ij up to round-off; a pair of two fallback rows gets
         * exactly grad_i W_ij (0.5 (1 + 1) gw, the product term is 0), as in the branch below. */
        const ej_real wv = bws[q];
        const bool fj = !(bM[0][q] > 0.0); /* fallback row j: M_j^-1 = 0 */
        const ej_real s0 = mi0 + bM[0][q], s1 = mi1 + bM[1][q], s2 = mi2 + bM[2][q];
        const ej_real s3 = mi3 + bM[3][q], s4 = mi4 + bM[4][q], s5 = mi5 + bM[5][q];
        const ej_real yx = s0 * rx + s3 * ry + s5 * rz;
        const ej_real yy = dim > 1 ? s3 * rx + s1 * ry + s4 * rz : 0.0;
        const ej_real yz = dim > 2 ? s5 * rx + s4 * ry + s2 * rz : 0.0;
        const ej_real cu = -0.5 * wv, ck = 0.5 * (cfi + (fj ? 1.0 : 0.0)) * gw;
        gx = cu * yx + ck * rx;
        gy = dim > 1 ? cu * yy + ck * ry : 0.0;
        gz = dim > 2 ? cu * yz + ck * rz : 0.0;
        vG = (fbi && fj) ? vr * gw : vx * gx + vy * gy + vz * gz;
        vC = fbi ? vr * gw : vG; /* shape_continuity: symmetric (a fallback row: the kernel divergence) */
      } else if (shape) { /* the expressions of sph_pairs, with selects for the fallbacks */
        const ej_real wv = bws[q];
        const ej_real ux = -wv * rx, uy = -wv * ry, uz = -wv * rz;
        const ej_real sx = mi0 * ux + mi3 * uy + mi5 * uz;
        const ej_real sy = dim > 1 ? mi3 * ux + mi1 * uy + mi4 * uz : 0.0;
        const ej_real sz = dim > 2 ? mi5 * ux + mi4 * uy + mi2 * uz : 0.0;
        const ej_real ix = fbi ? gx : sx, iy = fbi ? gy : sy, iz = fbi ? gz : sz;
        vC = fbi ? vr * gw : vx * ix + vy * iy + vz * iz;
        if (sym) {
          const ej_real tx = bM[0][q] * ux + bM[3][q] * uy + bM[5][q] * uz;
          const ej_real ty = dim > 1 ? bM[3][q] * ux + bM[1][q] * uy + bM[4][q] * uz : 0.0;
          const ej_real tz = dim > 2 ? bM[5][q] * ux + bM[4][q] * uy + bM[2][q] * uz : 0.0;
          const bool fj = !(bM[0][q] > 0.0); /* fallback row j: M_j^-1 = 0 */
          const ej_real jx = fj ? gx : tx, jy = fj ? gy : ty, jz = fj ? gz : tz;
          gx = 0.5 * (ix + jx), gy = 0.5 * (iy + jy), gz = 0.5 * (iz + jz);
          vG = (fbi && fj) ? vr * gw : vx * gx + vy * gy + vz * gz;
          /* shape_continuity: symmetric: the continuity equation with G_ij too (a fallback row keeps
           * the renormalised kernel divergence) */
          if (cont_sym && !fbi) vC = vG;
        } else {
          gx = ix, gy = iy, gz = iz;
          vG = fbi ? vr * gw : vx * gx + vy * gy + vz * gz;
        }
      }
      /* pairs beyond 2 hbar (the skin) add exact zeros */
      const ej_real wk = keep ? wj : 0.0;
      mumax = keep && -mu > mumax ? -mu : mumax;
      drho += wk * vC;
      norm += wk * r2 * gw;
      if (visc_kernel || energy_own) {
        /* pressure with G_ij; viscosity with G_ij or grad_i W_ij (radial: v_ij.grad_i W_ij >= 0 wherever
         * Pi_ij > 0, so the viscous heating is >= 0); energy 1/2 (p_i + p_j) or p_i (x2, halved below) */
        /* vol_pair: m_j (p_i + p_j)/(rho_i rho_j) = V_j (p_i/rho_i + p_j/rho_i), V_j = m_j/rho_j = wj */
        const ej_real fp = keep ? (vol_pair ? wj * (p_over_rho_i + bpr[q] * rhoj * rhoj * inv_rhoi) : mj * (pri + bpr[q]))
                                : 0.0;
        const ej_real fv = keep ? mj * pi_ij : 0.0;
        const ej_real vx_ = visc_kernel ? kx : gx, vy_ = visc_kernel ? ky : gy, vz_ = visc_kernel ? kz : gz;
        const ej_real vV = visc_kernel ? vK : vG;
        /* a pair where both rows fell back is a plain kernel-gradient pair: exactly the kernel
         * form (000 Eqs 23-24), bitwise; the classification is symmetric in i, j, so energy is
         * conserved pair by pair either way */
        const bool plain = fbi && !(bM[0][q] > 0.0);
        const ej_real fPk = keep ? fP : 0.0;
        const ej_real tx = fp * gx + fv * vx_, ty = fp * gy + fv * vy_, tz = fp * gz + fv * vz_;
        ax -= plain ? fPk * gx : tx;
        if (dim > 1) ay -= plain ? fPk * gy : ty;
        if (dim > 2) az -= plain ? fPk * gz : tz;
        const ej_real te = (energy_own ? (keep ? 2.0 * (vol_pair ? wj * p_over_rho_i : mj * pri) : 0.0) : fp) * vG + fv * vV;
        de += plain ? fPk * vG : te;
        dw += plain ? fv * vG : fv * vV;
      } else {
        const ej_real fPk = keep ? fP : 0.0;
        ax -= fPk * gx;
        if (dim > 1) ay -= fPk * gy;
        if (dim > 2) az -= fPk * gz;
        de += fPk * vG;
        dw += keep ? mj * pi_ij * vG : 0.0;
      }
    }
  }
  sph_row_store(A, i, dim, ren, volume_form, rhoi, ax, ay, az, drho, norm, de, dw, mumax);
}

static inline SPH_ALWAYS_INLINE void sph_pairs_blocked(const int kernel, const int dim, const int shape,
                                                        const sph_pair_args *A, ej_range rg)
{
  /* shape == 3: rows that did not fall back (nearly all) run their own instantiation (sph_pairs_row's fb0).
   * A local copy of the arguments: the stores into a[], e_dot[]... cannot alias it, so the pointers and
   * constants stay in registers across rows. */
  const sph_pair_args L = *A;
  /* gathered neighbour data (16 KiB of stack, 6 KiB more for bM with the shape forms); one array so that
   * every buffer is a constant offset from one base register (no spilled pointers); declared here, once
   * per range, not per row */
  ej_real buf[NBUF][SPH_BLK];
  ej_real bM[shape >= 2 ? 6 : 1][SPH_BLK]; /* shape >= 2: the neighbours' M_j^-1 */
  ej_idx jb[SPH_BLK];                      /* neighbours of the block (the compaction gather's) */
  for (ej_idx i = rg.begin; i < rg.end; ++i) {
    if (shape == 3 && !L.fb[i]) sph_pairs_row(kernel, dim, 3, true, &L, i, buf, bM, jb);
    else sph_pairs_row(kernel, dim, shape, false, &L, i, buf, bM, jb);
  }
}

/* Summation density (density: summation; Monaghan, ARA&A 30 (1992) 543, Eq 2.7):
 * rho_i = m_i W(0, h_i) + sum_j m_j W(|x_ij|, hbar_ij), with h of the previous step (the h field:
 * h follows rho, so the pair evaluates the kernel with the h that found its neighbours). The core
 * integrates rho with the trapezoid rho = rho_half + dt/2 rho_dot after the passes; setting
 * rho_dot = 2 (rho_sum - rho_half)/dt makes that land on rho_sum, so the density of the step is
 * the summed one wherever the core looks (frames, checkpoints, the next step's pass 0). */
static inline SPH_ALWAYS_INLINE void sph_sum_rows(const int kernel, const int dim, const ej_real *restrict x,
                                                   const ej_real *restrict m, const ej_real *restrict h,
                                                   const ej_off *restrict off, const ej_idx *restrict idx,
                                                   const ej_real *restrict rho_half, ej_real dt,
                                                   ej_real *restrict rho, ej_real *restrict rho_dot, ej_range rg)
{
  const ej_real sigma = sph_kernel_sigma(kernel, dim);
  for (ej_idx i = rg.begin; i < rg.end; ++i) {
    ej_real sum = m[i] * sigma * sph_inv_pow(1.0 / h[i], dim) * sph_kernel_f(kernel, dim, 0.0);
    for (ej_off k = off[i]; k < off[i + 1]; ++k) {
      const ej_idx j = idx[k];
      const ej_real rx = x[3 * i] - x[3 * j];
      const ej_real ry = dim > 1 ? x[3 * i + 1] - x[3 * j + 1] : 0.0;
      const ej_real rz = dim > 2 ? x[3 * i + 2] - x[3 * j + 2] : 0.0;
      const ej_real r2 = rx * rx + ry * ry + rz * rz;
      const ej_real hbar = 0.5 * (h[i] + h[j]);
      if (r2 >= 4.0 * hbar * hbar) continue;
      const ej_real inv_h = 1.0 / hbar;
      sum += m[j] * sigma * sph_inv_pow(inv_h, dim) * sph_kernel_f(kernel, dim, sqrt(r2) * inv_h);
    }
    rho_dot[i] = dt > 0.0 ? 2.0 * (sum - rho_half[i]) / dt : 0.0;
    rho[i] = sum;
  }
}

static ej_err sph_sum_pass(const sph_state *s, ej_set *set, const ej_nbr *nbr, ej_range r)
{
  const ej_real *x = ej_set_field(set, "x"), *m = ej_set_field(set, "m"), *h = ej_set_field(set, "h");
  const ej_real *rho_half = ej_set_field(set, "rho_half");
  ej_real *rho = ej_set_field(set, "rho"), *rho_dot = ej_set_field(set, "rho_dot");
  EJ_ENSURE(x && m && h && rho_half && rho && rho_dot && nbr, EJ_ERR_INTERNAL,
            "set '%s': sph summation-density fields missing", s->set_name);
  const ej_real dt = ej_set_dt(set);
#define SPH_SUM_CASE(k, d)                                                                              \
  case (k) * 4 + (d):                                                                                   \
    sph_sum_rows((k), (d), x, m, h, nbr->off, nbr->idx, rho_half, dt, rho, rho_dot, r);                \
    break
  switch (s->cfg.kernel * 4 + s->dim) {
    SPH_FOR_EACH_KERNEL_DIM(SPH_SUM_CASE);
  default: EJ_FAIL(EJ_ERR_INTERNAL, "sph: kernel %d, dimension %d", s->cfg.kernel, s->dim);
  }
#undef SPH_SUM_CASE
  return EJ_OK;
}

static ej_err sph_pair_pass(const sph_state *s, ej_set *set, const ej_nbr *nbr, ej_range r)
{
  EJ_ENSURE(nbr && nbr->n_rows >= r.end, EJ_ERR_INTERNAL, "set '%s': sph neighbour list has %d rows, range ends at %d",
            s->set_name, nbr ? (int)nbr->n_rows : -1, (int)r.end);
  sph_pair_args A = {
      .x = ej_set_field(set, "x"), .v = ej_set_field(set, "v"),
      .m = ej_set_field(set, s->cfg.geometry == SPH_GEOM_SPHERICAL ? "m_line" : "m"), /* line mass: pass 0 */
      .rho = ej_set_field(set, "rho"), .p_rho2 = ej_set_field(set, "p_rho2"), .c = ej_set_field(set, "c"),
      .h = ej_set_field(set, "h"), .w_cont = ej_set_field(set, "w_cont"), .L = ej_set_field(set, "L_corr"),
      .M = ej_set_field(set, "M_inv"), .fb = ej_set_field_int(set, "grad_fallback"),
      .volume_form = s->cfg.continuity != SPH_CONT_MASS, .unit_w = s->cfg.continuity == SPH_CONT_NUMBER,
      .renormalize = s->cfg.renormalize,
      .cont_rate = s->cfg.density == SPH_DENS_CONTINUITY, .a = ej_set_field(set, "a"), .rho_dot = ej_set_field(set, "rho_dot"),
      .e_dot = ej_set_field(set, "e_dot"), .w_dot = ej_set_field(set, "w_visc_dot"),
      .mu_max = ej_set_field(set, "mu_max"), .off = nbr->off, .idx = nbr->idx,
      .alpha = s->cfg.alpha, .beta = s->cfg.beta, .eta2 = s->cfg.eta * s->cfg.eta,
      .visc_kernel = s->cfg.shape_viscosity == SPH_SHAPE_VISC_KERNEL,
      .energy_own = s->cfg.shape_energy == SPH_SHAPE_ENERGY_OWN,
      .cont_sym = s->cfg.shape_continuity == SPH_SHAPE_CONT_SYMMETRIC,
      .kept = s->kept && ej_set_count(set) <= s->kept_cap ? s->kept : NULL, .kept_n = s->kept_n,
      .ren_div = ej_set_field(set, "ren_div"), .ren_norm = ej_set_field(set, "ren_norm")};
  EJ_ENSURE(A.x && A.v && A.m && A.rho && A.p_rho2 && A.c && A.h && A.w_cont && A.a && A.rho_dot && A.e_dot && A.w_dot &&
                A.mu_max,
            EJ_ERR_INTERNAL, "set '%s': sph fields missing", s->set_name);
  const int shape = s->cfg.gradient != SPH_GRAD_SHAPE ? 0 : s->cfg.shape_form == SPH_SHAPE_PAPER ? 1 : 2;
  EJ_ENSURE(!shape || (A.M && A.fb), EJ_ERR_INTERNAL, "set '%s': sph shape-tensor fields missing", s->set_name);
  /* the symmetric form with the default options: its own instantiation (sph_pairs_blocked, shape 3) */
  const bool shape_defaults = A.volume_form && A.visc_kernel && A.energy_own && A.cont_sym;
  /* One instantiation per (kernel, dim, gradient): no per-pair dispatch. */
#define SPH_CASE(k, d)                                                                                  \
  case (k) * 4 + (d):                                                                                   \
    if (shape == 1) sph_pairs_blocked((k), (d), 1, &A, r);                                              \
    else if (shape == 2 && shape_defaults) sph_pairs_blocked((k), (d), 3, &A, r);                       \
    else if (shape == 2) sph_pairs_blocked((k), (d), 2, &A, r);                                         \
    else if (s->cfg.correction) sph_pairs((k), (d), true, 0, &A, r);                                    \
    else sph_pairs_blocked((k), (d), 0, &A, r);                                                         \
    break
  switch (s->cfg.kernel * 4 + s->dim) {
    SPH_FOR_EACH_KERNEL_DIM(SPH_CASE);
  default: EJ_FAIL(EJ_ERR_INTERNAL, "sph: kernel %d, dimension %d", s->cfg.kernel, s->dim);
  }
#undef SPH_CASE
  return EJ_OK;
}

/* ------------------------------------------------------------------ solids (strength: true) */

/* Solid mechanics (issue 6): the Libersky-Petschek form of SPH for elastic-plastic solids,
 * L. D. Libersky, A. G. Petschek, T. C. Carney, J. R. Hipp, F. A. Allahdadi, J. Comput. Phys.
 * 109 (1993) 67, with the stress of the material plugin (digest 001 §1.4-1.6 and errata):
 *   L_i = sum_j V_j (v_j - v_i) (x) g_i,   g_i = grad_i W_ij or L_corr,i grad_i W_ij (001 Eq 1.6)
 *   d_i = sym L_i, w_i = skew L_i; stress of t_n rotated by Hughes-Winget Q sigma Q^T (or the
 *   explicit Jaumann spin sigma + dt (w sigma - sigma w)), then the material's update with d_i
 *   drho_i/dt = -rho_i tr L_i                                   (volume form of 001 Eq 3)
 *   dv_i/dt = sum_j m_j (sigma_i/rho_i^2 + sigma_j/rho_j^2 + f_ij^n (R_i + R_j) - Pi_ij I) G_ij
 *             (the Libersky-Petschek form; 001 Eq 1b prints (sigma_i + sigma_j)/(rho_i rho_j), equally
 *             conservative and nearly equal within one material, offered across sets by continuum's
 *             form: volume; with the sign erratum of 001 §1.4: -Pi_ij, since sigma is tension-positive)
 *   de_i/dt = -sum_j m_j (sigma_i/rho_i^2 + f_ij^n R_i - Pi_ij/2 I) : (v_ij (x) G_ij)
 *             (001 Eq 1c with errata §1.5: AV heating included, deviatoric work sigma:d/rho
 *             without the 1/2; the pairwise split makes m.v.a + m de/dt sum to zero exactly)
 *   G_ij = grad_i W_ij, or (L_i + L_j)/2 grad_i W_ij with correction (antisymmetric in ij).
 * Artificial stress (Gray, Monaghan & Swift, CMAME 190 (2001) 6641, Eqs 4.8-4.11, Monaghan,
 * JCP 159 (2000) 290): in the principal frame R'_aa = -eps sigma'_aa / rho^2 where
 * sigma'_aa > 0, else 0, rotated back; f_ij = W(r_ij, hbar) / W(dx, hbar) with dx = hbar / h_factor
 * (the current local spacing (m/rho)^(1/d) with variable_h, clipped by h_min/h_max; the initial one with
 * constant h). The Monaghan viscosity Pi_ij is the one of the gas path (000 Eq 26). */

typedef struct sph_solid_args {
  const ej_real *x, *v, *m, *rho, *c, *h, *L, *sr2, *R, *fsw;
  ej_real *a, *e_dot, *w_dot, *mu_max, *vx;
  const ej_off *off;
  const ej_idx *idx;
  ej_real alpha, beta, eta2, art_n, inv_hf, xsph;
  int kernel, dim;
  bool corr, art;
} sph_solid_args;

/* Kernel shape f(q) and derivative f'(q) of sph_kernel_f and sph_kernel_df (0 beyond the support)
 * for the vectorised solid loops: both pieces are computed and blended with 0/1 weights. GCC 12
 * (-ftrapping-math) sinks a product that only one side of a select needs into a branch, and then
 * neither if-converts nor vectorises the loop; a blend has no select to sink into. Every piece is
 * finite for finite q, so x * 1 + y * 0 = x: the same values as the select forms. */
static inline SPH_ALWAYS_INLINE ej_real sph_solid_kf(const int kernel, const int dim, const ej_real q)
{
  const ej_real in2 = q < 2.0 ? 1.0 : 0.0;
  if (kernel == SPH_KERNEL_CUBIC_SPLINE) {
    const ej_real t = 2.0 - q, w1 = q < 1.0 ? 1.0 : 0.0;
    const ej_real inner = 1.0 - 1.5 * q * q + 0.75 * q * q * q, outer = 0.25 * (t * t * t);
    return w1 * inner + (in2 - w1) * outer;
  }
  const ej_real t = 1.0 - 0.5 * q, t2 = t * t;
  const ej_real fw = dim == 1 ? t2 * t * (1.5 * q + 1.0) : t2 * t2 * (2.0 * q + 1.0);
  return in2 * fw;
}

static inline SPH_ALWAYS_INLINE ej_real sph_solid_kdf(const int kernel, const int dim, const ej_real q)
{
  const ej_real in2 = q < 2.0 ? 1.0 : 0.0;
  if (kernel == SPH_KERNEL_CUBIC_SPLINE) {
    const ej_real t = 2.0 - q, w1 = q < 1.0 ? 1.0 : 0.0;
    const ej_real inner = q * (-3.0 + 2.25 * q), outer = -0.75 * (t * t);
    return w1 * inner + (in2 - w1) * outer;
  }
  const ej_real t = 1.0 - 0.5 * q;
  const ej_real dw = dim == 1 ? -3.0 * q * (t * t) : -5.0 * q * (t * t * t);
  return in2 * dw;
}

/* Neighbour entries per block of the solid loops (the force loop gathers up to 32 values per
 * entry: 96 entries keep the buffers at 24 KiB, in L1). */
#define SPH_SOLID_BLK 96

#if defined(__AVX2__)
#include <immintrin.h>
/* Compress-store tables of sph_solid_gather's AVX2 path: for a 4-bit mask of kept lanes, the
 * 32-bit lane indices that move the kept 64-bit lanes (perm64) or 32-bit lanes (perm32) to the
 * front, in order (_mm256_permutevar8x32). */
static const int32_t sph_solid_perm64[16][8] __attribute__((aligned(32))) = {
    {0, 0, 0, 0, 0, 0, 0, 0}, {0, 1, 0, 0, 0, 0, 0, 0}, {2, 3, 0, 0, 0, 0, 0, 0}, {0, 1, 2, 3, 0, 0, 0, 0},
    {4, 5, 0, 0, 0, 0, 0, 0}, {0, 1, 4, 5, 0, 0, 0, 0}, {2, 3, 4, 5, 0, 0, 0, 0}, {0, 1, 2, 3, 4, 5, 0, 0},
    {6, 7, 0, 0, 0, 0, 0, 0}, {0, 1, 6, 7, 0, 0, 0, 0}, {2, 3, 6, 7, 0, 0, 0, 0}, {0, 1, 2, 3, 6, 7, 0, 0},
    {4, 5, 6, 7, 0, 0, 0, 0}, {0, 1, 4, 5, 6, 7, 0, 0}, {2, 3, 4, 5, 6, 7, 0, 0}, {0, 1, 2, 3, 4, 5, 6, 7}};
static const int32_t sph_solid_perm32[16][8] __attribute__((aligned(32))) = {
    {0, 0, 0, 0, 0, 0, 0, 0}, {0, 0, 0, 0, 0, 0, 0, 0}, {1, 0, 0, 0, 0, 0, 0, 0}, {0, 1, 0, 0, 0, 0, 0, 0},
    {2, 0, 0, 0, 0, 0, 0, 0}, {0, 2, 0, 0, 0, 0, 0, 0}, {1, 2, 0, 0, 0, 0, 0, 0}, {0, 1, 2, 0, 0, 0, 0, 0},
    {3, 0, 0, 0, 0, 0, 0, 0}, {0, 3, 0, 0, 0, 0, 0, 0}, {1, 3, 0, 0, 0, 0, 0, 0}, {0, 1, 3, 0, 0, 0, 0, 0},
    {2, 3, 0, 0, 0, 0, 0, 0}, {0, 2, 3, 0, 0, 0, 0, 0}, {1, 2, 3, 0, 0, 0, 0, 0}, {0, 1, 2, 3, 0, 0, 0, 0}};
#endif

/* Compaction gather of the pair loops (the gas loop sph_pairs_blocked with blk = SPH_BLK, the
 * shape pass, the two solid loops with SPH_SOLID_BLK): from list entry *k on, up to blk entries
 * inside 2 hbar (and, with drop_self, not coincident) go to the buffers bx, by, bz, bh, jb; the
 * slot of a skin entry is overwritten by the next one (branch-free). The test is the one of the
 * gas pair loop's `keep`, same operations in the same order (no contraction under -std=c11), so
 * every gathered entry has keep = true there and none it keeps is dropped. Callers pass xi1 = 0
 * (xi2 = 0) below 2D (3D), as the entries' unused components are read as 0. Returns the count
 * and advances *k past the entries read. blk and drop_self are constants at every call (inlined). */
static inline SPH_ALWAYS_INLINE int sph_gather_compact(const int dim, const int blk, const bool drop_self,
                                                       const ej_real *restrict x,
                                                     const ej_real *restrict h, const ej_idx *restrict idx,
                                                     ej_off *k, const ej_off kend, const ej_real xi0,
                                                     const ej_real xi1, const ej_real xi2, const ej_real hi,
                                                     ej_real *restrict bx, ej_real *restrict by, ej_real *restrict bz,
                                                     ej_real *restrict bh, ej_idx *restrict jb)
{
  int nk = 0;
  ej_off kk = *k;
#if defined(__AVX2__)
  /* 3D with AVX2: four entries at a time (gathers, one compare, compress-store through the
   * permutation tables). The same operations in the same order as the scalar loop below (no FMA:
   * -std=c11 keeps contraction off), so the same entries in the same slots and the same block
   * boundaries: bitwise the same results. The scalar loop finishes the block (nk > BLK - 4) and
   * the row (fewer than 4 entries left). */
  if (dim == 3) {
    const __m256d vx0 = _mm256_set1_pd(xi0), vx1 = _mm256_set1_pd(xi1), vx2 = _mm256_set1_pd(xi2);
    const __m256d vhi = _mm256_set1_pd(hi), half = _mm256_set1_pd(0.5), four = _mm256_set1_pd(4.0);
    for (; kk + 4 <= kend && nk <= blk - 4; kk += 4) {
      const __m128i j4 = _mm_loadu_si128((const __m128i *)(const void *)(idx + kk));
      /* scalar loads, not vgatherqpd (microcoded and slower on AMD Zen 3) */
      const ej_idx ja = idx[kk], jbb = idx[kk + 1], jc = idx[kk + 2], jd = idx[kk + 3];
      const ej_real *xa = x + 3 * (size_t)ja, *xb = x + 3 * (size_t)jbb, *xc = x + 3 * (size_t)jc,
                    *xd = x + 3 * (size_t)jd;
      __m256d X, Y; /* x and y: two 128-bit loads per pair of entries, interleaved (sph_pairs_xy4) */
      sph_pairs_xy4(x, idx + kk, &X, &Y);
      const __m256d Z = _mm256_set_pd(xd[2], xc[2], xb[2], xa[2]), H = _mm256_set_pd(h[jd], h[jc], h[jbb], h[ja]);
      const __m256d hb = _mm256_mul_pd(half, _mm256_add_pd(vhi, H));
      const __m256d d0 = _mm256_sub_pd(vx0, X), d1 = _mm256_sub_pd(vx1, Y), d2 = _mm256_sub_pd(vx2, Z);
      const __m256d r2 = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(d0, d0), _mm256_mul_pd(d1, d1)),
                                       _mm256_mul_pd(d2, d2));
      __m256d in = _mm256_cmp_pd(r2, _mm256_mul_pd(_mm256_mul_pd(four, hb), hb), _CMP_LT_OQ);
      if (drop_self) in = _mm256_and_pd(in, _mm256_cmp_pd(r2, _mm256_setzero_pd(), _CMP_GT_OQ));
      const int msk = _mm256_movemask_pd(in);
      const __m256i p = _mm256_load_si256((const __m256i *)(const void *)sph_solid_perm64[msk]);
      _mm256_storeu_pd(bx + nk, _mm256_castps_pd(_mm256_permutevar8x32_ps(_mm256_castpd_ps(X), p)));
      _mm256_storeu_pd(by + nk, _mm256_castps_pd(_mm256_permutevar8x32_ps(_mm256_castpd_ps(Y), p)));
      _mm256_storeu_pd(bz + nk, _mm256_castps_pd(_mm256_permutevar8x32_ps(_mm256_castpd_ps(Z), p)));
      _mm256_storeu_pd(bh + nk, _mm256_castps_pd(_mm256_permutevar8x32_ps(_mm256_castpd_ps(H), p)));
      const __m256i pj = _mm256_load_si256((const __m256i *)(const void *)sph_solid_perm32[msk]);
      _mm_storeu_si128((__m128i *)(void *)(jb + nk),
                       _mm256_castsi256_si128(_mm256_permutevar8x32_epi32(_mm256_castsi128_si256(j4), pj)));
      nk += __builtin_popcount((unsigned)msk);
    }
  }
#endif
  for (; kk < kend && nk < blk; ++kk) {
    const ej_idx j = idx[kk];
    const ej_real xj0 = x[3 * j], xj1 = dim > 1 ? x[3 * j + 1] : 0.0, xj2 = dim > 2 ? x[3 * j + 2] : 0.0;
    const ej_real hj = h[j], hb = 0.5 * (hi + hj);
    const ej_real d0 = xi0 - xj0, d1 = xi1 - xj1, d2 = xi2 - xj2, r2 = d0 * d0 + d1 * d1 + d2 * d2;
    bx[nk] = xj0, by[nk] = xj1, bz[nk] = xj2, bh[nk] = hj, jb[nk] = j;
    nk += r2 < 4.0 * hb * hb && (!drop_self || r2 > 0.0);
  }
  *k = kk;
  return nk;
}


/* The gas pair loop's and the shape pass's gather (blocks of SPH_BLK, coincident entries kept). */
static inline SPH_ALWAYS_INLINE int sph_pairs_gather(const int dim, const ej_real *restrict x,
                                                     const ej_real *restrict h, const ej_idx *restrict idx,
                                                     ej_off *k, const ej_off kend, const ej_real xi0,
                                                     const ej_real xi1, const ej_real xi2, const ej_real hi,
                                                     ej_real *restrict bx, ej_real *restrict by, ej_real *restrict bz,
                                                     ej_real *restrict bh, ej_idx *restrict jb)
{
  return sph_gather_compact(dim, SPH_BLK, false, x, h, idx, k, kend, xi0, xi1, xi2, hi, bx, by, bz, bh, jb);
}

/* The solid pair loops' gather (blocks of SPH_SOLID_BLK). */
static inline SPH_ALWAYS_INLINE int sph_solid_gather(const int dim, const bool drop_self, const ej_real *restrict x,
                                                     const ej_real *restrict h, const ej_idx *restrict idx,
                                                     ej_off *k, const ej_off kend, const ej_real xi0,
                                                     const ej_real xi1, const ej_real xi2, const ej_real hi,
                                                     ej_real *restrict bx, ej_real *restrict by, ej_real *restrict bz,
                                                     ej_real *restrict bh, ej_idx *restrict jb)
{
  return sph_gather_compact(dim, SPH_SOLID_BLK, drop_self, x, h, idx, k, kend, xi0, xi1, xi2, hi, bx, by, bz, bh,
                            jb);
}

#if defined(__AVX2__)
/* Gather of a[stride * j + comp] for the four indices j4[0..3] into dst[0..3]: scalar loads into
 * one vector and one store (instead of four scalar stores). Data movement only. */
static inline SPH_ALWAYS_INLINE void sph_solid_g4(const ej_real *restrict a, const size_t stride,
                                                  const ej_idx *restrict j4, ej_real *restrict dst)
{
  _mm256_storeu_pd(dst, _mm256_set_pd(a[stride * (size_t)j4[3]], a[stride * (size_t)j4[2]],
                                      a[stride * (size_t)j4[1]], a[stride * (size_t)j4[0]]));
}
#endif

/* Velocity gradient of particle i (3x3 row-major, zero outside the dim x dim block), blocked like
 * sph_pairs_blocked: the neighbours' data are gathered into contiguous buffers (a scalar loop),
 * then a vectorised loop sums A_ac = sum_j V_j (v_j - v_i)_a (grad_i W_ij)_c; with correction
 * L_i, which is the same for every pair of the row, is applied once at the end:
 * sum_j V_j dv (x) L_i grad W = A L_i (L_i symmetric). Entries beyond 2 hbar (the skin) and
 * coincident pairs are dropped while gathering (compaction). V_j = m_j/rho_j with 1/hbar, 1/r and 1/rho_j from one
 * division (r >= 1e-12 hbar). */
static inline SPH_ALWAYS_INLINE void sph_solid_velgrad_row(const int kernel, const int dim, const ej_real *restrict x,
                                                           const ej_real *restrict v, const ej_real *restrict m,
                                                           const ej_real *restrict rho, const ej_real *restrict h,
                                                           const ej_real *restrict L, const ej_off *restrict off,
                                                           const ej_idx *restrict idx, const ej_idx i, ej_real Lv[9])
{
  const ej_real sigma = sph_kernel_sigma(kernel, dim);
  enum { BX, BY, BZ, BH, BVX, BVY, BVZ, BM, BRHO, BW, NBUF };
  ej_real buf[NBUF][SPH_SOLID_BLK];
  ej_real *restrict bx = buf[BX], *restrict by = buf[BY], *restrict bz = buf[BZ], *restrict bh = buf[BH];
  ej_real *restrict bvx = buf[BVX], *restrict bvy = buf[BVY], *restrict bvz = buf[BVZ];
  ej_real *restrict bm = buf[BM], *restrict brho = buf[BRHO];
  const ej_real xi0 = x[3 * i], xi1 = dim > 1 ? x[3 * i + 1] : 0.0, xi2 = dim > 2 ? x[3 * i + 2] : 0.0;
  const ej_real vi0 = v[3 * i], vi1 = dim > 1 ? v[3 * i + 1] : 0.0, vi2 = dim > 2 ? v[3 * i + 2] : 0.0;
  const ej_real hi = h[i];
  ej_real s00 = 0, s01 = 0, s02 = 0, s10 = 0, s11 = 0, s12 = 0, s20 = 0, s21 = 0, s22 = 0;
  ej_idx jb[SPH_SOLID_BLK];
  const ej_off kend = off[i + 1];
  for (ej_off k = off[i]; k < kend;) {
    /* compaction: only the entries inside 2 hbar (and not coincident) enter the buffers */
    const int nk = sph_solid_gather(dim, true, x, h, idx, &k, kend, xi0, xi1, xi2, hi, bx, by, bz, bh, jb);
    int q4 = 0; /* entries [0, q4) gathered four at a time (3D, AVX2) */
#if defined(__AVX2__)
    if (dim == 3)
      for (; q4 + 4 <= nk; q4 += 4) {
        __m256d V0, V1; /* v_x, v_y: two 128-bit loads per pair of entries (sph_pairs_xy4) */
        sph_pairs_xy4(v, jb + q4, &V0, &V1);
        _mm256_storeu_pd(bvx + q4, V0), _mm256_storeu_pd(bvy + q4, V1);
        sph_solid_g4(v + 2, 3, jb + q4, bvz + q4);
        sph_solid_g4(m, 1, jb + q4, bm + q4), sph_solid_g4(rho, 1, jb + q4, brho + q4);
      }
#endif
    for (int q = q4; q < nk; ++q) {
      const ej_idx j = jb[q];
      bvx[q] = v[3 * j], bvy[q] = dim > 1 ? v[3 * j + 1] : 0.0, bvz[q] = dim > 2 ? v[3 * j + 2] : 0.0;
      bm[q] = m[j], brho[q] = rho[j];
#if defined(__GNUC__)
      __asm__ volatile(""); /* keeps the gather scalar (as in sph_pairs_blocked) */
#endif
    }
    /* Two loops: the weights V_j grad W first (elementwise, into bw), then the nine sums. In one loop
     * GCC 12 spilled accumulators (9 sums beside the row's x_i, v_i, h_i and the kernel's constants).
     * The same operations in the same order: bitwise the one-loop sums. */
    ej_real *restrict bw = buf[BW];
#if defined(_OPENMP)
#pragma omp simd
#endif
    for (int q = 0; q < nk; ++q) {
      const ej_real rx = xi0 - bx[q], ry = dim > 1 ? xi1 - by[q] : 0.0, rz = dim > 2 ? xi2 - bz[q] : 0.0;
      const ej_real r2 = rx * rx + ry * ry + rz * rz;
      const ej_real hbar = 0.5 * (hi + bh[q]);
      const ej_real r = sqrt(r2); /* > 0: coincident pairs were left out */
      const ej_real rhoj = brho[q], P = r * hbar, D = 1.0 / (P * rhoj), Dr = D * rhoj;
      const ej_real inv_h = r * Dr, inv_r = hbar * Dr, inv_rho = P * D;
      const ej_real gw = sigma * sph_inv_pow(inv_h, dim + 1) * sph_solid_kdf(kernel, dim, r * inv_h) * inv_r;
      bw[q] = bm[q] * inv_rho * gw;
    }
#if defined(_OPENMP)
#pragma omp simd reduction(+ : s00, s01, s02, s10, s11, s12, s20, s21, s22)
#endif
    for (int q = 0; q < nk; ++q) {
      const ej_real rx = xi0 - bx[q], ry = dim > 1 ? xi1 - by[q] : 0.0, rz = dim > 2 ? xi2 - bz[q] : 0.0;
      const ej_real w = bw[q];
      const ej_real dx = w * (bvx[q] - vi0);
      s00 += dx * rx;
      if (dim > 1) s01 += dx * ry;
      if (dim > 2) s02 += dx * rz;
      if (dim > 1) {
        const ej_real dy = w * (bvy[q] - vi1);
        s10 += dy * rx, s11 += dy * ry;
        if (dim > 2) s12 += dy * rz;
      }
      if (dim > 2) {
        const ej_real dz = w * (bvz[q] - vi2);
        s20 += dz * rx, s21 += dz * ry, s22 += dz * rz;
      }
    }
  }
  const ej_real S[9] = {s00, s01, s02, s10, s11, s12, s20, s21, s22};
  if (!L) {
    for (int k = 0; k < 9; ++k) Lv[k] = S[k];
    return;
  }
  ej_real Li[9];
  ej_s6_to_m3(Li, L + 6 * i);
  if (dim < 3) Li[2] = Li[5] = Li[6] = Li[7] = Li[8] = 0.0; /* only the dim x dim block is used */
  if (dim < 2) Li[1] = Li[3] = Li[4] = 0.0;
  ej_m3_mul(Lv, S, Li);
}

/* Dispatch of sph_solid_velgrad_row: one instantiation per (kernel, dim). */
static void sph_solid_velgrad(int kernel, int dim, const ej_real *x, const ej_real *v, const ej_real *m,
                              const ej_real *rho, const ej_real *h, const ej_real *L, const ej_off *off,
                              const ej_idx *idx, ej_idx i, ej_real Lv[9])
{
#define SPH_SOLID_VG_CASE(k, d)                                                                         \
  case (k) * 4 + (d): sph_solid_velgrad_row((k), (d), x, v, m, rho, h, L, off, idx, i, Lv); break
  switch (kernel * 4 + dim) {
    SPH_FOR_EACH_KERNEL_DIM(SPH_SOLID_VG_CASE);
  default:
    for (int k = 0; k < 9; ++k) Lv[k] = NAN; /* unreachable: create checked kernel and dim */
  }
#undef SPH_SOLID_VG_CASE
}

/* Artificial stress tensor R of a Cauchy stress s at density rho (Gray et al. 2001 Eq 4.9-4.11):
 * principal values by ej_s6_eig, R'_a = -eps s'_a / rho^2 for s'_a > 0. */
static void sph_solid_art_stress(int dim, ej_real eps, const ej_real s[6], ej_real rho, ej_real R[6])
{
  ej_real lam[3], V[9], t[6];
  memcpy(t, s, sizeof t);
  if (dim < 3) t[2] = t[4] = t[5] = 0.0; /* the out-of-plane stress does not act on in-plane pairs */
  if (dim < 2) t[1] = t[3] = 0.0;
  /* No principal tension when every Gershgorin disc lies in (-inf, 0] (the usual state of a
   * compressed solid): R = 0 without the Jacobi iteration. */
  if (t[0] + fabs(t[3]) + fabs(t[5]) <= 0.0 && t[1] + fabs(t[3]) + fabs(t[4]) <= 0.0 &&
      t[2] + fabs(t[4]) + fabs(t[5]) <= 0.0) {
    for (int k = 0; k < 6; ++k) R[k] = 0.0;
    return;
  }
  ej_s6_eig(lam, V, t);
  for (int k = 0; k < 3; ++k) lam[k] = lam[k] > 0.0 ? -eps * lam[k] / (rho * rho) : 0.0;
  ej_s6_from_eig(R, lam, V);
}

/* Adds the walls' share of the velocity gradient to Lv (row-major 3 x 3, L[a][q] = d v_a / d x_q)
 * and zeroes it for the next evaluation's sum: Lw = sum_w V_w (v_w - v_i) (x) grad_i W_iw as
 * sph_wall added it (a free-slip wall: its normal part); with the correction, that with the
 * corrected gradient L_corr,i grad_i W_iw, i.e. Lw L_corr,i (L_corr symmetric, Voigt xx yy zz xy yz
 * zx), the correction of the set's own pairs, whose B_i holds the walls' share B_wall. */
static inline void sph_add_wall_gradient(ej_real *restrict Lw, const ej_real *restrict Lc, ej_real *restrict Lv)
{
  /* no wall near (every particle of a set without walls): nothing to add, nothing to zero, no store */
  if (!(Lw[0] != 0.0 || Lw[1] != 0.0 || Lw[2] != 0.0 || Lw[3] != 0.0 || Lw[4] != 0.0 || Lw[5] != 0.0 ||
        Lw[6] != 0.0 || Lw[7] != 0.0 || Lw[8] != 0.0))
    return;
  if (Lc) {
    const ej_real C[9] = {Lc[0], Lc[3], Lc[5], Lc[3], Lc[1], Lc[4], Lc[5], Lc[4], Lc[2]};
    for (int a = 0; a < 3; ++a)
      for (int q = 0; q < 3; ++q) Lv[3 * a + q] += Lw[3 * a] * C[q] + Lw[3 * a + 1] * C[3 + q] + Lw[3 * a + 2] * C[6 + q];
  } else {
    for (int k = 0; k < 9; ++k) Lv[k] += Lw[k];
  }
  for (int k = 0; k < 9; ++k) Lw[k] = 0.0;
}

/* Solid pass 2 (per particle, reads neighbours' x, v, rho, m, h): velocity gradient, density
 * rate, objective rotation, the material's update, sound speed, sigma/rho^2 and R. */
static ej_err sph_solid_stress_pass(const sph_state *s, ej_set *set, const ej_nbr *nbr, ej_range r)
{
  const int dim = s->dim, kernel = s->cfg.kernel;
  const ej_real *x = ej_set_field(set, "x"), *v = ej_set_field(set, "v"), *m = ej_set_field(set, "m");
  const ej_real *h = ej_set_field(set, "h"), *e = ej_set_field(set, "e");
  ej_real *rho = ej_set_field(set, "rho"), *rho_dot = ej_set_field(set, "rho_dot");
  ej_real *p = ej_set_field(set, "p"), *c = ej_set_field(set, "c"), *stress = ej_set_field(set, "stress");
  ej_real *d_rate = ej_set_field(set, "d_rate"), *c_mat = ej_set_field(set, "c_mat");
  ej_real *wp_inc = ej_set_field(set, "wp_inc"), *wp_dot = ej_set_field(set, "w_plastic_dot");
  ej_real *sr2 = ej_set_field(set, "sigma_rho2"), *R = ej_set_field(set, "art_stress");
  const ej_real *L = s->cfg.correction ? ej_set_field(set, "L_corr") : NULL;
  ej_real *L_wall = ej_set_field(set, "L_wall"); /* added by sph_wall's pre-pass (or zero); zeroed here */
  int32_t *failed = ej_set_field_int(set, "failed");
  ej_real *fsw = s->cfg.visc_switch == SPH_VSW_BALSARA ? ej_set_field(set, "visc_switch") : NULL;
  EJ_ENSURE(x && v && m && h && e && rho && rho_dot && p && c && stress && d_rate && c_mat && wp_inc && wp_dot &&
                sr2 && R && failed && nbr && (!s->cfg.correction || L) &&
                (s->cfg.visc_switch != SPH_VSW_BALSARA || fsw),
            EJ_ERR_INTERNAL, "set '%s': sph solid fields missing", s->set_name);
  if (r.end <= r.begin) return EJ_OK;
  const ej_real dt = ej_set_dt(set);
  for (ej_idx i = r.begin; i < r.end; ++i) {
    ej_real Lv[9], W[9];
    sph_solid_velgrad(kernel, dim, x, v, m, rho, h, L, nbr->off, nbr->idx, i, Lv);
    /* the wall's share (sph_wall, Peng et al. 2019 / digest 001 §1.10: the dummy particles enter
     * L_i as SPH neighbours), so one material update sees the whole gradient, spin included */
    if (L_wall) sph_add_wall_gradient(L_wall + 9 * (size_t)i, L ? L + 6 * (size_t)i : NULL, Lv);
    ej_m3_sym(d_rate + 6 * i, Lv);
    rho_dot[i] += -rho[i] * (Lv[0] + Lv[4] + Lv[8]);
    if (fsw) { /* Balsara (JCP 121 (1995) 357) with Springel's 1e-4 c/h floor; c of the last evaluation */
      const ej_real dv = fabs(Lv[0] + Lv[4] + Lv[8]);
      const ej_real w0 = Lv[7] - Lv[5], w1 = Lv[2] - Lv[6], w2 = Lv[3] - Lv[1]; /* curl: L = grad v, row-major */
      const ej_real den = dv + sqrt(w0 * w0 + w1 * w1 + w2 * w2) + 1e-4 * c[i] / h[i];
      fsw[i] = den > 0.0 ? dv / den : 1.0;
    }
    if (dt > 0.0) {
      ej_m3_skew(W, Lv);
      ej_real *sg = stress + 6 * i;
      if (s->cfg.stress_rate == SPH_RATE_HW) {
        ej_real Q[9];
        if (!ej_hughes_winget(Q, W, dt)) return sph_bad_particle(s, set, i, "Hughes-Winget spin |w| dt", ej_m3_norm(W) * dt);
        ej_s6_rotate(sg, Q, sg);
      } else { /* explicit Jaumann spin: sigma + dt (w sigma - sigma w) */
        ej_real S[9], A[9], B[9], T[9];
        ej_s6_to_m3(S, sg);
        ej_m3_mul(A, W, S);
        ej_m3_mul(B, S, W);
        for (int k = 0; k < 9; ++k) T[k] = S[k] + dt * (A[k] - B[k]);
        ej_m3_to_s6(sg, T);
      }
    }
  }
  const ej_idx n = r.end - r.begin;
  if (dt > 0.0) {
    ej_real *hist_base[SPH_MAX_HIST], *hist[SPH_MAX_HIST];
    const int nh = ej_set_hist(set, hist_base, SPH_MAX_HIST);
    for (int k = 0; k < nh; ++k) hist[k] = hist_base[k] + r.begin;
    for (ej_idx i = r.begin; i < r.end; ++i) wp_inc[i] = 0.0;
    ej_mat_batch b = {.n = n, .dt = dt, .rho = rho + r.begin, .e = e + r.begin, .d = d_rate + 6 * (size_t)r.begin,
                      .F = NULL, .p = s->eos ? p + r.begin : NULL, .stress = stress + 6 * (size_t)r.begin,
                      .hist = hist, .c = c_mat + r.begin, .w_plastic = wp_inc + r.begin,
                      .failed = failed + r.begin};
    EJ_TRY(ej_material_update(s->mat, &b));
  } else { /* the initial evaluation: stress of the initial state (the EOS pressure) */
    for (ej_idx i = r.begin; i < r.end; ++i) {
      ej_real *sg = stress + 6 * i;
      if (s->eos) {
        const ej_real mean = ej_s6_trace(sg) / 3.0;
        for (int k = 0; k < 3; ++k) sg[k] += -mean - p[i];
      }
      c_mat[i] = sqrt((s->K + 4.0 * s->G / 3.0) / rho[i]);
      wp_inc[i] = 0.0;
    }
  }
  for (ej_idx i = r.begin; i < r.end; ++i) {
    ej_real *sg = stress + 6 * i;
    if (failed[i]) { /* a failed point keeps no shear and no tension (its pressure only) */
      const ej_real pm = -ej_s6_trace(sg) / 3.0;
      sg[0] = sg[1] = sg[2] = pm > 0.0 ? -pm : 0.0;
      sg[3] = sg[4] = sg[5] = 0.0;
    }
    for (int k = 0; k < 6; ++k)
      if (!isfinite(sg[k])) return sph_bad_particle(s, set, i, "stress component", sg[k]);
    p[i] = -ej_s6_trace(sg) / 3.0;
    /* signal speed: the larger of the EOS and the material sound speeds (001 §1.7 [X]) */
    c[i] = s->eos ? fmax(c[i], c_mat[i]) : c_mat[i];
    if (dt > 0.0) wp_dot[i] += wp_inc[i] / dt;
    const ej_real ir2 = 1.0 / (rho[i] * rho[i]);
    for (int k = 0; k < 6; ++k) sr2[6 * i + k] = sg[k] * ir2;
    if (s->cfg.art_stress) sph_solid_art_stress(dim, s->cfg.art_eps, sg, rho[i], R + 6 * i);
    else for (int k = 0; k < 6; ++k) R[6 * i + k] = 0.0;
  }
  return EJ_OK;
}

/* Solid pass 3 (pairs, gather form): accelerations, energy rate, viscous work, mu_max, XSPH.
 * Blocked like sph_pairs_blocked: per row, up to SPH_SOLID_BLK entries are gathered into
 * contiguous buffers (scalar loop), then one vectorised loop (omp simd reduction) evaluates the
 * pair terms of the equations above; the entries beyond 2 hbar are dropped while gathering (no
 * branch). The summation order is fixed for a row, so the result is the same for any number of
 * threads. The reciprocals 1/hbar, 1/r, 1/(r^2 + eta^2 hbar^2), 1/(rho_i + rho_j) come from one
 * division (r >= 1e-12 hbar, rho >= the floor: no overflow or underflow at physical scales).
 * Per pair, with Ti = sigma_i/rho_i^2 + f^n R_i - Pi/2 I and Tj likewise:
 *   a_i += m_j (Ti + Tj) G_ij,  e_dot_i -= m_j v_ij . (Ti G_ij),  w_dot_i += m_j Pi/2 v_ij . G_ij. */
static inline SPH_ALWAYS_INLINE void sph_solid_force_blocked(const int kernel, const int dim, const bool corr,
                                                             const bool art4, const bool do_xsph,
                                                             const sph_solid_args *A, ej_range rg)
{
  const ej_real *restrict x = A->x, *restrict v = A->v, *restrict m = A->m, *restrict rho = A->rho;
  const ej_real *restrict c = A->c, *restrict h = A->h, *restrict sr2 = A->sr2, *restrict R = A->R;
  const ej_real *restrict L = A->L;
  const ej_off *restrict off = A->off;
  const ej_idx *restrict idx = A->idx;
  const ej_real sigma = sph_kernel_sigma(kernel, dim);
  const ej_real alpha = A->alpha, beta = A->beta, eta2 = A->eta2, xsph = A->xsph;
  /* art4 (art_n = 4, the default) is a constant of the instantiation: in the vectorised loop both
   * sides of a select are evaluated, so a run-time choice would call the vector pow for every pair */
  /* do_xsph (xsph > 0) is a constant of the instantiation too: without XSPH (the default) the
   * pair loop skips the kernel value and the three XSPH sums */
  const bool art = A->art;
  const ej_real art_n = A->art_n;
  /* 1/f(dx/h): the artificial stress weight f_ij = f(q) / f(dx/h) */
  const ej_real inv_fdx = 1.0 / sph_kernel_f(kernel, dim, A->inv_hf);
  /* visc_switch: balsara: Pi_ij gets (f_i + f_j)/2. A run-time choice: without it f_i and the f_j
   * buffer hold 1.0, so the product is exactly Pi_ij (bitwise the results without the switch) for
   * one load and three operations per pair, and no further instantiations of this loop */
  const ej_real *restrict fsw = A->fsw;
  const bool bals = fsw != NULL;
  enum { BX, BY, BZ, BH, BVX, BVY, BVZ, BRHO, BC, BM, BF, BGX, BGY, BGZ, BID1, BIRS, BFN, BWX, BS0,
         BR0 = BS0 + 6, BL0 = BR0 + 6, NBUF = BL0 + 6 };
  ej_real buf[NBUF][SPH_SOLID_BLK]; /* fixed size: a variable-length array defeats the vectoriser */
  ej_real *restrict bx = buf[BX], *restrict by = buf[BY], *restrict bz = buf[BZ], *restrict bh = buf[BH];
  ej_real *restrict bvx = buf[BVX], *restrict bvy = buf[BVY], *restrict bvz = buf[BVZ];
  ej_real *restrict brho = buf[BRHO], *restrict bc = buf[BC], *restrict bm = buf[BM], *restrict bf = buf[BF];
  ej_idx jb[SPH_SOLID_BLK];
  if (!bals)
    for (int q = 0; q < SPH_SOLID_BLK; ++q) bf[q] = 1.0;
  for (ej_idx i = rg.begin; i < rg.end; ++i) {
    const ej_real xi0 = x[3 * i], xi1 = dim > 1 ? x[3 * i + 1] : 0.0, xi2 = dim > 2 ? x[3 * i + 2] : 0.0;
    const ej_real vi0 = v[3 * i], vi1 = dim > 1 ? v[3 * i + 1] : 0.0, vi2 = dim > 2 ? v[3 * i + 2] : 0.0;
    const ej_real hi = h[i], rhoi = rho[i], ci = c[i], fi = bals ? fsw[i] : 1.0;
    const ej_real si0 = sr2[6 * i], si1 = sr2[6 * i + 1], si2 = sr2[6 * i + 2];
    const ej_real si3 = sr2[6 * i + 3], si4 = sr2[6 * i + 4], si5 = sr2[6 * i + 5];
    const ej_real Ri0 = art ? R[6 * i] : 0.0, Ri1 = art ? R[6 * i + 1] : 0.0, Ri2 = art ? R[6 * i + 2] : 0.0;
    const ej_real Ri3 = art ? R[6 * i + 3] : 0.0, Ri4 = art ? R[6 * i + 4] : 0.0, Ri5 = art ? R[6 * i + 5] : 0.0;
    const ej_real Li0 = corr ? L[6 * i] : 0.0, Li1 = corr ? L[6 * i + 1] : 0.0, Li2 = corr ? L[6 * i + 2] : 0.0;
    const ej_real Li3 = corr ? L[6 * i + 3] : 0.0, Li4 = corr ? L[6 * i + 4] : 0.0, Li5 = corr ? L[6 * i + 5] : 0.0;
    ej_real ax = 0.0, ay = 0.0, az = 0.0, de = 0.0, dw = 0.0, mumax = 0.0, xs0 = 0.0, xs1 = 0.0, xs2 = 0.0;
    const ej_off kend = off[i + 1];
    for (ej_off k = off[i]; k < kend;) {
      /* compaction: only the entries inside 2 hbar enter the buffers */
      const int nk = sph_solid_gather(dim, false, x, h, idx, &k, kend, xi0, xi1, xi2, hi, bx, by, bz, bh, jb);
      int q6 = 0; /* the tensor rows of entries [0, q6) are gathered by sph_gather_t6 */
#if defined(__AVX2__)
      for (; q6 + 4 <= nk; q6 += 4) {
        ej_real *const b0 = &buf[0][0] + q6; /* the whole buffer array: rows t = 0..5 of each tensor */
        sph_gather_t6(sr2, jb + q6, b0 + BS0 * SPH_SOLID_BLK, SPH_SOLID_BLK);
        sph_gather_t6(R, jb + q6, b0 + BR0 * SPH_SOLID_BLK, SPH_SOLID_BLK);
        if (corr) sph_gather_t6(L, jb + q6, b0 + BL0 * SPH_SOLID_BLK, SPH_SOLID_BLK);
      }
#endif
      int q4 = 0; /* v, rho, c, m of entries [0, q4) gathered four at a time (3D, AVX2) */
#if defined(__AVX2__)
      if (dim == 3)
        for (; q4 + 4 <= nk; q4 += 4) {
          __m256d V0, V1; /* v_x, v_y: two 128-bit loads per pair of entries (sph_pairs_xy4) */
          sph_pairs_xy4(v, jb + q4, &V0, &V1);
          _mm256_storeu_pd(bvx + q4, V0), _mm256_storeu_pd(bvy + q4, V1);
          sph_solid_g4(v + 2, 3, jb + q4, bvz + q4), sph_solid_g4(rho, 1, jb + q4, brho + q4);
          sph_solid_g4(c, 1, jb + q4, bc + q4), sph_solid_g4(m, 1, jb + q4, bm + q4);
          if (bals) sph_solid_g4(fsw, 1, jb + q4, bf + q4);
        }
#endif
      for (int q = q4; q < nk; ++q) {
        const ej_idx j = jb[q];
        bvx[q] = v[3 * j], bvy[q] = dim > 1 ? v[3 * j + 1] : 0.0, bvz[q] = dim > 2 ? v[3 * j + 2] : 0.0;
        brho[q] = rho[j], bc[q] = c[j], bm[q] = m[j];
        if (bals) bf[q] = fsw[j];
#if defined(__GNUC__)
        __asm__ volatile(""); /* keeps the gather scalar (as in sph_pairs_blocked) */
#endif
      }
      for (int q = q6; q < nk; ++q) {
        const ej_idx j = jb[q];
        for (int t = 0; t < 6; ++t) buf[BS0 + t][q] = sr2[6 * j + t];
        /* R always (zero without art_stress): a load under a condition keeps GCC 12 from
         * if-converting, and so from vectorising, the pair loop */
        for (int t = 0; t < 6; ++t) buf[BR0 + t][q] = R[6 * j + t];
        if (corr)
          for (int t = 0; t < 6; ++t) buf[BL0 + t][q] = L[6 * j + t];
#if defined(__GNUC__)
        __asm__ volatile(""); /* keeps the gather scalar (as in sph_pairs_blocked) */
#endif
      }
      /* Two loops (as the gas pair loop): the pair's geometric factors first (G_ij, 1/d1, 1/(rho_i + rho_j),
       * the artificial-stress weight f^n and the XSPH kernel value, elementwise into buffers), then the
       * sums. In one loop GCC 12 spilled accumulators (up to 9 sums beside ~20 row constants). The same
       * operations in the same order: bitwise the one-loop sums. */
#if defined(_OPENMP)
#pragma omp simd
#endif
      for (int q = 0; q < nk; ++q) {
        const ej_real rx = xi0 - bx[q], ry = dim > 1 ? xi1 - by[q] : 0.0, rz = dim > 2 ? xi2 - bz[q] : 0.0;
        const ej_real r2 = rx * rx + ry * ry + rz * rz;
        const ej_real hbar = 0.5 * (hi + bh[q]);
        const ej_real r_raw = sqrt(r2), r_min = 1e-12 * hbar, r = r_raw > r_min ? r_raw : r_min;
        const ej_real d1 = r2 + eta2 * hbar * hbar, rho_sum = rhoi + brho[q];
        const ej_real P = r * hbar, Q = d1 * rho_sum, D = 1.0 / (P * Q);
        const ej_real QD = Q * D, PD = P * D;
        const ej_real inv_h = r * QD, inv_r = hbar * QD, inv_d1 = rho_sum * PD, inv_rho_sum = d1 * PD;
        const ej_real qq = r * inv_h;
        const ej_real gw = sigma * sph_inv_pow(inv_h, dim + 1) * sph_solid_kdf(kernel, dim, qq) * inv_r;
        ej_real gx = gw * rx, gy = gw * ry, gz = gw * rz;
        if (corr) { /* G_ij = (L_i + L_j)/2 grad_i W_ij */
          const ej_real l0 = 0.5 * (Li0 + buf[BL0][q]), l1 = 0.5 * (Li1 + buf[BL0 + 1][q]);
          const ej_real l2 = 0.5 * (Li2 + buf[BL0 + 2][q]), l3 = 0.5 * (Li3 + buf[BL0 + 3][q]);
          const ej_real l4 = 0.5 * (Li4 + buf[BL0 + 4][q]), l5 = 0.5 * (Li5 + buf[BL0 + 5][q]);
          const ej_real u0 = gx, u1 = gy, u2 = gz;
          gx = l0 * u0 + l3 * u1 + l5 * u2;
          gy = dim > 1 ? l3 * u0 + l1 * u1 + l4 * u2 : 0.0;
          gz = dim > 2 ? l5 * u0 + l4 * u1 + l2 * u2 : 0.0;
        }
        /* no branches in this loop (only selects): GCC 12 leaves it scalar otherwise */
        const ej_real f = sph_solid_kf(kernel, dim, qq), fr = f * inv_fdx;
        buf[BFN][q] = (art ? 1.0 : 0.0) * (art4 ? (fr * fr) * (fr * fr) : pow(fr, art_n));
        buf[BGX][q] = gx, buf[BGY][q] = gy, buf[BGZ][q] = gz, buf[BID1][q] = inv_d1, buf[BIRS][q] = inv_rho_sum;
        if (do_xsph) buf[BWX][q] = sigma * sph_inv_pow(inv_h, dim) * f;
      }
#if defined(_OPENMP)
#pragma omp simd reduction(+ : ax, ay, az, de, dw, xs0, xs1, xs2) reduction(max : mumax)
#endif
      for (int q = 0; q < nk; ++q) {
        const ej_real rx = xi0 - bx[q], ry = dim > 1 ? xi1 - by[q] : 0.0, rz = dim > 2 ? xi2 - bz[q] : 0.0;
        const ej_real hbar = 0.5 * (hi + bh[q]);
        const ej_real gx = buf[BGX][q], gy = buf[BGY][q], gz = buf[BGZ][q];
        const ej_real inv_d1 = buf[BID1][q], inv_rho_sum = buf[BIRS][q];
        const ej_real vx = vi0 - bvx[q], vy = dim > 1 ? vi1 - bvy[q] : 0.0, vz = dim > 2 ? vi2 - bvz[q] : 0.0;
        const ej_real vr = vx * rx + vy * ry + vz * rz;
        const ej_real mu = hbar * (vr < 0.0 ? vr : 0.0) * inv_d1;
        const ej_real pi_ij = (-alpha * 0.5 * (ci + bc[q]) * mu + beta * mu * mu) * 2.0 * inv_rho_sum *
                              (0.5 * (fi + bf[q]));
        mumax = -mu > mumax ? -mu : mumax;
        const ej_real fn = buf[BFN][q];
        const ej_real hp = 0.5 * pi_ij;
        /* Ti = sigma_i/rho_i^2 + f^n R_i - Pi/2 I; T = Ti + Tj */
        const ej_real ti0 = si0 + fn * Ri0 - hp, ti1 = si1 + fn * Ri1 - hp, ti2 = si2 + fn * Ri2 - hp;
        const ej_real ti3 = si3 + fn * Ri3, ti4 = si4 + fn * Ri4, ti5 = si5 + fn * Ri5;
        const ej_real tj0 = buf[BS0][q] + fn * buf[BR0][q] - hp;
        const ej_real tj1 = buf[BS0 + 1][q] + fn * buf[BR0 + 1][q] - hp;
        const ej_real tj2 = buf[BS0 + 2][q] + fn * buf[BR0 + 2][q] - hp;
        const ej_real tj3 = buf[BS0 + 3][q] + fn * buf[BR0 + 3][q];
        const ej_real tj4 = buf[BS0 + 4][q] + fn * buf[BR0 + 4][q];
        const ej_real tj5 = buf[BS0 + 5][q] + fn * buf[BR0 + 5][q];
        /* Ti G and Tj G (symmetric, Voigt xx yy zz xy yz zx) */
        const ej_real ix = ti0 * gx + ti3 * gy + ti5 * gz, iy = ti3 * gx + ti1 * gy + ti4 * gz;
        const ej_real iz = ti5 * gx + ti4 * gy + ti2 * gz;
        const ej_real jx = tj0 * gx + tj3 * gy + tj5 * gz, jy = tj3 * gx + tj1 * gy + tj4 * gz;
        const ej_real jz = tj5 * gx + tj4 * gy + tj2 * gz;
        const ej_real mk = bm[q];
        ax += mk * (ix + jx);
        if (dim > 1) ay += mk * (iy + jy);
        if (dim > 2) az += mk * (iz + jz);
        de -= mk * (vx * ix + vy * iy + vz * iz);
        dw += mk * hp * (vx * gx + vy * gy + vz * gz);
        /* XSPH (Monaghan, JCP 82 (1989) 1, Eq 2.6): (m_j / rhobar) (v_j - v_i) W_ij */
        if (do_xsph) { /* a constant of the instantiation: no branch in the loop */
          const ej_real wx = buf[BWX][q];
          const ej_real fx = -xsph * mk * 2.0 * inv_rho_sum * wx;
          xs0 += fx * vx, xs1 += fx * vy, xs2 += fx * vz;
        }
      }
    }
    if (do_xsph) A->vx[3 * i] = xs0, A->vx[3 * i + 1] = xs1, A->vx[3 * i + 2] = xs2;
    A->a[3 * i] += ax;
    if (dim > 1) A->a[3 * i + 1] += ay;
    if (dim > 2) A->a[3 * i + 2] += az;
    A->e_dot[i] += de;
    A->w_dot[i] += dw;
    A->mu_max[i] = mumax;
  }
}

/* Dispatch: one instantiation per (kernel, dim, correction, art_n = 4 or not, XSPH or not). */
static void sph_solid_force_rows(const sph_solid_args *A, ej_range rg)
{
#define SPH_SOLID_F_XS(k, d, c, a4)                                                                     \
  do {                                                                                                  \
    if (A->xsph > 0.0) sph_solid_force_blocked((k), (d), (c), (a4), true, A, rg);                       \
    else sph_solid_force_blocked((k), (d), (c), (a4), false, A, rg);                                    \
  } while (0)
#define SPH_SOLID_F_CASE(k, d)                                                                          \
  case (k) * 4 + (d):                                                                                   \
    if (A->art_n == 4.0) {                                                                              \
      if (A->corr) SPH_SOLID_F_XS((k), (d), true, true);                                                \
      else SPH_SOLID_F_XS((k), (d), false, true);                                                       \
    } else {                                                                                            \
      if (A->corr) SPH_SOLID_F_XS((k), (d), true, false);                                               \
      else SPH_SOLID_F_XS((k), (d), false, false);                                                      \
    }                                                                                                   \
    break
  switch (A->kernel * 4 + A->dim) {
    SPH_FOR_EACH_KERNEL_DIM(SPH_SOLID_F_CASE);
  default: break; /* unreachable: create checked kernel and dim */
  }
#undef SPH_SOLID_F_CASE
#undef SPH_SOLID_F_XS
}

static ej_err sph_solid_force_pass(const sph_state *s, ej_set *set, const ej_nbr *nbr, ej_range r)
{
  sph_solid_args A = {.x = ej_set_field(set, "x"), .v = ej_set_field(set, "v"), .m = ej_set_field(set, "m"),
                      .rho = ej_set_field(set, "rho"), .c = ej_set_field(set, "c"), .h = ej_set_field(set, "h"),
                      .L = ej_set_field(set, "L_corr"), .sr2 = ej_set_field(set, "sigma_rho2"),
                      .R = ej_set_field(set, "art_stress"), .a = ej_set_field(set, "a"),
                      .e_dot = ej_set_field(set, "e_dot"), .w_dot = ej_set_field(set, "w_visc_dot"),
                      .mu_max = ej_set_field(set, "mu_max"), .off = nbr ? nbr->off : NULL,
                      .idx = nbr ? nbr->idx : NULL, .alpha = s->cfg.alpha, .beta = s->cfg.beta,
                      .eta2 = s->cfg.eta * s->cfg.eta, .art_n = s->cfg.art_n, .inv_hf = 1.0 / s->cfg.h_factor,
                      .kernel = s->cfg.kernel, .dim = s->dim, .corr = s->cfg.correction,
                      .art = s->cfg.art_stress, .vx = ej_set_field(set, "v_xsph"), .xsph = s->cfg.xsph,
                      .fsw = s->cfg.visc_switch == SPH_VSW_BALSARA ? ej_set_field(set, "visc_switch") : NULL};
  EJ_ENSURE(A.x && A.v && A.m && A.rho && A.c && A.h && A.sr2 && A.R && A.a && A.e_dot && A.w_dot && A.mu_max &&
                A.off && (!A.corr || A.L),
            EJ_ERR_INTERNAL, "set '%s': sph solid fields missing", s->set_name);
  EJ_ENSURE(A.vx, EJ_ERR_INTERNAL, "set '%s': sph field v_xsph missing", s->set_name);
  sph_solid_force_rows(&A, r);
  return EJ_OK;
}

/* XSPH (xsph > 0, strength only): the positions move by dt v_xsph after the integrator's step
 * (the neighbour skin check sees the moved x); velocities, momentum and energy are untouched. */
static ej_err sph_post_step(void *state, ej_set *set, ej_range r)
{
  const sph_state *s = state;
  /* Density floor after the integrator's corrector (rho = rho_half + dt/2 rho_dot(t_n+1)): the
   * floor of pass 0 acts on the predictor only, so without this a corrector that overshoots leaves
   * rho < floor (even < 0) in the state that is output and carried to the next step. The floor is
   * positive for rho_min > 0; a NaN is left for pass 0 to report. e, v and the energy budget are
   * untouched (rho does not enter the energy). */
  {
    ej_real *rho = ej_set_field(set, "rho");
    const ej_real *m = ej_set_field(set, "m"), *vol0 = ej_set_field(set, "vol0");
    EJ_ENSURE(rho && m && vol0, EJ_ERR_INTERNAL, "set '%s': sph fields missing", s->set_name);
    for (ej_idx i = r.begin; i < r.end; ++i) {
      const ej_real floor = sph_floor_of(s, m[i], vol0[i]);
      if (rho[i] < floor) rho[i] = floor;
    }
  }
  if (!s->cfg.strength || !(s->cfg.xsph > 0.0)) return EJ_OK;
  ej_real *x = ej_set_field(set, "x");
  const ej_real *vx = ej_set_field(set, "v_xsph");
  EJ_ENSURE(x && vx, EJ_ERR_INTERNAL, "set '%s': sph XSPH fields missing", s->set_name);
  const ej_real dt = ej_set_dt(set);
  for (ej_idx i = r.begin; i < r.end; ++i)
    for (int d = 0; d < s->dim; ++d) x[3 * i + d] += dt * vx[3 * i + d];
  return EJ_OK;
}

static ej_err sph_counters(void *state, ej_counter *out, int max, int *n)
{
  const sph_state *s = state;
  *n = 0;
  if (s->cfg.gradient == SPH_GRAD_SHAPE && max >= 1) {
    out[0] = (ej_counter){.name = "shape tensor fallbacks to the kernel gradient (particle-steps)",
                          .value = s->shape_fallbacks};
    *n = 1;
    return EJ_OK;
  }
  const int32_t *fb = ej_set_field_int(s->set, "corr_fallbacks");
  if (!fb || max < 1) return EJ_OK;
  int64_t total = 0;
  for (ej_idx i = 0; i < ej_set_count(s->set); ++i) total += fb[i];
  out[0] = (ej_counter){.name = "gradient correction fallbacks (particle-steps)", .value = total};
  *n = 1;
  return EJ_OK;
}

/* Per-step series: the number of particles whose shape tensor fell back to the kernel gradient
 * in this step's force evaluation (the core calls report once per step, serially). */
static ej_err sph_report(void *state, const ej_set *set, ej_series_value *out, int max, int *n)
{
  sph_state *s = state;
  *n = 0;
  if (s->cfg.gradient != SPH_GRAD_SHAPE || max < 1) return EJ_OK;
  const int32_t *fb = ej_set_field_int(set, "grad_fallback");
  EJ_ENSURE(fb, EJ_ERR_INTERNAL, "set '%s': sph field grad_fallback missing", s->set_name);
  int64_t count = 0;
  for (ej_idx i = 0; i < ej_set_count(set); ++i) count += fb[i];
  s->shape_fallbacks += count;
  out[0] = (ej_series_value){.name = "gradient_fallbacks", .value = (ej_real)count, .role = EJ_SERIES_PLAIN};
  *n = 1;
  return EJ_OK;
}

/* Artificial conductivity (`conductivity: alpha_u` > 0, gas only; README "Artificial
 * conductivity"): D. J. Price, "Modelling discontinuities and Kelvin-Helmholtz instabilities in
 * SPH", J. Comput. Phys. 227 (2008) 10040, section 4 (the conductivity term of the energy
 * equation and its signal speed for hydrodynamics, v_sig^u = sqrt(|p_i - p_j| / rhobar_ij)):
 *   de_i/dt += sum_j m_j alpha_u v_sig^u (e_i - e_j) / rhobar_ij dW/dr(r_ij, hbar),   dW/dr <= 0,
 * rhobar = (rho_i + rho_j)/2, so heat flows from the hotter to the colder particle and only
 * where the pressure jumps (none at a contact in pressure equilibrium, none in a uniform flow).
 * m_i de_i/dt + m_j de_j/dt = 0 pair by pair (energy conserved to round-off). geometry:
 * spherical: the 1D sums use the line mass mu = m/(4 pi r^2) and the pair term is weighted by
 * rbar^2/r_i^2, rbar = (|r_i| + |r_j|)/2 (the flux through the mid-sphere), so that
 * m_i de_i = 4 pi rbar^2 mu_i mu_j (...) is again antisymmetric. Own loop over the list, run
 * only when alpha_u > 0 (the pair loops and their results are unchanged otherwise). */
static ej_err sph_cond_pass(const sph_state *s, ej_set *set, const ej_nbr *nbr, ej_range r)
{
  const bool sph_sph = s->cfg.geometry == SPH_GEOM_SPHERICAL;
  const ej_real *x = ej_set_field(set, "x"), *m = ej_set_field(set, sph_sph ? "m_line" : "m");
  const ej_real *rho = ej_set_field(set, "rho"), *p = ej_set_field(set, "p"), *e = ej_set_field(set, "e");
  const ej_real *h = ej_set_field(set, "h");
  ej_real *e_dot = ej_set_field(set, "e_dot");
  EJ_ENSURE(x && m && rho && p && e && h && e_dot && nbr, EJ_ERR_INTERNAL, "set '%s': sph conductivity fields missing",
            s->set_name);
  const int kernel = s->cfg.kernel, dim = s->dim;
  const ej_real sigma = sph_kernel_sigma(kernel, dim), au = s->cfg.conductivity;
  for (ej_idx i = r.begin; i < r.end; ++i) {
    const ej_real hi = h[i], rhoi = rho[i], pi = p[i], ei = e[i];
    const ej_real ai = fabs(x[3 * i]), inv_ri2 = sph_sph ? 1.0 / fmax(ai * ai, 1e-300) : 1.0;
    ej_real de = 0.0;
    for (ej_off k = nbr->off[i]; k < nbr->off[i + 1]; ++k) {
      const ej_idx j = nbr->idx[k];
      ej_real r2 = 0.0;
      for (int q = 0; q < dim; ++q) r2 += (x[3 * i + q] - x[3 * j + q]) * (x[3 * i + q] - x[3 * j + q]);
      const ej_real hbar = 0.5 * (hi + h[j]);
      if (r2 >= 4.0 * hbar * hbar || r2 <= 0.0) continue;
      const ej_real inv_h = 1.0 / hbar, rr = sqrt(r2);
      const ej_real dwdr = sigma * sph_inv_pow(inv_h, dim + 1) * sph_kernel_df(kernel, dim, rr * inv_h);
      de += sph_cond_pair(m[j], pi, p[j], rhoi, rho[j], ei, e[j], sph_sph, ai, fabs(x[3 * j]), inv_ri2, dwdr);
    }
    e_dot[i] += au * de;
  }
  return EJ_OK;
}

/* geometry: spherical, after the pair pass of the same range (README "Spherical symmetry").
 * With mu_j = m_j/(4 pi r_j^2) in place of m_j the pair pass gives the 1D (planar) terms:
 *   dv_i/dt = -sum_j mu_j (P_i + P_j + Pi_ij) dW_ij/dr_i,  P = p/rho^2,
 * a consistent -(1/rho) dp/dr (no geometric term in the momentum equation), and
 *   de_i/dt = 1/2 sum_j mu_j (P_i + P_j + Pi_ij) (v_i - v_j) dW_ij/dr_i,  drho_i/dt = -rho_i (dv/dr)_i.
 * The divergence lacks 2v/r. This pass makes them
 *   drho_i/dt = -rho_i ((dv/dr)_i + 2 v_i/r_i)                                   (per particle)
 *   de_i/dt   = P_i sum_j mu_j (v_i - v_j) dW_ij/dr_i - 2 (p_i/rho_i) v_i/r_i     (own pressure)
 *             + 1/2 sum_j mu_j Pi_ij u_ij dW_ij/dr_i,   u_ij = (r_i^2 v_i - r_j^2 v_j) / r_i^2
 * by adding sum_j mu_j dW_ij/dr_i [(P_i - P_j)/2 (v_i - v_j) + Pi_ij/2 (u_ij - (v_i - v_j))]
 * - 2 P_i rho_i v_i / r_i (and the viscous part to w_visc_dot).
 * Energy. With m_i = 4 pi r_i^2 mu_i and any f_ij = f_ji, B_ij = mu_i mu_j f_ij dW_ij/dr_i = -B_ji:
 *   sum_i m_i v_i sum_j mu_j f_ij dW_ij/dr_i = 2 pi sum_ij B_ij (r_i^2 v_i - r_j^2 v_j)
 *                                             = sum_i m_i (1/2) sum_j mu_j f_ij u_ij dW_ij/dr_i,
 * so the viscous pair (f = Pi) conserves sum m (v^2/2 + e) exactly, and so would the pressure
 * with de_i/dt = P_i sum_j mu_j u_ij dW_ij/dr_i (the pair form of -(p/rho)(1/r^2) d(r^2 v)/dr).
 * That exact form is NOT used: its SPH derivative of r^2 v (~ r^3) is wrong by O(h^2/r^2) next to
 * r = 0 (at r = dx/2, h = 2 dx it over-cools the innermost particle, which then implodes onto the
 * axis; measured: the 1D Sedov blast collapses at t = 1e-5 s). The local form above is exact for a
 * homologous flow; its energy error is the difference of the two divergence estimates weighted by
 * m_i P_i, O(h^2) in smooth flow (README: measured balance). The own-pressure form (Monaghan 1992;
 * Price, JCP 231 (2012) 759) rather than the pair pass's (P_i + P_j)/2: with 2v/r, a cold particle
 * pushed by a hot neighbour would be charged half the neighbour's p dV (e < 0: measured collapse of
 * the Sedov blast in 400 steps). Pi_ij is recomputed as in sph_pairs (the blocked loop's
 * one-division reciprocals differ from it by round-off only). Mirror ghosts of x = 0
 * (x_j' = -x_j, v_j' = -v_j) are handled like any neighbour: r^2 v is odd in x like v. */
static ej_err sph_geom_pass(const sph_state *s, ej_set *set, const ej_nbr *nbr, ej_range r)
{
  const ej_real *x = ej_set_field(set, "x"), *v = ej_set_field(set, "v"), *mu = ej_set_field(set, "m_line");
  const ej_real *rho = ej_set_field(set, "rho"), *pr = ej_set_field(set, "p_rho2"), *c = ej_set_field(set, "c");
  const ej_real *h = ej_set_field(set, "h");
  ej_real *rho_dot = ej_set_field(set, "rho_dot"), *e_dot = ej_set_field(set, "e_dot");
  ej_real *w_dot = ej_set_field(set, "w_visc_dot");
  ej_real *pflag = s->cfg.spherical_energy == 1 ? ej_set_field(set, "pdv_pair") : NULL;
  EJ_ENSURE(x && v && mu && rho && pr && c && h && rho_dot && e_dot && w_dot && nbr, EJ_ERR_INTERNAL,
            "set '%s': sph spherical fields missing", s->set_name);
  const int kernel = s->cfg.kernel;
  const ej_real sigma = sph_kernel_sigma(kernel, 1);
  const ej_real alpha = s->cfg.alpha, beta = s->cfg.beta, eta2 = s->cfg.eta * s->cfg.eta;
  for (ej_idx i = r.begin; i < r.end; ++i) {
    const ej_real xi = x[3 * i], vi = v[3 * i], hi = h[i], rhoi = rho[i], ci = c[i], pri = pr[i];
    /* particles sit at x >= dx/2 (mirror ghosts of x = 0); the guard only avoids 0/0 */
    const ej_real ri = fmax(fabs(xi), 1e-9 * hi), inv_ri2 = 1.0 / (ri * ri);
    rho_dot[i] += -2.0 * rhoi * vi / ri;
    /* away from the axis the exact pair form P_i sum_j mu_j u_ij dW_ij/dr_i (energy conserved with
     * the momentum equation; the local form lost 19 % of a TNT charge's energy in the 1D blast,
     * validation/charge_in_air/README.md); near the axis the local form (see above) */
    const ej_real pexact = pflag && ri >= SPH_SPHERICAL_EXACT_R * hi ? 1.0 : 0.0;
    if (pflag) pflag[i] = pexact;
    ej_real de = 0.0, dw = 0.0;
    for (ej_off k = nbr->off[i]; k < nbr->off[i + 1]; ++k) {
      const ej_idx j = nbr->idx[k];
      const ej_real xj = x[3 * j], rx = xi - xj, r2 = rx * rx;
      const ej_real hbar = 0.5 * (hi + h[j]);
      if (r2 >= 4.0 * hbar * hbar) continue;
      const ej_real rr = sqrt(r2) > 1e-12 * hbar ? sqrt(r2) : 1e-12 * hbar, inv_h = 1.0 / hbar;
      const ej_real dW = sigma * inv_h * inv_h * sph_kernel_df(kernel, 1, rr * inv_h) / rr * rx; /* dW_ij/dr_i */
      const ej_real vr = (vi - v[3 * j]) * rx;
      const ej_real muv = hbar * (vr < 0.0 ? vr : 0.0) / (r2 + eta2 * hbar * hbar);
      const ej_real pi_ij = (-alpha * 0.5 * (ci + c[j]) * muv + beta * muv * muv) * 2.0 / (rhoi + rho[j]);
      const ej_real vij = vi - v[3 * j], u = (xi * xi * vi - xj * xj * v[3 * j]) * inv_ri2;
      const ej_real w = mu[j] * dW;
      de += w * (0.5 * (pri - pr[j]) * vij + (pexact * pri + 0.5 * pi_ij) * (u - vij));
      dw += w * pi_ij * (u - vij);
    }
    e_dot[i] += de - (1.0 - pexact) * 2.0 * pri * rhoi * vi / ri;
    w_dot[i] += 0.5 * dw;
  }
  return EJ_OK;
}

/* Logical passes: 0 summation density (density: summation only), 1 per particle, 2 matrix
 * (correction or shape tensor only), 3 pairs. The unused ones are skipped (pass_count), so the
 * core's pass k is the k-th used one and saves the ghost refreshes of the others. */
static bool sph_has_matrix_pass(const sph_config *cfg) { return cfg->correction || cfg->gradient == SPH_GRAD_SHAPE; }

static int sph_logical_pass(const sph_config *cfg, int pass)
{
  if (cfg->density != SPH_DENS_SUMMATION) ++pass;
  if (!sph_has_matrix_pass(cfg) && pass >= 2) ++pass;
  return pass;
}

static int sph_pass_count(const void *state)
{
  const sph_state *s = state;
  if (s->cfg.strength) return 3 + (s->cfg.correction ? 1 : 0); /* particle, [L_corr], stress, forces */
  return 2 + (sph_has_matrix_pass(&s->cfg) ? 1 : 0) + (s->cfg.density == SPH_DENS_SUMMATION ? 1 : 0);
}

static ej_err sph_compute(void *state, ej_set *set, const ej_nbr *nbr, int pass, ej_range r)
{
  const sph_state *s = state;
  if (s->cfg.strength) {
    const int lp = (!s->cfg.correction && pass >= 1) ? pass + 1 : pass;
    switch (lp) {
    case 0: EJ_TRY(sph_particle_pass(s, set, r)); break;
    case 1: EJ_TRY(sph_corr_pass(s, set, nbr, r)); break;
    case 2: EJ_TRY(sph_solid_stress_pass(s, set, nbr, r)); break;
    case 3: EJ_TRY(sph_solid_force_pass(s, set, nbr, r)); break;
    default: EJ_FAIL(EJ_ERR_INTERNAL, "sph: pass %d of %d", pass, sph_pass_count(s));
    }
    return EJ_OK;
  }
  switch (sph_logical_pass(&s->cfg, pass)) {
  case 0: EJ_TRY(sph_sum_pass(s, set, nbr, r)); break;
  case 1: EJ_TRY(sph_particle_pass(s, set, r)); break;
  case 2:
    if (s->cfg.gradient == SPH_GRAD_SHAPE) EJ_TRY(sph_shape_pass(s, set, nbr, r));
    else EJ_TRY(sph_corr_pass(s, set, nbr, r));
    break;
  case 3:
    EJ_TRY(sph_pair_pass(s, set, nbr, r));
    if (s->cfg.geometry == SPH_GEOM_SPHERICAL) EJ_TRY(sph_geom_pass(s, set, nbr, r));
    if (s->cfg.conductivity > 0.0) EJ_TRY(sph_cond_pass(s, set, nbr, r));
    break;
  default: EJ_FAIL(EJ_ERR_INTERNAL, "sph: pass %d of %d", pass, sph_pass_count(s));
  }
  return EJ_OK;
}

/* ------------------------------------------------------------------ time step */

/* dt_i = h_i / (c_i + 1.2 (alpha c_i + beta max_j |mu_ij|)), the Courant condition with the
 * viscous signal speed, and the force condition dt_i = sqrt(h_i / |a_i|) (Monaghan 1992,
 * ARA&A 30, section 10.3; the factor 1.2 on the viscous term is the project's, the more
 * conservative of the published choices). The core multiplies by the CFL factor. A particle
 * at rest with c = 0 sets no limit (HUGE_VAL). */
static ej_err sph_stable_dt(void *state, const ej_set *set, ej_range r, ej_real *dt)
{
  const sph_state *s = state;
  const ej_real *restrict h = ej_set_field(set, "h");
  const ej_real *restrict c = ej_set_field(set, "c");
  const ej_real *restrict mu = ej_set_field(set, "mu_max");
  const ej_real *restrict a = ej_set_field(set, "a");
  EJ_ENSURE(h && c && mu && a, EJ_ERR_INTERNAL, "set '%s': sph fields missing", s->set_name);
  const ej_real alpha = s->cfg.alpha, beta = s->cfg.beta;
  /* solids: the particle speed joins the signal speed (001 §1.11, with its erratum: the EOS or
   * material sound speed, whichever is larger, instead of sqrt(E/rho)) */
  const ej_real *restrict v = s->cfg.strength ? ej_set_field(set, "v") : NULL;
  /* Relative density rate bound dt_i = drho_max rho_i/|rho_dot_i| (the criterion of ulpd, |tr L| dt
   * <= 1/2, for the continuity equation). The core calls stable_dt after the method's passes AND
   * the interactions (core/src/sim.c: ej_compute_all, then ej_next_dt), so rho_dot here is the full
   * rate of t_n+1, interface share (continuum, pd_sph) included, which is the rate the next drift
   * uses for the density predictor rho + dt rho_dot. With summation density rho_dot is a function
   * of dt itself (sph_sum_rows) and the bound is not applied. */
  const ej_real *restrict rho = ej_set_field(set, "rho");
  const ej_real *restrict rho_dot = s->cfg.density == SPH_DENS_CONTINUITY ? ej_set_field(set, "rho_dot") : NULL;
  EJ_ENSURE(rho, EJ_ERR_INTERNAL, "set '%s': sph field rho missing", s->set_name);
  const ej_real cr = s->cfg.drho_max;
  ej_real best = HUGE_VAL;
  for (ej_idx i = r.begin; i < r.end; ++i) {
    if (rho_dot && fabs(rho_dot[i]) * best > cr * rho[i]) best = cr * rho[i] / fabs(rho_dot[i]);
    const ej_real vi = v ? sqrt(v[3 * i] * v[3 * i] + v[3 * i + 1] * v[3 * i + 1] + v[3 * i + 2] * v[3 * i + 2]) : 0.0;
    const ej_real sig = c[i] + vi + 1.2 * (alpha * c[i] + beta * mu[i]);
    if (sig > 0.0) best = fmin(best, h[i] / sig);
    const ej_real a2 = a[3 * i] * a[3 * i] + a[3 * i + 1] * a[3 * i + 1] + a[3 * i + 2] * a[3 * i + 2];
    if (a2 > 0.0) best = fmin(best, sqrt(h[i] / sqrt(a2)));
  }
  *dt = best;
  return EJ_OK;
}

/* ------------------------------------------------------------------ registration */

/* renormalize_interfaces (README "Renormalisation across interfaces"): the continuity rate
 * rho_i fac sum_j V_j (v_i - v_j) . grad_i W_ij with fac = -dim / sum_j V_j r_ij dW/dr over the
 * set's own neighbours (pass 2) and the coupled sets' (continuum, pd_sph), clamped as in
 * sph_row_store; the same operations as sph_row_store's for a particle without other-set pairs. */
static ej_err sph_finish(void *state, ej_set *set, ej_range r)
{
  const sph_state *s = state;
  if (!s->cfg.renormalize_interfaces) return EJ_OK;
  const ej_real *ren_div = ej_set_field(set, "ren_div"), *ren_norm = ej_set_field(set, "ren_norm");
  const ej_real *rho = ej_set_field(set, "rho");
  ej_real *rho_dot = ej_set_field(set, "rho_dot");
  EJ_ENSURE(ren_div && ren_norm && rho && rho_dot, EJ_ERR_INTERNAL, "set '%s': sph renormalisation fields missing",
            s->set_name);
  const ej_real dim = (ej_real)s->dim;
  for (ej_idx i = r.begin; i < r.end; ++i) {
    ej_real drho = ren_div[i];
    const ej_real norm = ren_norm[i];
    if (norm < 0.0) drho *= sph_ren_clamp(-dim / norm);
    rho_dot[i] += rho[i] * drho;
  }
  return EJ_OK;
}

static ej_err sph_check_config(const void *config, ej_diag *diag)
{
  const sph_config *cfg = config;
  /* continuity: number divides the unweighted divergence by the unweighted renormalisation sum:
   * without that sum (renormalize: false, or the correction, which skips it) it has no units */
  if (cfg->continuity == SPH_CONT_NUMBER && (!cfg->renormalize || cfg->correction || cfg->gradient != SPH_GRAD_KERNEL))
    return ej_diag_error(diag, "continuity",
                         "continuity: number needs renormalize: true, the kernel gradient and no correction");
  if (cfg->renormalize_interfaces &&
      (!cfg->renormalize || cfg->correction || cfg->gradient != SPH_GRAD_KERNEL ||
       cfg->density != SPH_DENS_CONTINUITY || cfg->strength ||
       cfg->geometry != SPH_GEOM_PLANAR))
    return ej_diag_error(diag, "renormalize_interfaces",
                         "renormalize_interfaces needs renormalize: true with the plain kernel gradient, "
                         "density: continuity, strength: false and geometry: planar");
  /* geometry: spherical supports the kernel-gradient gas path (its dimension: 1 is checked in create,
   * which sees the dimension) */
  if (cfg->geometry == SPH_GEOM_SPHERICAL) {
    if (cfg->strength)
      return ej_diag_error(diag, "geometry", "geometry: spherical supports gases only (strength: false): the hoop "
                                             "stress of a spherical solid is not implemented");
    if (cfg->gradient == SPH_GRAD_SHAPE || cfg->correction)
      return ej_diag_error(diag, "geometry", "geometry: spherical supports gradient: kernel without correction only "
                                             "(the 1D kernel gradient is already exact for linear fields at h = 2 dx)");
    if (cfg->density == SPH_DENS_SUMMATION)
      return ej_diag_error(diag, "geometry", "geometry: spherical supports density: continuity only");
  }
  if (cfg->strength && cfg->gradient == SPH_GRAD_SHAPE)
    return ej_diag_error(diag, "gradient", "strength: true supports gradient: kernel only (with optional correction)");
  if (cfg->strength && cfg->density == SPH_DENS_SUMMATION)
    return ej_diag_error(diag, "density", "strength: true supports density: continuity only");
  if (cfg->visc_switch != SPH_VSW_NONE && !cfg->strength)
    return ej_diag_error(diag, "visc_switch", "visc_switch: balsara needs strength: true (it uses the velocity "
                                              "gradient of the solid stress pass)");
  if (cfg->gradient == SPH_GRAD_SHAPE && cfg->correction)
    return ej_diag_error(diag, "correction",
                         "correction applies to the kernel gradient only; gradient: shape_tensor is already "
                         "exact for linear fields (remove one of them)");
  return EJ_OK;
}

/* The solid passes' writes (strength: true; 2026-12-03), in sph_compute's order: particle pass, the
 * correction pass (correction only), the stress pass (velocity gradient, rotation, material update,
 * sigma/rho^2, artificial stress; it consumes sph_wall's L_wall and B_wall), the force pass (a, rates,
 * mu_max, XSPH velocity); post_step floors rho and, with XSPH, moves x. Before, every solid pass counted
 * as writing every field, so the images were copied in full (10-12 % of a Taylor bar step). */
static int sph_solid_pass_writes(const sph_config *cfg, int pass, const char **names, int max)
{
  if (cfg->density == SPH_DENS_SUMMATION || cfg->geometry != SPH_GEOM_PLANAR || cfg->conductivity > 0.0 || max < 16)
    return -1;
  static const char *const particle[] = {"rho", "h", "p", "c", "p_rho2", "w_cont", NULL};
  static const char *const corr[] = {"L_corr", "B_wall", "corr_fallbacks", NULL};
  static const char *const stress[] = {"rho_dot", "d_rate", "stress",     "c_mat",      "wp_inc", "failed",       "p",
                                       "c",       "sigma_rho2", "art_stress", "L_wall", "w_plastic_dot", NULL};
  static const char *const force[] = {"a", "e_dot", "w_visc_dot", "mu_max", "v_xsph", NULL};
  int n = 0;
  if (pass == EJ_PASS_POST_STEP) {
    names[n++] = "rho";
    if (cfg->xsph > 0.0) names[n++] = "x";
    return n;
  }
  const int lp = (!cfg->correction && pass >= 1) ? pass + 1 : pass;
  const char *const *l = lp == 0 ? particle : lp == 1 ? corr : lp == 2 ? stress : lp == 3 ? force : NULL;
  if (!l) return -1;
  while (l[n]) names[n] = l[n], ++n;
  if (lp == 2 && cfg->visc_switch == SPH_VSW_BALSARA) names[n++] = "visc_switch";
  return n;
}

/* The fields each pass writes (ABI 1.3 pass_writes: the core then copies to the ghosts only what
 * was written since the last refresh). Listed for the gas form with continuity density, the
 * kernel gradient without correction or the shape tensor, planar geometry and no conductivity
 * (passes: particle, [shape: M_inv and its fallback flag], pairs; post_step: the density floor);
 * every other configuration answers -1 (every field). */
static int sph_pass_writes(const void *state, int pass, const char **names, int max)
{
  const sph_state *s = state;
  const sph_config *cfg = &s->cfg;
  if (cfg->strength) return sph_solid_pass_writes(cfg, pass, names, max);
  if (cfg->density == SPH_DENS_SUMMATION || cfg->correction || cfg->geometry != SPH_GEOM_PLANAR ||
      cfg->conductivity > 0.0 || max < 6)
    return -1;
  const bool shape = cfg->gradient == SPH_GRAD_SHAPE;
  static const char *const particle[] = {"rho", "h", "p", "c", "p_rho2", "w_cont"};
  static const char *const shape_f[] = {"M_inv", "grad_fallback", "M_cpl"};
  static const char *const pairs[] = {"a", "rho_dot", "e_dot", "w_visc_dot", "mu_max"};
  static const char *const post[] = {"rho"};
  const int pair_pass = shape ? 2 : 1;
  const char *const *l = pass == EJ_PASS_POST_STEP ? post
                         : pass == 0               ? particle
                         : shape && pass == 1      ? shape_f
                         : pass == pair_pass       ? pairs
                                                   : NULL;
  const int n = pass == EJ_PASS_POST_STEP ? 1 : pass == 0 ? 6 : shape && pass == 1 ? 3 : pass == pair_pass ? 5 : -1;
  for (int k = 0; k < n; ++k) names[k] = l[k];
  return n;
}

static const ej_method_ops sph_ops = {
    .struct_size = sizeof(ej_method_ops),
    .name = "sph",
    .summary = "Standard SPH: gas dynamics (continuity density, Monaghan viscosity) and solids (strength: true)",
    .doc = "Compressible SPH in the standard symmetric form (Fan & Li, digest 000 Eqs 22-28, with the Eq 24 "
           "sign erratum): density by the continuity equation (continuity: auto, renormalised "
           "so that uniform compression is exact), pressure from the material's EOS, Monaghan viscosity, "
           "cubic-spline or Wendland C2 kernel with support 2h, variable h bounded by h_min and h_max, an "
           "optional conservative kernel gradient correction, optional summation density, and the "
           "consistent SPH of digest 000 Eqs 29-37 (gradient: shape_tensor, current shape tensor, with a "
           "counted fallback to the kernel gradient where it is ill-conditioned). Energy and momentum are "
           "conserved to round-off by the semi-discrete equations (not by shape_form: paper). Needs an EOS, "
           "or with strength: true a strength model: then the Libersky-Petschek solid form (material stress "
           "rotated by Hughes-Winget or Jaumann, Monaghan/Gray artificial stress, optional XSPH).",
    .params = sph_params,
    .config_size = sizeof(sph_config),
    .check_config = sph_check_config,
    .declare = sph_declare,
    .create = sph_create,
    .setup = sph_setup,
    .support = sph_support,
    .n_passes = 4,
    .compute = sph_compute,
    .stable_dt = sph_stable_dt,
    .finish = sph_finish,
    .post_step = sph_post_step,
    .post_step_local = true, /* own particles: the density floor and the XSPH move */
    .counters = sph_counters,
    .pass_count = sph_pass_count,
    .destroy = sph_destroy,
    .report = sph_report,
    .pass_writes = sph_pass_writes,
};

static ej_err sph_register(ej_registry *reg)
{
  EJ_TRY(ej_register_method(reg, &sph_ops));
  return EJ_OK;
}

EJ_PLUGIN_DEFINE(sph, "0.1.0", "BSD-3-Clause", "Standard SPH gas dynamics (continuity form)", sph_register)

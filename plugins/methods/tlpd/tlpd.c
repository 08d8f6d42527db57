/* Total-Lagrangian non-ordinary state-based ("correspondence") peridynamics.
 *
 * Sources (read the errata in the digests):
 *   000 = Fan & Li 2017, digest shared/digests/000-fan-li-pd-sph-soil.md, section 1.1-1.2, 1.6;
 *   002 = Zhu & Zhao, digest shared/digests/002-zhu-zhao-pd-rock-blasting.md, section 1.2-1.6.
 *
 * Per particle i with family H_i (bonds j with reference vector X = x0_j - x0_i, intact):
 *   K_i = sum_j w_ij V_j X (x) X                               (000 Eq 7/12, dV_J erratum)
 *   F_i = (sum_j w_ij V_j Y (x) X) K_i^-1,  Y = x_j - x_i      (000 Eqs 10-13; 002 Eq 5)
 *   P_i = J sigma F^-T                                         (002 Eq 3 with the F^-T erratum)
 *   T_i<X> = w P_i K_i^-1 X                                    (000 Eqs 5-6; 002 Eq 2)
 * force_form sum (Silling 2007; 002 Eq 1): rho0 a_i = sum_j (T_i<X_ij> - T_j<X_ji>) V_j
 * force_form difference (000 Eq 9 as the paper used): rho0 a_i = sum_j w (P_j - P_i) K_i^-1 X V_j
 * (000 Eq 3 read with the T^JI / X_JI erratum; the difference form is not antisymmetric, so
 * momentum is not conserved exactly near surfaces, and a uniform stress exerts no force).
 *
 * Objective stress update, Hughes-Winget with alpha = 1/2 (000 Eqs 78-94): with the increment
 * du = x_n+1 - x_n (x_n kept in the field x_prev), grad_X du = (sum w V_j du_ij (x) X) K^-1
 * (Eq 80), F_n+1/2 = F_n+1 - grad_X du / 2 (Eq 79), h = grad_X du F_n+1/2^-1 (Eq 88),
 * d = sym(h)/dt, omega = skew(h) (Eqs 89-90), Lambda = (I - omega/2)^-1 (I + omega/2) (Eq 94),
 * sigma_hat = Lambda sigma_n Lambda^T (Eq 93 with the transpose erratum, digest 000 row 19), then
 * the material plugin (ej_material_update) with d and F. A rigid rotation gives d = 0 and
 * Lambda equal to the increment of rotation exactly.
 *
 * Energy: e_dot_i = P_i : Fdot_i / rho0_i with Fdot = (sum w V_j (v_j - v_i) (x) X) K^-1, which is
 * sigma : d / rho with d = sym(Fdot F^-1); with the sum form, sum_i m_i (v_i.a_i + e_dot_i) = 0
 * exactly for the semi-discrete system, so the energy budget closes. Extra bond forces
 * (hourglass control, the spring fallback) put their power sum_j V_j T<X_ij>.(v_j - v_i) / rho0
 * into e as well; the hourglass part is also accumulated in w_hg (EJ_ENERGY_HOURGLASS).
 *
 * Two passes: pass 0 per particle over its bonds (F, increments, rotation, material, P K^-1);
 * the core copies fields to the mirror ghosts; pass 1 forces (gather form: row i only). */
#include <math.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ejecta/plugin.h"
#include "ejecta/tensor.h"

/* ------------------------------------------------------------------ configuration */

enum { TLPD_W_CONSTANT = 0, TLPD_W_QUADRATIC = 1, TLPD_W_GAUSSIAN = 2 };
static const char *const tlpd_influence_names[] = {"constant", "quadratic", "gaussian", NULL};
enum { TLPD_FORM_SUM = 0, TLPD_FORM_DIFFERENCE = 1 };
static const char *const tlpd_form_names[] = {"sum", "difference", NULL};
enum { TLPD_NONOBJ_RATE = 0, TLPD_NONOBJ_SMALL_STRAIN = 1 };
static const char *const tlpd_nonobj_names[] = {"rate", "small_strain", NULL};
enum { TLPD_HG_NONE = 0, TLPD_HG_ZHU_ZHAO = 1, TLPD_HG_SILLING = 2 };
static const char *const tlpd_hg_names[] = {"none", "zhu_zhao", "silling", NULL};
enum { TLPD_CONTACT_OFF = 0, TLPD_CONTACT_UNBONDED = 1, TLPD_CONTACT_ALL = 2 };
static const char *const tlpd_contact_names[] = {"off", "unbonded", "all", NULL};
enum { TLPD_CLAW_SPRING = 0, TLPD_CLAW_IMPACT = 1 };
static const char *const tlpd_claw_names[] = {"spring", "impact", NULL};
enum { TLPD_INV_ABORT = 0, TLPD_INV_POINT_FAILURE = 1 };
static const char *const tlpd_inv_names[] = {"abort", "point_failure", NULL};

typedef struct tlpd_failure_cfg {
  ej_real critical_stretch;
  ej_real cut_distance;
} tlpd_failure_cfg;

typedef struct tlpd_traction_cfg {
  ej_real pressure;
  ej_real normal[3];
  ej_real lo[3], hi[3];
  ej_real rise_time;
  ej_real frequency;
} tlpd_traction_cfg;

typedef struct tlpd_config {
  ej_real horizon;
  ej_real horizon_length;
  ej_real horizon_grading;
  int influence;
  bool partial_volume;
  int force_form;
  bool objective;
  int nonobjective;
  int hourglass;
  ej_real hourglass_coefficient;
  ej_real min_rcond;
  bool output_F;
  bool energy_correction;
  bool break_skip;
  bool ghost_force_correction;
  ej_real damping;
  int contact;
  int contact_law;
  ej_real contact_alpha, contact_beta;
  int inversion;
  tlpd_failure_cfg failure;
  tlpd_traction_cfg traction;
  ej_initial_stress initial_stress; /* pre-stressed / geostatic start (core, ABI 1.13) */
} tlpd_config;

static const ej_param tlpd_failure_params[] = {
    EJ_PARAM_REAL(tlpd_failure_cfg, critical_stretch, "1", 0, 0, 0, EJ_PF_HAS_MIN,
                  "Critical bond stretch s0 (000 Eqs 14-16): a bond with (|Y| - |X|)/|X| > s0 breaks for good; "
                  "0 disables bond breaking (point failure of the material still breaks all bonds of the point)."),
    EJ_PARAM_REAL(tlpd_failure_cfg, cut_distance, "1", 0, 0, 1, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX,
                  "Crack-opening cut of seed 002 (Sec. 2.4 (b)), in spacings: besides its own bonds, a failed "
                  "point breaks every intact bond whose reference segment passes closer to it than cut_distance "
                  "min(dx_i, dx_j) (both ends within min(delta_i, delta_j) of the point); 002 uses 0.5. 0 = off."),
    {0}};

static const ej_param tlpd_traction_params[] = {
    EJ_PARAM_REAL(tlpd_traction_cfg, pressure, "Pa", 0, 0, 0, 0,
                  "Pressure on the surface layer (positive pushes along -normal); 0 = no traction."),
    EJ_PARAM_ARRAY(tlpd_traction_cfg, normal, 3, "1", 0, "Outward unit normal of the loaded surface."),
    EJ_PARAM_ARRAY(tlpd_traction_cfg, lo, 3, "m", 0,
                   "Lower corner of the box (reference configuration) that selects the loaded surface layer."),
    EJ_PARAM_ARRAY(tlpd_traction_cfg, hi, 3, "m", 0, "Upper corner of the selecting box."),
    EJ_PARAM_REAL(tlpd_traction_cfg, rise_time, "s", 0, 0, 0, EJ_PF_HAS_MIN,
                  "Linear ramp of the pressure from 0 over this time, then constant (000 Fig. 4)."),
    EJ_PARAM_REAL(tlpd_traction_cfg, frequency, "1/s", 0, 0, 0, EJ_PF_HAS_MIN,
                  "If > 0, harmonic load P(t) = pressure (1 - cos(frequency t)) / 2 (000 Eq 97), angular "
                  "frequency in rad/s; rise_time is then ignored."),
    {0}};

static const ej_param tlpd_params[] = {
    EJ_PARAM_REAL(tlpd_config, horizon, "1", 3.0, 1.0, 10.0, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX,
                  "Horizon as a multiple m of each particle's local spacing vol0^(1/dim): delta_i = m dx_i."),
    EJ_PARAM_REAL(tlpd_config, horizon_length, "m", 0, 0, 0, EJ_PF_HAS_MIN,
                  "Absolute horizon for every particle; 0 = use horizon times the local spacing."),
    EJ_PARAM_REAL(tlpd_config, horizon_grading, "1", 0, 0, 0, EJ_PF_HAS_MIN,
                  "Variable spacing (refine:) with horizon = m dx_i: largest slope g of the per-particle horizon, "
                  "delta_i = max_j (m dx_j - g max(0, |X_ij| - (dx_i + dx_j)/2)) over the set (j = i included), so a "
                  "finer zone's horizon grows linearly to the coarser zone's over (m dx_c - m dx_f)/g instead of "
                  "jumping at the interface (0.125: 4 mm / 8 mm pulse reflection 3.95 % -> below 1 %, "
                  "validation/tlpd_refine). 0 = off; no effect at uniform spacing or with horizon_length."),
    EJ_PARAM_ENUM(tlpd_config, influence, tlpd_influence_names, "constant",
                  "Influence function w(r): constant 1, quadratic (1 - r/delta)^2 (002 section 1.2, "
                  "normalised), gaussian exp(-(r/delta)^2)."),
    EJ_PARAM_BOOL(tlpd_config, partial_volume, 1,
                  "Partial-volume correction: a bond with delta - dx/2 < r < delta + dx/2 counts the "
                  "fraction (delta + dx/2 - r)/dx of the neighbour's volume."),
    EJ_PARAM_ENUM(tlpd_config, force_form, tlpd_form_names, "sum",
                  "sum: T_i<X_ij> - T_j<X_ji> (Silling 2007; conserves momentum and energy exactly); difference: "
                  "w (P_j - P_i) K_i^-1 X (000 Eq 9, the paper's form; no force from a uniform stress)."),
    EJ_PARAM_BOOL(tlpd_config, objective, 1,
                  "Objective update: Hughes-Winget rotation and the rotation-neutralised rate (000 Eqs 78-94); "
                  "false: no rotation of the stress (not objective, the scheme 000 Fig. 8a contrasts with; for "
                  "demonstration only; which rate: nonobjective)."),
    {.name = "nonobjective", .type = EJ_PT_ENUM, .offset = offsetof(tlpd_config, nonobjective), .flags = EJ_PF_EXPERT,
     .unit = "1", .choices = tlpd_nonobj_names, .def_str = "rate",
     .doc = "Strain increment when objective is false: rate, sym(h) with h = grad_X du F_n+1/2^-1 (000 Eqs 88-92 "
            "without the rotation of Eq 93: sigma += C:d dt); small_strain, sym(grad_X du) (infinitesimal strain "
            "from the reference gradient, no push-forward)."},
    EJ_PARAM_ENUM(tlpd_config, hourglass, tlpd_hg_names, "zhu_zhao",
                  "Zero-energy mode control: zhu_zhao, bond force 2 c E w (Y - F X) / tr K (002 Eq 15 with "
                  "its digest's modulus and w); silling, bond-level 2 c G w (Y - F X) / (|X|^2 sum w V) after "
                  "Silling 2017; none."),
    EJ_PARAM_REAL(tlpd_config, hourglass_coefficient, "1", 0.01, 0, 0, EJ_PF_HAS_MIN,
                  "Penalty coefficient c of the hourglass control (002: 0.01)."),
    EJ_PARAM_REAL(tlpd_config, min_rcond, "1", 1e-6, 0, 0.3, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX | EJ_PF_EXPERT,
                  "Reciprocal condition number of K below which a particle uses the bond-based spring "
                  "fallback (002 section 1.3) instead of the correspondence force. The default catches only "
                  "exactly planar or collinear families; fragmenting soil needs about 1e-2, where a damaged "
                  "particle's few intact bonds that nearly lie in a plane no longer define F (README "
                  "\"Degenerate families\")."),
    EJ_PARAM_BOOL(tlpd_config, output_F, 0, "Write the deformation gradient F to the output frames."),
    {.name = "energy_correction", .type = EJ_PT_BOOL, .offset = offsetof(tlpd_config, energy_correction),
     .flags = EJ_PF_EXPERT, .unit = "1", .def = 1,
     .doc = "Re-evaluate the internal-energy rate at the final velocity of the step (exact in total, per "
            "particle -a_int . (v_n+1 - v_pred)); false leaves the core's predicted-velocity rate, whose energy "
            "error grows as dt^2 sum |a_n+1 - a_n|^2 (2.6 % on the tearing bar at cfl 0.5)."},
    {.name = "break_skip", .type = EJ_PT_BOOL, .offset = offsetof(tlpd_config, break_skip),
     .flags = EJ_PF_EXPERT, .unit = "1", .def = 1,
     .doc = "Skip the bond-break sweep of a row while no bond of it can have reached the critical stretch (its "
            "reference-cell block's displacement since its last sweep, twice, below its smallest sqrt(lim)|X| - |Y|) "
            "and no particle of the block failed since: the same broken bonds as sweeping every row every step, "
            "at a fraction of the cost where the body is at rest. false sweeps every row every step."},
    EJ_PARAM_BOOL(tlpd_config, ghost_force_correction, 0,
                  "Opt-in, variable spacing only: remove the ghost force of a uniform stress on the rows near a change of "
                  "spacing (f_i -= P_i e_i, e_i = K_i^-1 m1_i + sum_j B_ij K_j^-1 X_ij), so that a uniform strain gives "
                  "zero force across a refine: interface; its power goes to e (momentum not exact there). Off by default: "
                  "with fracture and large strain (examples/buried_charge.yaml) it drove det F < 0 at step 765."),
    EJ_PARAM_REAL(tlpd_config, damping, "1/s", 0, 0, 0, EJ_PF_HAS_MIN,
                  "Mass-proportional velocity damping a -= damping v (for quasi-static runs); the removed "
                  "energy is reported as dissipated."),
    EJ_PARAM_ENUM(tlpd_config, contact, tlpd_contact_names, "off",
                  "Short-range contact (LAMMPS pair peri, Silling & Askari 2005): repulsion 15 c_s V_j (d - r)/delta, "
                  "c_s = 18 K/(pi delta^4), between particles closer than d = min(0.9 |X_ij|, 1.35 min(dx_i, dx_j)); "
                  "unbonded: pairs without an intact bond (broken, detached, or never in a family), all: every pair "
                  "(LAMMPS), off."),
    EJ_PARAM_ENUM(tlpd_config, contact_law, tlpd_claw_names, "spring",
                  "Contact force law (with contact unbonded/all): spring, LAMMPS's repulsion alone (elastic, stops "
                  "relative speeds up to ~2 sqrt(0.14 K/rho)); impact, the spring plus, on approaching pairs, the "
                  "pairwise viscous pressure rho (alpha c |v_n| + beta v_n^2) on the face min(dx_i, dx_j)^(dim-1) (dissipative; "
                  "heat into e, reported as contact_dissipated)."),
    EJ_PARAM_REAL(tlpd_config, contact_alpha, "1", 1.0, 0, 0, EJ_PF_HAS_MIN,
                  "contact_law impact: coefficient of the linear term rho alpha c |v_n| (c = sqrt((K + 4G/3)/rho0), "
                  "the material's small-strain longitudinal wave speed)."),
    EJ_PARAM_REAL(tlpd_config, contact_beta, "1", 2.0, 0, 0, EJ_PF_HAS_MIN,
                  "contact_law impact: coefficient of the quadratic term rho beta v_n^2."),
    EJ_PARAM_ENUM(tlpd_config, inversion, tlpd_inv_names, "abort",
                  "A particle whose F has det F <= 0 (or a singular F_n+1/2, a failed Hughes-Winget rotation): abort "
                  "stops the run with an error; point_failure breaks all its bonds (detached, P = 0), counts it and "
                  "goes on."),
    EJ_PARAM_BLOCK(tlpd_config, failure, tlpd_failure_params, tlpd_failure_cfg, 0,
                   "Bond breaking (critical stretch)."),
    EJ_PARAM_BLOCK(tlpd_config, traction, tlpd_traction_params, tlpd_traction_cfg, 0,
                   "A pressure on a surface layer, applied as forces P A_i on the particles in a box "
                   "(A_i = vol0_i / dx_i, the face of the particle's cell)."),
    EJ_PARAM_BLOCK(tlpd_config, initial_stress, ej_initial_stress_params, ej_initial_stress, 0,
                   "Initial Cauchy stress (like LS-DYNA *INITIAL_STRESS): a pre-stressed or geostatic start, "
                   "uniform, per particle from a CSV file, or geostatic from the overburden; F = I at t = 0, the "
                   "material takes it as its stress state (no strain energy is booked for it in e)."),
    {0}};

static ej_err tlpd_check_config(const void *config, ej_diag *diag)
{
  const tlpd_config *c = config;
  const tlpd_traction_cfg *t = &c->traction;
  if (c->contact_law == TLPD_CLAW_IMPACT && c->contact == TLPD_CONTACT_OFF)
    return ej_diag_error(diag, "contact_law", "contact_law: impact needs contact: unbonded or all (contact is off)");
  if (t->pressure != 0) {
    const ej_real nn = t->normal[0] * t->normal[0] + t->normal[1] * t->normal[1] + t->normal[2] * t->normal[2];
    if (fabs(nn - 1) > 1e-6) return ej_diag_error(diag, "traction", "traction.normal must be a unit vector (|n|^2 = %g)", nn);
    for (int k = 0; k < 3; ++k)
      if (!(t->hi[k] >= t->lo[k]))
        return ej_diag_error(diag, "traction", "traction box: hi[%d] = %g is below lo[%d] = %g", k, t->hi[k], k, t->lo[k]);
  }
  return ej_initial_stress_check(&c->initial_stress, diag);
}

/* ------------------------------------------------------------------ state */

enum { TLPD_OK = 0, TLPD_FALLBACK = 1, TLPD_DETACHED = 2 };
/* per-bond weights w beta V_j, double (HEAD stored them as float: a relative 1e-8 change of
 * the 40-step bench results and no measurable speed difference, so double it is) */
typedef double tlpd_wt;
enum { TLPD_BROKEN = 1 };
#define TLPD_MAX_HIST 32

typedef struct tlpd_state {
  tlpd_config cfg;
  const ej_set *set;
  const char *name;
  int dim;
  const ej_material *mat;
  const ej_eos *eos;
  ej_real K, G, E, Kd; /* moduli; Kd: dimension's bulk modulus for the spring fallback */
  /* lazily allocated at the first compute (the family exists from then on, plugin.h) */
  atomic_int ready;
  atomic_int any_failed;
  ej_idx n;
  ej_off nb;
  const ej_off *off;   /* the reference family (never rebuilt, so the pointers stay valid) */
  const ej_idx *idx;
  bool wb_alias;       /* wb == wa (uniform spacing) */
  tlpd_wt *wa, *wb;    /* [nb] w_i beta_i V_j (owner's horizon), w_j beta_j V_j (neighbour's) */
  ej_real *Kinv;       /* [9n] */
  ej_real *d6;         /* [6n] rate of deformation for the material batch */
  ej_real *wp;         /* [n] plastic work increment */
  ej_real *p_eos;      /* [n] EOS pressure (if the material has an EOS) */
  ej_real *c_eos;      /* [n] */
  ej_real *area;       /* [n] traction area (0: not loaded) */
  uint8_t *row_ready;  /* [n] */
  ej_real *dxp;        /* [n] local spacing vol0^(1/dim) */
  int32_t *nbroken;    /* [n] broken bonds of the row */
  ej_real *aint;       /* [3n] acceleration of the internal (tlpd) forces of this step's pass 1 */
  ej_real *vpred;      /* [3n] the predicted velocity the rates were evaluated with (pass 0) */
  uint8_t *vp_ok;      /* [n] vpred and aint belong to this step */
  uint8_t *row_intact; /* [n] no broken bond in the row (the bond loops skip the flag test) */
  uint8_t *mixed;      /* [n] the row has a bond to a particle of another vol0 (variable spacing) */
  uint8_t *full;       /* [n] the row's family fills its horizon ball (the neighbours' cells, each of its own
                        * size, cover >= 0.85 of the ball's volume: not at a free surface) */
  uint8_t *gf_state;   /* [n] ghost-force vector: 0 not computed, 1 not in the interface zone, 2 egf holds it */
  ej_real *egf;        /* [3n] K_i e_i: the force of a uniform P on row i is P_i e_i = PK_i (K_i e_i) */
  ej_real *m1;         /* [3n] first moment sum_j w_ij V_j X over intact bonds (force pass: sum_j A G_i X = G_i m1) */
  int32_t *n_fallback; /* [n] particle-steps with a singular K */
  ej_idx *jmax;        /* [n] largest neighbour index of the row (a 4-wide load of any neighbour's
                        * VEC3 stays inside the array when jmax + 1 < nall: no per-bond test) */
  uint8_t *notok;      /* [n] status != TLPD_OK (kept by refresh_row, counted in n_notok) */
  atomic_int n_notok;  /* rows with a singular K or detached: 0 = every row (so every ghost, a copy
                        * of one) is a correspondence point, and the force loop needs no status test */
  /* stable step of the current family (tlpd_stable_dt): per row h_self = |K^-1 m1| and
   * H = sum_l |g_l| + h_self, g_l = w V_l K^-1 X_l (reference quantities, change only when
   * bonds break); cached 2/sqrt(lambda_i), the time it was computed, the last refresh time */
  ej_real *hself, *hsum;
  _Atomic double t_refresh;
  /* inversion: point_failure: particles point-failed at det F <= 0 */
  uint8_t *pfail;      /* [n] */
  /* failure.cut_distance: failed particles in row i (any bond state) when its cut was last tested;
   * failed never clears, so an unchanged count means an unchanged set (the cut is idempotent) */
  int32_t *cut_nf;     /* [n] */
  /* contact: a dense cell grid over owned + ghost particles, rebuilt once per force pass
   * (serial, first range in); cells >= 1.35 dx_min, row i searches 1.35 dx_i around it */
  ej_real c_dxmin;     /* smallest dx over owned + ghost particles (grid cells >= 1.35 dx_min) */
  ej_real c_gh, c_glo[3];
  int64_t c_gn[3];
  size_t c_ncap;       /* cells allocated (4 nall + 64, the cap of pd's grid) */
  uint32_t *c_cellof;  /* [nall] */
  ej_idx *c_order;     /* [nall] particles sorted by cell (stable: ascending index in a cell) */
  uint32_t *c_start;   /* [c_ncap + 1] */
  _Atomic double c_grid_t;
  atomic_llong c_grid_epoch;
  atomic_llong epoch;  /* bumped by report (once per step) */
  /* horizon_grading: the particles whose horizon m dx exceeds the smallest (the sources of the
   * graded horizon) in a cell grid over all particles; built at the first support call, freed at
   * the first compute (tlpd_support, tlpd_grade) */
  atomic_int gr_ready;
  ej_real *gr_pts;     /* [5 ns] x0, m dx, dx of each source, by cell */
  ej_idx *gr_start;    /* [ncell + 1] */
  ej_real *gr_cmax;    /* [ncell] largest m dx of the cell's sources (-inf: none) */
  ej_real *gr_ub;      /* [ncell] upper bound of the graded horizon anywhere in the cell */
  ej_real gr_lo[3], gr_h, gr_dmax;
  int gr_nc[3];
  ej_real *kc;         /* [n] contact stiffness sum_j 15 c_s V_j / delta of the last force pass (stable step) */
  ej_real *avis;       /* [3n] contact_law impact: acceleration of the viscous contact force (this step) */
  ej_real *cc;         /* [n] contact_law impact: viscous coefficient sum_j A rho (alpha c + beta |v_n|), N s/m */
  int32_t *ncont;      /* [n] contact pairs of row i in the last force pass */
  /* Bond-break sweep skip (post_step; README "Implementation notes", "Bond-break skip"). A cell grid
   * over the owned particles' reference positions; row i's block, the cells within bk_m[i] of its
   * own, holds its whole family (and its mirror ghosts' sources). finish records each cell's largest
   * displacement since the last post_step, |x - x_prev|, and counts new failures per cell; post_step
   * adds the block's largest displacement to the row's budget and skips the row's bond sweep while
   * 2 budget < slack, a lower bound of the row's smallest sqrt(lim)|X| - |Y| at its last sweep, and
   * no failed particle ends an intact bond of it: no flag could change. Exact: the same flags as
   * sweeping every row every step. */
  bool bk_on;
  int bk_nc[3];
  ej_real bk_lo[3], bk_inv; /* grid origin, 1 / cell size */
  size_t bk_ncell;
  int32_t *bk_cell;           /* [n] reference cell of particle i */
  int64_t *bk_nskip;          /* [n] sweeps skipped (the counters op sums them) */
  uint8_t *bk_hot;            /* [n] consecutive sweeps whose slack lasted less than a step: from 2 on the
                               * slack (a square root per bond) is computed only every 8th sweep */
  uint8_t *bk_m;              /* [n] row i's block: the cells within bk_m[i] of its own in each direction
                               * (its longest bond over the cell size, rounded up) */
  uint8_t *bk_fseen;          /* [n] failed, as counted in bk_fcell */
  ej_real *bk_budget;         /* [n] sum, since row i's last sweep, of its block's largest displacement */
  ej_real *bk_slack;          /* [n] lower bound of min over the unbroken bonds of sqrt(lim)|X| - |Y| at that sweep */
  int64_t *bk_fsum;           /* [n] failed particles counted in row i's block at that sweep */
  uint32_t *bk_gen;           /* [n] bk_gen_now at row i's last post_step (0: never) */
  uint8_t *bk_cf;             /* [n] check_fail (failed ends break bonds) at that sweep */
  uint8_t *bk_gok;            /* [n] ghost neighbours: 0 not checked, 1 none or every ghost's source in the row's
                               * block (a mirror image: its displacement is its source's, in length), 2 not */
  ej_idx *bk_src;             /* [n] owned index of id k (ids of the owned particles: a permutation of 0..n-1) */
  _Atomic uint64_t *bk_dcell; /* [ncell] largest |x - x_prev| of the cell at the last finish (bits of a double >= 0) */
  atomic_llong *bk_fcell;     /* [ncell] failed particles of the cell counted so far (failed never clears) */
  _Atomic uint64_t *bk_tcell; /* [ncell] the cell's last bond break (largest pd_t_break, bits of a double >= 0):
                               * stable_dt skips the family scan of a row whose block broke nothing since */
  atomic_uint bk_gen_now;     /* finish calls (bumped by the range holding particle 0) */
  /* serial report accumulators */
  ej_real w_traction, w_damping, t_last;
} tlpd_state;

/* ------------------------------------------------------------------ declare */

static ej_err tlpd_declare(const void *config, int dim, ej_decl *d)
{
  const tlpd_config *cfg = config;
  EJ_ENSURE(dim >= 1 && dim <= 3, EJ_ERR_ARG, "tlpd: dimension %d not in 1..3", dim);
  const ej_field_decl fields[] = {
      /* stress and c are ghosted: tlpd's own loops do not read them at images, but a coupling does
       * (continuum, pd_sph: a partner's mirror and periodic images sit in its lists) */
      {.name = "stress", .kind = EJ_SYM6, .flags = EJ_FIELD_OUTPUT, .unit = "Pa", .doc = "Cauchy stress."},
      {.name = "F", .kind = EJ_TENSOR9, .flags = cfg->output_F ? EJ_FIELD_OUTPUT : 0u, .unit = "1",
       .doc = "Nonlocal deformation gradient N K^-1 (checkpointed: the next step differences it)."},
      {.name = "PK", .kind = EJ_TENSOR9, .flags = EJ_FIELD_SCRATCH, .unit = "Pa/m^2",
       .doc = "First Piola-Kirchhoff stress times K^-1 (force state per bond vector)."},
      {.name = "K_inv", .kind = EJ_TENSOR9, .flags = EJ_FIELD_SCRATCH, .unit = "1/m^5",
       .doc = "Inverse reference shape tensor over intact bonds (published for pd_sph form paper)."},
      {.name = "G_pk", .kind = EJ_TENSOR9, .flags = EJ_FIELD_SCRATCH, .unit = "Pa/m^2",
       .doc = "P K^-1 - C F, stored by columns: the bond-force matrix of the sum form with hourglass control folded in."},
      {.name = "x_prev", .kind = EJ_VEC3, .flags = EJ_FIELD_POSITION, .unit = "m",
       .doc = "Position at the previous step (displacement increment of the Hughes-Winget update)."},
      {.name = "rho", .kind = EJ_SCALAR, .flags = EJ_FIELD_OUTPUT, .unit = "kg/m^3", .doc = "Density rho0 / det F."},
      {.name = "e", .kind = EJ_SCALAR, .flags = EJ_FIELD_OUTPUT, .unit = "J/kg", .rate = "e_dot",
       .energy = EJ_ENERGY_INTERNAL, .doc = "Specific internal energy (stress work, hourglass and fallback work)."},
      {.name = "w_hg", .kind = EJ_SCALAR, .flags = EJ_FIELD_NO_GHOST, .unit = "J/kg", .rate = "w_hg_dot",
       .energy = EJ_ENERGY_HOURGLASS, .doc = "Specific work of the hourglass forces (already part of e)."},
      {.name = "w_plastic", .kind = EJ_SCALAR, .flags = EJ_FIELD_NO_GHOST, .unit = "J/kg", .energy = EJ_ENERGY_PLASTIC,
       .doc = "Specific plastic work reported by the material."},
      {.name = "damage", .kind = EJ_SCALAR, .flags = EJ_FIELD_OUTPUT | EJ_FIELD_NO_GHOST, .unit = "1",
       .doc = "1 - intact family volume / family volume (000 Eq 17)."},
      {.name = "failed", .kind = EJ_INT, .flags = 0, .unit = "1", .doc = "Point failure flag set by the material."},
      {.name = "pd_status", .kind = EJ_INT, .flags = EJ_FIELD_SCRATCH, .unit = "1",
       .doc = "0 correspondence, 1 spring fallback (singular K), 2 detached (no intact bond)."},
      {.name = "pd_coef", .kind = EJ_SCALAR, .flags = EJ_FIELD_SCRATCH, .unit = "Pa/m^2",
       .doc = "Hourglass coefficient (or the spring constant of the fallback)."},
      {.name = "c", .kind = EJ_SCALAR, .flags = EJ_FIELD_SCRATCH, .unit = "m/s",
       .doc = "Sound speed from the material."},
      {.name = "pd_hsum", .kind = EJ_SCALAR, .flags = EJ_FIELD_SCRATCH, .unit = "1/m",
       .doc = "Sum of the norms of the row's gradient weights |w V K^-1 X| (stable step)."},
      /* state that a restart must find as the run left it (checkpointed, not scratch), so that a
       * restarted run continues bitwise (tests/unit/test_restart_methods.c) */
      {.name = "pd_fprev", .kind = EJ_INT, .flags = EJ_FIELD_NO_GHOST, .unit = "1",
       .doc = "1 if F holds F_n of the previous step over the same bonds (grad du = F - F_n)."},
      {.name = "pd_dt_fam", .kind = EJ_SCALAR, .flags = EJ_FIELD_NO_GHOST, .unit = "s",
       .doc = "Cached stable step of the particle's family (0: not computed)."},
      {.name = "pd_dt_fam_t", .kind = EJ_SCALAR, .flags = EJ_FIELD_NO_GHOST, .unit = "s",
       .doc = "Time at which pd_dt_fam was computed (valid while no bond of the family has broken since)."},
      {.name = "pd_t_break", .kind = EJ_SCALAR, .flags = EJ_FIELD_NO_GHOST, .unit = "s",
       .doc = "Time at which a bond of the particle's row last broke (0: never)."},
  };
  for (size_t k = 0; k < sizeof fields / sizeof fields[0]; ++k) EJ_TRY(ej_decl_field(d, &fields[k]));
  if (cfg->horizon_grading > 0 && !(cfg->horizon_length > 0)) {
    /* ghost-copied: the reaction weights w_j beta_j V_j need a mirror ghost's horizon */
    const ej_field_decl hz = {.name = "pd_horizon", .kind = EJ_SCALAR, .flags = 0u, .unit = "m",
                              .doc = "Graded horizon delta_i of horizon_grading (set with the reference family)."};
    EJ_TRY(ej_decl_field(d, &hz));
  }
  if (cfg->force_form == TLPD_FORM_DIFFERENCE) {
    const ej_field_decl P = {.name = "P", .kind = EJ_TENSOR9, .flags = EJ_FIELD_SCRATCH, .unit = "Pa",
                             .doc = "First Piola-Kirchhoff stress."};
    EJ_TRY(ej_decl_field(d, &P));
  }
  if (cfg->contact != TLPD_CONTACT_OFF && cfg->contact_law == TLPD_CLAW_IMPACT) {
    const ej_field_decl wc = {.name = "w_contact", .kind = EJ_SCALAR, .flags = EJ_FIELD_NO_GHOST, .unit = "J/kg",
                              .rate = "w_contact_dot", .energy = EJ_ENERGY_VISCOUS,
                              .doc = "Specific work dissipated by the impact contact's viscous pressure (already part of e)."};
    EJ_TRY(ej_decl_field(d, &wc));
  }
  EJ_TRY(ej_decl_neighbours(d, EJ_NBR_REFERENCE));
  return EJ_OK;
}

/* ------------------------------------------------------------------ create / destroy */

/* the graded-horizon search grid (horizon_grading) */
static void tlpd_grade_free(tlpd_state *s)
{
  ej_free(s->gr_pts), ej_free(s->gr_start), ej_free(s->gr_cmax), ej_free(s->gr_ub);
  s->gr_pts = s->gr_cmax = s->gr_ub = NULL;
  s->gr_start = NULL;
}

static void tlpd_free_arrays(tlpd_state *s)
{
  if (!s->wb_alias) ej_free(s->wb);
  ej_free(s->wa), ej_free(s->Kinv), ej_free(s->d6), ej_free(s->wp);
  ej_free(s->p_eos), ej_free(s->c_eos), ej_free(s->area), ej_free(s->row_ready), ej_free(s->n_fallback);
  ej_free(s->m1), ej_free(s->row_intact), ej_free(s->aint), ej_free(s->vpred), ej_free(s->vp_ok), ej_free(s->dxp), ej_free(s->nbroken);
  ej_free(s->mixed), ej_free(s->full), ej_free(s->gf_state), ej_free(s->egf);
  ej_free(s->hself), ej_free(s->hsum);
  ej_free(s->jmax), ej_free(s->notok);
  ej_free(s->pfail), ej_free(s->cut_nf), ej_free(s->kc), ej_free(s->cc), ej_free(s->avis), ej_free(s->ncont);
  ej_free(s->c_cellof), ej_free(s->c_order), ej_free(s->c_start);
  ej_free(s->bk_cell), ej_free(s->bk_fseen), ej_free(s->bk_budget), ej_free(s->bk_slack), ej_free(s->bk_fsum);
  ej_free(s->bk_gen), ej_free(s->bk_cf), ej_free((void *)s->bk_dcell), ej_free((void *)s->bk_fcell);
  ej_free((void *)s->bk_tcell);
  s->bk_tcell = NULL;
  ej_free(s->bk_gok), ej_free(s->bk_src), ej_free(s->bk_m), ej_free(s->bk_nskip), ej_free(s->bk_hot);
  s->bk_gok = s->bk_m = s->bk_hot = NULL, s->bk_src = NULL, s->bk_nskip = NULL;
  s->bk_cell = NULL, s->bk_fseen = s->bk_cf = NULL, s->bk_budget = s->bk_slack = NULL, s->bk_fsum = NULL;
  s->bk_gen = NULL, s->bk_dcell = NULL, s->bk_fcell = NULL, s->bk_on = false;
  tlpd_grade_free(s);
}

static void tlpd_destroy(void *state)
{
  tlpd_state *s = state;
  if (!s) return;
  tlpd_free_arrays(s);
  ej_free(s);
}

static ej_err tlpd_create(const void *config, ej_set *set, const ej_model *model, void **state)
{
  EJ_ENSURE(config && set && model && state, EJ_ERR_ARG, "tlpd: NULL argument to create");
  const tlpd_config *cfg = config;
  const ej_material *mat = ej_model_material(model);
  EJ_ENSURE(mat, EJ_ERR_UNSUPPORTED,
            "set '%s': tlpd needs a strength model, and material '%s' has none (add model: elastic, ...)",
            ej_set_name(set), ej_model_name(model));
  EJ_ENSURE(ej_material_n_hist(mat) <= TLPD_MAX_HIST, EJ_ERR_UNSUPPORTED, "tlpd: material has %d history variables (max %d)",
            ej_material_n_hist(mat), TLPD_MAX_HIST);
  tlpd_state *s = ej_calloc(1, sizeof *s);
  EJ_ENSURE(s, EJ_ERR_MEM, "tlpd: out of memory");
  s->cfg = *cfg;
  s->set = set;
  s->name = ej_set_name(set);
  s->dim = ej_set_dim(set);
  s->mat = mat;
  s->eos = ej_model_eos(model);
  ej_err rc = ej_material_moduli(mat, &s->K, &s->G);
  if (rc != EJ_OK) {
    ej_free(s);
    EJ_FAIL(rc, "set '%s': tlpd needs the material's moduli", s->name);
  }
  s->E = 9 * s->K * s->G / (3 * s->K + s->G);
  /* bulk modulus of the dimension: 3D K; 2D plane strain lambda + mu; 1D uniaxial strain lambda + 2 mu */
  s->Kd = s->dim == 3 ? s->K : s->dim == 2 ? s->K + s->G / 3 : s->K + 4 * s->G / 3;
  s->t_last = -INFINITY;
  atomic_init(&s->ready, 0);
  atomic_init(&s->any_failed, 0);
  atomic_init(&s->n_notok, 0);
  atomic_init(&s->c_grid_t, NAN);
  atomic_init(&s->c_grid_epoch, -1);
  atomic_init(&s->epoch, 0);
  atomic_init(&s->gr_ready, 0);
  *state = s;
  return EJ_OK;
}

/* ------------------------------------------------------------------ geometry helpers */

/* 4 doubles (GCC/Clang vector extension; plain scalar code where the target has no SIMD):
 * the bond loops keep a 3-vector in lanes 0-2 (lane 3 unused) */
typedef double tlpd_v4 __attribute__((vector_size(32)));
/* the same, for unaligned loads from a double array */
typedef double tlpd_v4u __attribute__((vector_size(32), aligned(8), may_alias));
/* (macros, not functions: a 32-byte vector crossing a function boundary changes the ABI
 * without -mavx, -Wpsabi) */
#define TLPD_LD3(p) ((tlpd_v4){(p)[0], (p)[1], (p)[2], 0})
/* 4 consecutive doubles (the caller guarantees p[3] is inside the array) */
#define TLPD_LD4(p) ((tlpd_v4)(*(const tlpd_v4u *)(const void *)(p)))
/* the 3-vector of particle j of a VEC3 field with nall particles: one 4-wide load (lane 3 =
 * the next particle's first component, never used) except for the last particle */
#define TLPD_LDJ(a, j, nall) ((j) + 1 < (nall) ? TLPD_LD4((a) + 3 * (size_t)(j)) : TLPD_LD3((a) + 3 * (size_t)(j)))

/* a * b + c, contracted as the general force loop's A Ci + B C_j is (an FMA where the target has
 * one, so that the fast loop gives the same bits; plain multiply-add otherwise, no libm call) */
#ifdef __FMA__
#define TLPD_MADD(a, b, c) fma((a), (b), (c))
#else
#define TLPD_MADD(a, b, c) ((a) * (b) + (c))
#endif

static inline ej_real tlpd_root(int dim, ej_real v) { return dim == 3 ? cbrt(v) : dim == 2 ? sqrt(v) : v; }

/* local spacing and horizon of a particle */
static inline ej_real tlpd_dx(const tlpd_state *s, ej_real vol0) { return tlpd_root(s->dim, vol0); }
static inline ej_real tlpd_delta(const tlpd_state *s, ej_real dx)
{
  return s->cfg.horizon_length > 0 ? s->cfg.horizon_length : s->cfg.horizon * dx;
}

/* w(r) beta(r) for a particle with horizon delta and spacing dx */
static inline ej_real tlpd_weight(const tlpd_config *c, ej_real r, ej_real delta, ej_real dx)
{
  ej_real beta;
  if (c->partial_volume) {
    const ej_real lo = delta - 0.5 * dx, hi = delta + 0.5 * dx;
    beta = r <= lo ? 1 : r >= hi ? 0 : (hi - r) / dx;
  } else {
    beta = r < delta ? 1 : 0;
  }
  if (beta <= 0) return 0;
  const ej_real q = r / delta;
  switch (c->influence) {
  case TLPD_W_QUADRATIC: return q < 1 ? beta * (1 - q) * (1 - q) : 0;
  case TLPD_W_GAUSSIAN: return beta * exp(-q * q);
  default: return beta;
  }
}

/* ------------------------------------------------------------------ graded horizon */

/* Graded horizon (horizon_grading, issue 4 item 5). With delta_i = m dx_i the horizon jumps with
 * the spacing at a refine: interface (12 -> 24 mm at 4 mm / 8 mm), and on the rows within a
 * horizon of it the dual-horizon operator is first-order inconsistent (the divergence of a linear
 * stress is off by s_i = 0.55-1.47; validation/tlpd_refine: 3.5-4 % reflection with the
 * ghost-force correction). horizon_grading g > 0 takes
 *   delta_i = max_j (D_j - g max(0, |X_ij| - (dx_i + dx_j)/2)),   D_j = m dx_j  (j = i included),
 * the smallest function above every D_j with slope at most g: a finer zone's horizon grows
 * linearly to the coarser zone's over (D_c - D_f)/g next to the interface, so the neighbouring
 * horizons of the dual-horizon rows (Ren, Zhuang, Cai & Rabczuk 2016, each bond with its owner's
 * horizon) differ by at most g times their distance. At uniform spacing delta_i = m dx_i exactly.
 * The grading rule is ejecta's (1-D model and check in validation/tlpd_refine/README.md). Sources
 * are the set's own particles (not mirror images). Search: the particles with D above the
 * smallest, in a cell grid over the whole set (cells about a quarter of the reach (D_max -
 * D_min)/g + dx_max, at most 4n + 64), with a per-cell upper bound so that a particle out of
 * every source's reach costs one test. Serial build, read-only queries (any thread count gives
 * the same delta: a maximum, independent of the scan order). */
static inline int tlpd_gr_cell(const tlpd_state *s, int d, ej_real x)
{
  const int c = (int)floor((x - s->gr_lo[d]) / s->gr_h);
  return c < 0 ? 0 : c >= s->gr_nc[d] ? s->gr_nc[d] - 1 : c;
}

/* the grid cell of point p (row-major, x fastest) */
static inline size_t tlpd_gr_index(const tlpd_state *s, const ej_real *p)
{
  return ((size_t)tlpd_gr_cell(s, 2, p[2]) * (size_t)s->gr_nc[1] + (size_t)tlpd_gr_cell(s, 1, p[1])) * (size_t)s->gr_nc[0] +
         (size_t)tlpd_gr_cell(s, 0, p[0]);
}

static ej_err tlpd_grade_build(tlpd_state *s, const ej_set *set)
{
  const ej_idx n = ej_set_count(set);
  const ej_real *x0 = ej_set_field(set, "x0"), *vol0 = ej_set_field(set, "vol0");
  if (!x0) x0 = ej_set_field(set, "x");
  EJ_ENSURE(x0 && vol0, EJ_ERR_INTERNAL, "set '%s': positions or vol0 missing", s->name);
  const ej_real g = s->cfg.horizon_grading;
  ej_real dmin = HUGE_VAL, dmax = -HUGE_VAL, dxmax = 0, lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
  for (ej_idx i = 0; i < n; ++i) {
    const ej_real dx = tlpd_dx(s, vol0[i]), D = tlpd_delta(s, dx);
    dmin = fmin(dmin, D), dmax = fmax(dmax, D), dxmax = fmax(dxmax, dx);
    for (int d = 0; d < 3; ++d) lo[d] = fmin(lo[d], x0[3 * i + d]), hi[d] = fmax(hi[d], x0[3 * i + d]);
  }
  s->gr_dmax = dmax;
  if (!(dmax > dmin)) return EJ_OK; /* uniform spacing: delta_i = m dx_i, no grid */
  const ej_real reach = (dmax - dmin) / g + dxmax;
  ej_real h = 0.25 * reach;
  size_t ncell;
  for (;;) {
    ncell = 1;
    for (int d = 0; d < 3; ++d) {
      s->gr_nc[d] = d < s->dim ? (int)fmin(floor((hi[d] - lo[d]) / h) + 1, 1e6) : 1;
      ncell *= (size_t)s->gr_nc[d];
    }
    if (ncell <= 4 * (size_t)n + 64) break;
    h *= 1.5;
  }
  s->gr_h = h;
  for (int d = 0; d < 3; ++d) s->gr_lo[d] = lo[d];
  s->gr_start = ej_calloc(ncell + 1, sizeof *s->gr_start);
  s->gr_cmax = ej_malloc(ncell * sizeof *s->gr_cmax);
  s->gr_ub = ej_malloc(ncell * sizeof *s->gr_ub);
  ej_real *tmp = ej_malloc(ncell * sizeof *tmp);
  EJ_ENSURE(s->gr_start && s->gr_cmax && s->gr_ub && tmp, EJ_ERR_MEM, "set '%s': out of memory (horizon_grading)", s->name);
  size_t ns = 0;
  for (size_t c = 0; c < ncell; ++c) s->gr_cmax[c] = -HUGE_VAL;
  for (ej_idx i = 0; i < n; ++i) {
    const ej_real dx = tlpd_dx(s, vol0[i]), D = tlpd_delta(s, dx);
    if (!(D > dmin)) continue;
    const size_t c = tlpd_gr_index(s, x0 + 3 * i);
    s->gr_start[c + 1]++;
    s->gr_cmax[c] = fmax(s->gr_cmax[c], D);
    ++ns;
  }
  for (size_t c = 0; c < ncell; ++c) s->gr_start[c + 1] += s->gr_start[c];
  s->gr_pts = ej_malloc((ns ? ns : 1) * 5 * sizeof *s->gr_pts);
  ej_idx *fill = ej_malloc(ncell * sizeof *fill);
  if (!s->gr_pts || !fill) {
    ej_free(tmp), ej_free(fill);
    EJ_FAIL(EJ_ERR_MEM, "set '%s': out of memory (horizon_grading)", s->name);
  }
  memcpy(fill, s->gr_start, ncell * sizeof *fill);
  for (ej_idx i = 0; i < n; ++i) {
    const ej_real dx = tlpd_dx(s, vol0[i]), D = tlpd_delta(s, dx);
    if (!(D > dmin)) continue;
    const size_t c = tlpd_gr_index(s, x0 + 3 * i);
    ej_real *q = s->gr_pts + 5 * (size_t)fill[c]++;
    q[0] = x0[3 * i], q[1] = x0[3 * i + 1], q[2] = x0[3 * i + 2], q[3] = D, q[4] = dx;
  }
  ej_free(fill);
  /* per-cell bound: ub_c = max_k (M_k(c) - g max(0, (k - 1) h - dx_max)), M_k the largest cmax
   * within k cells (Chebyshev; a cube max filter applied k times). Points of cells k apart are at
   * least (k - 1) h apart, so ub_c >= delta_i of every particle in the cell. */
  const int K = (int)ceil(reach / h) + 1;
  memcpy(tmp, s->gr_cmax, ncell * sizeof *tmp);
  for (size_t c = 0; c < ncell; ++c) s->gr_ub[c] = tmp[c];
  const size_t st[3] = {1, (size_t)s->gr_nc[0], (size_t)s->gr_nc[0] * (size_t)s->gr_nc[1]};
  for (int k = 1; k <= K; ++k) {
    for (int d = 0; d < s->dim; ++d) { /* radius-1 max filter along d, in place over a line buffer */
      const size_t nd = (size_t)s->gr_nc[d];
      for (size_t c = 0; c < ncell; ++c) {
        if ((c / st[d]) % nd != 0) continue; /* line starts */
        ej_real prev = -HUGE_VAL, cur = tmp[c];
        for (size_t q = 0; q < nd; ++q) {
          const ej_real next = q + 1 < nd ? tmp[c + (q + 1) * st[d]] : -HUGE_VAL;
          tmp[c + q * st[d]] = fmax(cur, fmax(prev, next));
          prev = cur, cur = next;
        }
      }
    }
    const ej_real pen = g * fmax(0, (k - 1) * h - dxmax);
    for (size_t c = 0; c < ncell; ++c) s->gr_ub[c] = fmax(s->gr_ub[c], tmp[c] - pen);
  }
  ej_free(tmp);
  return EJ_OK;
}

/* delta of a particle at p with spacing dx (the rule above) */
static ej_real tlpd_grade(const tlpd_state *s, const ej_real *p, ej_real dx)
{
  const ej_real D = tlpd_delta(s, dx);
  if (!s->gr_pts || !(D < s->gr_dmax)) return D;
  if (!(s->gr_ub[tlpd_gr_index(s, p)] > D)) return D;
  int c0[3];
  for (int d = 0; d < 3; ++d) c0[d] = tlpd_gr_cell(s, d, p[d]);
  const ej_real g = s->cfg.horizon_grading, h = s->gr_h;
  const int K = (int)ceil(((s->gr_dmax - D) / g + s->gr_dmax) / h) + 1; /* dx_j <= D_max */
  int a[3], b[3];
  for (int d = 0; d < 3; ++d) {
    a[d] = c0[d] - K < 0 ? 0 : c0[d] - K;
    b[d] = c0[d] + K >= s->gr_nc[d] ? s->gr_nc[d] - 1 : c0[d] + K;
  }
  ej_real best = D;
  for (int cz = a[2]; cz <= b[2]; ++cz)
    for (int cy = a[1]; cy <= b[1]; ++cy)
      for (int cx = a[0]; cx <= b[0]; ++cx) {
        const size_t c = ((size_t)cz * (size_t)s->gr_nc[1] + (size_t)cy) * (size_t)s->gr_nc[0] + (size_t)cx;
        if (!(s->gr_cmax[c] > best)) continue;
        const int cc[3] = {cx, cy, cz};
        ej_real bd2 = 0; /* squared distance from p to the cell's box */
        for (int d = 0; d < s->dim; ++d) {
          const ej_real l = s->gr_lo[d] + cc[d] * h, u = l + h;
          const ej_real e = p[d] < l ? l - p[d] : p[d] > u ? p[d] - u : 0;
          bd2 += e * e;
        }
        if (!(s->gr_cmax[c] - g * fmax(0, sqrt(bd2) - 0.5 * (dx + s->gr_dmax)) > best)) continue;
        for (ej_idx k = s->gr_start[c]; k < s->gr_start[c + 1]; ++k) {
          const ej_real *q = s->gr_pts + 5 * (size_t)k;
          const ej_real X0 = q[0] - p[0], X1 = q[1] - p[1], X2 = q[2] - p[2];
          const ej_real v = q[3] - g * fmax(0, sqrt(X0 * X0 + X1 * X1 + X2 * X2) - 0.5 * (dx + q[4]));
          best = v > best ? v : best;
        }
      }
  return best;
}

static ej_err tlpd_support(void *state, const ej_set *set, ej_range r, ej_real *radius)
{
  tlpd_state *s = state;
  const ej_real *vol0 = ej_set_field(set, "vol0");
  EJ_ENSURE(vol0, EJ_ERR_INTERNAL, "set '%s': vol0 missing", s->name);
  ej_real *hz = s->cfg.horizon_grading > 0 && !(s->cfg.horizon_length > 0) ? ej_set_field(set, "pd_horizon") : NULL;
  const ej_real *x0 = ej_set_field(set, "x0");
  if (!x0) x0 = ej_set_field(set, "x");
  if (hz && !atomic_load_explicit(&s->gr_ready, memory_order_acquire)) {
    ej_err rc = EJ_OK;
#pragma omp critical(tlpd_grade)
    {
      if (!atomic_load_explicit(&s->gr_ready, memory_order_relaxed)) {
        rc = tlpd_grade_build(s, set);
        if (rc == EJ_OK) atomic_store_explicit(&s->gr_ready, 1, memory_order_release);
      }
    }
    EJ_TRY(rc);
  }
  for (ej_idx i = r.begin; i < r.end; ++i) {
    const ej_real dx = tlpd_dx(s, vol0[i]);
    const ej_real d = hz ? (hz[i] = tlpd_grade(s, x0 + 3 * i, dx)) : tlpd_delta(s, dx);
    radius[i - r.begin] = d + (s->cfg.partial_volume ? 0.5 * dx : 0.0);
  }
  return EJ_OK;
}

static ej_err tlpd_setup(void *state, ej_set *set)
{
  const tlpd_state *s = state;
  const ej_idx n = ej_set_count(set);
  const ej_real *x = ej_set_field(set, "x"), *m = ej_set_field(set, "m"), *vol0 = ej_set_field(set, "vol0");
  ej_real *xp = ej_set_field(set, "x_prev");
  EJ_ENSURE(x && m && vol0 && xp, EJ_ERR_INTERNAL, "set '%s': tlpd fields missing", s->name);
  for (ej_idx i = 0; i < n; ++i) {
    EJ_ENSURE(m[i] > 0 && vol0[i] > 0, EJ_ERR_INPUT, "set '%s': particle %d has mass %g, volume %g", s->name, (int)i,
              m[i], vol0[i]);
    memcpy(xp + 3 * i, x + 3 * i, 3 * sizeof *x);
  }
  ej_real *stress = ej_set_field(set, "stress");
  EJ_ENSURE(stress, EJ_ERR_INTERNAL, "set '%s': tlpd field stress missing", s->name);
  return ej_initial_stress_apply(&s->cfg.initial_stress, set, stress);
}

/* ------------------------------------------------------------------ lazy allocation */

/* *a = max(*a, v) for a double v >= 0 (or NaN: +inf) stored as its bits: non-negative doubles order as
 * their bit patterns. */
static void tlpd_atomic_max(_Atomic uint64_t *a, ej_real v)
{
  uint64_t nv;
  memcpy(&nv, &v, sizeof nv);
  if (v != v) nv = UINT64_C(0x7ff0000000000000);
  uint64_t old = atomic_load_explicit(a, memory_order_relaxed);
  while (old < nv && !atomic_compare_exchange_weak_explicit(a, &old, nv, memory_order_relaxed, memory_order_relaxed)) {
  }
}

/* The bond-break skip's grid (tlpd_state.bk_*) over the owned particles' x0: cells as wide as the
 * shortest row's longest bond, at most 2^22 cells and blocks of at most 59 cells each way (wider
 * cells otherwise: the bound stays valid, only coarser). Row i's block radius bk_m[i] = its longest
 * bond over the cell size, rounded up. Without memory for it the skip is off (every row swept, as
 * before). */
static void tlpd_skip_setup(tlpd_state *s, ej_set *set)
{
  const ej_real *x0 = ej_set_field(set, "x0");
  const ej_idx n = s->n;
  s->bk_on = false;
  if (!x0 || n == 0) return;
  /* each row's longest bond (kept in bk_slack until the first sweep overwrites it); the cells are as
   * wide as the shortest of these, so that a refined zone's rows read a block of their own size */
  s->bk_slack = ej_calloc((size_t)n, sizeof *s->bk_slack);
  if (!s->bk_slack) return;
  ej_real lmin2 = HUGE_VAL, lmax2 = 0, lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
  for (ej_idx i = 0; i < n; ++i) {
    for (int a = 0; a < 3; ++a) lo[a] = fmin(lo[a], x0[3 * i + a]), hi[a] = fmax(hi[a], x0[3 * i + a]);
    ej_real l2 = 0;
    for (ej_off k = s->off[i]; k < s->off[i + 1]; ++k) {
      const ej_idx j = s->idx[k];
      const ej_real X0 = x0[3 * j] - x0[3 * i], X1 = x0[3 * j + 1] - x0[3 * i + 1], X2 = x0[3 * j + 2] - x0[3 * i + 2];
      l2 = fmax(l2, X0 * X0 + X1 * X1 + X2 * X2);
    }
    s->bk_slack[i] = sqrt(l2);
    if (l2 > 0) lmin2 = fmin(lmin2, l2), lmax2 = fmax(lmax2, l2);
  }
  if (!(lmax2 > 0) || !isfinite(lmax2)) return;
  ej_real L = sqrt(lmin2) * (1 + 1e-9);
  for (;;) {
    double cells = 1;
    for (int a = 0; a < 3; ++a) cells *= floor((hi[a] - lo[a]) / L) + 1;
    if (cells <= (double)(1 << 22) && sqrt(lmax2) / L < 60) break;
    L *= 1.25;
  }
  s->bk_ncell = 1;
  for (int a = 0; a < 3; ++a) {
    s->bk_lo[a] = lo[a];
    s->bk_nc[a] = (int)floor((hi[a] - lo[a]) / L) + 1;
    s->bk_ncell *= (size_t)s->bk_nc[a];
  }
  s->bk_inv = 1 / L;
  const size_t nn = (size_t)n;
  s->bk_cell = ej_malloc(nn * sizeof *s->bk_cell);
  s->bk_fseen = ej_calloc(nn, 1);
  s->bk_budget = ej_calloc(nn, sizeof *s->bk_budget);
  s->bk_m = ej_malloc(nn);
  s->bk_nskip = ej_calloc(nn, sizeof *s->bk_nskip);
  s->bk_hot = ej_calloc(nn, 1);
  s->bk_fsum = ej_calloc(nn, sizeof *s->bk_fsum);
  s->bk_gen = ej_calloc(nn, sizeof *s->bk_gen);
  s->bk_cf = ej_calloc(nn, 1);
  s->bk_gok = ej_calloc(nn, 1);
  s->bk_src = ej_malloc(nn * sizeof *s->bk_src);
  s->bk_dcell = ej_malloc(s->bk_ncell * sizeof *s->bk_dcell);
  s->bk_fcell = ej_malloc(s->bk_ncell * sizeof *s->bk_fcell);
  s->bk_tcell = ej_malloc(s->bk_ncell * sizeof *s->bk_tcell);
  if (!s->bk_cell || !s->bk_fseen || !s->bk_budget || !s->bk_slack || !s->bk_fsum || !s->bk_gen || !s->bk_cf ||
      !s->bk_dcell || !s->bk_fcell || !s->bk_tcell || !s->bk_gok || !s->bk_src || !s->bk_m || !s->bk_nskip || !s->bk_hot)
    return; /* tlpd_free_arrays frees what was allocated */
  /* owned ids: a permutation of 0..n-1 (sim.c numbers a set's particles, a sort permutes them);
   * otherwise the ghosts' sources are unknown and every row with a ghost neighbour sweeps */
  const int32_t *id = ej_set_field_int(set, "id");
  for (ej_idx i = 0; i < n; ++i) s->bk_src[i] = -1;
  bool perm = id != NULL;
  for (ej_idx i = 0; perm && i < n; ++i) {
    perm = id[i] >= 0 && id[i] < n && s->bk_src[id[i]] < 0;
    if (perm) s->bk_src[id[i]] = i;
  }
  if (!perm) memset(s->bk_gok, 2, nn);
  for (ej_idx i = 0; i < n; ++i) {
    int64_t c = 0;
    for (int a = 2; a >= 0; --a) {
      int q = (int)floor((x0[3 * i + a] - lo[a]) * s->bk_inv);
      q = q < 0 ? 0 : q >= s->bk_nc[a] ? s->bk_nc[a] - 1 : q;
      c = c * s->bk_nc[a] + q;
    }
    s->bk_cell[i] = (int32_t)c;
    const ej_real m = ceil(s->bk_slack[i] * s->bk_inv);
    s->bk_m[i] = (uint8_t)(m < 1 ? 1 : m);
    s->bk_slack[i] = 0;
  }
  for (size_t c = 0; c < s->bk_ncell; ++c) {
    atomic_init(&s->bk_dcell[c], UINT64_C(0x7ff0000000000000)); /* +inf until the first finish */
    atomic_init(&s->bk_fcell[c], 0);
    atomic_init(&s->bk_tcell[c], 0);
  }
  /* the breaks so far (a restart's pd_t_break; 0 for a row that never broke) */
  const ej_real *tbrk = ej_set_field(set, "pd_t_break");
  for (ej_idx i = 0; tbrk && i < n; ++i)
    if (tbrk[i] > 0) tlpd_atomic_max(&s->bk_tcell[s->bk_cell[i]], tbrk[i]);
  atomic_init(&s->bk_gen_now, 1);
  s->bk_on = s->bk_ncell <= (size_t)INT32_MAX;
}

static ej_err tlpd_alloc(tlpd_state *s, ej_set *set, const ej_nbr *nbr)
{
  const ej_idx n = ej_set_count(set);
  EJ_ENSURE(nbr && nbr->n_rows == n && ej_set_bond_flags(set), EJ_ERR_INTERNAL,
            "set '%s': tlpd reference family missing", s->name);
  /* the graded-horizon search grid served the support calls before the family was built */
  tlpd_grade_free(s);
  atomic_store(&s->gr_ready, 0);
  s->n = n;
  s->nb = nbr->off[n];
  s->off = nbr->off;
  s->idx = nbr->idx;
  const size_t nn = (size_t)n ? (size_t)n : 1, nb = (size_t)s->nb ? (size_t)s->nb : 1;
  s->wa = ej_malloc(nb * sizeof *s->wa);
  /* uniform spacing (every vol0 equal, ghosts included): w_j beta_j V_j = w_i beta_i V_j, so
   * the neighbour's weights are the owner's (half the per-bond weight memory and traffic) */
  {
    const ej_real *vol0 = ej_set_field(set, "vol0");
    const ej_idx nall = ej_set_count_all(set);
    bool uniform = vol0 != NULL;
    for (ej_idx i = 1; uniform && i < nall; ++i) uniform = vol0[i] == vol0[0];
    s->wb_alias = uniform;
  }
  s->wb = s->wb_alias ? s->wa : ej_malloc(nb * sizeof *s->wb);
  s->Kinv = ej_malloc(9 * nn * sizeof *s->Kinv);
  s->d6 = ej_calloc(6 * nn, sizeof *s->d6);
  s->wp = ej_calloc(nn, sizeof *s->wp);
  s->area = ej_calloc(nn, sizeof *s->area);
  s->row_ready = ej_calloc(nn, 1);
  s->row_intact = ej_calloc(nn, 1);
  s->aint = ej_calloc(3 * nn, sizeof *s->aint);
  s->vpred = ej_calloc(3 * nn, sizeof *s->vpred);
  s->vp_ok = ej_calloc(nn, 1);
  s->dxp = ej_calloc(nn, sizeof *s->dxp);
  s->nbroken = ej_calloc(nn, sizeof *s->nbroken);
  s->m1 = ej_calloc(3 * nn, sizeof *s->m1);
  s->mixed = ej_calloc(nn, 1);
  s->full = ej_calloc(nn, 1);
  s->gf_state = ej_calloc(nn, 1);
  s->egf = ej_calloc(3 * nn, sizeof *s->egf);
  s->n_fallback = ej_calloc(nn, sizeof *s->n_fallback);
  s->jmax = ej_calloc(nn, sizeof *s->jmax);
  s->notok = ej_calloc(nn, 1);
  s->hself = ej_calloc(nn, sizeof *s->hself);
  s->hsum = ej_calloc(nn, sizeof *s->hsum);
  {
    /* the time of the last bond break: -inf in a fresh run, the checkpoint's on a restart (bonds
     * break only in post_step, at t > 0) */
    const ej_real *tbrk = ej_set_field(set, "pd_t_break");
    ej_real tr = -INFINITY;
    for (ej_idx i = 0; i < n; ++i)
      if (tbrk[i] > 0) tr = fmax(tr, tbrk[i]);
    atomic_store(&s->t_refresh, tr);
  }
  if (s->eos) {
    s->p_eos = ej_calloc(nn, sizeof *s->p_eos);
    s->c_eos = ej_calloc(nn, sizeof *s->c_eos);
  }
  s->pfail = ej_calloc(nn, 1);
  if (s->cfg.failure.cut_distance > 0) s->cut_nf = ej_calloc(nn, sizeof *s->cut_nf);
  bool c_ok = true;
  if (s->cfg.contact != TLPD_CONTACT_OFF) {
    const ej_idx nall = ej_set_count_all(set);
    const size_t na = (size_t)nall ? (size_t)nall : 1;
    const ej_real *vol0 = ej_set_field(set, "vol0");
    ej_real vmin = HUGE_VAL;
    for (ej_idx i = 0; vol0 && i < nall; ++i) vmin = fmin(vmin, vol0[i]);
    s->c_dxmin = nall > 0 ? tlpd_dx(s, vmin) : 0;
    s->c_ncap = 4 * na + 64;
    s->kc = ej_calloc(nn, sizeof *s->kc);
    s->cc = ej_calloc(nn, sizeof *s->cc);
    s->avis = ej_calloc(3 * nn, sizeof *s->avis);
    s->ncont = ej_calloc(nn, sizeof *s->ncont);
    s->c_cellof = ej_malloc(na * sizeof *s->c_cellof);
    s->c_order = ej_malloc(na * sizeof *s->c_order);
    s->c_start = ej_malloc((s->c_ncap + 1) * sizeof *s->c_start);
    c_ok = s->kc && s->cc && s->avis && s->ncont && s->c_cellof && s->c_order && s->c_start && (nall == 0 || s->c_dxmin > 0);
  }
  if (!s->wa || !s->wb || !s->Kinv || !s->d6 || !s->wp || !s->area || !s->row_ready || !s->n_fallback || !s->row_intact || !s->aint || !s->vpred || !s->vp_ok || !s->dxp || !s->nbroken ||
      !s->m1 || !s->mixed || !s->full || !s->gf_state || !s->egf || !s->hself || !s->hsum ||
      !s->jmax || !s->notok || (s->eos && (!s->p_eos || !s->c_eos)) || !s->pfail || !c_ok ||
      (s->cfg.failure.cut_distance > 0 && !s->cut_nf)) {
    tlpd_free_arrays(s);
    s->wa = s->wb = NULL;
    s->Kinv = s->d6 = s->wp = s->area = s->p_eos = s->c_eos = NULL;
    s->row_ready = s->row_intact = s->vp_ok = NULL;
    s->aint = s->vpred = NULL;
    s->m1 = s->hself = s->hsum = s->dxp = NULL;
    s->nbroken = NULL;
    s->n_fallback = NULL;
    s->mixed = s->full = s->gf_state = NULL;
    s->egf = NULL;
    s->jmax = NULL;
    s->notok = NULL;
    s->pfail = NULL;
    s->cut_nf = NULL;
    s->kc = s->cc = s->avis = NULL;
    s->ncont = NULL;
    s->c_cellof = s->c_start = NULL;
    s->c_order = NULL;
    EJ_FAIL(EJ_ERR_MEM, "set '%s': tlpd out of memory for %lld bonds", s->name, (long long)s->nb);
  }
  /* without a critical stretch only failed ends break bonds: no skip (nor its memory and finish) */
  if (s->cfg.break_skip && s->cfg.failure.critical_stretch > 0) tlpd_skip_setup(s, set);
  return EJ_OK;
}

/* K_i^-1, status, coefficient and damage of row i over its intact bonds (000 Eqs 16-17,
 * section 5 for a particle without bonds; 002 section 1.3 for a singular K). */
static void tlpd_refresh_row_(tlpd_state *s, ej_set *set, const ej_nbr *nbr, ej_idx i)
{
  const ej_real *x0 = ej_set_field(set, "x0"), *vol0 = ej_set_field(set, "vol0");
  int32_t *status = ej_set_field_int(set, "pd_status");
  ej_real *coef = ej_set_field(set, "pd_coef"), *damage = ej_set_field(set, "damage");
  ej_real *hsum_f = ej_set_field(set, "pd_hsum");
  const uint8_t *flags = ej_set_bond_flags(set);
  const int dim = s->dim;
  s->hself[i] = s->hsum[i] = hsum_f[i] = 0;
  ej_real K[9] = {0}, m1 = 0, wsum = 0, vall = 0, vint = 0, M1[3] = {0, 0, 0};
  int nint = 0;
  int32_t nbr_broken = 0;
  for (ej_off k = nbr->off[i]; k < nbr->off[i + 1]; ++k) nbr_broken += (flags[k] & TLPD_BROKEN) != 0;
  s->row_intact[i] = nbr_broken == 0;
  s->nbroken[i] = nbr_broken;
  for (ej_off k = nbr->off[i]; k < nbr->off[i + 1]; ++k) {
    const ej_real w = s->wa[k];
    if (w <= 0) continue;
    const ej_idx j = nbr->idx[k];
    vall += vol0[j];
    if (flags[k] & TLPD_BROKEN) continue;
    vint += vol0[j];
    ++nint;
    const ej_real X[3] = {x0[3 * j] - x0[3 * i], x0[3 * j + 1] - x0[3 * i + 1], x0[3 * j + 2] - x0[3 * i + 2]};
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) K[3 * a + b] += w * X[a] * X[b];
    m1 += w * sqrt(X[0] * X[0] + X[1] * X[1] + X[2] * X[2]);
    for (int a = 0; a < 3; ++a) M1[a] += w * X[a];
    wsum += w;
  }
  memcpy(s->m1 + 3 * i, M1, sizeof M1);
  s->gf_state[i] = 0; /* ghost-force vector recomputed at the next force pass */
  ej_set_field_int(set, "pd_fprev")[i] = 0; /* the bond set changed: F of the previous step is not N_n K^-1 */
  damage[i] = vall > 0 ? 1 - vint / vall : 1;
  ej_real *Ki = s->Kinv + 9 * i;
  ej_m3_identity(Ki);
  if (nint == 0) {
    status[i] = TLPD_DETACHED;
    coef[i] = 0;
    return;
  }
  ej_real trK = 0;
  for (int a = 0; a < dim; ++a) trK += K[4 * a];
  for (int a = dim; a < 3; ++a) K[4 * a] = 1; /* pad unused dimensions */
  /* scale to O(1) before the condition estimate so that the pad does not dominate */
  const ej_real sc = trK > 0 ? dim / trK : 1;
  ej_real Ks[9];
  for (int k = 0; k < 9; ++k) Ks[k] = K[k] * sc;
  for (int a = dim; a < 3; ++a) Ks[4 * a] = 1;
  ej_real Kis[9];
  const ej_real rc = ej_m3_inverse(Kis, Ks);
  if (!(rc >= s->cfg.min_rcond) || rc == 0) {
    status[i] = TLPD_FALLBACK;
    /* bond-based micromodulus matching the bulk energy of an isotropic stretch s over the
     * discrete family: (1/4) c s^2 sum w |X| = dim^2 Kd s^2 / 2 (Silling & Askari 2005 in the
     * continuum 3D limit, c = 18 K / (pi delta^4) for w = 1). */
    coef[i] = m1 > 0 ? 2.0 * dim * dim * s->Kd / m1 : 0;
    return;
  }
  for (int k = 0; k < 9; ++k) Ki[k] = Kis[k] * sc;
  for (int a = dim; a < 3; ++a) Ki[4 * a] = 1;
  status[i] = TLPD_OK;
  /* the row's gradient weights g_l = w V_l K^-1 X_l and g_i = -K^-1 m1 (grad u_i = sum_l u_l g_l
   * + u_i g_i) for the stable step (tlpd_stable_dt) */
  {
    ej_real u[3], hs = 0;
    for (ej_off k = nbr->off[i]; k < nbr->off[i + 1]; ++k) {
      const ej_real w = s->wa[k];
      if (w <= 0 || (flags[k] & TLPD_BROKEN)) continue;
      const ej_idx j = nbr->idx[k];
      const ej_real X[3] = {x0[3 * j] - x0[3 * i], x0[3 * j + 1] - x0[3 * i + 1], x0[3 * j + 2] - x0[3 * i + 2]};
      ej_m3_apply(u, Ki, X);
      hs += w * sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    }
    ej_m3_apply(u, Ki, M1);
    s->hself[i] = sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    s->hsum[i] = hsum_f[i] = hs + s->hself[i];
  }
  switch (s->cfg.hourglass) {
  case TLPD_HG_ZHU_ZHAO: coef[i] = 2 * s->cfg.hourglass_coefficient * s->E / trK; break;
  case TLPD_HG_SILLING: coef[i] = wsum > 0 ? 2 * s->cfg.hourglass_coefficient * s->G / wsum : 0; break;
  default: coef[i] = 0;
  }
}

/* refresh_row_ and the count of rows that are not correspondence points (n_notok) */
static void tlpd_refresh_row(tlpd_state *s, ej_set *set, const ej_nbr *nbr, ej_idx i)
{
  tlpd_refresh_row_(s, set, nbr, i);
  const int32_t *status = ej_set_field_int(set, "pd_status");
  const uint8_t bad = status[i] != TLPD_OK;
  if (bad != s->notok[i]) {
    s->notok[i] = bad;
    atomic_fetch_add_explicit(&s->n_notok, bad ? 1 : -1, memory_order_relaxed);
  }
}

static inline ej_real tlpd_traction_p(const tlpd_traction_cfg *t, ej_real time)
{
  if (t->pressure == 0) return 0;
  if (t->frequency > 0) return 0.5 * t->pressure * (1 - cos(t->frequency * time));
  if (t->rise_time > 0 && time < t->rise_time) return t->pressure * time / t->rise_time;
  return t->pressure;
}

static void tlpd_init_row(tlpd_state *s, ej_set *set, const ej_nbr *nbr, ej_idx i)
{
  const ej_real *x0 = ej_set_field(set, "x0"), *vol0 = ej_set_field(set, "vol0");
  const ej_real *hz = ej_set_field(set, "pd_horizon"); /* horizon_grading (NULL: delta = m dx) */
  const ej_real dxi = tlpd_dx(s, vol0[i]), di = hz ? hz[i] : tlpd_delta(s, dxi);
  s->dxp[i] = dxi;
  ej_idx jm = 0;
  for (ej_off k = nbr->off[i]; k < nbr->off[i + 1]; ++k) jm = nbr->idx[k] > jm ? nbr->idx[k] : jm;
  s->jmax[i] = jm;
  ej_real vball = 0; /* sum of beta V over the family, against the horizon ball's volume */
  for (ej_off k = nbr->off[i]; k < nbr->off[i + 1]; ++k) {
    const ej_idx j = nbr->idx[k];
    const ej_real X[3] = {x0[3 * j] - x0[3 * i], x0[3 * j + 1] - x0[3 * i + 1], x0[3 * j + 2] - x0[3 * i + 2]};
    const ej_real r = sqrt(X[0] * X[0] + X[1] * X[1] + X[2] * X[2]);
    s->wa[k] = (tlpd_wt)(tlpd_weight(&s->cfg, r, di, dxi) * vol0[j]);
    if (vol0[j] != vol0[i] || (hz && hz[j] != hz[i])) s->mixed[i] = 1; /* another spacing or horizon */
    if (s->mixed[i] || vol0[j] != vol0[i]) { /* the neighbour's cell, of its own size, inside the ball */
      const ej_real dxj = tlpd_dx(s, vol0[j]);
      vball += fmin(1, fmax(0, (di + 0.5 * dxj - r) / dxj)) * vol0[j];
    } else {
      vball += fmin(1, fmax(0, (di + 0.5 * dxi - r) / dxi)) * vol0[j];
    }
    if (!s->wb_alias) {
      const ej_real dxj = tlpd_dx(s, vol0[j]), dj = hz ? hz[j] : tlpd_delta(s, dxj);
      s->wb[k] = (tlpd_wt)(tlpd_weight(&s->cfg, r, dj, dxj) * vol0[j]);
    }
  }
  vball += vol0[i];
  const ej_real ball = s->dim == 3 ? 4.0 / 3.0 * M_PI * di * di * di : s->dim == 2 ? M_PI * di * di : 2 * di;
  s->full[i] = vball >= 0.85 * ball;
  const tlpd_traction_cfg *t = &s->cfg.traction;
  s->area[i] = 0;
  if (t->pressure != 0) {
    bool in = true;
    for (int k = 0; k < 3; ++k) in = in && x0[3 * i + k] >= t->lo[k] && x0[3 * i + k] <= t->hi[k];
    if (in) s->area[i] = vol0[i] / dxi;
  }
  /* the first row set-up is not a change of the bond set: on a restart the checkpoint's F and
   * pd_fprev stay valid (in a fresh run pd_fprev is still 0 here) */
  int32_t *fprev = ej_set_field_int(set, "pd_fprev");
  const int32_t keep = fprev[i];
  tlpd_refresh_row(s, set, nbr, i);
  fprev[i] = keep;
  s->row_ready[i] = 1;
}

/* ------------------------------------------------------------------ pass 0: kinematics, stress */

static ej_err tlpd_bad(const tlpd_state *s, const ej_set *set, ej_idx i, const char *what, ej_real val)
{
  const ej_real *x = ej_set_field(set, "x");
  const int32_t *id = ej_set_field_int(set, "id");
  EJ_FAIL(EJ_ERR_NUMERIC, "set '%s': tlpd particle id %d at (%g, %g, %g): %s = %g", s->name, id ? (int)id[i] : (int)i,
          x[3 * i], x[3 * i + 1], x[3 * i + 2], what, val);
}

/* inversion: point_failure (issue 8): particle i, whose F is inverted or singular (det F <= 0,
 * det F_n+1/2 = 0, or no Hughes-Winget rotation), is detached for the rest of this step (status
 * TLPD_DETACHED: F = I, P = 0, no hourglass force; its neighbours' force states on it still act,
 * so momentum stays exact) and flagged `failed` after the material batch, so that post_step breaks
 * every bond at both ends (the point failure of 000 section 5, symmetric). Counted in pfail. */
static void tlpd_point_fail(tlpd_state *s, int32_t *status, int32_t *fprev, ej_idx i)
{
  status[i] = TLPD_DETACHED;
  s->pfail[i] = 1;
  fprev[i] = 0;
  if (!s->notok[i]) {
    s->notok[i] = 1;
    atomic_fetch_add_explicit(&s->n_notok, 1, memory_order_relaxed);
  }
}

static ej_err tlpd_pass_kinematics(tlpd_state *s, ej_set *set, const ej_nbr *nbr, ej_range r)
{
  const ej_real *restrict x = ej_set_field(set, "x"), *restrict v = ej_set_field(set, "v");
  const ej_real *restrict xp = ej_set_field(set, "x_prev"), *restrict x0 = ej_set_field(set, "x0");
  const ej_real *restrict m = ej_set_field(set, "m"), *restrict vol0 = ej_set_field(set, "vol0");
  ej_real *restrict F = ej_set_field(set, "F"), *restrict PK = ej_set_field(set, "PK");
  ej_real *restrict P = ej_set_field(set, "P"), *restrict stress = ej_set_field(set, "stress");
  ej_real *restrict rho = ej_set_field(set, "rho"), *restrict e = ej_set_field(set, "e");
  ej_real *restrict e_dot = ej_set_field(set, "e_dot"), *restrict c = ej_set_field(set, "c");
  ej_real *restrict w_pl = ej_set_field(set, "w_plastic");
  int32_t *restrict status = ej_set_field_int(set, "pd_status"), *restrict failed = ej_set_field_int(set, "failed");
  int32_t *restrict fprev = ej_set_field_int(set, "pd_fprev");
  const uint8_t *restrict flags = ej_set_bond_flags(set);
  ej_real *restrict w_dot = ej_set_field(set, "w_hg_dot"), *restrict G = ej_set_field(set, "G_pk");
  ej_real *restrict Kinv_f = ej_set_field(set, "K_inv");
  const ej_real *restrict coef = ej_set_field(set, "pd_coef");
  EJ_ENSURE(x && v && xp && x0 && m && vol0 && F && PK && stress && rho && e && e_dot && c && w_pl && status && failed &&
                w_dot && G && coef && Kinv_f,
            EJ_ERR_INTERNAL, "set '%s': tlpd fields missing", s->name);
  const ej_off *restrict off = nbr->off;
  const ej_idx *restrict idx = nbr->idx;
  const tlpd_wt *restrict wa = s->wa;
  const ej_idx nall = ej_set_count_all(set);
  const ej_real dt = ej_set_dt(set);
  const int dim = s->dim;
  const bool objective = s->cfg.objective;
  const bool pfail_on = s->cfg.inversion == TLPD_INV_POINT_FAILURE;

  memcpy(s->vpred + 3 * (size_t)r.begin, v + 3 * (size_t)r.begin, 3 * (size_t)(r.end - r.begin) * sizeof *v);
  memset(s->vp_ok + r.begin, 1, (size_t)(r.end - r.begin));
  /* the bond-break skip's displacement maxima are measured afresh by this evaluation's finish
   * (nothing else reads or writes them during the passes) */
  if (s->bk_on && r.begin == 0)
    for (size_t c = 0; c < s->bk_ncell; ++c) atomic_store_explicit(&s->bk_dcell[c], 0, memory_order_relaxed);
  for (ej_idx i = r.begin; i < r.end; ++i) {
    if (!s->row_ready[i]) tlpd_init_row(s, set, nbr, i);
    ej_real *Fi = F + 9 * i, *di = s->d6 + 6 * i;
    ej_real N[9] = {0}, Nd[9] = {0}, Nv[9] = {0}, SYV = 0;
    if (status[i] == TLPD_OK) {
      const ej_real xi0 = x[3 * i], xi1 = x[3 * i + 1], xi2 = x[3 * i + 2];
      const ej_real vi0 = v[3 * i], vi1 = v[3 * i + 1], vi2 = v[3 * i + 2];
      const ej_real Xi0 = x0[3 * i], Xi1 = x0[3 * i + 1], Xi2 = x0[3 * i + 2];
      /* With the same bonds as at the previous step, N_n K^-1 is the F of that step (x_prev is
       * the x of that step's force evaluation), so grad_X du = F_n+1 - F_n (Eq 80) without a
       * third bond sum. The flag is set only by post_step (x_prev := x after this pass), and
       * cleared by a change of the bond set and at a restart; otherwise the sum is taken. */
      const bool prev = fprev[i] != 0;
      if (prev) {
        /* 4-wide (GCC/Clang vector extension, lane 3 unused): N += Y (x) wX, Nv += V (x) wX;
         * the same operations per element as the scalar form (7 vector accumulators instead
         * of 19 scalars, which spilled) */
        const tlpd_v4 Xi = TLPD_LD3(x0 + 3 * i), xi = TLPD_LD3(x + 3 * i), vi = TLPD_LD3(v + 3 * i);
        tlpd_v4 n0 = {0}, n1 = {0}, n2 = {0}, v0 = {0}, v1 = {0}, v2 = {0}, syv = {0};
        const bool intact = s->row_intact[i];
        if (intact && s->jmax[i] + 1 < nall) {
          /* the common row: no broken bond, every neighbour's 4-wide load inside the arrays, no
           * per-bond test; by columns, c_b += Y wX_b, cv_b += V wX_b (one broadcast of wX_b serves
           * N and Nv). Every element sums the same products in the same order as the general
           * loop's rows n_a, v_a below: bitwise the same sums. */
          tlpd_v4 c0 = {0}, c1 = {0}, c2 = {0}, cv0 = {0}, cv1 = {0}, cv2 = {0};
          for (ej_off k = off[i]; k < off[i + 1]; ++k) {
            const ej_real w = wa[k];
            const size_t j3 = 3 * (size_t)idx[k];
            const tlpd_v4 X = w * (TLPD_LD4(x0 + j3) - Xi);
            const tlpd_v4 Y = TLPD_LD4(x + j3) - xi, V = TLPD_LD4(v + j3) - vi;
            syv += w * (Y * V);
            c0 += Y * X[0], c1 += Y * X[1], c2 += Y * X[2];
            cv0 += V * X[0], cv1 += V * X[1], cv2 += V * X[2];
          }
          /* back to rows (n_a[b] = c_b[a]) */
          n0 = (tlpd_v4){c0[0], c1[0], c2[0], 0}, n1 = (tlpd_v4){c0[1], c1[1], c2[1], 0};
          n2 = (tlpd_v4){c0[2], c1[2], c2[2], 0};
          v0 = (tlpd_v4){cv0[0], cv1[0], cv2[0], 0}, v1 = (tlpd_v4){cv0[1], cv1[1], cv2[1], 0};
          v2 = (tlpd_v4){cv0[2], cv1[2], cv2[2], 0};
        } else {
          for (ej_off k = off[i]; k < off[i + 1]; ++k) {
            if (!intact && (flags[k] & TLPD_BROKEN)) continue;
            const ej_real w = wa[k];
            const ej_idx j = idx[k];
            const tlpd_v4 X = w * (TLPD_LDJ(x0, j, nall) - Xi);
            const tlpd_v4 Y = TLPD_LDJ(x, j, nall) - xi, V = TLPD_LDJ(v, j, nall) - vi;
            syv += w * (Y * V);
            n0 += Y[0] * X, n1 += Y[1] * X, n2 += Y[2] * X;
            v0 += V[0] * X, v1 += V[1] * X, v2 += V[2] * X;
          }
        }
        SYV = syv[0] + syv[1] + syv[2];
        for (int b = 0; b < 3; ++b) {
          N[b] = n0[b], N[3 + b] = n1[b], N[6 + b] = n2[b];
          Nv[b] = v0[b], Nv[3 + b] = v1[b], Nv[6 + b] = v2[b];
        }
      } else {
        const ej_real ui0 = xi0 - xp[3 * i], ui1 = xi1 - xp[3 * i + 1], ui2 = xi2 - xp[3 * i + 2];
        for (ej_off k = off[i]; k < off[i + 1]; ++k) {
          if (flags[k] & TLPD_BROKEN) continue;
          const ej_real w = wa[k];
          const ej_idx j = idx[k];
          const ej_real X0 = w * (x0[3 * j] - Xi0), X1 = w * (x0[3 * j + 1] - Xi1), X2 = w * (x0[3 * j + 2] - Xi2);
          const ej_real Y[3] = {x[3 * j] - xi0, x[3 * j + 1] - xi1, x[3 * j + 2] - xi2};
          const ej_real U[3] = {x[3 * j] - xp[3 * j] - ui0, x[3 * j + 1] - xp[3 * j + 1] - ui1,
                                x[3 * j + 2] - xp[3 * j + 2] - ui2};
          const ej_real V[3] = {v[3 * j] - vi0, v[3 * j + 1] - vi1, v[3 * j + 2] - vi2};
          SYV += w * (Y[0] * V[0] + Y[1] * V[1] + Y[2] * V[2]);
          for (int a = 0; a < 3; ++a) {
            N[3 * a] += Y[a] * X0, N[3 * a + 1] += Y[a] * X1, N[3 * a + 2] += Y[a] * X2;
            Nd[3 * a] += U[a] * X0, Nd[3 * a + 1] += U[a] * X1, Nd[3 * a + 2] += U[a] * X2;
            Nv[3 * a] += V[a] * X0, Nv[3 * a + 1] += V[a] * X1, Nv[3 * a + 2] += V[a] * X2;
          }
        }
      }
      const ej_real *Ki = s->Kinv + 9 * i;
      ej_real dF[9], Fd[9], Fn[9];
      memcpy(Fn, Fi, sizeof Fn);
      ej_m3_mul(Fi, N, Ki);
      if (prev)
        for (int k = 0; k < 9; ++k) dF[k] = Fi[k] - Fn[k];
      else
        ej_m3_mul(dF, Nd, Ki);
      ej_m3_mul(Fd, Nv, Ki);
      fprev[i] = 0; /* set again by post_step, when x_prev becomes this x */
      for (int a = dim; a < 3; ++a) Fi[4 * a] = 1, dF[4 * a] = 0, Fd[4 * a] = 0;
      /* 000 Eqs 79, 88-90: h = grad_X du F_n+1/2^-1 */
      ej_real Fh[9], Fhi[9], h[9];
      for (int k = 0; k < 9; ++k) Fh[k] = Fi[k] - 0.5 * dF[k];
      if (ej_m3_inverse(Fhi, Fh) == 0) {
        if (!pfail_on) return tlpd_bad(s, set, i, "det F_n+1/2", ej_m3_det(Fh));
        goto inverted;
      }
      ej_real d6h[6];
      if (objective || s->cfg.nonobjective == TLPD_NONOBJ_RATE) {
        /* objective: false with nonobjective: rate skips only the rotation below (000 Eq 92
         * with sigma_hat = sigma_n): d from the spatial increment gradient is zero for a rigid
         * rotation, but a stressed rotating body keeps its stress in the old orientation */
        ej_m3_mul(h, dF, Fhi);
        ej_m3_sym(d6h, h);
      } else {
        /* objective: false, nonobjective: small_strain: infinitesimal-strain
         * increments from the reference gradient, sym(grad_X du), no push-forward by F^-1 and no
         * rotation of the stress. Not objective: a rigid rotation by theta accumulates the
         * strain sym(R - I) (cos theta - 1 in the plane of rotation), so a spinning body is
         * strained (a stress-free soil cylinder flies apart, a stiff one's speeds diverge at
         * 0.84 ms: validation/tlpd_rotation). nonobjective: small_strain; demonstration only. */
        ej_m3_sym(d6h, dF);
      }
      for (int k = 0; k < 6; ++k) di[k] = dt > 0 ? d6h[k] / dt : 0;
      if (objective && dt > 0) {
        ej_real om[9], Q[9];
        ej_m3_skew(om, h);
        /* Lambda = (I - omega/2)^-1 (I + omega/2) (Eq 94, alpha = 1/2); sigma_hat = Lambda sigma Lambda^T */
        if (!ej_hughes_winget(Q, om, 1.0)) {
          if (!pfail_on) return tlpd_bad(s, set, i, "Hughes-Winget |omega|", ej_m3_norm(om));
          goto inverted;
        }
        ej_s6_rotate(stress + 6 * i, Q, stress + 6 * i);
      }
      const ej_real J = ej_m3_det(Fi);
      if (!(J > 0)) {
        if (!pfail_on) return tlpd_bad(s, set, i, "det F", J);
        goto inverted;
      }
      rho[i] = m[i] / (vol0[i] * J);
      /* keep Fd for the stress power below: stash in PK (overwritten after the material) */
      memcpy(PK + 9 * i, Fd, sizeof Fd);
      /* power of the 002 hourglass forces of row i, sum_j C w V_j (Y - F X).(v_j - v_i)
       * = C (sum_j w V_j Y.V - F : Nv), from the sums of this pass (no second bond loop) */
      if (s->cfg.hourglass == TLPD_HG_ZHU_ZHAO && coef[i] > 0) {
        ej_real FN = 0;
        for (int k = 0; k < 9; ++k) FN += Fi[k] * Nv[k];
        const ej_real ehg = coef[i] * (SYV - FN) * vol0[i] / m[i];
        e_dot[i] += ehg;
        w_dot[i] += ehg;
      }
      continue;
    inverted:
      tlpd_point_fail(s, status, fprev, i);
    } /* not a correspondence point (fallback, detached, or point-failed just now) */
    ej_m3_identity(Fi);
    for (int k = 0; k < 6; ++k) di[k] = 0;
    rho[i] = m[i] / vol0[i];
  }
  /* the strength model over the range (VUMAT-like batch) */
  const ej_idx nr = r.end - r.begin;
  if (nr > 0) {
    ej_real *hist[TLPD_MAX_HIST], *hr[TLPD_MAX_HIST];
    const int nh = ej_set_hist(set, hist, TLPD_MAX_HIST);
    for (int k = 0; k < nh && k < TLPD_MAX_HIST; ++k) hr[k] = hist[k] + r.begin;
    ej_mat_batch b = {.n = nr, .dt = dt, .rho = rho + r.begin, .e = e + r.begin, .d = s->d6 + 6 * (size_t)r.begin,
                      .F = F + 9 * (size_t)r.begin, .p = NULL, .stress = stress + 6 * (size_t)r.begin,
                      .hist = hr, .c = c + r.begin, .w_plastic = s->wp + r.begin, .failed = failed + r.begin};
    if (s->eos) {
      EJ_TRY(ej_eos_evaluate_set(s->eos, set, r, rho + r.begin, e + r.begin, s->p_eos + r.begin, s->c_eos + r.begin));
      b.p = s->p_eos + r.begin;
    }
    EJ_TRY(ej_material_update(s->mat, &b));
  }
  bool any_failed = false;
  for (ej_idx i = r.begin; i < r.end; ++i) {
    w_pl[i] += s->wp[i];
    if (s->pfail[i]) failed[i] = 1; /* point failure at inversion: post_step breaks its bonds */
    any_failed |= failed[i] != 0;
    ej_real *PKi = PK + 9 * i;
    if (status[i] == TLPD_OK && pfail_on) {
      ej_real Ft[9];
      if (ej_m3_inverse(Ft, F + 9 * i) == 0) {
        tlpd_point_fail(s, status, fprev, i);
        failed[i] = 1;
        any_failed = true;
        ej_m3_identity(F + 9 * i);
      }
    }
    if (status[i] != TLPD_OK) {
      if (status[i] == TLPD_DETACHED) memset(stress + 6 * i, 0, 6 * sizeof *stress); /* 000 section 5: P = 0 */
      memset(PKi, 0, 9 * sizeof *PKi);
      memset(G + 9 * i, 0, 9 * sizeof *G);
      if (P) memset(P + 9 * i, 0, 9 * sizeof *P);
      continue;
    }
    const ej_real *Fi = F + 9 * i;
    ej_real Fd[9], Finv[9], sig[9], Pi[9];
    memcpy(Fd, PKi, sizeof Fd);
    if (ej_m3_inverse(Finv, Fi) == 0) return tlpd_bad(s, set, i, "det F", ej_m3_det(Fi));
    ej_s6_to_m3(sig, stress + 6 * i);
    /* P = J sigma F^-T (002 Eq 3 with the F^-T erratum) */
    ej_m3_mul_bt(Pi, sig, Finv);
    const ej_real J = ej_m3_det(Fi);
    ej_real pw = 0;
    for (int k = 0; k < 9; ++k) {
      Pi[k] *= J;
      pw += Pi[k] * Fd[k];
    }
    e_dot[i] += pw * vol0[i] / m[i];
    ej_m3_mul(PKi, Pi, s->Kinv + 9 * i);
    memcpy(Kinv_f + 9 * i, s->Kinv + 9 * i, 9 * sizeof *Kinv_f);
    if (P) memcpy(P + 9 * i, Pi, sizeof Pi);
    const ej_real Ci = s->cfg.hourglass == TLPD_HG_ZHU_ZHAO ? coef[i] : 0;
    /* stored by columns (G_pk[9i + 3c + r] = G_rc) for the 4-wide force loop */
    for (int rr = 0; rr < 3; ++rr)
      for (int cc = 0; cc < 3; ++cc) G[9 * i + 3 * cc + rr] = PKi[3 * rr + cc] - Ci * Fi[3 * rr + cc];
  }
  if (any_failed) atomic_store_explicit(&s->any_failed, 1, memory_order_relaxed);
  return EJ_OK;
}

/* ------------------------------------------------------------------ contact (issue 8) */

/* Short-range contact as LAMMPS pair peri applies it (pair_peri_pmb.cpp / pair_peri_lps.cpp
 * "short-range forces"; Silling & Askari 2005, the contact of their section 7; the same law as
 * ejecta's pd method, plugins/methods/pd/README.md): two particles closer than
 *   d_ij = min(0.9 |X_ij|, 1.35 lc_ij),   lc_ij = min(dx_i, dx_j) (LAMMPS: the lattice constant),
 * repel with the force density on i
 *   f_i = 15 c_s V_j (d_ij - r)/delta_ij (x_i - x_j)/r,   c_s = 18 K / (pi delta_ij^4)
 * (LAMMPS's kshort: the PMB micromodulus of the bulk modulus K; 2-D and 1-D: tlpd_contact_k),
 * delta_ij = (delta_i + delta_j)/2. Force V_i f_i = -(V_j f_j): antisymmetric, so momentum is
 * conserved to round-off; each row sums its own pairs (gather form). The pair is a spring of energy
 * U = V_i V_j 15 c_s (d - r)^2 / (2 delta); its power -dU/dt = F_ij.(v_i - v_j) is booked half per
 * end into e (e_dot_i -= F_ij.(v_i - v_j) / (2 m_i)), so kinetic + internal is conserved and the
 * core's budget closes (as the hourglass forces' power); the contact acceleration also enters aint,
 * so energy_correction's identity sum m (a_int.z + e_dot(z)) = 0 still holds. `unbonded` leaves out
 * pairs joined by an intact bond (the correspondence stress already resists their compression). */

/* dense grid over the bounding box of owned + ghost particles (serial, once per force pass; the
 * cells grow when fragments spread so far that they would outnumber 4 nall + 64, as pd's grid) */
static ej_err tlpd_contact_grid(tlpd_state *s, const ej_set *set)
{
  const ej_idx na = ej_set_count_all(set);
  const ej_real *x = ej_set_field(set, "x");
  const int dim = s->dim;
  ej_real lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
  for (int d = 0; d < dim; ++d) lo[d] = HUGE_VAL, hi[d] = -HUGE_VAL;
  for (ej_idx p = 0; p < na; ++p)
    for (int d = 0; d < dim; ++d) {
      const ej_real v = x[3 * (size_t)p + d];
      EJ_ENSURE(isfinite(v), EJ_ERR_NUMERIC, "set '%s': tlpd particle %d has a non-finite position", s->name, (int)p);
      lo[d] = v < lo[d] ? v : lo[d];
      hi[d] = v > hi[d] ? v : hi[d];
    }
  ej_real h = 1.35 * s->c_dxmin;
  size_t nc;
  for (;;) {
    nc = 1;
    for (int d = 0; d < 3; ++d) {
      s->c_gn[d] = d < dim && na ? (int64_t)floor((hi[d] - lo[d]) / h) + 1 : 1;
      nc *= (size_t)s->c_gn[d];
    }
    if (nc <= s->c_ncap) break;
    h *= 1.25;
  }
  s->c_gh = h;
  memcpy(s->c_glo, lo, sizeof lo);
  memset(s->c_start, 0, (nc + 1) * sizeof *s->c_start);
  const ej_real ih = 1.0 / h;
  for (ej_idx p = 0; p < na; ++p) {
    int64_t c = 0;
    for (int d = dim - 1; d >= 0; --d) {
      int64_t k = (int64_t)((x[3 * (size_t)p + d] - lo[d]) * ih);
      k = k < 0 ? 0 : k >= s->c_gn[d] ? s->c_gn[d] - 1 : k;
      c = c * s->c_gn[d] + k;
    }
    s->c_cellof[p] = (uint32_t)c;
    s->c_start[c + 1]++;
  }
  for (size_t c = 0; c < nc; ++c) s->c_start[c + 1] += s->c_start[c];
  for (ej_idx p = 0; p < na; ++p) s->c_order[s->c_start[s->c_cellof[p]]++] = p;
  for (size_t c = nc; c > 0; --c) s->c_start[c] = s->c_start[c - 1];
  s->c_start[0] = 0;
  return EJ_OK;
}

/* the first range of a force pass builds the grid (key: time and report's step epoch) */
static ej_err tlpd_contact_ready(tlpd_state *s, const ej_set *set)
{
  const double t = ej_set_time(set);
  const long long ep = atomic_load_explicit(&s->epoch, memory_order_acquire);
  if (atomic_load_explicit(&s->c_grid_t, memory_order_acquire) == t &&
      atomic_load_explicit(&s->c_grid_epoch, memory_order_acquire) == ep)
    return EJ_OK;
  ej_err rc = EJ_OK;
#pragma omp critical(tlpd_contact_grid)
  {
    if (!(atomic_load_explicit(&s->c_grid_t, memory_order_relaxed) == t &&
          atomic_load_explicit(&s->c_grid_epoch, memory_order_relaxed) == ep)) {
      rc = tlpd_contact_grid(s, set);
      if (rc == EJ_OK) {
        atomic_store_explicit(&s->c_grid_epoch, ep, memory_order_release);
        atomic_store_explicit(&s->c_grid_t, t, memory_order_release);
      }
    }
  }
  if (rc != EJ_OK) EJ_FAIL(rc, NULL);
  return EJ_OK;
}

/* intact bond i-j in row i's reference family (rows sorted ascending: binary search) */
static bool tlpd_bonded(const tlpd_state *s, const uint8_t *flags, ej_idx i, ej_idx j)
{
  ej_off lo = s->off[i], hi = s->off[i + 1];
  while (lo < hi) {
    const ej_off mid = lo + (hi - lo) / 2;
    if (s->idx[mid] < j) lo = mid + 1;
    else hi = mid;
  }
  return lo < s->off[i + 1] && s->idx[lo] == j && !(flags[lo] & TLPD_BROKEN);
}

/* contact_law impact (issue 8, fifth pass): LAMMPS's spring alone stores at most ~0.14 K/rho per
 * unit mass (149 m/s of relative speed for the buried-charge sand), so km/s interpenetration passes
 * through it. On a pair in contact (r < d_ij, as the spring) that approaches, w = (v_i - v_j).e < 0,
 * e = (x_i - x_j)/r, the impact law adds the pairwise viscous pressure of an artificial viscosity
 * (von Neumann-Richtmyer quadratic + Landshoff linear term, as SPH's Monaghan viscosity in pairwise
 * form: Monaghan 1992, Annu. Rev. Astron. Astrophys. 30, Eq 4.2, alpha c mu + beta mu^2, with the
 * pair's normal approach speed for mu), acting on the face A_ij = min(dx_i, dx_j)^2:
 *   F_i = A_ij rho_ij (alpha c_ij |w| + beta w^2) e,   F_j = -F_i,
 * rho_ij = (rho0_i + rho0_j)/2 (rho0 = m/vol0), c_ij = sqrt((K + 4G/3)/rho_ij). Every operand is
 * symmetric in i, j and enters with the same rounding from both rows, so F_j = -F_i bitwise
 * (momentum to round-off). Frictionless (along e only), never attractive (w < 0 only). Its power
 * F_i.(v_i - v_j) = -|F| |w| < 0 is heat: booked half per end into e like the spring's (so the
 * core's budget and energy_correction's identity stay exact) and, as dissipation, into w_contact
 * (EJ_ENERGY_VISCOUS, reported, already part of e) and the series contact_dissipated. Relative
 * motion of two equal particles: dw/ds = -(2/dx)(alpha c + beta |w|), i.e. the pair stops within
 * s = dx/(2 beta) ln(1 + beta |w0|/(alpha c)) of the contact distance (0.72 dx for 2 km/s, beta 2,
 * c = 240 m/s). No search-sourced formula of a PD contact of this form was found; this is ejecta's
 * law, documented in plugins/methods/tlpd/README.md. */

/* Spring constant of a contact pair, k = 15 c_s V_j / delta, with the PMB micromodulus of the
 * bulk modulus in the set's dimension (LAMMPS's kshort is the 3-D one, 18 K/(pi delta^4)): 2-D
 * 12 K/(pi delta^3) (Silling & Askari 2005's 2-D form, V_j an area), 1-D 2 K/delta^2 (V_j a
 * length). Until 2026-11-30 the 3-D formula served every dimension: with V_j an area it is
 * 1/delta times too large in units of metres, at a 0.8 mm rock spacing a spring 2/omega = 19 ns
 * against a 39 ns wave step (plugins/methods/tlpd/README.md, Limits). */
static inline ej_real tlpd_contact_k(const tlpd_state *s, ej_real dl, ej_real volj)
{
  if (s->dim == 3) return 15.0 * 18.0 * s->K / (M_PI * dl * dl * dl * dl * dl) * volj; /* as before, bitwise */
  if (s->dim == 2) return 15.0 * 12.0 * s->K / (M_PI * dl * dl * dl * dl) * volj;
  return 15.0 * 2.0 * s->K / (dl * dl * dl) * volj;
}

/* contact force density on row i (f), its power share (pw, W/m^3: e_dot_i += pw vol0_i / m_i; pv:
 * the dissipated part, >= 0), stiffness sum (ksum) and viscous coefficient sum (csum, N s/m);
 * cells scanned in a fixed order, so the sum does not depend on threads */
static int tlpd_contact_row(const tlpd_state *s, const ej_set *set, ej_idx i, ej_real f[3], ej_real *pw, ej_real *pv,
                            ej_real *fvis, ej_real *ksum, ej_real *csum)
{
  const ej_real *x = ej_set_field(set, "x"), *v = ej_set_field(set, "v"), *x0 = ej_set_field(set, "x0");
  const ej_real *vol0 = ej_set_field(set, "vol0"), *m = ej_set_field(set, "m");
  const uint8_t *flags = ej_set_bond_flags(set);
  const bool unb = s->cfg.contact == TLPD_CONTACT_UNBONDED;
  const bool imp = s->cfg.contact_law == TLPD_CLAW_IMPACT;
  const ej_real ca = s->cfg.contact_alpha, cb = s->cfg.contact_beta, Mlong = s->K + 4.0 / 3.0 * s->G;
  const ej_real rhoi = m[i] / vol0[i], dtn = imp ? ej_set_dt(set) : 0;
  ej_real qd = 0, cs = 0, fvx = 0, fvy = 0, fvz = 0;
  const ej_real xi = x[3 * i], yi = x[3 * i + 1], zi = x[3 * i + 2];
  const ej_real dxi = tlpd_dx(s, vol0[i]), di = tlpd_delta(s, dxi);
  const ej_real rc = 1.35 * dxi, rc2 = rc * rc; /* d_ij <= 1.35 min(dx_i, dx_j) <= 1.35 dx_i */
  const int64_t nx = s->c_gn[0], ny = s->c_gn[1], nz = s->c_gn[2], gr = (int64_t)ceil(rc / s->c_gh - 1e-9);
  const int64_t c = s->c_cellof[i], cx = c % nx, cy = (c / nx) % ny, cz = c / (nx * ny);
  const int64_t xl = cx - gr > 0 ? cx - gr : 0, xh = cx + gr < nx ? cx + gr : nx - 1;
  ej_real f0 = 0, f1 = 0, f2 = 0, p = 0, ks = 0;
  int cnt = 0;
  for (int64_t z = cz - gr; z <= cz + gr; ++z) {
    if (z < 0 || z >= nz) continue;
    for (int64_t y = cy - gr; y <= cy + gr; ++y) {
      if (y < 0 || y >= ny) continue;
      const int64_t base = (z * ny + y) * nx;
      for (uint32_t q = s->c_start[base + xl]; q < s->c_start[base + xh + 1]; ++q) {
        const ej_idx j = s->c_order[q];
        if (j == i) continue;
        const ej_real ex = xi - x[3 * j], ey = yi - x[3 * j + 1], ez = zi - x[3 * j + 2];
        const ej_real r2 = ex * ex + ey * ey + ez * ez;
        if (r2 >= rc2) continue;
        const ej_real dxj = vol0[j] == vol0[i] ? dxi : tlpd_dx(s, vol0[j]);
        const ej_real X0 = x0[3 * j] - x0[3 * i], X1 = x0[3 * j + 1] - x0[3 * i + 1], X2 = x0[3 * j + 2] - x0[3 * i + 2];
        const ej_real d = fmin(0.9 * sqrt(X0 * X0 + X1 * X1 + X2 * X2), 1.35 * fmin(dxi, dxj));
        if (r2 >= d * d) continue;
        if (unb && tlpd_bonded(s, flags, i, j)) continue;
        const ej_real dl = dxj == dxi ? di : 0.5 * (di + tlpd_delta(s, dxj));
        const ej_real k = tlpd_contact_k(s, dl, vol0[j]);
        const ej_real rr = sqrt(r2);
        ej_real fm = rr > 0 ? k * (d - rr) / rr : 0;
        const ej_real u0 = v[3 * i] - v[3 * j], u1 = v[3 * i + 1] - v[3 * j + 1], u2 = v[3 * i + 2] - v[3 * j + 2];
        if (imp && rr > 0) {
          const ej_real w = (ex * u0 + ey * u1 + ez * u2) / rr; /* normal relative speed, < 0 approaching */
          const ej_real rho = 0.5 * (rhoi + m[j] / vol0[j]), lc = fmin(dxi, dxj);
          /* the face of the pair, lc^(dim-1): an area in 3-D, a length in 2-D (forces per unit
           * thickness), 1 in 1-D; until 2026-11-30 lc^2 in every dimension, which made the 2-D
           * dashpot 1/lc (per metre) too weak */
          const ej_real face = s->dim == 3 ? lc * lc : s->dim == 2 ? lc : 1.0;
          ej_real cv = face * rho * (ca * sqrt(Mlong / rho) + cb * fabs(w)); /* N s/m */
          /* at most the pair's inelastic stop in one step, c dt <= mu = m_i m_j/(m_i + m_j) (symmetric in
           * i, j): a stiffer dashpot would reverse the approach within the step. This clamp, not a
           * smaller step, keeps the first contact of a fast pair stable: a step bound from c would
           * lag that contact by a step and then cut dt while |a| is large, and velocity Verlet's
           * energy error sum_n (dt_n^2 - dt_n-1^2) m |a_n|^2 / 8 would no longer telescope (measured:
           * balance / KE0 -0.23 with the bound, 2e-16 with the clamp alone, two particles at 1 km/s). */
          if (dtn > 0) cv = fmin(cv, m[i] * m[j] / (m[i] + m[j]) / dtn);
          cs += cv;
          if (w < 0) {
            const ej_real fv = -cv * w / (vol0[i] * rr); /* force density / r: F_i = cv |w| e */
            fm += fv;
            qd += 0.5 * fv * rr * (-w);                   /* half of the pair's dissipated power density */
            fvx += fv * ex, fvy += fv * ey, fvz += fv * ez;
          }
        }
        const ej_real g0 = fm * ex, g1 = fm * ey, g2 = fm * ez;
        f0 += g0, f1 += g1, f2 += g2;
        p -= 0.5 * (g0 * u0 + g1 * u1 + g2 * u2);
        ks += k;
        ++cnt;
      }
    }
  }
  f[0] = f0, f[1] = f1, f[2] = f2;
  *pw = p;
  *pv = qd;
  if (fvis) fvis[0] = fvx, fvis[1] = fvy, fvis[2] = fvz;
  *ksum = ks;
  *csum = cs;
  return cnt;
}

/* ------------------------------------------------------------------ pass 1: forces */

/* Ghost force of a change of spacing (issue 4, item 3). With the sum form, a uniform first
 * Piola-Kirchhoff stress P puts the force density P e_i on row i,
 *   e_i = K_i^-1 m1_i + sum_j B_ij K_j^-1 X_ij   (intact bonds, j a correspondence point),
 * which vanishes in the interior of a uniform lattice but not within a horizon of a refine:
 * interface (dual-horizon rows: one-sided, unequal-volume families and neighbours' K_j of the
 * other spacing; up to 0.25 P/dx in 1-D, validation/tlpd_refine). On the rows of the interface
 * zone (a bond to a particle of another vol0, or a neighbour with one) the force pass subtracts
 * P_i e_i = PK_i (K_i e_i), except on rows that see a free surface (own or a neighbour's family
 * not filling its horizon ball): a uniform strain then gives zero force there (the patch test of
 * tests/unit/test_tlpd.c), like the partial-stress correction of Silling, Littlewood & Seleson
 * (2015, variable horizon). The correction is not antisymmetric, so momentum is exact only for a
 * uniform stress on those rows; its power goes to e so that the energy budget closes. Rows of a
 * uniform spacing (free surfaces included) are untouched. Computed once per row (again after its
 * bonds break), from the K^-1 of the neighbours at that time. */
static void tlpd_ghost_vector(tlpd_state *s, const ej_set *set, const ej_nbr *nbr, ej_idx i, const ej_real *Kinv_f)
{
  const ej_real *x0 = ej_set_field((ej_set *)set, "x0"), *vol0 = ej_set_field((ej_set *)set, "vol0");
  const int32_t *status = ej_set_field_int((ej_set *)set, "pd_status");
  const uint8_t *flags = ej_set_bond_flags((ej_set *)set);
  const ej_real *hz = ej_set_field((ej_set *)set, "pd_horizon");
  bool zone = s->mixed[i], full = s->full[i];
  for (ej_off k = nbr->off[i]; k < nbr->off[i + 1]; ++k) {
    const ej_idx j = nbr->idx[k];
    zone = zone || (j < s->n ? s->mixed[j] : vol0[j] != vol0[i] || (hz && hz[j] != hz[i]));
    full = full && (j >= s->n || s->full[j]); /* a mirror ghost completes the family */
  }
  s->gf_state[i] = 1;
  /* rows that see a free surface (their own or a neighbour's family truncated) keep the sum
   * form's surface force: the correction there removed the restoring force of the surface
   * layer and was unstable (2-D, det F < 0 within 50 steps) */
  if (!zone || !full || status[i] != TLPD_OK) return;
  ej_real e[3], sb[3] = {0, 0, 0};
  ej_m3_apply(e, s->Kinv + 9 * i, s->m1 + 3 * i);
  for (ej_off k = nbr->off[i]; k < nbr->off[i + 1]; ++k) {
    if (flags[k] & TLPD_BROKEN) continue;
    const ej_idx j = nbr->idx[k];
    if (status[j] != TLPD_OK || !(s->wb[k] > 0)) continue;
    const ej_real X[3] = {x0[3 * j] - x0[3 * i], x0[3 * j + 1] - x0[3 * i + 1], x0[3 * j + 2] - x0[3 * i + 2]};
    ej_real u[3];
    ej_m3_apply(u, j < s->n ? s->Kinv + 9 * j : Kinv_f + 9 * j, X);
    for (int q = 0; q < 3; ++q) sb[q] += s->wb[k] * u[q];
  }
  for (int q = 0; q < 3; ++q) e[q] += sb[q];
  /* K_i e_i (K from its inverse; the padded dimensions of K^-1 are 1 and e has no component there) */
  ej_real Kf[9] = {0};
  if (ej_m3_inverse(Kf, s->Kinv + 9 * i) == 0) return;
  ej_m3_apply(s->egf + 3 * i, Kf, e);
  for (int q = s->dim; q < 3; ++q) s->egf[3 * i + q] = 0;
  s->gf_state[i] = 2;
}

static ej_err tlpd_pass_forces(tlpd_state *s, ej_set *set, const ej_nbr *nbr, ej_range r)
{
  const ej_real *restrict x = ej_set_field(set, "x"), *restrict v = ej_set_field(set, "v");
  const ej_real *restrict x0 = ej_set_field(set, "x0"), *restrict m = ej_set_field(set, "m");
  const ej_real *restrict vol0 = ej_set_field(set, "vol0");
  const ej_real *restrict F = ej_set_field(set, "F"), *restrict PK = ej_set_field(set, "PK");
  const ej_real *restrict P = ej_set_field(set, "P"), *restrict coef = ej_set_field(set, "pd_coef");
  const int32_t *restrict status = ej_set_field_int(set, "pd_status");
  ej_real *restrict a = ej_set_field(set, "a"), *restrict e_dot = ej_set_field(set, "e_dot");
  ej_real *restrict w_dot = ej_set_field(set, "w_hg_dot");
  const uint8_t *restrict flags = ej_set_bond_flags(set);
  EJ_ENSURE(x && v && x0 && m && vol0 && F && PK && coef && status && a && e_dot && w_dot, EJ_ERR_INTERNAL,
            "set '%s': tlpd fields missing", s->name);
  const bool diff = s->cfg.force_form == TLPD_FORM_DIFFERENCE;
  EJ_ENSURE(!diff || P, EJ_ERR_INTERNAL, "set '%s': tlpd field P missing", s->name);
  const bool silling = s->cfg.hourglass == TLPD_HG_SILLING;
  const ej_off *restrict off = nbr->off;
  const ej_idx *restrict idx = nbr->idx;
  const tlpd_wt *restrict wa = s->wa, *restrict wb = s->wb;
  const ej_idx nall = ej_set_count_all(set);
  const ej_real ptr = tlpd_traction_p(&s->cfg.traction, ej_set_time(set));
  const ej_real *nrm = s->cfg.traction.normal;
  const ej_real damp = s->cfg.damping;

  const ej_real *restrict G = ej_set_field(set, "G_pk");
  const bool fast = !diff && !silling && G;
  const ej_real *Kinv_f = ej_set_field(set, "K_inv");
  const bool gfc = s->cfg.ghost_force_correction && !s->wb_alias && !diff && Kinv_f;
  const bool all_ok = s->wb_alias && atomic_load_explicit(&s->n_notok, memory_order_relaxed) == 0;
  const bool contact = s->cfg.contact != TLPD_CONTACT_OFF;
  ej_real *restrict wc_dot = contact && s->cfg.contact_law == TLPD_CLAW_IMPACT ? ej_set_field(set, "w_contact_dot") : NULL;
  EJ_ENSURE(!contact || s->cfg.contact_law != TLPD_CLAW_IMPACT || wc_dot, EJ_ERR_INTERNAL,
            "set '%s': tlpd field w_contact_dot missing", s->name);
  if (contact) EJ_TRY(tlpd_contact_ready(s, set));
  for (ej_idx i = r.begin; i < r.end; ++i) {
    const int si = status[i];
    ej_real fc[3] = {0, 0, 0}, pc = 0; /* contact force density and power share */
    if (contact) {
      ej_real ks, cs, pv, fv[3];
      s->ncont[i] = tlpd_contact_row(s, set, i, fc, &pc, &pv, fv, &ks, &cs);
      s->kc[i] = ks;
      s->cc[i] = cs;
      if (wc_dot) {
        const ej_real iv = vol0[i] / m[i];
        wc_dot[i] += pv * iv;
        for (int q = 0; q < 3; ++q) s->avis[3 * i + q] = fv[q] * iv; /* for post_step's correction */
      }
    }
    if (gfc && s->gf_state[i] == 0) tlpd_ghost_vector(s, set, nbr, i, Kinv_f);
    ej_real gc[3] = {0, 0, 0}; /* ghost-force correction -P_i e_i (force density) */
    if (gfc && s->gf_state[i] == 2 && si == TLPD_OK) {
      const ej_real *PKi = PK + 9 * i, *eg = s->egf + 3 * i;
      for (int q = 0; q < 3; ++q) gc[q] = -(PKi[3 * q] * eg[0] + PKi[3 * q + 1] * eg[1] + PKi[3 * q + 2] * eg[2]);
    }
    if (fast && si != TLPD_FALLBACK) {
      /* sum form with 002 hourglass control, both ends correspondence (or detached):
       * t = (A G_i + B G_j) X + (A C_i + B C_j) Y, G = P K^-1 - C F (pass 0) */
      const ej_real *Gi = G + 9 * i, *M1 = s->m1 + 3 * i;
      const ej_real Ci = si == TLPD_OK ? coef[i] : 0;
      /* the row's own part, sum_j A G_i X = G_i m1 (m1 over intact bonds, refresh_row) */
      tlpd_v4 f = {Gi[0] * M1[0] + Gi[3] * M1[1] + Gi[6] * M1[2], Gi[1] * M1[0] + Gi[4] * M1[1] + Gi[7] * M1[2],
                   Gi[2] * M1[0] + Gi[5] * M1[1] + Gi[8] * M1[2], 0};
      const tlpd_v4 xi = TLPD_LD3(x + 3 * i), Xi = TLPD_LD3(x0 + 3 * i);
      const bool intact = s->row_intact[i];
      if (all_ok && intact && s->jmax[i] + 1 < nall) {
        /* the common row: uniform spacing (B = A), no broken bond, every row a correspondence
         * point (n_notok = 0, so coef_j is the hourglass coefficient and there is no spring
         * fallback), every neighbour's 4-wide load inside the arrays: the operations of the
         * general loop below in the same order, without its per-bond tests (bitwise the same) */
        for (ej_off k = off[i]; k < off[i + 1]; ++k) {
          const ej_real A = wa[k]; /* = wb[k] (aliased) */
          const ej_idx j = idx[k];
          const size_t j3 = 3 * (size_t)j;
          const tlpd_v4 Y = TLPD_LD4(x + j3) - xi;
          const tlpd_v4 X = A * (TLPD_LD4(x0 + j3) - Xi);
          const ej_real *Gj = G + 9 * (size_t)j;
          const ej_real cy = TLPD_MADD(A, coef[j], A * Ci);
          f += TLPD_LD4(Gj) * X[0] + TLPD_LD4(Gj + 3) * X[1] + TLPD_LD4(Gj + 6) * X[2] + cy * Y;
        }
      } else {
        for (ej_off k = off[i]; k < off[i + 1]; ++k) {
          if (!intact && (flags[k] & TLPD_BROKEN)) continue;
          const ej_idx j = idx[k];
          const ej_real A = wa[k], B = wb[k];
          const int sj = status[j];
          const tlpd_v4 Y = TLPD_LDJ(x, j, nall) - xi;
          if (sj == TLPD_FALLBACK) {
            const tlpd_v4 X = TLPD_LD3(x0 + 3 * j) - Xi;
            const ej_real ly = sqrt(Y[0] * Y[0] + Y[1] * Y[1] + Y[2] * Y[2]), lx = sqrt(X[0] * X[0] + X[1] * X[1] + X[2] * X[2]);
            const ej_real sf = (ly > 0 ? 0.5 * coef[j] * B * (ly - lx) / (lx * ly) : 0) + A * Ci;
            f += sf * Y;
            continue;
          }
          const tlpd_v4 X = B * (TLPD_LDJ(x0, j, nall) - Xi);
          const ej_real *Gj = G + 9 * j;
          const ej_real cy = A * Ci + B * (sj == TLPD_OK ? coef[j] : 0);
          /* columns of G_j: slots 0-3 and 3-6 (lane 3 unused), 6-8 */
          f += TLPD_LD4(Gj) * X[0] + TLPD_LD4(Gj + 3) * X[1] + TLPD_LD3(Gj + 6) * X[2] + cy * Y;
        }
      }
      ej_real f0 = f[0] + gc[0], f1 = f[1] + gc[1], f2 = f[2] + gc[2];
      const ej_real iv = vol0[i] / m[i];
      if (contact) {
        f0 += fc[0], f1 += fc[1], f2 += fc[2];
        e_dot[i] += pc * iv;
      }
      a[3 * i] += f0 * iv, a[3 * i + 1] += f1 * iv, a[3 * i + 2] += f2 * iv;
      if (gfc) { /* the correction's power into e (zero where gc = 0) */
        const ej_real pc = (gc[0] * v[3 * i] + gc[1] * v[3 * i + 1] + gc[2] * v[3 * i + 2]) * iv;
        e_dot[i] -= pc;
      }
      s->aint[3 * i] = f0 * iv, s->aint[3 * i + 1] = f1 * iv, s->aint[3 * i + 2] = f2 * iv;
      if (s->area[i] > 0 && ptr != 0) {
        const ej_real fa = -ptr * s->area[i] / m[i];
        for (int q = 0; q < 3; ++q) a[3 * i + q] += fa * nrm[q];
      }
      if (damp > 0)
        for (int q = 0; q < 3; ++q) a[3 * i + q] -= damp * v[3 * i + q];
      continue;
    }
    const ej_real *PKi = PK + 9 * i, *Fi = F + 9 * i, *Ki = s->Kinv + 9 * i;
    const ej_real *Pi = diff ? P + 9 * i : NULL;
    const ej_real Ci = coef[i];
    const ej_real xi0 = x[3 * i], xi1 = x[3 * i + 1], xi2 = x[3 * i + 2];
    const ej_real vi0 = v[3 * i], vi1 = v[3 * i + 1], vi2 = v[3 * i + 2];
    ej_real f0 = 0, f1 = 0, f2 = 0, ehg = 0, ex = 0;
    for (ej_off k = off[i]; k < off[i + 1]; ++k) {
      if (flags[k] & TLPD_BROKEN) continue;
      const ej_idx j = idx[k];
      const ej_real A = wa[k], B = wb[k];
      const int sj = status[j];
      const ej_real X[3] = {x0[3 * j] - x0[3 * i], x0[3 * j + 1] - x0[3 * i + 1], x0[3 * j + 2] - x0[3 * i + 2]};
      const ej_real Y[3] = {x[3 * j] - xi0, x[3 * j + 1] - xi1, x[3 * j + 2] - xi2};
      const ej_real V[3] = {v[3 * j] - vi0, v[3 * j + 1] - vi1, v[3 * j + 2] - vi2};
      ej_real t[3] = {0, 0, 0};
      if (si == TLPD_OK && A > 0) {
        if (diff) {
          /* 000 Eq 9: w (P_j - P_i) K_i^-1 X V_j */
          ej_real u[3];
          ej_m3_apply(u, Ki, X);
          const ej_real *Pj = P + 9 * j;
          for (int q = 0; q < 3; ++q)
            t[q] += A * ((Pj[3 * q] - Pi[3 * q]) * u[0] + (Pj[3 * q + 1] - Pi[3 * q + 1]) * u[1] +
                         (Pj[3 * q + 2] - Pi[3 * q + 2]) * u[2]);
        } else {
          for (int q = 0; q < 3; ++q) t[q] += A * (PKi[3 * q] * X[0] + PKi[3 * q + 1] * X[1] + PKi[3 * q + 2] * X[2]);
        }
        if (Ci > 0) {
          /* 002 Eq 15 (digest form): T_hg,i<X> = C_i w (Y - F_i X); power into e and w_hg */
          const ej_real g = silling ? 1 / (X[0] * X[0] + X[1] * X[1] + X[2] * X[2]) : 1;
          ej_real z[3];
          for (int q = 0; q < 3; ++q) z[q] = Ci * A * g * (Y[q] - (Fi[3 * q] * X[0] + Fi[3 * q + 1] * X[1] + Fi[3 * q + 2] * X[2]));
          for (int q = 0; q < 3; ++q) t[q] += z[q];
          if (silling) ehg += z[0] * V[0] + z[1] * V[1] + z[2] * V[2]; /* zhu_zhao: in pass 0 */
        }
      } else if (si == TLPD_FALLBACK && A > 0) {
        /* 002 section 1.3 fallback with its digest's erratum: bond-based c s Y/|Y|, half per end */
        const ej_real ly = sqrt(Y[0] * Y[0] + Y[1] * Y[1] + Y[2] * Y[2]);
        const ej_real lx = sqrt(X[0] * X[0] + X[1] * X[1] + X[2] * X[2]);
        if (ly > 0) {
          const ej_real sf = 0.5 * Ci * A * (ly - lx) / (lx * ly);
          ej_real z[3] = {sf * Y[0], sf * Y[1], sf * Y[2]};
          for (int q = 0; q < 3; ++q) t[q] += z[q];
          ex += z[0] * V[0] + z[1] * V[1] + z[2] * V[2];
        }
      }
      /* the neighbour's force state on the reversed bond: -T_j<X_ji> V_j (dual horizon: j's weight) */
      if (!diff && B > 0) {
        if (sj == TLPD_OK) {
          const ej_real *PKj = PK + 9 * j;
          for (int q = 0; q < 3; ++q) t[q] += B * (PKj[3 * q] * X[0] + PKj[3 * q + 1] * X[1] + PKj[3 * q + 2] * X[2]);
        }
      }
      if (B > 0) {
        const ej_real Cj = coef[j];
        if (sj == TLPD_OK && Cj > 0) {
          const ej_real *Fj = F + 9 * j;
          const ej_real g = silling ? 1 / (X[0] * X[0] + X[1] * X[1] + X[2] * X[2]) : 1;
          for (int q = 0; q < 3; ++q)
            t[q] += Cj * B * g * (Y[q] - (Fj[3 * q] * X[0] + Fj[3 * q + 1] * X[1] + Fj[3 * q + 2] * X[2]));
        } else if (sj == TLPD_FALLBACK) {
          const ej_real ly = sqrt(Y[0] * Y[0] + Y[1] * Y[1] + Y[2] * Y[2]);
          const ej_real lx = sqrt(X[0] * X[0] + X[1] * X[1] + X[2] * X[2]);
          if (ly > 0) {
            const ej_real sf = 0.5 * Cj * B * (ly - lx) / (lx * ly);
            for (int q = 0; q < 3; ++q) t[q] += sf * Y[q];
          }
        }
      }
      f0 += t[0], f1 += t[1], f2 += t[2];
    }
    f0 += gc[0], f1 += gc[1], f2 += gc[2];
    ex -= gc[0] * vi0 + gc[1] * vi1 + gc[2] * vi2;
    if (contact) {
      f0 += fc[0], f1 += fc[1], f2 += fc[2];
      ex += pc;
    }
    /* force densities -> accelerations: rho0_i = m_i / vol0_i */
    const ej_real iv = vol0[i] / m[i];
    a[3 * i] += f0 * iv, a[3 * i + 1] += f1 * iv, a[3 * i + 2] += f2 * iv;
    s->aint[3 * i] = f0 * iv, s->aint[3 * i + 1] = f1 * iv, s->aint[3 * i + 2] = f2 * iv;
    e_dot[i] += (ehg + ex) * iv;
    w_dot[i] += ehg * iv;
    if (s->area[i] > 0 && ptr != 0) {
      const ej_real fa = -ptr * s->area[i] / m[i];
      for (int q = 0; q < 3; ++q) a[3 * i + q] += fa * nrm[q];
    }
    if (damp > 0)
      for (int q = 0; q < 3; ++q) a[3 * i + q] -= damp * v[3 * i + q];
  }
  return EJ_OK;
}

static ej_err tlpd_compute(void *state, ej_set *set, const ej_nbr *nbr, int pass, ej_range r)
{
  tlpd_state *s = state;
  if (!atomic_load_explicit(&s->ready, memory_order_acquire)) {
    ej_err rc = EJ_OK;
#pragma omp critical(tlpd_alloc)
    {
      if (!atomic_load_explicit(&s->ready, memory_order_relaxed)) {
        rc = tlpd_alloc(s, set, nbr);
        if (rc == EJ_OK) atomic_store_explicit(&s->ready, 1, memory_order_release);
      }
    }
    EJ_TRY(rc);
  }
  EJ_ENSURE(nbr && nbr->n_rows >= r.end, EJ_ERR_INTERNAL, "set '%s': tlpd family has too few rows", s->name);
  switch (pass) {
  case 0: EJ_TRY(tlpd_pass_kinematics(s, set, nbr, r)); break;
  case 1: EJ_TRY(tlpd_pass_forces(s, set, nbr, r)); break;
  default: EJ_FAIL(EJ_ERR_INTERNAL, "tlpd: pass %d of 2", pass);
  }
  return EJ_OK;
}

/* ------------------------------------------------------------------ after the step: bonds */

#if defined(__GNUC__)
#define TLPD_ALWAYS_INLINE static inline __attribute__((always_inline))
#else
#define TLPD_ALWAYS_INLINE static inline
#endif

/* The bond-breaking test of row i (tlpd_post_step): or-s TLPD_BROKEN into the flags of the bonds
 * stretched beyond the limit (|Y|^2 > lim |X|^2) or, with check_fail, with a failed end; returns
 * nonzero iff a flag changed. check_fail is a constant at both call sites (two vector loops). */
TLPD_ALWAYS_INLINE int tlpd_break_row(const tlpd_state *s, const ej_real *restrict x, const ej_real *restrict x0,
                                      const ej_real lim, const int32_t *restrict failed, const bool check_fail,
                                      uint8_t *restrict fl, const ej_idx i, const bool want, ej_real *slack)
{
  const ej_real xi0 = x[3 * i], xi1 = x[3 * i + 1], xi2 = x[3 * i + 2];
  const ej_real Xi0 = x0[3 * i], Xi1 = x0[3 * i + 1], Xi2 = x0[3 * i + 2];
  const int fi = check_fail && failed[i] != 0;
  const ej_idx *restrict idx = s->idx;
  int changed = 0;
  ej_real mn = INFINITY;
  const bool fin = want && lim < INFINITY; /* the skip's slack wanted and finite (want: a constant at each call) */
#if defined(_OPENMP)
#pragma omp simd reduction(| : changed) reduction(min : mn)
#endif
  for (ej_off k = s->off[i]; k < s->off[i + 1]; ++k) {
    const ej_idx j = idx[k];
    const ej_real X0 = x0[3 * j] - Xi0, X1 = x0[3 * j + 1] - Xi1, X2 = x0[3 * j + 2] - Xi2;
    const ej_real Y0 = x[3 * j] - xi0, Y1 = x[3 * j + 1] - xi1, Y2 = x[3 * j + 2] - xi2;
    const ej_real lx2 = X0 * X0 + X1 * X1 + X2 * X2, ly2 = Y0 * Y0 + Y1 * Y1 + Y2 * Y2;
    const int brk = (ly2 > lim * lx2) | (check_fail ? fi | (failed[j] != 0) : 0);
    const uint8_t f = fl[k], nf = (uint8_t)(f | (brk ? TLPD_BROKEN : 0));
    changed |= nf != f;
    fl[k] = nf;
    /* the skip's slack over the bonds left intact (|Y| <= sqrt(lim)|X| there):
     * sqrt(lim)|X| - |Y| = (lim |X|^2 - |Y|^2) / (sqrt(lim)|X| + |Y|) >= (lim |X|^2 - |Y|^2) / (2 sqrt(lim |X|^2)),
     * less a round-off margin of 1e-12 lim |X|^2 on the numerator */
    const ej_real a2 = lim * lx2;
    const ej_real sl = (nf & TLPD_BROKEN) || !fin ? INFINITY : (a2 - ly2 - 1e-12 * a2) / (2 * sqrt(a2));
    mn = sl < mn ? sl : mn;
  }
  *slack = want ? mn : -1; /* not computed: the row sweeps again next step */
  return changed;
}

/* The crack-opening cut of seed 002 Sec. 2.4 (b) (failure.cut_distance; digest 002 §4: "all bonds
 * whose minimum distance to the failed point is < half the element size", reference configuration as
 * the digest's [REC]). Row i breaks its intact bond i-k when a failed particle p (p != i, k) lies
 * within R = min(delta_i, delta_k) of both ends and closer than r = cut_distance min(dx_i, dx_k) to
 * the segment X_i X_k. Every such p is in both rows (each row holds every particle within its own
 * horizon >= R), and every quantity below is symmetric in the two ends to the bit (the distance to
 * the segment from the cross product |(p - a) x (p - b)|^2 / |b - a|^2, whose terms only change sign
 * when a and b swap; the foot test as two dot products that swap), so rows i and k take the same
 * decision: the flags stay symmetric. Against 002's rule this leaves out a p farther than R from one
 * end, which is then within r of the other end (a foot within r^2/(2|X_ik|) of it): no such pair
 * exists on a lattice of spacing >= 2r. The test runs only when the number of failed particles in
 * the row changed since the last test (failed never clears); returns nonzero iff a flag changed. */
static int tlpd_cut_row(tlpd_state *s, const ej_real *restrict x0, const ej_real *restrict vol0,
                        const ej_real *restrict hz, const int32_t *restrict failed, uint8_t *restrict fl,
                        const ej_idx i)
{
  enum { CAP = 256 };
  ej_idx fp[CAP];
  const ej_off b = s->off[i], e = s->off[i + 1];
  int32_t nf = 0;
  for (ej_off k = b; k < e; ++k) nf += failed[s->idx[k]] != 0;
  if (nf == s->cut_nf[i]) return 0;
  s->cut_nf[i] = nf;
  const ej_real dxi = tlpd_dx(s, vol0[i]), di = hz ? hz[i] : tlpd_delta(s, dxi);
  const ej_real *a = x0 + 3 * i;
  int changed = 0;
  for (ej_off c0 = b; c0 < e; c0 += CAP) { /* the failed members in chunks of CAP */
    int m = 0;
    for (ej_off k = c0; k < e && k < c0 + CAP; ++k)
      if (failed[s->idx[k]]) fp[m++] = s->idx[k];
    if (m == 0) continue;
    for (ej_off k = b; k < e; ++k) {
      if (fl[k] & TLPD_BROKEN) continue;
      const ej_idx j = s->idx[k];
      const ej_real dxj = tlpd_dx(s, vol0[j]), dj = hz ? hz[j] : tlpd_delta(s, dxj);
      const ej_real R = di < dj ? di : dj, R2 = R * R * (1 - 1e-9);
      const ej_real rc = s->cfg.failure.cut_distance * (dxi < dxj ? dxi : dxj), rc2 = rc * rc;
      const ej_real *bb = x0 + 3 * j;
      const ej_real ab0 = bb[0] - a[0], ab1 = bb[1] - a[1], ab2 = bb[2] - a[2];
      const ej_real lab2 = ab0 * ab0 + ab1 * ab1 + ab2 * ab2;
      for (int q = 0; q < m; ++q) {
        const ej_idx p = fp[q];
        if (p == j) continue;
        const ej_real *xp = x0 + 3 * p;
        const ej_real u0 = xp[0] - a[0], u1 = xp[1] - a[1], u2 = xp[2] - a[2];  /* p - a */
        const ej_real w0 = xp[0] - bb[0], w1 = xp[1] - bb[1], w2 = xp[2] - bb[2]; /* p - b */
        const ej_real lu2 = u0 * u0 + u1 * u1 + u2 * u2, lw2 = w0 * w0 + w1 * w1 + w2 * w2;
        if (!(lu2 < R2) || !(lw2 < R2)) continue;
        /* foot inside the segment: (p - a).(b - a) > 0 and (p - b).(a - b) > 0, i.e. -(w.ab) > 0 */
        const ej_real da = u0 * ab0 + u1 * ab1 + u2 * ab2, db = w0 * ab0 + w1 * ab1 + w2 * ab2;
        bool cut;
        if (da > 0 && db < 0) {
          const ej_real c0x = u1 * w2 - u2 * w1, c1x = u2 * w0 - u0 * w2, c2x = u0 * w1 - u1 * w0;
          cut = c0x * c0x + c1x * c1x + c2x * c2x < rc2 * lab2;
        } else {
          cut = (lu2 < lw2 ? lu2 : lw2) < rc2;
        }
        if (cut) {
          fl[k] |= TLPD_BROKEN;
          changed = 1;
          break;
        }
      }
    }
  }
  return changed;
}

/* Bond-break skip: whether a ghost of row i is failed in its source but not yet in its own copy
 * (post_step runs before the next ghost refresh), so that the row, which just swept with the old
 * copy, looks again next step instead of taking the block's failure count as seen. */
static bool tlpd_ghost_lag(const tlpd_state *s, const int32_t *restrict failed, const int32_t *restrict id, ej_idx i)
{
  for (ej_off k = s->off[i]; k < s->off[i + 1]; ++k) {
    const ej_idx j = s->idx[k];
    if (j < s->n || failed[j] || !id || id[j] < 0 || id[j] >= s->n) continue;
    const ej_idx src = s->bk_src[id[j]];
    if (src >= 0 && failed[src]) return true;
  }
  return false;
}

/* Bond-break skip (tlpd_state.bk_*): cell c's grid coordinates. */
static inline void tlpd_cell_coords(const tlpd_state *s, int32_t c, int q[3])
{
  q[0] = c % s->bk_nc[0], q[1] = (c / s->bk_nc[0]) % s->bk_nc[1], q[2] = c / (s->bk_nc[0] * s->bk_nc[1]);
}

/* Over the cells within m of cell c in each direction: the largest of bits[] (non-negative doubles
 * stored as their bits, which order as the values) and, with cnt, the sum of cnt[]. */
static ej_real tlpd_block_scan(const tlpd_state *s, int32_t c, int m, const _Atomic uint64_t *bits,
                               const atomic_llong *cnt, int64_t *sum)
{
  const int n0 = s->bk_nc[0], n1 = s->bk_nc[1], n2 = s->bk_nc[2];
  int q[3];
  tlpd_cell_coords(s, c, q);
  uint64_t mx = 0;
  int64_t sm = 0;
  for (int c2 = q[2] > m ? q[2] - m : 0; c2 <= q[2] + m && c2 < n2; ++c2)
    for (int c1 = q[1] > m ? q[1] - m : 0; c1 <= q[1] + m && c1 < n1; ++c1)
      for (int c0 = q[0] > m ? q[0] - m : 0; c0 <= q[0] + m && c0 < n0; ++c0) {
        const size_t cc = ((size_t)c2 * (size_t)n1 + (size_t)c1) * (size_t)n0 + (size_t)c0;
        const uint64_t b = atomic_load_explicit(&bits[cc], memory_order_relaxed);
        mx = b > mx ? b : mx;
        if (cnt) sm += atomic_load_explicit(&cnt[cc], memory_order_relaxed);
      }
  if (sum) *sum = sm;
  ej_real v;
  memcpy(&v, &mx, sizeof v);
  return v;
}

/* Whether every ghost neighbour of row i has its source in row i's block of cells (tlpd_state.bk_gok):
 * then the block's displacement maximum bounds the ghost's too, for an isometric image (mirror or
 * periodic) moves its source's distance. A mirror image's source is as close in the reference
 * configuration as the image; a periodic image's is not (such rows always sweep). */
static uint8_t tlpd_skip_ghosts(const tlpd_state *s, const int32_t *id, ej_idx i)
{
  int a[3], b[3];
  tlpd_cell_coords(s, s->bk_cell[i], a);
  const int m = s->bk_m[i];
  for (ej_off k = s->off[i]; k < s->off[i + 1]; ++k) {
    const ej_idx j = s->idx[k];
    if (j < s->n) continue;
    if (!id || id[j] < 0 || id[j] >= s->n) return 2;
    const ej_idx src = s->bk_src[id[j]];
    if (src < 0) return 2;
    tlpd_cell_coords(s, s->bk_cell[src], b);
    if (abs(a[0] - b[0]) > m || abs(a[1] - b[1]) > m || abs(a[2] - b[2]) > m) return 2;
  }
  return 1;
}

/* The displacement maxima and the new failures per cell (after every interaction, so after the
 * decohesion of pd_sph too: the failed flags post_step will read). x_prev is the x of the last
 * post_step, so |x - x_prev| is each particle's displacement since then. */
static ej_err tlpd_finish(void *state, ej_set *set, ej_range r)
{
  tlpd_state *s = state;
  if (!s->bk_on || !atomic_load_explicit(&s->ready, memory_order_acquire)) return EJ_OK;
  const ej_real *x = ej_set_field(set, "x"), *xp = ej_set_field(set, "x_prev");
  const int32_t *failed = ej_set_field_int(set, "failed");
  EJ_ENSURE(x && xp && failed, EJ_ERR_INTERNAL, "set '%s': tlpd fields missing", s->name);
  int32_t cur = -1;
  ej_real dm = 0;
  for (ej_idx i = r.begin; i <= r.end; ++i) {
    const int32_t c = i < r.end ? s->bk_cell[i] : -2;
    if (c != cur && cur >= 0) tlpd_atomic_max(&s->bk_dcell[cur], dm); /* a run of one cell ends (NaN: +inf) */
    if (i == r.end) break;
    if (c != cur) cur = c, dm = 0;
    const ej_real d0 = x[3 * i] - xp[3 * i], d1 = x[3 * i + 1] - xp[3 * i + 1], d2 = x[3 * i + 2] - xp[3 * i + 2];
    const ej_real d = sqrt(d0 * d0 + d1 * d1 + d2 * d2);
    dm = d > dm || d != d ? d : dm;
    if (failed[i] && !s->bk_fseen[i]) {
      s->bk_fseen[i] = 1;
      atomic_fetch_add_explicit(&s->bk_fcell[c], 1, memory_order_relaxed);
    }
  }
  if (r.begin == 0) atomic_fetch_add_explicit(&s->bk_gen_now, 1, memory_order_relaxed);
  return EJ_OK;
}

static ej_err tlpd_post_step(void *state, ej_set *set, ej_range r)
{
  tlpd_state *s = state;
  const ej_real *x = ej_set_field(set, "x"), *x0 = ej_set_field(set, "x0");
  ej_real *xp = ej_set_field(set, "x_prev");
  const int32_t *failed = ej_set_field_int(set, "failed"), *status = ej_set_field_int(set, "pd_status");
  uint8_t *flags = ej_set_bond_flags(set);
  EJ_ENSURE(x && x0 && xp && failed && status && flags, EJ_ERR_INTERNAL, "set '%s': tlpd fields missing", s->name);
  memcpy(xp + 3 * (size_t)r.begin, x + 3 * (size_t)r.begin, 3 * (size_t)(r.end - r.begin) * sizeof *x);
  /* Energy consistency of the rate predictor. The core evaluates e_dot with the predicted
   * velocity vp = v_n + dt a_n and integrates e with the trapezoid, while the kinetic energy
   * moves with v_n+1 = vp + dt/2 (a_n+1 - a_n); summed over the run this creates
   * (dt^2/4) sum_steps sum_i m_i |a_n+1 - a_n|^2 (always >= 0: the tearing bar's 2.6 % at cfl 0.5,
   * O(dt^3) globally, large where broken families rattle). Since sum_i m_i (a_int,i . z + e_dot_i(z))
   * = 0 for any velocity field z (sum form: exact), the rate at the final velocity differs from
   * the predicted one by sum_i m_i e_dot_i(v_n+1 - vp) = -sum_i m_i a_int,i . (v_n+1 - vp). Each
   * particle takes its share -a_int,i . dv_i (the exact total; the split among neighbours is the
   * per-particle approximation, O(dt) of the rate): half a step of it now, and e_dot keeps it for
   * the first half-kick of the next step. Prescribed-velocity particles have dv = 0. */
  if (s->cfg.energy_correction && atomic_load_explicit(&s->ready, memory_order_acquire)) {
    ej_real *e = ej_set_field(set, "e"), *e_dot = ej_set_field(set, "e_dot");
    const ej_real *v = ej_set_field(set, "v");
    const ej_real h = 0.5 * ej_set_dt(set);
    const bool imp = s->cfg.contact != TLPD_CONTACT_OFF && s->cfg.contact_law == TLPD_CLAW_IMPACT;
    ej_real *wc = imp ? ej_set_field(set, "w_contact") : NULL, *wc_dot = imp ? ej_set_field(set, "w_contact_dot") : NULL;
    if (wc && !wc_dot) wc = NULL;
    if (e && e_dot && v)
      for (ej_idx i = r.begin; i < r.end; ++i) {
        if (!s->vp_ok[i]) continue;
        s->vp_ok[i] = 0;
        const ej_real *ai = s->aint + 3 * i, *vp = s->vpred + 3 * i, *vi = v + 3 * i;
        const ej_real corr = -(ai[0] * (vi[0] - vp[0]) + ai[1] * (vi[1] - vp[1]) + ai[2] * (vi[2] - vp[2]));
        e[i] += h * corr;
        e_dot[i] += corr;
        if (wc) { /* the viscous contact's share, so that sum m w_contact is the heat booked in e */
          const ej_real *av = s->avis + 3 * i;
          const ej_real cw = -(av[0] * (vi[0] - vp[0]) + av[1] * (vi[1] - vp[1]) + av[2] * (vi[2] - vp[2]));
          wc[i] += h * cw;
          wc_dot[i] += cw;
        }
      }
  }
  /* F (pass 0 of this step) is now N(x_prev) K^-1 for the rows that have one */
  if (atomic_load_explicit(&s->ready, memory_order_acquire)) {
    int32_t *fprev = ej_set_field_int(set, "pd_fprev");
    for (ej_idx i = r.begin; i < r.end; ++i) fprev[i] = status[i] == TLPD_OK;
  }
  const ej_real s0 = s->cfg.failure.critical_stretch;
  const bool check_fail = atomic_load_explicit(&s->any_failed, memory_order_relaxed) != 0;
  for (ej_idx i = r.begin; i < r.end; ++i)
    if (status[i] == TLPD_FALLBACK) ++s->n_fallback[i];
  if (!(s0 > 0) && !check_fail) return EJ_OK;
  /* 000 Eqs 14-16: irreversible breaking of bonds stretched beyond s0; a failed point (the
   * material's flag) loses every bond, and so does the bond's other end, so that the pair
   * stays symmetric (both rows take the same decision from the same |Y| and |X|). */
  const ej_nbr nbr = {.n_rows = s->n, .off = s->off, .idx = s->idx};
  ej_real *tbrk = ej_set_field(set, "pd_t_break");
  /* stretch > s0  <=>  |Y|^2 > (1 + s0)^2 |X|^2 (no square root). Branch-free over the row so
   * that it vectorises (gathers): every bond is tested, a broken one stays broken (the flag is
   * or-ed), and a row is dirty iff a flag changed, as with the former skip-the-broken loop (the
   * same decisions, 2026-11-29; this sweep was 23 % of the fine buried-charge step). Without a
   * critical stretch the limit is +inf (never exceeded; |X| > 0). */
  const ej_real lim = s0 > 0 ? (1 + s0) * (1 + s0) : INFINITY;
  /* the bond-break skip (tlpd_state.bk_*): a row sweeps unless a finish ran since its last
   * post_step, every ghost neighbour's source is in its block, check_fail is as at its last sweep,
   * no failed particle ends an intact bond of it, and twice its budget is below its slack */
  const bool skip_on = s->bk_on;
  const bool cut_on = s->cut_nf != NULL;
  const ej_real *vol0 = cut_on ? ej_set_field(set, "vol0") : NULL;
  const ej_real *hz = cut_on ? ej_set_field(set, "pd_horizon") : NULL; /* horizon_grading (NULL: delta = m dx) */
  EJ_ENSURE(!cut_on || vol0, EJ_ERR_INTERNAL, "set '%s': tlpd vol0 missing", s->name);
  const int32_t *id = skip_on ? ej_set_field_int(set, "id") : NULL;
  const uint32_t gen = skip_on ? atomic_load_explicit(&s->bk_gen_now, memory_order_relaxed) : 0;
  int32_t bc = -1;
  int bm = 0;
  ej_real bdm = 0;
  int64_t bfs = 0;
  for (ej_idx i = r.begin; i < r.end; ++i) {
    bool newfail = false; /* the row's block counted a failure since its last sweep */
    if (skip_on) {
      const int32_t c = s->bk_cell[i];
      const int m = s->bk_m[i];
      if (c != bc || m != bm) /* rows of one cell share it */
        bc = c, bm = m, bdm = tlpd_block_scan(s, c, m, s->bk_dcell, s->bk_fcell, &bfs);
      const bool measured = s->bk_gen[i] != 0 && s->bk_gen[i] != gen;
      s->bk_gen[i] = gen;
      if (measured && !s->bk_gok[i]) s->bk_gok[i] = s->jmax[i] < s->n ? 1 : tlpd_skip_ghosts(s, id, i);
      bool skip = measured && s->bk_gok[i] == 1 && s->bk_cf[i] == (uint8_t)check_fail;
      if (skip) {
        const bool first = s->bk_budget[i] == 0; /* the first step since the row's last sweep */
        s->bk_budget[i] += bdm;
        skip = 2 * s->bk_budget[i] * (1 + 1e-9) < s->bk_slack[i]; /* no bond can have reached the limit */
        if (!skip && first) s->bk_hot[i] = (uint8_t)(s->bk_hot[i] < 255 ? s->bk_hot[i] + 1 : 9);
        else if (skip) s->bk_hot[i] = 0;
      }
      newfail = s->bk_fsum[i] != bfs;
      if (skip && check_fail && newfail) {
        /* a particle of the block failed since the row's last sweep: does one end an intact bond
         * (as the sweep reads it: a ghost's own copy of failed)? A ghost whose source failed but
         * whose copy does not say so yet (refreshed at a later pass) keeps the count unsettled, so
         * that the row looks again next step, as the sweep would. With failure.cut_distance the
         * row sweeps: the new failure may cut any bond of it, also where its own bond to the
         * failed particle broke earlier (by stretch) while the other end's row cuts. */
        bool settled = true;
        skip = !cut_on && !failed[i];
        for (ej_off k = s->off[i]; skip && k < s->off[i + 1]; ++k) {
          if (flags[k] & TLPD_BROKEN) continue;
          const ej_idx j = s->idx[k];
          skip = !failed[j];
          if (skip && j >= s->n && failed[s->bk_src[id[j]]]) settled = false;
        }
        if (skip && settled) s->bk_fsum[i] = bfs;
      }
      if (skip) { /* the sweep would change no flag */
        ++s->bk_nskip[i];
        continue;
      }
      s->bk_cf[i] = (uint8_t)check_fail, s->bk_fsum[i] = bfs, s->bk_budget[i] = 0;
    }
    ej_real slack;
    const bool want = skip_on && (s->bk_hot[i] < 2 || (s->bk_hot[i] & 7) == 0);
    const int changed = check_fail ? (want ? tlpd_break_row(s, x, x0, lim, failed, true, flags, i, true, &slack)
                                           : tlpd_break_row(s, x, x0, lim, failed, true, flags, i, false, &slack))
                                   : (want ? tlpd_break_row(s, x, x0, lim, failed, false, flags, i, true, &slack)
                                           : tlpd_break_row(s, x, x0, lim, failed, false, flags, i, false, &slack));
    if (skip_on) s->bk_slack[i] = slack;
    const int cut = cut_on && check_fail ? tlpd_cut_row(s, x0, vol0, hz, failed, flags, i) : 0;
    /* a ghost's source failed in this step only if the block's count moved */
    if (newfail && check_fail && s->jmax[i] >= s->n && tlpd_ghost_lag(s, failed, id, i))
      s->bk_fsum[i] = -1; /* look again next step, with the refreshed copy */
    const bool dirty = (changed | cut) != 0;
    if (dirty) {
      tlpd_refresh_row(s, set, &nbr, i);
      atomic_store_explicit(&s->t_refresh, ej_set_time(set), memory_order_relaxed);
      tbrk[i] = ej_set_time(set);
      if (skip_on) tlpd_atomic_max(&s->bk_tcell[s->bk_cell[i]], tbrk[i]);
    }
  }
  return EJ_OK;
}

/* ------------------------------------------------------------------ time step */

/* Stable step of particle i over its current family (Gershgorin bound).
 *
 * Linearised about the reference state, the sum form is the gradient of the energy
 * W = sum_k V_k W(F_k), F_k - I = sum_n u_n (x) h_kn with h_kl = w V_l K_k^-1 X_kl for the intact
 * bonds of row k and h_kk = -K_k^-1 m1_k (m1 = sum w V X: zero for a full, symmetric family,
 * large for a one-sided or partly broken one). With |C : A| <= Cmax |A| (isotropic:
 * Cmax = dim lambda + 2 mu, the volumetric eigenvalue of C restricted to dim dimensions), the
 * stiffness is bounded by sum_k V_k Cmax (h_k h_k^T) (x) I, and Gershgorin's row sum gives
 *   lambda_max(M^-1 Kstiff) <= max_i (1/m_i) sum_{k: i in row k} V_k Cmax |h_ki| H_k,
 *   H_k = sum_n |h_kn|,
 * the rows k being i itself (|h_ii| = |K_i^-1 m1_i|) and the j whose intact family holds i
 * (|h_ji| = w_j V_i |K_j^-1 X_ji|). The hourglass forces C w (Y - F X) are bounded by bond
 * springs C w V (F X is the weighted least-squares fit of Y, so the hourglass energy is at most
 * the spring energy), the spring fallback is a spring 0.5 C w V/|X|; a spring network adds
 * 2 sum_j k_ij / m_i. Velocity Verlet is stable for dt < 2/sqrt(lambda_max):
 *   dt_fam,i = 2 / sqrt(lambda_i).
 Measured (3D bar, horizon 3, validation/tlpd_tearing): intact 0.84-1.09 dx/c (corners
 * lowest; in 1D an interior particle gets 4.7 dx/c, the correspondence operator being smooth),
 * torn particles down to 0.73 dx/c. The step is
 *   dt_i = min(dx_i / c_i, dt_fam,i)   (times the core's cfl),
 * dx/c keeping the measured accuracy of intact bodies (cfl 1 with dx/c is at the edge).
 * Cached per particle; recomputed after a bond of its family has broken, i.e. of row i or of
 * the row of a neighbour (tlpd_stable_dt; the rows of the ghosts use their copies from the last
 * pass).
 * Velocity damping adds dt <= 1/damping. */
typedef struct tlpd_dt_fields { /* the fields tlpd_family_dt reads, looked up once per range */
  const ej_real *x0, *vol0, *m, *c, *coef, *Kinv_f, *hsum_f;
  const int32_t *status;
  const uint8_t *flags;
} tlpd_dt_fields;

static ej_real tlpd_family_dt(const tlpd_state *s, const tlpd_dt_fields *F, ej_idx i)
{
  const ej_real *x0 = F->x0, *vol0 = F->vol0, *m = F->m, *c = F->c, *coef = F->coef;
  const ej_real *Kinv_f = F->Kinv_f, *hsum_f = F->hsum_f;
  const int32_t *status = F->status;
  const uint8_t *flags = F->flags;
  const ej_idx n = s->n;
  const bool silling = s->cfg.hourglass == TLPD_HG_SILLING, zz = s->cfg.hourglass == TLPD_HG_ZHU_ZHAO;
  /* Cmax = dim lambda + 2 mu from the moduli, scaled by the particle's rho0 c^2 / (lambda + 2 mu)
   * when its material is stiffer than the moduli say (an EOS, a hardened state) */
  const ej_real lam = s->K - 2 * s->G / 3, Mmod = s->K + 4 * s->G / 3;
  const ej_real rho0 = m[i] / vol0[i];
  const ej_real Mi = fmax(Mmod, rho0 * c[i] * c[i]);
  const ej_real Cmax = Mmod > 0 ? Mi * fmax(s->dim * lam + 2 * s->G, 2 * s->G) / Mmod : Mi;
  const int si = status[i];
  ej_real sum = si == TLPD_OK ? Cmax * vol0[i] * s->hself[i] * s->hsum[i] : 0, ks = 0;
  for (ej_off k = s->off[i]; k < s->off[i + 1]; ++k) {
    if (flags[k] & TLPD_BROKEN) continue;
    const ej_idx j = s->idx[k];
    const ej_real A = s->wa[k], B = s->wb[k];
    const ej_real X[3] = {x0[3 * j] - x0[3 * i], x0[3 * j + 1] - x0[3 * i + 1], x0[3 * j + 2] - x0[3 * i + 2]};
    const ej_real r2 = X[0] * X[0] + X[1] * X[1] + X[2] * X[2];
    const int sj = status[j];
    if (sj == TLPD_OK && B > 0) {
      ej_real u[3];
      ej_m3_apply(u, j < n ? s->Kinv + 9 * j : Kinv_f + 9 * j, X);
      const ej_real Hj = j < n ? s->hsum[j] : hsum_f[j];
      sum += Cmax * B * vol0[i] * sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]) * Hj;
    }
    /* bond springs bounding the hourglass and fallback forces on i (force = V_i k Y) */
    if (si == TLPD_OK && zz) ks += A * coef[i];
    else if (si == TLPD_OK && silling) ks += A * coef[i] / r2;
    else if (si == TLPD_FALLBACK) ks += 0.5 * A * coef[i] / sqrt(r2);
    if (sj == TLPD_OK && zz) ks += B * coef[j];
    else if (sj == TLPD_OK && silling) ks += B * coef[j] / r2;
    else if (sj == TLPD_FALLBACK) ks += 0.5 * B * coef[j] / sqrt(r2);
  }
  const ej_real lmax = (sum + 2 * ks * vol0[i]) / m[i];
  return lmax > 0 ? 2 / sqrt(lmax) : HUGE_VAL;
}

static ej_err tlpd_stable_dt(void *state, const ej_set *set, ej_range r, ej_real *dt)
{
  tlpd_state *s = state;
  const ej_real *c = ej_set_field(set, "c"), *vol0 = ej_set_field(set, "vol0");
  EJ_ENSURE(c && vol0, EJ_ERR_INTERNAL, "set '%s': tlpd fields missing", s->name);
  ej_real best = HUGE_VAL;
  const bool ready = atomic_load_explicit(&s->ready, memory_order_acquire) && s->n == ej_set_count(set);
  for (ej_idx i = r.begin; i < r.end; ++i)
    if (c[i] > 0) best = fmin(best, (ready && s->row_ready[i] ? s->dxp[i] : tlpd_dx(s, vol0[i])) / c[i]);
  if (ready) {
    const ej_real t = ej_set_time(set), tr = atomic_load_explicit(&s->t_refresh, memory_order_relaxed);
    ej_real *dt_fam = ej_set_field(set, "pd_dt_fam"), *dt_fam_t = ej_set_field(set, "pd_dt_fam_t");
    const ej_real *tbrk = ej_set_field(set, "pd_t_break");
    const tlpd_dt_fields F = {.x0 = ej_set_field(set, "x0"), .vol0 = vol0, .m = ej_set_field(set, "m"), .c = c,
                              .coef = ej_set_field(set, "pd_coef"), .Kinv_f = ej_set_field(set, "K_inv"),
                              .hsum_f = ej_set_field(set, "pd_hsum"), .status = ej_set_field_int(set, "pd_status"),
                              .flags = ej_set_bond_flags(set)};
    const ej_idx n = s->n;
    int32_t tc = -1; /* the skip's block of the last row (post_step's grid) and its last break */
    int tm = 0;
    ej_real tblk = 0;
    for (ej_idx i = r.begin; i < r.end; ++i) {
      if (!s->row_ready[i]) continue;
      /* Recomputed when the family changed after dt_fam was computed: dt_fam,i reads row i
       * (its bonds, status, K^-1, H) and, for every bond, the row of the other end j. A row
       * changes only when one of its bonds breaks (post_step: pd_t_break = t; a failed point
       * breaks its bonds there too), so the family changed iff pd_t_break of i or of one of its
       * owned neighbours is >= the cached time. A ghost neighbour's row is a copy whose
       * pd_t_break is not ghosted: a row with one takes the last break of the whole set
       * (t_refresh). No break anywhere since the cached time (t_refresh < dt_fam_t): nothing to
       * scan. (pd_t_break is 0 for a row that never broke: a family cached at t = 0 is computed
       * once more after the first break anywhere.) A restart restores dt_fam,
       * its time and pd_t_break: the same decisions. Before 2026-11-29 any break in the set
       * recomputed every family (a full bond sweep per step while a blast breaks bonds; 30 % of
       * the fine buried-charge step after set-up). */
      bool stale = !(dt_fam[i] > 0);
      /* quiet: no break anywhere since dt_fam was computed, or (the skip's grid, post_step) none in
       * row i's block and no ghost neighbour (read as the set's last break below): the scan would
       * find tf < dt_fam_t */
      bool quiet = dt_fam_t[i] > tr;
      if (!stale && !quiet && s->bk_on && s->jmax[i] < n) {
        if (s->bk_cell[i] != tc || s->bk_m[i] != tm) /* rows of one cell share it */
          tc = s->bk_cell[i], tm = s->bk_m[i], tblk = tlpd_block_scan(s, tc, tm, s->bk_tcell, NULL, NULL);
        quiet = tblk < dt_fam_t[i];
      }
      if (!stale && !quiet) {
        ej_real tf = tbrk[i]; /* the family's last break (a max: vectorises, one gather per bond) */
        const ej_idx *restrict idx = s->idx;
#if defined(_OPENMP)
#pragma omp simd reduction(max : tf)
#endif
        for (ej_off k = s->off[i]; k < s->off[i + 1]; ++k) {
          const ej_idx j = idx[k];
          const ej_real tj = j < n ? tbrk[j] : tr;
          tf = tj > tf ? tj : tf;
        }
        stale = dt_fam_t[i] <= tf;
      }
      if (stale) {
        dt_fam[i] = tlpd_family_dt(s, &F, i);
        dt_fam_t[i] = t;
      }
      best = fmin(best, dt_fam[i]);
    }
  }
  /* contact springs of the last force pass (Gershgorin, as the bond springs of tlpd_family_dt):
   * lambda_i <= 2 sum_j k_ij / m_i, k_ij = V_i V_j 15 c_s / delta. With contact_law impact the
   * pairs are also dashpots c_ij = A rho (alpha c + beta |w|) (Gershgorin: eta_i <= 2 sum_j c_ij / m_i):
   * a damped oscillator x'' + eta x' + omega^2 x = 0 under central differences is stable for
   * dt <= 2 / (h + sqrt(omega^2 + h^2)), h = eta/2 (= 2/omega without damping, 2/eta without the
   * spring; Belytschko, Liu & Moran 2000, Sec. 6.3, the critical step with damping) */
  if (ready && s->cfg.contact != TLPD_CONTACT_OFF) {
    const ej_real *m = ej_set_field(set, "m");
    for (ej_idx i = r.begin; i < r.end; ++i) {
      /* contact_law impact: the dashpots are clamped to the pair's one-step stop instead (contact_row);
       * cc is kept for the report only. Several saturated contacts on one particle can still
       * overshoot (a limit, plugins/methods/tlpd/README.md). */
      const ej_real w2 = 2 * s->kc[i] * vol0[i] / m[i], h = 0;
      if (w2 > 0 || h > 0) best = fmin(best, 2 / (h + sqrt(w2 + h * h)));
    }
  }
  if (s->cfg.damping > 0) best = fmin(best, 1.0 / s->cfg.damping);
  *dt = best;
  return EJ_OK;
}

/* ------------------------------------------------------------------ reports */

static void tlpd_bond_stats(const tlpd_state *s, const ej_set *set, int64_t *broken, ej_real *mean_damage,
                            int64_t *fallback, int64_t *detached)
{
  const uint8_t *flags = ej_set_bond_flags(set);
  const ej_real *damage = ej_set_field(set, "damage");
  const int32_t *status = ej_set_field_int(set, "pd_status");
  *broken = 0, *fallback = 0, *detached = 0;
  *mean_damage = 0;
  if (!atomic_load(&s->ready) || !flags) return;
  ej_real sd = 0;
  for (ej_idx i = 0; i < s->n; ++i) {
    *broken += s->nbroken[i]; /* kept by refresh_row */
    sd += damage[i];
    *fallback += s->n_fallback[i];
    *detached += status[i] == TLPD_DETACHED;
  }
  *mean_damage = s->n > 0 ? sd / s->n : 0;
}

static ej_err tlpd_report(void *state, const ej_set *set, ej_series_value *out, int max, int *n)
{
  tlpd_state *s = state;
  *n = 0;
  EJ_ENSURE(max >= 5, EJ_ERR_INTERNAL, "tlpd: report needs 5 slots");
  const ej_real t = ej_set_time(set), dt = ej_set_dt(set);
  /* work of the traction and of the damping over the step just taken, with the mid-step
   * velocity (exact for a constant force, as for gravity in the core) */
  if (atomic_load(&s->ready) && dt > 0 && t > s->t_last) {
    const ej_real *vh = ej_set_field(set, "v_half"), *v = ej_set_field(set, "v"), *m = ej_set_field(set, "m");
    const ej_real pm = 0.5 * (tlpd_traction_p(&s->cfg.traction, t - dt) + tlpd_traction_p(&s->cfg.traction, t));
    const ej_real *nrm = s->cfg.traction.normal;
    ej_real wt = 0, wd = 0;
    for (ej_idx i = 0; i < s->n; ++i) {
      const ej_real *u = vh ? vh + 3 * i : v + 3 * i;
      if (s->area[i] > 0) wt -= pm * s->area[i] * (nrm[0] * u[0] + nrm[1] * u[1] + nrm[2] * u[2]);
      if (s->cfg.damping > 0) wd += s->cfg.damping * m[i] * (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    }
    s->w_traction += wt * dt;
    s->w_damping += wd * dt;
    s->t_last = t;
  }
  int64_t broken, fb, det;
  ej_real md;
  tlpd_bond_stats(s, set, &broken, &md, &fb, &det);
  out[0] = (ej_series_value){.name = "mean_damage", .value = md, .role = EJ_SERIES_PLAIN};
  out[1] = (ej_series_value){.name = "broken_bonds", .value = (ej_real)broken, .role = EJ_SERIES_PLAIN};
  out[2] = (ej_series_value){.name = "detached", .value = (ej_real)det, .role = EJ_SERIES_PLAIN};
  out[3] = (ej_series_value){.name = "traction_work", .value = s->w_traction, .role = EJ_SERIES_WORK};
  out[4] = (ej_series_value){.name = "damping_dissipated", .value = s->w_damping, .role = EJ_SERIES_DISSIPATED};
  *n = 5;
  atomic_fetch_add_explicit(&s->epoch, 1, memory_order_acq_rel); /* a new step: the contact grid is rebuilt */
  if (s->cfg.inversion == TLPD_INV_POINT_FAILURE && max > *n) {
    int64_t pf = 0;
    for (ej_idx i = 0; atomic_load(&s->ready) && i < s->n; ++i) pf += s->pfail[i];
    out[(*n)++] = (ej_series_value){.name = "inverted_failed", .value = (ej_real)pf, .role = EJ_SERIES_PLAIN};
  }
  if (s->cfg.contact != TLPD_CONTACT_OFF && max > *n) {
    int64_t nc = 0;
    for (ej_idx i = 0; atomic_load(&s->ready) && i < s->n; ++i) nc += s->ncont[i];
    out[(*n)++] = (ej_series_value){.name = "contact_pairs", .value = (ej_real)nc, .role = EJ_SERIES_PLAIN};
  }
  /* contact_law impact: the heat of the viscous contact pressure so far (J). It is already in e
   * (so PLAIN: a DISSIPATED role would subtract it from the budget a second time); the core's
   * energy summary also counts w_contact under "viscous". */
  if (s->cfg.contact != TLPD_CONTACT_OFF && s->cfg.contact_law == TLPD_CLAW_IMPACT && max > *n) {
    const ej_real *wc = ej_set_field((ej_set *)set, "w_contact"), *m = ej_set_field((ej_set *)set, "m");
    ej_real wsum = 0;
    for (ej_idx i = 0; wc && i < ej_set_count(set); ++i) wsum += m[i] * wc[i];
    out[(*n)++] = (ej_series_value){.name = "contact_dissipated", .value = wsum, .role = EJ_SERIES_PLAIN};
  }
  return EJ_OK;
}

static ej_err tlpd_counters(void *state, ej_counter *out, int max, int *n)
{
  tlpd_state *s = state;
  *n = 0;
  if (max < 3) return EJ_OK;
  int64_t broken, fb, det;
  ej_real md;
  tlpd_bond_stats(s, s->set, &broken, &md, &fb, &det);
  out[0] = (ej_counter){.name = "singular shape tensor K, spring fallback (particle-steps)", .value = fb};
  out[1] = (ej_counter){.name = "broken bonds (both directions)", .value = broken};
  out[2] = (ej_counter){.name = "detached particles", .value = det};
  *n = 3;
  if (s->bk_on && max > *n) {
    int64_t ns = 0;
    for (ej_idx i = 0; i < s->n; ++i) ns += s->bk_nskip[i];
    out[(*n)++] = (ej_counter){.name = "bond-break sweeps skipped (row-steps, break_skip)", .value = ns};
  }
  if (s->cfg.inversion == TLPD_INV_POINT_FAILURE && max > *n) {
    int64_t pf = 0;
    for (ej_idx i = 0; atomic_load(&s->ready) && i < s->n; ++i) pf += s->pfail[i];
    out[(*n)++] = (ej_counter){.name = "point failures at det F <= 0 (particles)", .value = pf};
  }
  return EJ_OK;
}

/* ------------------------------------------------------------------ registration */

/* Checkpointed state (ABI 1.8): the traction work and the damping dissipation summed so far
 * and the time they were last summed to, so that a restarted run's energy budget continues. */
static ej_err tlpd_save_state(const void *state, ej_real *buf, int max, int *n)
{
  const tlpd_state *s = state;
  EJ_ENSURE(max >= 3, EJ_ERR_INTERNAL, "tlpd: %d state slots, needs 3", max);
  buf[0] = s->w_traction;
  buf[1] = s->w_damping;
  buf[2] = s->t_last;
  *n = 3;
  return EJ_OK;
}

static ej_err tlpd_load_state(void *state, const ej_real *buf, int n)
{
  tlpd_state *s = state;
  EJ_ENSURE(n == 3, EJ_ERR_INPUT, "tlpd: %d state values in the checkpoint, expected 3", n);
  s->w_traction = buf[0];
  s->w_damping = buf[1];
  s->t_last = buf[2];
  return EJ_OK;
}

/* The fields each pass writes (ABI 1.3 pass_writes), so that the core copies to the ghosts before a pass
 * only what changed since the last refresh instead of every field (the rotated 3 x 3 tensors F, PK,
 * G_pk, K_inv of every mirror image: 10 % of the default example's step before 2026-12-03). Fields
 * the material or EOS write (history, p) are added by the core. Pass 0 includes the rows set up on
 * first use (tlpd_init_row: status, coefficient, H, damage) and the point failures; post_step the
 * bond breaking (tlpd_refresh_row) and the energy correction. EJECTA_GHOST_CHECK=1 compares every
 * partial refresh with a full one (tests/unit/test_ghosts_refresh.c runs a TL-PD scene with it). */
static int tlpd_pass_writes(const void *state, int pass, const char **names, int max)
{
  const tlpd_state *s = state;
  static const char *const kin[] = {"F",        "PK",      "G_pk",    "K_inv",  "stress",    "rho",
                                    "e",        "e_dot",   "w_hg_dot", "c",     "w_plastic", "failed",
                                    "pd_status", "pd_fprev", "pd_coef", "pd_hsum", "damage", NULL};
  static const char *const frc[] = {"a", "e_dot", "w_hg_dot", NULL};
  static const char *const post[] = {"x_prev",    "e",       "e_dot",   "pd_fprev", "pd_t_break",
                                     "pd_status", "pd_coef", "pd_hsum", "damage",   NULL};
  const bool diff = s->cfg.force_form == TLPD_FORM_DIFFERENCE;
  const bool imp = s->cfg.contact != TLPD_CONTACT_OFF && s->cfg.contact_law == TLPD_CLAW_IMPACT;
  const char *const *l = pass == EJ_PASS_POST_STEP ? post : pass == 0 ? kin : pass == 1 ? frc : NULL;
  if (!l || max < 20) return -1;
  int n = 0;
  while (l[n]) names[n] = l[n], ++n;
  if (pass == 0 && diff) names[n++] = "P";
  if (pass != 0 && imp) names[n++] = "w_contact_dot";
  if (pass == EJ_PASS_POST_STEP && imp) names[n++] = "w_contact";
  return n;
}

static const ej_method_ops tlpd_ops = {
    .struct_size = sizeof(ej_method_ops),
    .name = "tlpd",
    .summary = "Total-Lagrangian correspondence (non-ordinary state-based) peridynamics",
    .doc = "Fixed families from the reference configuration (horizon m dx_i, partial volumes, dual horizon for "
           "variable spacing); shape tensor K, deformation gradient F = N K^-1, P = J sigma F^-T, force state "
           "w P K^-1 X in Silling's sum form or 000's difference form (Eq 9); Hughes-Winget objective stress "
           "update (000 Eqs 78-94, transpose erratum of Eq 93) and any strength model; hourglass control "
           "(002 Eq 15 or Silling 2017); critical-stretch bond breaking, damage (000 Eqs 14-17), point "
           "failure, spring fallback for a singular K; a surface pressure and velocity damping for "
           "quasi-static loading.",
    .params = tlpd_params,
    .config_size = sizeof(tlpd_config),
    .check_config = tlpd_check_config,
    .declare = tlpd_declare,
    .create = tlpd_create,
    .setup = tlpd_setup,
    .support = tlpd_support,
    .n_passes = 2,
    .compute = tlpd_compute,
    .stable_dt = tlpd_stable_dt,
    .post_step = tlpd_post_step,
    .post_step_local = true, /* own rows; reads x, x0 and failed of the other ends, which the kick does not write */
    .finish = tlpd_finish,   /* the bond-break skip's displacement maxima and failure counts */
    .counters = tlpd_counters,
    .destroy = tlpd_destroy,
    .pass_count = NULL,
    .report = tlpd_report,
    .pass_writes = tlpd_pass_writes,
    .save_state = tlpd_save_state,
    .load_state = tlpd_load_state,
};

static ej_err tlpd_register(ej_registry *reg)
{
  EJ_TRY(ej_register_method(reg, &tlpd_ops));
  return EJ_OK;
}

EJ_PLUGIN_DEFINE(tlpd, "0.1.0", "BSD-3-Clause", "Total-Lagrangian correspondence peridynamics", tlpd_register)

/* Interaction `pd_sph`: coupling of a peridynamic solid (tlpd: soil, rock) and a fluid set
 * (sph or ulpd: explosive products, air), Fan & Li (000) §2.4.
 *
 * form: pairwise (default) — equal and opposite pair forces from the fluid's stress only
 *   (the "traction" weights of continuum_pair.h): the solid's own stress acts through its PD
 *   operator, whose truncated families at the interface already give the solid's side of the
 *   traction; adding the solid's stress again (the symmetric SPH form) would count it twice and
 *   makes the interface stiff. Neither weighting transmits a plane wave within 3 % yet
 *   (validation/pd_sph_impedance: fluid -59 %, both +84 % on T for Z2/Z1 = 0.35). Exact
 *   momentum and energy conservation with either.
 * form: paper — 000 Eqs 39-42 with the sign corrections of the digest (§1.5, errata 11-12):
 *   PD side (particle I of the solid, fluid neighbours J inside its horizon):
 *     rho0_I a_I += sum_J w(|X_IJ|) (P_J - P_I) K_I^-1 X_IJ V_J                      (Eq 39)
 *     P_J = -J_J p_J F_J^-T                                  (Eq 40, sign corrected)
 *   ejecta's choices where the paper is silent (digest "GAP"): the fluid particle's F is the
 *   isotropic F_J = (rho0_J / rho_J)^(1/3) I, so P_J = -p_J J_J^(2/3) I; its "reference" bond
 *   is pulled back through the solid particle's F, X_IJ = F_I^-1 x_IJ; V_J = m_J / rho_J.
 *   Fluid side (particle I of the fluid, solid neighbours J inside its kernel support): J is
 *   seen as a fluid particle of density rho_J = rho0_J / J_J (Eq 41 with J_J, erratum 12) and
 *   pressure p_J = -tr(sigma_J) / 3 (Eq 42, sign corrected), in the standard SPH momentum,
 *   energy and continuity sums with Monaghan viscosity.
 *   The two sides are not action-reaction pairs: momentum is conserved only approximately (the
 *   digest's remark); test_pd_sph.c measures the drift.
 *
 * Decohesion (ejecta's own design; 000 claims a "pressure-driven decohesion criterion" but gives
 * no formula, see its digest): a solid particle whose fluid neighbours reach a pressure above
 * `decohesion_pressure`, or whose volumetric strain J - 1 exceeds `decohesion_strain`, is marked
 * failed (field `failed`); the PD method then breaks all its bonds (point failure). */
#include <math.h>
#include <string.h>

#include "../continuum/continuum_pair.h"
#include "ejecta/plugin.h"
#include "ejecta/tensor.h"

enum { PDSPH_PAIRWISE = 0, PDSPH_PAPER = 1 };
enum { PDSPH_W_CONSTANT = 0, PDSPH_W_CONICAL2 = 1 };

typedef struct pd_sph_config {
  int form;
  int pair_stress;
  int kernel;
  ej_real alpha, beta, eta, h_factor;
  ej_real horizon;
  int influence;
  ej_real decohesion_pressure, decohesion_strain;
} pd_sph_config;

static const char *const pd_sph_forms[] = {"pairwise", "paper", NULL};
static const char *const pd_sph_pair_stress[] = {"fluid", "both", NULL};
static const char *const pd_sph_kernels[] = {"cubic_spline", "wendland_c2", NULL};
static const char *const pd_sph_influences[] = {"constant", "conical2", NULL};

static const ej_param pd_sph_params[] = {
    EJ_PARAM_ENUM(pd_sph_config, form, pd_sph_forms, "pairwise",
                  "pairwise: equal and opposite pair forces (exact momentum and energy); paper: 000 Eqs 39-42 "
                  "with the digest's sign corrections (approximate momentum exchange)."),
    EJ_PARAM_ENUM(pd_sph_config, pair_stress, pd_sph_pair_stress, "fluid",
                  "form pairwise: whose stress enters the pair term: fluid (the solid's own PD operator carries "
                  "its side) or both (the symmetric SPH form of the continuum interaction)."),
    EJ_PARAM_ENUM(pd_sph_config, kernel, pd_sph_kernels, "cubic_spline", "SPH kernel of the fluid-side sums."),
    EJ_PARAM_REAL(pd_sph_config, alpha, "1", 1.0, 0, 10, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX,
                  "Monaghan viscosity, linear coefficient, on approaching interface pairs."),
    EJ_PARAM_REAL(pd_sph_config, beta, "1", 2.0, 0, 20, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX,
                  "Monaghan viscosity, quadratic coefficient."),
    EJ_PARAM_REAL(pd_sph_config, eta, "1", 0.1, 0, 1, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX | EJ_PF_MIN_OPEN,
                  "Viscosity singularity guard (eta^2 hbar^2 added to r^2)."),
    EJ_PARAM_REAL(pd_sph_config, h_factor, "1", 1.3, 0.5, 3, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX,
                  "Smoothing length of solid particles (no 'h' field), in initial spacings."),
    EJ_PARAM_REAL(pd_sph_config, horizon, "1", 3.0, 1, 6, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX,
                  "form paper: horizon of a solid particle for its fluid neighbours, in its initial spacings."),
    EJ_PARAM_ENUM(pd_sph_config, influence, pd_sph_influences, "constant",
                  "form paper: influence function w of Eq 39: constant or (1 - r/delta)^2."),
    EJ_PARAM_REAL(pd_sph_config, decohesion_pressure, "Pa", 0, 0, 0, EJ_PF_HAS_MIN,
                  "ejecta decohesion: a solid particle whose fluid neighbours exceed this pressure loses all its "
                  "bonds; 0 = off."),
    EJ_PARAM_REAL(pd_sph_config, decohesion_strain, "1", 0, 0, 0, EJ_PF_HAS_MIN,
                  "ejecta decohesion: a solid particle next to the fluid whose J - 1 exceeds this loses all its "
                  "bonds; 0 = off."),
    {0}};

typedef struct pd_sph_state {
  pd_sph_config cfg;
  cpl_params P;
  const ej_set *solid; /* the set that publishes F (the PD side) */
  cpl_dt dt;
} pd_sph_state;

static ej_err pd_sph_create(const void *config, ej_set *a, ej_set *b, void **state)
{
  const pd_sph_config *c = config;
  EJ_ENSURE(b && a != b, EJ_ERR_INTERNAL, "pd_sph: the scene check lets only two different sets through");
  const bool fa = ej_set_field(a, "F") != NULL, fb = ej_set_field(b, "F") != NULL;
  if (fa == fb)
    EJ_FAIL(EJ_ERR_INPUT,
            "pd_sph couples one peridynamic set (publishing a deformation gradient F, e.g. tlpd) with one fluid "
            "set; sets '%s' and '%s' %s",
            ej_set_name(a), ej_set_name(b), fa ? "both publish F" : "publish no F");
  pd_sph_state *s = ej_calloc(1, sizeof *s);
  EJ_ENSURE(s, EJ_ERR_MEM, "out of memory");
  s->cfg = *c;
  s->P = (cpl_params){.kernel = c->kernel, .form = CPL_FORM_VOLUME, .alpha = c->alpha, .beta = c->beta, .eta = c->eta, .h_factor = c->h_factor};
  s->solid = fa ? a : b;
  const ej_err rc = cpl_dt_init(&s->dt, a, b);
  if (rc != EJ_OK) {
    ej_free(s);
    return rc;
  }
  *state = s;
  return EJ_OK;
}

static inline ej_real pd_sph_spacing(int dim, ej_real vol0)
{
  return dim == 1 ? vol0 : dim == 2 ? sqrt(vol0) : cbrt(vol0);
}

/* PD side of the paper form: Eq 39 over the fluid neighbours of solid particles in r. */
static ej_err pd_sph_paper_solid(const pd_sph_state *s, const cpl_side *S, const cpl_side *G, ej_set *solid,
                                 const ej_nbr *sg, ej_range r)
{
  const ej_real *F = ej_set_field(solid, "F"), *Kinv = ej_set_field(solid, "K_inv"), *PK = ej_set_field(solid, "PK");
  if (!Kinv || !PK)
    EJ_FAIL(EJ_ERR_INPUT, "pd_sph form paper needs the solid's method to publish K_inv and PK (tlpd does)");
  const ej_model *model = ej_set_model(solid);
  const ej_real rho0 = ej_model_rho0(model);
  const ej_model *gmodel = ej_set_model(G->set);
  const ej_real rho0_g = ej_model_rho0(gmodel);
  for (ej_idx i = r.begin; i < r.end; ++i) {
    ej_real Fi_inv[9], Ki[9];
    if (ej_m3_inverse(Fi_inv, F + 9 * i) == 0) continue; /* a crushed particle: no coupling force */
    ej_s6_to_m3(Ki, Kinv + 6 * i);
    const ej_real delta = s->cfg.horizon * pd_sph_spacing(S->dim, S->vol0[i]);
    ej_real f[3] = {0, 0, 0};
    for (ej_off k = sg->off[i]; k < sg->off[i + 1]; ++k) {
      const ej_idx j = sg->idx[k];
      const ej_real x[3] = {G->x[3 * j] - S->x[3 * i], G->x[3 * j + 1] - S->x[3 * i + 1], G->x[3 * j + 2] - S->x[3 * i + 2]};
      ej_real X[3];
      ej_m3_apply(X, Fi_inv, x);
      const ej_real lx = sqrt(X[0] * X[0] + X[1] * X[1] + X[2] * X[2]);
      if (lx >= delta || lx <= 0) continue;
      const ej_real w = s->cfg.influence == PDSPH_W_CONSTANT ? 1.0 : (1 - lx / delta) * (1 - lx / delta);
      /* fluid P_J = -p_J J^(2/3) I with J = rho0_J / rho_J (isotropic F_J) */
      const ej_real Jg = rho0_g / G->rho[j];
      const ej_real pj = G->p ? G->p[j] : -(G->stress[6 * j] + G->stress[6 * j + 1] + G->stress[6 * j + 2]) / 3;
      const ej_real Pj = -pj * cbrt(Jg * Jg);
      ej_real KX[3], PKX[3];
      ej_m3_apply(KX, Ki, X);
      ej_m3_apply(PKX, PK + 9 * i, X);
      const ej_real Vj = G->m[j] / G->rho[j];
      for (int q = 0; q < 3; ++q) f[q] += w * (Pj * KX[q] - PKX[q]) * Vj;
    }
    for (int q = 0; q < 3; ++q) S->a[3 * i + q] += f[q] / rho0;
  }
  return EJ_OK;
}

/* Fluid side of the paper form: standard SPH sums with the solid particle as a fluid particle of
 * density rho0/J and pressure -tr(sigma)/3 (Eqs 41-42). */
static void pd_sph_paper_fluid(const pd_sph_state *s, const cpl_side *G, const cpl_side *S, const ej_nbr *gs,
                               ej_range r)
{
  const int dim = G->dim;
  const ej_real sigma_k = sph_kernel_sigma(s->P.kernel, dim);
  for (ej_idx i = r.begin; i < r.end; ++i) {
    const ej_real rho_i = G->rho[i], pi_ = G->p ? G->p[i] : -ej_s6_trace(G->stress + 6 * i) / 3;
    const ej_real hi = cpl_h(G, i), ci = cpl_c(G, i), pr_i = pi_ / (rho_i * rho_i);
    ej_real acc[3] = {0, 0, 0}, de = 0, drho = 0;
    for (ej_off k = gs->off[i]; k < gs->off[i + 1]; ++k) {
      const ej_idx j = gs->idx[k];
      const ej_real dx[3] = {S->x[3 * j] - G->x[3 * i], S->x[3 * j + 1] - G->x[3 * i + 1], S->x[3 * j + 2] - G->x[3 * i + 2]};
      const ej_real r2 = dx[0] * dx[0] + dx[1] * dx[1] + dx[2] * dx[2];
      const ej_real hbar = 0.5 * (hi + cpl_h(S, j));
      if (r2 >= 4 * hbar * hbar || r2 <= 0) continue;
      const ej_real rr = sqrt(r2), ih = 1 / hbar;
      const ej_real dwdr = sigma_k * sph_inv_pow(ih, dim + 1) * sph_kernel_df(s->P.kernel, dim, rr * ih);
      const ej_real g[3] = {-dwdr * dx[0] / rr, -dwdr * dx[1] / rr, -dwdr * dx[2] / rr};
      const ej_real dv[3] = {S->v[3 * j] - G->v[3 * i], S->v[3 * j + 1] - G->v[3 * i + 1], S->v[3 * j + 2] - G->v[3 * i + 2]};
      const ej_real vx = dv[0] * dx[0] + dv[1] * dx[1] + dv[2] * dx[2];
      const ej_real rho_j = S->rho[j]; /* tlpd: rho0 / det F (Eq 41) */
      const ej_real pj = -ej_s6_trace(S->stress + 6 * j) / 3;
      ej_real pij = 0;
      if (vx < 0) {
        const ej_real mu = hbar * vx / (r2 + s->P.eta * s->P.eta * hbar * hbar);
        pij = (-s->P.alpha * 0.5 * (ci + cpl_c(S, j)) * mu + s->P.beta * mu * mu) / (0.5 * (rho_i + rho_j));
      }
      const ej_real mj = S->m[j], coef = pr_i + pj / (rho_j * rho_j) + pij;
      const ej_real vg = dv[0] * g[0] + dv[1] * g[1] + dv[2] * g[2]; /* (v_j - v_i) . grad_i W */
      for (int q = 0; q < 3; ++q) acc[q] -= mj * coef * g[q];
      de -= mj * (pr_i + 0.5 * pij) * vg; /* (v_i - v_j) . grad_i W = -vg */
      drho -= (mj / rho_j) * vg;
    }
    for (int q = 0; q < 3; ++q) G->a[3 * i + q] += acc[q];
    if (G->e_dot) G->e_dot[i] += de;
    if (G->rho_dot) G->rho_dot[i] += rho_i * drho;
  }
}

/* ejecta's decohesion rule on the solid side (see the file comment). */
static void pd_sph_decohesion(const pd_sph_state *s, const cpl_side *S, const cpl_side *G, ej_set *solid,
                              const ej_nbr *sg, ej_range r)
{
  int32_t *failed = ej_set_field_int(solid, "failed");
  const ej_real *F = ej_set_field(solid, "F");
  if (!failed) return;
  for (ej_idx i = r.begin; i < r.end; ++i) {
    if (failed[i] || sg->off[i + 1] == sg->off[i]) continue;
    bool fail = false;
    if (s->cfg.decohesion_strain > 0 && F && ej_m3_det(F + 9 * i) - 1 > s->cfg.decohesion_strain) fail = true;
    if (s->cfg.decohesion_pressure > 0)
      for (ej_off k = sg->off[i]; k < sg->off[i + 1] && !fail; ++k) {
        const ej_idx j = sg->idx[k];
        const ej_real dx[3] = {G->x[3 * j] - S->x[3 * i], G->x[3 * j + 1] - S->x[3 * i + 1], G->x[3 * j + 2] - S->x[3 * i + 2]};
        const ej_real hbar = 0.5 * (cpl_h(S, i) + cpl_h(G, j));
        if (dx[0] * dx[0] + dx[1] * dx[1] + dx[2] * dx[2] >= 4 * hbar * hbar) continue;
        const ej_real pj = G->p ? G->p[j] : -ej_s6_trace(G->stress + 6 * j) / 3;
        fail = pj > s->cfg.decohesion_pressure;
      }
    if (fail) failed[i] = 1;
  }
}

static ej_err pd_sph_compute(void *state, ej_set *a, ej_set *b, const ej_nbr *ab, int pass, ej_range r)
{
  (void)pass;
  const pd_sph_state *s = state;
  cpl_side A, B;
  EJ_TRY(cpl_bind(&A, a, "pd_sph", s->cfg.h_factor));
  EJ_TRY(cpl_bind(&B, b, "pd_sph", s->cfg.h_factor));
  const bool a_is_solid = a == s->solid;
  if (s->cfg.form == PDSPH_PAIRWISE) {
    /* traction form (file comment): only the fluid's stress enters the pair term */
    if (s->cfg.pair_stress == 1) cpl_gather(&s->P, &A, &B, ab, r);
    else if (a_is_solid) cpl_gather_w(&s->P, &A, &B, ab, r, 0, 1, 0);
    else cpl_gather_w(&s->P, &A, &B, ab, r, 1, 0, 1);
  } else if (a_is_solid) {
    EJ_TRY(pd_sph_paper_solid(s, &A, &B, a, ab, r));
  } else {
    if (!B.stress) EJ_FAIL(EJ_ERR_INPUT, "pd_sph form paper: the solid set '%s' publishes no stress", ej_set_name(b));
    pd_sph_paper_fluid(s, &A, &B, ab, r);
  }
  if (a_is_solid && (s->cfg.decohesion_pressure > 0 || s->cfg.decohesion_strain > 0))
    pd_sph_decohesion(s, &A, &B, a, ab, r);
  cpl_dt_gather(&A, &B, ab, r, cpl_dt_of(&s->dt, a));
  return EJ_OK;
}

static ej_err pd_sph_stable_dt(void *state, const ej_set *a, const ej_set *b, ej_real *dt)
{
  *dt = cpl_dt_min(&((const pd_sph_state *)state)->dt, a, b);
  return EJ_OK;
}

static void pd_sph_destroy(void *state)
{
  pd_sph_state *s = state;
  if (!s) return;
  cpl_dt_free(&s->dt);
  ej_free(s);
}

static const ej_interaction_ops pd_sph_ops = {
    .struct_size = sizeof(ej_interaction_ops),
    .name = "pd_sph",
    .summary = "Peridynamics-SPH coupling (Fan & Li 000 §2.4, sign-corrected) with a conserving pairwise form",
    .doc = "Couples a peridynamic solid set (tlpd) with a fluid set (sph, ulpd). form: pairwise applies equal and "
           "opposite SPH stress-form pair forces (exact momentum and energy); form: paper applies 000 Eqs 39-42 with "
           "the digest's sign corrections (P = -J p F^-T for a fluid particle seen from the PD side, p = -tr(P F^T)/(3J) "
           "for a PD particle seen from the fluid side) and an isotropic F for fluid particles. Optional decohesion "
           "(ejecta's own rule): solid particles next to fluid above a pressure, or dilated beyond a strain, lose "
           "all their bonds. See plugins/interactions/pd_sph/README.md.",
    .params = pd_sph_params,
    .config_size = sizeof(pd_sph_config),
    .create = pd_sph_create,
    .compute = pd_sph_compute,
    .stable_dt = pd_sph_stable_dt,
    .destroy = pd_sph_destroy,
    .both_ways = true,
    .n_passes = 1,
    .n_sets = 2,
};

static ej_err pd_sph_register(ej_registry *reg) { return ej_register_interaction(reg, &pd_sph_ops); }

EJ_PLUGIN_DEFINE(pd_sph, "0.1.0", "BSD-3-Clause", "Peridynamics-SPH coupling", pd_sph_register)

/* Interaction `continuum`: generic coupling of two continuum particle sets of any methods
 * (SPH–SPH of different materials, UL-PD–TL-PD, SPH–TL-PD, RKPM...) through the pairwise
 * SPH stress form of continuum_pair.h. Both ways, so each pair force is applied with opposite
 * signs to the two particles: momentum and energy are conserved to round-off. A set run by sph with
 * the shape tensor gets the other set's neighbours in its M_i (a pre-pass before sph's shape pass,
 * core ABI 1.7 pre_pass_before) and sph's G_ij on the interface pairs (gradient: auto; README). */
#include <math.h>
#include <string.h>

#include "continuum_pair.h"
#include "ejecta/plugin.h"

typedef struct continuum_config {
  int kernel;
  int form;
  int continuity;
  ej_real alpha, beta, eta, h_factor;
  ej_real conductivity;
  int gradient;
} continuum_config;

static const char *const continuum_kernels[] = {"cubic_spline", "wendland_c2", NULL};
static const char *const continuum_forms[] = {"volume", "standard", NULL};
static const char *const continuum_continuity[] = {"volume", "blend", NULL};

static const ej_param continuum_params[] = {
    EJ_PARAM_ENUM(continuum_config, kernel, continuum_kernels, "cubic_spline",
                  "Kernel of the interface pair terms (support 2 hbar, hbar the mean smoothing length of the pair)."),
    EJ_PARAM_ENUM(continuum_config, form, continuum_forms, "volume",
                  "Pair form: volume, (sigma_i + sigma_j)/(rho_i rho_j) (Colagrossi & Landrini 2003; robust at "
                  "density ratios over 1000), or standard, sigma_i/rho_i^2 + sigma_j/rho_j^2."),
    EJ_PARAM_ENUM(continuum_config, continuity, continuum_continuity, "volume",
                  "Interface continuity: volume, rho_i sum_j (m_j/rho_j) v_ij.grad W (001 Eq 3), or blend, the "
                  "density-ratio-adaptive blend of 001 Eq 4 (Liu, Zhang & Feng 2017): psi = 1/ln(rho_max/rho_min) "
                  "over the support, weight (rho_i + psi rho_j)/((1 + psi) rho_j) on m_j v_ij.grad W."),
    EJ_PARAM_REAL(continuum_config, alpha, "1", 1.0, 0, 10, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX,
                  "Monaghan artificial viscosity, linear coefficient, on approaching interface pairs."),
    EJ_PARAM_REAL(continuum_config, beta, "1", 2.0, 0, 20, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX,
                  "Monaghan artificial viscosity, quadratic coefficient."),
    EJ_PARAM_REAL(continuum_config, eta, "1", 0.1, 0, 1, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX | EJ_PF_MIN_OPEN,
                  "Viscosity singularity guard: eta^2 hbar^2 is added to r^2."),
    EJ_PARAM_REAL(continuum_config, h_factor, "1", 0, 0, 3, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX,
                  "Smoothing length of a particle whose method publishes no 'h', in initial spacings; 0: the "
                  "h/spacing ratio of the other particle of each pair when it has an h, else 1.3."),
    EJ_PARAM_REAL(continuum_config, conductivity, "1", 0.0, 0.0, 10.0, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX,
                  "Artificial conductivity alpha_u on the interface pairs (Price 2008): de_i/dt += sum_j m_j alpha_u "
                  "v_sig (e_i - e_j)/rhobar dW/dr, v_sig = sqrt(|p_i - p_j|/rhobar), both sets' e exchanged "
                  "antisymmetrically (energy conserved); needs e on both sets; 0 is off."),
    EJ_PARAM_ENUM(continuum_config, gradient, cpl_gradient_names, "auto",
                  "Pair gradient. auto: where a set runs sph with gradient: shape_tensor, its shape tensor M_i "
                  "includes the other set's neighbours (a pre-pass before the pass that inverts it) and the "
                  "interface pairs use sph's symmetric G_ij = (M_i^-1 + M_j^-1) w_ij x_ij / 2 (the kernel gradient "
                  "for a side without it or on its fallback) in the stress and pdV terms and a shape-tensor "
                  "particle's continuity, the kernel gradient in the viscosity; kernel: the kernel gradient grad_i W on every pair (the form before "
                  "2026-11-30). Without a shape-tensor set both are the same."),
    {0}};

typedef struct continuum_state {
  cpl_params P;
  cpl_dt dt;
} continuum_state;

static ej_err continuum_create(const void *config, ej_set *a, ej_set *b, void **state)
{
  const continuum_config *c = config;
  EJ_ENSURE(b && a != b, EJ_ERR_INTERNAL, "continuum: the scene check lets only two different sets through");
  for (int k = 0; k < 2; ++k)
    EJ_TRY(cpl_check_ren(k ? b : a, "continuum", c->continuity == CPL_CONT_VOLUME, "continuity: volume"));
  continuum_state *s = ej_calloc(1, sizeof *s);
  EJ_ENSURE(s, EJ_ERR_MEM, "out of memory");
  s->P = (cpl_params){.kernel = c->kernel, .form = c->form, .continuity = c->continuity, .alpha = c->alpha,
                      .beta = c->beta, .eta = c->eta, .h_factor = c->h_factor,
                      .conductivity = c->conductivity, .shape = c->gradient == CPL_GRADIENT_AUTO};
  const ej_err rc = cpl_dt_init(&s->dt, a, b);
  if (rc != EJ_OK) {
    ej_free(s);
    return rc;
  }
  *state = s;
  return EJ_OK;
}

/* Binding per call: field pointers move when a set grows its ghosts at a rebuild. */
static ej_err continuum_compute(void *state, ej_set *a, ej_set *b, const ej_nbr *ab, int pass, ej_range r)
{
  const continuum_state *s = state;
  cpl_side A, B;
  EJ_TRY(cpl_bind(&A, a, "continuum", s->P.h_factor));
  EJ_TRY(cpl_bind(&B, b, "continuum", s->P.h_factor));
  if (pass < 0) { /* the pre-pass (before sph's shape pass): the other set's share of M_i */
    if (s->P.shape) cpl_shape_share(&s->P, &A, &B, ab, r);
    return EJ_OK;
  }
  cpl_gather(&s->P, &A, &B, ab, r);
  cpl_dt_gather(&A, &B, ab, r, cpl_dt_of(&s->dt, a));
  return EJ_OK;
}

static ej_err continuum_stable_dt(void *state, const ej_set *a, const ej_set *b, ej_real *dt)
{
  *dt = cpl_dt_min(&((const continuum_state *)state)->dt, a, b);
  return EJ_OK;
}

static void continuum_destroy(void *state)
{
  continuum_state *s = state;
  if (!s) return;
  cpl_dt_free(&s->dt);
  ej_free(s);
}

static int continuum_pass_writes(const void *state, int pass, int side, const char **names, int max)
{
  (void)state, (void)side;
  return cpl_pass_writes(pass, names, max, NULL);
}

static const ej_interaction_ops continuum_ops = {
    .struct_size = sizeof(ej_interaction_ops),
    .name = "continuum",
    .summary = "Generic momentum-conserving coupling of two continuum sets of any methods (SPH stress form)",
    .doc = "Pairwise SPH stress-form forces between the particles of two sets, dv_i/dt = sum_j m_j S_ij grad_i W with "
           "S_ij = (sigma_i + sigma_j)/(rho_i rho_j) - Pi_ij I (form: volume, default) or sigma_i/rho_i^2 + "
           "sigma_j/rho_j^2 - Pi_ij I (form: standard), with the matching energy and continuity terms, evaluated from "
           "each side in gather form so that the pair forces are equal and opposite: momentum and energy are "
           "conserved to round-off. Works for every method that publishes rho and stress or p (sigma = -p I), "
           "optionally c and h. See plugins/interactions/continuum/README.md.",
    .params = continuum_params,
    .config_size = sizeof(continuum_config),
    .create = continuum_create,
    .compute = continuum_compute,
    .stable_dt = continuum_stable_dt,
    .destroy = continuum_destroy,
    .both_ways = true,
    .n_passes = 1,
    .n_sets = 2,
    .n_pre_passes = 1,
    .pre_pass_before = "M_inv",
    .pass_writes = continuum_pass_writes,
};

static ej_err continuum_register(ej_registry *reg) { return ej_register_interaction(reg, &continuum_ops); }

EJ_PLUGIN_DEFINE(continuum, "0.1.0", "BSD-3-Clause", "Generic continuum coupling between two particle sets",
                 continuum_register)

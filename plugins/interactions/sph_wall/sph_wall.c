/* Interaction `sph_wall`: dummy-particle walls of Adami, Hu & Adams, J. Comput. Phys. 231 (2012)
 * 7057-7075 ("A generalized wall boundary condition for smoothed particle hydrodynamics"), as
 * digest 001 §1.10 (Chen et al. 2021, after Peng et al. 2019 for soils) uses them, between an SPH
 * set (gas/liquid, or solid with `strength: true`) and a wall set whose particles do not move
 * under the wall forces (method rigid_body with fix_translation/fix_rotation [1,1,1], or any
 * method with fixed or prescribed-velocity boundary conditions).
 *
 * Gather form in two passes (both_ways; the core calls pass 0 then pass 1, each first over the
 * SPH set's ranges, then over the wall set's ranges, with ghosts refreshed in between), and for a
 * solid with wall_gradient a pre-pass (pass -1, n_pre_passes = 1: before sph's own passes) that
 * adds the wall's share of the velocity gradient (with sph's correction, of B_i too) to sph's
 * fields L_wall (and B_wall), which sph consumes and zeroes (sw_grad_pass):
 *  pass 0, wall side: each wall particle w extrapolates from its SPH neighbours f (owned and
 *    ghost), with W_wf = W(|x_w - x_f|, h_f) and r_wf = x_w - x_f,
 *      sigma_w = [sum_f sigma_f W_wf - ((g - a_w) . sum_f rho_f r_wf W_wf) I] / sum_f W_wf
 *    (Adami Eq 27 written for a stress tensor: digest 001 §1.10 with its index erratum, the
 *    (g - a) . r term is a dot product times I; sigma = -p I gives Adami's p_w exactly);
 *      v~_w = sum_f v_f W_wf / sum_f W_wf                                     (Adami Eq 22)
 *    no-slip: v_w,visc = 2 v_w - v~_w                                         (Adami Eq 23)
 *    viscosity_velocity: wall (either slip): v_w,visc = v_w, the wall particle's own velocity in the
 *      Monaghan viscosity (PySPH's Adami scheme: MomentumEquationArtificialViscosity takes the
 *      solids as sources with their own velocity; Eq 23's ghost velocity enters only its physical
 *      viscous term SolidWallNoSlipBC, pysph/sph/wc/transport_velocity.py and sph/scheme.py);
 *    viscosity_velocity: wall_normal: as wall, but only the normal part ((v_i - v_w).n) n of the
 *      relative velocity enters the viscosity and the viscous force acts along (grad_i W . n) n,
 *      n = n_i the SPH particle's wall normal sum_w (x_i - x_w)|dW/dr| normalised (as the
 *      gradient pre-pass): damping of the normal approach without friction;
 *    free-slip: no viscous wall term (Adami et al. impose no-slip through the viscous term only: for
 *      free slip the viscous wall interaction is dropped), and the stress mirrored about the wall with
 *      n = sum_f (x_f - x_w) W_wf / |...| (towards the material):
 *      sigma_w <- Q sigma_w Q^T, Q = I - 2 n n^T, so that the shear traction n.sigma.t of the
 *      pair sum cancels (a frictionless wall for a solid; no effect on a pressure);
 *    density: auto = the EOS inverse p(rho_w, e~_w) = p_w for a set without strength (Adami Eq 28,
 *      by Newton on the EOS with c^2 as dp/drho), the Shepard average of rho_f for solids;
 *      or shepard / rest (rho0 of the SPH set's material) on request.
 *  pass 1, SPH side: for each SPH particle i and wall neighbour w, with m_w = rho_w vol0_w (the
 *    wall particle's geometric volume; the wall material's own rho0 plays no role) and
 *    grad_i W = dW/dr(r, h_i) (x_i - x_w)/r:
 *      dv_i/dt   += sum_w m_w (sigma_i/rho_i^2 + sigma_w/rho_w^2 - Pi_iw I) grad_i W
 *      drho_i/dt += rho_i sum_w vol0_w (v_i - v_w) . grad_i W            (v_w the wall's velocity;
 *                   not for a solid with wall_gradient: sph's -rho tr(L + L_wall) holds it)
 *      de_i/dt   += -sum_w m_w (sigma_i/rho_i^2) : ((v_i - v_w) (x) grad_i W)
 *                   + sum_w m_w Pi_iw (v_i - v_w) . grad_i W   (all viscous heat to i: minus the
 *                     power of the viscous force relative to the wall)
 *    Pi_iw is Monaghan's viscosity (digest 001 §1.7 with the §1.4 sign erratum: -Pi I) on the
 *    velocity v_i - v_w,visc, c and rho of the pair from i and w.
 *
 * The wall has no internal energy: the part of the pair work that a symmetric SPH pair would give
 * to w is reported as the series `work` (role WORK: work done on the SPH set by the wall and its
 * discretisation), so the core's energy budget stays closed.
 *
 * Stable step of the wall pairs: h_i / (c_i + 2 |v_i - v_w|) (the wall's stress is extrapolated
 * from the same material, so signals cross the pair at c_i; 2 |v| closes the gap). */
#include <math.h>
#include <string.h>

#include "../../methods/sph/sph_kernels.h"
#include "ejecta/plugin.h"
#include "ejecta/tensor.h"

enum { SW_NO_SLIP = 0, SW_FREE_SLIP = 1 };
enum { SW_RHO_AUTO = 0, SW_RHO_SHEPARD = 1, SW_RHO_REST = 2 };
enum { SW_VISC_EXTRAPOLATED = 0, SW_VISC_WALL = 1, SW_VISC_WALL_NORMAL = 2 };

typedef struct sw_config {
  int kernel;
  int slip;
  int density;
  ej_real gravity[3];
  ej_real wall_acceleration[3];
  ej_real alpha, beta, eta;
  bool wall_gradient;
  int viscosity_velocity;
} sw_config;

static const char *const sw_kernels[] = {"cubic_spline", "wendland_c2", NULL};
static const char *const sw_slips[] = {"no_slip", "free_slip", NULL};
static const char *const sw_densities[] = {"auto", "shepard", "rest", NULL};
static const char *const sw_visc_velocities[] = {"extrapolated", "wall", "wall_normal", NULL};

static const ej_param sw_params[] = {
    EJ_PARAM_ENUM(sw_config, kernel, sw_kernels, "cubic_spline",
                  "Kernel of the wall pair terms, support 2 h_i with h_i the SPH particle's smoothing length: use "
                  "the SPH set's kernel."),
    EJ_PARAM_ENUM(sw_config, slip, sw_slips, "no_slip",
                  "no_slip: the viscous term sees the wall velocity 2 v_w - v~_w and the wall stress is the "
                  "extrapolated one (shear transmitted); free_slip: no viscous wall term and the stress mirrored "
                  "about the wall (no shear traction)."),
    EJ_PARAM_ENUM(sw_config, density, sw_densities, "auto",
                  "Wall particle density: auto (EOS inverse of the wall pressure for a set without strength, "
                  "Adami Eq 28; Shepard average for solids), shepard (kernel average of the neighbours' "
                  "densities) or rest (rho0 of the SPH set's material)."),
    EJ_PARAM_ARRAY(sw_config, gravity, 3, "m/s^2", 0,
                   "Body acceleration g of the pressure extrapolation (Adami Eq 27): give the scene's gravity "
                   "(3 components; interactions cannot read it)."),
    EJ_PARAM_ARRAY(sw_config, wall_acceleration, 3, "m/s^2", 0,
                   "Acceleration a_w of the wall (Adami Eq 27); zero for a wall at rest or moving at constant "
                   "velocity."),
    EJ_PARAM_REAL(sw_config, alpha, "1", 1.0, 0, 10, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX,
                  "Monaghan artificial viscosity of the wall pairs, linear coefficient (use the SPH set's)."),
    EJ_PARAM_REAL(sw_config, beta, "1", 2.0, 0, 20, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX,
                  "Monaghan artificial viscosity of the wall pairs, quadratic coefficient (use the SPH set's)."),
    EJ_PARAM_REAL(sw_config, eta, "1", 0.1, 0, 1, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX | EJ_PF_MIN_OPEN,
                  "Viscosity singularity guard: eta^2 h^2 is added to r^2."),
    EJ_PARAM_BOOL(sw_config, wall_gradient, 1,
                  "Solids: the wall pairs enter the velocity gradient of the SPH particles next to the wall, "
                  "L_i += sum_w vol0_w (v_w - v_i) (x) grad_i W (free slip: normal part only), through sph's field "
                  "L_wall filled before sph's stress pass (one material update per step; without it a solid sees "
                  "no elastic compression or shear from the wall)."),
    EJ_PARAM_ENUM(sw_config, viscosity_velocity, sw_visc_velocities, "extrapolated",
                  "Velocity of the wall particle in the wall pairs' Monaghan viscosity: extrapolated (no_slip: "
                  "2 v_w - v~_w, Adami Eq 23; free_slip: no viscous wall term) or wall (the wall particle's own "
                  "velocity v_w for either slip, as PySPH's Adami scheme applies its artificial viscosity) or wall_normal "
                  "(only the normal relative velocity n.(v_i - v_w) enters, and the viscous force acts along n, the "
                  "wall normal: damping without friction)."),
    {0}};

typedef struct sw_state {
  sw_config cfg;
  const ej_set *fluid, *wall;
  ej_idx n_fluid, n_wall;
  const ej_eos *eos; /* EOS inverse for the wall density (NULL: Shepard or rest) */
  bool grad;          /* solid with wall_gradient: the pre-pass fills sph's L_wall */
  ej_real rho_rest;
  bool solid;
  /* per wall particle (owned; the wall set has no ghosts) */
  ej_real *w_sig;   /* [6] extrapolated (and for free slip mirrored) stress */
  ej_real *w_rho;   /* wall density */
  ej_real *w_vvis;  /* [3] velocity the viscous term sees */
  /* per SPH particle */
  ej_real *f_dt;    /* stable step of its wall pairs */
  ej_real *f_power; /* m_i (v_i . a_i^wall + de_i^wall): power of the wall's share */
  ej_real *f_force; /* [3] m_i a_i^wall */
  ej_real work, power_prev;
  ej_real force[3];
  bool have_power;
} sw_state;

static void sw_destroy(void *state)
{
  sw_state *s = state;
  if (!s) return;
  ej_free(s->w_sig), ej_free(s->w_rho), ej_free(s->w_vvis);
  ej_free(s->f_dt), ej_free(s->f_power), ej_free(s->f_force);
  ej_free(s);
}

static ej_err sw_create(const void *config, ej_set *a, ej_set *b, void **state)
{
  EJ_ENSURE(b && a != b, EJ_ERR_INTERNAL, "sph_wall: the scene check lets only two different sets through");
  const sw_config *c = config;
  if (!ej_set_field(a, "h") || !ej_set_field(a, "rho") || !(ej_set_field(a, "p") || ej_set_field(a, "stress")))
    EJ_FAIL(EJ_ERR_INPUT,
            "sph_wall: the first set '%s' must be an SPH set (fields h, rho and p or stress); write sets: [sph_set, "
            "wall_set]",
            ej_set_name(a));
  /* A wall set with mirror or periodic images (an SPH wall under a symmetry or periodic boundary)
   * cannot be extrapolated: its ghosts have no wall state. Known from the scene (ABI 1.10), so
   * `ejecta check` refuses it at the interaction; compute keeps the same test on the actual ghosts. */
  if (ej_set_has_images(b))
    EJ_FAIL(EJ_ERR_INPUT,
            "sph_wall: wall set '%s' gets mirror or periodic images from a symmetry or periodic boundary: restrict "
            "those boundaries to the SPH set ('set: %s') and extend the wall across the plane by the kernel support",
            ej_set_name(b), ej_set_name(a));
  sw_state *s = ej_calloc(1, sizeof *s);
  EJ_ENSURE(s, EJ_ERR_MEM, "out of memory");
  s->cfg = *c;
  s->fluid = a, s->wall = b;
  s->n_fluid = ej_set_count(a), s->n_wall = ej_set_count(b);
  s->solid = ej_set_field(a, "stress") != NULL;
  const ej_model *model = ej_set_model(a);
  s->rho_rest = model ? ej_model_rho0(model) : 0;
  const ej_eos *eos = model ? ej_model_eos(model) : NULL;
  if (c->density == SW_RHO_AUTO && !s->solid) s->eos = eos;
  if (s->solid && c->wall_gradient) {
    if (!ej_set_field(a, "L_wall")) {
      ej_free(s);
      EJ_FAIL(EJ_ERR_INPUT,
              "sph_wall: wall_gradient needs the field L_wall on set '%s' (method sph with strength: true); set "
              "wall_gradient: false for another method",
              ej_set_name(a));
    }
    s->grad = true;
  }
  const size_t nw = (size_t)s->n_wall + 1, nf = (size_t)s->n_fluid + 1;
  s->w_sig = ej_calloc(6 * nw, sizeof(ej_real));
  s->w_rho = ej_calloc(nw, sizeof(ej_real));
  s->w_vvis = ej_calloc(3 * nw, sizeof(ej_real));
  s->f_dt = ej_calloc(nf, sizeof(ej_real));
  s->f_power = ej_calloc(nf, sizeof(ej_real));
  s->f_force = ej_calloc(3 * nf, sizeof(ej_real));
  if (!s->w_sig || !s->w_rho || !s->w_vvis || !s->f_dt || !s->f_power || !s->f_force) {
    sw_destroy(s);
    EJ_FAIL(EJ_ERR_MEM, "out of memory");
  }
  for (ej_idx i = 0; i < s->n_fluid; ++i) s->f_dt[i] = INFINITY;
  *state = s;
  return EJ_OK;
}

/* Stress of SPH particle i (sigma = -p I for a set without strength). */
static inline void sw_fluid_stress(const ej_real *stress, const ej_real *p, ej_idx i, ej_real sig[6])
{
  if (stress) {
    for (int k = 0; k < 6; ++k) sig[k] = stress[6 * i + k];
  } else {
    sig[0] = sig[1] = sig[2] = -p[i];
    sig[3] = sig[4] = sig[5] = 0;
  }
}

/* Density with p(rho, e) = p_w (Adami Eq 28 for a general EOS): Newton with dp/drho ~ c^2, which
 * is exact for a barotropic EOS and close for p(rho, e) at the small wall compressions. */
static ej_err sw_eos_inverse(const sw_state *s, ej_real p_w, ej_real e_w, ej_real rho_start, ej_real *rho)
{
  ej_real r = rho_start > 0 ? rho_start : s->rho_rest;
  for (int it = 0; it < 20; ++it) {
    ej_real p, c;
    EJ_TRY(ej_eos_evaluate(s->eos, 1, &r, &e_w, &p, &c));
    if (!(c > 0)) break;
    ej_real dr = (p - p_w) / (c * c);
    /* keep rho positive: at most halve it per iteration */
    if (dr > 0.5 * r) dr = 0.5 * r;
    r -= dr;
    if (fabs(dr) <= 1e-12 * r) break;
  }
  *rho = r;
  return EJ_OK;
}

/* Pass 0 over wall particles r: extrapolated stress, density and viscous velocity. */
static ej_err sw_wall_pass(sw_state *s, ej_set *wall, ej_set *fl, const ej_nbr *wf, ej_range r)
{
  const int dim = ej_set_dim(wall);
  const sw_config *c = &s->cfg;
  const ej_real *xw = ej_set_field(wall, "x"), *vw = ej_set_field(wall, "v");
  const ej_real *xf = ej_set_field(fl, "x"), *vf = ej_set_field(fl, "v"), *rf = ej_set_field(fl, "rho");
  const ej_real *hf = ej_set_field(fl, "h"), *pf = ej_set_field(fl, "p"), *sf = ej_set_field(fl, "stress");
  const ej_real *ef = ej_set_field(fl, "e");
  const ej_real sigma_k = sph_kernel_sigma(c->kernel, dim);
  const ej_real ga[3] = {c->gravity[0] - c->wall_acceleration[0], c->gravity[1] - c->wall_acceleration[1],
                         c->gravity[2] - c->wall_acceleration[2]};
  for (ej_idx w = r.begin; w < r.end; ++w) {
    ej_real sw = 0, sig[6] = {0, 0, 0, 0, 0, 0}, rr[3] = {0, 0, 0}, vt[3] = {0, 0, 0}, nn[3] = {0, 0, 0};
    ej_real rho_s = 0, e_s = 0;
    for (ej_off k = wf->off[w]; k < wf->off[w + 1]; ++k) {
      const ej_idx f = wf->idx[k];
      const ej_real d[3] = {xw[3 * w] - xf[3 * f], xw[3 * w + 1] - xf[3 * f + 1], xw[3 * w + 2] - xf[3 * f + 2]};
      const ej_real r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
      const ej_real h = hf[f];
      if (r2 >= 4.0 * h * h) continue;
      const ej_real ih = 1.0 / h;
      const ej_real W = sigma_k * sph_inv_pow(ih, dim) * sph_kernel_f(c->kernel, dim, sqrt(r2) * ih);
      ej_real sg[6];
      sw_fluid_stress(sf, pf, f, sg);
      for (int q = 0; q < 6; ++q) sig[q] += sg[q] * W;
      for (int q = 0; q < 3; ++q) {
        rr[q] += rf[f] * d[q] * W; /* rho_f r_wf W_wf, r_wf = x_w - x_f */
        vt[q] += vf[3 * f + q] * W;
        nn[q] -= d[q] * W; /* towards the material */
      }
      rho_s += rf[f] * W;
      if (ef) e_s += ef[f] * W;
      sw += W;
    }
    ej_real *S = &s->w_sig[6 * w], *V = &s->w_vvis[3 * w];
    const ej_real *v0 = &vw[3 * w];
    if (sw <= 0) {
      for (int q = 0; q < 6; ++q) S[q] = 0;
      for (int q = 0; q < 3; ++q) V[q] = v0[q];
      s->w_rho[w] = s->rho_rest;
      continue;
    }
    const ej_real isw = 1.0 / sw;
    /* Adami Eq 27 / digest 001 §1.10: sigma_w = [sum sigma_f W - ((g - a_w) . sum rho_f r_wf W) I] / sum W */
    const ej_real hyd = (ga[0] * rr[0] + ga[1] * rr[1] + ga[2] * rr[2]) * isw;
    for (int q = 0; q < 6; ++q) S[q] = sig[q] * isw;
    S[0] -= hyd, S[1] -= hyd, S[2] -= hyd;
    for (int q = 0; q < 3; ++q) vt[q] *= isw;
    const bool own = c->viscosity_velocity != SW_VISC_EXTRAPOLATED;
    if (own)
      for (int q = 0; q < 3; ++q) V[q] = v0[q]; /* the wall's own velocity in the viscosity */
    if (c->slip == SW_NO_SLIP) {
      if (!own)
        for (int q = 0; q < 3; ++q) V[q] = 2.0 * v0[q] - vt[q]; /* Adami Eq 23 */
    } else {
      const ej_real nl = sqrt(nn[0] * nn[0] + nn[1] * nn[1] + nn[2] * nn[2]);
      if (nl > 0) {
        const ej_real n[3] = {nn[0] / nl, nn[1] / nl, nn[2] / nl};
        for (int q = 0; q < 3; ++q) V[q] = v0[q]; /* viscosity_velocity: wall (else unused) */
        ej_real Q[9];
        for (int a = 0; a < 3; ++a)
          for (int b = 0; b < 3; ++b) Q[3 * a + b] = (a == b ? 1.0 : 0.0) - 2.0 * n[a] * n[b];
        ej_s6_rotate(S, Q, S);
      } else {
        for (int q = 0; q < 3; ++q) V[q] = v0[q];
      }
    }
    const ej_real rho_sh = rho_s * isw;
    if (c->density == SW_RHO_REST) {
      s->w_rho[w] = s->rho_rest;
    } else if (s->eos) {
      const ej_real p_w = -(S[0] + S[1] + S[2]) / 3.0;
      EJ_TRY(sw_eos_inverse(s, p_w, e_s * isw, rho_sh, &s->w_rho[w]));
    } else {
      s->w_rho[w] = rho_sh;
    }
    if (!(s->w_rho[w] > 0)) s->w_rho[w] = s->rho_rest;
  }
  return EJ_OK;
}


/* The geometry of a particle-wall pair: dx = x_w - x_i, dW/dr and grad_i W; false outside the
 * support (2h) or at zero distance. */
static inline bool sw_pair(int kernel, int dim, const ej_real *xi, const ej_real *xw, ej_real h, ej_real ih,
                           ej_real dwfac, ej_real dx[3], ej_real *dwdr, ej_real g[3])
{
  for (int q = 0; q < 3; ++q) dx[q] = xw[q] - xi[q];
  const ej_real r2 = dx[0] * dx[0] + dx[1] * dx[1] + dx[2] * dx[2];
  if (r2 >= 4.0 * h * h || r2 <= 0) return false;
  const ej_real rr = sqrt(r2);
  *dwdr = dwfac * sph_kernel_df(kernel, dim, rr * ih);
  for (int q = 0; q < 3; ++q) g[q] = -*dwdr * dx[q] / rr;
  return true;
}

/* Pre-pass (pass -1, before sph's passes) over solid SPH particles r: the wall's share of the
 * velocity gradient, added to sph's scratch field L_wall, which sph_solid_stress_pass adds to
 * its own L_i before the single material update of the step (rate of deformation and spin), and
 * zeroes:
 *   L_w,i = sum_w vol0_w (v_w - v_i) (x) grad_i W(x_i - x_w, h_i)
 * the wall particles as SPH neighbours of i in 001 Eq 1.6 (Peng et al. 2019's dummy particles in
 * the strain rate), with the wall's own velocity v_w as in the continuity and energy terms. Free
 * slip keeps only the normal part (n . L_w n) n (x) n (no shear, no spin from a frictionless wall).
 * sph's continuity rho_dot = -rho tr L then holds the wall's compression, so the fluid pass adds
 * no drho for these particles. With sph's correction the wall's share of B_i,
 *   B_w,i = sum_w vol0_w (x_w - x_i) (x) grad_i W(x_i - x_w, h_i),
 * is added to sph's B_wall, which sph's correction pass adds to B_i before inverting it, and sph
 * multiplies L_w,i by that L_corr,i: the wall particles are neighbours in B_i as in L_i, so a
 * linear velocity field gives the exact gradient next to the wall (Bonet & Lok 1999's condition
 * over the whole neighbourhood; before 2026-12-03 L_w,i was added uncorrected to a sum corrected
 * over the set's own neighbours only: sph README "Walls in the corrected gradient"). x and v are
 * those of t_n+1; h_i is the previous evaluation's (sph's setup value at t = 0). */
static ej_err sw_grad_pass(const sw_state *s, ej_set *fl, ej_set *wall, const ej_nbr *fw, ej_range r)
{
  const int dim = ej_set_dim(fl);
  const sw_config *c = &s->cfg;
  const ej_real *xf = ej_set_field(fl, "x"), *vf = ej_set_field(fl, "v"), *hf = ej_set_field(fl, "h");
  const ej_real *xw = ej_set_field(wall, "x"), *vw = ej_set_field(wall, "v"), *volw = ej_set_field(wall, "vol0");
  ej_real *Lwall = ej_set_field(fl, "L_wall");
  ej_real *Bwall = ej_set_field(fl, "B_wall"); /* sph with correction: true only */
  EJ_ENSURE(xf && vf && hf && xw && vw && volw && Lwall, EJ_ERR_INTERNAL, "sph_wall: fields missing");
  const ej_real sigma_k = sph_kernel_sigma(c->kernel, dim);
  for (ej_idx i = r.begin; i < r.end; ++i) {
    const ej_real h = hf[i];
    if (!(h > 0)) continue;
    const ej_real ih = 1.0 / h, dwfac = sigma_k * sph_inv_pow(ih, dim + 1);
    ej_real Lw[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0}, Bw[6] = {0, 0, 0, 0, 0, 0}, nrm[3] = {0, 0, 0};
    int n_wall = 0;
    for (ej_off k = fw->off[i]; k < fw->off[i + 1]; ++k) {
      const ej_idx w = fw->idx[k];
      ej_real dx[3], dwdr, g[3];
      if (!sw_pair(c->kernel, dim, xf + 3 * (size_t)i, xw + 3 * (size_t)w, h, ih, dwfac, dx, &dwdr, g)) continue;
      const ej_real dv[3] = {vw[3 * w] - vf[3 * i], vw[3 * w + 1] - vf[3 * i + 1], vw[3 * w + 2] - vf[3 * i + 2]};
      for (int a = 0; a < 3; ++a)
        for (int q = 0; q < 3; ++q) Lw[3 * a + q] += volw[w] * dv[a] * g[q];
      /* B_i's wall share, sum V_w (x_w - x_i) (x) grad_i W (symmetric: dx is parallel to g) */
      const ej_real vb = volw[w];
      Bw[0] += vb * dx[0] * g[0], Bw[1] += vb * dx[1] * g[1], Bw[2] += vb * dx[2] * g[2];
      Bw[3] += vb * dx[0] * g[1], Bw[4] += vb * dx[1] * g[2], Bw[5] += vb * dx[2] * g[0];
      for (int q = 0; q < 3; ++q) nrm[q] += dx[q] * dwdr; /* dW/dr < 0, x_w - x_i: away from the wall */
      ++n_wall;
    }
    if (n_wall == 0) continue;
    if (c->slip == SW_FREE_SLIP) {
      const ej_real nl = sqrt(nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2]);
      if (nl > 0) {
        const ej_real n[3] = {nrm[0] / nl, nrm[1] / nl, nrm[2] / nl};
        ej_real Ln[3];
        ej_m3_apply(Ln, Lw, n);
        const ej_real lnn = n[0] * Ln[0] + n[1] * Ln[1] + n[2] * Ln[2];
        for (int a = 0; a < 3; ++a)
          for (int q = 0; q < 3; ++q) Lw[3 * a + q] = lnn * n[a] * n[q];
      } else {
        for (int q = 0; q < 9; ++q) Lw[q] = 0;
      }
    }
    /* added, not stored: sph zeroes both after use, so two sph_wall interactions on one set sum */
    ej_real *L = Lwall + 9 * (size_t)i;
    for (int q = 0; q < 9; ++q) L[q] += Lw[q];
    if (Bwall)
      for (int q = 0; q < 6; ++q) Bwall[6 * (size_t)i + q] += Bw[q];
  }
  return EJ_OK;
}

/* Pass 1 over SPH particles r: the wall pair terms. */
static ej_err sw_fluid_pass(sw_state *s, ej_set *fl, ej_set *wall, const ej_nbr *fw, ej_range r)
{
  const int dim = ej_set_dim(fl);
  const sw_config *c = &s->cfg;
  const ej_real *xf = ej_set_field(fl, "x"), *vf = ej_set_field(fl, "v"), *rf = ej_set_field(fl, "rho");
  const ej_real *hf = ej_set_field(fl, "h"), *pf = ej_set_field(fl, "p"), *sf = ej_set_field(fl, "stress");
  const ej_real *cf = ej_set_field(fl, "c"), *mf = ej_set_field(fl, "m");
  ej_real *af = ej_set_field(fl, "a"), *rdot = ej_set_field(fl, "rho_dot"), *edot = ej_set_field(fl, "e_dot");
  const ej_real *xw = ej_set_field(wall, "x"), *vw = ej_set_field(wall, "v"), *volw = ej_set_field(wall, "vol0");
  const ej_real sigma_k = sph_kernel_sigma(c->kernel, dim);
  for (ej_idx i = r.begin; i < r.end; ++i) {
    ej_real si[6];
    sw_fluid_stress(sf, pf, i, si);
    const ej_real rho_i = rf[i], h = hf[i], ih = 1.0 / h, c_i = cf ? cf[i] : 0;
    const ej_real irho2 = 1.0 / (rho_i * rho_i);
    const ej_real dwfac = sigma_k * sph_inv_pow(ih, dim + 1);
    ej_real acc[3] = {0, 0, 0}, de = 0, drho = 0, dt = INFINITY;
    /* wall_normal: the particle's wall normal n_i = sum_w (x_i - x_w) |dW/dr| / |...| (as the
     * free-slip gradient pre-pass; exact for a flat wall, edges of the material do not tilt it) */
    ej_real ni[3] = {0, 0, 0};
    if (c->viscosity_velocity == SW_VISC_WALL_NORMAL) {
      for (ej_off k = fw->off[i]; k < fw->off[i + 1]; ++k) {
        ej_real dx[3], dwdr, g[3];
        if (!sw_pair(c->kernel, dim, xf + 3 * (size_t)i, xw + 3 * (size_t)fw->idx[k], h, ih, dwfac, dx, &dwdr, g))
          continue;
        for (int q = 0; q < 3; ++q) ni[q] += dx[q] * dwdr;
      }
      const ej_real nl = sqrt(ni[0] * ni[0] + ni[1] * ni[1] + ni[2] * ni[2]);
      for (int q = 0; q < 3; ++q) ni[q] = nl > 0 ? ni[q] / nl : 0.0;
    }
    for (ej_off k = fw->off[i]; k < fw->off[i + 1]; ++k) {
      const ej_idx w = fw->idx[k];
      ej_real dx[3], dwdr, g[3];
      if (!sw_pair(c->kernel, dim, xf + 3 * (size_t)i, xw + 3 * (size_t)w, h, ih, dwfac, dx, &dwdr, g)) continue;
      const ej_real r2 = dx[0] * dx[0] + dx[1] * dx[1] + dx[2] * dx[2];
      const ej_real rho_w = s->w_rho[w], m_w = rho_w * volw[w];
      const ej_real *V = &s->w_vvis[3 * w];
      /* viscosity on v_i - v_w,visc (x_iw = -dx) */
      ej_real dvv[3] = {vf[3 * i] - V[0], vf[3 * i + 1] - V[1], vf[3 * i + 2] - V[2]};
      const bool nrm_only = c->viscosity_velocity == SW_VISC_WALL_NORMAL;
      ej_real gn[3] = {0, 0, 0}; /* wall_normal: the viscous force along (g . n) n, no friction */
      if (nrm_only) {
        const ej_real *nw = ni;
        const ej_real vn = dvv[0] * nw[0] + dvv[1] * nw[1] + dvv[2] * nw[2];
        const ej_real gnn = g[0] * nw[0] + g[1] * nw[1] + g[2] * nw[2];
        for (int q = 0; q < 3; ++q) dvv[q] = vn * nw[q], gn[q] = gnn * nw[q];
      }
      const ej_real vx = -(dvv[0] * dx[0] + dvv[1] * dx[1] + dvv[2] * dx[2]);
      ej_real pi = 0;
      /* free slip: no viscous wall term unless viscosity_velocity: wall or wall_normal */
      if (vx < 0 && (c->slip == SW_NO_SLIP || c->viscosity_velocity != SW_VISC_EXTRAPOLATED)) {
        const ej_real mu = h * vx / (r2 + c->eta * c->eta * h * h);
        pi = (-c->alpha * c_i * mu + c->beta * mu * mu) / (0.5 * (rho_i + rho_w));
      }
      const ej_real *sw = &s->w_sig[6 * w];
      const ej_real irho2w = 1.0 / (rho_w * rho_w);
      ej_real t[6], S[9], Si[9];
      for (int q = 0; q < 6; ++q) t[q] = si[q] * irho2 + sw[q] * irho2w;
      if (!nrm_only) t[0] -= pi, t[1] -= pi, t[2] -= pi;
      ej_s6_to_m3(S, t);
      for (int q = 0; q < 6; ++q) t[q] = si[q] * irho2;
      ej_s6_to_m3(Si, t);
      ej_real Sg[3], Sig[3];
      ej_m3_apply(Sg, S, g);
      ej_m3_apply(Sig, Si, g);
      for (int q = 0; q < 3; ++q) acc[q] += m_w * Sg[q];
      if (nrm_only)
        for (int q = 0; q < 3; ++q) acc[q] -= m_w * pi * gn[q];
      const ej_real dv[3] = {vf[3 * i] - vw[3 * w], vf[3 * i + 1] - vw[3 * w + 1], vf[3 * i + 2] - vw[3 * w + 2]};
      de -= m_w * (dv[0] * Sig[0] + dv[1] * Sig[1] + dv[2] * Sig[2]);
      /* viscous heat = minus the power of the viscous force on i relative to the wall, so the wall
       * viscosity does no net work: with (v_i - v_w,visc) it would double-count for no-slip */
      {
        const ej_real *gv = nrm_only ? gn : g;
        de += m_w * pi * (dv[0] * gv[0] + dv[1] * gv[1] + dv[2] * gv[2]);
      }
      drho += volw[w] * (dv[0] * g[0] + dv[1] * g[1] + dv[2] * g[2]);
      const ej_real wsp = c_i + 2.0 * sqrt(dv[0] * dv[0] + dv[1] * dv[1] + dv[2] * dv[2]);
      if (wsp > 0 && h / wsp < dt) dt = h / wsp;
    }
    for (int q = 0; q < 3; ++q) af[3 * i + q] += acc[q];
    if (edot) edot[i] += de;
    /* with the wall gradient sph's rho_dot = -rho tr(L + L_wall) already holds this term */
    if (rdot && !s->grad) rdot[i] += rho_i * drho;
    s->f_dt[i] = dt;
    const ej_real m = mf[i];
    s->f_power[i] = m * (vf[3 * i] * acc[0] + vf[3 * i + 1] * acc[1] + vf[3 * i + 2] * acc[2] + (edot ? de : 0));
    for (int q = 0; q < 3; ++q) s->f_force[3 * i + q] = m * acc[q];
  }
  return EJ_OK;
}

static ej_err sw_compute(void *state, ej_set *a, ej_set *b, const ej_nbr *ab, int pass, ej_range r)
{
  sw_state *s = state;
  if (a == s->fluid) {
    if (pass < 0) return s->grad ? sw_grad_pass(s, a, b, ab, r) : EJ_OK;
    if (pass != 1) return EJ_OK;
    EJ_ENSURE(ej_set_count(a) == s->n_fluid, EJ_ERR_INTERNAL, "sph_wall: set '%s' changed size", ej_set_name(a));
    return sw_fluid_pass(s, a, b, ab, r);
  }
  if (pass != 0) return EJ_OK; /* the pre-pass has nothing to do on the wall side */
  /* create refused a wall set with images (ej_set_has_images), so it never has ghosts */
  EJ_ENSURE(ej_set_count_all(a) == ej_set_count(a), EJ_ERR_INTERNAL, "sph_wall: wall set '%s' has %d ghost particles",
            ej_set_name(a), (int)(ej_set_count_all(a) - ej_set_count(a)));
  EJ_ENSURE(ej_set_count(a) == s->n_wall, EJ_ERR_INTERNAL, "sph_wall: set '%s' changed size", ej_set_name(a));
  return sw_wall_pass(s, a, b, ab, r);
}

static ej_err sw_stable_dt(void *state, const ej_set *a, const ej_set *b, ej_real *dt)
{
  (void)a, (void)b;
  const sw_state *s = state;
  ej_real d = INFINITY;
  for (ej_idx i = 0; i < s->n_fluid; ++i) d = s->f_dt[i] < d ? s->f_dt[i] : d;
  *dt = d;
  return EJ_OK;
}

static ej_err sw_post_step(void *state, ej_set *a, ej_set *b)
{
  (void)b;
  sw_state *s = state;
  ej_real P = 0, F[3] = {0, 0, 0};
  for (ej_idx i = 0; i < s->n_fluid; ++i) {
    P += s->f_power[i];
    for (int q = 0; q < 3; ++q) F[q] += s->f_force[3 * i + q];
  }
  /* trapezoid in the power of the two ends of the step */
  const ej_real dt = ej_set_dt(a);
  s->work += s->have_power ? 0.5 * dt * (s->power_prev + P) : dt * P;
  s->power_prev = P;
  s->have_power = true;
  for (int q = 0; q < 3; ++q) s->force[q] = F[q];
  return EJ_OK;
}

static ej_err sw_report(void *state, ej_series_value *out, int max, int *n)
{
  const sw_state *s = state;
  if (max < 4) EJ_FAIL(EJ_ERR_INTERNAL, "sph_wall: report needs 4 slots");
  out[0] = (ej_series_value){.name = "force_x", .value = s->force[0], .role = EJ_SERIES_PLAIN};
  out[1] = (ej_series_value){.name = "force_y", .value = s->force[1], .role = EJ_SERIES_PLAIN};
  out[2] = (ej_series_value){.name = "force_z", .value = s->force[2], .role = EJ_SERIES_PLAIN};
  out[3] = (ej_series_value){.name = "work", .value = s->work, .role = EJ_SERIES_WORK};
  *n = 4;
  return EJ_OK;
}

/* Checkpointed state (ABI 1.8): the wall work summed so far and the power at the end of
 * the last step (the trapezoid's left end), so that a restarted run's energy budget continues. */
static ej_err sw_save_state(const void *state, ej_real *buf, int max, int *n)
{
  const sw_state *s = state;
  EJ_ENSURE(max >= 3, EJ_ERR_INTERNAL, "sph_wall: %d state slots, needs 3", max);
  buf[0] = s->work;
  buf[1] = s->power_prev;
  buf[2] = (ej_real)s->have_power;
  *n = 3;
  return EJ_OK;
}

static ej_err sw_load_state(void *state, const ej_real *buf, int n)
{
  sw_state *s = state;
  EJ_ENSURE(n == 3, EJ_ERR_INPUT, "sph_wall: %d state values in the checkpoint, expected 3", n);
  s->work = buf[0];
  s->power_prev = buf[1];
  s->have_power = buf[2] != 0;
  return EJ_OK;
}

/* The fields the passes write on the SPH set (ABI 1.11) */
static int sw_pass_writes(const void *state, int pass, int side, const char **names, int max)
{
  (void)state, (void)side; /* the wall set has no images; names it lacks are skipped */
  if (max < 3) return -1;
  if (pass < 0) { /* the wall's share of the solid's velocity gradient (and of B with correction) */
    names[0] = "L_wall", names[1] = "B_wall";
    return 2;
  }
  if (pass == 0) return 0; /* the wall side's extrapolation: the plugin's own arrays */
  names[0] = "a", names[1] = "rho_dot", names[2] = "e_dot";
  return 3;
}

static const ej_interaction_ops sw_ops = {
    .struct_size = sizeof(ej_interaction_ops),
    .name = "sph_wall",
    .summary = "Dummy-particle walls for SPH fluids and solids (Adami, Hu & Adams 2012), free- or no-slip",
    .doc = "Wall particles (second set, held fixed or moving at a prescribed velocity) take a pressure or stress "
           "extrapolated from the SPH set's particles, sigma_w = [sum sigma_f W - ((g - a_w) . sum rho_f r_wf W) I] "
           "/ sum W (Adami et al. JCP 231 (2012) Eq 27, digest 001 §1.10), a density from the EOS inverse (fluids) "
           "or the neighbours (solids), and a viscous velocity 2 v_w - v~_w (no-slip; free-slip has no viscous "
           "wall term and mirrors the stress); the SPH particles then feel the wall through the SPH momentum, continuity and "
           "energy pair terms. Pass 0 evaluates the wall particles, pass 1 the SPH side. See "
           "plugins/interactions/sph_wall/README.md.",
    .params = sw_params,
    .config_size = sizeof(sw_config),
    .create = sw_create,
    .compute = sw_compute,
    .stable_dt = sw_stable_dt,
    .destroy = sw_destroy,
    .both_ways = true,
    .n_passes = 2,
    .post_step = sw_post_step,
    .post_step_sums_only = true, /* work and force sums only: no particle field written */
    .report = sw_report,
    .n_sets = 2,
    .n_pre_passes = 1,
    .save_state = sw_save_state,
    .load_state = sw_load_state,
    .pass_writes = sw_pass_writes,
};

static ej_err sw_register(ej_registry *reg) { return ej_register_interaction(reg, &sw_ops); }

EJ_PLUGIN_DEFINE(sph_wall, "0.1.0", "BSD-3-Clause", "Adami dummy-particle walls for SPH", sw_register)

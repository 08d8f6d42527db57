/* The momentum- and energy-conserving pair force between two continuum particle sets, shared
 * by the `continuum` interaction and the `pairwise` form of `pd_sph`.
 *
 * Any method that publishes the field conventions below can be coupled, whatever it is (SPH,
 * UL-PD, TL-PD, RKPM): x, v, m (core), rho, and either `stress` (Cauchy, Voigt, tension
 * positive) or `p` (pressure, compression positive: sigma = -p I). Optional: `c` (sound
 * speed; else from the set's material moduli or EOS), `h` (smoothing length; else h_factor
 * times the particle's initial spacing vol0^(1/dim)), `rho_dot` and `e_dot` (the interface's
 * share of the continuity and energy equations is added when the set integrates them).
 *
 * Pair terms with grad_i W = dW/dr(r, hbar) (x_i - x_j) / r, in one of two forms:
 *   standard (Libersky & Petschek 1991 for a stress tensor):
 *     S_ij = sigma_i / rho_i^2 + sigma_j / rho_j^2 - Pi_ij I,  E_i = sigma_i / rho_i^2 - Pi_ij/2 I
 *   volume (default; Colagrossi & Landrini 2003, Eq 2.9, written for a stress tensor): the pair
 *     force does not grow with the density ratio, which interfaces of explosive products and air
 *     (ratio > 1000) need:
 *     S_ij = (sigma_i + sigma_j) / (rho_i rho_j) - Pi_ij I,  E_i = sigma_i / (rho_i rho_j) - Pi_ij/2 I
 *   dv_i/dt   += sum_j m_j S_ij grad_i W
 *   de_i/dt   += -sum_j m_j E_i : ((v_i - v_j) (x) grad_i W)
 *   drho_i/dt += rho_i sum_j (m_j / rho_j) (v_i - v_j) . grad_i W      (001 Eq 3), or with
 *   continuity blend (001 Eq 4, Liu, Zhang & Feng 2017), the density-ratio-adaptive blend of the
 *   mass form (Eq 2) and Eq 3:
 *   drho_i/dt += sum_j (rho_i + psi_i rho_j) / ((1 + psi_i) rho_j) m_j (v_i - v_j) . grad_i W,
 *   psi_i = 1 / ln(rho_max / rho_min) over i's support (this list's part of it)
 * Pi_ij is Monaghan's (1992) viscosity on approaching pairs. S_ij is symmetric in i and j and
 * grad_j W = -grad_i W, so the force on j is minus the force on i (momentum to round-off), and
 * E_i + E_j = S_ij, so the work of the pair equals minus the change of the two internal energies
 * (energy to round-off): each side is computed by its own gather call.
 */
#ifndef EJ_CONTINUUM_PAIR_H
#define EJ_CONTINUUM_PAIR_H

#include <math.h>

#include "../../methods/sph/sph_kernels.h"
#include "ejecta/plugin.h"
#include "ejecta/tensor.h"

typedef struct cpl_side {
  const ej_set *set;
  int dim;
  const ej_real *x, *v, *m, *vol0, *rho, *p, *stress, *c, *h, *e;
  ej_real *a, *rho_dot, *e_dot;
  ej_real *ren_div, *ren_norm; /* sph renormalize_interfaces: the raw divergence and norm sums */
  const ej_real *Minv;         /* sph gradient: shape_tensor: M_i^-1 (SYM6), else NULL */
  const int32_t *fb;           /* ... and its fallback flag (1: the row uses the kernel gradient) */
  ej_real *Mcpl;               /* ... and the coupled sets' share of M_i (continuum's pre-pass adds to it) */
  ej_real c_fallback;  /* sound speed when the set has no c field */
  ej_real h_fallback;  /* h_factor, when the set has no h field */
  int spherical;       /* sph geometry: spherical (1D, x = r) with spherical_energy: pair (pdv_pair) */
  int line;            /* the set publishes m_line (sph geometry: spherical, 1D, x = r) */
} cpl_side;

enum { CPL_FORM_VOLUME = 0, CPL_FORM_STANDARD = 1 };

enum { CPL_CONT_VOLUME = 0, CPL_CONT_BLEND = 1 };

/* The couplings' `gradient` parameter (continuum, pd_sph): auto, a shape-tensor side's half of G_ij
 * (cpl_shape_half) and its share of M_i (cpl_shape_share); kernel, grad_i W on every pair. */
enum { CPL_GRADIENT_AUTO = 0, CPL_GRADIENT_KERNEL = 1 };
static const char *const cpl_gradient_names[] = {"auto", "kernel", NULL};

typedef struct cpl_params {
  int kernel;
  int form;
  int continuity; /* CPL_CONT_VOLUME (Eq 3 of 001) or CPL_CONT_BLEND (001 Eq 4) */
  ej_real alpha, beta, eta;
  ej_real h_factor;
  ej_real conductivity; /* artificial conductivity alpha_u (Price 2008) on the interface pairs; 0: off */
  int shape;            /* 1: a side with sph's shape tensor (M_inv) takes its half of G_ij (continuum
                         * gradient: auto); 0: the kernel gradient on every pair */
} cpl_params;

/* A set with sph `renormalize_interfaces` (fields ren_div, ren_norm) takes the interface pairs'
 * volume-form continuity into its renormalised divergence (sph finish); only the volume form and
 * continuity weight 1 keep that divergence consistent, so other couplings refuse it. */
static inline ej_err cpl_check_ren(const ej_set *set, const char *who, bool ok, const char *why)
{
  if (ej_set_field(set, "ren_norm") && !ok)
    EJ_FAIL(EJ_ERR_INPUT, "%s: set '%s' has sph renormalize_interfaces, which needs %s", who, ej_set_name(set), why);
  return EJ_OK;
}

/* The fields a coupling's pass writes on the set whose rows it sums (ABI 1.11 pass_writes; either side,
 * names a set lacks are skipped by the core): the pre-pass the shape-tensor share M_cpl, the pair passes
 * a, the continuity and energy rates and the renormalisation sums, plus `extra` (pd_sph: failed). */
static inline int cpl_pass_writes(int pass, const char **names, int max, const char *extra)
{
  static const char *const pairs[] = {"a", "rho_dot", "e_dot", "ren_div", "ren_norm"};
  if (max < 6) return -1;
  if (pass < 0) {
    names[0] = "M_cpl";
    return 1;
  }
  int n = 0;
  for (size_t k = 0; k < sizeof pairs / sizeof *pairs; ++k) names[n++] = pairs[k];
  if (extra) names[n++] = extra;
  return n;
}

/* Binds the fields of a set; EJ_ERR_INPUT names what is missing. */
static inline ej_err cpl_bind(cpl_side *s, ej_set *set, const char *who, ej_real h_factor)
{
  s->set = set;
  s->dim = ej_set_dim(set);
  s->x = ej_set_field(set, "x");
  s->v = ej_set_field(set, "v");
  /* a set that publishes a line mass (sph geometry: spherical) couples with it: the 1D sums of a
   * spherically symmetric set weigh neighbours by m/(4 pi r^2), not by the shell mass m */
  s->m = ej_set_field(set, "m_line");
  s->spherical = s->m != NULL && ej_set_field(set, "pdv_pair") != NULL; /* sph spherical_energy: pair */
  s->line = s->m != NULL;
  if (!s->m) s->m = ej_set_field(set, "m");
  s->vol0 = ej_set_field(set, "vol0");
  s->a = ej_set_field(set, "a");
  s->rho = ej_set_field(set, "rho");
  s->p = ej_set_field(set, "p");
  s->stress = ej_set_field(set, "stress");
  s->c = ej_set_field(set, "c");
  s->h = ej_set_field(set, "h");
  s->rho_dot = ej_set_field(set, "rho_dot");
  s->e_dot = ej_set_field(set, "e_dot");
  s->e = ej_set_field(set, "e");
  s->ren_div = ej_set_field(set, "ren_div");
  s->ren_norm = ej_set_field(set, "ren_norm");
  s->Minv = ej_set_field(set, "M_inv");
  s->fb = ej_set_field_int(set, "grad_fallback");
  s->Mcpl = ej_set_field(set, "M_cpl");
  if (!s->Minv || !s->fb) s->Minv = NULL, s->fb = NULL, s->Mcpl = NULL;
  s->h_fallback = h_factor;
  if (!s->rho)
    EJ_FAIL(EJ_ERR_INPUT, "%s: set '%s' has no density field 'rho' (its method does not publish one)", who,
            ej_set_name(set));
  if (!s->p && !s->stress)
    EJ_FAIL(EJ_ERR_INPUT, "%s: set '%s' publishes neither 'stress' nor 'p'", who, ej_set_name(set));
  s->c_fallback = 0;
  const ej_model *model = ej_set_model(set);
  const ej_material *mat = model ? ej_model_material(model) : NULL;
  if (mat) {
    ej_real K, G;
    EJ_TRY(ej_material_moduli(mat, &K, &G));
    s->c_fallback = sqrt((K + 4.0 * G / 3.0) / ej_model_rho0(model));
  }
  return EJ_OK;
}

static inline void cpl_stress(const cpl_side *s, ej_idx i, ej_real sig[6])
{
  if (s->stress) {
    for (int k = 0; k < 6; ++k) sig[k] = s->stress[6 * i + k];
  } else {
    sig[0] = sig[1] = sig[2] = -s->p[i];
    sig[3] = sig[4] = sig[5] = 0;
  }
}

static inline ej_real cpl_dx(const cpl_side *s, ej_idx i)
{
  const ej_real v = s->vol0[i];
  return s->dim == 1 ? v : s->dim == 2 ? sqrt(v) : cbrt(v);
}

/* hbar of the pair (i of side a, j of side b). A particle of a method without an 'h' field gets
 * h_factor times its spacing, or, with h_factor 0 (the default), the h/spacing ratio of the
 * other particle of the pair when that one has an h (so that an SPH set's kernel sums run at
 * the same h/dx across the interface: sph uses 2 in 1D, 1.5 in 2D, 1.3 in 3D), else 1.3.
 * Symmetric in the pair, so pair forces stay equal and opposite. */
static inline ej_real cpl_hbar(const cpl_side *a, ej_idx i, const cpl_side *b, ej_idx j)
{
  ej_real hi, hj;
  if (a->h) hi = a->h[i];
  else if (a->h_fallback > 0) hi = a->h_fallback * cpl_dx(a, i);
  else hi = (b->h ? b->h[j] / cpl_dx(b, j) : 1.3) * cpl_dx(a, i);
  if (b->h) hj = b->h[j];
  else if (b->h_fallback > 0) hj = b->h_fallback * cpl_dx(b, j);
  else hj = (a->h ? a->h[i] / cpl_dx(a, i) : 1.3) * cpl_dx(b, j);
  return 0.5 * (hi + hj);
}

static inline ej_real cpl_c(const cpl_side *s, ej_idx i) { return s->c ? s->c[i] : s->c_fallback; }

/* Shape tensor across an interface (README "Shape tensor across an interface"; sph README
 * "gradient: shape_tensor", digest 000 Eqs 29-31). A side whose method is sph with the shape
 * tensor publishes M_inv (M_i^-1, Voigt), grad_fallback and M_cpl. Its M_i must run over every
 * neighbour, the other set's too, or its consistent gradient is one-sided at the interface and
 * the kernel pairs below count the interface a second time (validation/c4_air: +84 % on the first
 * air shock). continuum's pre-pass, which the core runs right before the pass that inverts M_i
 * (pre_pass_before "M_inv": after both sets' h, floored rho and EOS of t_n+1), adds
 *   M_cpl_i += sum_j V_j w(|x_ij|, hbar) x_ij (x) x_ij,   V_j = m_j / rho_j,  x_ij = x_j - x_i,
 * over the other set's neighbours j inside 2 hbar, with the pair's kernel and hbar, so that the
 * pair gradient below is exact for linear fields across the interface. */
static inline void cpl_shape_share(const cpl_params *P, const cpl_side *A, const cpl_side *B, const ej_nbr *ab,
                                   ej_range r)
{
  if (!A->Mcpl) return;
  const int dim = A->dim;
  const ej_real sigma_k = sph_kernel_sigma(P->kernel, dim);
  for (ej_idx i = r.begin; i < r.end; ++i) {
    ej_real b[6] = {0, 0, 0, 0, 0, 0}; /* xx yy zz xy yz zx */
    for (ej_off k = ab->off[i]; k < ab->off[i + 1]; ++k) {
      const ej_idx j = ab->idx[k];
      const ej_real dx[3] = {B->x[3 * j] - A->x[3 * i], dim > 1 ? B->x[3 * j + 1] - A->x[3 * i + 1] : 0.0,
                             dim > 2 ? B->x[3 * j + 2] - A->x[3 * i + 2] : 0.0};
      const ej_real r2 = dx[0] * dx[0] + dx[1] * dx[1] + dx[2] * dx[2];
      const ej_real hbar = cpl_hbar(A, i, B, j);
      if (r2 >= 4.0 * hbar * hbar || r2 <= 0) continue;
      const ej_real ih = 1.0 / hbar;
      const ej_real w =
          (B->m[j] / B->rho[j]) * sigma_k * sph_inv_pow(ih, dim) * sph_kernel_f(P->kernel, dim, sqrt(r2) * ih);
      b[0] += w * dx[0] * dx[0], b[1] += w * dx[1] * dx[1], b[2] += w * dx[2] * dx[2];
      b[3] += w * dx[0] * dx[1], b[4] += w * dx[1] * dx[2], b[5] += w * dx[2] * dx[0];
    }
    for (int c = 0; c < 6; ++c) A->Mcpl[6 * i + c] += b[c];
  }
}

/* Side s's half of G_ij for its particle k: M_k^-1 u (u = w_ij x_ij, x_ij = x_j - x_i seen from
 * particle i of the gather), or the kernel gradient g = grad_i W_ij where s has no shape tensor
 * or k's M was ill-conditioned (sph's fallback), as sph's own pairs do. */
static inline void cpl_shape_half(const cpl_side *s, ej_idx k, const ej_real u[3], const ej_real g[3], ej_real out[3])
{
  if (!s->Minv || s->fb[k]) {
    out[0] = g[0], out[1] = g[1], out[2] = g[2];
    return;
  }
  const ej_real *M = s->Minv + 6 * k;
  out[0] = M[0] * u[0] + M[3] * u[1] + M[5] * u[2];
  out[1] = M[3] * u[0] + M[1] * u[1] + M[4] * u[2];
  out[2] = M[5] * u[0] + M[4] * u[1] + M[2] * u[2];
}

/* Adds the pair terms of the neighbours j (of side b) to particles i in r (of side a).
 * wa, wb (0 or 1) say whose stress enters S_ij; ea is side a's share of the viscous heat. The
 * symmetric coupling uses wa = wb = 1, ea = 1/2. The traction coupling of a PD solid (whose own
 * operator already carries its free-surface response) uses only the fluid's stress: from the
 * solid's side wa = 0, wb = 1, ea = 0; from the fluid's side wa = 1, wb = 0, ea = 1. Both sides
 * then compute the same S_ij, and E_a + E_b = S_ij still holds. */
static inline void cpl_gather_wc(const cpl_params *P, const cpl_side *A, const cpl_side *B, const ej_nbr *ab,
                                 ej_range r, ej_real wa, ej_real wb, ej_real ea, ej_real wc)
{
  const int dim = A->dim;
  const ej_real sigma_k = sph_kernel_sigma(P->kernel, dim);
  for (ej_idx i = r.begin; i < r.end; ++i) {
    ej_real si[6];
    cpl_stress(A, i, si);
    const ej_real rho_i = A->rho[i], irho2_i = 1.0 / (rho_i * rho_i), c_i = cpl_c(A, i);
    (void)irho2_i;
    ej_real acc[3] = {0, 0, 0}, de = 0, drho = 0, drho_m = 0, dq = 0, dnorm = 0;
    /* artificial conductivity across the interface (README "Artificial conductivity"; Price,
     * J. Comput. Phys. 227 (2008) 10040, section 4): both sides need an internal energy e */
    const int cond = P->conductivity > 0 && A->e && B->e && A->e_dot;
    const ej_real p_i = -(si[0] + si[1] + si[2]) / 3.0;
    const ej_real ai_abs = fabs(A->x[3 * i]);
    const ej_real inv_ai2 = A->line ? 1.0 / fmax(ai_abs * ai_abs, 1e-300) : 1.0;
    /* A spherical side (1D, x = r) with sph `spherical_energy: pair`, away from the axis
     * (|x_i| >= SPH_SPHERICAL_EXACT_R h_i, the switch of sph's spherical pass, same h) takes the
     * pdV work in the exact pair form: v_i - v_j -> u_ij =
     * v_i - v_j r_j^2/r_i^2, so that sum m (v^2/2 + e) is conserved with the momentum (sph README
     * "Spherical symmetry"); sph then adds no local -2 (p/rho) v/r for this particle. */
    const ej_real xi0 = A->x[3 * i];
    const int sph_exact = A->spherical && A->h && fabs(xi0) >= SPH_SPHERICAL_EXACT_R * A->h[i];
    const ej_real inv_xi2 = sph_exact ? 1.0 / (xi0 * xi0) : 0.0;
    /* 001 Eq 4 (Liu, Zhang & Feng 2017): psi_i = 1 / ln k_i, k_i = rho_max / rho_min over i and
     * the particles of its support that this list sees (the other set's: across a material
     * interface they carry the density jump); k_i = 1 (psi infinite) is Eq 2, the mass form. */
    ej_real psi = -1; /* < 0: the volume form (Eq 3) */
    if (P->continuity == CPL_CONT_BLEND) {
      ej_real rmin = rho_i, rmax = rho_i;
      for (ej_off k = ab->off[i]; k < ab->off[i + 1]; ++k) {
        const ej_idx j = ab->idx[k];
        const ej_real dx[3] = {B->x[3 * j] - A->x[3 * i], B->x[3 * j + 1] - A->x[3 * i + 1],
                               B->x[3 * j + 2] - A->x[3 * i + 2]};
        const ej_real hbar = cpl_hbar(A, i, B, j);
        if (dx[0] * dx[0] + dx[1] * dx[1] + dx[2] * dx[2] >= 4.0 * hbar * hbar) continue;
        rmin = B->rho[j] < rmin ? B->rho[j] : rmin;
        rmax = B->rho[j] > rmax ? B->rho[j] : rmax;
      }
      const ej_real lk = log(rmax / rmin);
      psi = lk > 1e-9 ? 1.0 / lk : INFINITY;
    }
    /* a side with sph's shape tensor: G_ij (cpl_shape_half); else bitwise the kernel form */
    const int shp = P->shape && (A->Minv || B->Minv) && !sph_exact;
    for (ej_off k = ab->off[i]; k < ab->off[i + 1]; ++k) {
      const ej_idx j = ab->idx[k];
      const ej_real dx[3] = {B->x[3 * j] - A->x[3 * i], B->x[3 * j + 1] - A->x[3 * i + 1],
                             B->x[3 * j + 2] - A->x[3 * i + 2]};
      const ej_real r2 = dx[0] * dx[0] + dx[1] * dx[1] + dx[2] * dx[2];
      const ej_real hbar = cpl_hbar(A, i, B, j);
      if (r2 >= 4.0 * hbar * hbar || r2 <= 0) continue;
      const ej_real rr = sqrt(r2), ih = 1.0 / hbar;
      const ej_real dwdr = sigma_k * sph_inv_pow(ih, dim + 1) * sph_kernel_df(P->kernel, dim, rr * ih);
      /* grad_i W = dW/dr (x_i - x_j)/r = -dW/dr dx / r */
      const ej_real g[3] = {-dwdr * dx[0] / rr, -dwdr * dx[1] / rr, -dwdr * dx[2] / rr};
      const ej_real dv[3] = {B->v[3 * j] - A->v[3 * i], B->v[3 * j + 1] - A->v[3 * i + 1],
                             B->v[3 * j + 2] - A->v[3 * i + 2]}; /* v_j - v_i */
      const ej_real vx = dv[0] * dx[0] + dv[1] * dx[1] + dv[2] * dx[2];
      ej_real pi = 0;
      if (vx < 0) { /* approaching */
        const ej_real mu = hbar * vx / (r2 + P->eta * P->eta * hbar * hbar);
        const ej_real cbar = 0.5 * (c_i + cpl_c(B, j)), rbar = 0.5 * (rho_i + B->rho[j]);
        pi = (-P->alpha * cbar * mu + P->beta * mu * mu) / rbar;
      }
      ej_real sj[6];
      cpl_stress(B, j, sj);
      const ej_real irho2_j = 1.0 / (B->rho[j] * B->rho[j]), mj = B->m[j];
      /* standard: sigma_i/rho_i^2 + sigma_j/rho_j^2; volume: (sigma_i + sigma_j)/(rho_i rho_j) */
      const ej_real wi = wa * (P->form == CPL_FORM_STANDARD ? irho2_i : 1.0 / (rho_i * B->rho[j]));
      const ej_real wj = wb * (P->form == CPL_FORM_STANDARD ? irho2_j : 1.0 / (rho_i * B->rho[j]));
      ej_real vg;
      if (shp) {
        /* G_ij = (half_i + half_j)/2 in the stress and pdV terms (sph's symmetric form, antisymmetric
         * in i, j); the viscosity keeps the kernel gradient (sph's default shape_viscosity: kernel,
         * a radial pair force) */
        const ej_real w = sigma_k * sph_inv_pow(ih, dim) * sph_kernel_f(P->kernel, dim, rr * ih);
        const ej_real u[3] = {w * dx[0], w * dx[1], w * dx[2]};
        ej_real hi[3], hj[3], G[3];
        cpl_shape_half(A, i, u, g, hi);
        cpl_shape_half(B, j, u, g, hj);
        for (int q = 0; q < 3; ++q) G[q] = 0.5 * (hi[q] + hj[q]);
        ej_real t[6], T[9], Ti[9], TG[3], TiG[3];
        for (int q = 0; q < 6; ++q) t[q] = si[q] * wi + sj[q] * wj;
        ej_s6_to_m3(T, t);
        for (int q = 0; q < 6; ++q) t[q] = si[q] * wi;
        ej_s6_to_m3(Ti, t);
        ej_m3_apply(TG, T, G);
        ej_m3_apply(TiG, Ti, G);
        for (int q = 0; q < 3; ++q) acc[q] += mj * (TG[q] - pi * g[q]);
        const ej_real dvg = dv[0] * g[0] + dv[1] * g[1] + dv[2] * g[2];
        de += mj * (dv[0] * TiG[0] + dv[1] * TiG[1] + dv[2] * TiG[2] - ea * pi * dvg);
        /* continuity (row i only, no conservation at stake): G_ij on a shape-tensor side (sph's
         * shape_continuity symmetric); the kernel gradient on a side without it, so that its
         * divergence and its renormalisation sums (renormalize_interfaces) use the same weights */
        vg = A->Minv ? dv[0] * G[0] + dv[1] * G[1] + dv[2] * G[2] : dvg;
      } else {
        ej_real S[9], Si[9];
        {
          ej_real t[6];
          for (int q = 0; q < 6; ++q) t[q] = si[q] * wi + sj[q] * wj;
          t[0] -= pi, t[1] -= pi, t[2] -= pi;
          ej_s6_to_m3(S, t);
          for (int q = 0; q < 6; ++q) t[q] = si[q] * wi;
          t[0] -= ea * pi, t[1] -= ea * pi, t[2] -= ea * pi;
          ej_s6_to_m3(Si, t);
        }
        ej_real Sg[3], Sig[3];
        ej_m3_apply(Sg, S, g);
        ej_m3_apply(Sig, Si, g);
        for (int q = 0; q < 3; ++q) acc[q] += mj * Sg[q];
        /* (v_i - v_j) = -dv */
        if (sph_exact) {
          const ej_real xj0 = B->x[3 * j];
          de += mj * ((B->v[3 * j] * xj0 * xj0 * inv_xi2 - A->v[3 * i]) * Sig[0]); /* -u_ij (1D) */
        } else {
          de += mj * (dv[0] * Sig[0] + dv[1] * Sig[1] + dv[2] * Sig[2]);
        }
        vg = dv[0] * g[0] + dv[1] * g[1] + dv[2] * g[2];
      }
      if (cond) {
        /* the pair of sph_cond_pair (a line-mass side weighs it by rbar^2/r_i^2: energy to round-off) */
        const ej_real p_j = -(sj[0] + sj[1] + sj[2]) / 3.0;
        dq += sph_cond_pair(mj, p_i, p_j, rho_i, B->rho[j], A->e[i], B->e[j], A->line, ai_abs, fabs(B->x[3 * j]),
                            inv_ai2, dwdr);
      }
      if (psi < 0) drho -= (mj / B->rho[j]) * vg, dnorm += (mj / B->rho[j]) * rr * dwdr;
      else if (isinf(psi)) drho_m -= mj * vg;
      else drho_m -= (rho_i + psi * B->rho[j]) / ((1 + psi) * B->rho[j]) * mj * vg; /* 001 Eq 4 */
    }
    for (int q = 0; q < 3; ++q) A->a[3 * i + q] += acc[q];
    if (A->e_dot) A->e_dot[i] += de;
    if (cond) A->e_dot[i] += P->conductivity * dq;
    if (A->ren_norm) { /* sph renormalize_interfaces: sph's finish renormalises own + these pairs */
      A->ren_div[i] += wc * drho, A->ren_norm[i] += wc * dnorm;
      if (A->rho_dot) A->rho_dot[i] += wc * drho_m;
    } else if (A->rho_dot) {
      A->rho_dot[i] += wc * (rho_i * drho + drho_m);
    }
  }
}

static inline void cpl_gather_w(const cpl_params *P, const cpl_side *A, const cpl_side *B, const ej_nbr *ab,
                                ej_range r, ej_real wa, ej_real wb, ej_real ea)
{
  cpl_gather_wc(P, A, B, ab, r, wa, wb, ea, 1);
}

/* Stable step of the interface pairs of particles i in r: a pair closes its gap at |v_ij| and
 * exchanges signals at c_i + c_j, so dt_i = min_j hbar / (c_i + c_j + 2 |v_ij|) (the core applies
 * the scene's cfl). The methods' own steps ignore the other set's particles: without this, a
 * fast fluid particle squeezed between solid particles overshoots its density in one step. */
static inline void cpl_dt_gather(const cpl_side *A, const cpl_side *B, const ej_nbr *ab, ej_range r, ej_real *dt)
{
  for (ej_idx i = r.begin; i < r.end; ++i) {
    ej_real d = INFINITY;
    const ej_real ci = cpl_c(A, i);
    for (ej_off k = ab->off[i]; k < ab->off[i + 1]; ++k) {
      const ej_idx j = ab->idx[k];
      const ej_real dx[3] = {B->x[3 * j] - A->x[3 * i], B->x[3 * j + 1] - A->x[3 * i + 1],
                             B->x[3 * j + 2] - A->x[3 * i + 2]};
      const ej_real hbar = cpl_hbar(A, i, B, j);
      if (dx[0] * dx[0] + dx[1] * dx[1] + dx[2] * dx[2] >= 4.0 * hbar * hbar) continue;
      const ej_real dv[3] = {B->v[3 * j] - A->v[3 * i], B->v[3 * j + 1] - A->v[3 * i + 1],
                             B->v[3 * j + 2] - A->v[3 * i + 2]};
      const ej_real w = ci + cpl_c(B, j) + 2.0 * sqrt(dv[0] * dv[0] + dv[1] * dv[1] + dv[2] * dv[2]);
      if (w > 0 && hbar / w < d) d = hbar / w;
    }
    dt[i] = d;
  }
}

/* Per owned particle of both sets: the interface pairs' stable step, written by the gather
 * calls of each side and reduced by the interaction's stable_dt op. */
typedef struct cpl_dt {
  const ej_set *a;
  ej_real *dt_a, *dt_b;
} cpl_dt;

static inline ej_err cpl_dt_init(cpl_dt *t, const ej_set *a, const ej_set *b)
{
  t->a = a;
  t->dt_a = ej_malloc(((size_t)ej_set_count(a) + 1) * sizeof *t->dt_a);
  t->dt_b = ej_malloc(((size_t)ej_set_count(b) + 1) * sizeof *t->dt_b);
  if (!t->dt_a || !t->dt_b) {
    ej_free(t->dt_a), ej_free(t->dt_b);
    t->dt_a = t->dt_b = NULL;
    EJ_FAIL(EJ_ERR_MEM, "out of memory");
  }
  for (ej_idx i = 0; i < ej_set_count(a); ++i) t->dt_a[i] = INFINITY;
  for (ej_idx i = 0; i < ej_set_count(b); ++i) t->dt_b[i] = INFINITY;
  return EJ_OK;
}

static inline void cpl_dt_free(cpl_dt *t) { ej_free(t->dt_a), ej_free(t->dt_b); }

/* The array of the side whose particles a gather call writes. */
static inline ej_real *cpl_dt_of(const cpl_dt *t, const ej_set *side) { return side == t->a ? t->dt_a : t->dt_b; }

static inline ej_real cpl_dt_min(const cpl_dt *t, const ej_set *a, const ej_set *b)
{
  ej_real d = INFINITY;
  for (ej_idx i = 0; i < ej_set_count(a); ++i) d = t->dt_a[i] < d ? t->dt_a[i] : d;
  for (ej_idx i = 0; i < ej_set_count(b); ++i) d = t->dt_b[i] < d ? t->dt_b[i] : d;
  return d;
}

static inline void cpl_gather(const cpl_params *P, const cpl_side *A, const cpl_side *B, const ej_nbr *ab,
                              ej_range r)
{
  cpl_gather_w(P, A, B, ab, r, 1, 1, 0.5);
}

#endif /* EJ_CONTINUUM_PAIR_H */

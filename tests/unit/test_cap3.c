/* cap3: the three-invariant viscoplastic cap model (Chi et al. 2017, 003 Eqs 57-87 with the
 * errata of digest 003 §7). Material-point paths:
 *  - the spectral helper of tensor.h (reconstruction, orthogonality);
 *  - "cap removed equals Drucker-Prager to round-off" (003 §5.1): no cap, no hardening,
 *    psi = 1, C - M Xi = 0 (the hyperbola of Eq 57 becomes the cone sqrt(J2) = C - M I1), against
 *    dp_damage with damage off (beta = 3 sqrt2 M, A = sqrt2 C, b = 3 sqrt2 M_g), associated and not;
 *  - Lode dependence: sqrt(J2) at failure in triaxial extension = psi x compression (Eq 61);
 *  - the analytic first and second derivatives behind the return's Newton Jacobian (Lode function
 *    gradient and Hessian, the shear function's slope, its signed square's slope and curvature)
 *    against central differences;
 *  - Duvaut-Lions relaxation at frozen strain: overstress x 1/(1 + dt/tau) per step;
 *  - V1-V4 of 003 §5.1 (Tables 2 and 4, the M_g = 0.05 and q1 = 0.001 variants) as homogeneous
 *    single-cube paths. The report gives no curves (figures missing), so these check what is
 *    closed form on any path: the elastic branch, f <= 0 always and f = 0 on plastic steps
 *    (tau = 0), evaluated by an independent implementation of Eqs 57-61 and 64-67 below from the
 *    returned stress and history, and the crush curve Eqs 59, 69, 71 from (kappa, eps_v_p).
 * The cube size is in the missing figures: a 1 mm cube is assumed (d = 0.02 mm -> 2 %). */
#include "material_point_driver.h"
#include "../../plugins/materials/cap3/cap3_math.h"

const ej_plugin_info *ej_plugin_cap3_info(void);
const ej_plugin_info *ej_plugin_dp_damage_info(void);

#define MPa 1e6

static void c3_open(mpd *m, bool table4)
{
  mpd_open(m, ej_plugin_cap3_info(), "cap3");
  mpd_set(m, "E", 9000 * MPa);
  mpd_set(m, "nu", 0.15);
  if (table4) {
    mpd_set(m, "R", 2.0);
    mpd_set(m, "R_g", 2.0);
    mpd_set(m, "n0_star", 0.1);
    mpd_set(m, "q1", 10.0 / MPa);
  }
}

/* ---- independent evaluation of Eqs 57-61, 64-67 (Table 2/4 values unless changed) */
typedef struct ref {
  double psi, R, kappa0, M, Cmax, Cres, C0, gC, Ximax, Xires, Xi0, gXi, n0, q1;
} ref;
static ref ref_table(bool t4)
{
  ref r = {0.8, t4 ? 2.0 : 1.0, -50 * MPa, 0.2, 5.5 * MPa, 2 * MPa, 4.5 * MPa, 1, 11 * MPa, 7 * MPa, 10 * MPa, 1,
           t4 ? 0.1 : 1e-3, (t4 ? 10.0 : 1.0) / MPa};
  return r;
}
static double ref_gauss(double mx, double rs, double v0, double pk, double g)
{
  const double b = log((mx - rs) / (v0 - rs)) / (pk * pk);
  return (mx - rs) * exp(-b * (g - pk) * (g - pk)) + rs;
}
static double ref_Ff(double C, double M, double Xi, double I1)
{
  return sqrt(fmax((C - M * I1) * (C - M * I1) - (C - M * Xi) * (C - M * Xi), 0));
}
/* f of Eq 60 from the stress and history (kappa, gamma); also X of Eq 59 */
static double ref_f(const ref *r, const double sg[6], double kappa, double gamma, double *Xout)
{
  const double C = ref_gauss(r->Cmax, r->Cres, r->C0, r->gC, gamma);
  const double Xi = ref_gauss(r->Ximax, r->Xires, r->Xi0, r->gXi, gamma);
  const double X = kappa - r->R * ref_Ff(C, r->M, Xi, kappa);
  if (Xout) *Xout = X;
  double s[6];
  const double I1 = 3 * ej_s6_dev(s, sg);
  const double J2 = 0.5 * ej_s6_ddot(s, s);
  double S3[9], S[9], T[9];
  ej_s6_to_m3(S, s);
  ej_m3_mul(T, S, S);
  ej_m3_mul(S3, T, S);
  const double J3 = ej_m3_trace(S3) / 3;
  const double sin3b = J2 > 0 ? fmax(-1, fmin(1, -1.5 * sqrt(3.0) * J3 / pow(J2, 1.5))) : 0;
  const double Gam = 0.5 * (1 + sin3b + (1 - sin3b) / r->psi);
  double Fc = 1;
  if (I1 < kappa) Fc = 1 - pow((I1 - kappa) / (X - kappa), 2);
  const double It = C >= r->M * Xi ? Xi : 2 * C / r->M - Xi;
  if (I1 > It || Fc < 0) return 1e30;
  return Gam * sqrt(J2) - sqrt(Fc) * ref_Ff(C, r->M, Xi, I1);
}
/* crush curve: X from eps_v_p by Eqs 69 and 71 */
static double ref_X_crush(const ref *r, double epsv)
{
  const double X0 = r->kappa0 - r->R * ref_Ff(r->C0, r->M, r->Xi0, r->kappa0);
  const double ns = (epsv + r->n0) / (1 + epsv);
  return X0 + log(ns / r->n0) / r->q1;
}

START_TEST(test_eig)
{
  const ej_real s[6] = {3.1, -1.2, 0.4, 0.7, -2.2, 1.3};
  ej_real lam[3], V[9], t[6], VtV[9];
  ej_s6_eig(lam, V, s);
  ej_s6_from_eig(t, lam, V);
  for (int k = 0; k < 6; ++k) ck_assert_double_eq_tol(t[k], s[k], 1e-14);
  ej_m3_mul_at(VtV, V, V);
  for (int k = 0; k < 9; ++k) ck_assert_double_eq_tol(VtV[k], k % 4 == 0, 1e-14);
  ck_assert_double_eq_tol(lam[0] + lam[1] + lam[2], 3.1 - 1.2 + 0.4, 1e-14);
}
END_TEST

/* cap3 as a cone: no cap, no hardening, rate independent, C = M Xi (the hyperbola degenerates to
 * sqrt(J2) Gamma = C - M I1), the potential's C_g = M_g Xi. */
static void c3_cone(mpd *a, double E, double nu, double C, double M, double Mg, double psi)
{
  const double Xi = C / M, Cg = Mg * Xi;
  mpd_open(a, ej_plugin_cap3_info(), "cap3");
  mpd_set(a, "E", E), mpd_set(a, "nu", nu);
  mpd_set(a, "psi", psi);
  mpd_set_bool(a, "cap", false);
  mpd_set(a, "tau", 0);
  mpd_set(a, "a_t", 0), mpd_set(a, "a_c", 0), mpd_set(a, "a_s", 0);
  mpd_set(a, "M", M), mpd_set(a, "M_g", Mg);
  mpd_set(a, "C_max", C), mpd_set(a, "C_res", C), mpd_set(a, "C_0", C);
  mpd_set(a, "C_maxg", Cg), mpd_set(a, "C_resg", Cg), mpd_set(a, "C_0g", Cg);
  mpd_set(a, "Xi_max", Xi), mpd_set(a, "Xi_res", Xi), mpd_set(a, "Xi_0", Xi);
  mpd_create(a);
}

/* Cap removed = Drucker-Prager to round-off (the report's claim, 003 §4 "matched up to machine
 * round off error"), associated (M_g = M) and non-associated (M_g = M/2, C_g = M_g Xi). */
START_TEST(test_dp_limit)
{
  for (int nonassoc = 0; nonassoc < 2; ++nonassoc) {
    const double C = 5 * MPa, M = 0.2, Mg = nonassoc ? 0.1 : M;
    mpd a, r;
    c3_cone(&a, 9000 * MPa, 0.15, C, M, Mg, 1.0);
    mpd_open(&r, ej_plugin_dp_damage_info(), "dp_damage");
    mpd_set(&r, "E", 9000 * MPa), mpd_set(&r, "nu", 0.15);
    mpd_set(&r, "beta", 3 * sqrt(2.0) * M), mpd_set(&r, "A", sqrt(2.0) * C), mpd_set(&r, "b", 3 * sqrt(2.0) * Mg);
    mpd_set_bool(&r, "damage", false);
    mpd_create(&r);
    unsigned seed = 777;
    double maxerr = 0, smax = 0;
    for (int n = 0; n < 1500; ++n) {
      ej_real d[6];
      for (int k = 0; k < 6; ++k) {
        seed = seed * 1103515245u + 12345u;
        d[k] = ((seed >> 8) / 16777216.0 - 0.5) * 4e-4 + (k < 3 ? -3e-6 : 0);
      }
      ck_assert_int_eq(mpd_step(&a, d, 1.0), EJ_OK);
      ck_assert_int_eq(mpd_step(&r, d, 1.0), EJ_OK);
      for (int k = 0; k < 6; ++k) {
        maxerr = fmax(maxerr, fabs(a.stress[k] - r.stress[k]));
        smax = fmax(smax, fabs(r.stress[k]));
      }
    }
    printf("cap3 DP limit (%s): eps_p %g, max diff %g Pa of %g Pa (%.2e)\n", nonassoc ? "non-assoc" : "assoc",
           mpd_hist(&r, "eps_p"), maxerr, smax, maxerr / smax);
    ck_assert(mpd_hist(&r, "eps_p") > 1e-3);
    ck_assert(mpd_hist(&a, "cap_fallbacks") == 0);
    ck_assert_msg(maxerr < 1e-11 * smax, "cap3 vs DP: %g of %g", maxerr, smax);
    ck_assert_double_eq_tol(mpd_hist(&a, "eps_v_p"), mpd_hist(&r, "eps_v_p"), 1e-12);
    mpd_close(&a);
    mpd_close(&r);
  }
}
END_TEST

/* Beyond the tension tip the hyperbola's other branch, (C - M I1)^2 >= (C - M Xi)^2 mirrored about
 * I1 = C/M, is not admissible (the defect fixed 2026-11-30: a cohesionless cone carried 1.8 MPa of
 * hydrostatic tension). (1) A cohesionless cone (C = 1 Pa = M Xi, the glass beads of
 * validation/sphere_drop with psi = 1: M = beta/(3 sqrt 2) for phi = 24 deg, no dilatancy) against
 * dp_damage (friction_angle 24 deg, cohesion 0, dilation 0) on random strain paths that compress,
 * stay, and dilate: the stresses agree to the apex offset (cap3's tip I1 = C/M, 1.84 Pa of mean
 * stress; dp_damage's apex is 0) and the plastic strains to 1e-3 (measured 0.5-2e-6: the same
 * offset). (2) Table 2's values (C_0 = 4.5 MPa, Xi_0 = 10 MPa, C > M Xi: tip at Xi; hardening
 * off) pulled hydrostatically: I1 never exceeds the tip. */
START_TEST(test_tension_tip)
{
  for (int drift = 0; drift < 3; ++drift) {
    const double C = 1.0, beta = 2 * sqrt(6.0) * sin(24 * M_PI / 180) / (3 - sin(24 * M_PI / 180));
    const double M = beta / (3 * sqrt(2.0)), Xi = C / M;
    mpd a, r;
    c3_cone(&a, 204.86 * MPa, 0.3227, C, M, 1e-6 * M, 1.0);
    mpd_open(&r, ej_plugin_dp_damage_info(), "dp_damage");
    mpd_set(&r, "E", 204.86 * MPa), mpd_set(&r, "nu", 0.3227);
    mpd_set(&r, "friction_angle", 24 * M_PI / 180), mpd_set(&r, "cohesion", 0), mpd_set(&r, "dilation_angle", 0);
    mpd_set_bool(&r, "damage", false);
    mpd_create(&r);
    unsigned seed = 777;
    double maxerr = 0, smax = 0, I1max = -HUGE_VAL;
    const double dr = (drift - 1) * 3e-6; /* compress, stay, dilate */
    for (int n = 0; n < 1500; ++n) {
      ej_real d[6];
      for (int k = 0; k < 6; ++k) {
        seed = seed * 1103515245u + 12345u;
        d[k] = ((seed >> 8) / 16777216.0 - 0.5) * 4e-5 + (k < 3 ? dr : 0);
      }
      ck_assert_int_eq(mpd_step(&a, d, 1.0), EJ_OK);
      ck_assert_int_eq(mpd_step(&r, d, 1.0), EJ_OK);
      for (int k = 0; k < 6; ++k) {
        maxerr = fmax(maxerr, fabs(a.stress[k] - r.stress[k]));
        smax = fmax(smax, fabs(r.stress[k]));
      }
      I1max = fmax(I1max, a.stress[0] + a.stress[1] + a.stress[2]);
    }
    printf("cap3 cohesionless cone vs dp_damage, strain drift %+g per step: max diff %.4g Pa of %.4g Pa, "
           "max I1 %.4g Pa (tip %.4g), eps_p rel. diff %.2e\n",
           dr, maxerr, smax, I1max, Xi, fabs(mpd_hist(&a, "eps_p") / mpd_hist(&r, "eps_p") - 1));
    ck_assert(mpd_hist(&r, "eps_p") > 1e-4);
    ck_assert(mpd_hist(&a, "cap_fallbacks") == 0);
    ck_assert_msg(maxerr < 1.01 * Xi / 3, "cap3 vs DP: %g Pa", maxerr);
    ck_assert(I1max <= Xi * (1 + 1e-9));
    ck_assert_double_eq_tol(mpd_hist(&a, "eps_p"), mpd_hist(&r, "eps_p"), 1e-3 * mpd_hist(&r, "eps_p"));
    mpd_close(&a);
    mpd_close(&r);
  }
  /* (2) Table 2, no cap: hydrostatic pull in 50 steps of 1e-4 (K = 4.3 GPa: 0.43 MPa of I1 / 3 per step) */
  mpd m;
  c3_open(&m, false);
  mpd_set_bool(&m, "cap", false);
  mpd_set(&m, "tau", 0);
  mpd_set(&m, "a_t", 0), mpd_set(&m, "a_c", 0), mpd_set(&m, "a_s", 0); /* no hardening: the tip stays Xi_0 */
  mpd_create(&m);
  double I1max = -HUGE_VAL;
  for (int n = 0; n < 50; ++n) {
    const ej_real d[6] = {1e-4, 1e-4, 1e-4, 0, 0, 0};
    ck_assert_int_eq(mpd_step(&m, d, 1.0), EJ_OK);
    I1max = fmax(I1max, m.stress[0] + m.stress[1] + m.stress[2]);
  }
  printf("cap3 Table 2 hydrostatic pull: max I1 %.6g MPa (Xi_0 10 MPa)\n", I1max / MPa);
  ck_assert(I1max <= 10 * MPa * (1 + 1e-9));
  ck_assert(I1max > 9 * MPa);
  mpd_close(&m);
}
END_TEST

/* Eq 61: at the same I1 the failure sqrt(J2) in triaxial extension is psi times that in triaxial
 * compression (perfectly plastic hyperbola, no cap, Table 2 psi = 0.8). */
START_TEST(test_lode)
{
  double ratio[2];
  for (int ext = 0; ext < 2; ++ext) {
    mpd m;
    c3_open(&m, false);
    mpd_set_bool(&m, "cap", false);
    mpd_set(&m, "tau", 0);
    mpd_set(&m, "a_t", 0), mpd_set(&m, "a_c", 0), mpd_set(&m, "a_s", 0);
    mpd_create(&m);
    const double s = ext ? 1 : -1;
    const ej_real d[6] = {2 * s, -s, -s, 0, 0, 0}; /* isochoric TXC / TXE direction */
    for (int n = 0; n < 200; ++n) ck_assert_int_eq(mpd_step(&m, d, 1e-5), EJ_OK);
    const double I1 = 3 * mpd_mean(m.stress), rJ2 = mpd_snorm(m.stress) / sqrt(2.0);
    ratio[ext] = rJ2 / ref_Ff(4.5 * MPa, 0.2, 10 * MPa, I1);
    ck_assert(mpd_hist(&m, "eps_p") > 0);
    mpd_close(&m);
  }
  printf("cap3 Lode: sqrt(J2)/F_f TXC %.15f TXE %.15f\n", ratio[0], ratio[1]);
  ck_assert_double_eq_tol(ratio[0], 1.0, 1e-10);
  ck_assert_double_eq_tol(ratio[1], 0.8, 1e-10);
}
END_TEST

/* The derivatives c3_newton's analytic Jacobian is built from (cap3_math.h) against central
 * differences of the function one order down: the Lode function's gradient and Hessian at general
 * and near-triaxial points for psi 0.8, 7/9 and 1, the signed shear function's slope and its
 * signed square's slope and curvature (the flow direction's pieces) on the hyperbola (C > M Xi and C < M Xi), the cone, inside the cap and beyond the
 * tension tip. Relative to the largest entry (at least the natural scale); the differences' own
 * error is ~1e-8. */
static double c3_fd_rel(double a, double b, double scale) { return fabs(a - b) / fmax(scale, 1e-300); }

START_TEST(test_derivatives)
{
  const double psis[3] = {0.8, 7.0 / 9.0, 1.0};
  const double pts[5][3] = {{-30e6, -12e6, 4e6}, {-5e6, -20e6, -21e6}, {-20e6, -5e6, -5.0001e6},
                            {-20e6, -20.0002e6, -5e6}, {3e6, -1e6, 0.2e6}};
  double eg = 0, eh = 0;
  for (int ip = 0; ip < 3; ++ip)
    for (int k = 0; k < 5; ++k) {
      ej_real g[3], H[3][3];
      c3_lode(psis[ip], pts[k], g, H, 5.5e6);
      /* scales: the gradient is O(1), the Hessian O(1/sqrt J2) (psi = 7/9 is flat in extension:
       * there the Hessian vanishes and a relative measure would compare round-off) */
      const double m = (pts[k][0] + pts[k][1] + pts[k][2]) / 3;
      const double rJ2 = sqrt(0.5 * ((pts[k][0] - m) * (pts[k][0] - m) + (pts[k][1] - m) * (pts[k][1] - m) +
                                     (pts[k][2] - m) * (pts[k][2] - m)));
      double gmax = 1, hmax = 1 / (2 * rJ2);
      for (int A = 0; A < 3; ++A) {
        gmax = fmax(gmax, fabs(g[A]));
        for (int B = 0; B < 3; ++B) hmax = fmax(hmax, fabs(H[A][B]));
      }
      for (int B = 0; B < 3; ++B) {
        const double h = 1e-5 * 1e6;
        ej_real xp[3] = {pts[k][0], pts[k][1], pts[k][2]}, xm[3] = {pts[k][0], pts[k][1], pts[k][2]};
        xp[B] += h, xm[B] -= h;
        ej_real gp[3], gm[3];
        const double fp = c3_lode(psis[ip], xp, gp, NULL, 5.5e6), fm = c3_lode(psis[ip], xm, gm, NULL, 5.5e6);
        eg = fmax(eg, c3_fd_rel(g[B], (fp - fm) / (2 * h), gmax));
        for (int A = 0; A < 3; ++A) eh = fmax(eh, c3_fd_rel(H[A][B], (gp[A] - gm[A]) / (2 * h), hmax));
      }
    }
  /* shear: (C, M, Xi, kappa, X, cap) cases and I1 points */
  const struct {
    double C, M, Xi, kappa, X;
    bool cap;
    double I1[3];
  } cs[5] = {
      {4.5e6, 0.2, 10e6, -50e6, -120e6, true, {-80e6, -20e6, 5e6}},   /* Table 2: cap, hyperbola */
      {2e6, 0.2, 11e6, -50e6, -100e6, true, {-60e6, -10e6, 8e6}},     /* C < M Xi: the other root */
      {1.0, 0.18, 1.0 / 0.18, 0, 0, false, {-4e4, -10, 5.0}},        /* the cone C = M Xi */
      {4.5e6, 0.2, 10e6, -50e6, -120e6, false, {12e6, 30e6, 60e6}},  /* beyond the tension tip */
      {4.5e6, 0.05, 10e6, -50e6, -70e6, true, {-69e6, -55e6, -30e6}}, /* M_g-like slope, steep cap */
  };
  double e1 = 0, e2 = 0, e3 = 0;
  for (int c = 0; c < 5; ++c)
    for (int k = 0; k < 3; ++k) {
      const double I1 = cs[c].I1[k], h = 1e-6 * fmax(fabs(I1), 1e3);
      ej_real d1, p1, p2, p1p, p1m;
      c3_shear(cs[c].C, cs[c].M, cs[c].Xi, cs[c].kappa, cs[c].X, cs[c].cap, I1, &d1);
      const double fp = c3_shear(cs[c].C, cs[c].M, cs[c].Xi, cs[c].kappa, cs[c].X, cs[c].cap, I1 + h, NULL);
      const double fm = c3_shear(cs[c].C, cs[c].M, cs[c].Xi, cs[c].kappa, cs[c].X, cs[c].cap, I1 - h, NULL);
      e1 = fmax(e1, c3_fd_rel(d1, (fp - fm) / (2 * h), fabs(d1)));
      c3_shear_sq(cs[c].C, cs[c].M, cs[c].Xi, cs[c].kappa, cs[c].X, cs[c].cap, I1, &p1, &p2);
      const double qp = c3_shear_sq(cs[c].C, cs[c].M, cs[c].Xi, cs[c].kappa, cs[c].X, cs[c].cap, I1 + h, &p1p, NULL);
      const double qm = c3_shear_sq(cs[c].C, cs[c].M, cs[c].Xi, cs[c].kappa, cs[c].X, cs[c].cap, I1 - h, &p1m, NULL);
      e2 = fmax(e2, c3_fd_rel(p1, (qp - qm) / (2 * h), fabs(p1)));
      e3 = fmax(e3, c3_fd_rel(p2, (p1p - p1m) / (2 * h), fmax(fabs(p2), 1e-3 * fabs(p1) / fmax(fabs(I1), 1))));
    }
  printf("cap3 derivatives vs central differences: Lode gradient %.2e, Hessian %.2e; shear slope %.2e; its signed "
         "square's slope %.2e, curvature %.2e\n", eg, eh, e1, e2, e3);
  ck_assert(eg < 1e-6 && eh < 1e-6 && e1 < 1e-6 && e2 < 1e-6 && e3 < 1e-6);
}
END_TEST

/* Duvaut-Lions at frozen strain in the DP limit: overstress decays by 1/(1 + dt/tau) per step. */
START_TEST(test_duvaut_lions)
{
  mpd m;
  c3_open(&m, false);
  mpd_set(&m, "psi", 1.0);
  mpd_set_bool(&m, "cap", false);
  mpd_set(&m, "a_t", 0), mpd_set(&m, "a_c", 0), mpd_set(&m, "a_s", 0);
  mpd_set(&m, "tau", 0.01);
  mpd_set(&m, "M_g", 0.0); /* no dilatancy: the quasi-static stress is fixed at frozen strain */
  mpd_create(&m);
  const ej_real d[6] = {0, 0, 0, 1, 0, 0}, z[6] = {0};
  for (int n = 0; n < 10; ++n) ck_assert_int_eq(mpd_step(&m, d, 1e-4), EJ_OK); /* well past yield */
  const double tau_y = ref_Ff(4.5 * MPa, 0.2, 10 * MPa, 0); /* sqrt(J2) = sxy at I1 = 0 */
  double over = m.stress[3] - tau_y;
  ck_assert(over > 0.1 * tau_y);
  for (int n = 0; n < 20; ++n) {
    ck_assert_int_eq(mpd_step(&m, z, 1e-3), EJ_OK);
    const double o1 = m.stress[3] - tau_y;
    ck_assert_double_eq_tol(o1 / over, 1 / (1 + 0.1), 1e-9);
    over = o1;
  }
  mpd_close(&m);
}
END_TEST

/* Runs a strain-rate program (segments of constant d) with tau = 0 and checks the surface. */
typedef struct seg {
  ej_real d[6];
  int n;
} seg;
static void run_path(const char *name, bool t4, double Mg, double q1, const seg *sg, int nseg, double dt,
                     double *kappa_end, double *gamma_end)
{
  mpd m;
  c3_open(&m, t4);
  mpd_set(&m, "tau", 0);
  mpd_set(&m, "M_g", Mg);
  mpd_set(&m, "q1", q1);
  mpd_create(&m);
  ref r = ref_table(t4);
  r.q1 = q1;
  FILE *csv = mpd_csv_open(name, "step,sxx,syy,szz,sxy,sxz,I1,sqrtJ2,kappa,gamma,f");
  double fmaxv = 0, fplast = 0, crush = 0;
  int step = 0, nplastic = 0;
  for (int k = 0; k < nseg; ++k)
    for (int n = 0; n < sg[k].n; ++n, ++step) {
      const double ep0 = mpd_hist(&m, "eps_p"), ev0 = mpd_hist(&m, "eps_v_p");
      ck_assert_int_eq(mpd_step(&m, sg[k].d, dt), EJ_OK);
      for (int c = 0; c < 6; ++c) ck_assert(isfinite(m.stress[c]));
      const double kap = mpd_hist(&m, "cap_kappa"), gam = mpd_hist(&m, "cap_gamma");
      double X;
      const double f = ref_f(&r, m.stress, kap, gam, &X);
      fmaxv = fmax(fmaxv, f);
      if (mpd_hist(&m, "eps_p") > ep0 || mpd_hist(&m, "eps_v_p") != ev0) {
        ++nplastic;
        fplast = fmax(fplast, fabs(f));
      }
      if (mpd_hist(&m, "cap_fallbacks") > 0 && nplastic >= 0) {
        fprintf(stderr, "%s: first fallback at step %d, I1 %g sqrtJ2 %g kappa %g eps_v_p %g\n", name, step,
               3 * mpd_mean(m.stress), mpd_snorm(m.stress) / sqrt(2.0), kap, mpd_hist(&m, "eps_v_p"));
        nplastic = -1000000;
      }
      crush = fmax(crush, fabs(X - ref_X_crush(&r, mpd_hist(&m, "eps_v_p"))));
      if (csv)
        fprintf(csv, "%d,%.10g,%.10g,%.10g,%.10g,%.10g,%.10g,%.10g,%.10g,%.10g,%.3g\n", step, m.stress[0],
                m.stress[1], m.stress[2], m.stress[3], m.stress[5], 3 * mpd_mean(m.stress),
                mpd_snorm(m.stress) / sqrt(2.0), kap, gam, f);
    }
  if (csv) fclose(csv);
  printf("cap3 %s: %d plastic steps of %d, max f %.3g Pa, max |f| plastic %.3g Pa, crush-curve error %.3g Pa, "
         "kappa %.6g MPa, gamma %.6g, fallbacks %g\n",
         name, nplastic, step, fmaxv, fplast, crush, mpd_hist(&m, "cap_kappa") / MPa, mpd_hist(&m, "cap_gamma"),
         mpd_hist(&m, "cap_fallbacks"));
  ck_assert(nplastic > 0);
  ck_assert_msg(fmaxv < 1e-6 * MPa, "%s: f = %g above the surface", name, fmaxv);
  ck_assert_msg(fplast < 1e-6 * MPa, "%s: plastic step off the surface by %g", name, fplast);
  ck_assert_msg(crush < 1e-6 * MPa, "%s: crush curve off by %g", name, crush);
  ck_assert(mpd_hist(&m, "cap_fallbacks") == 0);
  if (kappa_end) *kappa_end = mpd_hist(&m, "cap_kappa");
  if (gamma_end) *gamma_end = mpd_hist(&m, "cap_gamma");
  mpd_close(&m);
}

/* V1 (003 §5.1.1b, Table 2): uniaxial-strain compression to 0.5 %; elastic start checked against
 * sigma_xx = -(K + 4G/3) eps. */
START_TEST(test_v1_uniaxial)
{
  const double K = 9000 * MPa / (3 * 0.7), G = 9000 * MPa / 2.3;
  mpd m;
  c3_open(&m, false);
  mpd_create(&m);
  const ej_real d[6] = {-1e-5, 0, 0, 0, 0, 0};
  ck_assert_int_eq(mpd_step(&m, d, 1.0), EJ_OK);
  ck_assert_double_eq_tol(m.stress[0], -(K + 4 * G / 3) * 1e-5, 1e-6);
  ck_assert_double_eq_tol(m.stress[1], -(K - 2 * G / 3) * 1e-5, 1e-6);
  mpd_close(&m);
  /* 0.5 %: with Table 2's n0* = 1e-3 the crush curve is exhausted (eps_v_p -> -n0*, X -> -inf)
   * near 0.6 % axial strain, where the return needs the radial fallback (README, limits). */
  seg s[1] = {{{-2e-5, 0, 0, 0, 0, 0}, 250}};
  double kap;
  run_path("cap3_v1_uniaxial", false, 0.2, 1.0 / MPa, s, 1, 1.0, &kap, NULL);
  ck_assert_msg(kap < -50 * MPa, "the cap must have moved (kappa %g)", kap);
}
END_TEST

/* V2 (003 §5.1.2b, Table 4): 0.0015 mm on all sides (1 s), relaxation 1 s, 0.02 mm on top (1 s). */
START_TEST(test_v2_triaxial)
{
  seg s[3] = {{{-1.5e-3, -1.5e-3, -1.5e-3, 0, 0, 0}, 500}, {{0}, 500}, {{-2e-2, 0, 0, 0, 0, 0}, 1000}};
  run_path("cap3_v2_triaxial", true, 0.2, 10.0 / MPa, s, 3, 2e-3, NULL, NULL);
}
END_TEST

/* V3 (003 §5.1.3, Table 2 with M_g = 0.05): uniaxial extension 0.01 mm (1 %). */
START_TEST(test_v3_extension)
{
  seg s[1] = {{{1e-5, 0, 0, 0, 0, 0}, 1000}};
  double gam;
  run_path("cap3_v3_extension", false, 0.05, 1.0 / MPa, s, 1, 1.0, NULL, &gam);
  ck_assert(gam > 0);
}
END_TEST

/* V4 (003 §5.1.4, Table 4 with q1 = 0.001): compression 0.01 mm, then shear 0.02 mm with the top
 * held vertically (principal axes rotate). */
START_TEST(test_v4_compression_shear)
{
  seg s[2] = {{{0, 0, -1e-5, 0, 0, 0}, 1000}, {{0, 0, 0, 0, 0, 1e-5}, 1000}};
  run_path("cap3_v4_comp_shear", true, 0.2, 0.001 / MPa, s, 2, 1.0, NULL, NULL);
}
END_TEST

START_TEST(test_config)
{
  mpd m;
  c3_open(&m, false);
  mpd_set(&m, "C_0", 6 * MPa);
  mpd_expect_reject(&m); /* C_0 > C_max */
  mpd_close(&m);
  c3_open(&m, false);
  mpd_set(&m, "M_g", 0.3);
  mpd_expect_reject(&m); /* M_g > M */
  mpd_close(&m);
  c3_open(&m, false);
  mpd_set(&m, "kappa0", 20 * MPa);
  mpd_expect_reject(&m); /* kappa0 above Xi_0 */
  mpd_close(&m);
}
END_TEST

int main(void)
{
  Suite *s = suite_create("cap3");
  TCase *tc = tcase_create("paths");
  tcase_set_timeout(tc, 60);
  tcase_add_test(tc, test_eig);
  tcase_add_test(tc, test_dp_limit);
  tcase_add_test(tc, test_tension_tip);
  tcase_add_test(tc, test_lode);
  tcase_add_test(tc, test_derivatives);
  tcase_add_test(tc, test_duvaut_lions);
  tcase_add_test(tc, test_v1_uniaxial);
  tcase_add_test(tc, test_v2_triaxial);
  tcase_add_test(tc, test_v3_extension);
  tcase_add_test(tc, test_v4_compression_shear);
  tcase_add_test(tc, test_config);
  suite_add_tcase(s, tc);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}

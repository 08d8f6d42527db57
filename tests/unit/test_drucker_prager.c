/* drucker_prager: material-point stress paths against closed forms (Fan & Li 2017 Eqs 43-59,
 * digest 000 §2.1 with the Eq 58 erratum). Sand-like constants E = 98.5 MPa, nu = 0.25
 * (000 Table 2), phi = 20 deg, psi = 10 deg, c = 50 kPa, beta = -1 unless a test says otherwise.
 * With EJ_MP_CSV_DIR set the paths are written as CSV for validation/material_points. */
#include "material_point_driver.h"

const ej_plugin_info *ej_plugin_drucker_prager_info(void);

#define DEG (M_PI / 180.0)
static const double E_ = 98.5e6, NU_ = 0.25, C_ = 50e3;
static const double K_ = 98.5e6 / (3 * (1 - 2 * 0.25)), G_ = 98.5e6 / (2 * (1 + 0.25));

static double A_of(double x, double beta) { return 2 * sqrt(6.0) * cos(x) / (3 + beta * sin(x)); }
static double B_of(double x, double beta) { return 2 * sqrt(6.0) * sin(x) / (3 + beta * sin(x)); }

static void dp_open(mpd *m, double phi_deg, double psi_deg, double c)
{
  mpd_open(m, ej_plugin_drucker_prager_info(), "drucker_prager");
  mpd_set(m, "E", E_);
  mpd_set(m, "nu", NU_);
  mpd_set(m, "friction_angle", phi_deg * DEG);
  mpd_set(m, "dilation_angle", psi_deg * DEG);
  mpd_set(m, "cohesion", c);
}

/* Uniaxial strain (oedometer) compression: lateral/axial = nu/(1-nu) while elastic, yield at
 * eps_y = A c / (2G sqrt(2/3) - B K); after yield the path is linear with the closed-form slope
 * (perfect plasticity on the cone, constant deviator direction). */
START_TEST(test_uniaxial_strain)
{
  mpd m;
  dp_open(&m, 20, 10, C_);
  mpd_create(&m);
  const double A = A_of(20 * DEG, -1), B = B_of(20 * DEG, -1), Bp = B_of(10 * DEG, -1);
  const double eps_y = A * C_ / (2 * G_ * sqrt(2.0 / 3.0) - B * K_); /* magnitude */
  const double rate = -1.0, dt = eps_y / 37.3; /* yield falls inside a step */
  const ej_real d[6] = {rate, 0, 0, 0, 0, 0};
  FILE *csv = mpd_csv_open("dp_uniaxial_strain", "eps_axial,sxx,syy,sxx_exact,syy_exact");
  /* post-yield slopes per unit |eps|: dgamma = (2G sqrt(2/3) - B K) / (2G + B K Bp) */
  const double dg = (2 * G_ * sqrt(2.0 / 3.0) - B * K_) / (2 * G_ + B * K_ * Bp);
  double max_err = 0;
  for (int n = 1; n <= 150; ++n) {
    ck_assert_int_eq(mpd_step(&m, d, dt), EJ_OK);
    const double e = n * dt; /* |eps| */
    double sxx, syy;
    if (e <= eps_y) {
      sxx = -(K_ + 4 * G_ / 3) * e, syy = -(K_ - 2 * G_ / 3) * e;
      ck_assert_double_eq_tol(m.stress[1] / m.stress[0], NU_ / (1 - NU_), 1e-12);
    } else {
      const double de = e - eps_y;
      const double p = -K_ * eps_y + K_ * (-de - Bp * dg * de);
      const double q = sqrt(2.0 / 3.0) * 2 * G_ * eps_y + 2 * G_ * (sqrt(2.0 / 3.0) * de - dg * de);
      /* s = q n, n = diag(-2, 1, 1)/sqrt(6) for axial compression */
      sxx = p - 2 * q / sqrt(6.0), syy = p + q / sqrt(6.0);
      ck_assert_double_eq_tol(mpd_snorm(m.stress), A * C_ - B * mpd_mean(m.stress), 1e-9 * G_ * e);
    }
    max_err = fmax(max_err, fmax(fabs(m.stress[0] - sxx), fabs(m.stress[1] - syy)) / (G_ * e));
    if (csv) fprintf(csv, "%.17g,%.17g,%.17g,%.17g,%.17g\n", -e, m.stress[0], m.stress[1], sxx, syy);
  }
  if (csv) fclose(csv);
  ck_assert_msg(max_err < 1e-10, "uniaxial strain: max error %g (relative to 2G eps)", max_err);
  ck_assert(m.stress[2] == m.stress[1]);
  mpd_close(&m);
}
END_TEST

/* Drained triaxial compression: hydrostatic to -sc, then axial compression with the lateral
 * stress held at -sc. Peak deviator q = (A c + B sc)/(sqrt(2/3) - B/3), which for beta = -1 is
 * exactly Mohr-Coulomb: q = (2 c cos phi + 2 sc sin phi)/(1 - sin phi). */
START_TEST(test_triaxial_peak)
{
  const double scs[] = {50e3, 200e3, 800e3};
  FILE *csv = mpd_csv_open("dp_triaxial", "sc,eps_axial,q,q_peak_exact");
  for (int t = 0; t < 3; ++t) {
    const double sc = scs[t];
    mpd m;
    dp_open(&m, 20, 10, C_);
    mpd_create(&m);
    const double dt = 1e-5;
    ej_real d[6] = {0};
    for (int n = 0; n < 10; ++n) { /* hydrostatic, elastic */
      for (int k = 0; k < 3; ++k) d[k] = -sc / (3 * K_) / (10 * dt);
      ck_assert_int_eq(mpd_step(&m, d, dt), EJ_OK);
    }
    for (int k = 0; k < 3; ++k) ck_assert_double_eq_tol(m.stress[k], -sc, 1e-6 * sc);
    ck_assert_double_eq_tol(mpd_hist(&m, "eps_p"), 0, 1e-15);
    const double phi = 20 * DEG, A = A_of(phi, -1), B = B_of(phi, -1);
    const double q_dp = (A * C_ + B * sc) / (sqrt(2.0 / 3.0) - B / 3);
    const double q_mc = (2 * C_ * cos(phi) + 2 * sc * sin(phi)) / (1 - sin(phi));
    ck_assert_double_eq_tol(q_dp, q_mc, 1e-12 * q_mc);
    const int ctrl[6] = {0, 1, 1, 0, 0, 0};
    const ej_real target[6] = {0, -sc, -sc, 0, 0, 0};
    double eps = 0, q = 0, ev0 = 0, ep0 = 0;
    for (int n = 0; n < 800; ++n) {
      d[0] = -1.0, d[3] = d[4] = d[5] = 0;
      mpd_step_mixed(&m, d, ctrl, target, 2e-5, G_);
      eps += 2e-5;
      q = m.stress[1] - m.stress[0];
      ck_assert(q <= q_mc * (1 + 1e-9));
      if (n == 700) ev0 = mpd_hist(&m, "eps_v_p"), ep0 = mpd_hist(&m, "eps_p");
      if (csv) fprintf(csv, "%g,%.17g,%.17g,%.17g\n", sc, -eps, q, q_mc);
    }
    ck_assert_msg(mpd_relerr(q, q_mc) < 1e-9, "sc = %g: q = %.17g, Mohr-Coulomb %.17g", sc, q, q_mc);
    /* non-associated dilatancy on the plateau: d eps_v_p / d eps_p = B(psi) sqrt(3/2) */
    const double ratio = (mpd_hist(&m, "eps_v_p") - ev0) / (mpd_hist(&m, "eps_p") - ep0);
    ck_assert_msg(mpd_relerr(ratio, B_of(10 * DEG, -1) * sqrt(1.5)) < 1e-8, "dilatancy ratio %.12g vs %.12g", ratio,
                  B_of(10 * DEG, -1) * sqrt(1.5));
    mpd_close(&m);
  }
  if (csv) fclose(csv);
}
END_TEST

/* Simple shear (psi = 0, no volume change): tau = 2 G eps_xy up to tau_y = A c / sqrt(2), then
 * a plateau; the plastic work is tau_y * 2 d eps_xy^p per unit volume. */
START_TEST(test_pure_shear)
{
  mpd m;
  dp_open(&m, 20, 0, C_);
  mpd_create(&m);
  const double tau_y = A_of(20 * DEG, -1) * C_ / sqrt(2.0);
  const double gy = tau_y / (2 * G_), dt = gy / 13.7;
  const ej_real d[6] = {0, 0, 0, 1.0, 0, 0};
  FILE *csv = mpd_csv_open("dp_pure_shear", "eps_xy,sxy,sxy_exact");
  for (int n = 1; n <= 60; ++n) {
    ck_assert_int_eq(mpd_step(&m, d, dt), EJ_OK);
    const double e = n * dt, ex = e <= gy ? 2 * G_ * e : tau_y;
    ck_assert_double_eq_tol(m.stress[3], ex, 1e-9 * tau_y);
    ck_assert_double_eq_tol(mpd_mean(m.stress), 0, 1e-9 * tau_y);
    if (csv) fprintf(csv, "%.17g,%.17g,%.17g\n", e, m.stress[3], ex);
  }
  if (csv) fclose(csv);
  const double e = 60 * dt, wp = tau_y * 2 * (e - gy) / m.rho;
  ck_assert_msg(mpd_relerr(m.wp_total, wp) < 1e-9, "plastic work %.12g vs %.12g", m.wp_total, wp);
  ck_assert_double_eq_tol(mpd_hist(&m, "eps_p"), sqrt(2.0 / 3.0) * sqrt(2.0) * (e - gy), 1e-9 * e);
  ck_assert_double_eq_tol(mpd_hist(&m, "eps_v_p"), 0, 1e-15);
  mpd_close(&m);
}
END_TEST

/* Hydrostatic extension: the mean stress rises elastically to the apex A c / B and stays there;
 * the extra volume is plastic: eps_v_p = eps_v - apex / K. */
START_TEST(test_apex_return)
{
  const double psis[] = {0, 10};
  for (int t = 0; t < 2; ++t) {
    mpd m;
    dp_open(&m, 20, psis[t], C_);
    mpd_create(&m);
    const double apex = A_of(20 * DEG, -1) * C_ / B_of(20 * DEG, -1);
    const double dt = apex / (3 * K_) / 7.5;
    const ej_real d[6] = {1, 1, 1, 0, 0, 0};
    FILE *csv = t ? mpd_csv_open("dp_apex", "eps_v,p,p_exact") : NULL;
    for (int n = 1; n <= 30; ++n) {
      ck_assert_int_eq(mpd_step(&m, d, dt), EJ_OK);
      const double ev = 3 * n * dt, pe = fmin(K_ * ev, apex);
      for (int k = 0; k < 3; ++k) ck_assert_double_eq_tol(m.stress[k], pe, 1e-10 * apex);
      ck_assert_double_eq_tol(mpd_snorm(m.stress), 0, 1e-10 * apex);
      ck_assert_double_eq_tol(mpd_hist(&m, "eps_v_p"), fmax(ev - apex / K_, 0), 1e-12);
      if (csv) fprintf(csv, "%.17g,%.17g,%.17g\n", ev, mpd_mean(m.stress), pe);
    }
    if (csv) fclose(csv);
    /* the trial state with a deviator inside the apex region also lands on the apex */
    const ej_real d2[6] = {1, 0.5, 0.2, 0.1, 0, 0};
    ck_assert_int_eq(mpd_step(&m, d2, 1e-3), EJ_OK);
    ck_assert_double_eq_tol(mpd_snorm(m.stress), 0, 1e-10 * apex);
    ck_assert_double_eq_tol(mpd_mean(m.stress), apex, 1e-10 * apex);
    mpd_close(&m);
  }
}
END_TEST

/* Tension cutoff T below the apex: hydrostatic extension stops at T; uniaxial extension ends on
 * the cutoff plane with an admissible deviator. */
START_TEST(test_tension_cutoff)
{
  const double T = 10e3;
  mpd m;
  dp_open(&m, 20, 10, C_);
  mpd_set(&m, "tension_cutoff", T);
  mpd_create(&m);
  const ej_real d[6] = {1, 1, 1, 0, 0, 0};
  const double dt = T / (3 * K_) / 4.3;
  for (int n = 1; n <= 20; ++n) {
    ck_assert_int_eq(mpd_step(&m, d, dt), EJ_OK);
    const double pe = fmin(3 * K_ * n * dt, T);
    for (int k = 0; k < 3; ++k) ck_assert_double_eq_tol(m.stress[k], pe, 1e-10 * T);
  }
  mpd_close(&m);
  /* uniaxial-strain extension: the cutoff is reached with a deviator below the cone radius */
  dp_open(&m, 20, 10, C_);
  mpd_set(&m, "tension_cutoff", T);
  mpd_create(&m);
  const ej_real d1[6] = {1, 0, 0, 0, 0, 0};
  const double A = A_of(20 * DEG, -1), B = B_of(20 * DEG, -1);
  for (int n = 1; n <= 40; ++n) {
    ck_assert_int_eq(mpd_step(&m, d1, 2e-5), EJ_OK);
    ck_assert(mpd_mean(m.stress) <= T * (1 + 1e-12));
    ck_assert(mpd_snorm(m.stress) <= (A * C_ - B * mpd_mean(m.stress)) * (1 + 1e-12));
  }
  ck_assert_double_eq_tol(mpd_mean(m.stress), T, 1e-9 * T);
  ck_assert(mpd_hist(&m, "eps_v_p") > 0);
  mpd_close(&m);
}
END_TEST

/* Duvaut-Lions: tau -> 0 reproduces the rate-independent path; at fixed strain the overstress
 * decays by 1/(1 + dt/tau) per step (backward Euler of d(sigma)/dt = -(sigma - sigma_qs)/tau),
 * which tends to exp(-t/tau). */
START_TEST(test_viscoplastic)
{
  mpd a, b;
  dp_open(&a, 20, 10, C_);
  mpd_create(&a);
  dp_open(&b, 20, 10, C_);
  mpd_set(&b, "relaxation_time", 1e-14);
  mpd_create(&b);
  const ej_real d[6] = {-1, 0.2, 0.1, 0.3, -0.1, 0.05};
  for (int n = 0; n < 100; ++n) {
    ck_assert_int_eq(mpd_step(&a, d, 1e-4), EJ_OK);
    ck_assert_int_eq(mpd_step(&b, d, 1e-4), EJ_OK);
  }
  for (int k = 0; k < 6; ++k) ck_assert_double_eq_tol(b.stress[k], a.stress[k], 1e-8 * G_ * 1e-2);
  ck_assert_double_eq_tol(mpd_hist(&b, "eps_p"), mpd_hist(&a, "eps_p"), 1e-9);
  mpd_close(&a);
  mpd_close(&b);

  const double tau = 1e-3, dt = 1e-5;
  mpd m;
  dp_open(&m, 20, 0, C_);
  mpd_set(&m, "relaxation_time", tau);
  mpd_create(&m);
  const double tau_y = A_of(20 * DEG, -1) * C_ / sqrt(2.0);
  const double t0 = 3 * tau_y; /* trial shear stress after one step */
  const ej_real d0[6] = {0, 0, 0, t0 / (2 * G_) / dt, 0, 0}, dz[6] = {0};
  ck_assert_int_eq(mpd_step(&m, d0, dt), EJ_OK);
  const double k1 = 1 / (1 + dt / tau);
  ck_assert_double_eq_tol(m.stress[3] - tau_y, (t0 - tau_y) * k1, 1e-10 * tau_y);
  FILE *csv = mpd_csv_open("dp_relaxation", "t,sxy,sxy_exact_discrete,sxy_exp");
  for (int n = 2; n <= 300; ++n) {
    ck_assert_int_eq(mpd_step(&m, dz, dt), EJ_OK);
    const double ex = tau_y + (t0 - tau_y) * pow(k1, n);
    ck_assert_double_eq_tol(m.stress[3], ex, 1e-9 * tau_y);
    if (csv) fprintf(csv, "%.17g,%.17g,%.17g,%.17g\n", n * dt, m.stress[3], ex, tau_y + (t0 - tau_y) * exp(-n * dt / tau));
  }
  if (csv) fclose(csv);
  /* O(dt/tau) from the continuous solution */
  ck_assert(fabs(m.stress[3] - (tau_y + (t0 - tau_y) * exp(-300 * dt / tau))) < 0.01 * (t0 - tau_y));
  mpd_close(&m);
}
END_TEST

/* Cohesion hardening: pure shear with H_c: tau = (A (c0 + H A gamma))/sqrt(2), dgamma = the
 * plastic deviatoric strain norm (Eq 57-59). */
START_TEST(test_hardening)
{
  const double H = 2e6;
  mpd m;
  dp_open(&m, 20, 0, C_);
  mpd_set(&m, "H_c", H);
  mpd_create(&m);
  const double A = A_of(20 * DEG, -1);
  const ej_real d[6] = {0, 0, 0, 1, 0, 0};
  for (int n = 0; n < 100; ++n) ck_assert_int_eq(mpd_step(&m, d, 1e-4), EJ_OK);
  /* tau = 2G (e - gp/sqrt2 ...): solve the linear relation in closed form */
  const double e = 100 * 1e-4;
  /* on the cone: sqrt2 tau = A (c0 + H A g), tau = 2G(e - g/sqrt2)  (g = ||de_p||, e^p_xy = g/sqrt2) */
  const double g = (2 * G_ * sqrt(2.0) * e - A * C_) / (2 * G_ + H * A * A);
  const double tau = A * (C_ + H * A * g) / sqrt(2.0);
  ck_assert_msg(mpd_relerr(m.stress[3], tau) < 1e-9, "tau %.12g vs %.12g", m.stress[3], tau);
  ck_assert_double_eq_tol(mpd_hist(&m, "cohesion"), C_ + H * A * g, 1e-9 * C_);
  mpd_close(&m);
}
END_TEST

START_TEST(test_moduli_sound_config)
{
  mpd m;
  dp_open(&m, 30, 0, 0);
  mpd_create(&m);
  ej_real K, G;
  ck_assert_int_eq(m.ops->moduli(m.state, &K, &G), EJ_OK);
  ck_assert_double_eq_tol(K, K_, 1e-6);
  ck_assert_double_eq_tol(G, G_, 1e-6);
  const ej_real d[6] = {0};
  m.rho = 1700;
  ck_assert_int_eq(mpd_step(&m, d, 1e-6), EJ_OK);
  ck_assert_double_eq_tol(m.c, sqrt((K_ + 4 * G_ / 3) / 1700), 1e-9);
  ck_assert(!m.ops->needs_eos);
  mpd_close(&m);
  /* K and G instead of E and nu give the same material */
  mpd_open(&m, ej_plugin_drucker_prager_info(), "drucker_prager");
  mpd_set(&m, "K", K_);
  mpd_set(&m, "G", G_);
  mpd_create(&m);
  mpd_close(&m);
  /* bad inputs */
  mpd_open(&m, ej_plugin_drucker_prager_info(), "drucker_prager");
  mpd_set(&m, "E", E_);
  mpd_expect_reject(&m); /* E without nu */
  mpd_set(&m, "nu", 0.3);
  mpd_set(&m, "K", K_);
  mpd_set(&m, "G", G_);
  mpd_expect_reject(&m); /* both pairs */
  mpd_close(&m);
  dp_open(&m, 20, 25, 0);
  mpd_expect_reject(&m); /* psi > phi */
  mpd_close(&m);
}
END_TEST

int main(void)
{
  Suite *s = suite_create("drucker_prager");
  TCase *tc = tcase_create("paths");
  tcase_add_test(tc, test_uniaxial_strain);
  tcase_add_test(tc, test_triaxial_peak);
  tcase_add_test(tc, test_pure_shear);
  tcase_add_test(tc, test_apex_return);
  tcase_add_test(tc, test_tension_cutoff);
  tcase_add_test(tc, test_viscoplastic);
  tcase_add_test(tc, test_hardening);
  tcase_add_test(tc, test_moduli_sound_config);
  suite_add_tcase(s, tc);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}

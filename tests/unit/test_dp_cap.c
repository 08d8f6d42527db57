/* dp_cap: the cap model against drucker_prager (cap removed: identical to round-off on the same
 * paths) and against the closed-form hydrostatic compaction curve of the crush law
 * (000 Eqs 62-63, 76-77): on the hydrostat the stress sits on the cap tip, I1 = X(eps_v_p), and
 * the total volumetric strain is eps_v = eps_v_p + I1/(3K). */
#include "material_point_driver.h"

const ej_plugin_info *ej_plugin_drucker_prager_info(void);
const ej_plugin_info *ej_plugin_dp_cap_info(void);

#define DEG (M_PI / 180.0)
static const double E_ = 98.5e6, NU_ = 0.25;
static const double K_ = 98.5e6 / (3 * (1 - 2 * 0.25)), G_ = 98.5e6 / (2 * (1 + 0.25));

static void open_pair(mpd *dp, mpd *cap, double phi, double psi, double c, int cap_mode)
{
  mpd_open(dp, ej_plugin_drucker_prager_info(), "drucker_prager");
  mpd_open(cap, ej_plugin_dp_cap_info(), "dp_cap");
  mpd *m[2] = {dp, cap};
  for (int k = 0; k < 2; ++k) {
    mpd_set(m[k], "E", E_);
    mpd_set(m[k], "nu", NU_);
    mpd_set(m[k], "friction_angle", phi * DEG);
    mpd_set(m[k], "dilation_angle", psi * DEG);
    mpd_set(m[k], "cohesion", c);
  }
  if (cap_mode == 0) mpd_set_bool(cap, "cap", false);
  else mpd_set(cap, "kappa0", -1e13); /* cap out of reach */
  mpd_create(dp);
  mpd_create(cap);
}

/* A path of 6 legs exercising elastic loading, shear yield, dilatant flow, unloading, apex. */
static void path_rate(int n, ej_real d[6])
{
  static const ej_real legs[6][6] = {{-1, 0, 0, 0, 0, 0},        {-0.2, -0.2, -0.2, 0, 0, 0}, {0, 0, 0, 1, 0.3, 0},
                                     {-0.5, 0.4, 0.1, -0.2, 0, 0.6}, {1, 1, 1, 0, 0, 0},       {-1, 0.3, 0.3, 0, 0.1, 0}};
  memcpy(d, legs[(n / 40) % 6], 6 * sizeof *d);
}

START_TEST(test_cap_removed_equals_dp)
{
  const double phis[] = {20, 35}, psis[] = {10, 0}, cs[] = {100e3, 0};
  double worst = 0;
  for (int mode = 0; mode < 2; ++mode)
    for (int t = 0; t < 2; ++t) {
      mpd dp, cap;
      open_pair(&dp, &cap, phis[t], psis[t], cs[t], mode);
      for (int n = 0; n < 240; ++n) {
        ej_real d[6];
        path_rate(n, d);
        ck_assert_int_eq(mpd_step(&dp, d, 2e-4), EJ_OK);
        ck_assert_int_eq(mpd_step(&cap, d, 2e-4), EJ_OK);
        double scale = 1e3;
        for (int k = 0; k < 6; ++k) scale = fmax(scale, fabs(dp.stress[k]));
        for (int k = 0; k < 6; ++k) worst = fmax(worst, fabs(cap.stress[k] - dp.stress[k]) / scale);
        ck_assert_double_eq_tol(mpd_hist(&cap, "eps_p"), mpd_hist(&dp, "eps_p"), 1e-10);
        ck_assert_double_eq_tol(mpd_hist(&cap, "eps_v_p"), mpd_hist(&dp, "eps_v_p"), 1e-10);
      }
      ck_assert(mpd_hist(&dp, "eps_p") > 1e-3); /* the path is plastic */
      ck_assert_double_eq_tol(cap.wp_total, dp.wp_total, 1e-9 * fabs(dp.wp_total));
      mpd_close(&dp);
      mpd_close(&cap);
    }
  ck_assert_msg(worst < 1e-11, "dp_cap without cap vs drucker_prager: worst relative stress difference %g", worst);
}
END_TEST

/* closed-form crush curve (test's own copy of 000 Eqs 76-77) */
static double crush(double X0, double p1, double p3, double ev)
{
  return ev <= 0 ? X0 + log(1 + ev / p3) / p1 : X0 * pow(1 + ev, 1 / (X0 * p1 * p3));
}

START_TEST(test_hydrostatic_compaction)
{
  /* 000 Table 2 DPC row: phi 0.35 rad, psi 0.17 rad, c 100 kPa, R 10, kappa0 -2 kPa, beta -1 */
  mpd m;
  mpd_open(&m, ej_plugin_dp_cap_info(), "dp_cap");
  mpd_set(&m, "E", E_);
  mpd_set(&m, "nu", NU_);
  mpd_set(&m, "friction_angle", 0.35);
  mpd_set(&m, "dilation_angle", 0.17);
  mpd_set(&m, "cohesion", 100e3);
  mpd_create(&m);
  const double A = 2 * sqrt(6.0) * cos(0.35) / (3 - sin(0.35)) * 100e3, B = 2 * sqrt(6.0) * sin(0.35) / (3 - sin(0.35));
  const double X0 = -2e3 - 10 * (A - B * (-2e3) / 3), p1 = 1.2e-8, p3 = 0.25;
  ck_assert_double_eq_tol(mpd_hist(&m, "cap_X"), X0, 1e-6);
  ck_assert_double_eq_tol(X0, -1.738167e6, 5.0); /* hand value (README) */
  const double dt = 1e-3, rate = -0.5;            /* d = rate (1,1,1): eps_v rate 3*rate */
  const ej_real d[6] = {rate, rate, rate, 0, 0, 0};
  FILE *csv = mpd_csv_open("dpc_hydrostatic", "eps_v,I1,I1_exact,eps_v_p");
  double ev = 0, max_err = 0;
  for (int n = 1; n <= 80; ++n) {
    ck_assert_int_eq(mpd_step(&m, d, dt), EJ_OK);
    ev += 3 * rate * dt;
    /* exact: elastic while 3K ev >= X0, else solve ev = evp + X(evp)/(3K) for evp by bisection */
    double I1x;
    if (3 * K_ * ev >= X0) {
      I1x = 3 * K_ * ev;
    } else {
      double lo = -p3 * (1 - 1e-15), hi = 0;
      for (int it = 0; it < 200; ++it) {
        const double mid = 0.5 * (lo + hi);
        if (mid + crush(X0, p1, p3, mid) / (3 * K_) > ev) hi = mid;
        else lo = mid;
      }
      I1x = crush(X0, p1, p3, 0.5 * (lo + hi));
    }
    const double I1 = 3 * mpd_mean(m.stress);
    max_err = fmax(max_err, fabs(I1 - I1x) / fabs(I1x));
    ck_assert_double_eq_tol(mpd_snorm(m.stress), 0, 1e-9 * fabs(I1));
    if (I1x < X0) { /* on the cap: I1 = X(eps_v_p) and the strain split */
      ck_assert_double_eq_tol(I1, crush(X0, p1, p3, mpd_hist(&m, "eps_v_p")), 1e-9 * fabs(I1));
      ck_assert_double_eq_tol(ev, mpd_hist(&m, "eps_v_p") + I1 / (3 * K_), 1e-12);
    }
    if (csv) fprintf(csv, "%.17g,%.17g,%.17g,%.17g\n", ev, I1, I1x, mpd_hist(&m, "eps_v_p"));
  }
  ck_assert_msg(max_err < 1e-9, "hydrostatic compaction: max relative error in I1 %g", max_err);
  ck_assert(mpd_hist(&m, "eps_v_p") < -0.01);
  /* unloading is elastic: cap_X and eps_v_p stay */
  const double evp = mpd_hist(&m, "eps_v_p"), X = mpd_hist(&m, "cap_X"), I1a = 3 * mpd_mean(m.stress);
  const ej_real du[6] = {-rate, -rate, -rate, 0, 0, 0};
  for (int n = 1; n <= 5; ++n) {
    ck_assert_int_eq(mpd_step(&m, du, dt), EJ_OK);
    ev -= 3 * rate * dt;
    if (csv) fprintf(csv, "%.17g,%.17g,%.17g,%.17g\n", ev, 3 * mpd_mean(m.stress), I1a + 9 * K_ * (-rate) * dt * n,
                     mpd_hist(&m, "eps_v_p"));
  }
  if (csv) fclose(csv);
  ck_assert(mpd_hist(&m, "eps_v_p") == evp && mpd_hist(&m, "cap_X") == X);
  ck_assert_double_eq_tol(3 * mpd_mean(m.stress), I1a + 9 * K_ * (-rate) * dt * 5, 1e-9 * fabs(I1a));
  mpd_close(&m);
}
END_TEST

/* Yield function of the test (independent copy) for admissibility checks. */
static double fyield(double p, double q, double A, double B, double X, double kap, double R_unused)
{
  (void)R_unused;
  double F = 1;
  if (3 * p < kap) {
    const double r = (3 * p - kap) / (X - kap);
    F = 1 - r * r;
  }
  const double psi2 = (A - B * p) * (A - B * p);
  return q - sqrt(fmax(F, 0)) * sqrt(psi2);
}

/* High-confinement triaxial compression reaches the cap: every state admissible, the plastic
 * states on the surface, plastic compaction on the cap. */
START_TEST(test_triaxial_on_cap)
{
  mpd m;
  mpd_open(&m, ej_plugin_dp_cap_info(), "dp_cap");
  mpd_set(&m, "E", E_);
  mpd_set(&m, "nu", NU_);
  mpd_set(&m, "friction_angle", 0.35);
  mpd_set(&m, "dilation_angle", 0.17);
  mpd_set(&m, "cohesion", 100e3);
  mpd_create(&m);
  const double A = 2 * sqrt(6.0) * cos(0.35) / (3 - sin(0.35)) * 100e3, B = 2 * sqrt(6.0) * sin(0.35) / (3 - sin(0.35));
  const double sc = 500e3; /* I1 = -1.5 MPa, just inside the initial cap X0 = -1.738 MPa */
  ej_real d[6] = {0};
  for (int k = 0; k < 3; ++k) d[k] = -sc / (3 * K_) / 1e-3;
  ck_assert_int_eq(mpd_step(&m, d, 1e-3), EJ_OK);
  ck_assert_double_eq_tol(mpd_hist(&m, "eps_p"), 0, 1e-15);
  const int ctrl[6] = {0, 1, 1, 0, 0, 0};
  const ej_real target[6] = {0, -sc, -sc, 0, 0, 0};
  FILE *csv = mpd_csv_open("dpc_triaxial_cap", "eps_axial,p,q,f,cap_X");
  bool saw_compaction = false;
  for (int n = 1; n <= 300; ++n) {
    d[0] = -1, d[3] = d[4] = d[5] = 0;
    const double evp0 = mpd_hist(&m, "eps_v_p");
    mpd_step_mixed(&m, d, ctrl, target, 2e-5, G_);
    const double X = mpd_hist(&m, "cap_X");
    const double kap = fmin((X + 10 * A) / (1 + 10 * B / 3), 0.0);
    const double p = mpd_mean(m.stress), q = mpd_snorm(m.stress);
    const double f = fyield(p, q, A, B, X, kap, 10);
    ck_assert_msg(f <= 1e-8 * sc, "step %d: f = %g", n, f);
    if (mpd_hist(&m, "eps_v_p") != evp0) {
      ck_assert_msg(fabs(f) <= 1e-8 * sc, "plastic step %d off the surface: f = %g", n, f);
      if (3 * p < kap) saw_compaction = saw_compaction || mpd_hist(&m, "eps_v_p") < evp0;
    }
    if (csv) fprintf(csv, "%.17g,%.17g,%.17g,%.17g,%.17g\n", -2e-5 * n, p, q, f, X);
  }
  if (csv) fclose(csv);
  ck_assert(saw_compaction);
  ck_assert(mpd_hist(&m, "cap_X") < -1.74e6); /* the cap hardened */
  mpd_close(&m);
}
END_TEST

/* Tension cap below the apex: hydrostatic extension stops at zeta. */
START_TEST(test_tension_cap)
{
  const double zeta = 20e3;
  mpd m;
  mpd_open(&m, ej_plugin_dp_cap_info(), "dp_cap");
  mpd_set(&m, "E", E_);
  mpd_set(&m, "nu", NU_);
  mpd_set(&m, "friction_angle", 0.35);
  mpd_set(&m, "cohesion", 100e3);
  mpd_set(&m, "zeta", zeta);
  mpd_create(&m);
  const ej_real d[6] = {1, 1, 1, 0, 0, 0};
  const double dt = zeta / (3 * K_) / 5.5;
  for (int n = 1; n <= 20; ++n) {
    ck_assert_int_eq(mpd_step(&m, d, dt), EJ_OK);
    const double pe = fmin(3 * K_ * n * dt, zeta);
    for (int k = 0; k < 3; ++k) ck_assert_double_eq_tol(m.stress[k], pe, 1e-9 * zeta);
  }
  /* psi = 0: g has no tension rounding, the flow at p = zeta is deviatoric: the sheared trial
   * stays at the tip (p = zeta, q = 0) */
  const ej_real d2[6] = {0, 0, 0, 2, 0, 0};
  ck_assert_int_eq(mpd_step(&m, d2, 1e-3), EJ_OK);
  ck_assert_double_eq_tol(mpd_mean(m.stress), zeta, 1e-9 * zeta);
  ck_assert_double_eq_tol(mpd_snorm(m.stress), 0, 1e-9 * zeta);
  mpd_close(&m);
  /* associated (psi = phi): the smooth tension cap returns inside, p < zeta, q > 0, on f = 0 */
  mpd_open(&m, ej_plugin_dp_cap_info(), "dp_cap");
  mpd_set(&m, "E", E_);
  mpd_set(&m, "nu", NU_);
  mpd_set(&m, "friction_angle", 0.35);
  mpd_set(&m, "dilation_angle", 0.35);
  mpd_set(&m, "cohesion", 100e3);
  mpd_set(&m, "zeta", zeta);
  mpd_set_bool(&m, "cap", false);
  mpd_create(&m);
  for (int n = 1; n <= 20; ++n) ck_assert_int_eq(mpd_step(&m, d, dt), EJ_OK);
  ck_assert_int_eq(mpd_step(&m, d2, 1e-3), EJ_OK);
  {
    const double A = 2 * sqrt(6.0) * cos(0.35) / (3 - sin(0.35)) * 100e3, B = 2 * sqrt(6.0) * sin(0.35) / (3 - sin(0.35));
    const double p = mpd_mean(m.stress), q = mpd_snorm(m.stress), t = A - B * zeta;
    ck_assert_msg(p < zeta && q > 0, "p %g q %g", p, q);
    ck_assert_double_eq_tol(q, sqrt((A - B * p) * (A - B * p) - t * t), 1e-8 * zeta);
  }
  mpd_close(&m);
  mpd_open(&m, ej_plugin_dp_cap_info(), "dp_cap");
  mpd_set(&m, "E", E_);
  mpd_set(&m, "nu", NU_);
  mpd_set(&m, "zeta", -1e6);
  mpd_expect_reject(&m); /* zeta below kappa0/3 */
  mpd_close(&m);
}
END_TEST

int main(void)
{
  Suite *s = suite_create("dp_cap");
  TCase *tc = tcase_create("paths");
  tcase_add_test(tc, test_cap_removed_equals_dp);
  tcase_add_test(tc, test_hydrostatic_compaction);
  tcase_add_test(tc, test_triaxial_on_cap);
  tcase_add_test(tc, test_tension_cap);
  suite_add_tcase(s, tc);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}

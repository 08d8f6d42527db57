/* soil_evp: steady simple shear at constant pressure reaches the closed-form mu(I) stress
 * tau = p [mu_s + (mu_2 - mu_s) g/(g + xi sqrt p)] (digest 001 §2.5 with the sqrt(p) erratum)
 * at several shear rates; quasi-static limit mu_s p; stress-free in tension and below rho_c.
 * Constants of 001 Table 5: E 21.6 MPa, nu 0.3, xi 1.1233, mu_s 0.6419, mu_2 0.8435, rho_c 500. */
#include "material_point_driver.h"

const ej_plugin_info *ej_plugin_soil_evp_info(void);

static const double E_ = 21.6e6, NU_ = 0.3, XI_ = 1.1233, MUS_ = 0.6419, MU2_ = 0.8435;
static const double K_ = 21.6e6 / (3 * (1 - 0.6));

static void evp_open(mpd *m)
{
  mpd_open(m, ej_plugin_soil_evp_info(), "soil_evp");
  mpd_set(m, "E", E_);
  mpd_set(m, "nu", NU_);
  mpd_set(m, "xi", XI_);
  mpd_set(m, "mu_s", MUS_);
  mpd_set(m, "mu_2", MU2_);
  mpd_set(m, "rho_c", 500);
  mpd_create(m);
  m->rho = 1379;
}

static double tau_closed(double p, double g) { return p * (MUS_ + (MU2_ - MUS_) * g / (g + XI_ * sqrt(p))); }

START_TEST(test_steady_shear)
{
  const double p = 10e3;
  const double rates[] = {1e-3, 1.0, 30.0, 300.0, 3000.0};
  FILE *csv = mpd_csv_open("evp_steady_shear", "gamma_dot,tau,tau_exact,tau_as_printed");
  for (int r = 0; r < 5; ++r) {
    mpd m;
    evp_open(&m);
    ej_real d[6] = {0};
    for (int k = 0; k < 3; ++k) d[k] = -p / (3 * K_) / 1e-3;
    ck_assert_int_eq(mpd_step(&m, d, 1e-3), EJ_OK);
    ck_assert_double_eq_tol(mpd_mean(m.stress), -p, 1e-9 * p);
    const double g = rates[r], dt = 0.02 / g / 400; /* total shear 0.02 over 400 steps */
    const ej_real ds[6] = {0, 0, 0, g / 2, 0, 0}; /* engineering shear rate g = 2 d_xy */
    for (int n = 0; n < 400; ++n) ck_assert_int_eq(mpd_step(&m, ds, dt), EJ_OK);
    const double tau = m.stress[3], ex = tau_closed(p, g);
    ck_assert_msg(mpd_relerr(tau, ex) < 1e-9, "rate %g: tau %.12g vs %.12g", g, tau, ex);
    ck_assert_double_eq_tol(mpd_mean(m.stress), -p, 1e-9 * p); /* no dilatancy */
    /* the as-printed alpha = xi G dt p would give the rate term g/(g + xi p): far off */
    const double printed = p * (MUS_ + (MU2_ - MUS_) * g / (g + XI_ * p));
    if (csv) fprintf(csv, "%g,%.17g,%.17g,%.17g\n", g, tau, ex, printed);
    mpd_close(&m);
  }
  if (csv) fclose(csv);
  /* quasi-static limit: mu_s p */
  ck_assert_double_eq_tol(tau_closed(p, 1e-12), MUS_ * p, 1e-6 * p);
}
END_TEST

START_TEST(test_tension_and_disconnection)
{
  mpd m;
  evp_open(&m);
  ej_real d[6] = {-1, -1, -1, 0, 0, 0};
  ck_assert_int_eq(mpd_step(&m, d, 1e-4), EJ_OK);
  ck_assert(mpd_mean(m.stress) < 0);
  const ej_real dt[6] = {2, 2, 2, 0.5, 0, 0}; /* net extension: p_tr < 0 */
  ck_assert_int_eq(mpd_step(&m, dt, 1e-4), EJ_OK);
  for (int k = 0; k < 6; ++k) ck_assert(m.stress[k] == 0);
  ck_assert_int_eq(mpd_step(&m, d, 1e-4), EJ_OK);
  ck_assert(mpd_mean(m.stress) < 0);
  m.rho = 400; /* below rho_c */
  ck_assert_int_eq(mpd_step(&m, d, 1e-4), EJ_OK);
  for (int k = 0; k < 6; ++k) ck_assert(m.stress[k] == 0);
  mpd_close(&m);
}
END_TEST

int main(void)
{
  Suite *s = suite_create("soil_evp");
  TCase *tc = tcase_create("paths");
  tcase_add_test(tc, test_steady_shear);
  tcase_add_test(tc, test_tension_and_disconnection);
  suite_add_tcase(s, tc);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}

/* mie_gruneisen: Hugoniot consistency (p(rho_H, e_H) = rho0 Us up with e_H = up^2/2), the rho0
 * erratum of the energy term, sound speed against finite differences, tension branch.
 * Constants: Armco iron and aluminium of digest 001 Table 3. */
#include "eos_point_driver.h"

const ej_plugin_info *ej_plugin_mie_gruneisen_info(void);

static void mg_open(epd *f, double rho0, double C0, double S1, double S2, double S3, double g0, double a)
{
  epd_open(f, ej_plugin_mie_gruneisen_info(), "mie_gruneisen");
  epd_set(f, "rho0", rho0);
  epd_set(f, "C0", C0);
  epd_set(f, "S1", S1);
  epd_set(f, "S2", S2);
  epd_set(f, "S3", S3);
  epd_set(f, "gamma0", g0);
  epd_set(f, "a", a);
  epd_create(f);
}

START_TEST(test_hugoniot)
{
  const double mats[2][5] = {{7890, 3630, 1.80, 1.81, 0.46}, {2700, 5240, 1.40, 1.97, 0.48}};
  for (int m = 0; m < 2; ++m) {
    epd f;
    mg_open(&f, mats[m][0], mats[m][1], mats[m][2], 0, 0, mats[m][3], mats[m][4]);
    double worst = 0;
    for (double up = 10; up <= 3000; up *= 1.5) {
      const double rho0 = mats[m][0], Us = mats[m][1] + mats[m][2] * up;
      const double rho = rho0 * Us / (Us - up), eH = 0.5 * up * up;
      const double p = epd_p(&f, rho, eH, NULL), pH = rho0 * Us * up;
      worst = fmax(worst, fabs(p - pH) / pH);
    }
    ck_assert_msg(worst < 1e-12, "material %d: Hugoniot error %g", m, worst);
    epd_close(&f);
  }
  /* with S2 and S3: Us solves Us = C0 + S1 up + S2 up^2/Us + S3 up^3/Us^2 (fixed point) */
  epd f;
  mg_open(&f, 8930, 3940, 1.49, 0.3, -0.2, 2.02, 0.47);
  for (double up = 50; up <= 2000; up *= 2) {
    double Us = 3940 + 1.49 * up;
    for (int it = 0; it < 200; ++it) Us = 3940 + 1.49 * up + 0.3 * up * up / Us - 0.2 * up * up * up / (Us * Us);
    const double rho = 8930 * Us / (Us - up), p = epd_p(&f, rho, 0.5 * up * up, NULL), pH = 8930 * Us * up;
    ck_assert_msg(fabs(p - pH) < 1e-11 * pH, "up %g: %.12g vs %.12g", up, p, pH);
  }
  epd_close(&f);
}
END_TEST

START_TEST(test_energy_term_and_tension)
{
  epd f;
  mg_open(&f, 7890, 3630, 1.80, 0, 0, 1.81, 0.46);
  /* rho0 erratum: at rho = rho0 the pressure is gamma0 rho0 e (a pressure, not gamma0 e) */
  ck_assert_double_eq_tol(epd_p(&f, 7890, 1e5, NULL), 1.81 * 7890 * 1e5, 1e-6);
  /* hand value of digest 001 §2.2: p(mu = 0.1, e = 0) = 12.4 GPa for iron, 8.04 GPa for Al */
  ck_assert_double_eq_tol(epd_p(&f, 7890 * 1.1, 0, NULL) / 1e9, 12.4, 0.05);
  /* tension branch mu < 0: rho0 C0^2 mu + (gamma0 + a mu) rho0 e */
  const double mu = -0.05, e = 2e4;
  const double ex = 7890 * 3630.0 * 3630 * mu + (1.81 + 0.46 * mu) * 7890 * e;
  ck_assert_double_eq_tol(epd_p(&f, 7890 * (1 + mu), e, NULL), ex, 1e-9 * fabs(ex));
  epd_close(&f);
  mg_open(&f, 2700, 5240, 1.40, 0, 0, 1.97, 0.48);
  ck_assert_double_eq_tol(epd_p(&f, 2700 * 1.1, 0, NULL) / 1e9, 8.04, 0.01);
  epd_close(&f);
}
END_TEST

START_TEST(test_sound_speed)
{
  epd f;
  mg_open(&f, 8930, 3940, 1.49, 0.3, -0.2, 2.02, 0.47);
  const double states[][2] = {{8930, 0}, {9500, 1e5}, {11000, 5e5}, {8500, 1e4}, {14000, 2e6}};
  for (int k = 0; k < 5; ++k) {
    double c;
    epd_p(&f, states[k][0], states[k][1], &c);
    const double c2 = epd_c2_fd(&f, states[k][0], states[k][1]);
    ck_assert_msg(fabs(c * c - c2) < 1e-6 * c2, "state %d: c^2 %.10g, FD %.10g", k, c * c, c2);
  }
  double c0;
  epd_p(&f, 8930, 0, &c0);
  ck_assert_double_eq_tol(c0, 3940, 1e-9); /* c = C0 at the reference state */
  epd_close(&f);
}
END_TEST

int main(void)
{
  Suite *s = suite_create("mie_gruneisen");
  TCase *tc = tcase_create("eos");
  tcase_add_test(tc, test_hugoniot);
  tcase_add_test(tc, test_energy_term_and_tension);
  tcase_add_test(tc, test_sound_speed);
  suite_add_tcase(s, tc);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}

/* polynomial EOS: linear use (p = K mu + gamma0 rho0 e), cubic use against hand values, the
 * tension rule (C2 and C6 dropped for mu < 0), sound speed against finite differences. */
#include "eos_point_driver.h"

const ej_plugin_info *ej_plugin_polynomial_info(void);

START_TEST(test_linear)
{
  epd f;
  epd_open(&f, ej_plugin_polynomial_info(), "polynomial");
  epd_set(&f, "rho0", 1000);
  epd_set(&f, "C1", 2.2e9);
  epd_set(&f, "C4", 0.28);
  epd_set(&f, "C5", 0.28);
  epd_create(&f);
  for (double mu = -0.05; mu <= 0.1; mu += 0.01) {
    const double rho = 1000 * (1 + mu), e = 3e4;
    double c;
    const double p = epd_p(&f, rho, e, &c);
    ck_assert_double_eq_tol(p, 2.2e9 * mu + 0.28 * (1 + mu) * 1000 * e, 1e-6);
    const double c2 = epd_c2_fd(&f, rho, e);
    ck_assert_msg(fabs(c * c - c2) < 1e-6 * c2, "mu %g: %g vs %g", mu, c * c, c2);
  }
  double c0;
  epd_p(&f, 1000, 0, &c0);
  ck_assert_double_eq_tol(c0, sqrt(2.2e9 / 1000), 1e-9);
  epd_close(&f);
}
END_TEST

START_TEST(test_cubic_and_tension)
{
  /* a soil-like cubic fit: C1 = 1e9, C2 = 3e9, C3 = 5e9, C6 = 0.5 */
  epd f;
  epd_open(&f, ej_plugin_polynomial_info(), "polynomial");
  epd_set(&f, "rho0", 1800);
  epd_set(&f, "C0", 1e5);
  epd_set(&f, "C1", 1e9);
  epd_set(&f, "C2", 3e9);
  epd_set(&f, "C3", 5e9);
  epd_set(&f, "C4", 0.2);
  epd_set(&f, "C5", 0.1);
  epd_set(&f, "C6", 0.5);
  epd_create(&f);
  /* hand value at mu = 0.2, e = 1e4: 1e5 + 2e8 + 1.2e8 + 4e7 + (0.2 + 0.02 + 0.02) * 1.8e7 = 3.64420e8 */
  ck_assert_double_eq_tol(epd_p(&f, 1800 * 1.2, 1e4, NULL), 3.6442e8, 1e2);
  /* tension: mu = -0.1: C2 and C6 dropped: 1e5 - 1e8 - 5e6 + (0.2 - 0.01) * 1.8e7 = -1.015e8 */
  ck_assert_double_eq_tol(epd_p(&f, 1800 * 0.9, 1e4, NULL), -1.0148e8, 1e2);
  const double states[][2] = {{1801, 0}, {2100, 1e4}, {2500, 1e5}, {1700, 1e3}}; /* off mu = 0: the tension rule makes c^2 jump there */
  for (int k = 0; k < 4; ++k) {
    double c;
    epd_p(&f, states[k][0], states[k][1], &c);
    const double c2 = epd_c2_fd(&f, states[k][0], states[k][1]);
    ck_assert_msg(fabs(c * c - c2) < 1e-6 * c2, "state %d: %g vs %g", k, c * c, c2);
  }
  epd_close(&f);
  /* tension_quadratic: true keeps them: -1e8 + 3e7 - 5e6 + (0.2 - 0.01 + 0.005) * 1.8e7 */
  epd_open(&f, ej_plugin_polynomial_info(), "polynomial");
  epd_set(&f, "rho0", 1800);
  epd_set(&f, "C0", 1e5);
  epd_set(&f, "C1", 1e9);
  epd_set(&f, "C2", 3e9);
  epd_set(&f, "C3", 5e9);
  epd_set(&f, "C4", 0.2);
  epd_set(&f, "C5", 0.1);
  epd_set(&f, "C6", 0.5);
  epd_set(&f, "tension_quadratic", 1);
  epd_create(&f);
  ck_assert_double_eq_tol(epd_p(&f, 1800 * 0.9, 1e4, NULL), 1e5 - 1e8 + 3e7 - 5e6 + 0.195 * 1.8e7, 1e2);
  epd_close(&f);
}
END_TEST

int main(void)
{
  Suite *s = suite_create("polynomial");
  TCase *tc = tcase_create("eos");
  tcase_add_test(tc, test_linear);
  tcase_add_test(tc, test_cubic_and_tension);
  suite_add_tcase(s, tc);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}

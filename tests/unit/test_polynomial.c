/* polynomial EOS: linear use (p = K mu + gamma0 rho0 e), cubic use against hand values, the
 * tension rule (C2 and C6 dropped for mu < 0), sound speed against finite differences, and
 * `tension: linear` (C2, C3, C6 dropped in tension, T2 added) against PySPH's MieGruneisenEOS
 * tension branch written out. */
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

/* Enum parameter by name (epd_set writes reals and booleans only). */
static void epd_set_enum(epd *f, const char *name, int v)
{
  for (const ej_param *p = f->ops->params; p && p->name; ++p)
    if (strcmp(p->name, name) == 0) {
      ck_assert_int_eq(p->type, EJ_PT_ENUM);
      *(int *)((char *)f->config + p->offset) = v;
      return;
    }
  ck_abort_msg("no parameter %s", name);
}

/* PySPH's steel of the taylor_bar example: C 3630, S 1800, gamma 1.81, r0 7850. */
static void pysph_coeffs(epd *f, int linear)
{
  const double r0 = 7850, C = 3630, S = 1800, g = 1.81, a0 = r0 * C * C;
  const double b0 = a0 * (1 + 2 * (S - 1)), c0 = a0 * (2 * (S - 1) + 3 * (S - 1) * (S - 1));
  epd_open(f, ej_plugin_polynomial_info(), "polynomial");
  epd_set(f, "rho0", r0);
  epd_set(f, "C1", a0);
  epd_set(f, "C2", b0 - 0.5 * g * a0);
  epd_set(f, "C3", c0 - 0.5 * g * b0);
  epd_set(f, "C4", g);
  epd_set(f, "C5", g);
  if (linear) {
    epd_set_enum(f, "tension", 1);
    epd_set(f, "T2", -0.5 * g * a0);
  }
  epd_create(f);
}

START_TEST(test_tension_linear)
{
  const double r0 = 7850, C = 3630, S = 1800, g = 1.81, a0 = r0 * C * C;
  const double b0 = a0 * (1 + 2 * (S - 1)), c0 = a0 * (2 * (S - 1) + 3 * (S - 1) * (S - 1));
  epd lin, dyn;
  pysph_coeffs(&lin, 1);
  pysph_coeffs(&dyn, 0);
  double worst = 0;
  for (int k = 0; k < 6; ++k) {
    const double mu = -1e-4 * pow(3.0, k), e = 1e3 * k, rho = r0 * (1 + mu);
    /* PySPH (hvi.py): p = (1 - gamma mu / 2) a0 mu + gamma rho e for mu < 0 */
    const double ref = (1 - 0.5 * g * mu) * a0 * mu + g * rho * e;
    double c;
    const double p = epd_p(&lin, rho, e, &c);
    worst = fmax(worst, fabs(p - ref) / fabs(ref));
    ck_assert_msg(fabs(p - ref) <= 1e-12 * fabs(ref), "mu %g: %.17g vs PySPH %.17g", mu, p, ref);
    const double c2 = epd_c2_fd(&lin, rho, e);
    ck_assert_msg(fabs(c * c - c2) < 1e-6 * c2, "mu %g: c^2 %g vs %g", mu, c * c, c2);
    /* the default (ls_dyna) keeps C3 mu^3: at mu = -1e-3 ten times the linear branch's tension */
    const double pd = epd_p(&dyn, rho, e, NULL);
    ck_assert_double_eq_tol(pd, a0 * mu + (c0 - 0.5 * g * b0) * mu * mu * mu + g * r0 * (1 + mu) * e,
                            1e-9 * fabs(pd));
    if (k == 2) fprintf(stderr, "mu %g: tension linear %.6g Pa (PySPH %.6g), ls_dyna %.6g Pa\n", mu, p, ref, pd);
  }
  fprintf(stderr, "tension: linear vs PySPH's tension branch: worst relative difference %.3g\n", worst);
  /* compression: both branches the same, bitwise */
  for (int k = 0; k < 5; ++k) {
    const double rho = r0 * (1 + 2e-4 * k), e = 500.0 * k;
    double c1, c2;
    ck_assert(epd_p(&lin, rho, e, &c1) == epd_p(&dyn, rho, e, &c2));
    ck_assert(c1 == c2);
  }
  epd_close(&lin);
  epd_close(&dyn);
  /* T2 without tension: linear, and tension_quadratic with it, are refused */
  epd f;
  epd_open(&f, ej_plugin_polynomial_info(), "polynomial");
  epd_set(&f, "rho0", 1000);
  epd_set(&f, "C1", 1e9);
  epd_set(&f, "T2", 1e8);
  ck_assert_int_ne(f.ops->create(f.config, &f.state), EJ_OK);
  epd_set_enum(&f, "tension", 1);
  epd_set(&f, "tension_quadratic", 1);
  ck_assert_int_ne(f.ops->create(f.config, &f.state), EJ_OK);
  epd_set(&f, "tension_quadratic", 0);
  epd_create(&f);
  epd_close(&f);
}
END_TEST

int main(void)
{
  Suite *s = suite_create("polynomial");
  TCase *tc = tcase_create("eos");
  tcase_add_test(tc, test_linear);
  tcase_add_test(tc, test_cubic_and_tension);
  tcase_add_test(tc, test_tension_linear);
  suite_add_tcase(s, tc);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}

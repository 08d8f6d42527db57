/* von_mises: uniaxial-stress tension (yield at sigma_y0, tangent E H/(E + H)), pure shear
 * plateau sigma_y0/sqrt3 with its plastic work, the EOS variant (mean stress -p from b->p). */
#include "material_point_driver.h"

const ej_plugin_info *ej_plugin_von_mises_info(void);

static const double E_ = 200e9, NU_ = 0.3, SY_ = 300e6;
static const double G_ = 200e9 / 2.6;

static void vm_open(mpd *m, double H)
{
  mpd_open(m, ej_plugin_von_mises_info(), "von_mises");
  mpd_set(m, "E", E_);
  mpd_set(m, "nu", NU_);
  mpd_set(m, "yield_stress", SY_);
  mpd_set(m, "H", H);
}

START_TEST(test_uniaxial_tension)
{
  const double H = 2e9, Et = E_ * H / (E_ + H), ey = SY_ / E_;
  mpd m;
  vm_open(&m, H);
  mpd_set_enum(&m, "volumetric", "elastic");
  mpd_create(&m);
  const int ctrl[6] = {0, 1, 1, 0, 0, 0};
  const ej_real target[6] = {0};
  const double dt = ey / 9.3;
  FILE *csv = mpd_csv_open("vm_uniaxial", "eps,sxx,sxx_exact");
  double err = 0;
  for (int n = 1; n <= 60; ++n) {
    ej_real d[6] = {1, -NU_, -NU_, 0, 0, 0};
    mpd_step_mixed(&m, d, ctrl, target, dt, G_);
    const double e = n * dt, ex = e <= ey ? E_ * e : SY_ + Et * (e - ey);
    err = fmax(err, fabs(m.stress[0] - ex) / SY_);
    ck_assert_double_eq_tol(m.stress[1], 0, 1e-6 * SY_);
    if (csv) fprintf(csv, "%.17g,%.17g,%.17g\n", e, m.stress[0], ex);
  }
  if (csv) fclose(csv);
  ck_assert_msg(err < 1e-9, "uniaxial tension: max error %g of sigma_y", err);
  const double e = 60 * dt;
  ck_assert_double_eq_tol(mpd_hist(&m, "eps_p"), (m.stress[0] - SY_) / H, 1e-12);
  ck_assert_double_eq_tol(mpd_hist(&m, "eps_p"), (e - ey) * E_ / (E_ + H), 1e-9 * e);
  mpd_close(&m);
}
END_TEST

START_TEST(test_pure_shear)
{
  mpd m;
  vm_open(&m, 0);
  mpd_create(&m);
  const double ty = SY_ / sqrt(3.0), gy = ty / (2 * G_), dt = gy / 11.1;
  const ej_real d[6] = {0, 0, 0, 1, 0, 0};
  for (int n = 1; n <= 50; ++n) {
    ck_assert_int_eq(mpd_step(&m, d, dt), EJ_OK);
    const double e = n * dt;
    ck_assert_double_eq_tol(m.stress[3], e <= gy ? 2 * G_ * e : ty, 1e-10 * ty);
  }
  const double e = 50 * dt;
  ck_assert_double_eq_tol(m.wp_total, ty * 2 * (e - gy) / m.rho, 1e-9 * ty * e / m.rho);
  ck_assert_double_eq_tol(mpd_hist(&m, "eps_p"), 2 * (e - gy) / sqrt(3.0), 1e-12);
  mpd_close(&m);
}
END_TEST

START_TEST(test_eos_variant)
{
  mpd a, b;
  vm_open(&a, 1e9);
  mpd_set_enum(&a, "volumetric", "elastic");
  mpd_create(&a);
  vm_open(&b, 1e9);
  mpd_create(&b); /* auto: takes b->p when passed */
  ej_real p = 0;
  b.pext = &p;
  const ej_real d[6] = {-1, 0.2, 0.3, 0.4, -0.2, 0.1};
  for (int n = 1; n <= 40; ++n) {
    p = 1e8 * n;
    ck_assert_int_eq(mpd_step(&a, d, 2e-4), EJ_OK);
    ck_assert_int_eq(mpd_step(&b, d, 2e-4), EJ_OK);
    ck_assert_double_eq_tol(mpd_mean(b.stress), -p, 1e-6 * p);
    ej_real sa[6], sb[6];
    ej_s6_dev(sa, a.stress), ej_s6_dev(sb, b.stress);
    for (int k = 0; k < 6; ++k) ck_assert_double_eq_tol(sb[k], sa[k], 1e-6 * SY_);
  }
  ck_assert(mpd_hist(&b, "eps_p") > 0);
  mpd_close(&a);
  mpd_close(&b);
  /* volumetric: eos without a pressure is an error */
  mpd m;
  vm_open(&m, 0);
  mpd_set_enum(&m, "volumetric", "eos");
  mpd_create(&m);
  const ej_real dz[6] = {0};
  ck_assert_int_eq(mpd_step(&m, dz, 1e-6), EJ_ERR_UNSUPPORTED);
  ej_error_clear();
  mpd_close(&m);
}
END_TEST

int main(void)
{
  Suite *s = suite_create("von_mises");
  TCase *tc = tcase_create("paths");
  tcase_add_test(tc, test_uniaxial_tension);
  tcase_add_test(tc, test_pure_shear);
  tcase_add_test(tc, test_eos_variant);
  suite_add_tcase(s, tc);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
